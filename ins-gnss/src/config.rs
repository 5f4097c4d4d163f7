//! Run configuration: our TOML format (documented in `ins-gnss/config.example.toml`)
//! and KF-GINS YAML configurations, accepted as they are. Paths are relative to the
//! configuration file. Units at this boundary are the datasheet ones (degrees, deg/h,
//! mGal, deg/√h, m/s/√h, hours); everything is converted to SI when the filter is built.

use core::fmt;
use std::path::{Path, PathBuf};

use manifolds::So3;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

pub use crate::columns::{GnssColumns, ImuColumns, TruthColumns};

use crate::checks::{finite, nonneg, positive};
use ins_gnss_core::gnss::GNSS_STREAMS;
use ins_gnss_core::imu::{BiasModel, ImuNoise, DEG_PER_H, MGAL};
use ins_gnss_core::io::{BadLinePolicy, ImuFormat};
use ins_gnss_core::mechanization::Mechanization;
use ins_gnss_core::navigator::{GnssConfig, InitialState, InitialStd, ScaleInit};
use ins_gnss_core::position::GeoPos;
use ins_gnss_core::scale::ScaleFactorNoise;
use ins_gnss_core::state::InsState;
use ins_gnss_core::vehicle::{
    DetectorConfig, NhcConfig, OdometerConfig, VehicleAiding, ZuptConfig, VEHICLE_STREAMS,
};

/// Every measurement stream a configuration may name in `filter.streams`.
pub const STREAMS: [estimator_core::StreamId; 7] = [
    GNSS_STREAMS[0],
    GNSS_STREAMS[1],
    GNSS_STREAMS[2],
    VEHICLE_STREAMS[0],
    VEHICLE_STREAMS[1],
    VEHICLE_STREAMS[2],
    VEHICLE_STREAMS[3],
];

/// A configuration that cannot be used, with the file and the key.
#[derive(Clone, Debug, PartialEq)]
pub struct ConfigError {
    /// The configuration file.
    pub path: PathBuf,
    /// What is wrong (names the key).
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.message)
    }
}

impl std::error::Error for ConfigError {}

/// Input files and their timing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataSection {
    /// IMU file.
    pub imu: PathBuf,
    /// GNSS file (7 or 13 columns).
    pub gnss: PathBuf,
    /// Output directory. Default `out`.
    #[serde(default = "default_output")]
    pub output: PathBuf,
    /// IMU sampling rate, Hz.
    pub imu_rate: f64,
    /// `increments` (default) or `rates`.
    #[serde(default)]
    pub imu_format: ImuFormatName,
    /// Time of the initial state, s (default: the first IMU sample).
    #[serde(default)]
    pub start_time: Option<f64>,
    /// Last time to process, s (default: the end of the IMU file).
    #[serde(default)]
    pub end_time: Option<f64>,
    /// `error` (default) or `skip`: what to do with malformed lines.
    #[serde(default)]
    pub bad_lines: PolicyName,
    /// Largest IMU gap, in IMU intervals. Default 5. A longer gap is an error, or with
    /// `bad_lines = "skip"` bridged in one step up to `max_bridge`.
    #[serde(default = "default_max_gap")]
    pub max_gap: f64,
    /// Largest gap that `bad_lines = "skip"` bridges, in IMU intervals. Default 20; a
    /// longer gap is an error naming the lines on both sides.
    #[serde(default = "default_max_bridge")]
    pub max_bridge: f64,
    /// Seconds added to every IMU time stamp, so that the IMU and the GNSS share one
    /// clock (an IMU stamped 0.3 s late: `-0.3`). Default 0. The start's checks compare
    /// the gyro's turns with the GNSS course and name a clear offset with this key.
    #[serde(default)]
    pub imu_time_offset: f64,
    /// A truth file for evaluation (11 columns, 4-column positions, or a log with a
    /// header read through `truth_columns`), optional.
    #[serde(default)]
    pub truth: Option<PathBuf>,
    /// The IMU file is a log with a header: which column holds what
    /// ([`ImuColumns`]; `[data.imu_columns]` alone is the default map).
    #[serde(default)]
    pub imu_columns: Option<ImuColumns>,
    /// The GNSS file is a log with a header ([`GnssColumns`]).
    #[serde(default)]
    pub gnss_columns: Option<GnssColumns>,
    /// `auto` (default: an RTKLIB solution when its header says so, NMEA when the lines
    /// start with `$`, else the 7/13-column format), `columns`, `rtklib` (a `.pos` file)
    /// or `nmea`; `[gnss.quality]` scales the σ of the last two by solution quality.
    #[serde(default)]
    pub gnss_format: GnssFormatName,
    /// The truth file is a log with a header ([`TruthColumns`]).
    #[serde(default)]
    pub truth_columns: Option<TruthColumns>,
    /// Broadcast ephemerides for `gnss.coupling = "tight"`: RINEX navigation files
    /// (merged). A u-blox log brings its own GPS ephemerides; a RINEX observation file
    /// needs these.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nav: Vec<PathBuf>,
}

fn default_output() -> PathBuf {
    PathBuf::from("out")
}
fn default_max_gap() -> f64 {
    5.0
}
fn default_max_bridge() -> f64 {
    ins_gnss_core::io::formats::DEFAULT_MAX_BRIDGE
}

/// IMU format names in configs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ImuFormatName {
    /// Increments.
    #[default]
    Increments,
    /// Rates (CSV with header).
    Rates,
}

/// GNSS file layouts in configs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GnssFormatName {
    /// Detected from the header.
    #[default]
    Auto,
    /// The 7/13-column format or a column-mapped log.
    Columns,
    /// An RTKLIB solution file.
    Rtklib,
    /// NMEA 0183 (GGA, GST, RMC/ZDA).
    Nmea,
}

impl From<GnssFormatName> for ins_gnss_core::io::GnssFormat {
    fn from(f: GnssFormatName) -> Self {
        match f {
            GnssFormatName::Auto => Self::Auto,
            GnssFormatName::Columns => Self::Columns,
            GnssFormatName::Rtklib => Self::Rtklib,
            GnssFormatName::Nmea => Self::Nmea,
        }
    }
}

/// `[gnss.quality]`: σ factors of RTKLIB solutions by quality flag `Q`, and the qualities
/// whose epochs are dropped.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QualitySection {
    /// σ factor for fixed solutions (Q = 1). Default 1.
    #[serde(default = "q_fix")]
    pub fix: f64,
    /// Float (Q = 2). Default 2.
    #[serde(default = "q_float")]
    pub float: f64,
    /// SBAS (Q = 3). Default 5.
    #[serde(default = "q_single")]
    pub sbas: f64,
    /// DGPS (Q = 4). Default 3.
    #[serde(default = "q_dgps")]
    pub dgps: f64,
    /// Single point (Q = 5). Default 5.
    #[serde(default = "q_single")]
    pub single: f64,
    /// PPP (Q = 6). Default 2.
    #[serde(default = "q_float")]
    pub ppp: f64,
    /// Qualities dropped: any of `fix`, `float`, `sbas`, `dgps`, `single`, `ppp`.
    #[serde(default)]
    pub drop: Vec<String>,
}

fn q_fix() -> f64 {
    1.0
}
fn q_float() -> f64 {
    2.0
}
fn q_dgps() -> f64 {
    3.0
}
fn q_single() -> f64 {
    5.0
}

impl Default for QualitySection {
    fn default() -> Self {
        Self {
            fix: q_fix(),
            float: q_float(),
            sbas: q_single(),
            dgps: q_dgps(),
            single: q_single(),
            ppp: q_float(),
            drop: Vec::new(),
        }
    }
}

impl QualitySection {
    /// The reader's factors, or the key that is wrong.
    pub fn factors(&self) -> Result<ins_gnss_core::io::rtklib::QualityFactors, String> {
        use ins_gnss_core::io::rtklib::QUALITY_NAMES;
        let f = [1.0, self.fix, self.float, self.sbas, self.dgps, self.single, self.ppp];
        for (name, v) in QUALITY_NAMES.iter().zip(f).skip(1) {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("`gnss.quality.{name}` = {v}: a σ factor must be positive"));
            }
        }
        let mut drop = [false; 7];
        for d in &self.drop {
            match QUALITY_NAMES.iter().position(|n| n == d).filter(|&i| i > 0) {
                Some(i) => drop[i] = true,
                None => {
                    return Err(format!(
                        "`gnss.quality.drop`: unknown quality `{d}` (fix, float, sbas, dgps, \
                         single, ppp)"
                    ))
                }
            }
        }
        Ok(ins_gnss_core::io::rtklib::QualityFactors { factor: f, drop })
    }
}

