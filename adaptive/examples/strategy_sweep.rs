//! Every strategy on the test suite's constant-velocity scenario, swept over the ratio of
//! process to measurement noise, clean and with 10σ outliers in 5 % of epochs.
//!
//! Model: 3-D constant velocity at 1 Hz, `x = [p, v]`, white acceleration with PSD `q`
//! (m²/s³), position measured with σ = 1 m. For each `q` the table gives the position
//! RMS (m) averaged over 8 seeds; the same seeded data go to every strategy.
//!
//! Run: `cargo run --release -p adaptive --features campaigns --example strategy_sweep`

#[path = "../tests/common/mod.rs"]
mod common;

use adaptive::{Afkf, AnyStrategy, FadingAt, STRATEGY_NAMES};
use common::{run, simulate, Scenario};

fn main() {
    let mut variants: Vec<(String, AnyStrategy)> =
        STRATEGY_NAMES.iter().map(|n| (n.to_string(), n.parse().unwrap())).collect();
    variants.push(("afkf-rec0.95".into(), AnyStrategy::Afkf(Afkf::recursive(0.95))));
    variants.push((
        "afkf-pred".into(),
        AnyStrategy::Afkf(Afkf::windowed(20).applied_at(FadingAt::Prediction)),
    ));
    println!(
        "| q | case | {} |",
        variants.iter().map(|v| v.0.as_str()).collect::<Vec<_>>().join(" | ")
    );
    println!("|---|---|{}", "---|".repeat(variants.len()));
    for q in [0.05, 0.01, 0.002] {
        for (case, outliers) in [("clean", 0.0), ("outliers", 0.05)] {
            let mut rms = vec![0.0; variants.len()];
            for seed in 0..8 {
                let sc = Scenario { q, outlier_rate: outliers, seed, ..Default::default() };
                let data = simulate(&sc);
                for (i, (_, s)) in variants.iter().enumerate() {
                    rms[i] += run(s.clone(), &sc, &data, 20).rms_pos / 8.0;
                }
            }
            let cells: Vec<String> = rms.iter().map(|v| format!("{v:.3}")).collect();
            println!("| {q} | {case} | {} |", cells.join(" | "));
        }
    }
}
