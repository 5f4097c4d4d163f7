//! The cost of what is newer than the filter's plain step (single-threaded), figures in
//! `docs/history/benches.md`:
//!
//! - a range-bearing update of a 3-state planar robot: plain (Jacobian), iterated (to
//!   convergence), unscented (7 sigma points), and an unscented prediction;
//! - the start's checks on a simulated drive: the static-start detector over 30 s of
//!   100 Hz IMU with 1 Hz fixes, and the in-motion alignment over 60 s of motion.
//!
//! Run: `cargo bench --bench estimators`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, Criterion};
use estimator::estimator_core::{
    ErrorStateFilter, FixedNoise, MeasurementJacobians, MeasurementModel, ProcessJacobians,
    ProcessModel, SigmaPoints,
};
use estimator::ins_gnss::align::{align_in_motion, detect_static, time_offset, turn_ratio};
use estimator::ins_gnss::imu::DEG_PER_H;
use estimator::ins_gnss::GeoPos;
use ins_gnss_sim::scenarios::{gnss_1hz, mems_imu};
use ins_gnss_sim::simulate;
use ins_gnss_sim::{Segment, Start, Trajectory};
use nalgebra::{Const, Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};

/// Range and bearing of a landmark from a planar pose (x, y, heading).
struct RangeBearing(Vector2<f64>);

impl MeasurementModel for RangeBearing {
    type State = Vector3<f64>;
    type Measurement = Vector2<f64>;

    fn predict(&self, x: &Vector3<f64>) -> Vector2<f64> {
        let d = self.0 - x.xy();
        Vector2::new(d.norm(), d.y.atan2(d.x) - x.z)
    }

    fn jacobian(&self, x: &Vector3<f64>) -> MeasurementJacobians<Const<2>, Const<3>> {
        let d = self.0 - x.xy();
        let q = d.norm_squared();
        let r = q.sqrt();
        MeasurementJacobians { H: Matrix2x3::new(-d.x / r, -d.y / r, 0.0, d.y / q, -d.x / q, -1.0) }
    }
}

/// A unicycle at 1 m/s turning at 0.1 rad/s.
struct Unicycle;

impl ProcessModel for Unicycle {
    type State = Vector3<f64>;
    type Input = ();

    fn propagate(&self, x: &Vector3<f64>, _u: &(), dt: f64) -> Vector3<f64> {
        Vector3::new(x.x + dt * x.z.cos(), x.y + dt * x.z.sin(), x.z + 0.1 * dt)
    }

    #[allow(non_snake_case)]
    fn jacobians(&self, x: &Vector3<f64>, _u: &(), dt: f64) -> ProcessJacobians<Const<3>> {
        let mut Phi = Matrix3::identity();
        Phi[(0, 2)] = -dt * x.z.sin();
        Phi[(1, 2)] = dt * x.z.cos();
        ProcessJacobians { Phi, Q: Matrix3::from_diagonal(&Vector3::new(1e-3, 1e-3, 1e-4)) }
    }
}

fn updates(c: &mut Criterion) {
    let filter = ErrorStateFilter::new(
        Vector3::new(2.0, 6.0, 0.3),
        Matrix3::from_diagonal(&Vector3::new(0.1, 0.1, 0.05)),
        FixedNoise,
    )
    .unwrap();
    let lm = RangeBearing(Vector2::new(5.0, 10.0));
    let z = lm.predict(&Vector3::new(2.3, 5.8, 0.32));
    let r = Matrix2::from_diagonal(&Vector2::new(0.09, 0.01));
    let sp = SigmaPoints::default();
    let iterations = filter.clone().update_iterated(&lm, &z, &r, 20, 1e-9).unwrap().iterations;
    eprintln!("the iterated update takes {iterations} linearisations here");
    let mut g = c.benchmark_group("estimators");
    g.bench_function("range_bearing_update_plain", |b| {
        b.iter_batched_ref(
            || filter.clone(),
            |f| black_box(f.update(&lm, &z, &r).unwrap().nis),
            BatchSize::SmallInput,
        )
    });
    g.bench_function("range_bearing_update_iterated", |b| {
        b.iter_batched_ref(
            || filter.clone(),
            |f| black_box(f.update_iterated(&lm, &z, &r, 20, 1e-9).unwrap().iterations),
            BatchSize::SmallInput,
        )
    });
    g.bench_function("range_bearing_update_unscented", |b| {
        b.iter_batched_ref(
            || filter.clone(),
            |f| black_box(f.update_unscented(&lm, &z, &r, &sp).unwrap().nis),
            BatchSize::SmallInput,
        )
    });
    g.bench_function("unicycle_predict_plain", |b| {
        b.iter_batched_ref(
            || filter.clone(),
            |f| f.predict(&Unicycle, &(), 0.1).unwrap(),
            BatchSize::SmallInput,
        )
    });
    g.bench_function("unicycle_predict_unscented", |b| {
        b.iter_batched_ref(
            || filter.clone(),
            |f| f.predict_unscented(&Unicycle, &(), 0.1, &sp).unwrap(),
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

fn start_checks(c: &mut Criterion) {
    let deg = core::f64::consts::PI / 180.0;
    let lever = Vector3::new(0.5, 0.0, -1.0);
    let start = Start {
        t: 0.0,
        pos: GeoPos::from_degrees(45.0, 7.6, 240.0),
        speed: 0.0,
        yaw: 30.0 * deg,
        pitch: 0.0,
    };
    let segments = [
        Segment::stop(30.0),
        Segment::accelerate(10.0, 1.0),
        Segment::turn(20.0, 4.5 * deg),
        Segment::straight(15.0),
        Segment::turn(10.0, -6.0 * deg),
        Segment::straight(15.0),
    ];
    let traj = Trajectory::new(start, &segments).unwrap();
    let data = simulate(&traj, 100.0, &mems_imu(), &gnss_1hz(lever), 5);
    let mut g = c.benchmark_group("start_checks");
    g.bench_function("detect_static_30s_static_of_100s", |b| {
        b.iter(|| black_box(detect_static(&data.imu, &data.gnss, 1.0).samples))
    });
    g.bench_function("align_in_motion_60s", |b| {
        b.iter(|| {
            black_box(align_in_motion(
                &data.imu,
                &data.gnss,
                30.0,
                &Vector3::zeros(),
                1.0,
                &lever,
                60.0,
                1.0 * deg,
                100.0 * DEG_PER_H,
                0.0,
            ))
        })
    });
    g.bench_function("time_offset_70s_within_10s", |b| {
        b.iter(|| {
            black_box(time_offset(&data.imu, &data.gnss, 30.0, 100.0, 10.0, &Vector3::zeros()))
        })
    });
    g.bench_function("turn_ratio_70s", |b| {
        b.iter(|| black_box(turn_ratio(&data.imu, &data.gnss, 30.0, 100.0)))
    });
    g.finish();
}

fn main() {
    let mut c = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .configure_from_args();
    updates(&mut c);
    start_checks(&mut c);
    c.final_summary();
}
