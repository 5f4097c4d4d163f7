//! Raw GNSS benchmarks (single-threaded), figures in `benches/README.md` (history: `docs/history/benches.md`):
//!
//! - a satellite's state from its broadcast record (position, velocity, clock);
//! - a single point of a real epoch (station 0759, 8 satellites): preparing the
//!   satellites, and the whole solution;
//! - the tightly coupled filter: one 20-state IMU epoch (against the 15-state one), one
//!   satellite's pseudorange update, one range-rate update;
//! - one RTK epoch of the shipped baseline (0759 against 3040, GPS L1 + L2, 8–9
//!   satellites, the filter after 20 epochs): kinematic from the single point, and with
//!   a prior (an INS's prediction) instead.
//!
//! Run: `cargo bench --bench raw_gnss`.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{BatchSize, Criterion};
use estimator::estimator_core::{ErrorStateFilter, FixedNoise, NoObserver};
use estimator::ins_gnss::model::ImuInput;
use estimator::ins_gnss::InsModel;
use gnss::spp::{prepare, single_point, SppOptions};
use gnss::{read_nav, ObsReader};
use ins_gnss_core::tight::{ClockNoise, InsModelTc, InsStateTc, Pseudorange, RangeRate, M20};
use ins_gnss_sim::raw::{simulate_raw, RawSim};
use ins_gnss_sim::{scenarios, simulate, GnssSim, Trajectory};
use nalgebra::{Matrix1, Vector1, Vector3};

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

fn spp(c: &mut Criterion) {
    let nav = read_nav(&data("rinex-rtklib/07590920.05n.zst")).unwrap();
    let epoch =
        ObsReader::open(&data("rinex-rtklib/07590920.05o.zst")).unwrap().nth(10).unwrap().unwrap();
    let opt = SppOptions::default();
    let kb = nav.klobuchar.unwrap();
    let e = nav.ephemerides.select(epoch.sats[0].sat, &epoch.time).unwrap().clone();
    let mut g = c.benchmark_group("raw_gnss");
    g.bench_function("satellite_state", |b| b.iter(|| black_box(e.state(black_box(&epoch.time)))));
    g.bench_function("spp_prepare_8_satellites", |b| {
        b.iter(|| black_box(prepare(&epoch, &nav.ephemerides, &opt)))
    });
    g.bench_function("spp_epoch_8_satellites", |b| {
        b.iter(|| black_box(single_point(&epoch, &nav.ephemerides, Some(&kb), &opt, None).unwrap()))
    });
    g.finish();
}

