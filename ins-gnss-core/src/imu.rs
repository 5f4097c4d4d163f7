//! IMU data and error specifications.
//!
//! Newtypes keep angular and velocity increments from being swapped; units are SI inside
//! (rad, m/s, s). Datasheet units (deg/√h, m/s/√h, deg/h, mGal, hours) are converted at
//! the boundary by [`ImuNoise::from_datasheet`].

use nalgebra::Vector3;

/// One IMU sample: increments over `(t − dt, t]` in the body frame (FRD).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// End of the interval, s.
    pub t: f64,
    /// Length of the interval, s.
    pub dt: f64,
    /// Angular increment `∫ ω_ib^b dt`, rad.
    pub dtheta: Vector3<f64>,
    /// Velocity increment `∫ f^b dt`, m/s.
    pub dvel: Vector3<f64>,
    /// The vehicle's odometer (wheel) speed at `t`, m/s, when the log has one (KF-GINS's
    /// optional 8th IMU column).
    pub odometer: Option<f64>,
}

impl ImuSample {
    /// From increments.
    pub fn from_increments(t: f64, dt: f64, dtheta: Vector3<f64>, dvel: Vector3<f64>) -> Self {
        Self { t, dt, dtheta, dvel, odometer: None }
    }

    /// From rates (rad/s, m/s²) held over the interval (trapezoid of the previous and
    /// current rates when `previous` is given, rectangle otherwise). The rate-type reader
    /// uses it where a higher-order rule has too few regular samples (see
    /// `ins_gnss_io::ImuReader`).
    pub fn from_rates(
        t: f64,
        dt: f64,
        gyro: Vector3<f64>,
        accel: Vector3<f64>,
        previous: Option<(Vector3<f64>, Vector3<f64>)>,
    ) -> Self {
        let (w, f) = match previous {
            Some((w0, f0)) => ((gyro + w0) * 0.5, (accel + f0) * 0.5),
            None => (gyro, accel),
        };
        Self { t, dt, dtheta: w * dt, dvel: f * dt, odometer: None }
    }

    /// The combined sample of a stretch of samples that opens with this one, before any
    /// is added ([`add_to_stretch`](Self::add_to_stretch)): nothing integrated yet.
    pub fn stretch_opening(&self) -> Self {
        ImuSample { dt: 0.0, dtheta: Vector3::zeros(), dvel: Vector3::zeros(), ..*self }
    }

    /// Add sample `s` to this combined sample of a stretch: the interval `Σ dt_k`, the
    /// angle `Σ Δθ_k` and the velocity increment `Σ (I + [θ_{<k}]×) Δv_k` (each sample's
    /// `Δv` turned into the stretch's first body frame by the angle turned before it, to
    /// first order), ending at `s`'s time. A covariance propagated at a lower rate than
    /// the state takes one step over it (`Navigator::with_covariance_interval`), and so
    /// does the smoother's backward pass ([`ProcessModel::fold_input`]).
    ///
    /// [`ProcessModel::fold_input`]: estimator_core::ProcessModel::fold_input
    pub fn add_to_stretch(&mut self, s: &ImuSample) {
        self.dvel += s.dvel + self.dtheta.cross(&s.dvel);
        self.dtheta += s.dtheta;
        self.dt += s.dt;
        self.t = s.t;
    }

    /// Mean angular rate over the interval, rad/s.
    pub fn rate(&self) -> Vector3<f64> {
        self.dtheta / self.dt
    }

    /// Mean specific force over the interval, m/s².
    pub fn specific_force(&self) -> Vector3<f64> {
        self.dvel / self.dt
    }

    /// Split at `t_split ∈ (t − dt, t)`: the first part ends at `t_split`, the second at
    /// `t`; increments are shared linearly (the exact split of a constant-rate interval).
    pub fn split(&self, t_split: f64) -> (ImuSample, ImuSample) {
        let t0 = self.t - self.dt;
        let a = ((t_split - t0) / self.dt).clamp(0.0, 1.0);
        let first = ImuSample {
            t: t_split,
            dt: self.dt * a,
            dtheta: self.dtheta * a,
            dvel: self.dvel * a,
            odometer: None,
        };
        let second = ImuSample {
            t: self.t,
            dt: self.dt * (1.0 - a),
            dtheta: self.dtheta * (1.0 - a),
            dvel: self.dvel * (1.0 - a),
            odometer: self.odometer,
        };
        (first, second)
    }
}

