//! What each strategy must show on seeded simulations (issue: adaptive strategies).

use crate::common;

use adaptive::{Afkf, AnyStrategy, FixedNoise, FusedDualWindow, Iae, Iakf, SageHusa};
use common::{all_strategies, count, run, simulate, Scenario};
use estimator_core::consistency::averaged_chi2_band;
use estimator_core::Verdict;

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn no_harm_when_the_model_is_right() {
    // Same seeded data for all; RMS averaged over seeds to keep one seed from deciding.
    let seeds = 8;
    let mut fixed = 0.0;
    let mut others = vec![0.0; all_strategies().len()];
    for seed in 0..seeds {
        let sc = Scenario { seed, ..Default::default() };
        let data = simulate(&sc);
        fixed += run(FixedNoise, &sc, &data, 20).rms_pos / seeds as f64;
        for (i, (_, s)) in all_strategies().into_iter().enumerate() {
            others[i] += run(s, &sc, &data, 20).rms_pos / seeds as f64;
        }
    }
    for ((name, _), rms) in all_strategies().iter().zip(&others) {
        eprintln!("{name:10} RMS {rms:.4} m (fixed {fixed:.4})");
        if *name == "iae-qr-faithful" {
            // Adapting Q from the gain at every update (the paper's IAE) adds process noise
            // the model did not need: measured 1.48 m against 0.87 m here. That is its
            // documented cost; the guarded `iae-qr` adds it only on a significant mismatch
            // (0.90 m).
            assert!(*rms > 1.2 * fixed, "iae-qr-faithful: RMS {rms:.4} vs fixed {fixed:.4}");
            continue;
        }
        assert!(*rms <= 1.10 * fixed, "{name}: RMS {rms:.4} vs fixed {fixed:.4}");
    }
}

#[test]
fn r_step_is_tracked_by_iae_and_sage_husa() {
    let sc = Scenario {
        epochs: 800,
        r_step_factor: 9.0,
        r_step_epoch: 300,
        seed: 42,
        ..Default::default()
    };
    let data = simulate(&sc);
    let true_tr = 3.0 * 9.0 * sc.sigma.powi(2);
    let settled = 450..800; // 150 epochs after the step: both windows have refilled
    let (lo, hi) = averaged_chi2_band(3, settled.len(), 0.99);
    for (name, strategy) in [
        ("iae", AnyStrategy::Iae(Iae::default())),
        ("sage-husa", AnyStrategy::SageHusa(SageHusa::default())),
    ] {
        let res = run(strategy, &sc, &data, 0);
        let tr: Vec<f64> = res.log.entries[settled.clone()]
            .iter()
            .map(|e| e.factors.lambda_r * 3.0 * sc.sigma.powi(2))
            .collect();
        let est = mean(&tr);
        eprintln!("{name}: mean tr(R̂) {est:.2} vs true {true_tr:.2}");
        assert!((est - true_tr).abs() <= 0.2 * true_tr, "{name}: tr(R̂) {est:.2} vs {true_tr:.2}");
        // NIS under the S the filter actually used returns to its band.
        let nis = mean(
            &res.log.entries[settled.clone()].iter().map(|e| e.nis_adapted).collect::<Vec<_>>(),
        );
        eprintln!("{name}: mean adapted NIS {nis:.2}, band [{lo:.2}, {hi:.2}]");
        assert!(nis >= lo && nis <= hi, "{name}: mean NIS {nis:.2} outside [{lo:.2}, {hi:.2}]");
    }
    // The fixed filter's NIS is far outside its band after the step (sensitivity check).
    let fixed = run(FixedNoise, &sc, &data, 0);
    let fixed_nis =
        mean(&fixed.log.entries[settled.clone()].iter().map(|e| e.nis).collect::<Vec<_>>());
    assert!(fixed_nis > hi, "fixed NIS {fixed_nis:.2} should exceed {hi:.2}");
}

#[test]
fn outliers_are_cut_by_iakf_and_fused() {
    let seeds = 6;
    let (mut fixed, mut iakf, mut fused) = (0.0, 0.0, 0.0);
    for seed in 0..seeds {
        let sc = Scenario {
            outlier_rate: 0.05,
            outlier_sigmas: 10.0,
            seed: 100 + seed,
            ..Default::default()
        };
        let data = simulate(&sc);
        fixed += run(FixedNoise, &sc, &data, 20).rms_pos;
        iakf += run(Iakf::default(), &sc, &data, 20).rms_pos;
        fused += run(FusedDualWindow::default(), &sc, &data, 20).rms_pos;
    }
    eprintln!("RMS: fixed {fixed:.3}, iakf {iakf:.3}, fused {fused:.3} (sums over {seeds} seeds)");
    assert!(iakf <= 0.7 * fixed, "iakf {iakf} vs fixed {fixed}");
    assert!(fused <= 0.7 * fixed, "fused {fused} vs fixed {fixed}");
}

#[test]
fn afkf_reacts_to_underestimated_process_noise() {
    let seeds = 10;
    let (mut nees_fixed, mut nees_afkf, mut lambda_max) = (0.0, 0.0, 1.0_f64);
    for seed in 0..seeds {
        let sc = Scenario { q_true_factor: 10.0, seed: 200 + seed, ..Default::default() };
        let data = simulate(&sc);
        nees_fixed += mean(&run(FixedNoise, &sc, &data, 0).nees[50..]) / seeds as f64;
        let res = run(Afkf::default(), &sc, &data, 0);
        nees_afkf += mean(&res.nees[50..]) / seeds as f64;
        lambda_max = res.log.entries.iter().fold(lambda_max, |m, e| m.max(e.factors.lambda_p));
    }
    let (lo, hi) = averaged_chi2_band(6, 350 * seeds as usize, 0.95);
    let dist = |v: f64| {
        if v > hi {
            v - hi
        } else if v < lo {
            lo - v
        } else {
            0.0
        }
    };
    eprintln!(
        "mean NEES: fixed {nees_fixed:.2}, afkf {nees_afkf:.2}; band [{lo:.2}, {hi:.2}]; max λ {lambda_max:.2}"
    );
    assert!(lambda_max > 1.0);
    assert!(
        dist(nees_afkf) < dist(nees_fixed),
        "afkf NEES {nees_afkf} not closer than fixed {nees_fixed}"
    );
}

#[test]
fn gated_strategies_converge_from_a_far_start() {
    // 200 m initial error with a filter that believes 1 m: every early innovation fails
    // the χ² test. The guard must re-admit measurements so the filter converges.
    let sc = Scenario { x0_error: 200.0, p0_pos: 1.0, seed: 9, ..Default::default() };
    let data = simulate(&sc);
    for (name, s) in [
        ("iakf", AnyStrategy::Iakf(Iakf::default())),
        ("fused", AnyStrategy::Fused(FusedDualWindow::default())),
    ] {
        let res = run(s, &sc, &data, 0);
        let readmitted =
            res.log.entries.iter().filter(|e| e.reason.contains("re-admitted")).count();
        eprintln!("{name}: final error {:.3} m, re-admissions {readmitted}", res.final_error);
        assert!(readmitted > 0, "{name} never needed the guard: the test would prove nothing");
        assert!(res.final_error < 5.0, "{name} did not converge: {}", res.final_error);
        // It stops gating once converged: the last 100 epochs are mostly nominal.
        let tail = &res.log.entries[300..];
        let rejected = tail.iter().filter(|e| e.verdict == Verdict::Rejected).count();
        assert!(rejected < 10, "{name}: {rejected} rejections in the last 100 epochs");
    }
    let _ = count;
}
