//! Property test: P stays symmetric positive definite across random sequences of predict
//! and update with random PD P0, Q, R and random F, H.

#![allow(non_snake_case)]

use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, FixedNoise};
use nalgebra::{SMatrix, SVector};
use proptest::prelude::*;

fn matrix<const R: usize, const C: usize>(scale: f64) -> impl Strategy<Value = SMatrix<f64, R, C>> {
    prop::collection::vec(-scale..scale, R * C).prop_map(SMatrix::from_vec)
}

fn spd<const N: usize>(floor: f64) -> impl Strategy<Value = SMatrix<f64, N, N>> {
    matrix::<N, N>(2.0).prop_map(move |a| a * a.transpose() + SMatrix::identity() * floor)
}

#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
enum Op {
    Predict(SMatrix<f64, 5, 5>, SMatrix<f64, 5, 5>),
    Update(SMatrix<f64, 2, 5>, SMatrix<f64, 2, 2>, SVector<f64, 2>),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (matrix::<5, 5>(1.2), spd::<5>(1e-3)).prop_map(|(f, q)| Op::Predict(f, q)),
        (matrix::<2, 5>(3.0), spd::<2>(1e-3), matrix::<2, 1>(10.0))
            .prop_map(|(h, r, z)| Op::Update(h, r, z)),
    ]
}

fn assert_spd(p: &SMatrix<f64, 5, 5>) -> Result<(), TestCaseError> {
    let scale = p.abs().max().max(1.0);
    prop_assert!((p - p.transpose()).abs().max() <= 1e-12 * scale, "not symmetric: {p}");
    prop_assert!(p.iter().all(|v| v.is_finite()));
    prop_assert!(p.cholesky().is_some(), "not positive definite: {p}");
    let min_eig = p.symmetric_eigenvalues().min();
    prop_assert!(min_eig > 0.0, "min eigenvalue {min_eig}");
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn covariance_stays_symmetric_positive_definite(
        p0 in spd::<5>(1e-2),
        ops in prop::collection::vec(op(), 1..40),
    ) {
        let mut f = ErrorStateFilter::new(SVector::<f64, 5>::zeros(), p0, FixedNoise).unwrap();
        for o in ops {
            match o {
                Op::Predict(phi, q) => f.predict(&LinearProcess { F: phi, Q: q }, &(), 0.01).unwrap(),
                Op::Update(h, r, z) => {
                    f.update(&LinearMeasurement::new(h), &z, &r).unwrap();
                }
            }
            assert_spd(&f.covariance())?;
        }
    }
}
