//! The simulator of the INS/GNSS library (`ins-gnss-core`): exact trajectories
//! ([`Trajectory`]), sensor errors ([`ImuErrors`], [`GnssSim`]), built-in drives
//! ([`scenarios`]), and
//! [`simulate`], which turns them into a dataset (IMU increments, GNSS epochs, truth) at
//! any IMU rate, seeded and deterministic. The `ins-gnss` program's `simulate` command,
//! the examples and the tests build on it.
#![deny(missing_docs)]
#![allow(non_snake_case)]

pub mod raw;
pub mod rtcm;
pub mod scenarios;
mod sensors;
mod trajectory;

use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::SeedableRng;

use ins_gnss_core::earth::{earth_rate_ned, transport_rate};
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::imu::ImuSample;
use ins_gnss_core::InsState;

pub use sensors::{GnssSim, GnssWindow, GnssWindowKind, ImuCorruptor, ImuErrors, VIBRATION_SPEED};
pub use trajectory::{Kinematics, Segment, Start, Trajectory, TrajectoryError, GRID};

/// One truth record: the true navigation state and the true IMU biases.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthRecord {
    /// Time, s.
    pub t: f64,
    /// True state (biases are the total true biases).
    pub state: InsState,
    /// Exact instantaneous `ω_ib^b` (rad/s) and `f^b` (m/s²).
    pub rates: (Vector3<f64>, Vector3<f64>),
}

/// A simulated dataset.
#[derive(Clone, Debug, Default)]
pub struct SimDataset {
    /// IMU samples (increments), from the first interval on.
    pub imu: Vec<ImuSample>,
    /// GNSS epochs.
    pub gnss: Vec<GnssEpoch>,
    /// Truth at the start and at every IMU epoch.
    pub truth: Vec<TruthRecord>,
}

impl SimDataset {
    /// Every IMU sample with the GNSS epochs that fall in its interval, `t ≤ sample.t`
    /// and after the previous sample, in order: the input of
    /// [`Navigator::process`](ins_gnss_core::Navigator::process). Does not allocate.
    pub fn replay(&self) -> impl Iterator<Item = (&ImuSample, &[GnssEpoch])> + '_ {
        let mut g = 0;
        self.imu.iter().map(move |s| {
            let first = g;
            while g < self.gnss.len() && self.gnss[g].t <= s.t + 1e-9 {
                g += 1;
            }
            (s, &self.gnss[first..g])
        })
    }
}

/// Exact IMU increments and truth kinematics of a trajectory at one IMU rate: the
/// expensive, error-free part of a simulation, computed once and reused for every seed.
#[derive(Clone, Debug)]
pub struct ExactImu {
    /// Exact samples (no sensor errors).
    pub samples: Vec<ImuSample>,
    /// Truth at the start and at the end of every sample.
    pub kinematics: Vec<Kinematics>,
}

impl ExactImu {
    /// Integrate `traj` at `imu_rate_hz`.
    pub fn new(traj: &Trajectory, imu_rate_hz: f64) -> Self {
        let dt = 1.0 / imu_rate_hz;
        let t0 = traj.start_time();
        let n = ((traj.end_time() - t0) / dt + 1e-9).floor() as usize;
        let mut samples = Vec::with_capacity(n);
        let mut kinematics = Vec::with_capacity(n + 1);
        kinematics.push(traj.at(t0));
        for i in 1..=n {
            let (ta, tb) = (t0 + (i - 1) as f64 * dt, t0 + i as f64 * dt);
            let (dtheta, dvel) = traj.increments(ta, tb);
            samples.push(ImuSample { t: tb, dt, dtheta, dvel, odometer: None });
            kinematics.push(traj.at(tb));
        }
        Self { samples, kinematics }
    }
}

/// The most samples of an exact IMU a [`Trajectory`] keeps for the next simulation
/// ([`Trajectory::exact_imu`]): 2¹⁸, 57 MB (216 bytes a sample; 44 minutes at 100 Hz). A longer one is
/// integrated again for each simulation ([`simulate_each`] streams it instead).
pub const EXACT_KEPT_SAMPLES: usize = 1 << 18;

impl Trajectory {
    /// The exact IMU of this trajectory at `imu_rate_hz` ([`ExactImu::new`]), integrated
    /// once and kept by the trajectory (and its clones) for the next call at the same rate
    /// — the seeds of a Monte-Carlo campaign share it — unless it holds more than
    /// [`EXACT_KEPT_SAMPLES`] samples. The same numbers as [`ExactImu::new`].
    pub fn exact_imu(&self, imu_rate_hz: f64) -> std::sync::Arc<ExactImu> {
        let key = imu_rate_hz.to_bits();
        let kept = self.exact.lock().ok().and_then(|k| k.clone());
        if let Some((rate, exact)) = kept
            && rate == key
        {
            return exact;
        }
        let exact = std::sync::Arc::new(ExactImu::new(self, imu_rate_hz));
        if exact.samples.len() <= EXACT_KEPT_SAMPLES
            && let Ok(mut k) = self.exact.lock()
        {
            *k = Some((key, exact.clone()));
        }
        exact
    }
}