/// Bad-line policy names in configs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PolicyName {
    /// Stop at the first malformed line.
    #[default]
    Error,
    /// Skip and count.
    Skip,
}

/// Initial state and its 1σ, datasheet units. Every key is optional: what is not given
/// is found from the data before the run starts (see [`crate::start`]): position and
/// velocity from the first GNSS fixes, roll and pitch by levelling over a static start or
/// by the in-motion alignment, heading by the in-motion alignment, the gyro biases from a
/// static start. Given values always win.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitSection {
    /// Latitude, longitude (deg), height (m).
    #[serde(default)]
    pub position: Option<[f64; 3]>,
    /// NED velocity, m/s.
    #[serde(default)]
    pub velocity: Option<[f64; 3]>,
    /// Roll, pitch, yaw, deg.
    #[serde(default)]
    pub attitude: Option<[f64; 3]>,
    /// Gyro bias, deg/h (from the static start when there is one, else 0).
    #[serde(default)]
    pub gyro_bias: Option<[f64; 3]>,
    /// Accelerometer bias, mGal. Default 0.
    #[serde(default)]
    pub accel_bias: Option<[f64; 3]>,
    /// Position 1σ (N, E, D), m.
    #[serde(default)]
    pub position_std: Option<[f64; 3]>,
    /// Velocity 1σ, m/s.
    #[serde(default)]
    pub velocity_std: Option<[f64; 3]>,
    /// Attitude 1σ, deg.
    #[serde(default)]
    pub attitude_std: Option<[f64; 3]>,
    /// Gyro bias 1σ, deg/h.
    #[serde(default)]
    pub gyro_bias_std: Option<[f64; 3]>,
    /// Accelerometer bias 1σ, mGal (default 20,000: a consumer MEMS turn-on bias).
    #[serde(default)]
    pub accel_bias_std: Option<[f64; 3]>,
    /// Gyro scale factors, ppm (21 states). Default 0.
    #[serde(default)]
    pub gyro_scale: [f64; 3],
    /// Accelerometer scale factors, ppm (21 states). Default 0.
    #[serde(default)]
    pub accel_scale: [f64; 3],
    /// Gyro scale-factor 1σ, ppm (21 states). Default 1000.
    #[serde(default = "default_scale_std")]
    pub gyro_scale_std: [f64; 3],
    /// Accelerometer scale-factor 1σ, ppm (21 states). Default 1000.
    #[serde(default = "default_scale_std")]
    pub accel_scale_std: [f64; 3],
}

impl Default for InitSection {
    fn default() -> Self {
        toml::from_str("").expect("every key of [init] has a default")
    }
}

impl InitSection {
    /// Every part of the initial state given (nothing to find from the data).
    pub fn is_complete(&self) -> bool {
        self.position.is_some()
            && self.velocity.is_some()
            && self.attitude.is_some()
            && self.position_std.is_some()
            && self.velocity_std.is_some()
            && self.attitude_std.is_some()
            && self.gyro_bias_std.is_some()
    }
}

/// `[imu]`: how the IMU is mounted.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuSection {
    /// The sensor's axes in the body (vehicle) frame, FRD: an axis map
    /// (`["-y", "-x", "-z"]`: body x is the sensor's −y, …), the sensor's roll, pitch, yaw
    /// relative to the body in degrees (`[180.0, 0.0, -90.0]`, the same mounting), or the
    /// sensor-to-body matrix `C_bs` (rows). Applied to every sample as it is read (after
    /// a column map's `axes`); the filter, the lever arms, NHC and the odometer then work
    /// in the body frame. A left-handed map is refused. Default: the sensor axes are the
    /// body's.
    #[serde(default)]
    pub mounting: Option<Mounting>,
}

/// A sensor mounting as the configuration states it ([`ImuSection::mounting`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    untagged,
    expecting = "a mounting: an axis map such as [\"-y\", \"-x\", \"-z\"], three angles \
                 [roll, pitch, yaw] in degrees, or a 3×3 matrix [[…], […], […]]"
)]
pub enum Mounting {
    /// Body x, y, z as signed sensor axes: `["-y", "-x", "-z"]`.
    Axes([String; 3]),
    /// Roll, pitch, yaw of the sensor relative to the body, degrees.
    Angles([f64; 3]),
    /// `C_bs`, row by row.
    Matrix([[f64; 3]; 3]),
}

impl Mounting {
    /// `C_bs` (sensor → body), checked to be a proper rotation. The error names what is
    /// wrong (the caller names the key).
    pub fn matrix(&self) -> Result<Matrix3<f64>, String> {
        let c = match self {
            Mounting::Axes(axes) => {
                let mut c = Matrix3::zeros();
                let mut seen = [false; 3];
                for (row, a) in axes.iter().enumerate() {
                    let a = a.trim().to_ascii_lowercase();
                    let (sign, name) = match a.strip_prefix('-') {
                        Some(n) => (-1.0, n),
                        None => (1.0, a.strip_prefix('+').unwrap_or(&a)),
                    };
                    let col = match name {
                        "x" => 0,
                        "y" => 1,
                        "z" => 2,
                        _ => {
                            return Err(format!(
                                "axis `{a}`: each entry is a sensor axis `x`, `y` or `z`, with a \
                                 sign if reversed (`-y`)"
                            ))
                        }
                    };
                    if seen[col] {
                        return Err(format!("sensor axis `{name}` named twice in {axes:?}"));
                    }
                    seen[col] = true;
                    c[(row, col)] = sign;
                }
                c
            }
            Mounting::Angles(a) => {
                finite("angles", a)?;
                if a.iter().any(|v| v.abs() > 360.0) {
                    return Err(format!("angles {a:?}: degrees within ±360"));
                }
                let d = core::f64::consts::PI / 180.0;
                So3::from_euler(a[0] * d, a[1] * d, a[2] * d).matrix()
            }
            Mounting::Matrix(m) => {
                let c = Matrix3::from_fn(|i, j| m[i][j]);
                finite("matrix", c.as_slice())?;
                let err = (c * c.transpose() - Matrix3::identity()).abs().max();
                if err > 1e-6 {
                    return Err(format!(
                        "the matrix is not a rotation (C Cᵀ differs from I by {err:.2e})"
                    ));
                }
                c
            }
        };
        if c.determinant() < 0.0 {
            return Err(format!(
                "{self:?} is left-handed (a mirror image, determinant −1): no rotation mounts \
                 a sensor so; one axis sign or one swap too many"
            ));
        }
        Ok(c)
    }
}

/// `[align]`: how the missing parts of `[init]` are found from the data, and the checks of
/// units and axes against the data.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlignSection {
    /// Window of the static-start detector, s. Default 1.
    #[serde(default = "one")]
    pub static_window: f64,
    /// Shortest static start used for levelling and gyro biases, s. Default 5.
    #[serde(default = "default_min_static")]
    pub min_static: f64,
    /// Longest span of data the in-motion alignment may use, s, counted from the end of
    /// a static start (of up to [`crate::start::STATIC_ALLOWANCE`] s), else from the
    /// start. Default 120.
    #[serde(default = "default_align_time")]
    pub max_time: f64,
    /// The alignment stops once its heading 1σ is below this, deg. Default 1.
    #[serde(default = "one")]
    pub heading_std: f64,
    /// Check units, axes and times against the data before the run (default true).
    #[serde(default = "yes")]
    pub checks: bool,
}

fn one() -> f64 {
    1.0
}
fn default_min_static() -> f64 {
    5.0
}
fn default_align_time() -> f64 {
    120.0
}

impl Default for AlignSection {
    fn default() -> Self {
        toml::from_str("").expect("every key of [align] has a default")
    }
}

fn default_scale_std() -> [f64; 3] {
    [1000.0; 3]
}

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
    /// stops when the start is not static for `align.min_static` seconds.
    #[serde(default)]
    pub from_static: bool,
    /// Raise `arw` / `vrw` on an axis where the static start (at least `align.min_static`
    /// seconds) shows the IMU [`crate::start::FLOOR_FACTOR`]× noisier at rest than
    /// declared: a filter told of less noise than the sensor has at rest is overconfident
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

