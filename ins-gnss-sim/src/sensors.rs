//! [`ImuErrors`] and what serves it (the documentation is on the item).

use manifolds::Manifold;
use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::Rng;
use rand_distr::StandardNormal;

use ins_gnss_core::imu::{BiasModel, ImuNoise};

/// IMU error specification for simulation, SI units.
///
/// IMU and GNSS error simulation (seeded, deterministic).
///
/// IMU: white noise on the increments (`σ_Δθ = ARW·√dt`, `σ_Δv = VRW·√dt`), a constant
/// turn-on bias, a bias that follows a first-order Gauss–Markov process (exact
/// discretisation `b⁺ = e^{−dt/τ} b + σ √(1 − e^{−2dt/τ}) n`) or a random walk, and a
/// scale-factor error: `Δθ_meas = (1 + s_g) ⊙ Δθ + b_g dt + n`.
/// GNSS: white position (and velocity) noise at the antenna, with time windows for
/// outages, interference (noise × factor, the reported σ unchanged) and outliers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuErrors {
    /// White noise and time-varying bias (the part a filter models).
    pub noise: ImuNoise,
    /// Constant gyro turn-on bias, rad/s.
    pub gyro_turn_on: Vector3<f64>,
    /// Constant accelerometer turn-on bias, m/s².
    pub accel_turn_on: Vector3<f64>,
    /// Gyro scale-factor error (fraction, e.g. 1e-3 = 1000 ppm).
    pub gyro_scale: Vector3<f64>,
    /// Accelerometer scale-factor error (fraction).
    pub accel_scale: Vector3<f64>,
    /// White vibration while the vehicle moves (a road shakes a car's IMU; a standing
    /// car's does not): 1σ per sample of the angular rate (rad/s) and specific force
    /// (m/s²) on each axis. Zero: none (no random numbers drawn).
    pub vibration: (f64, f64),
    /// A wheel odometer: its scale-factor error (fraction) and white noise (m/s, 1σ) on the
    /// forward speed; `None`: no odometer column.
    pub odometer: Option<(f64, f64)>,
    /// The IMU's mounting: roll, pitch, yaw of its axes relative to the vehicle's (rad),
    /// at the vehicle's reference point. The truth attitude is the IMU's.
    pub mounting: Vector3<f64>,
}

impl ImuErrors {
    /// An error-free IMU.
    pub fn none() -> Self {
        Self {
            noise: ImuNoise {
                arw: Vector3::zeros(),
                vrw: Vector3::zeros(),
                gyro_bias: Vector3::zeros(),
                accel_bias: Vector3::zeros(),
                bias_model: BiasModel::RandomWalk,
            },
            gyro_turn_on: Vector3::zeros(),
            accel_turn_on: Vector3::zeros(),
            gyro_scale: Vector3::zeros(),
            accel_scale: Vector3::zeros(),
            vibration: (0.0, 0.0),
            odometer: None,
            mounting: Vector3::zeros(),
        }
    }

    /// `R_vb` of the mounting (`None` when square, so square mounting costs nothing).
    pub fn mounting_rotation(&self) -> Option<manifolds::So3> {
        (self.mounting != Vector3::zeros())
            .then(|| manifolds::So3::from_euler(self.mounting.x, self.mounting.y, self.mounting.z))
    }

    /// The odometer reading for a true forward speed (draws a random number only when
    /// the IMU has an odometer); exactly 0 while the wheels stand.
    pub fn odometer_reading(&self, forward: f64, rng: &mut StdRng) -> Option<f64> {
        self.odometer.map(|(scale, sigma)| {
            let noise = sigma * rng.sample::<f64, _>(StandardNormal);
            if forward == 0.0 {
                0.0
            } else {
                forward * (1.0 + scale) + noise
            }
        })
    }
}

/// Above this speed (m/s) the simulated vehicle vibrates.
pub const VIBRATION_SPEED: f64 = 0.05;

/// The running state of a simulated IMU.
#[derive(Clone, Debug)]
pub struct ImuCorruptor {
    errors: ImuErrors,
    bg: Vector3<f64>,
    ba: Vector3<f64>,
}

fn normal3(rng: &mut StdRng) -> Vector3<f64> {
    Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal))
}

impl ImuCorruptor {
    /// Start with the Gauss–Markov bias drawn from its steady state (zero for a random walk).
    pub fn new(errors: ImuErrors, rng: &mut StdRng) -> Self {
        let (bg, ba) = match errors.noise.bias_model {
            BiasModel::GaussMarkov { .. } | BiasModel::GaussMarkovHeld { .. } => (
                normal3(rng).component_mul(&errors.noise.gyro_bias),
                normal3(rng).component_mul(&errors.noise.accel_bias),
            ),
            BiasModel::RandomWalk => (Vector3::zeros(), Vector3::zeros()),
        };
        Self { errors, bg, ba }
    }

