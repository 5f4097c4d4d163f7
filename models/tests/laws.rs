//! Every model's analytic Jacobians against central differences through ⊕/⊖; Singer's
//! noise by two independent paths; covariances stay SPD under random sequences.

#![allow(non_snake_case)]

use estimator_core::harness::{check_measurement_model, check_process_model};
use estimator_core::{ErrorStateFilter, FixedNoise, ProcessModel};
use manifolds::{So3, Tangent};
use models::ahrs::experiment::Variant;
use models::ahrs::sim::SensorErrors;
use models::ahrs::{AhrsInput, AhrsMeasurement, AhrsState};
use models::cs::{
    CsVariance, GaussianMembership, InterpolatedLimits, LimitRule, Membership, RangeLimits,
};
use models::kinematic::{
    markov_phi, singer_q_closed_form, singer_q_unit, ConstantAcceleration, ConstantVelocity,
    CurrentStatistical, Singer,
};
use nalgebra::{SMatrix, SVector, Vector1, Vector2, Vector3};
use proptest::prelude::*;

#[test]
fn kinematic_models_pass_the_jacobian_harness() {
    let x2 = (Vector2::new(1.0, -2.0), Vector2::new(0.5, 3.0));
    check_process_model(&ConstantVelocity::<2> { q: Vector2::new(0.1, 0.2) }, &x2, &(), 0.1, 1e-8)
        .unwrap();
    let x3 =
        (Vector3::new(1.0, 2.0, 3.0), Vector3::new(-1.0, 0.5, 0.2), Vector3::new(0.3, -0.2, 0.1));
    check_process_model(
        &ConstantAcceleration::<3> { q: Vector3::repeat(0.5) },
        &x3,
        &(),
        0.1,
        1e-8,
    )
    .unwrap();
    check_process_model(
        &Singer::<3> { alpha: 0.2, sigma2: Vector3::repeat(4.0) },
        &x3,
        &(),
        0.5,
        1e-8,
    )
    .unwrap();
    let cs = CurrentStatistical::<1> { alpha: 1.0 / 60.0, variance: CsVariance::default() };
    let x1 = (Vector1::new(3.0), Vector1::new(1.0), Vector1::new(0.4));
    check_process_model(&cs, &x1, &Vector1::new(0.4), 0.1, 1e-8).unwrap();
}

#[test]
fn ahrs_models_pass_the_jacobian_harness() {
    let errors = SensorErrors::default();
    let x = AhrsState {
        att: So3::from_euler(0.3, -0.2, 2.5),
        bg: Vector3::new(0.01, -0.02, 0.005),
        acc: Vector3::new(0.5, 1.2, -0.3),
    };
    for v in Variant::ALL {
        let u = AhrsInput { gyro: Vector3::new(0.1, -0.3, 0.25), abar: x.acc };
        check_process_model(&v.model(&errors, 100.0), &x, &u, 0.01, 1e-6).unwrap();
    }
    let m = AhrsMeasurement {
        g_n: Vector3::new(0.0, 0.0, 9.80665),
        m_n: Vector3::new(0.5, 0.0, 0.866),
    };
    check_measurement_model(&m, &x, 1e-7).unwrap();
}

