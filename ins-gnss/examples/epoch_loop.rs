//! A tight loop of INS epochs (mechanization + covariance propagation) for profilers:
//! `cargo build --profile profiling -p ins-gnss --example epoch_loop` then run it under
//! `perf record` or `valgrind --tool=callgrind`. Prints the time per epoch. With the
//! argument `update` it loops GNSS position+velocity updates instead, with `mechanization`
//! the mechanization alone.

use std::hint::black_box;
use std::time::Instant;

use estimator_core::{ErrorStateFilter, FixedNoise};
use ins_gnss_core::model::ImuInput;
use ins_gnss_core::{GnssPosVel, InsModel};
use ins_gnss_sim::{scenarios, simulate, GnssSim, Trajectory};
use nalgebra::{SMatrix, SVector, Vector3};

fn main() {
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs[..4]).unwrap();
    let none = GnssSim::none();
    let data = simulate(&traj, 200.0, &scenarios::mems_imu(), &none, 1);
    let model = InsModel::wgs84(scenarios::mems_imu().noise);
    let p = SMatrix::<f64, 15, 15>::from_fn(|i, j| if i == j { 1e-2 } else { 1e-5 });
    if std::env::args().nth(1).as_deref() == Some("update") {
        update_loop(&data.truth[8000].state, &data.imu[8000], p);
        return;
    }
    let n = 2_000_000;
    if std::env::args().nth(1).as_deref() == Some("mechanization") {
        use estimator_core::ProcessModel;
        let t = Instant::now();
        for k in 0..n {
            let i = 100 + k % 8000;
            let u = ImuInput { prev: Some(data.imu[i - 1]), cur: data.imu[i] };
            black_box(model.propagate(black_box(&data.truth[i].state), &u, 0.005));
        }
        println!("{:.3} µs per mechanization step", t.elapsed().as_secs_f64() / n as f64 * 1e6);
        return;
    }
    let mut f = ErrorStateFilter::new(data.truth[100].state.clone(), p, FixedNoise).unwrap();
    let t = Instant::now();
    for k in 0..n {
        let i = 100 + k % 8000;
        let u = ImuInput { prev: Some(data.imu[i - 1]), cur: data.imu[i] };
        f.predict(&model, black_box(&u), 0.005).unwrap();
        if k % 8000 == 0 {
            f.set_covariance(p).unwrap();
        }
    }
    println!("{:.3} µs per epoch", t.elapsed().as_secs_f64() / n as f64 * 1e6);
    black_box(f.state());
}

/// GNSS position+velocity updates from the same prior.
fn update_loop(
    x: &ins_gnss_core::InsState,
    imu: &ins_gnss_core::ImuSample,
    p: SMatrix<f64, 15, 15>,
) {
    use estimator_core::MeasurementModel;
    let m = GnssPosVel { lever_arm: Vector3::new(0.3, 0.0, -1.0), gyro_rate: imu.rate() };
    let z = (m.predict(x).0, x.vel);
    let r = SMatrix::<f64, 6, 6>::from_diagonal(&SVector::<f64, 6>::new(
        1.0, 1.0, 4.0, 0.01, 0.01, 0.01,
    ));
    let n = 1_000_000;
    let f0 = ErrorStateFilter::new(x.clone(), p, FixedNoise).unwrap();
    let t = Instant::now();
    for _ in 0..n {
        let mut f = black_box(f0.clone());
        black_box(f.update(&m, black_box(&z), &r).unwrap().nis);
    }
    println!(
        "{:.3} µs per update (with a copy of the filter)",
        t.elapsed().as_secs_f64() / n as f64 * 1e6
    );
}
