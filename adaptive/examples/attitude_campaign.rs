//! The attitude campaign: a user's own SO(3) × R³ filter (gyro bias; gravity and
//! magnetic directions as unit vectors in R³), every strategy swapped in by name, with
//! and without the gross-error gate, on clean data and with a magnetic disturbance
//! (the magnetometer's noise 10× its declared value for 60–120 s) and six 60°
//! magnetometer outliers, over many seeds.
//!
//! `cargo run --release -p adaptive --features campaigns --example attitude_campaign [SEEDS]` (default 50)
//! prints, per strategy and case, the mean attitude RMS after 10 s, the mean NEES (6
//! states), the runs with a P not positive definite, errors, subspace fallbacks and
//! "not helping" reports.

#[path = "../tests/common/attitude.rs"]
mod attitude;

use adaptive::{AnyStrategy, GrossErrorGate, STRATEGY_NAMES};
use attitude::{run, simulate, Outcome, Scenario};
use estimator_core::PriorScaling;

#[allow(clippy::type_complexity)]
fn summary(outs: &[Outcome]) -> (f64, f64, f64, usize, usize, usize, usize, f64) {
    let n = outs.len() as f64;
    let rms = outs.iter().map(|o| o.rms_deg).sum::<f64>() / n;
    let nees = outs.iter().map(|o| o.nees).sum::<f64>() / n;
    let beyond = outs.iter().map(|o| o.beyond99).sum::<f64>() / n * 100.0;
    let not_pd = outs.iter().filter(|o| o.not_pd > 0).count();
    let errs = outs.iter().map(|o| o.errors).sum();
    let fb = outs.iter().map(|o| o.fallbacks).sum();
    let nh = outs.iter().map(|o| o.not_helping).sum();
    let bias = outs.iter().map(|o| o.max_bias_sigma).fold(0.0, f64::max);
    (rms, nees, beyond, not_pd, errs, fb, nh, bias)
}

/// A strategy by name; `NAME+full` scales the whole prior instead of its measurement
/// subspace (the experiment that tells the two apart).
fn strategy(name: &str) -> AnyStrategy {
    if let Some(base) = name.strip_suffix("+nop") {
        // λ_P never applied (the guard never finds a mismatch): the process loop off
        return match base.parse().unwrap() {
            AnyStrategy::Fused(mut f) => {
                f.guard = Some(adaptive::FadingGuard { alpha: 0.0 });
                AnyStrategy::Fused(f)
            }
            other => other,
        };
    }
    match name.strip_suffix("+full") {
        Some(base) => match base.parse().unwrap() {
            AnyStrategy::Afkf(a) => AnyStrategy::Afkf(a.with_scaling(PriorScaling::Full)),
            AnyStrategy::Fused(mut f) => {
                f.scaling = PriorScaling::Full;
                AnyStrategy::Fused(f)
            }
            other => other,
        },
        None => name.parse().unwrap(),
    }
}

fn main() {
    let seeds: u64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(50);
    let only: Option<String> = std::env::args().nth(2);
    println!(
        "{:<26} {:>6} {:>8} {:>9} {:>6} {:>7} {:>6} {:>7} {:>7} {:>9}",
        "strategy", "case", "gate", "rms °", "NEES", ">χ²99", "¬PD", "errors", "fallbk", "¬helping"
    );
    for case in ["clean", "disturbed"] {
        let data: Vec<_> = (1..=seeds)
            .map(|s| {
                let sc = if case == "clean" { Scenario::clean(s) } else { Scenario::disturbed(s) };
                let d = simulate(&sc);
                (sc, d)
            })
            .collect();
        let names: Vec<&str> = match only.as_deref() {
            Some(o) => vec![o],
            None => STRATEGY_NAMES.to_vec(),
        };
        for name in names {
            for gated in [false, true] {
                let outs: Vec<Outcome> = data
                    .iter()
                    .map(|(sc, d)| {
                        let s = strategy(name);
                        if gated {
                            run(GrossErrorGate::new(s, 1e-6, 10), sc, d, 10.0, |_, _, _| {})
                        } else {
                            run(GrossErrorGate::disabled(s), sc, d, 10.0, |_, _, _| {})
                        }
                    })
                    .collect();
                let (rms, nees, beyond, not_pd, errs, fb, nh, bias) = summary(&outs);
                println!(
                    "{name:<26} {case:>6} {:>8} {rms:>9.3} {nees:>6.2} {beyond:>6.1}% {not_pd:>6} {errs:>7} {fb:>7} {nh:>9}  max σ_b {bias:.3}",
                    if gated { "gated" } else { "open" },
                );
            }
        }
    }
}
