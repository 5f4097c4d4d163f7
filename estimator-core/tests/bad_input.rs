//! Bad input gets a typed error naming the cause, and leaves the filter unchanged.

#![allow(non_snake_case)]

use estimator_core::fixed_from_dynamic;
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, FilterError, FixedNoise};
use nalgebra::{DMatrix, Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};

fn filter() -> ErrorStateFilter<Vector3<f64>> {
    ErrorStateFilter::new(Vector3::new(1.0, 2.0, 3.0), Matrix3::identity() * 2.0, FixedNoise)
        .unwrap()
}

fn sensor() -> LinearMeasurement<2, 3> {
    LinearMeasurement::new(Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0))
}

fn assert_unchanged(f: &ErrorStateFilter<Vector3<f64>>) {
    let g = filter();
    assert!((f.state() - g.state()).norm() < 1e-15);
    assert!((*f.covariance() - *g.covariance()).norm() < 1e-15);
}

#[test]
fn non_pd_p0_is_rejected() {
    let p0 = Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0); // eigenvalues 3, −1, 1
    let e = ErrorStateFilter::new(Vector3::zeros(), p0, FixedNoise).unwrap_err();
    assert_eq!(e, FilterError::NotPositiveDefinite { what: "initial covariance P0" });
    assert!(e.to_string().contains("initial covariance P0"));
}

#[test]
fn asymmetric_p0_is_rejected() {
    let mut p0 = Matrix3::identity();
    p0[(0, 1)] = 0.1;
    assert!(matches!(
        ErrorStateFilter::new(Vector3::zeros(), p0, FixedNoise),
        Err(FilterError::NotSymmetric { what: "initial covariance P0", .. })
    ));
}

#[test]
fn nan_state_is_rejected() {
    assert!(matches!(
        ErrorStateFilter::new(Vector3::new(f64::NAN, 0.0, 0.0), Matrix3::identity(), FixedNoise),
        Err(FilterError::NonFinite { what: "initial state x0" })
    ));
}

#[test]
fn non_pd_r_is_rejected_and_filter_unchanged() {
    let mut f = filter();
    let r = Matrix2::new(1.0, 0.0, 0.0, -1.0);
    let e = f.update(&sensor(), &Vector2::new(1.0, 1.0), &r).unwrap_err();
    assert_eq!(e, FilterError::NotPositiveDefinite { what: "measurement noise R" });
    assert_unchanged(&f);
    assert_eq!(f.epoch(), 0);
}

#[test]
fn nan_measurement_is_rejected_and_filter_unchanged() {
    let mut f = filter();
    let e = f.update(&sensor(), &Vector2::new(f64::NAN, 1.0), &Matrix2::identity()).unwrap_err();
    assert_eq!(e, FilterError::NonFinite { what: "measurement z" });
    assert_unchanged(&f);
}

#[test]
fn infinite_r_is_rejected() {
    let mut f = filter();
    let r = Matrix2::new(f64::INFINITY, 0.0, 0.0, 1.0);
    assert!(matches!(
        f.update(&sensor(), &Vector2::zeros(), &r),
        Err(FilterError::NonFinite { what: "measurement noise R" })
    ));
    assert_unchanged(&f);
}

#[test]
fn negative_or_nan_dt_is_rejected() {
    let mut f = filter();
    let m = LinearProcess { F: Matrix3::identity(), Q: Matrix3::identity() };
    assert_eq!(f.predict(&m, &(), -0.1).unwrap_err(), FilterError::InvalidTimeStep { dt: -0.1 });
    assert!(matches!(f.predict(&m, &(), f64::NAN), Err(FilterError::InvalidTimeStep { .. })));
    assert_unchanged(&f);
}

#[test]
fn nan_in_process_noise_leaves_filter_unchanged() {
    let mut f = filter();
    let mut q = Matrix3::identity();
    q[(1, 1)] = f64::NAN;
    let m = LinearProcess { F: Matrix3::identity(), Q: q };
    // caught at Q itself, before it reaches P, with the model named
    assert!(matches!(
        f.predict(&m, &(), 0.1).unwrap_err(),
        FilterError::InvalidProcessNoise { problem: "not finite", .. }
    ));
    assert_unchanged(&f);
    assert!(f.time().abs() < 1e-15);
}

