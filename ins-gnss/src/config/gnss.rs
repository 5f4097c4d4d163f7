//! `[gnss]` and `[gnss.tight]`: lever arm, σ overrides, loose or tight coupling.

use super::*;

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
    pub(crate) fn is_loose(&self) -> bool {
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
    /// `saastamoinen` (default; mapped by 1/sin(el), as RTKLIB's single point), `niell`
    /// (Saastamoinen's zenith delays mapped by Niell's functions: 0.5 m lower at 10° of
    /// elevation, 3 m at 5°) or `off`.
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
    /// Keep the position's and clock's σ at least what the satellites' persisting errors
    /// (orbit, clock, code bias, atmosphere residuals) leave a single point of each epoch
    /// (`TightConfig::error_floor`). Default true.
    #[serde(default = "yes")]
    pub error_floor: bool,
    /// Use the carrier phases differenced between consecutive epochs (velocity to mm/s;
    /// flagged or Doppler-inconsistent slips left out). Default false: over 16 simulated
    /// seeds it cuts the velocity error five-fold but leaves the attitude σ too small on
    /// some (`docs/results.md`).
    #[serde(default)]
    pub carrier: bool,
    /// σ of a carrier phase, m. Default 0.003 (RTKLIB's default for its constant term).
    #[serde(default = "default_phase_std")]
    pub phase_std: f64,
    /// The systems used, as RINEX letters or names: `G` (GPS), `E` (Galileo), `C`
    /// (BeiDou), `J` (QZSS). Default all four; Galileo's, BeiDou's and QZSS's clocks are
    /// biases against GPS's (inter-system bias states).
    #[serde(default = "default_systems")]
    pub systems: Vec<String>,
}

/// The single point's systems ([`SppOptions`](ins_gnss_core::raw::SppOptions)'s default), as
/// letters.
pub(crate) fn default_systems() -> Vec<String> {
    let systems = ins_gnss_core::raw::SppOptions::default().systems;
    systems.iter().map(|s| s.letter().to_string()).collect()
}

fn default_phase_std() -> f64 {
    0.003
}

pub(crate) fn default_elevation_mask() -> f64 {
    15.0
}
pub(crate) fn default_iono() -> String {
    "klobuchar".into()
}
pub(crate) fn default_tropo() -> String {
    "saastamoinen".into()
}
pub(crate) fn default_doppler_std() -> f64 {
    0.1
}
pub(crate) fn default_clock_drift_noise() -> f64 {
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
            error_floor: true,
            carrier: false,
            phase_std: default_phase_std(),
            systems: default_systems(),
        }
    }
}

impl TightSection {
    pub(crate) fn is_default(&self) -> bool {
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
        let troposphere = Troposphere::from_name(&self.troposphere).ok_or_else(|| {
            format!(
                "`gnss.tight.troposphere = \"{}\"`: saastamoinen, niell or off",
                self.troposphere
            )
        })?;
        if !(0.0..90.0).contains(&self.elevation_mask) {
            return Err(format!(
                "`gnss.tight.elevation_mask = {}`: degrees in 0…90",
                self.elevation_mask
            ));
        }
        for (key, v) in [
            ("doppler_std", self.doppler_std),
            ("clock_drift_noise", self.clock_drift_noise),
            ("phase_std", self.phase_std),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("`gnss.tight.{key} = {v}`: must be positive"));
            }
        }
        let systems = ins_gnss_core::raw::System::parse_list(&self.systems)
            .map_err(|e| format!("`gnss.tight.systems`: {e}"))?;
        Ok(ins_gnss_core::raw::SppOptions {
            elevation_mask: self.elevation_mask.to_radians(),
            ionosphere,
            troposphere,
            systems,
            doppler_std: self.doppler_std,
            ..Default::default()
        })
    }
}

pub(crate) fn yes() -> bool {
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
