//! SO(3) specifics beyond the generic laws: exp/log near 0 and π, Jacobian inverses,
//! Euler angles.

use approx::assert_relative_eq;
use core::f64::consts::PI;
use manifolds::{right_jacobian, right_jacobian_inverse, Manifold, So3};
use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;

#[test]
fn exp_log_round_trip_near_zero_and_pi() {
    for angle in [0.0, 1e-12, 1e-8, 1e-4, 1e-2 - 1e-9, 1e-2 + 1e-9, 1.0, 3.0, PI - 1e-6, PI - 1e-9]
    {
        for axis in [Vector3::x(), Vector3::new(1.0, 2.0, -3.0).normalize()] {
            let phi = axis * angle;
            let back = So3::exp(&phi).log();
            assert!((back - phi).norm() <= 1e-12 * angle.max(1.0), "angle {angle}: {back:?}");
        }
    }
}

#[test]
fn log_at_pi_has_angle_pi() {
    let r = So3::exp(&(Vector3::new(0.0, 0.0, 1.0) * PI));
    assert_relative_eq!(r.log().norm(), PI, epsilon = 1e-12);
}

#[test]
fn jacobian_inverse_is_inverse_near_zero_and_pi() {
    for angle in [0.0, 1e-9, 1e-3, 1e-2, 0.5, 2.0, PI - 1e-4] {
        let phi = Vector3::new(0.3, -0.5, 0.8).normalize() * angle;
        let prod = right_jacobian(&phi) * right_jacobian_inverse(&phi);
        assert!((prod - Matrix3::identity()).abs().max() < 1e-10, "angle {angle}");
    }
}

#[test]
fn exp_of_sum_linearises_with_right_jacobian() {
    // Exp(φ + δ) ≈ Exp(φ) Exp(Jr(φ) δ) to second order in δ.
    let phi = Vector3::new(0.7, -1.1, 0.4);
    let d = Vector3::new(1e-6, -2e-6, 3e-6);
    let lhs = So3::exp(&(phi + d));
    let rhs = So3::exp(&phi) * So3::exp(&(right_jacobian(&phi) * d));
    assert!((lhs.inverse() * rhs).log().norm() < 1e-11);
}

proptest! {
    #[test]
    fn euler_round_trip(roll in -3.1f64..3.1, pitch in -1.5f64..1.5, yaw in -3.1f64..3.1) {
        let (r, p, y) = So3::from_euler(roll, pitch, yaw).euler();
        prop_assert!((r - roll).abs() < 1e-9 && (p - pitch).abs() < 1e-9 && (y - yaw).abs() < 1e-9);
    }

    #[test]
    fn matrix_is_orthonormal(a in -3.0f64..3.0, b in -3.0f64..3.0, c in -3.0f64..3.0) {
        let m = So3::exp(&Vector3::new(a, b, c)).matrix();
        prop_assert!((m.transpose() * m - Matrix3::identity()).abs().max() < 1e-12);
        prop_assert!((m.determinant() - 1.0).abs() < 1e-12);
    }
}

proptest! {
    #[test]
    fn between_exp_is_the_product_of_three(
        a in prop::array::uniform3(-3.0f64..3.0),
        b in prop::array::uniform3(-3.0f64..3.0),
        c in prop::array::uniform3(-3.0f64..3.0),
    ) {
        let (a, b, c) = (Vector3::from(a), Vector3::from(b), Vector3::from(c));
        let m = So3::exp(&b);
        let product = So3::exp(&a) * m * So3::exp(&c);
        let between = m.between_exp(&a, &c);
        prop_assert!((between.matrix() - product.matrix()).abs().max() < 1e-14);
        prop_assert!((between.quaternion().norm() - 1.0).abs() < 1e-15);
        // ⊕ normalises once too
        let plus = m.oplus(&c);
        prop_assert!((plus.matrix() - (m * So3::exp(&c)).matrix()).abs().max() < 1e-14);
        prop_assert!((plus.quaternion().norm() - 1.0).abs() < 1e-15);
    }
}

/// `f32` against `f64` over angles from 1e-7 to π − 1e-3, on both sides of the series
/// threshold of each scalar (0.1 in f32, 1e-2 in f64): `Exp`, `Log`, `Jr` and `Jr⁻¹` in single
/// precision agree with double precision to a few ε of f32.
#[test]
fn single_precision_agrees_with_double() {
    let mut worst = [0.0f64; 4];
    let axes = [Vector3::x(), Vector3::new(1.0, 2.0, -3.0).normalize()];
    let mut angle = 1e-7;
    while angle < PI - 1e-3 {
        for axis in axes {
            let phi = axis * angle;
            let phi32 = phi.map(|v| v as f32);
            // the f32 input is the f64 one rounded: compare against f64 on the rounded input
            let phi_r = phi32.map(|v| v as f64);
            let q = So3::exp(&phi_r);
            let q32 = So3::<f32>::exp(&phi32);
            let d = (q32.cast::<f64>().ominus(&q)).norm();
            worst[0] = worst[0].max(d);
            let back = q32.log().map(|v| v as f64);
            worst[1] = worst[1].max((back - q.log()).norm() / angle.max(1.0));
            let jr = right_jacobian(&phi32).map(|v| v as f64) - right_jacobian(&phi_r);
            worst[2] = worst[2].max(jr.abs().max());
            let ji =
                right_jacobian_inverse(&phi32).map(|v| v as f64) - right_jacobian_inverse(&phi_r);
            worst[3] = worst[3].max(ji.abs().max() / right_jacobian_inverse(&phi_r).abs().max());
        }
        angle *= 1.07;
    }
    let eps = f32::EPSILON as f64;
    eprintln!("worst Exp, Log, Jr, Jr^-1 in units of eps_f32: {:?}", worst.map(|w| w / eps));
    for (what, w) in ["Exp", "Log", "Jr", "Jr⁻¹"].iter().zip(worst) {
        assert!(w <= 8.0 * eps, "{what}: f32 differs from f64 by {w:.3e} (ε = {eps:.3e})");
    }
}
