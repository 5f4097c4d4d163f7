//! The everyday-GNSS corpus's CI subset (`examples/everyday_corpus.rs` runs the whole
//! table): the simulated drive with fixes whose errors wander like a single point's
//! (Gauss–Markov 1.5/1.5/3 m, τ 100 s, over 0.3 m white) declared with their true σ,
//! ten times too small and ten times too large, and with white errors declared true;
//! a smaller wander (0.5/0.5/1 m, τ 30 s, over 0.1 m white) declared 10× too small, i.e.
//! at an RTK fix's σ;
//! seeds 1–3, each run as a user makes it (no `[init]`, the default gate, the noise
//! learned) and again given the true noise model.
//!
//! The laws, pooled over the seeds of a cell: no run refused; wandering errors run with
//! their persisting part as states, chosen by the bank of hypotheses (white errors may
//! too: a persisting part the data cannot tell from none is the cautious choice); the
//! share of epochs beyond the run's own 99 % ellipse at most 5 %; the horizontal RMS
//! within 1.2× of the runs given the true noise model.

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
        (Errors::White([1.0, 1.0, 2.0]), 1.0, None),
        (wander, 0.1, Some(true)),
        (wander, 1.0, Some(true)),
        (wander, 10.0, Some(true)),
        // a single point's small wander declaring an RTK fix's σ (5 cm): judged by the
        // bank all the same (its first 100 fixes' innovations contradict the declared σ
        // and are correlated); before, it ran white, 93 % of the epochs beyond the
        // ellipse (the corpus's 20 seeds: 17 judged, 13.7 % beyond; docs/results.md)
        (Errors::Wander([0.5, 0.5, 1.0], 30.0, 0.1), 0.1, Some(true)),
    ];
    for (errors, declared, persisting) in cells {
        let outs = cell(errors, declared);
        let name = format!("{} declared ×{declared}", errors.name());
        for (o, t) in &outs {
            assert!(o.refused.is_none(), "{name}: refused: {:?}", o.refused);
            assert!(t.refused.is_none(), "{name}, true model: refused: {:?}", t.refused);
            if let Some(p) = persisting {
                assert_eq!(o.persisting, p, "{name}: the bank chose wrong");
            }
        }
        let (beyond, score, truth) = pooled(&outs);
        eprintln!("{name}: {score:.3} m against {truth:.3} m, {:.1} % beyond", beyond * 100.0);
        assert!(beyond <= 0.05, "{name}: {:.1} % beyond the 99 % ellipse", beyond * 100.0);
        assert!(score <= 1.2 * truth, "{name}: {score:.3} m against {truth:.3} m");
    }
}

/// A persisting part stated (`gnss.errors.sigma`) with `learn` on: the white part's σ is
/// learned from the residuals (it used to stay at the declared σ). Fixes wandering 1.5 m
/// over 0.3 m white noise, declared 10× their total σ: the white part's variance factor
/// on the declared ends within 3× of the truth's (0.3² / 15.3²), and the reported σ
/// covers the error (≤ 5 % beyond the 99 % ellipse).
#[test]
fn a_stated_persisting_sigma_learns_its_white_part() {
    let wander = Errors::Wander([1.5, 1.5, 3.0], 100.0, 0.3);
    let d = sim_drive(5);
    let extra = "[gnss.errors]\nmodel = \"persisting\"\nsigma = [1.5, 1.5, 3.0]\ntau = 100.0\n";
    let cfg = config_of(&d, extra);
    let gnss = gnss_rows(&d, wander, 10.0, 5);
    let inputs =
        ins_gnss::run::Inputs::Arrays { imu: d.imu.clone(), imu_width: 7, gnss, gnss_width: 7 };
    let (summary, results): (ins_gnss::run::RunSummary, ins_gnss::run::Results) =
        ins_gnss::run::run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs).unwrap();
    let f = summary.fix_errors.expect("a run with the persisting part as states");
    let truth = 0.3f64.powi(2) / (10.0 * wander.total()[0]).powi(2);
    assert!(
        f.white > truth / 3.0 && f.white < 3.0 * truth,
        "white part's factor {:.2e} against the truth's {truth:.2e}",
        f.white
    );
    let t0 = results.nav.first().map_or(0.0, |x| x[0]);
    let (_, beyond) = score(&d, &results, t0);
    assert!(beyond <= 0.05, "{:.1} % beyond the 99 % ellipse", 100.0 * beyond);
}

