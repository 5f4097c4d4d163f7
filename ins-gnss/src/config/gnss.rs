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
    /// `loose` (default: `data.gnss` holds a receiver's fixes), `tight` (`data.gnss` is
    /// a RINEX observation file or a u-blox log, with `data.nav`: each satellite's
    /// pseudorange and Doppler update the filter) or `rtk` (the same, with a base
    /// station's observations in `data.base`: RTK's fixes update the filter).
    #[serde(default, skip_serializing_if = "Coupling::is_loose")]
    pub coupling: Coupling,
    /// Tight coupling's models ([`TightSection`]).
    #[serde(default, skip_serializing_if = "TightSection::is_default")]
    pub tight: TightSection,
    /// RTK's settings ([`RtkSection`]).
    #[serde(default, skip_serializing_if = "RtkSection::is_default")]
    pub rtk: RtkSection,
    /// The fixes' errors: white, or with a persisting part as states ([`ErrorsSection`]).
    #[serde(default, skip_serializing_if = "ErrorsSection::is_default")]
    pub errors: ErrorsSection,
    /// Heading from two antennas ([`HeadingSection`]).
    #[serde(default, skip_serializing_if = "HeadingSection::is_default")]
    pub heading: HeadingSection,
}

/// `[gnss.heading]`: the heading (and pitch) of a moving-base receiver's two antennas —
/// NMEA `HDT`/`THS` sentences in the GNSS log, or `data.heading`, a file of its own
/// (RTKLIB's moving-base solution in ENU, or NMEA). Each heading updates the filter at
/// its fix's time as the stream `gnss-heading`, gated and adapted like the others, and
/// gives the start its heading at the first fix.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadingSection {
    /// Use the headings the data carry. Default true.
    #[serde(default = "yes")]
    pub use_headings: bool,
    /// The baseline whose heading the receiver measures — from the moving base's antenna
    /// to the rover's (u-blox `relPosHeading`, RTKLIB's moving-base ENU) — in the body
    /// frame (FRD), m; only its direction matters. Default `[1, 0, 0]`: the rover's
    /// antenna ahead of the base's, the heading the vehicle's.
    #[serde(default = "forward")]
    pub baseline: [f64; 3],
    /// The heading's 1σ, deg, where the source states none (NMEA). Default 0.5.
    #[serde(default = "default_heading_std")]
    pub std: f64,
    /// The elevation's 1σ, deg, where the source states none. Default 1.
    #[serde(default = "default_pitch_std")]
    pub pitch_std: f64,
    /// Replace the sources' σ by `std` and `pitch_std`. Default false.
    #[serde(default)]
    pub replace_std: bool,
    /// Use the baseline's elevation where the source gives it (RTKLIB's ENU). Default
    /// true.
    #[serde(default = "yes")]
    pub pitch: bool,
}

fn forward() -> [f64; 3] {
    [1.0, 0.0, 0.0]
}

fn default_heading_std() -> f64 {
    0.5
}

fn default_pitch_std() -> f64 {
    1.0
}

impl Default for HeadingSection {
    fn default() -> Self {
        Self {
            use_headings: true,
            baseline: forward(),
            std: default_heading_std(),
            pitch_std: default_pitch_std(),
            replace_std: false,
            pitch: true,
        }
    }
}

impl HeadingSection {
    pub(crate) fn is_default(&self) -> bool {
        *self == Self::default()
    }

    pub(crate) fn check(&self) -> Result<(), String> {
        finite("gnss.heading.baseline", &self.baseline)?;
        if !ins_gnss_core::heading::has_horizontal_direction(&Vector3::from(self.baseline)) {
            return Err(format!(
                "`gnss.heading.baseline = {:?}`: the baseline from the primary antenna to the \
                 secondary (FRD, m) must have a horizontal direction in the body (a heading \
                 is not defined for antennas one above the other)",
                self.baseline
            ));
        }
        for (key, v) in [("gnss.heading.std", self.std), ("gnss.heading.pitch_std", self.pitch_std)]
        {
            if !(v.is_finite() && v > 0.0 && v < 90.0) {
                return Err(format!("`{key} = {v}`: degrees, positive, below 90"));
            }
        }
        Ok(())
    }

