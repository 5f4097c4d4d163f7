//! `[filter]` and `[filter.gate]`: strategy, states, the gross-error gate, smoothing.

use super::*;

/// Filter choices.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterSection {
    /// Noise strategy name (`fixed`, `iae`, `iae-qr`, `afkf`, `fused` and its readings,
    /// `iakf`, `iakf-raw`, `sage-husa`, `chi2-gate`; the papers' algorithms as written,
    /// unguarded: `afkf-faithful`, `afkf-xia-faithful`, `fused-faithful`,
    /// `iae-qr-faithful`). Default `fixed`; `--strategy` overrides it.
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
    /// Propagate the covariance at most once per this many seconds, over the IMU
    /// samples' increments combined, and always before an update (PX4's EKF2 does so);
    /// the state is propagated at every sample. Default 0.02 s (4 samples at 200 Hz):
    /// on navego, drive-0708 and the campaigns it moves no RMS by more than 0.4 % and
    /// cuts the filter's IMU epoch by about 40 % (`docs/history/benches.md`). `0`: at every
    /// sample, the exact mode. A smoothed run (`smooth`) records every sample and brings the
    /// covariance to now where the smoother stores one; its backward pass takes the forward
    /// pass's stretches (one transition over each stretch's increments combined, the
    /// smoothed correction interpolated in time inside it) and carries the adjoint
    /// covariance as each segment's product of transitions: its smoothed RMS moves by at
    /// most 0.3 % on those data sets, and navego's smoothed run is about 10 % faster than
    /// with every sample's own transition (`docs/history/benches.md`). The σ written between
    /// covariance steps are the last step's.
    #[serde(default = "default_covariance_interval")]
    pub covariance_interval: f64,
    /// Smoothing (`smooth`) with one covariance per update in its scratch file instead
    /// of two: the backward pass rebuilds the covariance before each update by replaying
    /// it from the update before, as the forward pass propagated it. The smoothed files
    /// are the same, byte for byte. On the simulated day (100 Hz, NHC at 10 Hz) the
    /// scratch goes from 2.68 to 1.77 GB; navego's smoothed run takes 7–9 % longer
    /// (`docs/history/benches.md`). Default false.
    #[serde(default)]
    pub smooth_low_scratch: bool,
}

pub(crate) fn default_states() -> u32 {
    15
}

pub(crate) fn default_covariance_interval() -> f64 {
    0.02
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
    /// With `mode = "adapt"`: learn each GNSS stream's noise from its inliers' residuals
    /// (the declared σ is a prior, not a fact): raised as far as the data show it too
    /// small; lowered where they show it too large, all the way for white innovations and
    /// to at most 5× what they show for innovations correlated from one epoch to the next
    /// (errors that persist over minutes, which the filter follows). The vehicle's
    /// constraints keep their configured noise. Default true; the factors learned are in
    /// the summary ([`adaptive::GrossErrorGate::learned`]).
    #[serde(default = "yes")]
    pub learn: bool,
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

pub(crate) fn default_gate_probability() -> f64 {
    adaptive::DEFAULT_PROBABILITY
}
pub(crate) fn default_readmit() -> u32 {
    adaptive::DEFAULT_READMIT_AFTER
}

impl Default for GateSection {
    fn default() -> Self {
        Self {
            enabled: true,
            probability: default_gate_probability(),
            readmit_after: default_readmit(),
            mode: GateModeName::default(),
            learn: true,
        }
    }
}

pub(crate) fn fixed() -> String {
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
            covariance_interval: default_covariance_interval(),
            smooth_low_scratch: false,
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

/// The error states a run carries: the INS's 15, or 21 with the scale factors
/// (`filter.states`), with the receiver clock (tight coupling), the fixes' persisting
/// error (decided at the start: [`FixErrorPlan::Persisting`]) or the calibration states
/// (`[calibrate]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StateKind {
    /// The calibration states beside the INS's (`[calibrate]`).
    Calibration,
    /// Tight coupling, 15 + the receiver clock.
    Tight15,
    /// Tight coupling with the scale factors.
    Tight21,
    /// The fixes' persisting error beside the 15.
    Persisting15,
    /// The fixes' persisting error beside the 21.
    Persisting21,
    /// The INS's 15.
    Ins15,
    /// The INS's 15 and the scale factors.
    Ins21,
}

impl Config {
    /// The states of a run of this configuration, the fixes' persisting error as states
    /// when `persisting` (the start's plan).
    pub fn state_kind(&self, persisting: bool) -> StateKind {
        let wide = self.filter.states == 21;
        let pick = |narrow, with_scale| if wide { with_scale } else { narrow };
        if self.calibrate.any() {
            StateKind::Calibration
        } else if self.gnss.coupling == Coupling::Tight {
            pick(StateKind::Tight15, StateKind::Tight21)
        } else if persisting {
            pick(StateKind::Persisting15, StateKind::Persisting21)
        } else {
            pick(StateKind::Ins15, StateKind::Ins21)
        }
    }
}
