//! Van Loan's discretisation against closed forms; the first-order one's error.

use estimator_core::discretize::{first_order, van_loan};
use nalgebra::{Matrix1, Matrix2, Vector2};

#[test]
fn van_loan_is_exact_for_white_acceleration() {
    // x = (position, velocity), acceleration white with density q
    let f = Matrix2::new(0.0, 1.0, 0.0, 0.0);
    let g = Vector2::new(0.0, 1.0);
    let q = Matrix1::new(0.7);
    for dt in [1e-3, 0.1, 1.0, 5.0] {
        let (phi, qd) = van_loan(&f, &g, &q, dt);
        let phi_exact = Matrix2::new(1.0, dt, 0.0, 1.0);
        let qd_exact = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * q[(0, 0)];
        let scale = qd_exact.abs().max();
        assert!((phi - phi_exact).abs().max() < 1e-12, "dt {dt}: Φ {phi}");
        assert!((qd - qd_exact).abs().max() < 1e-12 * scale.max(1.0), "dt {dt}: Q_d {qd}");
        // first order: Φ is exact here (F² = 0) but Q_d misses the dt³ and dt² terms
        let (phi1, qd1) = first_order(&f, &g, &q, dt);
        assert!((phi1 - phi_exact).abs().max() < 1e-15);
        assert!((qd1 - qd_exact).abs().max() > 0.2 * q[(0, 0)] * dt * dt);
    }
}

#[test]
fn van_loan_is_exact_for_an_oscillator() {
    // ẍ = −ω² x + w: Φ = [[cos, sin/ω], [−ω sin, cos]], Q_d from the integral in closed form
    let w = 2.0;
    let f = Matrix2::new(0.0, 1.0, -w * w, 0.0);
    let g = Vector2::new(0.0, 1.0);
    let q = 0.3;
    let dt = 0.4;
    let (phi, qd) = van_loan(&f, &g, &Matrix1::new(q), dt);
    let (s, c) = (w * dt).sin_cos();
    let phi_exact = Matrix2::new(c, s / w, -w * s, c);
    let (s2, c2) = (2.0 * w * dt).sin_cos();
    let q11 = q / (2.0 * w * w) * (dt - s2 / (2.0 * w));
    let q12 = q / (2.0 * w * w) * (1.0 - c2) / 2.0;
    let q22 = q / 2.0 * (dt + s2 / (2.0 * w));
    let qd_exact = Matrix2::new(q11, q12, q12, q22);
    assert!((phi - phi_exact).abs().max() < 1e-12, "{phi} vs {phi_exact}");
    assert!((qd - qd_exact).abs().max() < 1e-12, "{qd} vs {qd_exact}");
}

#[cfg(feature = "testing")]
mod harness_hint {
    use estimator_core::harness::JacobianMismatch;

    #[test]
    fn a_phi_mismatch_points_to_van_loan() {
        let e = JacobianMismatch {
            what: "process transition Φ",
            max_error: 4.25e-6,
            tolerance: 1e-6,
            at: (0, 1),
            values: (0.0, 0.0),
            step_spread: None,
        };
        assert!(e.to_string().contains("discretize::van_loan"), "{e}");
    }
}
