//! Filter benchmarks (single-threaded), see `benches/README.md` for a table of results (history: `docs/history/benches.md`):
//!
//! - predict and update vs state dimension (6 … 240) × covariance back-end;
//! - one 15-state INS epoch (mechanization + covariance propagation), dense vs structured;
//! - one GNSS position+velocity update of the INS filter;
//! - a whole run of the simulator's 10-minute drive at 200 Hz (IMU epochs per second);
//! - text in and out: the IMU reader and the navigation writer, in MB/s;
//! - the segment smoother on 8,000 INS epochs: the recorded forward pass, the backward
//!   pass (replay and adjoint recursion), and the adjoint product `Φᵀ Λ Φ`.
//!
//! Run: `cargo bench --bench filters` (add a filter, e.g. `-- ins_epoch`, to run a part).
//! The 240-state static matrices are large, so the benches run on a thread with a 256 MiB
//! stack.

#![allow(non_snake_case)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, BenchmarkId, Criterion, Throughput};
use estimator::estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator::estimator_core::{
    CovBackend, DynamicCov, ErrorStateFilter, FaerCov, FixedNoise, NoObserver, ProcessJacobians,
    ProcessModel, SegmentSmoother, StaticCov, StepRecorder, UpdateForm,
};
use estimator::ins_gnss::model::ImuInput;
use estimator::ins_gnss::{
    GnssConfig, GnssPosVel, InitialState, InitialStd, InsModel, InsState, Navigator,
};
use ins_gnss_sim::{scenarios, simulate, GnssSim, Trajectory};
use nalgebra::{Const, SMatrix, SVector, Vector3};

fn linear_problem<const N: usize>(
) -> (LinearProcess<N>, LinearMeasurement<3, N>, SMatrix<f64, N, N>) {
    // A contraction at every size (row sums ≤ 0.98 + 0.012): repeated predictions converge
    // to a steady state instead of overflowing.
    let F = SMatrix::<f64, N, N>::from_fn(|i, j| {
        if i == j {
            0.98
        } else {
            ((i * 31 + j * 17) % 13) as f64 * 1e-3 / N as f64
        }
    });
    let Q = SMatrix::<f64, N, N>::identity() * 1e-3;
    let H = SMatrix::<f64, 3, N>::from_fn(|i, j| if j % 3 == i { 1.0 } else { 0.0 });
    let P0 = SMatrix::<f64, N, N>::from_fn(|i, j| {
        if i == j {
            1.0
        } else {
            0.01 / (1.0 + (i as f64 - j as f64).abs())
        }
    });
    (LinearProcess { F, Q }, LinearMeasurement::new(H), P0)
}

fn bench_dim_backend<const N: usize, B: CovBackend<Const<N>>>(c: &mut Criterion, backend: B) {
    let (process, sensor, P0) = linear_problem::<N>();
    let name = B::NAME;
    let mut f = ErrorStateFilter::with_backend(SVector::<f64, N>::zeros(), P0, FixedNoise, backend)
        .unwrap();
    let mut g = c.benchmark_group("predict");
    g.bench_with_input(BenchmarkId::new(name, N), &N, |b, _| {
        b.iter(|| f.predict(black_box(&process), &(), 0.01).unwrap())
    });
    g.finish();
    let R = SMatrix::<f64, 3, 3>::identity();
    let zs: Vec<SVector<f64, 3>> =
        (0..16).map(|k| SVector::<f64, 3>::from_element(k as f64 * 0.01)).collect();
    let mut k = 0;
    let mut g = c.benchmark_group("update");
    g.bench_with_input(BenchmarkId::new(name, N), &N, |b, _| {
        b.iter(|| {
            k = (k + 1) % zs.len();
            black_box(f.update(&sensor, &zs[k], &R).unwrap().nis)
        })
    });
    g.finish();
}

