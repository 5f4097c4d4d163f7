//! The CS-MAEKF AHRS in single precision against double precision (issue 34): the same
//! filter, samples rounded to `f32`. `cargo run --release -p models --example ahrs_f32` runs
//! 50 seeds and an hour; this test runs three seeds.

use estimator_core::UpdateForm;
use models::ahrs::experiment::{f32_against_f64, Variant};
use models::ahrs::sim::{LoiteringFlight, SensorErrors};

#[test]
fn f32_attitude_within_a_twentieth_of_a_degree_of_f64() {
    let flight = LoiteringFlight::default();
    let errors = SensorErrors::default();
    let model = Variant::CsMaekf.model(&errors, flight.rate);
    for seed in 1..=3 {
        let samples = flight.simulate(&errors, seed);
        let d = f32_against_f64(&model, &flight, &samples, UpdateForm::Joseph, 50).unwrap();
        assert_eq!((d.failed_at, d.samples), (None, samples.len()), "seed {seed}");
        assert!(d.positive_definite, "seed {seed}: f32 P lost positive definiteness");
        assert!(d.max_deg <= 0.05, "seed {seed}: f32 differs from f64 by {:.3e}°", d.max_deg);
        // and the comparison is not vacuous: single precision does differ
        assert!(d.max_deg > 1e-6, "seed {seed}: {:.3e}°", d.max_deg);
    }
}

/// The no-heap outlier gate over `f32`: the AHRS filter with `NisGate` takes a consistent
/// accelerometer and magnetometer sample and refuses one with a 30 m/s² spike.
#[test]
fn nis_gate_in_f32() {
    use estimator_core::{ErrorStateFilter, NisGate, StaticCov, Verdict};
    use manifolds::So3;
    use models::ahrs::{AhrsMeasurement, AhrsState};
    use nalgebra::{SMatrix, SVector, Vector3};
    let x0 = AhrsState::<f32> { att: So3::identity(), bg: Vector3::zeros(), acc: Vector3::zeros() };
    let gate = NisGate { threshold: 16.81 }; // χ²(6) at 99 %
    let mut f: ErrorStateFilter<AhrsState<f32>, NisGate, StaticCov, f32> =
        ErrorStateFilter::new(x0, SMatrix::identity() * 0.01, gate).unwrap();
    let m = AhrsMeasurement::<f32> {
        g_n: Vector3::new(0.0, 0.0, 9.80665),
        m_n: Vector3::new(0.5, 0.0, 0.866),
    };
    let r = SMatrix::<f32, 6, 6>::identity() * 0.02;
    let good = SVector::<f32, 6>::new(0.0, 0.0, -9.80665, 0.5, 0.0, 0.866);
    assert_eq!(f.update(&m, &good, &r).unwrap().verdict, Verdict::Accepted);
    let mut spike = good;
    spike[0] += 30.0;
    let before = f.state().clone();
    assert_eq!(f.update(&m, &spike, &r).unwrap().verdict, Verdict::Rejected);
    assert_eq!(f.state(), &before);
}
