//! A range-bearing EKF on a 2-D pose (R², SO(2)) whose heading and bearing residuals
//! cross ±π. Handled through ⊖, the estimate never jumps by 2π; the same filter with a
//! naive subtraction residual does.

#![allow(non_snake_case)]

use core::f64::consts::PI;

use estimator_core::harness::{check_measurement_model, check_process_model};
use estimator_core::{
    ErrorStateFilter, FixedNoise, Manifold, MeasurementJacobians, MeasurementModel, ProcessModel,
    Tangent,
};
use manifolds::{So2, R1, R2};
use models::planar::{Pose2, RangeBearing, Unicycle};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3, U2, U3};
use rand::rngs::StdRng;
use rand::Rng;
use rand::SeedableRng;
use rand_distr::StandardNormal;

type Pose = Pose2;

/// The crate's sensor, optionally with the naive residual a filter without ⊖ would use.
struct Sensor {
    inner: RangeBearing,
    naive_residual: bool,
}

impl MeasurementModel for Sensor {
    type State = Pose;
    type Measurement = (R1, So2);
    fn predict(&self, x: &Pose) -> (R1, So2) {
        self.inner.predict(x)
    }
    fn jacobian(&self, x: &Pose) -> MeasurementJacobians<U2, U3> {
        self.inner.jacobian(x)
    }
    fn residual(&self, z: &(R1, So2), z_hat: &(R1, So2)) -> Vector2<f64> {
        if self.naive_residual {
            // Plain subtraction of angles.
            Vector2::new(z.0[0] - z_hat.0[0], z.1.angle() - z_hat.1.angle())
        } else {
            z.ominus(z_hat)
        }
    }
}

#[test]
fn models_pass_the_jacobian_harness() {
    let x: Pose = (R2::new(1.0, -2.0), So2::new(3.1));
    check_process_model(&Unicycle { sigma_v: 0.1, sigma_w: 0.01 }, &x, &(2.0, 0.3), 0.1, 1e-7)
        .unwrap();
    for lm in [Vector2::new(-10.0, 0.1), Vector2::new(5.0, 7.0)] {
        check_measurement_model(&RangeBearing { landmark: lm }, &x, 1e-7).unwrap();
    }
}

/// Drive a circle whose heading passes through ±π many times, with landmarks placed so
/// that bearings sit near ±π as well. Returns the largest heading error and the largest
/// one-step heading correction.
fn run(naive: bool, seed: u64) -> (f64, f64) {
    let mut r = StdRng::seed_from_u64(seed);
    let landmarks =
        [Vector2::new(-30.0, 0.05), Vector2::new(-25.0, -0.05), Vector2::new(5.0, 40.0)];
    let model = Unicycle { sigma_v: 0.05, sigma_w: 0.01 };
    let u = (5.0, 0.25);
    let dt = 0.1;
    let mut truth: Pose = (R2::new(0.0, -20.0), So2::new(PI - 0.05));
    let x0 = (truth.0 + R2::new(0.5, -0.5), truth.1.oplus(&nalgebra::Vector1::new(0.04)));
    let P0 = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.01));
    let mut f = ErrorStateFilter::new(x0, P0, FixedNoise).unwrap();
    let R = Matrix2::new(0.1f64.powi(2), 0.0, 0.0, 0.01f64.powi(2));
    let (mut worst_err, mut worst_jump) = (0.0_f64, 0.0_f64);
    for k in 0..600 {
        truth = model.propagate(&truth, &u, dt);
        f.predict(&model, &u, dt).unwrap();
        let lm = landmarks[k % landmarks.len()];
        let sensor = Sensor { inner: RangeBearing { landmark: lm }, naive_residual: naive };
        let clean = sensor.predict(&truth);
        let noise: Tangent<(R1, So2)> = Vector2::new(
            0.1 * r.sample::<f64, _>(StandardNormal),
            0.01 * r.sample::<f64, _>(StandardNormal),
        );
        let z = clean.oplus(&noise);
        let before = f.state().1;
        f.update(&sensor, &z, &R).unwrap();
        worst_jump = worst_jump.max(f.state().1.ominus(&before)[0].abs());
        worst_err = worst_err.max(f.state().1.ominus(&truth.1)[0].abs());
    }
    (worst_err, worst_jump)
}

#[test]
fn bearing_residual_crossing_pi_is_handled_through_ominus() {
    for seed in 0..5 {
        let (err, jump) = run(false, seed);
        assert!(err < 0.05, "seed {seed}: heading error {err}");
        assert!(jump < 0.05, "seed {seed}: heading correction {jump}");
    }
}

#[test]
fn naive_subtraction_breaks_on_the_same_data() {
    // The control: without ⊖ the ±π crossing produces wild corrections.
    let (err, jump) = run(true, 0);
    assert!(err > 0.5 || jump > 0.5, "naive residual unexpectedly fine: {err} {jump}");
}