fn dims(c: &mut Criterion) {
    macro_rules! all_backends {
        ($($n:literal),*) => {$(
            bench_dim_backend::<$n, _>(c, StaticCov);
            bench_dim_backend::<$n, _>(c, DynamicCov::default());
            bench_dim_backend::<$n, _>(c, FaerCov::default());
        )*};
    }
    all_backends!(6, 9, 15, 21, 30, 60, 120, 240);
}

/// The INS model with the dense default propagation, for comparison.
struct DenseIns(InsModel);

impl ProcessModel for DenseIns {
    type State = InsState;
    type Input = ImuInput;
    fn propagate(&self, x: &InsState, u: &ImuInput, dt: f64) -> InsState {
        self.0.propagate(x, u, dt)
    }
    fn jacobians(&self, x: &InsState, u: &ImuInput, dt: f64) -> ProcessJacobians<Const<15>> {
        self.0.jacobians(x, u, dt)
    }
}

/// 40 s of the simulated drive at 200 Hz: the true states and the IMU inputs that end at
/// them, with the start covariance and the model.
struct InsDrive {
    states: Vec<InsState>,
    inputs: Vec<ImuInput>,
    P: SMatrix<f64, 15, 15>,
    model: InsModel,
}

fn ins_setup() -> InsDrive {
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs[..4]).unwrap();
    let data = simulate(&traj, 200.0, &scenarios::mems_imu(), &GnssSim::none(), 1);
    let range = 100..8100;
    InsDrive {
        states: range.clone().map(|k| data.truth[k].state.clone()).collect(),
        inputs: range.map(|k| ImuInput { prev: Some(data.imu[k - 1]), cur: data.imu[k] }).collect(),
        P: SMatrix::<f64, 15, 15>::from_fn(|i, j| if i == j { 1e-2 } else { 1e-5 }),
        model: InsModel::wgs84(scenarios::mems_imu().noise),
    }
}

/// One filter epoch after another through the drive's IMU inputs, back to the start state
/// and covariance after the last (1 in 8,000 epochs). Repeating one input instead drives
/// the state away: after millions of epochs it is at orbital speed and height, where the
/// library's `sin_cos` takes a slower path.
fn drive_epochs<PM: ProcessModel<State = InsState, Input = ImuInput>>(
    b: &mut criterion::Bencher,
    d: &InsDrive,
    model: &PM,
) {
    let mut f = ErrorStateFilter::new(d.states[0].clone(), d.P, FixedNoise).unwrap();
    let mut k = 0;
    b.iter(|| {
        if k == d.inputs.len() {
            f.set_state(d.states[0].clone()).unwrap();
            f.set_covariance(d.P).unwrap();
            k = 0;
        }
        f.predict(model, black_box(&d.inputs[k]), 0.005).unwrap();
        k += 1;
    })
}

