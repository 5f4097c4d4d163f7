//! Shared driver for the simulated INS/GNSS tests: per-seed sensor errors and initial
//! errors drawn from the filter's own P0, a navigator run over the whole dataset, and
//! the truth-vs-estimate records the tests check.
#![allow(dead_code)]

use estimator_core::consistency::normalized_squared;
use estimator_core::{NoiseStrategy, UpdateLog};
use ins_gnss_core::imu::{DEG_PER_H, MGAL};
use ins_gnss_core::{GnssConfig, InitialState, InitialStd, InsModel, InsState, Navigator};
use ins_gnss_sim::{
    scenarios, simulate_from, ExactImu, GnssSim, GnssWindow, GnssWindowKind, SimDataset, Trajectory,
};
use manifolds::{Manifold, Tangent};
use nalgebra::{SVector, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

pub const TURN_ON_GYRO: f64 = 50.0 * DEG_PER_H;
pub const TURN_ON_ACCEL: f64 = 500.0 * MGAL;

pub struct Setup {
    pub traj: Trajectory,
    pub exact: ExactImu,
    pub gnss: GnssSim,
}

pub fn drive_setup(imu_rate: f64, outage: Option<(f64, f64)>) -> Setup {
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs).unwrap();
    let exact = ExactImu::new(&traj, imu_rate);
    let windows = outage
        .map(|(a, b)| vec![GnssWindow { start: a, end: b, kind: GnssWindowKind::Outage }])
        .unwrap_or_default();
    let gnss = GnssSim { windows, ..scenarios::gnss_1hz(Vector3::new(0.5, 0.2, -1.0)) };
    Setup { traj, exact, gnss }
}

/// The simulated IMU follows exactly the filter's model: the whole bias is a
/// Gauss–Markov process (σ 50°/h and 500 mGal, τ = 1 h) started from its steady state,
/// no separate turn-on bias, no scale factor.
pub fn imu_errors() -> ins_gnss_sim::ImuErrors {
    let mut e = scenarios::mems_imu();
    e.noise.gyro_bias = Vector3::repeat(TURN_ON_GYRO);
    e.noise.accel_bias = Vector3::repeat(TURN_ON_ACCEL);
    e.gyro_turn_on = Vector3::zeros();
    e.accel_turn_on = Vector3::zeros();
    e
}

pub fn initial_std() -> InitialStd {
    let deg = core::f64::consts::PI / 180.0;
    let gm = imu_errors().noise;
    InitialStd {
        att: Vector3::new(1.0 * deg, 1.0 * deg, 3.0 * deg),
        vel: Vector3::repeat(0.1),
        pos: Vector3::new(2.0, 2.0, 3.0),
        bg: gm.gyro_bias,
        ba: gm.accel_bias,
    }
}

/// The filter's start: the truth with an attitude, velocity and position error drawn from
/// P0 (`rng_seed`), the yaw error replaced by `yaw` when given, biases 0 (so the bias
/// error is the true bias).
pub fn initial_state(data: &SimDataset, rng_seed: u64, yaw: Option<f64>) -> InitialState {
    let mut rng = StdRng::seed_from_u64(rng_seed);
    let std = initial_std();
    let mut d = Tangent::<InsState>::zeros();
    for i in 0..3 {
        d[i] = std.att[i] * rng.sample::<f64, _>(StandardNormal);
        d[3 + i] = std.vel[i] * rng.sample::<f64, _>(StandardNormal);
        d[6 + i] = std.pos[i] * rng.sample::<f64, _>(StandardNormal);
    }
    if let Some(yaw) = yaw {
        d[2] = yaw;
    }
    let truth0 = &data.truth[0].state;
    let start = InsState { bg: Vector3::zeros(), ba: Vector3::zeros(), ..truth0.oplus(&d) };
    InitialState { time: data.truth[0].t, state: start, std }
}

pub struct Record {
    pub t: f64,
    pub error: SVector<f64, 15>,
    pub sigma: SVector<f64, 15>,
    pub nees: f64,
}

pub struct RunOutput {
    pub records: Vec<Record>,
    pub log: UpdateLog,
    pub data: SimDataset,
}

/// One seeded run: turn-on biases and the initial error drawn from P0; records the error
/// state at every whole second.
pub fn run<A: NoiseStrategy>(
    setup: &Setup,
    seed: u64,
    strategy: A,
    init_yaw_error: Option<f64>,
) -> RunOutput {
    run_with_interval(setup, seed, strategy, init_yaw_error, 0.0)
}

/// [`run`] with the covariance propagated once per `interval` s
/// ([`Navigator::with_covariance_interval`]; 0: at every sample).
pub fn run_with_interval<A: NoiseStrategy>(
    setup: &Setup,
    seed: u64,
    strategy: A,
    init_yaw_error: Option<f64>,
    interval: f64,
) -> RunOutput {
    let errors = imu_errors();
    let data = simulate_from(&setup.exact, &setup.traj, &errors, &setup.gnss, seed);
    let init = initial_state(&data, 10_000 + seed, init_yaw_error);
    let model = InsModel::wgs84(errors.noise);
    let cfg = GnssConfig { lever_arm: setup.gnss.lever_arm, ..GnssConfig::default() };
    let mut nav =
        Navigator::new(&init, model, strategy, cfg).unwrap().with_covariance_interval(interval);
    let mut log = UpdateLog::default();
    let mut records = Vec::new();
    for (k, (s, gnss)) in data.replay().enumerate() {
        nav.process(s, gnss, &mut log).unwrap();
        if (s.t - s.t.round()).abs() < 1e-9 {
            let truth = &data.truth[k + 1].state;
            let error = truth.ominus(nav.state());
            let nees = normalized_squared(&error, nav.covariance()).unwrap();
            records.push(Record { t: s.t, error, sigma: nav.sigma(), nees });
        }
    }
    RunOutput { records, log, data }
}

/// Run `seeds` in two threads.
pub fn run_many<A: NoiseStrategy + Clone + Send + Sync>(
    setup: &Setup,
    seeds: std::ops::Range<u64>,
    strategy: A,
    yaw: Option<f64>,
) -> Vec<RunOutput> {
    run_many_with_interval(setup, seeds, strategy, yaw, 0.0)
}

/// [`run_many`] with the covariance once per `interval` s.
#[allow(dead_code)]
pub fn run_many_with_interval<A: NoiseStrategy + Clone + Send + Sync>(
    setup: &Setup,
    seeds: std::ops::Range<u64>,
    strategy: A,
    yaw: Option<f64>,
    interval: f64,
) -> Vec<RunOutput> {
    let seeds: Vec<u64> = seeds.collect();
    let half = seeds.len() / 2;
    let (a, b) = seeds.split_at(half);
    let one = |seed: u64| run_with_interval(setup, seed, strategy.clone(), yaw, interval);
    std::thread::scope(|s| {
        let h = s.spawn(|| a.iter().map(|&seed| one(seed)).collect::<Vec<_>>());
        let mut second: Vec<_> = b.iter().map(|&seed| one(seed)).collect();
        let mut first = h.join().unwrap();
        first.append(&mut second);
        first
    })
}
