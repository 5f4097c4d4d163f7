//! Single against double precision for the CS-MAEKF AHRS (issue 34): the same filter in
//! `f32` and `f64` on the simulated loitering flight, 50 seeds of the 190 s flight at 100 Hz, then an
//! hour at 100 Hz (the loiter flown 19 times over) with the Joseph update (the default) and with the short form `P − KHP`.
//!
//! ```sh
//! cargo run --release -p models --example ahrs_f32
//! ```

use estimator_core::UpdateForm;
use models::ahrs::experiment::{f32_against_f64, Variant};
use models::ahrs::sim::{LoiteringFlight, SensorErrors};

fn main() {
    let flight = LoiteringFlight::default();
    let errors = SensorErrors::default();
    let model = Variant::CsMaekf.model(&errors, flight.rate);
    let (mut max, mut sq, mut n, mut min_eig, mut all_pd) =
        (0.0_f64, 0.0, 0usize, f64::INFINITY, true);
    for seed in 1..=50 {
        let samples = flight.simulate(&errors, seed);
        let d = f32_against_f64(&model, &flight, &samples, UpdateForm::Joseph, 100)
            .unwrap_or_else(|e| panic!("seed {seed}: the f64 filter failed: {e}"));
        assert!(
            d.failed_at.is_none(),
            "seed {seed}: the f32 filter failed at sample {:?}",
            d.failed_at
        );
        max = max.max(d.max_deg);
        sq += d.rms_deg * d.rms_deg * d.samples as f64;
        n += d.samples;
        min_eig = min_eig.min(d.min_relative_eigenvalue);
        all_pd &= d.positive_definite;
    }
    println!(
        "50 seeds x 190 s at 100 Hz (Joseph): f32 against f64 attitude, max {max:.2e} deg, RMS {:.2e} deg; \
         f32 P positive definite at every check: {all_pd}, smallest eigenvalue / largest {min_eig:.2e}",
        (sq / n as f64).sqrt()
    );
    let hour = flight.repeated((3600.0 / flight.duration()).ceil() as usize);
    let samples = hour.simulate(&errors, 1);
    for form in [UpdateForm::Joseph, UpdateForm::Short] {
        let d = f32_against_f64(&model, &hour, &samples, form, 100).expect("the f64 filter runs");
        println!(
            "{:.0} s at 100 Hz ({form:?}, {} samples): max {:.2e} deg, RMS {:.2e} deg, f32 P positive definite \
             at every check: {}, smallest eigenvalue / largest {:.2e}, f32 failure: {:?}",
            hour.duration(),
            d.samples,
            d.max_deg,
            d.rms_deg,
            d.positive_definite,
            d.min_relative_eigenvalue,
            d.failed_at
        );
    }
}