#[test]
fn a_nan_input_sample_is_named_as_a_non_finite_input() {
    // a gyro-like model: x' = x + u dt, Φ = I, Q from the model's own noise
    struct Integrates;
    impl estimator_core::ProcessModel for Integrates {
        type State = Vector3<f64>;
        type Input = Vector3<f64>;
        fn propagate(&self, x: &Vector3<f64>, u: &Vector3<f64>, dt: f64) -> Vector3<f64> {
            x + u * dt
        }
        fn jacobians(
            &self,
            _: &Vector3<f64>,
            u: &Vector3<f64>,
            dt: f64,
        ) -> estimator_core::ProcessJacobians<nalgebra::U3> {
            // a model whose Φ depends on the input, as a rotation's does
            let phi = Matrix3::identity() + Matrix3::from_diagonal(u) * (dt * 1e-3);
            estimator_core::ProcessJacobians { Phi: phi, Q: Matrix3::identity() * 1e-4 * dt }
        }
    }
    let mut f = filter();
    let e = f.predict(&Integrates, &Vector3::new(0.1, f64::NAN, 0.0), 0.01).unwrap_err();
    assert!(matches!(e, FilterError::NonFinite { .. }), "{e}");
    assert!(e.to_string().contains("input sample"), "{e}");
    assert_unchanged(&f);
}

#[test]
fn wrong_sized_runtime_matrix_is_a_typed_error() {
    let d = DMatrix::<f64>::identity(3, 2);
    let e =
        fixed_from_dynamic::<nalgebra::U2, nalgebra::U2>("measurement noise R", &d).unwrap_err();
    assert_eq!(
        e,
        FilterError::DimensionMismatch {
            what: "measurement noise R",
            expected: (2, 2),
            found: (3, 2)
        }
    );
    assert!(e.to_string().contains("3×2, expected 2×2"));
    let ok = fixed_from_dynamic::<nalgebra::U3, nalgebra::U2>("H", &d).unwrap();
    assert!((ok[(1, 1)] - 1.0).abs() < 1e-15);
}

#[test]
fn indefinite_process_noise_is_refused_naming_q_and_the_model() {
    let model = LinearProcess { F: Matrix3::identity(), Q: Matrix3::identity() * -0.5 };
    let check = |e: FilterError| match &e {
        FilterError::InvalidProcessNoise { model, problem, value } => {
            assert!(model.contains("LinearProcess"), "{model}");
            assert_eq!(*problem, "not positive semi-definite");
            assert!(*value < 0.0);
            assert!(e.to_string().contains("process noise Q_d of model `LinearProcess"), "{e}");
        }
        other => panic!("{other}"),
    };
    let mut f = filter();
    check(f.predict(&model, &(), 0.1).unwrap_err());
    assert_unchanged(&f);
    let mut d = ErrorStateFilter::with_backend(
        Vector3::new(1.0, 2.0, 3.0),
        Matrix3::identity() * 2.0,
        FixedNoise,
        estimator_core::DynamicCov::default(),
    )
    .unwrap();
    check(d.predict(&model, &(), 0.1).unwrap_err());
    assert_eq!(d.state(), &Vector3::new(1.0, 2.0, 3.0));
    // asymmetric and non-finite Q
    let mut q = Matrix3::identity();
    q[(0, 1)] = 0.5;
    let e = f.predict(&LinearProcess { F: Matrix3::identity(), Q: q }, &(), 0.1).unwrap_err();
    assert!(matches!(e, FilterError::InvalidProcessNoise { problem: "not symmetric", .. }), "{e}");
    let e = f
        .predict(
            &LinearProcess { F: Matrix3::identity(), Q: Matrix3::identity() * f64::NAN },
            &(),
            0.1,
        )
        .unwrap_err();
    assert!(matches!(e, FilterError::InvalidProcessNoise { problem: "not finite", .. }), "{e}");
    // a semi-definite Q (a direction without noise) is a covariance
    let psd = LinearProcess {
        F: Matrix3::identity(),
        Q: Matrix3::from_diagonal(&Vector3::new(1.0, 0.0, 2.0)),
    };
    f.predict(&psd, &(), 0.1).unwrap();
}
