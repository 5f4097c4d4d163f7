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
