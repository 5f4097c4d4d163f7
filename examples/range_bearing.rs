//! Range-bearing localisation of a planar robot on `(R², SO(2))`.
//!
//! Math: unicycle `p' = p + v dt [cos θ, sin θ]`, `θ' = θ ⊕ ω dt`; landmark measurement
//! `z = (|l − p|, atan2(l − p) ⊖ θ)` with the bearing on SO(2), so the residual
//! `z ⊖ h(x̂)` stays small when the bearing crosses ±π. Error state `[δp, δθ]`,
//! right perturbation, Joseph update, exact reset.
//!
//! Run: `cargo run --release --example range_bearing`

use estimator::estimator_core::{
    ErrorStateFilter, FixedNoise, Manifold, MeasurementModel, ProcessModel, UpdateLog,
};
use estimator::manifolds::{So2, R2};
use estimator::models::planar::{Pose2, RangeBearing, Unicycle};
use nalgebra::{Matrix2, Matrix3, Vector1, Vector2, Vector3};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let model = Unicycle { sigma_v: 0.05, sigma_w: 0.01 };
    let landmarks =
        [Vector2::new(-30.0, 0.05), Vector2::new(-25.0, -0.05), Vector2::new(5.0, 40.0)];
    let (u, dt) = ((5.0, 0.25), 0.1);
    // Deterministic "noise" so the example needs no RNG: a small periodic bearing error.
    let mut truth: Pose2 = (R2::new(0.0, -20.0), So2::new(3.1));
    let x0 = (truth.0 + R2::new(0.5, -0.5), truth.1.oplus(&Vector1::new(0.04)));
    let p0 = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.01));
    let mut filter = ErrorStateFilter::new(x0, p0, FixedNoise)?;
    let r = Matrix2::new(0.01, 0.0, 0.0, 1e-4);
    let mut log = UpdateLog::default();
    let mut worst = 0.0_f64;
    for k in 0..600 {
        truth = model.propagate(&truth, &u, dt);
        filter.predict(&model, &u, dt)?;
        let sensor = RangeBearing { landmark: landmarks[k % 3] };
        let z = sensor
            .predict(&truth)
            .oplus(&Vector2::new(0.05 * (k as f64).sin(), 0.005 * (0.7 * k as f64).cos()));
        filter.update_observed(&sensor, &z, &r, &mut log)?;
        worst = worst.max(filter.state().1.ominus(&truth.1)[0].abs());
    }
    let mean_nis = log.entries.iter().map(|e| e.nis).sum::<f64>() / log.entries.len() as f64;
    println!(
        "600 steps, heading crossing ±π {} times",
        (600.0 * 0.25 * dt / std::f64::consts::PI) as u32
    );
    println!("final position error {:.3} m", (filter.state().0 - truth.0).norm());
    println!("max heading error    {:.4} rad", worst);
    println!("mean NIS             {:.2} (2 dof)", mean_nis);
    Ok(())
}
