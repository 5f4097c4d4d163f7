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

mod convert;
mod data;
mod filter;
mod gnss;
mod init;
mod kf_gins;
mod noise;
mod options;
mod validate;
mod vehicle;

pub use data::*;
pub use filter::*;
pub use gnss::*;
pub use init::*;
pub use noise::*;
pub use options::*;
pub use vehicle::*;

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
}
