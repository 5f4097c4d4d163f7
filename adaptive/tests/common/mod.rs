//! A seeded 3-D constant-velocity simulation (state: position, velocity; measurement:
//! position, m = 3) with knobs for the situations the strategies exist for: a step in
//! the true R, outliers, a process noise larger than assumed, a far-off start.
#![allow(dead_code, non_snake_case)]

use estimator_core::consistency::normalized_squared;
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, NoiseStrategy, UpdateLog, Verdict};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

pub type X = SVector<f64, 6>;

#[derive(Clone, Debug)]
pub struct Scenario {
    pub epochs: usize,
    pub dt: f64,
    /// Assumed white-acceleration PSD (m²/s³).
    pub q: f64,
    /// True PSD as a multiple of the assumed one.
    pub q_true_factor: f64,
    /// Assumed measurement σ (m).
    pub sigma: f64,
    /// True measurement variance factor after `r_step_epoch` (1 = no step).
    pub r_step_factor: f64,
    pub r_step_epoch: usize,
    /// Fraction of epochs with an outlier, and its size in σ *per component* (random
    /// sign on each axis, as a multipath jump that moves every coordinate).
    pub outlier_rate: f64,
    pub outlier_sigmas: f64,
    /// Initial estimation error (m) along x, and the P0 the filter believes.
    pub x0_error: f64,
    pub p0_pos: f64,
    pub seed: u64,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            epochs: 400,
            dt: 1.0,
            q: 0.002,
            q_true_factor: 1.0,
            sigma: 1.0,
            r_step_factor: 1.0,
            r_step_epoch: usize::MAX,
            outlier_rate: 0.0,
            outlier_sigmas: 10.0,
            x0_error: 0.0,
            p0_pos: 1.0,
            seed: 1,
        }
    }
}

pub fn F(dt: f64) -> SMatrix<f64, 6, 6> {
    let mut f = SMatrix::<f64, 6, 6>::identity();
    for i in 0..3 {
        f[(i, i + 3)] = dt;
    }
    f
}

pub fn Q(dt: f64, q: f64) -> SMatrix<f64, 6, 6> {
    let mut m = SMatrix::<f64, 6, 6>::zeros();
    for i in 0..3 {
        m[(i, i)] = dt.powi(3) / 3.0 * q;
        m[(i, i + 3)] = dt.powi(2) / 2.0 * q;
        m[(i + 3, i)] = dt.powi(2) / 2.0 * q;
        m[(i + 3, i + 3)] = dt * q;
    }
    m
}

pub fn H() -> SMatrix<f64, 3, 6> {
    SMatrix::<f64, 3, 6>::from_fn(|r, c| if r == c { 1.0 } else { 0.0 })
}

/// Truth and measurements for one scenario (identical for every strategy).
pub struct Data {
    pub truth: Vec<X>,
    pub z: Vec<Vector3<f64>>,
    pub true_r_var: Vec<f64>,
    pub x0: X,
}

pub fn simulate(sc: &Scenario) -> Data {
    let mut rng = StdRng::seed_from_u64(sc.seed);
    let f = F(sc.dt);
    let lq = Q(sc.dt, sc.q * sc.q_true_factor).cholesky().unwrap().l();
    let mut x = X::from_column_slice(&[0.0, 0.0, 0.0, 10.0, -5.0, 1.0]);
    let x0 = x + X::from_column_slice(&[sc.x0_error, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let (mut truth, mut z, mut vars) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..sc.epochs {
        let w = X::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
        x = f * x + lq * w;
        let var = sc.sigma.powi(2) * if k >= sc.r_step_epoch { sc.r_step_factor } else { 1.0 };
        let mut v = Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal)) * var.sqrt();
        if rng.random::<f64>() < sc.outlier_rate {
            let signs = Vector3::from_fn(|_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
            v += signs * sc.outlier_sigmas * sc.sigma;
        }
        truth.push(x);
        z.push(H() * x + v);
        vars.push(var);
    }
    Data { truth, z, true_r_var: vars, x0 }
}

pub struct RunResult {
    /// RMS 3-D position error over all epochs after `skip`.
    pub rms_pos: f64,
    pub nees: Vec<f64>,
    pub log: UpdateLog,
    pub final_error: f64,
}

pub fn run<A: NoiseStrategy>(strategy: A, sc: &Scenario, data: &Data, skip: usize) -> RunResult {
    let p0 = SMatrix::<f64, 6, 6>::from_diagonal(&X::from_column_slice(&[
        sc.p0_pos, sc.p0_pos, sc.p0_pos, 1.0, 1.0, 1.0,
    ]));
    let mut f = ErrorStateFilter::new(data.x0, p0, strategy).unwrap();
    let process = LinearProcess { F: F(sc.dt), Q: Q(sc.dt, sc.q) };
    let sensor = LinearMeasurement::new(H());
    let R = Matrix3::identity() * sc.sigma.powi(2);
    let mut log = UpdateLog::default();
    let (mut se, mut n, mut nees) = (0.0, 0usize, Vec::new());
    for k in 0..sc.epochs {
        f.predict(&process, &(), sc.dt).unwrap();
        f.update_observed(&sensor, &data.z[k], &R, &mut log).unwrap();
        let e = data.truth[k] - f.state();
        nees.push(normalized_squared(&e, &f.covariance()).unwrap());
        if k >= skip {
            se += e.fixed_rows::<3>(0).norm_squared();
            n += 1;
        }
    }
    let final_error = (data.truth[sc.epochs - 1] - f.state()).fixed_rows::<3>(0).norm();
    RunResult { rms_pos: (se / n.max(1) as f64).sqrt(), nees, log, final_error }
}

pub fn count(log: &UpdateLog, v: Verdict) -> usize {
    log.entries.iter().filter(|e| e.verdict == v).count()
}

/// Every strategy of the crate with its defaults, by name.
pub fn all_strategies() -> Vec<(&'static str, adaptive::AnyStrategy)> {
    adaptive::STRATEGY_NAMES.iter().map(|n| (*n, n.parse().unwrap())).collect()
}
