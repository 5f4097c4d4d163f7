//! Simulated MEMS drive with GNSS position + velocity over 20 seeded runs: NEES inside the
//! 95 % χ² band, biases within 3σ at the end, and a 60 s outage covered by 3σ.

#![allow(non_snake_case)]

use crate::common;

fn at(r: &common::RunOutput, t: f64) -> &common::Record {
    r.records.iter().find(|x| (x.t - t).abs() < 1e-6).unwrap()
}

use common::{drive_setup, run_many_with_interval};
use estimator_core::consistency::{averaged_chi2_band, fraction_inside};
use estimator_core::FixedNoise;

const RUNS: u64 = 20;
const OUTAGE: (f64, f64) = (330.0, 390.0);

#[test]
fn mems_drive_is_consistent_and_outage_is_covered() {
    consistent_and_covered(0.0);
}

/// The same laws with the covariance propagated once per 50 ms (5 IMU samples combined,
/// `Navigator::with_covariance_interval`), the σ read as they stand between its steps.
#[test]
fn with_the_covariance_every_50_ms_too() {
    consistent_and_covered(0.05);
}

fn consistent_and_covered(interval: f64) {
    let setup = drive_setup(100.0, Some(OUTAGE));
    let runs = run_many_with_interval(&setup, 0..RUNS, FixedNoise, None, interval);
    let epochs = runs[0].records.len();

    // 1. Mean NEES per epoch after convergence (t ≥ 100 s), outside the outage.
    let (lo, hi) = averaged_chi2_band(15, RUNS as usize, 0.95);
    let mut mean_nees = Vec::new();
    for e in 0..epochs {
        let t = runs[0].records[e].t;
        if t < 100.0 || (t >= OUTAGE.0 && t < OUTAGE.1 + 30.0) {
            continue;
        }
        mean_nees.push(runs.iter().map(|r| r.records[e].nees).sum::<f64>() / RUNS as f64);
    }
    let inside = fraction_inside(&mean_nees, lo, hi);
    let avg = mean_nees.iter().sum::<f64>() / mean_nees.len() as f64;
    eprintln!(
        "covariance interval {interval} s: mean NEES {avg:.2} (15 dof); band [{lo:.2}, {hi:.2}]; inside at {:.1} % of {} epochs",
        inside * 100.0,
        mean_nees.len()
    );
    assert!(inside >= 0.90, "mean NEES inside the band at only {:.1} % of epochs", inside * 100.0);

    // 2. Biases at the end within 3σ (6 components × 20 runs; at most 2 outside, the
    //    expected number being 0.3).
    let mut outside = 0;
    for r in &runs {
        let last = r.records.last().unwrap();
        for i in 9..15 {
            if last.error[i].abs() > 3.0 * last.sigma[i] {
                outside += 1;
            }
        }
    }
    eprintln!("bias components outside 3σ at the end: {outside} of {}", RUNS * 6);
    assert!(outside <= 2);

    // 3. The outage: horizontal error grows and 3σ covers it.
    let horiz = |x: &common::Record| (x.error[6].powi(2) + x.error[7].powi(2)).sqrt();
    let (mut start, mut end) = (0.0, 0.0);
    let (mut covered, mut total) = (0, 0);
    for r in &runs {
        start += horiz(at(r, OUTAGE.0)) / RUNS as f64;
        end += horiz(at(r, OUTAGE.1 - 1.0)) / RUNS as f64;
        for x in r.records.iter().filter(|x| x.t >= OUTAGE.0 && x.t < OUTAGE.1) {
            for i in 6..8 {
                total += 1;
                if x.error[i].abs() <= 3.0 * x.sigma[i] {
                    covered += 1;
                }
            }
        }
    }
    let frac = covered as f64 / total as f64;
    eprintln!(
        "outage: mean horizontal error {start:.2} m → {end:.2} m; within 3σ {:.2} %",
        frac * 100.0
    );
    assert!(end > 3.0 * start, "error did not grow during the outage");
    assert!(frac >= 0.99, "3σ covers only {:.2} % of outage errors", frac * 100.0);
}
