//! Agreement of independent paths: the error-state filter on a Euclidean state is the
//! linear Kalman filter, and Joseph and short-form updates agree under the optimal gain.

#![allow(non_snake_case)]

use crate::common;

use common::{close, gaussian, rng, spd, PlainKf};
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, FixedNoise, UpdateForm};
use nalgebra::{Matrix2, Matrix2x4, Matrix4, Vector4};

#[test]
fn eskf_on_euclidean_state_reproduces_linear_kf_over_200_steps() {
    let mut r = rng(7);
    let dt = 0.1;
    let f = Matrix4::new(
        1.0, 0.0, dt, 0.0, //
        0.0, 1.0, 0.0, dt, //
        0.0, 0.0, 1.0, 0.0, //
        0.0, 0.0, 0.0, 1.0,
    );
    let q = spd::<4>(&mut r, 0.01) * 0.01;
    let h = Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0);
    let p0 = spd::<4>(&mut r, 0.5);
    let x0 = gaussian::<4, 1>(&mut r);

    let process = LinearProcess { F: f, Q: q };
    let sensor = LinearMeasurement::new(h);
    let mut eskf = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    let mut kf = PlainKf { x: x0, p: p0 };

    let mut truth = Vector4::new(0.0, 0.0, 1.0, -0.5);
    for k in 0..200 {
        truth = f * truth;
        eskf.predict(&process, &(), dt).unwrap();
        kf.predict(&f, &q);
        // Time-varying R so that the gain changes every step.
        let rk = spd::<2>(&mut r, 0.1) * (0.5 + (k % 7) as f64 * 0.1);
        let z = h * truth + gaussian::<2, 1>(&mut r) * 0.3;
        let report = eskf.update(&sensor, &z, &rk).unwrap();
        let nis = kf.update(&h, &z, &rk);
        assert!(close(eskf.state(), &kf.x, 1e-12), "x differs at step {k}");
        assert!(close(&eskf.covariance(), &kf.p, 1e-12), "P differs at step {k}");
        assert!((report.nis - nis).abs() <= 1e-12 * nis.max(1.0), "NIS differs at step {k}");
    }
}

#[test]
fn joseph_and_short_form_agree_under_optimal_gain() {
    let mut r = rng(11);
    for trial in 0..50 {
        let p0 = spd::<4>(&mut r, 0.1);
        let x0 = gaussian::<4, 1>(&mut r);
        let h = gaussian::<2, 4>(&mut r);
        let rk = spd::<2>(&mut r, 0.05);
        let z = gaussian::<2, 1>(&mut r);
        let sensor = LinearMeasurement::new(h);
        let mut joseph = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
        let mut short =
            ErrorStateFilter::new(x0, p0, FixedNoise).unwrap().with_update_form(UpdateForm::Short);
        joseph.update(&sensor, &z, &rk).unwrap();
        short.update(&sensor, &z, &rk).unwrap();
        assert!(close(&joseph.covariance(), &short.covariance(), 1e-10), "trial {trial}");
        assert!(close(joseph.state(), short.state(), 1e-12), "trial {trial}");
    }
}

#[test]
fn sequential_and_joint_updates_agree() {
    // Two independent scalar sensors applied one after the other equal one joint update
    // with block-diagonal R (a classic cross-check of the update path).
    let mut r = rng(5);
    let p0 = spd::<4>(&mut r, 0.2);
    let x0 = gaussian::<4, 1>(&mut r);
    let h = gaussian::<2, 4>(&mut r);
    let (r1, r2) = (0.3, 0.7);
    let z = gaussian::<2, 1>(&mut r);
    let mut joint = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    joint.update(&LinearMeasurement::new(h), &z, &Matrix2::new(r1, 0.0, 0.0, r2)).unwrap();
    let mut seq = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    let row = |i: usize| LinearMeasurement::new(h.fixed_rows::<1>(i).into_owned());
    seq.update(&row(0), &nalgebra::Vector1::new(z[0]), &nalgebra::Matrix1::new(r1)).unwrap();
    seq.update(&row(1), &nalgebra::Vector1::new(z[1]), &nalgebra::Matrix1::new(r2)).unwrap();
    assert!(close(joint.state(), seq.state(), 1e-12));
    assert!(close(&joint.covariance(), &seq.covariance(), 1e-12));
}