/// How the IMU biases evolve, in the filter (and in the simulator).
///
/// Which one fits depends on the sensor: a bias with a large constant (turn-on) part is
/// better served by [`RandomWalk`](BiasModel::RandomWalk), whose covariance does not
/// forget what the filter has learnt. On the navego ADIS16488 data (`ins-gnss run
/// kf-gins-ADIS16488.yaml`, GNSS position only, skip 60 s) we measured horizontal RMS
/// 1.433 m (random walk), 1.571 m (Gauss–Markov, estimate held: KF-GINS's behaviour and
/// figure) and 1.950 m (Gauss–Markov with the estimate decaying).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BiasModel {
    /// First-order Gauss–Markov with correlation time τ (s): `ḃ = −b/τ + w`,
    /// `E[w²] = 2σ²/τ`, σ the steady-state (bias instability) figure. The estimate
    /// decays with τ between updates, as the model says.
    GaussMarkov {
        /// Correlation time, s.
        tau: f64,
    },
    /// Gauss–Markov covariance (`F = −1/τ`, same noise) but the estimate is held
    /// between updates, as KF-GINS does.
    GaussMarkovHeld {
        /// Correlation time, s.
        tau: f64,
    },
    /// Random walk `ḃ = w` with `E[w²] = σ²` per second (σ in units/√s); the estimate is
    /// held between updates.
    RandomWalk,
}

/// IMU noise and bias specification, SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuNoise {
    /// Angular random walk, rad/√s (per axis).
    pub arw: Vector3<f64>,
    /// Velocity random walk, m/s/√s (per axis).
    pub vrw: Vector3<f64>,
    /// Gyro bias σ: steady-state for Gauss–Markov (rad/s), density for random walk (rad/s/√s).
    pub gyro_bias: Vector3<f64>,
    /// Accelerometer bias σ: steady-state (m/s²) or density (m/s²/√s).
    pub accel_bias: Vector3<f64>,
    /// Bias dynamics.
    pub bias_model: BiasModel,
}

/// deg/√h → rad/√s.
pub const DEG_PER_SQRT_H: f64 = core::f64::consts::PI / 180.0 / 60.0;
/// m/s/√h → m/s/√s.
pub const M_S_PER_SQRT_H: f64 = 1.0 / 60.0;
/// deg/h → rad/s.
pub const DEG_PER_H: f64 = core::f64::consts::PI / 180.0 / 3600.0;
/// mGal → m/s².
pub const MGAL: f64 = 1e-5;

impl ImuNoise {
    /// From datasheet units, as in KF-GINS configurations: ARW deg/√h, VRW m/s/√h,
    /// bias instabilities deg/h and mGal, Gauss–Markov correlation time in hours
    /// (a [`BiasModel::GaussMarkov`] model; see [`with_bias_model`](Self::with_bias_model)).
    pub fn from_datasheet(
        arw_deg_sqrt_h: Vector3<f64>,
        vrw_m_s_sqrt_h: Vector3<f64>,
        gyro_bias_deg_h: Vector3<f64>,
        accel_bias_mgal: Vector3<f64>,
        corr_time_h: f64,
    ) -> Self {
        Self {
            arw: arw_deg_sqrt_h * DEG_PER_SQRT_H,
            vrw: vrw_m_s_sqrt_h * M_S_PER_SQRT_H,
            gyro_bias: gyro_bias_deg_h * DEG_PER_H,
            accel_bias: accel_bias_mgal * MGAL,
            bias_model: BiasModel::GaussMarkov { tau: corr_time_h * 3600.0 },
        }
    }

    /// The same instability σ and correlation time τ under another bias model; for
    /// [`BiasModel::RandomWalk`] the density is the Gauss–Markov driving noise,
    /// `σ √(2/τ)`.
    pub fn with_bias_model(mut self, model: BiasModel) -> Self {
        let tau = match self.bias_model {
            BiasModel::GaussMarkov { tau } | BiasModel::GaussMarkovHeld { tau } => tau,
            BiasModel::RandomWalk => {
                self.bias_model = model;
                return self;
            }
        };
        if let BiasModel::RandomWalk = model {
            let k = (2.0 / tau).sqrt();
            self.gyro_bias *= k;
            self.accel_bias *= k;
        }
        self.bias_model = model;
        self
    }

    /// Power spectral densities of the bias driving noise `(gyro, accel)`.
    pub fn bias_psd(&self) -> (Vector3<f64>, Vector3<f64>) {
        match self.bias_model {
            BiasModel::GaussMarkov { tau } | BiasModel::GaussMarkovHeld { tau } => (
                self.gyro_bias.map(|s| 2.0 * s * s / tau),
                self.accel_bias.map(|s| 2.0 * s * s / tau),
            ),
            BiasModel::RandomWalk => {
                (self.gyro_bias.map(|s| s * s), self.accel_bias.map(|s| s * s))
            }
        }
    }

    /// `1/τ` of the bias model (0 for a random walk).
    pub fn inverse_tau(&self) -> f64 {
        match self.bias_model {
            BiasModel::GaussMarkov { tau } | BiasModel::GaussMarkovHeld { tau }
                if tau > 0.0 && tau.is_finite() =>
            {
                1.0 / tau
            }
            _ => 0.0,
        }
    }
}