/// GNSS use.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssSection {
    /// Antenna lever arm in the body frame (FRD), m.
    #[serde(default)]
    pub lever_arm: [f64; 3],
    /// Use the velocity columns of 13-column files. Default true.
    #[serde(default = "yes")]
    pub use_velocity: bool,
    /// Replace the file's position σ (N, E, D), m.
    #[serde(default)]
    pub position_std: Option<[f64; 3]>,
    /// Replace the file's velocity σ, m/s.
    #[serde(default)]
    pub velocity_std: Option<[f64; 3]>,
    /// RTKLIB solutions: σ factor per quality, qualities dropped.
    #[serde(default)]
    pub quality: QualitySection,
    /// `loose` (default: `data.gnss` holds a receiver's fixes) or `tight` (`data.gnss` is
    /// a RINEX observation file or a u-blox log, with `data.nav`: each satellite's
    /// pseudorange and Doppler update the filter).
    #[serde(default, skip_serializing_if = "Coupling::is_loose")]
    pub coupling: Coupling,
    /// Tight coupling's models ([`TightSection`]).
    #[serde(default, skip_serializing_if = "TightSection::is_default")]
    pub tight: TightSection,
}

/// How the GNSS aids the filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Coupling {
    /// A receiver's position (and velocity) fixes.
    #[default]
    Loose,
    /// Raw observations: one update per satellite.
    Tight,
}

impl Coupling {
    fn is_loose(&self) -> bool {
        *self == Coupling::Loose
    }
}

/// `[gnss.tight]`: the satellite models of tight coupling (and of the single points the
/// start's checks and alignment use).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TightSection {
    /// Elevation mask, degrees. Default 15.
    #[serde(default = "default_elevation_mask")]
    pub elevation_mask: f64,
    /// `klobuchar` (default, the broadcast model), `iono-free` (two frequencies; a
    /// satellite with one is not used) or `off`.
    #[serde(default = "default_iono")]
    pub ionosphere: String,
    /// `saastamoinen` (default) or `off`.
    #[serde(default = "default_tropo")]
    pub troposphere: String,
    /// Use the Dopplers (range rates) as well as the codes. Default true.
    #[serde(default = "yes")]
    pub doppler: bool,
    /// σ of a Doppler's range rate, m/s. Default 0.1.
    #[serde(default = "default_doppler_std")]
    pub doppler_std: f64,
    /// Random walk of the receiver clock's drift, m/s/√s. Default 0.1 (a TCXO).
    #[serde(default = "default_clock_drift_noise")]
    pub clock_drift_noise: f64,
}

fn default_elevation_mask() -> f64 {
    15.0
}
fn default_iono() -> String {
    "klobuchar".into()
}
fn default_tropo() -> String {
    "saastamoinen".into()
}
fn default_doppler_std() -> f64 {
    0.1
}
fn default_clock_drift_noise() -> f64 {
    0.1
}

impl Default for TightSection {
    fn default() -> Self {
        Self {
            elevation_mask: default_elevation_mask(),
            ionosphere: default_iono(),
            troposphere: default_tropo(),
            doppler: true,
            doppler_std: default_doppler_std(),
            clock_drift_noise: default_clock_drift_noise(),
        }
    }
}

impl TightSection {
    fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The single point's options these settings make (`gnss.tight.*` named in errors).
    pub fn spp_options(&self) -> Result<ins_gnss_core::raw::SppOptions, String> {
        use ins_gnss_core::raw::spp::{Ionosphere, Troposphere};
        let ionosphere = match self.ionosphere.as_str() {
            "off" => Ionosphere::Off,
            "klobuchar" => Ionosphere::Klobuchar,
            "iono-free" => Ionosphere::IonoFree,
            other => {
                return Err(format!(
                    "`gnss.tight.ionosphere = \"{other}\"`: klobuchar, iono-free or off"
                ))
            }
        };
        let troposphere = match self.troposphere.as_str() {
            "off" => Troposphere::Off,
            "saastamoinen" => Troposphere::Saastamoinen,
            other => {
                return Err(format!("`gnss.tight.troposphere = \"{other}\"`: saastamoinen or off"))
            }
        };
        if !(0.0..90.0).contains(&self.elevation_mask) {
            return Err(format!(
                "`gnss.tight.elevation_mask = {}`: degrees in 0…90",
                self.elevation_mask
            ));
        }
        for (key, v) in
            [("doppler_std", self.doppler_std), ("clock_drift_noise", self.clock_drift_noise)]
        {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("`gnss.tight.{key} = {v}`: must be positive"));
            }
        }
        Ok(ins_gnss_core::raw::SppOptions {
            elevation_mask: self.elevation_mask.to_radians(),
            ionosphere,
            troposphere,
            doppler_std: self.doppler_std,
            ..Default::default()
        })
    }
}

fn yes() -> bool {
    true
}

impl Default for GnssSection {
    fn default() -> Self {
        Self {
            lever_arm: [0.0; 3],
            use_velocity: true,
            position_std: None,
            velocity_std: None,
            quality: QualitySection::default(),
            coupling: Coupling::Loose,
            tight: TightSection::default(),
        }
    }
}

/// Filter choices.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterSection {
    /// Noise strategy name (`fixed`, `iae`, `afkf`, `fused`, `iakf`, `iakf-raw`,
    /// `sage-husa`). Default `fixed`; `--strategy` overrides it.
    #[serde(default = "fixed")]
    pub strategy: String,
    /// `wgs84` (default) or `flat-earth`.
    #[serde(default)]
    pub mechanization: MechanizationName,
    /// A strategy of its own for some measurement streams, by stream name
    /// (`gnss-position`, `gnss-position-velocity`): e.g. `{ gnss-position = "fused" }`.
    /// Streams not named use `strategy`.
    #[serde(default)]
    pub streams: std::collections::BTreeMap<String, String>,
    /// The gross-error gate in front of every strategy.
    #[serde(default)]
    pub gate: GateSection,
    /// Error states: 15 (attitude, velocity, position, biases; default) or 21 (and the
    /// gyro and accelerometer scale factors, as KF-GINS).
    #[serde(default = "default_states")]
    pub states: u32,
    /// Post-process: after the forward pass, run the fixed-interval smoother and write
    /// `nav_smoothed.txt` and `std_smoothed.txt` (`--smooth` sets it).
    #[serde(default)]
    pub smooth: bool,
}

fn default_states() -> u32 {
    15
}

/// The gross-error gate ([`adaptive::GrossErrorGate`]): refuses an innovation whose NIS
/// exceeds the χ² quantile at `1 − probability`, whatever the strategy.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GateSection {
    /// On by default; `false` gives KF-GINS's behaviour (every fix used).
    #[serde(default = "yes")]
    pub enabled: bool,
    /// Probability that a consistent innovation is refused. Default 1e-6.
    #[serde(default = "default_gate_probability")]
    pub probability: f64,
    /// Refusals in a row after which the next gated measurement is admitted with the
    /// prior inflated (the filter is doubted, not the measurement). Default 20.
    #[serde(default = "default_readmit")]
    pub readmit_after: u32,
    /// `"adapt"` (default): a stream whose innovations are all too large for their noise
    /// gets its `R` matched to them, and one whose innovations keep their direction gets
    /// its prior doubted, before anything is refused; `"refuse"`: refuse everything beyond
    /// the gate (the behaviour before; see [`adaptive::GateMode`]).
    #[serde(default)]
    pub mode: GateModeName,
}

/// `filter.gate.mode`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GateModeName {
    /// [`adaptive::GateMode::Adapt`].
    #[default]
    Adapt,
    /// [`adaptive::GateMode::Refuse`].
    Refuse,
}

impl From<GateModeName> for adaptive::GateMode {
    fn from(m: GateModeName) -> Self {
        match m {
            GateModeName::Adapt => adaptive::GateMode::Adapt,
            GateModeName::Refuse => adaptive::GateMode::Refuse,
        }
    }
}

/// The longest `gnss.lever_arm` accepted, m: beyond it the value is refused as a unit slip.
pub const MAX_LEVER_ARM: f64 = 50.0;

fn default_gate_probability() -> f64 {
    1e-6
}
fn default_readmit() -> u32 {
    20
}

