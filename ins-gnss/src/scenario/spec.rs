//! The sections of a scenario file, as `serde` reads them.

use super::*;

/// One motion segment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmentSpec {
    /// `stop`, `straight`, `turn`, `accelerate`, `decelerate`, `climb`.
    pub kind: String,
    /// Duration, s.
    pub duration: f64,
    /// Yaw rate for `turn`, pitch rate for `climb`, deg/s.
    #[serde(default)]
    pub rate: f64,
    /// Acceleration for `accelerate` / deceleration for `decelerate`, m/s² (positive).
    #[serde(default)]
    pub accel: f64,
}

/// Start of the trajectory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartSpec {
    /// Time, s.
    #[serde(default)]
    pub time: f64,
    /// Latitude, longitude (deg), height (m).
    pub position: [f64; 3],
    /// Speed, m/s.
    #[serde(default)]
    pub speed: f64,
    /// Yaw, deg.
    #[serde(default)]
    pub yaw: f64,
    /// Pitch, deg.
    #[serde(default)]
    pub pitch: f64,
}

/// IMU errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuSpec {
    /// Sampling rate, Hz.
    pub rate: f64,
    /// ARW, deg/√h.
    pub arw: f64,
    /// VRW, m/s/√h.
    pub vrw: f64,
    /// Gyro bias instability (Gauss–Markov σ), deg/h.
    pub gyro_bias_std: f64,
    /// Accelerometer bias instability, mGal.
    pub accel_bias_std: f64,
    /// Correlation time, hours.
    pub corr_time: f64,
    /// Constant gyro turn-on bias, deg/h.
    #[serde(default)]
    pub gyro_turn_on: [f64; 3],
    /// Constant accelerometer turn-on bias, mGal.
    #[serde(default)]
    pub accel_turn_on: [f64; 3],
    /// Gyro scale-factor error, ppm.
    #[serde(default)]
    pub gyro_scale_ppm: [f64; 3],
    /// Accelerometer scale-factor error, ppm.
    #[serde(default)]
    pub accel_scale_ppm: [f64; 3],
    /// Vibration while moving: 1σ per sample of the angular rate (deg/s) and the specific
    /// force (m/s²), each axis. Default none.
    #[serde(default)]
    pub vibration: [f64; 2],
    /// The IMU's roll, pitch, yaw relative to the car, degrees (set the same in a run's
    /// `[vehicle.nhc] mounting`). Default 0.
    #[serde(default)]
    pub mounting: [f64; 3],
    /// A wheel odometer in the IMU file's 8th column: `[scale error in ppm, noise σ in
    /// m/s]`. Default none.
    #[serde(default)]
    pub odometer: Option<[f64; 2]>,
}

/// A GNSS window.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindowSpec {
    /// Start, s.
    pub start: f64,
    /// End, s.
    pub end: f64,
    /// `outage`, `interference` or `outliers`.
    pub kind: String,
    /// Noise factor for `interference`.
    #[serde(default)]
    pub factor: f64,
    /// Probability per epoch for `outliers`.
    #[serde(default)]
    pub probability: f64,
    /// Outlier size in σ per axis.
    #[serde(default)]
    pub sigmas: f64,
}

/// GNSS receiver.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssSpec {
    /// Rate, Hz.
    pub rate: f64,
    /// Position σ (N, E, D), m.
    pub position_std: [f64; 3],
    /// Velocity σ, m/s (absent: position-only 7-column file).
    #[serde(default)]
    pub velocity_std: Option<[f64; 3]>,
    /// Lever arm (FRD), m.
    #[serde(default)]
    pub lever_arm: [f64; 3],
    /// Windows.
    #[serde(default, rename = "window")]
    pub windows: Vec<WindowSpec>,
    /// A moving-base receiver's heading at every fix ([`HeadingSpec`]), written to
    /// `HEADING.txt`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heading: Option<HeadingSpec>,
}

/// `[gnss.heading]` of a scenario: two antennas.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadingSpec {
    /// The baseline from the moving base's antenna to the rover's (FRD), m.
    pub baseline: [f64; 3],
    /// The heading's white noise and stated σ, deg (the elevation's twice this).
    pub std: f64,
}

/// The initial uncertainty written into the generated configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitSpec {
    /// Attitude 1σ, deg.
    pub attitude_std: [f64; 3],
    /// Velocity 1σ, m/s.
    pub velocity_std: [f64; 3],
    /// Position 1σ, m.
    pub position_std: [f64; 3],
    /// Errors actually added to the initial state given to the filter: attitude (deg),
    /// velocity (m/s), position (m).
    #[serde(default)]
    pub attitude_error: [f64; 3],
    /// Initial velocity error, m/s.
    #[serde(default)]
    pub velocity_error: [f64; 3],
    /// Initial position error (N, E, D), m.
    #[serde(default)]
    pub position_error: [f64; 3],
}

/// `[raw]`: satellites from a real navigation file, with the receiver the single point
/// assumes ([`ins_gnss_sim::raw::RawSim::spp_budget`]): URA-sized orbit errors, half the
/// Klobuchar delay, 0.3 m code bias per satellite, 1 Hz, 10° mask.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSpec {
    /// RINEX navigation file (relative to the scenario file); copied into the dataset.
    pub nav: PathBuf,
    /// GPS week of `start.time`, which is read as GPS seconds of that week (the
    /// ephemerides must cover the span).
    pub week: i32,
    /// Observation rate, Hz. Default 1.
    #[serde(default = "one")]
    pub rate: f64,
    /// Probability per satellite and epoch of a multipath outlier of 20–100 m on the code.
    #[serde(default)]
    pub outliers: f64,
    /// Satellites below this elevation are not tracked, degrees. Default 10.
    #[serde(default = "ten")]
    pub elevation_mask: f64,
    /// How the true troposphere maps Saastamoinen's zenith delays to a satellite:
    /// `saastamoinen` (default; 1/sin(el), as the single point's default model does) or
    /// `niell` (Niell's functions: a truth the default model misses at low elevation).
    #[serde(default = "default_truth_tropo")]
    pub troposphere: String,
    /// Sky masks: `[start, end, satellites left]` (s from `start.time`; 0 is a tunnel).
    #[serde(default)]
    pub masks: Vec<[f64; 3]>,
    /// Draw the satellites' orbit, code-bias and atmosphere errors afresh at every epoch
    /// (white, as the filter's model assumes) instead of once per satellite and run.
    #[serde(default)]
    pub white_errors: bool,
    /// Probability per satellite and epoch of a cycle slip of 1–49 cycles.
    #[serde(default)]
    pub slips: f64,
    /// Whether the receiver flags its slips (loss of lock). Default true.
    #[serde(default = "yes")]
    pub flag_slips: bool,
}

impl RawSpec {
    /// `troposphere` as the simulator's model; the message names the key.
    pub fn true_troposphere(&self) -> Result<ins_gnss_core::raw::spp::Troposphere, String> {
        use ins_gnss_core::raw::spp::Troposphere;
        // (the truth has a troposphere: `off` is not one)
        Troposphere::from_name(&self.troposphere).filter(|t| *t != Troposphere::Off).ok_or_else(
            || format!("`raw.troposphere = \"{}\"`: saastamoinen or niell", self.troposphere),
        )
    }
}

fn ten() -> f64 {
    10.0
}

fn default_truth_tropo() -> String {
    "saastamoinen".into()
}

fn yes() -> bool {
    true
}

fn one() -> f64 {
    1.0
}