    /// The library's settings (`None`: headings ignored).
    pub fn config(&self) -> Option<ins_gnss_core::heading::HeadingConfig> {
        self.use_headings.then(|| ins_gnss_core::heading::HeadingConfig {
            baseline: Vector3::from(self.baseline),
            std: self.std.to_radians(),
            pitch_std: self.pitch_std.to_radians(),
            force_std: self.replace_std,
            use_pitch: self.pitch,
        })
    }
}

/// `[gnss.errors]`: how the fixes' errors are modelled (loose coupling). A receiver
/// without corrections gives fixes whose errors wander by metres over minutes; taken as
/// white, the filter averages them away and reports a σ their error leaves behind. With a
/// persisting part, the fixes' error is split into a first-order Gauss–Markov process per
/// NED axis, three states of the filter (18 or 24 states), and white noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorsSection {
    /// `auto` (default: when the fixes' declared horizontal σ is above 0.1 m, i.e. not an
    /// RTK fix, the first 100 fixes give their total noise scale, then a bank of runs
    /// judges the white model against persisting parts of several σ and correlation
    /// times by the fixes' likelihood, and the run starts again with the one chosen;
    /// fixes declared at 0.1 m or less are white unless their first 100 show
    /// innovations both more than 2× their declared σ and correlated from fix to fix,
    /// and then judged the same way),
    /// `white` (the fixes' errors independent from fix to fix) or `persisting` (with
    /// `share`, `tau` and `sigma` as given).
    #[serde(default)]
    pub model: ErrorModel,
    /// The persisting part's share of the declared variance, 0–1. Default 0.9.
    #[serde(default = "default_error_share")]
    pub share: f64,
    /// The persisting part's correlation time, s. Default 300.
    #[serde(default = "default_error_tau")]
    pub tau: f64,
    /// The persisting part's σ (N, E, D), m, stated apart from the declared σ (which is
    /// then the white part's). Default: the share of the declared σ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma: Option<[f64; 3]>,
    /// Learn the white part's σ from the fixes' residuals and, without `sigma`, the split
    /// from the whiteness of the innovations (the declared σ and share are the prior).
    /// Default true.
    #[serde(default = "yes")]
    pub learn: bool,
}

/// `gnss.errors.model`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ErrorModel {
    /// Judged: white for fixes that declare an RTK fix's σ, unless their first
    /// innovations contradict it; otherwise the model the fixes' likelihood chooses among
    /// white and persisting parts.
    #[default]
    Auto,
    /// Independent from fix to fix.
    White,
    /// A persisting part, always.
    Persisting,
}

/// How a run models the fixes' errors (`gnss.errors`, [`ErrorsSection::plan`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FixErrorPlan {
    /// White: independent from fix to fix.
    White,
    /// White for the first [`PROBE_FIXES`] fixes, which give the fixes' total noise
    /// scale; then a bank of runs judges the white model against persisting parts by the
    /// fixes' likelihood, and the run starts again with the one chosen.
    Probe,
    /// Fixes that declare an RTK fix's σ: white, unless the first [`PROBE_FIXES`] fixes'
    /// innovations show a variance factor above [`CONTRADICTED_FACTOR`] on the σ they
    /// declare and a lag-one autocorrelation above [`CORRELATED_LAG`]; then as
    /// [`FixErrorPlan::Probe`] (the declared σ is a prior, not a fact: a single point's
    /// wandering fixes declaring centimetres are judged as a single point's).
    Check,
    /// With the persisting part as states.
    Persisting,
}

/// The fixes over which a probing run learns the fixes' total noise scale before the
/// bank judges their model.
pub const PROBE_FIXES: u64 = 100;

/// The declared horizontal σ (m) above which `gnss.errors.model = "auto"` probes for a
/// persisting part: an RTK fix declares centimetres, a float solution decimetres, a
/// single point metres.
pub const PERSISTING_ABOVE: f64 = 0.1;

/// The variance factor on their declared σ beyond which fixes declared at or below
/// [`PERSISTING_ABOVE`] may be judged as [`FixErrorPlan::Probe`] judges fixes (4: their
/// innovations twice the σ they declare; drive-0708's RTK fixes show 1.35, `noise
/// learned: gnss-position σ × 1.16`).
pub const CONTRADICTED_FACTOR: f64 = 4.0;

