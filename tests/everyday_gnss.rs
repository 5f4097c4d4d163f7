//! The everyday-GNSS corpus's CI subset (`examples/everyday_corpus.rs` runs the whole
//! table): the simulated drive with fixes whose errors wander like a single point's
//! (Gauss–Markov 1.5/1.5/3 m, τ 100 s, over 0.3 m white) declared with their true σ,
//! ten times too small and ten times too large, and with white errors declared true;
//! seeds 1–3, each run as a user makes it (no `[init]`, the default gate, the noise
//! learned) and again given the true noise model.
//!
//! The laws, pooled over the seeds of a cell: no run refused; white errors stay white
//! (the probe finds no persistence) and wandering ones restart with their persisting part
//! as states; the share of epochs beyond the run's own 99 % ellipse at most 5 %; the
//! horizontal RMS within 1.2× of the runs given the true noise model.

use crate::everyday::*;
use rayon::prelude::*;

fn cell(errors: Errors, declared: f64) -> Vec<(Outcome, Outcome)> {
    (1..=3u64)
        .into_par_iter()
        .map(|seed| {
            let d = sim_drive(seed);
            let o = run(&d, gnss_rows(&d, errors, declared, seed), "");
            let t = run(&d, gnss_rows(&d, errors, 1.0, seed), &errors.oracle());
            (o, t)
        })
        .collect()
}

#[test]
fn everyday_gnss_subset_keeps_its_sigma_honest_and_its_accuracy() {
    let wander = Errors::Wander([1.5, 1.5, 3.0], 100.0, 0.3);
    let cells = [
        (Errors::White([1.0, 1.0, 2.0]), 1.0, false),
        (wander, 0.1, true),
        (wander, 1.0, true),
        (wander, 10.0, true),
    ];
    for (errors, declared, persisting) in cells {
        let outs = cell(errors, declared);
        let name = format!("{} declared ×{declared}", errors.name());
        for (o, t) in &outs {
            assert!(o.refused.is_none(), "{name}: refused: {:?}", o.refused);
            assert!(t.refused.is_none(), "{name}, true model: refused: {:?}", t.refused);
            assert_eq!(o.persisting, persisting, "{name}: the probe decided wrong");
        }
        let n = outs.len() as f64;
        let beyond = outs.iter().map(|(o, _)| o.beyond).sum::<f64>() / n;
        let score = outs.iter().map(|(o, _)| o.score).sum::<f64>() / n;
        let truth = outs.iter().map(|(_, t)| t.score).sum::<f64>() / n;
        eprintln!("{name}: {score:.3} m against {truth:.3} m, {:.1} % beyond", beyond * 100.0);
        assert!(beyond <= 0.05, "{name}: {:.1} % beyond the 99 % ellipse", beyond * 100.0);
        assert!(score <= 1.2 * truth, "{name}: {score:.3} m against {truth:.3} m");
    }
}
