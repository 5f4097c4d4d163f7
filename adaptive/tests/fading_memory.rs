//! A fixed factor λ = α² reproduces the fading-memory filter
//! `P⁻ = α² F P Fᵀ + Q` (FilterPy's `FadingKalmanFilter`), written here independently.

#![allow(non_snake_case)]

use adaptive::Afkf;
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::ErrorStateFilter;
use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

#[test]
fn fixed_lambda_equals_fading_memory_filter() {
    let alpha: f64 = 1.02;
    let dt: f64 = 0.1;
    let F = Matrix2::new(1.0, dt, 0.0, 1.0);
    let Q = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.5;
    let H = Matrix1x2::new(1.0, 0.0);
    let R = Matrix1::new(0.25);
    let (x0, P0) = (Vector2::new(0.0, 1.0), Matrix2::identity());

    let mut f = ErrorStateFilter::new(x0, P0, Afkf::fading_memory(alpha)).unwrap();
    let (mut x, mut P) = (x0, P0);
    let process = LinearProcess { F, Q };
    let sensor = LinearMeasurement::new(H);
    for k in 0..300 {
        let z = Vector1::new(0.1 * k as f64 + (k as f64 * 0.37).sin());
        // Reference: x = F x; P = α² F P Fᵀ + Q; y = z − Hx; S = HPHᵀ + R; K = P Hᵀ/S;
        // x += K y; P = (I − KH) P (I − KH)ᵀ + K R Kᵀ.
        x = F * x;
        P = F * P * F.transpose() * (alpha * alpha) + Q;
        let y = z - H * x;
        let S = H * P * H.transpose() + R;
        let K = P * H.transpose() / S[0];
        x += K * y;
        let IKH = Matrix2::identity() - K * H;
        P = IKH * P * IKH.transpose() + K * R * K.transpose();

        f.predict(&process, &(), dt).unwrap();
        f.update(&sensor, &z, &R).unwrap();
        assert!((f.state() - x).abs().max() <= 1e-12 * x.abs().max().max(1.0), "x at {k}");
        assert!((*f.covariance() - P).abs().max() <= 1e-12 * P.abs().max().max(1.0), "P at {k}");
    }
    // A fading filter keeps more uncertainty than the plain one: the test compares
    // against a different quantity than FixedNoise would give.
    let mut plain = ErrorStateFilter::new(x0, P0, adaptive::FixedNoise).unwrap();
    for _ in 0..300 {
        plain.predict(&process, &(), dt).unwrap();
        plain.update(&sensor, &Vector1::new(0.0), &R).unwrap();
    }
    assert!(f.covariance()[(0, 0)] > 1.01 * plain.covariance()[(0, 0)]);
}

/// The covariance in one step for several state steps (`predict_state` n times, then
/// `predict_covariance(.., steps = n)`): with `F = I` and `Q = 0` the fading compounds to
/// `λⁿ P`, as n full predictions give; one state step then one covariance step at the state
/// before is `predict` bit for bit; the state follows the same path.
#[test]
fn a_covariance_step_for_n_state_steps_fades_by_lambda_to_the_n() {
    let alpha: f64 = 1.05;
    let identity = LinearProcess { F: Matrix2::identity(), Q: Matrix2::zeros() };
    let P0 = Matrix2::new(2.0, 0.3, 0.3, 1.0);
    let x0 = Vector2::new(1.0, -2.0);
    let mut full = ErrorStateFilter::new(x0, P0, Afkf::fading_memory(alpha)).unwrap();
    let mut split = full.clone();
    for _ in 0..4 {
        full.predict(&identity, &(), 0.1).unwrap();
        split.predict_state(&identity, &(), 0.1).unwrap();
    }
    assert_eq!(split.covariance().as_ref(), &P0, "the state steps leave P alone");
    split.predict_covariance(&identity, &x0, &(), 0.4, 4).unwrap();
    let want = P0 * alpha.powi(8);
    assert!((full.covariance().as_ref() - want).abs().max() < 1e-12);
    assert!((split.covariance().as_ref() - want).abs().max() < 1e-12);
    assert_eq!(split.state(), full.state());
    assert!((split.time() - full.time()).abs() < 1e-12);

    let dt = 0.1;
    let moving =
        LinearProcess { F: Matrix2::new(1.0, dt, 0.0, 1.0), Q: Matrix2::new(1e-3, 0.0, 0.0, 2e-3) };
    let mut one = ErrorStateFilter::new(x0, P0, Afkf::fading_memory(alpha)).unwrap();
    let mut halves = one.clone();
    one.predict(&moving, &(), dt).unwrap();
    let before = *halves.state();
    halves.predict_state(&moving, &(), dt).unwrap();
    halves.predict_covariance(&moving, &before, &(), dt, 1).unwrap();
    assert_eq!(halves.state(), one.state());
    assert_eq!(halves.covariance(), one.covariance());
}