/// The lag-one autocorrelation of the fixes' whitened innovations above which fixes
/// declared at or below [`PERSISTING_ABOVE`], and contradicted by their scatter
/// ([`CONTRADICTED_FACTOR`]), are judged for a persisting part. Chosen by the everyday
/// corpus's eight cells whose fixes declare ≤ 0.1 m (20 seeds each, 2026-12-07): at 0.6
/// (the gate's [`adaptive::CORRELATED`]) the wandering fixes' probe stayed under it on
/// 3–18 of 20 seeds, mean share beyond the 99 % ellipse 34.5 %, 58 of 160 runs flagged,
/// the geometric mean of the score over the true model's 1.43; at 0.45: 9.1 %, 9 flagged,
/// 1.30 (navego's white fixes worse, 0.446 → 0.737 m: the bank took a persisting part
/// for them on 9 of 20 seeds); at 0.3 (the gate's [`adaptive::WHITE_LAG`]) white fixes
/// were judged on 10–16 of 20 seeds (drive-0708 `aided-noinit` 3.49 → 6.88 m): the
/// innovations of a filter told 10× too small a σ are correlated whatever the fixes'.
pub const CORRELATED_LAG: f64 = 0.45;

impl FixErrorPlan {
    /// Whether a run on this plan probes the fixes' errors over its first
    /// [`PROBE_FIXES`] fixes.
    pub fn probes(self) -> bool {
        matches!(self, FixErrorPlan::Probe | FixErrorPlan::Check)
    }

    /// Whether the probe's finding — the variance factor on the fixes' declared σ and the
    /// lag-one autocorrelation of their whitened innovations — hands the fixes to the
    /// bank (always, probed; contradicted and correlated, checked).
    pub fn judges(self, factor: f64, lag_one: f64) -> bool {
        match self {
            FixErrorPlan::Probe => true,
            FixErrorPlan::Check => factor > CONTRADICTED_FACTOR && lag_one > CORRELATED_LAG,
            FixErrorPlan::White | FixErrorPlan::Persisting => false,
        }
    }
}

fn default_error_share() -> f64 {
    ins_gnss_core::navigator::FIX_ERROR_SHARE
}

fn default_error_tau() -> f64 {
    ins_gnss_core::navigator::FIX_ERROR_TAU
}

impl Default for ErrorsSection {
    fn default() -> Self {
        Self {
            model: ErrorModel::Auto,
            share: default_error_share(),
            tau: default_error_tau(),
            sigma: None,
            learn: true,
        }
    }
}

impl ErrorsSection {
    pub(crate) fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// How a run models the fixes' errors, for fixes that declare a horizontal σ of
    /// `declared` m (the larger of north and east; `None`: not known).
    pub fn plan(&self, declared: Option<f64>) -> FixErrorPlan {
        match self.model {
            ErrorModel::White => FixErrorPlan::White,
            ErrorModel::Persisting => FixErrorPlan::Persisting,
            ErrorModel::Auto if declared.is_some_and(|s| s > PERSISTING_ABOVE) => {
                FixErrorPlan::Probe
            }
            ErrorModel::Auto => FixErrorPlan::Check,
        }
    }

    /// The navigator's split of the fixes' error.
    pub fn split(&self) -> ins_gnss_core::navigator::FixErrorSplit {
        ins_gnss_core::navigator::FixErrorSplit {
            share: self.share,
            tau: self.tau,
            sigma: self.sigma.map(nalgebra::Vector3::from),
            learn: self.learn,
        }
    }

    /// The section's values checked (`gnss.errors.*` named in errors).
    pub(crate) fn check(&self) -> Result<(), String> {
        if !(0.0..=1.0).contains(&self.share) {
            return Err(format!("`gnss.errors.share = {}`: a fraction in 0…1", self.share));
        }
        if !(self.tau.is_finite() && self.tau > 0.0) {
            return Err(format!("`gnss.errors.tau = {}`: seconds, positive", self.tau));
        }
        if let Some(s) = &self.sigma
            && !s.iter().all(|v| v.is_finite() && *v >= 0.0)
        {
            return Err(format!("`gnss.errors.sigma = {s:?}`: metres, not negative"));
        }
        Ok(())
    }
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
    /// Raw observations of the rover and of a base station (`data.base`): each epoch's
    /// double differences, their ambiguities fixed to integers where they can be, by an
    /// RTK filter of its own and one around the INS prediction, which the first
    /// validates ([`RtkSection`]); a fix updates the filter as a position, `nav.pos`
    /// writes Q = 1 where one was taken.
    Rtk,
}