impl Default for GateSection {
    fn default() -> Self {
        Self {
            enabled: true,
            probability: default_gate_probability(),
            readmit_after: default_readmit(),
            mode: GateModeName::default(),
        }
    }
}

fn fixed() -> String {
    "fixed".into()
}

impl Default for FilterSection {
    fn default() -> Self {
        Self {
            strategy: fixed(),
            mechanization: MechanizationName::default(),
            streams: Default::default(),
            gate: GateSection::default(),
            states: default_states(),
            smooth: false,
        }
    }
}

/// Mechanization names in configs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MechanizationName {
    /// WGS-84 NED.
    #[default]
    Wgs84,
    /// Flat earth around the initial position.
    FlatEarth,
}

/// A whole run configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Files.
    pub data: DataSection,
    /// Initial state: what is not given is found from the data.
    #[serde(default)]
    pub init: InitSection,
    /// The IMU's mounting.
    #[serde(default)]
    pub imu: ImuSection,
    /// Initialisation from the data and the checks of units and axes.
    #[serde(default)]
    pub align: AlignSection,
    /// IMU noise.
    pub imu_noise: NoiseSection,
    /// GNSS use.
    #[serde(default)]
    pub gnss: GnssSection,
    /// Filter choices.
    #[serde(default)]
    pub filter: FilterSection,
    /// Land-vehicle aiding (off unless a subsection is present).
    #[serde(default)]
    pub vehicle: VehicleSection,
}

/// Land-vehicle aiding: `[vehicle.nhc]` and `[vehicle.zupt]`, each on when present.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleSection {
    /// The non-holonomic constraint.
    #[serde(default)]
    pub nhc: Option<NhcSection>,
    /// ZUPT and ZARU on detected stops.
    #[serde(default)]
    pub zupt: Option<ZuptSection>,
    /// The odometer: the IMU file's 8th column (forward wheel speed, m/s).
    #[serde(default)]
    pub odometer: Option<OdometerSection>,
}

/// `[vehicle.odometer]`: the forward speed of the IMU file's 8th column, its scale
/// calibrated against the filter while GNSS is available.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometerSection {
    /// The wheel point (middle of the rear axle) from the IMU, body frame FRD, m. Default 0.
    #[serde(default)]
    pub lever_arm: [f64; 3],
    /// 1σ of the scale-corrected forward speed, m/s. Default 0.1.
    #[serde(default = "default_odometer_std")]
    pub std: f64,
    /// Time between updates, s. Default 0.1.
    #[serde(default = "default_aiding_interval")]
    pub interval: f64,
    /// Time constant of the scale calibration, s. Default 120.
    #[serde(default = "default_calibration_time")]
    pub calibration_time: f64,
    /// Samples above 1 m/s with GNSS before the odometer is used. Default 500.
    #[serde(default = "default_calibration_samples")]
    pub calibration_samples: f64,
}

fn default_odometer_std() -> f64 {
    0.1
}
fn default_calibration_time() -> f64 {
    120.0
}
fn default_calibration_samples() -> f64 {
    500.0
}

impl Default for OdometerSection {
    fn default() -> Self {
        Self {
            lever_arm: [0.0; 3],
            std: default_odometer_std(),
            interval: default_aiding_interval(),
            calibration_time: default_calibration_time(),
            calibration_samples: default_calibration_samples(),
        }
    }
}

/// `[vehicle.nhc]`: lateral and vertical velocity zero at a point of the vehicle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NhcSection {
    /// Roll, pitch, yaw of the IMU relative to the vehicle frame, degrees. Default 0.
    #[serde(default)]
    pub mounting: [f64; 3],
    /// The constraint point (middle of the rear axle) from the IMU, body frame FRD, m.
    /// Default 0.
    #[serde(default)]
    pub lever_arm: [f64; 3],
    /// 1σ of the lateral and vertical velocity, m/s. Default [0.1, 0.1].
    #[serde(default = "default_nhc_std")]
    pub std: [f64; 2],
    /// Time between updates, s. Default 0.1.
    #[serde(default = "default_aiding_interval")]
    pub interval: f64,
    /// Applied only above this speed, m/s. Default 0.
    #[serde(default)]
    pub min_speed: f64,
}

fn default_nhc_std() -> [f64; 2] {
    [0.1, 0.1]
}
fn default_aiding_interval() -> f64 {
    0.1
}

impl Default for NhcSection {
    fn default() -> Self {
        Self {
            mounting: [0.0; 3],
            lever_arm: [0.0; 3],
            std: default_nhc_std(),
            interval: default_aiding_interval(),
            min_speed: 0.0,
        }
    }
}

/// `[vehicle.zupt]`: the stationary detector's thresholds and the ZUPT/ZARU noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ZuptSection {
    /// Detector window, s. Default 1.
    #[serde(default = "default_window")]
    pub window: f64,
    /// Largest bias-corrected rate in the window, deg/s. Default 0.5.
    #[serde(default = "default_gyro_max")]
    pub gyro_max: f64,
    /// Largest standard deviation of the specific-force magnitude in the window, m/s².
    /// Default 0.05.
    #[serde(default = "default_accel_std_max")]
    pub accel_std_max: f64,
    /// 1σ of the zero velocity, m/s. Default 0.02.
    #[serde(default = "default_zupt_std")]
    pub velocity_std: f64,
    /// 1σ of the zero angular rate beyond the window mean's white noise (added from
    /// `imu_noise.arw`), deg/s; 0 turns ZARU off. Default 0.01.
    #[serde(default = "default_zaru_std")]
    pub rate_std: f64,
    /// Time between ZUPTs while stationary, s. Default 0.1 (ZARU: once per window).
    #[serde(default = "default_aiding_interval")]
    pub interval: f64,
    /// ZUPT/ZARU only while the filter's speed is below this plus `speed_sigmas` σ of it,
    /// m/s. Default 0.3.
    #[serde(default = "default_zupt_max_speed")]
    pub max_speed: f64,
    /// σ of the filter's speed added to `max_speed` (a stop in an outage is still taken).
    /// Default 3; 0 for a detector that fires while the vehicle creeps.
    #[serde(default = "default_speed_sigmas")]
    pub speed_sigmas: f64,
}

fn default_speed_sigmas() -> f64 {
    3.0
}

fn default_zupt_max_speed() -> f64 {
    0.3
}

fn default_window() -> f64 {
    1.0
}
fn default_gyro_max() -> f64 {
    0.5
}
fn default_accel_std_max() -> f64 {
    0.05
}
fn default_zupt_std() -> f64 {
    0.02
}
fn default_zaru_std() -> f64 {
    0.01
}

impl Default for ZuptSection {
    fn default() -> Self {
        Self {
            window: default_window(),
            gyro_max: default_gyro_max(),
            accel_std_max: default_accel_std_max(),
            velocity_std: default_zupt_std(),
            rate_std: default_zaru_std(),
            interval: default_aiding_interval(),
            max_speed: default_zupt_max_speed(),
            speed_sigmas: default_speed_sigmas(),
        }
    }
}

/// The languages of a configuration's text ([`Config::parse`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigKind {
    /// Our TOML (`.toml`).
    Toml,
    /// A KF-GINS YAML (`.yaml`, `.yml`).
    KfGinsYaml,
    /// Our TOML's tables as JSON (what a Python dict becomes).
    Json,
}

/// The accelerometer bias 1σ when `[init]` does not give one, mGal: a consumer MEMS
/// turn-on bias (20 mg; KF-GINS's drive-0708 configuration uses the same).
pub const DEFAULT_ACCEL_BIAS_STD: [f64; 3] = [20_000.0; 3];

fn v3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