/// Simulate `traj` with an IMU at `imu_rate_hz` and a GNSS receiver; `seed` fixes the IMU
/// noise stream and `seed + 1` the GNSS one. The exact IMU is the trajectory's
/// ([`Trajectory::exact_imu`]: integrated once per trajectory and rate).
pub fn simulate(
    traj: &Trajectory,
    imu_rate_hz: f64,
    imu: &ImuErrors,
    gnss: &GnssSim,
    seed: u64,
) -> SimDataset {
    simulate_from(&traj.exact_imu(imu_rate_hz), traj, imu, gnss, seed)
}

/// [`simulate`] from precomputed exact data (the cheap, per-seed part).
pub fn simulate_from(
    exact: &ExactImu,
    traj: &Trajectory,
    imu: &ImuErrors,
    gnss: &GnssSim,
    seed: u64,
) -> SimDataset {
    let mut rng_imu = StdRng::seed_from_u64(seed);
    let mut corruptor = ImuCorruptor::new(*imu, &mut rng_imu);
    let n = exact.samples.len();
    let mut out = SimDataset {
        imu: Vec::with_capacity(n),
        truth: Vec::with_capacity(n + 1),
        gnss: Vec::new(),
    };
    let record = |k: &Kinematics, biases: (Vector3<f64>, Vector3<f64>)| TruthRecord {
        t: k.t,
        state: InsState { att: k.att, vel: k.vel, pos: k.pos, bg: biases.0, ba: biases.1 },
        rates: (k.w_ib_b, k.f_b),
    };
    let mount = imu.mounting_rotation();
    let body = |k: &Kinematics| mount.as_ref().map_or(*k, |r| k.mounted(r));
    out.truth.push(record(&body(&exact.kinematics[0]), corruptor.biases()));
    for (s, k) in exact.samples.iter().zip(&exact.kinematics[1..]) {
        let speed = k.vel.norm();
        let (dtheta, dvel) = match &mount {
            Some(r) => (r.inverse().rotate(&s.dtheta), r.inverse().rotate(&s.dvel)),
            None => (s.dtheta, s.dvel),
        };
        let (dtheta, dvel) = corruptor.corrupt(&dtheta, &dvel, s.dt, speed, &mut rng_imu);
        // the wheels measure the vehicle's forward speed
        let odometer = imu.odometer_reading(k.att.matrix().tr_mul(&k.vel).x, &mut rng_imu);
        out.imu.push(ImuSample { dtheta, dvel, odometer, ..*s });
        out.truth.push(record(&body(k), corruptor.biases()));
    }
    gnss_epochs(traj, gnss, seed, mount, |g| {
        out.gnss.push(g);
        Ok::<(), core::convert::Infallible>(())
    })
    .unwrap_or_else(|e| match e {});
    out
}

/// The GNSS epochs of `traj` as [`simulate`] draws them (seed `seed + 1`), in time order,
/// each handed to `each`.
fn gnss_epochs<E>(
    traj: &Trajectory,
    gnss: &GnssSim,
    seed: u64,
    mount: Option<manifolds::So3>,
    mut each: impl FnMut(GnssEpoch) -> Result<(), E>,
) -> Result<(), E> {
    let mut rng_gnss = StdRng::seed_from_u64(seed.wrapping_add(1));
    let t0 = traj.start_time();
    // GNSS epochs on their own clock, from t0 on.
    if gnss.rate_hz > 0.0 {
        let step = 1.0 / gnss.rate_hz;
        let m = ((traj.end_time() - t0) / step + 1e-9).floor() as usize;
        for j in 0..=m {
            let t = t0 + j as f64 * step;
            let Some((factor, outliers)) = gnss.conditions(t) else { continue };
            let k = traj.at(t);
            // the antenna's lever arm is in the IMU's frame
            let k = mount.as_ref().map_or(k, |r| k.mounted(r));
            let lever_n = k.att.rotate(&gnss.lever_arm);
            let ant = manifolds::Manifold::oplus(&k.pos, &lever_n);
            let pos = gnss.corrupt_position(&ant, factor, outliers, &mut rng_gnss);
            let vel = gnss.vel_sigma.map(|s| {
                let w_in = earth_rate_ned(k.pos.lat) + transport_rate(k.pos.lat, k.pos.h, &k.vel);
                let v_ant =
                    k.vel + k.att.rotate(&k.w_ib_b.cross(&gnss.lever_arm)) - w_in.cross(&lever_n);
                (gnss.corrupt_velocity(&v_ant, &s, factor, &mut rng_gnss), s)
            });
            each(GnssEpoch::new(t, pos, gnss.pos_sigma, vel))?;
        }
    }
    Ok(())
}

