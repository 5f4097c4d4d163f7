//! The attitude filter over a random corpus, as the property tests draw it
//! (`tests/invariant.rs`): 30 s at 50 Hz, the true direction σ 0.3–3× the declared one,
//! the magnetometer's noise 1–20× for 10–20 s, 0–7 magnetometer outliers of 60°, angular
//! rates 0.05–1.5 rad/s. Every strategy behind the default gate; per strategy, the runs
//! whose attitude RMS (after 5 s) is beyond 3× the fixed filter's on the same data, all
//! runs and those whose declared σ is at most 1.2× too small.
//!
//! `cargo run --release -p adaptive --features campaigns --example attitude_corpus [CASES]` (default 300).

#[path = "../tests/common/attitude.rs"]
mod attitude;

use adaptive::{AnyStrategy, FixedNoise, GrossErrorGate, STRATEGY_NAMES};
use rand::SeedableRng;

fn main() {
    let cases: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(300);
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let mut worse = vec![(0usize, 0usize); STRATEGY_NAMES.len()];
    let mut honest = 0;
    for _ in 0..cases {
        let sc = attitude::corpus_case(&mut rng);
        let declared_ok = sc.true_sigma_factor <= 1.2;
        honest += usize::from(declared_ok);
        let data = attitude::simulate(&sc);
        let gate = |s| GrossErrorGate::new(s, 1e-6, 10);
        let fixed =
            attitude::run(gate(AnyStrategy::Fixed(FixedNoise)), &sc, &data, 5.0, |_, _, _| {});
        for (i, name) in STRATEGY_NAMES.iter().enumerate() {
            let out = attitude::run(gate(name.parse().unwrap()), &sc, &data, 5.0, |_, _, _| {});
            if out.rms_deg > 3.0 * fixed.rms_deg.max(0.2) {
                worse[i].0 += 1;
                worse[i].1 += usize::from(declared_ok);
            }
        }
    }
    println!(
        "| strategy | runs beyond 3× fixed, all {cases} | declared σ ≤ 1.2× too small ({honest}) |"
    );
    println!("|---|---|---|");
    for (name, (all, ok)) in STRATEGY_NAMES.iter().zip(&worse) {
        println!("| {name} | {all} | {ok} |");
    }
}
