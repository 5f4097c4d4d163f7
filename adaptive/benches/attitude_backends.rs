//! The covariance back-ends on a user's own model, by `estimator_core::bench`: the attitude
//! filter of `tests/common/attitude.rs` (SO(3) × R³, 6 states; a 3-row direction update).
//! `cargo bench -p adaptive --bench attitude_backends`.

#[path = "../tests/common/attitude.rs"]
mod attitude;

use criterion::{criterion_group, criterion_main, Criterion};
use estimator_core::bench::compare_backends;
use nalgebra::{Matrix3, SMatrix, Vector3};

fn attitude_filter(c: &mut Criterion) {
    let model = attitude::Gyro { arw: 0.005, bias_walk: 1e-5 };
    let x0 = (manifolds::So3::from_euler(0.1, -0.05, 0.7), Vector3::zeros());
    let p0 = SMatrix::<f64, 6, 6>::identity() * 1e-3;
    let gyro = Vector3::new(0.1, -0.2, 0.3);
    let sensor = attitude::gravity();
    let z = Vector3::new(0.05, -0.02, -0.998).normalize();
    let r = Matrix3::identity() * 4e-4;
    compare_backends(c, "attitude", &x0, &p0, (&model, &gyro, 0.01), (&sensor, &z, &r));
}

criterion_group!(benches, attitude_filter);
criterion_main!(benches);
