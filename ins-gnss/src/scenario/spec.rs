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
    /// A base station this far from the start (north, east, up, m) under the same sky
    /// (`ins_gnss_sim::raw::simulate_rtk`): written as `base.obs`, its position in the
    /// header, and the configuration runs RTK (`gnss.coupling = "rtk"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base: Option<[f64; 3]>,
    /// The base receiver's clock at the start: bias (m) and drift (m/s); default
    /// [−12 km, −0.3 m/s]. A receiver stamps its epochs in its own time; `[0.0, 0.0]`
    /// stamps them on whole milliseconds, as an RTCM 3 stream carries them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_clock: Option<[f64; 2]>,
}

impl RawSpec {
    /// `troposphere` as the simulator's model; the message names the key.
    pub fn true_troposphere(&self) -> Result<gnss::spp::Troposphere, String> {
        use gnss::spp::Troposphere;
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

impl StartSpec {
    /// `[start]`'s checks.
    pub(super) fn validate(&self) -> Result<(), String> {
        finite("start.time", &[self.time])?;
        finite("start.position", &self.position)?;
        if self.position[0].abs() >= 89.9 || self.position[1].abs() > 360.0 {
            return Err(format!(
                "`start.position` latitude {}° / longitude {}°: |latitude| must be below 89.9°",
                self.position[0], self.position[1]
            ));
        }
        if !(-1_000.0..=100_000.0).contains(&self.position[2]) {
            return Err(format!(
                "`start.position` height {} m outside −1 km…+100 km",
                self.position[2]
            ));
        }
        finite("start.speed", &[self.speed])?;
        if !(0.0..=2_000.0).contains(&self.speed) {
            return Err(format!("`start.speed` {} m/s outside 0…2000 m/s", self.speed));
        }
        finite("start.yaw", &[self.yaw])?;
        finite("start.pitch", &[self.pitch])?;
        Ok(())
    }
}

impl ImuSpec {
    /// `[imu]`'s checks.
    pub(super) fn validate(&self) -> Result<(), String> {
        positive("imu.rate", &[self.rate])?;
        if self.rate > 10_000.0 {
            return Err(format!("`imu.rate` {} Hz above the 10 kHz limit", self.rate));
        }
        nonneg("imu.arw", &[self.arw])?;
        nonneg("imu.vrw", &[self.vrw])?;
        nonneg("imu.gyro_bias_std", &[self.gyro_bias_std])?;
        nonneg("imu.accel_bias_std", &[self.accel_bias_std])?;
        positive("imu.corr_time", &[self.corr_time])?;
        finite("imu.gyro_turn_on", &self.gyro_turn_on)?;
        finite("imu.accel_turn_on", &self.accel_turn_on)?;
        finite("imu.gyro_scale_ppm", &self.gyro_scale_ppm)?;
        finite("imu.accel_scale_ppm", &self.accel_scale_ppm)?;
        nonneg("imu.vibration", &self.vibration)?;
        finite("imu.mounting", &self.mounting)?;
        if self.mounting.iter().any(|a| a.abs() > 180.0) {
            return Err(format!(
                "`imu.mounting` {:?}: angles in degrees within ±180",
                self.mounting
            ));
        }
        if let Some([scale, sigma]) = self.odometer {
            finite("imu.odometer", &[scale])?;
            nonneg("imu.odometer", &[sigma])?;
        }
        Ok(())
    }
}

impl RawSpec {
    /// `[raw]`'s checks.
    pub(super) fn validate(&self) -> Result<(), String> {
        positive("raw.rate", &[self.rate])?;
        self.true_troposphere()?;
        if let Some(b) = &self.base {
            finite("raw.base", b)?;
            if nalgebra::Vector3::from(*b).norm() > 100e3 {
                return Err(format!("`raw.base` {b:?} m: a baseline of at most 100 km"));
            }
        }
        if !(0.0..90.0).contains(&self.elevation_mask) {
            return Err(format!("`raw.elevation_mask` {}: degrees in 0…90", self.elevation_mask));
        }
        for (key, p) in [("raw.outliers", self.outliers), ("raw.slips", self.slips)] {
            if !(0.0..=1.0).contains(&p) {
                return Err(format!("`{key}` {p}: a probability in 0…1"));
            }
        }
        for (k, m) in self.masks.iter().enumerate() {
            finite(&format!("raw.masks[{k}]"), m)?;
            if m[1] <= m[0] || m[2] < 0.0 || m[2].fract() != 0.0 {
                return Err(format!(
                    "`raw.masks[{k}]` {m:?}: [start, end, satellites left] with start < end \
                     and a whole number of satellites"
                ));
            }
        }
        Ok(())
    }
}

impl GnssSpec {
    /// `[gnss]`'s checks, its rate against the IMU's (`imu_rate`, Hz).
    pub(super) fn validate(&self, imu_rate: f64) -> Result<(), String> {
        if self.rate > imu_rate {
            return Err(format!("`gnss.rate` {} Hz above `imu.rate` {} Hz", self.rate, imu_rate));
        }
        positive("gnss.position_std", &self.position_std)?;
        if let Some(v) = &self.velocity_std {
            positive("gnss.velocity_std", v)?;
        }
        finite("gnss.lever_arm", &self.lever_arm)?;
        if let Some(h) = &self.heading {
            finite("gnss.heading.baseline", &h.baseline)?;
            let b = nalgebra::Vector3::from(h.baseline);
            if !ins_gnss_core::heading::has_horizontal_direction(&b) {
                return Err(format!(
                    "`gnss.heading.baseline` {:?} m: a baseline with a horizontal direction",
                    h.baseline
                ));
            }
            positive("gnss.heading.std", &[h.std])?;
        }
        if self.lever_arm.iter().any(|v| v.abs() > 100.0) {
            return Err(format!("`gnss.lever_arm` {:?} m beyond the 100 m limit", self.lever_arm));
        }
        for (k, w) in self.windows.iter().enumerate() {
            finite(&format!("gnss.window[{k}].start"), &[w.start])?;
            finite(&format!("gnss.window[{k}].end"), &[w.end])?;
            if w.end <= w.start {
                return Err(format!("`gnss.window[{k}]`: end must be after start"));
            }
            nonneg(&format!("gnss.window[{k}].factor"), &[w.factor])?;
            nonneg(&format!("gnss.window[{k}].sigmas"), &[w.sigmas])?;
            finite(&format!("gnss.window[{k}].probability"), &[w.probability])?;
            if !(0.0..=1.0).contains(&w.probability) {
                return Err(format!("`gnss.window[{k}].probability` must lie in 0…1"));
            }
        }
        Ok(())
    }
}

impl InitSpec {
    /// `[init]`'s checks.
    pub(super) fn validate(&self) -> Result<(), String> {
        positive("init.attitude_std", &self.attitude_std)?;
        positive("init.velocity_std", &self.velocity_std)?;
        positive("init.position_std", &self.position_std)?;
        finite("init.attitude_error", &self.attitude_error)?;
        finite("init.velocity_error", &self.velocity_error)?;
        finite("init.position_error", &self.position_error)?;
        Ok(())
    }
}