    /// Total true biases `(gyro, accel)` now.
    pub fn biases(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.errors.gyro_turn_on + self.bg, self.errors.accel_turn_on + self.ba)
    }

    /// Corrupt exact increments over an interval of `dt` of a vehicle moving at `speed`
    /// (m/s, for the vibration); advances the bias processes.
    pub fn corrupt(
        &mut self,
        dtheta: &Vector3<f64>,
        dvel: &Vector3<f64>,
        dt: f64,
        speed: f64,
        rng: &mut StdRng,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let e = &self.errors;
        let (bg, ba) = self.biases();
        let sq = dt.sqrt();
        let (vib_g, vib_a) = e.vibration;
        let (shake_g, shake_a) = if speed > VIBRATION_SPEED && (vib_g > 0.0 || vib_a > 0.0) {
            (normal3(rng) * (vib_g * dt), normal3(rng) * (vib_a * dt))
        } else {
            (Vector3::zeros(), Vector3::zeros())
        };
        let th = shake_g
            + dtheta
            + e.gyro_scale.component_mul(dtheta)
            + bg * dt
            + normal3(rng).component_mul(&e.noise.arw) * sq;
        let dv = shake_a
            + dvel
            + e.accel_scale.component_mul(dvel)
            + ba * dt
            + normal3(rng).component_mul(&e.noise.vrw) * sq;
        match e.noise.bias_model {
            BiasModel::GaussMarkov { tau } | BiasModel::GaussMarkovHeld { tau } if tau > 0.0 => {
                let phi = (-dt / tau).exp();
                let s = (1.0 - phi * phi).sqrt();
                self.bg = self.bg * phi + normal3(rng).component_mul(&e.noise.gyro_bias) * s;
                self.ba = self.ba * phi + normal3(rng).component_mul(&e.noise.accel_bias) * s;
            }
            _ => {
                self.bg += normal3(rng).component_mul(&e.noise.gyro_bias) * sq;
                self.ba += normal3(rng).component_mul(&e.noise.accel_bias) * sq;
            }
        }
        (th, dv)
    }
}

/// What happens to GNSS inside a window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GnssWindowKind {
    /// No epochs.
    Outage,
    /// Noise multiplied by `factor` (the reported σ stays nominal).
    Interference {
        /// Noise factor.
        factor: f64,
    },
    /// With probability `probability`, a jump of `sigmas`·σ (random sign) on each axis.
    Outliers {
        /// Probability per epoch.
        probability: f64,
        /// Size in σ per axis.
        sigmas: f64,
    },
}

/// A time window `[start, end)` of a GNSS effect.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssWindow {
    /// Start, s.
    pub start: f64,
    /// End, s.
    pub end: f64,
    /// The effect.
    pub kind: GnssWindowKind,
}

/// GNSS receiver simulation settings.
#[derive(Clone, Debug, PartialEq)]
pub struct GnssSim {
    /// Output rate, Hz.
    pub rate_hz: f64,
    /// Position noise σ (N, E, D), m.
    pub pos_sigma: Vector3<f64>,
    /// Velocity noise σ, m/s; `None`: position only (7-column files).
    pub vel_sigma: Option<Vector3<f64>>,
    /// Antenna lever arm (FRD), m.
    pub lever_arm: Vector3<f64>,
    /// Outage, interference and outlier windows.
    pub windows: Vec<GnssWindow>,
}

impl GnssSim {
    /// No GNSS at all (rate 0): an IMU-only dataset.
    pub fn none() -> Self {
        Self {
            rate_hz: 0.0,
            pos_sigma: Vector3::zeros(),
            vel_sigma: None,
            lever_arm: Vector3::zeros(),
            windows: Vec::new(),
        }
    }

    /// Noise factor and outlier setting at `t`; `None` during an outage.
    pub fn conditions(&self, t: f64) -> Option<(f64, Option<(f64, f64)>)> {
        let mut factor = 1.0;
        let mut outliers = None;
        for w in &self.windows {
            if t >= w.start && t < w.end {
                match w.kind {
                    GnssWindowKind::Outage => return None,
                    GnssWindowKind::Interference { factor: f } => factor *= f,
                    GnssWindowKind::Outliers { probability, sigmas } => {
                        outliers = Some((probability, sigmas))
                    }
                }
            }
        }
        Some((factor, outliers))
    }

    /// Noisy antenna position for a true antenna position.
    pub fn corrupt_position(
        &self,
        truth: &ins_gnss_core::GeoPos,
        factor: f64,
        outliers: Option<(f64, f64)>,
        rng: &mut StdRng,
    ) -> ins_gnss_core::GeoPos {
        let mut e = normal3(rng).component_mul(&self.pos_sigma) * factor;
        if let Some((p, k)) = outliers
            && rng.random::<f64>() < p
        {
            let signs = Vector3::from_fn(|_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
            e += signs.component_mul(&self.pos_sigma) * k;
        }
        truth.oplus(&e)
    }

    /// Noisy velocity.
    pub fn corrupt_velocity(
        &self,
        truth: &Vector3<f64>,
        sigma: &Vector3<f64>,
        factor: f64,
        rng: &mut StdRng,
    ) -> Vector3<f64> {
        truth + normal3(rng).component_mul(sigma) * factor
    }
}