fn tight(c: &mut Criterion) {
    let nav = read_nav(&data("rinex-rtklib/07590920.05n.zst")).unwrap();
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs[..6]).unwrap();
    let none = GnssSim::none();
    let data = simulate(&traj, 200.0, &scenarios::mems_imu(), &none, 1);
    let t_gps = gnss::GpsTime::from_calendar(2005, 4, 2, 3, 0, 0.0);
    let (epochs, _) = simulate_raw(
        &traj,
        &nav.ephemerides,
        &nav.klobuchar.unwrap(),
        &RawSim::spp_budget(t_gps),
        1,
    );
    let sats = prepare(&epochs[60], &nav.ephemerides, &SppOptions::default()).0;
    let k = 60 * 200;
    let x = InsStateTc {
        nav: data.truth[k].state.clone(),
        clock: nalgebra::Vector2::new(3.0e4, 0.5),
        isb: Vector3::zeros(),
    };
    let p = M20::identity() * 1e-2;
    let model = InsModelTc {
        base: InsModel::wgs84(scenarios::mems_imu().noise),
        clock: ClockNoise::default(),
    };
    let u = ImuInput { prev: Some(data.imu[k - 1]), cur: data.imu[k] };
    let mut g = c.benchmark_group("tight");
    let f20 = ErrorStateFilter::new(x.clone(), p, FixedNoise).unwrap();
    g.bench_function("imu_epoch_20_states", |b| {
        b.iter_batched_ref(
            || f20.clone(),
            |f| f.predict(&model, &u, 0.005).unwrap(),
            BatchSize::SmallInput,
        )
    });
    let base = InsModel::wgs84(scenarios::mems_imu().noise);
    let p15 = nalgebra::SMatrix::<f64, 15, 15>::identity() * 1e-2;
    let f15 = ErrorStateFilter::new(x.nav.clone(), p15, FixedNoise).unwrap();
    g.bench_function("imu_epoch_15_states", |b| {
        b.iter_batched_ref(
            || f15.clone(),
            |f| f.predict(&base, &u, 0.005).unwrap(),
            BatchSize::SmallInput,
        )
    });
    let s = &sats[0];
    let pr = Pseudorange { sat: s, corrections: 5.0, lever_arm: Vector3::new(0.4, 0.1, -1.2) };
    g.bench_function("pseudorange_update_1_satellite", |b| {
        b.iter_batched_ref(
            || f20.clone(),
            |f| {
                f.update_observed(&pr, &Vector1::new(s.range), &Matrix1::new(9.0), &mut NoObserver)
                    .unwrap()
                    .summary()
            },
            BatchSize::SmallInput,
        )
    });
    let rr = RangeRate {
        sat: s,
        lever_arm: Vector3::new(0.4, 0.1, -1.2),
        gyro_rate: Vector3::new(0.0, 0.0, 0.1),
    };
    let rate = s.range_rate.unwrap();
    g.bench_function("range_rate_update_1_satellite", |b| {
        b.iter_batched_ref(
            || f20.clone(),
            |f| {
                f.update_observed(&rr, &Vector1::new(rate), &Matrix1::new(0.01), &mut NoObserver)
                    .unwrap()
                    .summary()
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

fn rtk(c: &mut Criterion) {
    use gnss::rtk::{Rtk, RtkOptions};
    let nav = read_nav(&data("rinex-rtklib/07590920.05n.zst")).unwrap();
    let rover: Vec<_> = ObsReader::open(&data("rinex-rtklib/07590920.05o.zst"))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    let base: Vec<_> = ObsReader::open(&data("rinex-rtklib/30400920.05o.zst"))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    let base_pos = Vector3::new(-3978242.4348, 3382841.1715, 3649902.7667);
    let opt = RtkOptions::default();
    let kb = nav.klobuchar.unwrap();
    let spp = |e| single_point(e, &nav.ephemerides, Some(&kb), &opt.spp, None).unwrap().pos;
    let mut filter = Rtk::new(base_pos, opt.clone());
    for k in 0..20 {
        filter.step(&rover[k], &base[k], &nav.ephemerides, Some(spp(&rover[k]))).unwrap();
    }
    let (r, b) = (&rover[20], &base[20]);
    let s = spp(r);
    let mut g = c.benchmark_group("rtk");
    g.bench_function("epoch_l1_l2", |bench| {
        bench.iter_batched_ref(
            || filter.clone(),
            |f| black_box(f.step(r, b, &nav.ephemerides, Some(s)).unwrap()),
            BatchSize::SmallInput,
        )
    });
    let prior = (s, nalgebra::Matrix3::identity() * 0.01);
    g.bench_function("epoch_l1_l2_with_prior", |bench| {
        bench.iter_batched_ref(
            || filter.clone(),
            |f| black_box(f.step_with_prior(r, b, &nav.ephemerides, None, Some(prior)).unwrap()),
            BatchSize::SmallInput,
        )
    });
    g.bench_function("single_point_of_the_epoch", |bench| bench.iter(|| black_box(spp(r))));
    g.finish();
}

fn main() {
    let mut c = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .configure_from_args();
    spp(&mut c);
    tight(&mut c);
    rtk(&mut c);
    c.final_summary();
}