impl Config {
    /// Load a TOML (`.toml`) or KF-GINS YAML (`.yaml`, `.yml`) configuration; relative
    /// paths are resolved against the file's directory.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let err = |message: String| ConfigError { path: path.to_path_buf(), message };
        let text = std::fs::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
        // a UTF-8 byte-order mark (Windows editors write one) is not part of the text
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        let kind = match ext.as_str() {
            "yaml" | "yml" => ConfigKind::KfGinsYaml,
            _ => ConfigKind::Toml,
        };
        let base = path.parent().unwrap_or_else(|| Path::new("."));
        Self::parse(text, kind, base).map_err(err)
    }

    /// A configuration from text in `kind`, validated, its relative paths resolved against
    /// `base` ([`load`](Self::load) on a file's text; the Python bindings on a dict as
    /// JSON).
    pub fn parse(text: &str, kind: ConfigKind, base: &Path) -> Result<Self, String> {
        let mut cfg = match kind {
            ConfigKind::KfGinsYaml => kf_gins::from_yaml(text)?,
            ConfigKind::Toml => toml::from_str::<Config>(text).map_err(|e| e.to_string())?,
            ConfigKind::Json => serde_json::from_str::<Config>(text).map_err(|e| e.to_string())?,
        };
        for p in [&mut cfg.data.imu, &mut cfg.data.gnss, &mut cfg.data.output] {
            if p.is_relative() {
                *p = base.join(&*p);
            }
        }
        for t in cfg.data.truth.iter_mut().chain(cfg.data.nav.iter_mut()) {
            if t.is_relative() {
                *t = base.join(&*t);
            }
        }
        cfg.validate()?;
        Ok(cfg)
    }

    /// That each input file named exists; the error names its key (`data.imu`,
    /// `data.gnss`, `data.truth`; `imupath`, `gnsspath` in a KF-GINS YAML).
    pub fn require_inputs(&self) -> Result<(), ConfigError> {
        let inputs = [
            ("data.imu (imupath in a KF-GINS YAML)", Some(&self.data.imu)),
            ("data.gnss (gnsspath in a KF-GINS YAML)", Some(&self.data.gnss)),
            ("data.truth", self.data.truth.as_ref()),
        ];
        let navs = self.data.nav.iter().map(|n| ("data.nav", Some(n)));
        for (key, file) in inputs.into_iter().chain(navs) {
            let Some(file) = file else { continue };
            if !file.is_file() {
                let what = if file.exists() { "is not a file" } else { "does not exist" };
                return Err(ConfigError {
                    path: file.clone(),
                    message: format!(
                        "`{key}`: {what} (a relative path is read from the configuration's \
                         folder)"
                    ),
                });
            }
        }
        Ok(())
    }

    /// `gnss.coupling = "tight"` and what it excludes: the 21-state model (not coupled
    /// tightly yet), column maps and a fixes' format (the raw file names its contents).
    fn validate_tight(&self) -> Result<(), String> {
        self.gnss.tight.spp_options()?;
        if self.gnss.coupling != Coupling::Tight {
            if !self.data.nav.is_empty() {
                return Err("`data.nav` is read by tight coupling only: set `gnss.coupling = \
                            \"tight\"` (with raw observations in `data.gnss`) or remove it"
                    .into());
            }
            return Ok(());
        }
        if self.filter.states != 15 {
            return Err(format!(
                "`gnss.coupling = \"tight\"` runs on the 15-state model (with the receiver \
                 clock); `filter.states = {}` is not coupled tightly yet",
                self.filter.states
            ));
        }
        if self.data.gnss_columns.is_some() || self.data.gnss_format != GnssFormatName::Auto {
            return Err("`gnss.coupling = \"tight\"` reads `data.gnss` as RINEX observations \
                        or a u-blox log: remove `data.gnss_columns` and `data.gnss_format`"
                .into());
        }
        Ok(())
    }

    /// Check that every value is finite and physically possible; the message names the
    /// key and the limit. Heights must lie within −1 km…+100 km, lever arms within 100 m,
    /// noise densities and standard deviations must be positive, the start before the
    /// end.
    pub fn validate(&self) -> Result<(), String> {
        let d = &self.data;
        let rates = d.imu_format == ImuFormatName::Rates;
        if let Some(c) = &d.imu_columns {
            c.map(rates).map_err(|e| format!("`data.imu_columns`: {e}"))?;
        }
        self.gnss.quality.factors()?;
        self.validate_tight()?;
        if d.gnss_columns.is_some() && d.gnss_format == GnssFormatName::Rtklib {
            return Err("`data.gnss_format = \"rtklib\"` and `data.gnss_columns` exclude each \
                        other: an RTKLIB solution names its columns in its header"
                .into());
        }
        if let Some(c) = &d.gnss_columns {
            c.map().map_err(|e| format!("`data.gnss_columns`: {e}"))?;
            if c.position_std.is_none() && self.gnss.position_std.is_none() {
                return Err("`data.gnss_columns` names no `position_std` columns: set \
                            `gnss.position_std` (m) for the fixes"
                    .into());
            }
            if c.velocity.is_some()
                && c.velocity_std.is_none()
                && self.gnss.velocity_std.is_none()
                && self.gnss.use_velocity
            {
                return Err(
                    "`data.gnss_columns` has a `velocity` but no `velocity_std` \
                            columns: set `gnss.velocity_std` (m/s), or `gnss.use_velocity = false`"
                        .into(),
                );
            }
        }
        if let Some(c) = &d.truth_columns {
            c.map().map_err(|e| format!("`data.truth_columns`: {e}"))?;
        }
        finite("data.imu_rate", &[d.imu_rate])?;
        if !(d.imu_rate > 0.0 && d.imu_rate <= 100_000.0) {
            return Err(format!(
                "`data.imu_rate` must be positive and at most 100 kHz (Hz), got {}",
                d.imu_rate
            ));
        }
        finite("data.max_gap", &[d.max_gap])?;
        if d.max_gap < 1.0 {
            return Err(format!(
                "`data.max_gap` must be at least 1 (IMU intervals), got {}",
                d.max_gap
            ));
        }
        finite("data.max_bridge", &[d.max_bridge])?;
        finite("data.imu_time_offset", &[d.imu_time_offset])?;
        if d.max_bridge < d.max_gap {
            return Err(format!(
                "`data.max_bridge` ({}) must be at least `data.max_gap` ({}) (IMU intervals)",
                d.max_bridge, d.max_gap
            ));
        }
        if let Some(t) = d.start_time {
            finite("data.start_time", &[t])?;
        }
        if let Some(t) = d.end_time {
            finite("data.end_time", &[t])?;
        }
        if let (Some(s), Some(e)) = (d.start_time, d.end_time) {
            if s >= e {
                return Err(format!(
                    "`data.start_time` ({s} s) must be before `data.end_time` ({e} s)"
                ));
            }
        }
        let i = &self.init;
        for (key, v) in [
            ("init.position", i.position),
            ("init.velocity", i.velocity),
            ("init.attitude", i.attitude),
            ("init.gyro_bias", i.gyro_bias),
            ("init.accel_bias", i.accel_bias),
        ] {
            if let Some(v) = v {
                finite(key, &v)?;
            }
        }
        if let Some(p) = i.position {
            if p[0].abs() > 90.0 || p[1].abs() > 360.0 {
                return Err(format!(
                    "`init.position` latitude/longitude out of range (degrees): {p:?}"
                ));
            }
            if !(-1_000.0..=100_000.0).contains(&p[2]) {
                return Err(format!("`init.position` height {} m is outside −1 km…+100 km", p[2]));
            }
        }
        if let Some(v) = i.velocity {
            if v.iter().any(|v| v.abs() > 2_000.0) {
                return Err(format!("`init.velocity` {v:?} m/s: a component beyond 2 km/s"));
            }
        }
        for (key, v) in [
            ("init.position_std", i.position_std),
            ("init.velocity_std", i.velocity_std),
            ("init.attitude_std", i.attitude_std),
            ("init.gyro_bias_std", i.gyro_bias_std),
            ("init.accel_bias_std", i.accel_bias_std),
        ] {
            if let Some(v) = v {
                positive(key, &v)?;
            }
        }
        if let Some(m) = &self.imu.mounting {
            m.matrix().map_err(|e| format!("`imu.mounting`: {e}"))?;
        }
        let a = &self.align;
        positive("align.static_window", &[a.static_window])?;
        nonneg("align.min_static", &[a.min_static])?;
        positive("align.max_time", &[a.max_time])?;
        positive("align.heading_std", &[a.heading_std])?;
        finite("init.gyro_scale", &i.gyro_scale)?;
        finite("init.accel_scale", &i.accel_scale)?;
        if i.gyro_scale.iter().chain(&i.accel_scale).any(|v| v.abs() >= 1e5) {
            return Err(format!(
                "`init.gyro_scale`/`init.accel_scale` {:?} / {:?} ppm: a scale factor of 10 % or \
                 more is not a calibration error",
                i.gyro_scale, i.accel_scale
            ));
        }
        positive("init.gyro_scale_std", &i.gyro_scale_std)?;
        positive("init.accel_scale_std", &i.accel_scale_std)?;
        let n = &self.imu_noise;
        if n.from_static {
            if n.arw != [0.0; 3] || n.vrw != [0.0; 3] {
                return Err("`imu_noise.from_static` measures `arw` and `vrw` on the static \
                            start: give either, not both"
                    .into());
            }
        } else {
            if n.arw == [0.0; 3] || n.vrw == [0.0; 3] {
                return Err("missing `imu_noise.arw` (deg/√h) and `imu_noise.vrw` (m/s/√h), \
                            or `imu_noise.from_static = true` to measure them on the static \
                            start"
                    .into());
            }
            positive("imu_noise.arw", &n.arw)?;
            positive("imu_noise.vrw", &n.vrw)?;
        }
        self.check_bias_noise()?;
        positive("imu_noise.gyro_scale_std", &n.gyro_scale_std)?;
        positive("imu_noise.accel_scale_std", &n.accel_scale_std)?;
        if self.filter.states != 15 && self.filter.states != 21 {
            return Err(format!("`filter.states` must be 15 or 21, got {}", self.filter.states));
        }
        if self.filter.states == 21 && n.corr_time.is_none() {
            return Err("21 states need `imu_noise.corr_time` (hours): the scale factors' \
                        instability is a Gauss–Markov σ with that correlation time"
                .into());
        }
        finite("gnss.lever_arm", &self.gnss.lever_arm)?;
        // (plausibility before the run: a lever arm in cm or mm given in m ran to a wrong
        // result that no innovation test could tell, the antenna's offset turning with
        // the vehicle being taken up by the attitude)
        let lever = self.gnss.lever_arm.iter().map(|v| v * v).sum::<f64>().sqrt();
        if lever > MAX_LEVER_ARM {
            return Err(format!(
                "`gnss.lever_arm` {:?} m is {lever:.1} m long, beyond the {MAX_LEVER_ARM} m \
                 of any vehicle's antenna from its IMU: a value in cm or mm given in m?",
                self.gnss.lever_arm
            ));
        }
        if let Some(s) = &self.gnss.position_std {
            positive("gnss.position_std", s)?;
        }
        if let Some(s) = &self.gnss.velocity_std {
            positive("gnss.velocity_std", s)?;
        }
        let g = &self.filter.gate;
        finite("filter.gate.probability", &[g.probability])?;
        if !(g.probability > 0.0 && g.probability < 0.5) {
            return Err(format!(
                "`filter.gate.probability` must lie in (0, 0.5): the chance that a consistent \
                 innovation is refused, e.g. 1e-6; got {}",
                g.probability
            ));
        }
        if g.readmit_after == 0 {
            return Err("`filter.gate.readmit_after` must be at least 1".into());
        }
        if let Some(n) = &self.vehicle.nhc {
            finite("vehicle.nhc.mounting", &n.mounting)?;
            if n.mounting.iter().any(|a| a.abs() > 180.0) {
                return Err(format!(
                    "`vehicle.nhc.mounting` {:?}: angles in degrees within ±180",
                    n.mounting
                ));
            }
            finite("vehicle.nhc.lever_arm", &n.lever_arm)?;
            if n.lever_arm.iter().any(|v| v.abs() > 100.0) {
                return Err(format!(
                    "`vehicle.nhc.lever_arm` {:?} m: a component beyond the 100 m limit",
                    n.lever_arm
                ));
            }
            positive("vehicle.nhc.std", &n.std)?;
            nonneg("vehicle.nhc.interval", &[n.interval])?;
            nonneg("vehicle.nhc.min_speed", &[n.min_speed])?;
        }
        if let Some(o) = &self.vehicle.odometer {
            finite("vehicle.odometer.lever_arm", &o.lever_arm)?;
            if o.lever_arm.iter().any(|v| v.abs() > 100.0) {
                return Err(format!(
                    "`vehicle.odometer.lever_arm` {:?} m: a component beyond the 100 m limit",
                    o.lever_arm
                ));
            }
            positive("vehicle.odometer.std", &[o.std])?;
            nonneg("vehicle.odometer.interval", &[o.interval])?;
            positive("vehicle.odometer.calibration_time", &[o.calibration_time])?;
            positive("vehicle.odometer.calibration_samples", &[o.calibration_samples])?;
        }
        if let Some(z) = &self.vehicle.zupt {
            positive("vehicle.zupt.window", &[z.window])?;
            positive("vehicle.zupt.gyro_max", &[z.gyro_max])?;
            positive("vehicle.zupt.accel_std_max", &[z.accel_std_max])?;
            positive("vehicle.zupt.velocity_std", &[z.velocity_std])?;
            nonneg("vehicle.zupt.rate_std", &[z.rate_std])?;
            nonneg("vehicle.zupt.interval", &[z.interval])?;
            positive("vehicle.zupt.max_speed", &[z.max_speed])?;
            nonneg("vehicle.zupt.speed_sigmas", &[z.speed_sigmas])?;
        }
        self.filter
            .strategy
            .parse::<adaptive::AnyStrategy>()
            .map_err(|e| format!("`filter.strategy`: {e}"))?;
        for (stream, name) in &self.filter.streams {
            if !STREAMS.iter().any(|s| s.name() == stream) {
                let names: Vec<_> = STREAMS.iter().map(|s| s.name()).collect();
                return Err(format!(
                    "`filter.streams`: unknown stream `{stream}`; the streams are {}",
                    names.join(", ")
                ));
            }
            name.parse::<adaptive::AnyStrategy>()
                .map_err(|e| format!("`filter.streams.{stream}`: {e}"))?;
        }
        Ok(())
    }

    /// The run's strategy: `default` on every stream and the strategies of
    /// `filter.streams` on theirs, behind the gross-error gate of `filter.gate` (open when
    /// `filter.gate.enabled = false`).
    pub fn strategy(
        &self,
        default: adaptive::AnyStrategy,
    ) -> Result<adaptive::GrossErrorGate<adaptive::PerStream<adaptive::AnyStrategy>>, ConfigError>
    {
        let inner = self.stream_strategies(default)?;
        let g = &self.filter.gate;
        Ok(if g.enabled {
            adaptive::GrossErrorGate::new(inner, g.probability, g.readmit_after)
                .with_mode(g.mode.into())
        } else {
            adaptive::GrossErrorGate::disabled(inner)
        })
    }

    /// `default` on every stream, and the strategies of `filter.streams` on theirs.
    pub fn stream_strategies(
        &self,
        default: adaptive::AnyStrategy,
    ) -> Result<adaptive::PerStream<adaptive::AnyStrategy>, ConfigError> {
        let err = |message: String| ConfigError { path: PathBuf::from("filter.streams"), message };
        let mut s = adaptive::PerStream::new(default);
        // the vehicle's pseudo-measurements keep their configured noise unless named:
        // an R-estimating strategy would learn the tuning of a constraint, not a sensor
        for id in VEHICLE_STREAMS {
            s = s.with(id, adaptive::AnyStrategy::default());
        }
        for (stream, name) in &self.filter.streams {
            let id = *STREAMS
                .iter()
                .find(|s| s.name() == stream)
                .ok_or_else(|| err(format!("unknown stream `{stream}`")))?;
            s = s.with(id, name.parse().map_err(|e| err(format!("{e}")))?);
        }
        Ok(s)
    }

    /// The IMU noise in SI units.
    pub fn imu_noise(&self) -> ImuNoise {
        let n = &self.imu_noise;
        // (validated: the instability and τ are there unless a random walk is given)
        let tau_h = n.corr_time.unwrap_or(1.0);
        let noise = ImuNoise::from_datasheet(
            v3(n.arw),
            v3(n.vrw),
            v3(n.gyro_bias_std.unwrap_or_default()),
            v3(n.accel_bias_std.unwrap_or_default()),
            tau_h,
        );
        let tau = tau_h * 3600.0;
        let mut noise = noise.with_bias_model(match n.bias_model {
            BiasModelName::RandomWalk => BiasModel::RandomWalk,
            BiasModelName::GaussMarkov => BiasModel::GaussMarkov { tau },
            BiasModelName::GaussMarkovHeld => BiasModel::GaussMarkovHeld { tau },
        });
        // a random walk given as such replaces the density σ √(2/τ)
        if let Some(q) = self.gyro_bias_rw() {
            noise.gyro_bias = q;
        }
        if let Some(q) = self.accel_bias_rw() {
            noise.accel_bias = q;
        }
        noise
    }

    /// The gyro bias random walk given (`gyro_bias_rw` or `gyro_bias_rw_si`), rad/s/√s.
    fn gyro_bias_rw(&self) -> Option<Vector3<f64>> {
        let n = &self.imu_noise;
        n.gyro_bias_rw.map(|q| v3(q) * (DEG_PER_H / 60.0)).or(n.gyro_bias_rw_si.map(v3))
    }

    /// The accelerometer bias random walk given, m/s²/√s.
    fn accel_bias_rw(&self) -> Option<Vector3<f64>> {
        let n = &self.imu_noise;
        n.accel_bias_rw.map(|q| v3(q) * (MGAL / 60.0)).or(n.accel_bias_rw_si.map(v3))
    }

    /// Either the instability with its correlation time or the random walk, per sensor,
    /// each once; a random walk only with `bias_model = "random-walk"`.
    fn check_bias_noise(&self) -> Result<(), String> {
        let n = &self.imu_noise;
        let rw_model = n.bias_model == BiasModelName::RandomWalk;
        for (sensor, std, rw, rw_si, unit) in [
            ("gyro", n.gyro_bias_std, n.gyro_bias_rw, n.gyro_bias_rw_si, "deg/h"),
            ("accel", n.accel_bias_std, n.accel_bias_rw, n.accel_bias_rw_si, "mGal"),
        ] {
            let given: Vec<String> = [
                std.map(|_| format!("imu_noise.{sensor}_bias_std")),
                rw.map(|_| format!("imu_noise.{sensor}_bias_rw")),
                rw_si.map(|_| format!("imu_noise.{sensor}_bias_rw_si")),
            ]
            .into_iter()
            .flatten()
            .collect();
            match given.len() {
                0 => {
                    return Err(format!(
                        "missing `imu_noise.{sensor}_bias_std` ({unit}, with `corr_time`) or \
                         `imu_noise.{sensor}_bias_rw` ({unit}/√h; `_si`: SI per √s)"
                    ))
                }
                1 => {}
                _ => {
                    return Err(format!(
                        "`{}`: give the bias noise once, either as an instability with \
                         `corr_time` or as a random walk",
                        given.join("`, `")
                    ))
                }
            }
            if let Some(v) = std {
                positive(&format!("imu_noise.{sensor}_bias_std"), &v)?;
                match n.corr_time {
                    None => {
                        return Err(format!(
                            "`imu_noise.{sensor}_bias_std` needs `imu_noise.corr_time` (hours)"
                        ))
                    }
                    Some(t) => {
                        finite("imu_noise.corr_time", &[t])?;
                        if t <= 0.0 {
                            return Err(format!(
                                "`imu_noise.corr_time` must be positive (hours), got {t}"
                            ));
                        }
                    }
                }
            }
            for (key, v) in [("rw", rw), ("rw_si", rw_si)] {
                if let Some(v) = v {
                    positive(&format!("imu_noise.{sensor}_bias_{key}"), &v)?;
                    if !rw_model {
                        return Err(format!(
                            "`imu_noise.{sensor}_bias_{key}` is a random walk: it needs \
                             `bias_model = \"random-walk\"` (a Gauss–Markov model needs \
                             `{sensor}_bias_std` and `corr_time`)"
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// The noise densities the filter uses, SI, for the run summary.
    pub fn noise_echo(&self) -> String {
        let n = self.imu_noise();
        let f = |v: &Vector3<f64>| format!("[{:.3e}, {:.3e}, {:.3e}]", v.x, v.y, v.z);
        let bias = match n.bias_model {
            BiasModel::RandomWalk => format!(
                "bias random walk gyro {} rad/s/√s, accel {} m/s²/√s",
                f(&n.gyro_bias),
                f(&n.accel_bias)
            ),
            BiasModel::GaussMarkov { tau } | BiasModel::GaussMarkovHeld { tau } => format!(
                "bias Gauss–Markov σ gyro {} rad/s, accel {} m/s², τ {tau:.0} s",
                f(&n.gyro_bias),
                f(&n.accel_bias)
            ),
        };
        format!("noise (SI): ARW {} rad/√s, VRW {} m/s/√s; {bias}", f(&n.arw), f(&n.vrw))
    }

    /// The initial position (the data's, once [`crate::start`] has filled `[init]` in;
    /// the equator at sea level before).
    pub fn initial_position(&self) -> GeoPos {
        let p = self.init.position.unwrap_or_default();
        GeoPos::from_degrees(p[0], p[1], p[2])
    }

    /// The initial state at `time`, from `[init]` as it is after [`crate::start`] has
    /// filled in what was missing (an unfilled value is 0, and a missing 1σ is refused by
    /// that step before this is called).
    pub fn initial_state(&self, time: f64) -> InitialState {
        let i = &self.init;
        let d = core::f64::consts::PI / 180.0;
        let get = |v: Option<[f64; 3]>| v3(v.unwrap_or_default());
        let att = get(i.attitude) * d;
        let state = InsState {
            att: So3::from_euler(att.x, att.y, att.z),
            vel: get(i.velocity),
            pos: self.initial_position(),
            bg: get(i.gyro_bias) * DEG_PER_H,
            ba: get(i.accel_bias) * MGAL,
        };
        let std = InitialStd {
            att: get(i.attitude_std) * d,
            vel: get(i.velocity_std),
            pos: get(i.position_std),
            bg: get(i.gyro_bias_std) * DEG_PER_H,
            ba: v3(i.accel_bias_std.unwrap_or(DEFAULT_ACCEL_BIAS_STD)) * MGAL,
        };
        InitialState { time, state, std }
    }

    /// GNSS settings.
    pub fn gnss_config(&self) -> GnssConfig {
        GnssConfig {
            lever_arm: v3(self.gnss.lever_arm),
            use_velocity: self.gnss.use_velocity,
            pos_std: self.gnss.position_std.map(v3),
            vel_std: self.gnss.velocity_std.map(v3),
        }
    }

    /// The scale factors' process noise in SI units (fractions), in the convention of the
    /// bias model.
    pub fn scale_factor_noise(&self) -> ScaleFactorNoise {
        let n = &self.imu_noise;
        let model = self.imu_noise().bias_model;
        ScaleFactorNoise::from_ppm(
            v3(n.gyro_scale_std),
            v3(n.accel_scale_std),
            model,
            n.corr_time.unwrap_or(1.0) * 3600.0,
        )
    }

    /// The initial scale factors and their 1σ (fractions).
    pub fn scale_init(&self) -> ScaleInit {
        let i = &self.init;
        ScaleInit {
            sg: v3(i.gyro_scale) * 1e-6,
            sa: v3(i.accel_scale) * 1e-6,
            sg_std: v3(i.gyro_scale_std) * 1e-6,
            sa_std: v3(i.accel_scale_std) * 1e-6,
        }
    }

    /// The vehicle aiding in SI units.
    pub fn vehicle_aiding(&self) -> VehicleAiding {
        let d = core::f64::consts::PI / 180.0;
        VehicleAiding {
            nhc: self.vehicle.nhc.as_ref().map(|n| NhcConfig {
                mounting: v3(n.mounting) * d,
                lever_arm: v3(n.lever_arm),
                std: nalgebra::Vector2::new(n.std[0], n.std[1]),
                interval: n.interval,
                min_speed: n.min_speed,
            }),
            zupt: self.vehicle.zupt.as_ref().map(|z| ZuptConfig {
                detector: DetectorConfig {
                    window: z.window,
                    gyro_max: z.gyro_max * d,
                    accel_std_max: z.accel_std_max,
                },
                velocity_std: z.velocity_std,
                rate_std: (z.rate_std > 0.0).then_some(z.rate_std * d),
                interval: z.interval,
                max_speed: z.max_speed,
                speed_sigmas: z.speed_sigmas,
            }),
            odometer: self.vehicle.odometer.as_ref().map(|o| OdometerConfig {
                lever_arm: v3(o.lever_arm),
                std: o.std,
                interval: o.interval,
                calibration_time: o.calibration_time,
                calibration_samples: o.calibration_samples,
            }),
        }
    }

    /// The mechanization.
    pub fn mechanization(&self) -> Mechanization {
        match self.filter.mechanization {
            MechanizationName::Wgs84 => Mechanization::Wgs84,
            MechanizationName::FlatEarth => {
                Mechanization::FlatEarth { reference: self.initial_position() }
            }
        }
    }

    /// IMU format.
    pub fn imu_format(&self) -> ImuFormat {
        match self.data.imu_format {
            ImuFormatName::Increments => ImuFormat::Increments,
            ImuFormatName::Rates => ImuFormat::Rates,
        }
    }

    /// Bad-line policy.
    pub fn bad_lines(&self) -> BadLinePolicy {
        match self.data.bad_lines {
            PolicyName::Error => BadLinePolicy::Error,
            PolicyName::Skip => BadLinePolicy::Skip,
        }
    }
}

mod kf_gins {
    //! KF-GINS YAML configurations (keys as in its `dataset/kf-gins.yaml`).

    use std::path::PathBuf;

    use yaml_rust2::{Yaml, YamlLoader};

    use super::*;

    fn num(y: &Yaml) -> Option<f64> {
        match y {
            Yaml::Real(s) => s.parse().ok(),
            Yaml::Integer(i) => Some(*i as f64),
            _ => None,
        }
    }

    fn get<'a>(doc: &'a Yaml, key: &str) -> Result<&'a Yaml, String> {
        let mut node = doc;
        for part in key.split('.') {
            node = &node[part];
        }
        if node.is_badvalue() || node.is_null() {
            Err(format!("missing key `{key}`"))
        } else {
            Ok(node)
        }
    }

    fn scalar(doc: &Yaml, key: &str) -> Result<f64, String> {
        num(get(doc, key)?).ok_or_else(|| format!("key `{key}` must be a number"))
    }

    fn triple(doc: &Yaml, key: &str) -> Result<[f64; 3], String> {
        let v = get(doc, key)?;
        let arr = v.as_vec().ok_or_else(|| format!("key `{key}` must be a list of 3 numbers"))?;
        if arr.len() != 3 {
            return Err(format!("key `{key}` must have 3 numbers, has {}", arr.len()));
        }
        let mut out = [0.0; 3];
        for (o, y) in out.iter_mut().zip(arr) {
            *o = num(y).ok_or_else(|| format!("key `{key}` must contain numbers"))?;
        }
        Ok(out)
    }

    fn text(doc: &Yaml, key: &str) -> Result<String, String> {
        get(doc, key)?
            .as_str()
            .map(str::to_string)
            .ok_or_else(|| format!("key `{key}` must be a string"))
    }

    /// The keys of a KF-GINS configuration (top level, and under `imunoise`).
    const KEYS: [&str; 22] = [
        "imupath",
        "gnsspath",
        "outputpath",
        "imudatalen",
        "imudatarate",
        "starttime",
        "endtime",
        "initpos",
        "initvel",
        "initatt",
        "initgyrbias",
        "initaccbias",
        "initgyrscale",
        "initaccscale",
        "initposstd",
        "initvelstd",
        "initattstd",
        "initbgstd",
        "initbastd",
        "initsgstd",
        "initsastd",
        "antlever",
    ];
    const NOISE_KEYS: [&str; 7] = ["arw", "vrw", "gbstd", "abstd", "gsstd", "asstd", "corrtime"];

    /// Refuse a key that is not KF-GINS's (a misspelt key would otherwise be silently
    /// ignored), suggesting the closest one.
    fn check_keys(node: &Yaml, known: &[&str], prefix: &str) -> Result<(), String> {
        let Some(map) = node.as_hash() else { return Ok(()) };
        for key in map.keys() {
            let name = key.as_str().unwrap_or("");
            if name == "imunoise" && prefix.is_empty() {
                continue;
            }
            if !known.contains(&name) {
                let best = known
                    .iter()
                    .map(|k| (strsim::levenshtein(name, k), *k))
                    .min()
                    .filter(|(d, _)| *d <= 3)
                    .map(|(_, k)| format!(" (did you mean `{prefix}{k}`?)"))
                    .unwrap_or_default();
                return Err(format!("unknown key `{prefix}{name}`{best}"));
            }
        }
        Ok(())
    }

    /// Build our configuration from a KF-GINS YAML text. The scale-factor keys
    /// (`initgyrscale`, `initaccscale`, `initsgstd`, `initsastd`, `imunoise.gsstd`,
    /// `imunoise.asstd`, all ppm) set the 21-state filter's scale factors; the filter runs
    /// 15 states unless `--states 21` (or `filter.states` in TOML) asks for 21. Any other
    /// key is refused with the closest known one suggested.
    pub fn from_yaml(text_in: &str) -> Result<Config, String> {
        let docs =
            YamlLoader::load_from_str(text_in).map_err(|e| format!("not valid YAML: {e}"))?;
        let doc = docs.first().ok_or("empty YAML document")?;
        check_keys(doc, &KEYS, "")?;
        check_keys(&doc["imunoise"], &NOISE_KEYS, "imunoise.")?;
        let imudatalen = num(get(doc, "imudatalen").unwrap_or(&Yaml::Integer(7))).unwrap_or(7.0);
        if imudatalen != 7.0 && imudatalen != 8.0 {
            return Err(format!("key `imudatalen` must be 7 or 8, got {imudatalen}"));
        }
        let end = scalar(doc, "endtime").unwrap_or(-1.0);
        let output = text(doc, "outputpath").unwrap_or_else(|_| "out".into());
        Ok(Config {
            data: DataSection {
                imu: PathBuf::from(text(doc, "imupath")?),
                gnss: PathBuf::from(text(doc, "gnsspath")?),
                output: PathBuf::from(output),
                imu_rate: scalar(doc, "imudatarate")?,
                imu_format: ImuFormatName::Increments,
                start_time: Some(scalar(doc, "starttime")?),
                end_time: (end > 0.0).then_some(end),
                bad_lines: PolicyName::Error,
                max_gap: default_max_gap(),
                max_bridge: default_max_bridge(),
                imu_time_offset: 0.0,
                truth: None,
                imu_columns: None,
                gnss_columns: None,
                gnss_format: Default::default(),
                truth_columns: None,
                nav: Vec::new(),
            },
            init: InitSection {
                position: Some(triple(doc, "initpos")?),
                velocity: Some(triple(doc, "initvel")?),
                attitude: Some(triple(doc, "initatt")?),
                gyro_bias: Some(triple(doc, "initgyrbias").unwrap_or([0.0; 3])),
                accel_bias: Some(triple(doc, "initaccbias").unwrap_or([0.0; 3])),
                position_std: Some(triple(doc, "initposstd")?),
                velocity_std: Some(triple(doc, "initvelstd")?),
                attitude_std: Some(triple(doc, "initattstd")?),
                gyro_bias_std: Some(triple(doc, "initbgstd")?),
                accel_bias_std: Some(triple(doc, "initbastd")?),
                gyro_scale: triple(doc, "initgyrscale").unwrap_or([0.0; 3]),
                accel_scale: triple(doc, "initaccscale").unwrap_or([0.0; 3]),
                gyro_scale_std: triple(doc, "initsgstd").unwrap_or_else(|_| default_scale_std()),
                accel_scale_std: triple(doc, "initsastd").unwrap_or_else(|_| default_scale_std()),
            },
            imu_noise: NoiseSection {
                arw: triple(doc, "imunoise.arw")?,
                vrw: triple(doc, "imunoise.vrw")?,
                from_static: false,
                static_floor: true,
                gyro_bias_std: Some(triple(doc, "imunoise.gbstd")?),
                accel_bias_std: Some(triple(doc, "imunoise.abstd")?),
                corr_time: Some(scalar(doc, "imunoise.corrtime")?),
                gyro_bias_rw: None,
                gyro_bias_rw_si: None,
                accel_bias_rw: None,
                accel_bias_rw_si: None,
                gyro_scale_std: triple(doc, "imunoise.gsstd")
                    .unwrap_or_else(|_| default_scale_std()),
                accel_scale_std: triple(doc, "imunoise.asstd")
                    .unwrap_or_else(|_| default_scale_std()),
                bias_model: BiasModelName::default(),
            },
            gnss: GnssSection {
                lever_arm: triple(doc, "antlever").unwrap_or([0.0; 3]),
                ..GnssSection::default()
            },
            imu: ImuSection::default(),
            align: AlignSection::default(),
            filter: FilterSection::default(),
            vehicle: VehicleSection::default(),
        })
    }
}