impl Coupling {
    pub(crate) fn is_loose(&self) -> bool {
        *self == Coupling::Loose
    }

    /// Whether `data.gnss` holds raw observations (tight coupling, RTK).
    pub fn is_raw(&self) -> bool {
        *self != Coupling::Loose
    }
}

/// `[gnss.rtk]`: RTK's settings (`gnss.coupling = "rtk"`). The satellites' models of the
/// rover's single points (its first position, the start) are `[gnss.tight]`'s.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RtkSection {
    /// The base station's antenna, ECEF X, Y, Z (m). Default: its RINEX header's `APPROX
    /// POSITION XYZ` (a u-blox base log needs it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_position: Option<[f64; 3]>,
    /// Frequencies: 1 (L1/E1) or 2 (with L2/E5b). Default 2.
    #[serde(default = "two")]
    pub frequencies: usize,
    /// Elevation mask at the base, degrees. Default 15.
    #[serde(default = "default_elevation_mask")]
    pub elevation_mask: f64,
    /// The ratio test's threshold. Default 3 (RTKLIB's).
    #[serde(default = "three")]
    pub ratio: f64,
    /// The integer bootstrapping success rate the float ambiguities must promise before a
    /// fix. Default: 0.999 with one frequency, none (the ratio test alone) with two.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_success_rate: Option<f64>,
    /// The oldest base epoch a rover epoch is paired with, s. Default 1.
    #[serde(default = "one_second")]
    pub max_age: f64,
}

fn two() -> usize {
    2
}
fn three() -> f64 {
    3.0
}
fn one_second() -> f64 {
    1.0
}

impl Default for RtkSection {
    fn default() -> Self {
        Self {
            base_position: None,
            frequencies: 2,
            elevation_mask: default_elevation_mask(),
            ratio: 3.0,
            min_success_rate: None,
            max_age: 1.0,
        }
    }
}

impl RtkSection {
    pub(crate) fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The RTK filter's options these settings make, with `ins-gnss rtk`'s defaults (the
    /// code biases as states, a fix held with two frequencies). The error names its key
    /// (`gnss.rtk.*`).
    pub fn options(&self) -> Result<::gnss::rtk::RtkOptions, String> {
        let settings = super::rtk_settings::RtkSettings {
            frequencies: self.frequencies,
            mask: self.elevation_mask,
            ratio: self.ratio,
            max_age: self.max_age,
            min_success_rate: self.min_success_rate,
            ..Default::default()
        };
        let opt = settings.options().map_err(|(key, why)| {
            let key = match key {
                "mask" => "elevation_mask",
                k => k,
            };
            format!("`gnss.rtk.{key}` {why}")
        })?;
        if let Some(p) = self.base_position {
            super::rtk_settings::base_position(&p)
                .map_err(|e| format!("`gnss.rtk.base_position`: {e}"))?;
        }
        Ok(opt)
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
    /// some (`docs/history/results.md`).
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

/// The single point's systems ([`SppOptions`](::gnss::SppOptions)'s default), as
/// letters.
pub(crate) fn default_systems() -> Vec<String> {
    let systems = ::gnss::SppOptions::default().systems;
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
    pub fn spp_options(&self) -> Result<::gnss::SppOptions, String> {
        use ::gnss::spp::{Ionosphere, Troposphere};
        let ionosphere = match self.ionosphere.as_str() {
            "off" => Ionosphere::Off,
            "klobuchar" => Ionosphere::Klobuchar,
            "iono-free" => Ionosphere::IonoFree,
            other => {
                return Err(format!(
                    "`gnss.tight.ionosphere = \"{other}\"`: klobuchar, iono-free or off"
                ));
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
        let systems = ::gnss::System::parse_list(&self.systems)
            .map_err(|e| format!("`gnss.tight.systems`: {e}"))?;
        Ok(::gnss::SppOptions {
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
            rtk: RtkSection::default(),
            errors: ErrorsSection::default(),
            heading: HeadingSection::default(),
        }
    }
}