/// The same models in single precision, with the harness's `f32` step and tolerances
/// (`jacobian_tolerance::<f32>()` 2.4e-3, agreement `100 ε`): the Jacobians hold in `f32`.
#[test]
fn ahrs_models_pass_the_jacobian_harness_in_f32() {
    use estimator_core::harness::{
        check_measurement_model_in, check_process_model_in, jacobian_tolerance,
    };
    let errors = SensorErrors::default();
    let x = AhrsState::<f32> {
        att: So3::from_euler(0.3, -0.2, 2.5),
        bg: Vector3::new(0.01, -0.02, 0.005),
        acc: Vector3::new(0.5, 1.2, -0.3),
    };
    let (tol, step) = (jacobian_tolerance::<f32>(), 1e-3);
    for v in Variant::ALL {
        let u = AhrsInput { gyro: Vector3::new(0.1f32, -0.3, 0.25), abar: x.acc };
        check_process_model_in::<f32, _>(&v.model(&errors, 100.0), &x, &u, 0.01, tol, step)
            .unwrap();
    }
    let m = AhrsMeasurement::<f32> {
        g_n: Vector3::new(0.0, 0.0, 9.80665),
        m_n: Vector3::new(0.5, 0.0, 0.866),
    };
    check_measurement_model_in::<f32, _>(&m, &x, tol, step).unwrap();
    // and a wrong Jacobian is caught at that tolerance: H with its attitude block negated
    struct Wrong(AhrsMeasurement<f32>);
    impl estimator_core::MeasurementModel<f32> for Wrong {
        type State = AhrsState<f32>;
        type Measurement = nalgebra::SVector<f32, 6>;
        fn predict(&self, x: &AhrsState<f32>) -> Self::Measurement {
            self.0.predict(x)
        }
        fn jacobian(&self, x: &AhrsState<f32>) -> estimator_core::JacobiansOf<Self, f32> {
            let mut j = self.0.jacobian(x);
            let neg = -j.H.fixed_view::<3, 3>(0, 0);
            j.H.fixed_view_mut::<3, 3>(0, 0).copy_from(&neg);
            j
        }
    }
    assert!(check_measurement_model_in::<f32, _>(&Wrong(m), &x, tol, step).is_err());
}

#[test]
fn singer_noise_two_paths_agree() {
    // Van Loan's matrix exponential against Singer's closed form where the latter is
    // accurate (αT ≥ 0.5), and against the white-jerk limit as αT → 0.
    for (alpha, t) in [(0.5, 1.0), (1.0, 1.0), (0.3, 10.0), (2.0, 5.0)] {
        let a = singer_q_unit(alpha, t);
        let b = singer_q_closed_form(alpha, t);
        assert!((a - b).abs().max() <= 1e-9 * b.abs().max(), "α {alpha} T {t}: {a} vs {b}");
    }
    let t: f64 = 0.5;
    let small = singer_q_unit(1e-9, t);
    let jerk = SMatrix::<f64, 3, 3>::new(
        t.powi(5) / 20.0,
        t.powi(4) / 8.0,
        t.powi(3) / 6.0,
        t.powi(4) / 8.0,
        t.powi(3) / 3.0,
        t * t / 2.0,
        t.powi(3) / 6.0,
        t * t / 2.0,
        t,
    );
    assert!((small - jerk).abs().max() <= 1e-9 * jerk.abs().max());
    // Φ of the Markov model tends to the constant-acceleration Φ.
    let p = markov_phi(1e-9, t);
    assert!((p[(0, 2)] - t * t / 2.0).abs() < 1e-9 && (p[(2, 2)] - 1.0).abs() < 1e-9);
}

#[test]
fn cs_variance_law_and_membership() {
    let m = GaussianMembership::default();
    assert!(m.grade(0.0).abs() < 1e-15 && m.grade(0.5) < 0.02 && m.grade(20.0) > 0.99);
    let lim = InterpolatedLimits::default();
    let (hi, lo) = lim.limits(2.0, m.grade(2.0));
    assert!(hi > 2.0 && hi < 10.0 && lo < -2.0 && lo > -10.0);
    let range = RangeLimits { a_up: 3.0, a_neg_up: -3.0, a_th: 10.0, a_neg_th: -10.0 };
    assert!((range.limits(0.0, 0.0).0 - 3.0).abs() < 1e-15);
    // σ² = (4 − π)/π (a_max − ā)² above the floor.
    let law = CsVariance { floor: 0.0, ..CsVariance::default() };
    let abar: f64 = 4.0;
    let (hi, _) = lim.limits(abar, m.grade(abar));
    let expect = (4.0 - core::f64::consts::PI) / core::f64::consts::PI * (hi - abar).powi(2);
    assert!((law.variance(abar) - expect).abs() < 1e-12);
    assert!((CsVariance::default().variance(0.0) - 1.0).abs() < 1e-12, "floor applies at ā = 0");
}

