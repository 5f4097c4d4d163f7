//! `[data]`: the input files, their formats and the skip policy; `[gnss.quality]`.

use super::*;

/// Input files and their timing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataSection {
    /// IMU file (required unless `[data.ros]` gives a recording).
    #[serde(default, skip_serializing_if = "path_unset")]
    pub imu: PathBuf,
    /// GNSS file (7 or 13 columns; required unless `[data.ros]`).
    #[serde(default, skip_serializing_if = "path_unset")]
    pub gnss: PathBuf,
    /// Output directory. Default `out`.
    #[serde(default = "default_output")]
    pub output: PathBuf,
    /// IMU sampling rate, Hz (required unless `[data.ros]`, whose rate is the median
    /// interval of its IMU messages).
    #[serde(default, skip_serializing_if = "rate_unset")]
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
    /// A moving-base receiver's headings, a file of their own (`[gnss.heading]`): RTKLIB's
    /// moving-base solution in ENU (`out-solformat = enu`), NMEA with `HDT`/`THS`, or
    /// columns `t heading [σ [pitch σ]]` (deg), or a u-blox log's `NAV-RELPOSNED`. Each is
    /// attached to the fix (tight coupling: the raw epoch) at its time (within 1 ms).
    /// Headings in an NMEA `data.gnss` need no file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heading: Option<PathBuf>,
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
    /// A base station's raw observations (RINEX, a u-blox log, or RTCM 3 — a name with
    /// `.rtcm`, its MSM4/MSM7 messages) for `gnss.coupling = "rtk"`: its position from
    /// `gnss.rtk.base_position`, its RINEX header or its RTCM 1005/1006 message.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base: Option<PathBuf>,
    /// A ROS recording ([`RosSection`]) instead of `imu` and `gnss`.
    #[serde(default)]
    pub ros: Option<RosSection>,
}

fn path_unset(p: &Path) -> bool {
    p.as_os_str().is_empty()
}

fn rate_unset(r: &f64) -> bool {
    *r == 0.0
}

/// `[data.ros]`: the IMU, the GNSS fixes and the odometry from a ROS recording: a ROS 1
/// bag (bz2 or lz4 chunks) or an MCAP file (ROS 1 or ROS 2 CDR messages), read as it is.
/// The IMU messages' angular velocity and specific force are in their `frame_id`'s axes
/// (`imu.mounting` turns them into the body's, FRD); the odometry's forward speed
/// (`twist.linear.x` in its child frame) feeds `[vehicle.odometer]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RosSection {
    /// The recording (`.bag` or `.mcap`, told apart by their first bytes).
    pub recording: PathBuf,
    /// The `sensor_msgs/Imu` topic (default: the recording's only one).
    #[serde(default)]
    pub imu_topic: Option<String>,
    /// The `sensor_msgs/NavSatFix` topic (default: the recording's only one). Its status
    /// is the fix's quality (no fix: left out; fix, SBAS, GBAS: `[gnss.quality]`'s
    /// `single`, `sbas`, `dgps`), its ENU covariance the σ (an unknown covariance, type 0,
    /// needs `gnss.position_std`).
    #[serde(default)]
    pub fix_topic: Option<String>,
    /// The `nav_msgs/Odometry` topic (default: the recording's only one), read when
    /// `[vehicle.odometer]` is on: its forward speed, linear between its messages, is
    /// the odometer's reading at each IMU sample.
    #[serde(default)]
    pub odometry_topic: Option<String>,
    /// The body frame for the recording's static transforms (`/tf_static`), default the
    /// odometry's child frame, else `base_link`. When they connect it to the IMU's
    /// `frame_id`, they give `imu.mounting` (if not set) and, from the IMU, the antenna's
    /// (`gnss.lever_arm`) and the body origin's (`vehicle.odometer.lever_arm`) lever arms
    /// where those are left at zero; the run's summary says which.
    #[serde(default)]
    pub base_frame: Option<String>,
    /// `header` (default: the messages' header stamps) or `receive` (the times the
    /// recorder received them).
    #[serde(default)]
    pub stamps: StampsName,
    /// Take `imu_noise.arw` and `imu_noise.vrw` from the IMU messages' covariances (their
    /// median diagonal σ times √dt), instead of giving them. Default false.
    #[serde(default)]
    pub imu_noise_from_covariance: bool,
}

/// Which times a recording's messages carry.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StampsName {
    /// The header stamps (when the sensor measured).
    #[default]
    Header,
    /// The receive times (when the recorder got the message).
    Receive,
}

pub(crate) fn default_output() -> PathBuf {
    PathBuf::from("out")
}
pub(crate) fn default_max_gap() -> f64 {
    5.0
}
pub(crate) fn default_max_bridge() -> f64 {
    ins_gnss_io::formats::DEFAULT_MAX_BRIDGE
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

impl From<GnssFormatName> for ins_gnss_io::GnssFormat {
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

pub(crate) fn q_fix() -> f64 {
    1.0
}
pub(crate) fn q_float() -> f64 {
    2.0
}
pub(crate) fn q_dgps() -> f64 {
    3.0
}
pub(crate) fn q_single() -> f64 {
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
    pub fn factors(&self) -> Result<ins_gnss_io::rtklib::QualityFactors, String> {
        use ins_gnss_io::rtklib::QUALITY_NAMES;
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
                    ));
                }
            }
        }
        Ok(ins_gnss_io::rtklib::QualityFactors { factor: f, drop })
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
