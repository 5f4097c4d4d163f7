//! Consistency: ≥ 50 seeded Monte Carlo runs of a linear constant-velocity model; the
//! mean NEES must sit inside the 95 % χ² band at ≥ 90 % of epochs.

#![allow(non_snake_case)]

use crate::common;

use common::rng;
use estimator_core::consistency::{averaged_chi2_band, fraction_inside, normalized_squared};
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, FixedNoise};
use nalgebra::{Matrix2, Matrix2x4, Matrix4, Vector4};
use rand::Rng;
use rand_distr::StandardNormal;

#[test]
fn mean_nees_inside_95_percent_band() {
    const RUNS: usize = 60;
    const EPOCHS: usize = 150;
    let dt: f64 = 0.5;
    let q = 0.2; // white-acceleration PSD, m²/s³
    let F = Matrix4::new(
        1.0, 0.0, dt, 0.0, //
        0.0, 1.0, 0.0, dt, //
        0.0, 0.0, 1.0, 0.0, //
        0.0, 0.0, 0.0, 1.0,
    );
    let (a, b, c) = (dt.powi(3) / 3.0, dt.powi(2) / 2.0, dt);
    let Q = Matrix4::new(a, 0.0, b, 0.0, 0.0, a, 0.0, b, b, 0.0, c, 0.0, 0.0, b, 0.0, c) * q;
    let H = Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0);
    let R = Matrix2::identity() * 4.0;
    let Lq = Q.cholesky().unwrap().l();
    let P0 = Matrix4::from_diagonal(&Vector4::new(25.0, 25.0, 4.0, 4.0));
    let L0 = P0.cholesky().unwrap().l();

    let process = LinearProcess { F, Q };
    let sensor = LinearMeasurement::new(H);
    let mut mean_nees = vec![0.0; EPOCHS];
    for run in 0..RUNS {
        let mut r = rng(1000 + run as u64);
        let mut n4 = || Vector4::from_fn(|_, _| r.sample::<f64, _>(StandardNormal));
        let mut truth = Vector4::new(0.0, 0.0, 3.0, -1.0);
        let x0 = truth + L0 * n4();
        let w: Vec<Vector4<f64>> = (0..EPOCHS).map(|_| Lq * n4()).collect();
        let v: Vec<Vector4<f64>> = (0..EPOCHS).map(|_| n4() * 2.0).collect();
        let mut f = ErrorStateFilter::new(x0, P0, FixedNoise).unwrap();
        for k in 0..EPOCHS {
            truth = F * truth + w[k];
            f.predict(&process, &(), dt).unwrap();
            let z = H * truth + v[k].fixed_rows::<2>(0);
            f.update(&sensor, &z, &R).unwrap();
            let e = truth - f.state();
            mean_nees[k] += normalized_squared(&e, &f.covariance()).unwrap() / RUNS as f64;
        }
    }
    let (lo, hi) = averaged_chi2_band(4, RUNS, 0.95);
    let inside = fraction_inside(&mean_nees, lo, hi);
    assert!(
        inside >= 0.90,
        "mean NEES inside [{lo:.3}, {hi:.3}] at only {:.1} % of epochs",
        inside * 100.0
    );
    // The average over all epochs is close to the state dimension (4).
    let overall: f64 = mean_nees.iter().sum::<f64>() / EPOCHS as f64;
    assert!((overall - 4.0).abs() < 0.5, "overall mean NEES {overall}");
}
