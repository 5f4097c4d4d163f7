//! The checks a FilterPy user had to hand-write, through the public API: the plain χ² gate
//! (refuse when NIS > χ²_{1−α}(m), the posterior keeps the prior) against a gated KF
//! written out here, and the gain and log-likelihood each update reports.

#![allow(non_snake_case)]

use adaptive::ChiSquareGate;
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, FixedNoise, NoObserver, Verdict};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

fn setup() -> (LinearProcess<2>, Matrix1x2<f64>, Matrix1<f64>) {
    let dt: f64 = 0.1;
    let F = Matrix2::new(1.0, dt, 0.0, 1.0);
    let Q = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.5;
    (LinearProcess { F, Q }, Matrix1x2::new(1.0, 0.0), Matrix1::new(0.25))
}

/// Measurements with a 20σ outlier every 17 epochs.
fn z(k: usize) -> f64 {
    let clean = 0.1 * k as f64 + (k as f64 * 0.37).sin() * 0.3;
    if k % 17 == 5 {
        clean + 10.0
    } else {
        clean
    }
}

#[test]
fn chi_square_gate_equals_a_gated_kalman_filter_written_out() {
    let (process, H, R) = setup();
    let (x0, P0) = (Vector2::new(0.0, 1.0), Matrix2::identity());
    let gate = 6.634896601021214; // χ²_{0.99}(1) (scipy.stats.chi2.ppf(0.99, 1))
    let mut f = ErrorStateFilter::new(x0, P0, ChiSquareGate::new(0.01)).unwrap();
    let sensor = LinearMeasurement::new(H);
    let (mut x, mut P) = (x0, P0);
    let mut refused = 0;
    for k in 0..200 {
        x = process.F * x;
        P = process.F * P * process.F.transpose() + process.Q;
        let y = z(k) - (H * x)[0];
        let S = (H * P * H.transpose())[0] + R[0];
        let keep = y * y / S > gate;
        if !keep {
            let K = P * H.transpose() / S;
            x += K * y;
            let IKH = Matrix2::identity() - K * H;
            P = IKH * P * IKH.transpose() + K * R * K.transpose();
        }
        refused += usize::from(keep);

        f.predict(&process, &(), 0.1).unwrap();
        let r = f.update(&sensor, &Vector1::new(z(k)), &R).unwrap();
        assert_eq!(r.verdict == Verdict::Rejected, keep, "decision at {k}");
        assert!((f.state() - x).abs().max() <= 1e-12 * x.abs().max().max(1.0), "x at {k}");
        assert!((*f.covariance() - P).abs().max() <= 1e-12, "P at {k}");
    }
    assert!(
        (10..=14).contains(&refused),
        "the outliers (12 of them) are what is refused: {refused}"
    );
}

#[test]
fn reports_carry_the_gain_and_the_log_likelihood() {
    let (process, H, R) = setup();
    let mut f =
        ErrorStateFilter::new(Vector2::new(0.0, 1.0), Matrix2::identity(), FixedNoise).unwrap();
    let sensor = LinearMeasurement::new(H);
    for k in 0..50 {
        f.predict(&process, &(), 0.1).unwrap();
        let P = f.covariance().into_owned();
        let y = z(k) - f.state()[0];
        let S = P[(0, 0)] + R[0];
        let (report, K) =
            f.update_with_gain(&sensor, &Vector1::new(z(k)), &R, &mut NoObserver).unwrap();
        let K = K.expect("accepted");
        let K_ref = P * H.transpose() / S;
        assert!((K - K_ref).abs().max() <= 1e-13, "K at {k}: {K} vs {K_ref}");
        // scipy.stats.multivariate_normal.logpdf(y, 0, S) = −½ (ln 2π + ln S + y²/S)
        let ll = -0.5 * ((2.0 * core::f64::consts::PI).ln() + S.ln() + y * y / S);
        assert!((report.log_likelihood - ll).abs() <= 1e-12 * ll.abs().max(1.0), "LL at {k}");
    }
    // a rejected update has no gain, and its likelihood is that of the prior
    let mut g =
        ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), ChiSquareGate::new(0.01))
            .unwrap();
    let (report, K) =
        g.update_with_gain(&sensor, &Vector1::new(50.0), &R, &mut NoObserver).unwrap();
    assert!(K.is_none());
    let S: f64 = 1.25;
    let ll = -0.5 * ((2.0 * core::f64::consts::PI).ln() + S.ln() + 2500.0 / S);
    assert!((report.log_likelihood - ll).abs() <= 1e-12 * ll.abs());
}