fn ins(c: &mut Criterion) {
    let d = ins_setup();
    let mut g = c.benchmark_group("ins_epoch");
    g.bench_function("structured", |b| drive_epochs(b, &d, &d.model));
    let dense = DenseIns(d.model.clone());
    g.bench_function("dense", |b| drive_epochs(b, &d, &dense));
    g.bench_function("states_21", |b| {
        use estimator::ins_gnss::scale::{InsModel21, InsState21, ScaleFactorNoise};
        let scale = ScaleFactorNoise { gyro: Vector3::repeat(1e-6), accel: Vector3::repeat(1e-6) };
        let model = InsModel21 { base: d.model.clone(), scale };
        let x0 = |k: usize| InsState21 {
            nav: d.states[k].clone(),
            sg: Vector3::zeros(),
            sa: Vector3::zeros(),
        };
        let mut p0 = SMatrix::<f64, 21, 21>::from_fn(|i, j| if i == j { 1e-6 } else { 0.0 });
        p0.fixed_view_mut::<15, 15>(0, 0).copy_from(&d.P);
        let mut f = ErrorStateFilter::new(x0(0), p0, FixedNoise).unwrap();
        let mut k = 0;
        b.iter(|| {
            if k == d.inputs.len() {
                f.set_state(x0(0)).unwrap();
                f.set_covariance(p0).unwrap();
                k = 0;
            }
            f.predict(&model, black_box(&d.inputs[k]), 0.005).unwrap();
            k += 1;
        })
    });
    // The navigator's IMU path (checks, bookkeeping, the filter's step) with no GNSS:
    // the exact mode, and the covariance once per 20 ms (4 samples at 200 Hz), the state
    // at every sample (`Navigator::with_covariance_interval`).
    for (name, interval) in [("navigator_exact", 0.0), ("navigator_covariance_20ms", 0.02)] {
        g.bench_function(name, |b| {
            let start = || {
                let t0 = d.inputs[0].cur.t - d.inputs[0].cur.dt;
                Navigator::from_parts(
                    d.states[0].clone(),
                    d.P,
                    t0,
                    d.model.clone(),
                    FixedNoise,
                    GnssConfig::default(),
                )
                .unwrap()
                .with_covariance_interval(interval)
            };
            let mut nav = start();
            let mut out = Vec::with_capacity(16);
            let mut k = 0;
            b.iter(|| {
                if k == d.inputs.len() {
                    nav = start();
                    k = 0;
                }
                nav.process_into(black_box(&d.inputs[k].cur), &[], &mut NoObserver, &mut out)
                    .unwrap();
                k += 1;
            })
        });
    }
    g.bench_function("mechanization_only", |b| {
        let mut k = 0;
        b.iter(|| {
            k = (k + 1) % d.inputs.len();
            black_box(d.model.propagate(black_box(&d.states[k]), &d.inputs[k], 0.005))
        })
    });
    g.finish();

    let (x, P, u) = (&d.states[7900], d.P, d.inputs[7900]);
    let mut g = c.benchmark_group("gnss_update");
    let f = ErrorStateFilter::new(x.clone(), P, FixedNoise).unwrap();
    let m = GnssPosVel { lever_arm: Vector3::new(0.3, 0.0, -1.0), gyro_rate: u.cur.rate() };
    let z = (m_predict(&m, x), x.vel);
    let R = SMatrix::<f64, 6, 6>::from_diagonal(&SVector::<f64, 6>::new(
        1.0, 1.0, 4.0, 0.01, 0.01, 0.01,
    ));
    // Every iteration updates a fresh copy of the same filter (the copies are made before
    // each timed batch, not timed). Batches of 32 copies (about 240 KB) stay in the L2
    // cache, as a filter does in a navigation loop; criterion's `SmallInput` batches hold a
    // tenth of a sample's iterations (hundreds of MB here), and each update then streamed
    // its filter from main memory.
    for (name, form) in [
        ("pos_vel_15_states", UpdateForm::Joseph),
        ("pos_vel_15_states_joseph_factored", UpdateForm::JosephFactored),
        ("pos_vel_15_states_short", UpdateForm::Short),
    ] {
        let f = f.clone().with_update_form(form);
        g.bench_function(name, |b| {
            b.iter_batched_ref(
                || f.clone(),
                |f| black_box(f.update(&m, black_box(&z), &R).unwrap().nis),
                BatchSize::NumIterations(32),
            )
        });
    }
    g.finish();
}

fn m_predict(m: &GnssPosVel, x: &InsState) -> estimator::ins_gnss::GeoPos {
    use estimator::estimator_core::MeasurementModel;
    m.predict(x).0
}