fn is_spd<const N: usize>(p: &SMatrix<f64, N, N>) -> bool {
    let s = p.abs().max().max(1e-300);
    p.iter().all(|v| v.is_finite())
        && (p - p.transpose()).abs().max() <= 1e-12 * s
        && p.cholesky().is_some()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn singer_covariance_stays_spd(alpha in 0.01f64..2.0, s2 in 0.1f64..20.0, dts in prop::collection::vec(0.001f64..2.0, 1..30), zs in prop::collection::vec(-100.0f64..100.0, 30)) {
        let m = Singer::<1> { alpha, sigma2: Vector1::new(s2) };
        let x0 = (Vector1::new(0.0), Vector1::new(0.0), Vector1::new(0.0));
        let mut f = ErrorStateFilter::new(x0, SMatrix::<f64, 3, 3>::identity(), FixedNoise).unwrap();
        let pos = PositionOf;
        for (dt, z) in dts.iter().zip(&zs) {
            f.predict(&m, &(), *dt).unwrap();
            f.update(&pos, &Vector1::new(*z), &SMatrix::<f64, 1, 1>::new(1.0)).unwrap();
            prop_assert!(is_spd(&f.covariance()));
        }
    }

    #[test]
    fn ahrs_covariance_stays_spd(w in prop::collection::vec(prop::array::uniform3(-2.0f64..2.0), 1..60), acc in prop::array::uniform3(-5.0f64..5.0), which in 0usize..3) {
        let errors = SensorErrors::default();
        let model = Variant::ALL[which].model(&errors, 100.0);
        let meas = AhrsMeasurement { g_n: Vector3::new(0.0, 0.0, 9.8), m_n: Vector3::new(0.5, 0.0, 0.866) };
        let x0 = AhrsState { att: So3::identity(), bg: Vector3::zeros(), acc: Vector3::zeros() };
        let mut f = ErrorStateFilter::new(x0, SMatrix::<f64, 9, 9>::identity() * 0.01, FixedNoise).unwrap();
        for wi in &w {
            let u = AhrsInput { gyro: Vector3::new(wi[0], wi[1], wi[2]), abar: f.state().acc };
            f.predict(&model, &u, 0.01).unwrap();
            let z = SVector::<f64, 6>::new(acc[0], acc[1], acc[2] - 9.8, 0.5, 0.0, 0.866);
            f.update(&meas, &z, &(SMatrix::<f64, 6, 6>::identity() * 0.02)).unwrap();
            prop_assert!(is_spd(&f.covariance()));
        }
    }
}

/// Position of a 1-axis (p, v, a) state.
struct PositionOf;
impl estimator_core::MeasurementModel for PositionOf {
    type State = (Vector1<f64>, Vector1<f64>, Vector1<f64>);
    type Measurement = Vector1<f64>;
    fn predict(&self, x: &Self::State) -> Vector1<f64> {
        x.0
    }
    fn jacobian(
        &self,
        _: &Self::State,
    ) -> estimator_core::MeasurementJacobians<nalgebra::U1, nalgebra::U3> {
        estimator_core::MeasurementJacobians { H: SMatrix::<f64, 1, 3>::new(1.0, 0.0, 0.0) }
    }
}

#[test]
fn cs_prediction_holds_the_mean_acceleration() {
    // With ā equal to the current acceleration, the CS model predicts constant
    // acceleration (the "current" statistics).
    let cs = CurrentStatistical::<1> { alpha: 0.1, variance: CsVariance::default() };
    let x = (Vector1::new(0.0), Vector1::new(2.0), Vector1::new(1.5));
    let y = cs.propagate(&x, &Vector1::new(1.5), 0.5);
    assert!((y.2[0] - 1.5).abs() < 1e-12);
    assert!((y.1[0] - (2.0 + 1.5 * 0.5)).abs() < 1e-12);
    assert!((y.0[0] - (2.0 * 0.5 + 1.5 * 0.125)).abs() < 1e-12);
    let _ = Tangent::<AhrsState>::zeros();
}