/// A moving-base receiver's headings at `times` (the fixes' epochs): the heading (and
/// elevation) of the baseline `baseline` (body frame, FRD, m, from the primary antenna to
/// the secondary) of the IMU's attitude on `traj` (mounted at `mounting`, roll, pitch, yaw
/// in rad, as [`ImuErrors::mounting`]), with white noise of σ `sigma` rad on the heading
/// and `pitch_sigma` rad on the elevation, each stating its σ. Seed `seed + 3`.
pub fn antenna_headings(
    traj: &Trajectory,
    times: &[f64],
    baseline: &Vector3<f64>,
    mounting: &Vector3<f64>,
    sigma: f64,
    pitch_sigma: f64,
    seed: u64,
) -> Vec<ins_gnss_core::heading::AntennaHeading> {
    use rand_distr::{Distribution, StandardNormal};
    let mut rng = StdRng::seed_from_u64(seed.wrapping_add(3));
    let mount = (mounting.norm() > 0.0)
        .then(|| manifolds::So3::from_euler(mounting.x, mounting.y, mounting.z));
    times
        .iter()
        .map(|&t| {
            let k = traj.at(t);
            let k = mount.as_ref().map_or(k, |r| k.mounted(r));
            let b = k.att.rotate(baseline);
            let n1: f64 = StandardNormal.sample(&mut rng);
            let n2: f64 = StandardNormal.sample(&mut rng);
            let psi = b.y.atan2(b.x) + sigma * n1;
            let theta = (-b.z).atan2(b.xy().norm()) + pitch_sigma * n2;
            ins_gnss_core::heading::AntennaHeading {
                t,
                heading: ins_gnss_core::heading::wrap(psi),
                heading_std: Some(sigma),
                pitch: Some((theta, Some(pitch_sigma))),
                length: Some(baseline.norm()),
            }
        })
        .collect()
}

/// [`simulate`] without holding the dataset: the truth at the start, then every IMU
/// sample with the truth at its end, then every GNSS epoch, each handed to a callback as
/// it is generated (the same numbers as [`simulate`] with the same seed). Memory does not
/// grow with the duration or the rate, so a 24 h, 100 Hz drive streams to files.
pub fn simulate_each<E>(
    traj: &Trajectory,
    imu_rate_hz: f64,
    imu: &ImuErrors,
    gnss: &GnssSim,
    seed: u64,
    mut each_imu: impl FnMut(Option<&ImuSample>, &TruthRecord) -> Result<(), E>,
    each_gnss: impl FnMut(GnssEpoch) -> Result<(), E>,
) -> Result<(), E> {
    let mut rng_imu = StdRng::seed_from_u64(seed);
    let mut corruptor = ImuCorruptor::new(*imu, &mut rng_imu);
    let record = |k: &Kinematics, biases: (Vector3<f64>, Vector3<f64>)| TruthRecord {
        t: k.t,
        state: InsState { att: k.att, vel: k.vel, pos: k.pos, bg: biases.0, ba: biases.1 },
        rates: (k.w_ib_b, k.f_b),
    };
    let dt = 1.0 / imu_rate_hz;
    let t0 = traj.start_time();
    let n = ((traj.end_time() - t0) / dt + 1e-9).floor() as usize;
    let mount = imu.mounting_rotation();
    let body = |k: &Kinematics| mount.as_ref().map_or(*k, |r| k.mounted(r));
    each_imu(None, &record(&body(&traj.at(t0)), corruptor.biases()))?;
    for i in 1..=n {
        let (ta, tb) = (t0 + (i - 1) as f64 * dt, t0 + i as f64 * dt);
        let (dtheta, dvel) = traj.increments(ta, tb);
        let (dtheta, dvel) = match &mount {
            Some(r) => (r.inverse().rotate(&dtheta), r.inverse().rotate(&dvel)),
            None => (dtheta, dvel),
        };
        let end = traj.at(tb);
        let (dtheta, dvel) = corruptor.corrupt(&dtheta, &dvel, dt, end.vel.norm(), &mut rng_imu);
        let odometer = imu.odometer_reading(end.att.matrix().tr_mul(&end.vel).x, &mut rng_imu);
        let sample = ImuSample { t: tb, dt, dtheta, dvel, odometer };
        each_imu(Some(&sample), &record(&body(&end), corruptor.biases()))?;
    }
    gnss_epochs(traj, gnss, seed, mount, each_gnss)
}