fn whole_run(c: &mut Criterion) {
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs).unwrap();
    let gnss = scenarios::gnss_1hz(Vector3::zeros());
    let data = simulate(&traj, 200.0, &scenarios::mems_imu(), &gnss, 2);
    let deg = core::f64::consts::PI / 180.0;
    let std = InitialStd {
        att: Vector3::repeat(deg),
        vel: Vector3::repeat(0.1),
        pos: Vector3::repeat(2.0),
        bg: Vector3::repeat(3e-4),
        ba: Vector3::repeat(5e-3),
    };
    let init = InitialState { time: data.truth[0].t, state: data.truth[0].state.clone(), std };
    let mut g = c.benchmark_group("whole_run");
    g.throughput(Throughput::Elements(data.imu.len() as u64));
    g.sample_size(10);
    g.bench_function("drive_600s_200hz_imu_epochs", |b| {
        b.iter(|| {
            let mut nav = Navigator::new(
                &init,
                InsModel::wgs84(scenarios::mems_imu().noise),
                FixedNoise,
                GnssConfig::default(),
            )
            .unwrap();
            let mut out = Vec::with_capacity(4);
            for (s, gnss) in data.replay() {
                out.clear();
                nav.process_into(s, gnss, &mut NoObserver, &mut out).unwrap();
            }
            black_box(nav.state().pos.lat)
        })
    });
    g.finish();
}

/// The segment smoother on the 40 s of [`ins_setup`] at 200 Hz (8,000 epochs, no update:
/// segments of 128 steps, continued): the forward pass recording into memory, the
/// backward pass from that recording (one thread, the replay on a second, and one thread
/// with the segments' products of transitions, `AdjointForm::Accumulated`), and the
/// adjoint products alone (structured, dense, and the accumulated form's `Ψ Φ`).
fn smoother(c: &mut Criterion) {
    type Recorder = SegmentSmoother<InsState, ImuInput, std::io::Cursor<Vec<u8>>>;
    let d = ins_setup();
    let record = || {
        let mut f = ErrorStateFilter::new(d.states[0].clone(), d.P, FixedNoise).unwrap();
        let mut seg = Recorder::new(std::io::Cursor::new(Vec::new()), 128);
        for u in &d.inputs {
            seg.before_predict(&f, u, 0.005, true);
            f.predict(&d.model, u, 0.005).unwrap();
        }
        (f, seg)
    };
    let mut g = c.benchmark_group("smoother");
    g.throughput(Throughput::Elements(d.inputs.len() as u64));
    g.sample_size(10);
    g.bench_function("forward_recorded_8000_epochs", |b| b.iter(|| black_box(record().0.time())));
    // (the step-by-step adjoint, and the segments' products of transitions that the
    // program uses with a covariance interval)
    use estimator::estimator_core::AdjointForm::{Accumulated, PerStep};
    for (name, threaded, form) in [
        ("backward_8000_epochs", false, PerStep),
        ("backward_threaded_8000_epochs", true, PerStep),
        ("backward_accumulated_8000_epochs", false, Accumulated),
    ] {
        g.bench_function(name, |b| {
            b.iter_batched(
                || {
                    let (f, seg) = record();
                    (f, seg.with_adjoint_form(form))
                },
                |(f, seg)| {
                    let mut rows = 0;
                    let sink = |r: &[_]| {
                        rows += r.len();
                        Ok(())
                    };
                    if threaded {
                        seg.smooth_threaded(&f, &d.model, sink).unwrap();
                    } else {
                        seg.smooth(&f, &d.model, sink).unwrap();
                    }
                    rows
                },
                BatchSize::LargeInput,
            )
        });
    }
    g.finish();
    let mut g = c.benchmark_group("adjoint_sandwich");
    let phi_t = d.model.transition(&d.states[0], &d.inputs[0], 0.005).transpose();
    let lambda = SMatrix::<f64, 15, 15>::from_fn(|i, j| 1.0 / (1.0 + i as f64 + j as f64));
    let mut out = SMatrix::<f64, 15, 15>::zeros();
    g.bench_function("structured", |b| {
        b.iter(|| d.model.adjoint_sandwich(black_box(&phi_t), black_box(&lambda), &mut out))
    });
    let zero = SMatrix::<f64, 15, 15>::zeros();
    g.bench_function("dense", |b| {
        b.iter(|| {
            estimator::estimator_core::FilterScalar::dense_sandwich(
                black_box(&phi_t),
                black_box(&lambda),
                &zero,
                &mut out,
            )
        })
    });
    // the accumulated form's step (`AdjointForm::Accumulated`): `Ψ ← Ψ Φ`
    let psi = SMatrix::<f64, 15, 15>::from_fn(|i, j| 1.0 / (2.0 + i as f64 - 0.5 * j as f64));
    g.bench_function("times_transition", |b| {
        b.iter(|| d.model.times_transition(black_box(&psi), black_box(&phi_t), &mut out))
    });
    g.finish();
}

