//! The paper's loitering flight, simulated exactly, with MEMS sensor errors.
//!
//! A circle of radius 600 m at 200 m height flown clockwise (seen from above) at a roll
//! of 20° and zero pitch, starting at 20 m/s, with the speed sequence of the paper:
//! constant 30 s → +2 m/s² 10 s → constant 30 s → +2 m/s² 10 s → constant 30 s →
//! −2 m/s² 10 s → constant 30 s → −2 m/s² 10 s → constant 30 s (190 s).
//!
//! Kinematics: heading rate `ψ̇ = v/r`, so `ψ(t)` is closed-form (the speed is piecewise
//! linear); the body rate `ω = ψ̇ [0, sin φ, cos φ]` has a fixed direction, so the gyro
//! increments are exact; `v̇ⁿ = v̇ t̂ + (v²/r) n̂` (tangential and centripetal) and the
//! accelerometer measures `f = R_nbᵀ (v̇ⁿ − gⁿ)`. Earth rate is not simulated (the AHRS
//! models do not carry it either). The paper's 20° roll is kept as stated although a
//! coordinated turn at these speeds would bank less (4–15°).

use manifolds::So3;
use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

/// Sensor error figures of the simulated MEMS unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorErrors {
    /// Gyro white noise, rad/s per sample (1σ).
    pub gyro_noise: f64,
    /// Constant gyro drift σ per axis, rad/s (drawn per seed).
    pub gyro_drift: f64,
    /// Accelerometer white noise, m/s² per sample.
    pub accel_noise: f64,
    /// Magnetometer white noise, in units of |m_n| per sample.
    pub mag_noise: f64,
}

impl Default for SensorErrors {
    /// A consumer MEMS unit at 100 Hz: gyro 0.005 rad/s (0.29°/s) per sample, drift
    /// 0.2°/s, accelerometer 0.05 m/s², magnetometer 0.005.
    fn default() -> Self {
        Self {
            gyro_noise: 0.005,
            gyro_drift: 0.2f64.to_radians(),
            accel_noise: 0.05,
            mag_noise: 0.005,
        }
    }
}

/// One sample: sensor readings and the truth.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Time at the end of the interval, s.
    pub t: f64,
    /// Measured mean angular rate over the interval, rad/s.
    pub gyro: Vector3<f64>,
    /// Measured specific force at `t`, m/s².
    pub accel: Vector3<f64>,
    /// Measured magnetic field at `t`.
    pub mag: Vector3<f64>,
    /// True attitude at `t`.
    pub att: So3,
    /// True body-frame maneuvering acceleration at `t`, m/s².
    pub acc_b: Vector3<f64>,
    /// True gyro drift, rad/s.
    pub drift: Vector3<f64>,
}

/// The flight.
#[derive(Clone, Debug)]
pub struct LoiteringFlight {
    /// Radius, m.
    pub radius: f64,
    /// Roll, rad.
    pub roll: f64,
    /// Speed at t = 0, m/s.
    pub v0: f64,
    /// `(duration s, along-track acceleration m/s²)` segments.
    pub segments: Vec<(f64, f64)>,
    /// Sample rate, Hz.
    pub rate: f64,
    /// Gravity in NED.
    pub g_n: Vector3<f64>,
    /// Magnetic field in NED (unit vector, inclination 60°).
    pub m_n: Vector3<f64>,
}

impl Default for LoiteringFlight {
    fn default() -> Self {
        let inc = 60f64.to_radians();
        Self {
            radius: 600.0,
            roll: 20f64.to_radians(),
            v0: 20.0,
            segments: vec![
                (30.0, 0.0),
                (10.0, 2.0),
                (30.0, 0.0),
                (10.0, 2.0),
                (30.0, 0.0),
                (10.0, -2.0),
                (30.0, 0.0),
                (10.0, -2.0),
                (30.0, 0.0),
            ],
            rate: 100.0,
            g_n: Vector3::new(0.0, 0.0, 9.80665),
            m_n: Vector3::new(inc.cos(), 0.0, inc.sin()),
        }
    }
}

impl LoiteringFlight {
    /// `(speed, along-track acceleration, heading)` at time `t`.
    pub fn motion(&self, t: f64) -> (f64, f64, f64) {
        let (mut t0, mut v, mut psi) = (0.0, self.v0, 0.0);
        for &(d, a) in &self.segments {
            if t <= t0 + d {
                let tau = t - t0;
                return (v + a * tau, a, psi + (v * tau + 0.5 * a * tau * tau) / self.radius);
            }
            psi += (v * d + 0.5 * a * d * d) / self.radius;
            v += a * d;
            t0 += d;
        }
        (v, 0.0, psi + v * (t - t0) / self.radius)
    }

    /// Total duration, s.
    pub fn duration(&self) -> f64 {
        self.segments.iter().map(|s| s.0).sum()
    }

    /// True attitude at `t`.
    pub fn attitude(&self, t: f64) -> So3 {
        So3::from_euler(self.roll, 0.0, self.motion(t).2)
    }

    /// True body-frame acceleration `R_nbᵀ v̇ⁿ` at `t`.
    pub fn body_acceleration(&self, t: f64) -> Vector3<f64> {
        let (v, a, psi) = self.motion(t);
        let tangent = Vector3::new(psi.cos(), psi.sin(), 0.0);
        // Clockwise from above in NED (yaw increasing): the centre is to the right.
        let inward = Vector3::new(-psi.sin(), psi.cos(), 0.0);
        let accel_n = tangent * a + inward * (v * v / self.radius);
        self.attitude(t).inverse().rotate(&accel_n)
    }

    /// The bytes of a [`Recording`](super::Recording) of `samples` of this flight with
    /// `errors` (gyro, accelerometer and magnetometer rounded to counts of `lsb`): what the
    /// firmware example compiles in.
    pub fn recording(&self, errors: &SensorErrors, samples: &[Sample], lsb: [f64; 3]) -> Vec<u8> {
        let raw: Vec<[Vector3<f64>; 3]> =
            samples.iter().map(|s| [s.gyro, s.accel, s.mag]).collect();
        let mut bytes = Vec::new();
        super::Recording::write(
            &mut bytes,
            self.rate,
            errors.gyro_noise,
            &self.g_n,
            &self.m_n,
            &self.attitude(0.0),
            lsb,
            &raw,
        );
        bytes
    }

    /// Simulate with `errors` and `seed`.
    pub fn simulate(&self, errors: &SensorErrors, seed: u64) -> Vec<Sample> {
        let mut rng = StdRng::seed_from_u64(seed);
        let mut n3 = |s: f64| Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal)) * s;
        let drift = n3(errors.gyro_drift);
        let dt = 1.0 / self.rate;
        let n = (self.duration() * self.rate).round() as usize;
        let axis = Vector3::new(0.0, self.roll.sin(), self.roll.cos());
        let mut out = Vec::with_capacity(n);
        for k in 1..=n {
            let (ta, tb) = ((k - 1) as f64 * dt, k as f64 * dt);
            // Exact mean rate: the body rotates about a fixed axis by Δψ.
            let dpsi = self.motion(tb).2 - self.motion(ta).2;
            let gyro = axis * (dpsi / dt) + drift + n3(errors.gyro_noise);
            let att = self.attitude(tb);
            let acc_b = self.body_acceleration(tb);
            let r_bn = att.inverse();
            let accel = acc_b - r_bn.rotate(&self.g_n) + n3(errors.accel_noise);
            let mag = r_bn.rotate(&self.m_n) + n3(errors.mag_noise);
            out.push(Sample { t: tb, gyro, accel, mag, att, acc_b, drift });
        }
        out
    }
}
