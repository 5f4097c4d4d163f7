//! Land-vehicle aiding on the simulated car (`drive_600s`: three stops, turns, a climb),
//! with road vibration while moving: the stationary detector's false-alarm and miss rates,
//! and what NHC and ZUPT/ZARU do to the drift in GNSS outages, with the NEES of the aided
//! filter. The IMU is mounted square at the constraint point, so the simulated car obeys
//! NHC exactly.

use crate::common;

use estimator_core::consistency::normalized_squared;
use estimator_core::{FixedNoise, NoObserver};
use ins_gnss_core::vehicle::{
    DetectorConfig, NhcConfig, OdometerConfig, StationaryDetector, VehicleAiding, ZuptConfig,
};
use ins_gnss_core::{GnssConfig, InitialState, InsModel, InsState, Navigator};
use ins_gnss_sim::{simulate_from, SimDataset};
use manifolds::Manifold;
use nalgebra::Vector3;

/// Road vibration: 0.5°/s and 0.3 m/s² per sample (1σ, each axis) while moving. (Speeds
/// between 0 and `VIBRATION_SPEED`, the last few samples of a stop, shake nothing and are
/// left out of the detector's statistics: an IMU cannot tell 5 cm/s from rest.)
fn vibrating_imu() -> ins_gnss_sim::ImuErrors {
    ins_gnss_sim::ImuErrors {
        vibration: (0.5f64.to_radians(), 0.3),
        // a wheel odometer reading 2 % fast, 0.05 m/s noise
        odometer: Some((ODOMETER_SCALE - 1.0, 0.05)),
        ..common::imu_errors()
    }
}

const ODOMETER_SCALE: f64 = 1.02;

fn dataset(setup: &common::Setup, seed: u64) -> SimDataset {
    simulate_from(&setup.exact, &setup.traj, &vibrating_imu(), &setup.gnss, seed)
}

fn dataset_with(setup: &common::Setup, imu: &ins_gnss_sim::ImuErrors, seed: u64) -> SimDataset {
    simulate_from(&setup.exact, &setup.traj, imu, &setup.gnss, seed)
}

#[test]
fn detector_finds_the_stops_without_false_alarms() {
    let setup = common::drive_setup(100.0, None);
    let config = DetectorConfig::default();
    let (mut false_alarms, mut moving, mut missed, mut standing) = (0usize, 0usize, 0usize, 0usize);
    for seed in 0..3 {
        let data = dataset(&setup, seed);
        let mut d = StationaryDetector::new(config);
        let mut still_since = f64::NEG_INFINITY;
        for (k, s) in data.imu.iter().enumerate() {
            let truth = &data.truth[k + 1];
            let says = d.push(s.dt, &s.rate(), &s.specific_force(), &Vector3::zeros());
            let speed = truth.state.vel.norm();
            let still = speed < 1e-9;
            if speed > ins_gnss_sim::VIBRATION_SPEED {
                still_since = f64::INFINITY;
                moving += 1;
                false_alarms += usize::from(says);
            } else if still {
                if still_since.is_infinite() {
                    still_since = s.t;
                }
                // the detector needs one full window of stillness to decide
                if s.t - still_since > config.window + 0.02 {
                    standing += 1;
                    missed += usize::from(!says);
                }
            }
        }
    }
    let (fa, miss) = (false_alarms as f64 / moving as f64, missed as f64 / standing as f64);
    eprintln!(
        "detector over 3 seeds: false alarms {false_alarms}/{moving} samples moving ({:.4} %), \
         missed {missed}/{standing} samples standing ({:.3} %)",
        fa * 100.0,
        miss * 100.0
    );
    assert_eq!(false_alarms, 0, "false alarms while moving");
    assert!(miss < 0.01, "miss rate {miss}");
}

struct Aided {
    max_outage_error: f64,
    mean_nees: f64,
    updates: [usize; 4],
    odometer_scale: Option<f64>,
}

/// One run with `aiding` and a GNSS outage; the maximum horizontal error inside the
/// outage and the mean NEES at whole seconds.
fn run(setup: &common::Setup, seed: u64, aiding: VehicleAiding, outage: (f64, f64)) -> Aided {
    run_with(setup, &vibrating_imu(), seed, aiding, outage)
}