/// Text in and out at the speed of the parser and formatter: 20,000 IMU lines (KF-GINS
/// increments, 7 columns) read from memory, 20,000 navigation rows written to memory.
fn text_io(c: &mut Criterion) {
    use estimator::ins_gnss::GeoPos;
    use estimator::ins_gnss_io::formats::{
        write_nav, BadLinePolicy, ImuFormat, ImuReader, NavRecord,
    };
    use std::io::Write as _;
    let n = 20_000;
    let mut imu = Vec::new();
    for k in 0..n {
        let t = 456_300.0 + k as f64 * 0.005;
        let a = k as f64 * 1e-3;
        writeln!(
            imu,
            "{t:.3} {:.12e} {:.12e} {:.12e} {:.12e} {:.12e} {:.12e}",
            1e-5 * a.sin(),
            -2e-5 * a.cos(),
            3e-6 + 1e-7 * a,
            0.01 * a.cos(),
            -0.002 * a.sin(),
            -0.049 + 1e-5 * a
        )
        .unwrap();
    }
    let mut g = c.benchmark_group("text_io");
    g.throughput(Throughput::Bytes(imu.len() as u64));
    g.bench_function("imu_reader_20k_lines", |b| {
        b.iter(|| {
            let mut r = ImuReader::new(
                std::io::Cursor::new(&imu[..]),
                std::path::Path::new("bench-imu.txt"),
                ImuFormat::Increments,
                200.0,
                1.5,
                BadLinePolicy::Error,
            );
            let mut sum = 0.0;
            while let Some(s) = r.next_sample().unwrap() {
                sum += s.dvel.z;
            }
            black_box(sum)
        })
    });
    let rows: Vec<NavRecord> = (0..n)
        .map(|k| {
            let a = k as f64 * 1e-3;
            NavRecord {
                week: 2017.0,
                t: 456_300.0 + k as f64 * 0.005,
                pos: GeoPos { lat: 0.5 + 1e-7 * a, lon: 2.0 - 1e-7 * a, h: 30.0 + a.sin() },
                vel: Vector3::new(10.0 * a.cos(), 10.0 * a.sin(), 0.01),
                att: Vector3::new(0.01 * a.sin(), -0.02, a % 3.0),
            }
        })
        .collect();
    let mut out = Vec::with_capacity(4 << 20);
    for r in &rows {
        write_nav(&mut out, r).unwrap();
    }
    g.throughput(Throughput::Bytes(out.len() as u64));
    g.bench_function("nav_writer_20k_rows", |b| {
        b.iter(|| {
            out.clear();
            for r in &rows {
                write_nav(&mut out, r).unwrap();
            }
            black_box(out.len())
        })
    });
    g.finish();
}

fn main() {
    std::thread::Builder::new()
        .stack_size(256 << 20)
        .spawn(|| {
            let mut c = Criterion::default()
                .warm_up_time(Duration::from_millis(500))
                .measurement_time(Duration::from_secs(2))
                .configure_from_args();
            ins(&mut c);
            text_io(&mut c);
            smoother(&mut c);
            whole_run(&mut c);
            dims(&mut c);
            c.final_summary();
        })
        .expect("bench thread")
        .join()
        .expect("bench thread panicked");
}
