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