fn run_with(
    setup: &common::Setup,
    imu: &ins_gnss_sim::ImuErrors,
    seed: u64,
    aiding: VehicleAiding,
    outage: (f64, f64),
) -> Aided {
    let data = dataset_with(setup, imu, seed);
    let truth0 = &data.truth[0].state;
    let std = common::initial_std();
    let start = InsState { bg: Vector3::zeros(), ba: Vector3::zeros(), ..truth0.clone() };
    let init = InitialState { time: data.truth[0].t, state: start, std };
    // the filter knows the vibration as extra white noise (it cannot tell it from noise)
    let mut noise = common::imu_errors().noise;
    let (vib_g, vib_a) = vibrating_imu().vibration;
    let dt: f64 = 0.01;
    noise.arw = noise.arw.map(|a| (a * a + vib_g * vib_g * dt).sqrt());
    noise.vrw = noise.vrw.map(|a| (a * a + vib_a * vib_a * dt).sqrt());
    let model = InsModel::wgs84(noise);
    let cfg = GnssConfig { lever_arm: setup.gnss.lever_arm, ..GnssConfig::default() };
    let mut nav =
        Navigator::new(&init, model, FixedNoise, cfg).unwrap().with_vehicle_aiding(aiding);
    let (mut worst, mut nees, mut n, mut updates) = (0.0f64, 0.0, 0.0, [0usize; 4]);
    let mut out = Vec::new();
    for (k, (s, gnss)) in data.replay().enumerate() {
        out.clear();
        nav.process_into(s, gnss, &mut NoObserver, &mut out).unwrap();
        for u in &out {
            if let Some(i) =
                ins_gnss_core::vehicle::VEHICLE_STREAMS.iter().position(|v| *v == u.stream)
            {
                updates[i] += 1;
            }
        }
        let truth = &data.truth[k + 1].state;
        let e = truth.ominus(nav.state());
        if s.t >= outage.0 && s.t < outage.1 {
            worst = worst.max((e[6] * e[6] + e[7] * e[7]).sqrt());
        }
        if (s.t - s.t.round()).abs() < 1e-9 && s.t > 30.0 {
            nees += normalized_squared(&e, nav.covariance()).unwrap();
            n += 1.0;
        }
    }
    Aided {
        max_outage_error: worst,
        mean_nees: nees / n,
        updates,
        odometer_scale: nav.odometer_scale(),
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn nhc_cuts_the_drift_of_a_moving_outage_and_stays_consistent() {
    // 60 s outage over a turn and a straight at 12 m/s
    let outage = (360.0, 420.0);
    let setup = common::drive_setup(100.0, Some(outage));
    let nhc = VehicleAiding { nhc: Some(NhcConfig::default()), ..Default::default() };
    let seeds = 0..4usize;
    let (mut plain, mut aided, mut nees) = (Vec::new(), Vec::new(), Vec::new());
    for seed in seeds.clone().map(|s| s as u64) {
        plain.push(run(&setup, seed, VehicleAiding::default(), outage).max_outage_error);
        let a = run(&setup, seed, nhc, outage);
        assert!(a.updates[0] > 5000, "NHC updates {}", a.updates[0]);
        aided.push(a.max_outage_error);
        nees.push(a.mean_nees);
    }
    let (p, a, q) = (mean(&plain), mean(&aided), mean(&nees));
    eprintln!(
        "60 s outage, max horizontal error over {} seeds: GNSS only {p:.2} m, + NHC {a:.2} m; mean NEES with NHC {q:.2} (15 states)",
        seeds.len()
    );
    assert!(a < 0.7 * p, "NHC {a} vs plain {p}");
    // NEES of 15 states: mean 15; over 4 runs × ~570 correlated samples allow a wide band
    assert!(q > 5.0 && q < 30.0, "mean NEES {q}");
}

#[test]
fn zupt_holds_the_position_through_a_stop_without_gnss() {
    // outage from just before the second stop (260–290 s) to after the restart
    let outage = (255.0, 300.0);
    let setup = common::drive_setup(100.0, Some(outage));
    let zupt = VehicleAiding { zupt: Some(ZuptConfig::default()), ..Default::default() };
    let (mut plain, mut aided) = (Vec::new(), Vec::new());
    for seed in 0..4u64 {
        plain.push(run(&setup, seed, VehicleAiding::default(), outage).max_outage_error);
        let a = run(&setup, seed, zupt, outage);
        assert!(a.updates[1] > 100 && a.updates[2] > 10, "ZUPT/ZARU updates {:?}", a.updates);
        aided.push(a.max_outage_error);
    }
    let (p, a) = (mean(&plain), mean(&aided));
    eprintln!(
        "45 s outage over a 30 s stop, max horizontal error: GNSS only {p:.2} m, + ZUPT/ZARU {a:.2} m"
    );
    assert!(a < 0.5 * p, "ZUPT {a} vs plain {p}");
}

#[test]
fn odometer_cuts_the_along_track_drift_and_finds_its_scale() {
    let outage = (360.0, 420.0);
    let setup = common::drive_setup(100.0, Some(outage));
    let nhc = VehicleAiding { nhc: Some(NhcConfig::default()), ..Default::default() };
    let odo = VehicleAiding { odometer: Some(OdometerConfig::default()), ..nhc };
    let (mut plain, mut aided, mut scales) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 0..3u64 {
        plain.push(run(&setup, seed, nhc, outage).max_outage_error);
        let a = run(&setup, seed, odo, outage);
        assert!(a.updates[3] > 2000, "odometer updates {:?}", a.updates);
        aided.push(a.max_outage_error);
        scales.push(a.odometer_scale.expect("calibrated"));
    }
    let (p, a) = (mean(&plain), mean(&aided));
    let worst = scales.iter().map(|k| (k - ODOMETER_SCALE).abs()).fold(0.0, f64::max);
    eprintln!(
        "60 s outage, max horizontal error: NHC {p:.2} m, NHC + odometer {a:.2} m; odometer \
         scale found {scales:.4?} (true {ODOMETER_SCALE})"
    );
    assert!(a < 0.6 * p, "odometer {a} vs NHC {p}");
    assert!(worst < 0.002, "scale off by {worst}");

    // stops found by the wheels alone (an IMU detector that never fires)
    let deaf = DetectorConfig { gyro_max: 1e-12, ..DetectorConfig::default() };
    let zupt = ZuptConfig { detector: deaf, ..ZuptConfig::default() };
    let without = run(&setup, 0, VehicleAiding { zupt: Some(zupt), ..nhc }, outage);
    let with = run(&setup, 0, VehicleAiding { zupt: Some(zupt), ..odo }, outage);
    assert_eq!(without.updates[1], 0, "the deaf detector fired");
    assert!(with.updates[1] > 500, "ZUPTs from the odometer: {:?}", with.updates);
}

#[test]
fn nhc_needs_the_mounting_angles_of_a_misaligned_imu() {
    // the IMU pitched 1.5° and yawed 3° against the car
    let deg = core::f64::consts::PI / 180.0;
    let mounting = Vector3::new(0.0, 1.5 * deg, 3.0 * deg);
    let imu = ins_gnss_sim::ImuErrors { mounting, ..vibrating_imu() };
    let outage = (360.0, 420.0);
    let setup = common::drive_setup(100.0, Some(outage));
    let aiding = |m: Vector3<f64>| VehicleAiding {
        nhc: Some(NhcConfig { mounting: m, ..NhcConfig::default() }),
        ..Default::default()
    };
    let (mut right, mut wrong, mut nees) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 0..3u64 {
        let a = run_with(&setup, &imu, seed, aiding(mounting), outage);
        right.push(a.max_outage_error);
        nees.push(a.mean_nees);
        wrong.push(run_with(&setup, &imu, seed, aiding(Vector3::zeros()), outage).max_outage_error);
    }
    let (r, w, q) = (mean(&right), mean(&wrong), mean(&nees));
    eprintln!(
        "IMU mounted 1.5° pitch, 3° yaw: 60 s outage max horizontal error with the right \
         mounting {r:.2} m, assuming it square {w:.2} m; mean NEES (right) {q:.2}"
    );
    assert!(r < 0.7 * w, "right {r} vs wrong {w}");
    assert!(q > 5.0 && q < 30.0, "mean NEES {q}");
}
