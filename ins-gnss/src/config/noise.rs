//! `[imu_noise]`: the IMU's noise in datasheet units.

use super::*;

/// IMU noise, datasheet units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSection {
    /// Angular random walk, deg/√h (required unless `from_static`).
    #[serde(default)]
    pub arw: [f64; 3],
    /// Velocity random walk, m/s/√h (required unless `from_static`).
    #[serde(default)]
    pub vrw: [f64; 3],
    /// Measure ARW and VRW per axis on the static start (σ of the rates and specific
    /// forces times √dt; vibration at rest included) instead of `arw` and `vrw`; the run
    /// stops when the IMU does not show the start still for `align.min_static` seconds
    /// (a span the IMU shows still counts even when the fixes drift over it: no zero
    /// velocity or gyro bias is taken from it then, but its noise is the IMU's).
    #[serde(default)]
    pub from_static: bool,
    /// Raise `arw` / `vrw` on an axis where the static start, or the span the IMU shows
    /// still while the fixes drift (at least `align.min_static` seconds), shows the IMU
    /// 1.5× noisier at rest than declared: a filter told of less noise than the sensor
    /// has at rest is overconfident
    /// (on drive-0708 with KF-GINS's generic figures the innovations are 4.5× their σ and
    /// the 21-state filter diverges). Reported in the run summary. Default true; `false`
    /// keeps the declared noise whatever the data show.
    #[serde(default = "yes")]
    pub static_floor: bool,
    /// Gyro bias instability (Gauss–Markov σ), deg/h; with `corr_time`. Or give the
    /// bias random walk (`gyro_bias_rw` or `gyro_bias_rw_si`) instead.
    #[serde(default)]
    pub gyro_bias_std: Option<[f64; 3]>,
    /// Accelerometer bias instability, mGal; or `accel_bias_rw` / `accel_bias_rw_si`.
    #[serde(default)]
    pub accel_bias_std: Option<[f64; 3]>,
    /// Gauss–Markov correlation time of the instabilities, hours.
    #[serde(default)]
    pub corr_time: Option<f64>,
    /// Gyro bias random walk (the density of its driving noise), deg/h/√h, instead of
    /// `gyro_bias_std` and `corr_time` (`bias_model = "random-walk"`).
    #[serde(default)]
    pub gyro_bias_rw: Option<[f64; 3]>,
    /// The same in rad/s/√s.
    #[serde(default)]
    pub gyro_bias_rw_si: Option<[f64; 3]>,
    /// Accelerometer bias random walk, mGal/√h.
    #[serde(default)]
    pub accel_bias_rw: Option<[f64; 3]>,
    /// The same in m/s²/√s.
    #[serde(default)]
    pub accel_bias_rw_si: Option<[f64; 3]>,
    /// Gyro scale-factor instability (Gauss–Markov σ with `corr_time`), ppm (21 states).
    /// Default 1000.
    #[serde(default = "default_scale_std")]
    pub gyro_scale_std: [f64; 3],
    /// Accelerometer scale-factor instability, ppm (21 states). Default 1000.
    #[serde(default = "default_scale_std")]
    pub accel_scale_std: [f64; 3],
    /// How the filter models the biases: `random-walk` (default; density `σ √(2/τ)`),
    /// `gauss-markov`, or `gauss-markov-held` (KF-GINS's behaviour). See
    /// [`BiasModel`] for the measured difference.
    #[serde(default)]
    pub bias_model: BiasModelName,
}

/// Bias-model names in configs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BiasModelName {
    /// Random walk driven by the Gauss–Markov noise density.
    #[default]
    RandomWalk,
    /// Gauss–Markov, estimate decaying.
    GaussMarkov,
    /// Gauss–Markov covariance, estimate held (KF-GINS).
    GaussMarkovHeld,
}

impl core::str::FromStr for BiasModelName {
    type Err = String;

    /// The configuration's names: `random-walk`, `gauss-markov`, `gauss-markov-held`.
    fn from_str(name: &str) -> Result<Self, String> {
        match name {
            "random-walk" => Ok(Self::RandomWalk),
            "gauss-markov" => Ok(Self::GaussMarkov),
            "gauss-markov-held" => Ok(Self::GaussMarkovHeld),
            _ => Err(format!(
                "unknown bias model `{name}`: random-walk, gauss-markov, gauss-markov-held"
            )),
        }
    }
}