/// The bank's score of an update ([`ins_gnss::run::robust_log_likelihood`]): an inlier's
/// log-likelihood as the filter reports it; beyond χ² 0.999 of the dimension, the
/// quadratic term no longer grows (a gross error costs a model no more than a rare
/// inlier), for a refused update (nominal NIS) and an adapted one (its NIS) alike.
#[test]
fn the_banks_likelihood_caps_gross_errors() {
    use estimator_core::{Factors, UpdateSummary, Verdict};
    let ll = |nis: f64, adapted: f64, verdict: Verdict| {
        // ln det S = 2 for the example
        let q = if adapted.is_finite() { adapted } else { nis };
        let u = UpdateSummary {
            stream: ins_gnss_core::gnss::GNSS_POSITION,
            epoch: 1,
            time: 0.0,
            dim: 3,
            nis,
            nis_adapted: adapted,
            verdict,
            reason: "",
            factors: Factors::default(),
            prior_scaling_fallback: false,
            not_helping: false,
            log_likelihood: -0.5 * (3.0 * (2.0 * std::f64::consts::PI).ln() + 2.0 + q),
        };
        ins_gnss::run::robust_log_likelihood(&u)
    };
    let full = |q: f64| -0.5 * (3.0 * (2.0 * std::f64::consts::PI).ln() + 2.0 + q);
    approx::assert_relative_eq!(ll(4.0, 4.0, Verdict::Accepted), full(4.0), epsilon = 1e-12);
    approx::assert_relative_eq!(
        ll(20.0, f64::NAN, Verdict::Rejected),
        full(16.266),
        epsilon = 1e-9
    );
    approx::assert_relative_eq!(ll(1e6, f64::NAN, Verdict::Rejected), full(16.266), epsilon = 1e-9);
    approx::assert_relative_eq!(ll(1e6, 9.0, Verdict::Inflated), full(9.0), epsilon = 1e-12);
}

/// The issue's own case on real data: drive-0708's IMU from its shipped KF-GINS YAML (its
/// `[init]` and datasheet noise), its RTK fixes moved by the wander (1.5/1.5/3 m,
/// τ 100 s, over 0.3 m white) and declaring that σ; seeds 1–2. The bank runs the fixes'
/// persisting part, the reported σ covers the error (≤ 5 % of the epochs beyond the 99 %
/// ellipse; step 2's learned split left 17 %, KF-GINS on the same files 79 %) and the
/// outages' score is within 1.2× of the same run told the true model.
#[test]
fn drive_0708_with_wandering_fixes_keeps_its_sigma_honest() {
    let wander = Errors::Wander([1.5, 1.5, 3.0], 100.0, 0.3);
    let d = drive_0708("kf-gins-outage15.yaml");
    let outs: Vec<(Outcome, Outcome)> = (1..=2u64)
        .into_par_iter()
        .map(|seed| {
            let o = run(&d, gnss_rows(&d, wander, 1.0, seed), "");
            let t = run(&d, gnss_rows(&d, wander, 1.0, seed), &wander.oracle());
            (o, t)
        })
        .collect();
    for (o, _) in &outs {
        assert!(o.refused.is_none(), "refused: {:?}", o.refused);
        assert!(o.persisting, "the bank chose the white model");
    }
    let (beyond, score, truth) = pooled(&outs);
    eprintln!("drive-0708: {score:.3} m against {truth:.3} m, {:.1} % beyond", beyond * 100.0);
    assert!(beyond <= 0.05, "{:.1} % beyond the 99 % ellipse", beyond * 100.0);
    assert!(score <= 1.2 * truth, "{score:.3} m against {truth:.3} m");
}
