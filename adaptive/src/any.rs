//! Run-time selection of a strategy by name (for the program and configuration files).

use core::fmt;
use core::str::FromStr;

use estimator_core::{Adaptation, FilterAlloc, FixedNoise, NoiseStrategy, PostUpdate};
use nalgebra::{DefaultAllocator, DimName};

use crate::{
    Afkf, ChiSquareGate, FusedDualWindow, GrossTest, Iae, Iakf, Inflation, RReading, SageHusa,
};

/// Any of the crate's strategies, chosen at run time. Static dispatch by `match`; a filter
/// typed `ErrorStateFilter<X, AnyStrategy>` can run every strategy.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
pub enum AnyStrategy {
    /// [`FixedNoise`].
    Fixed(FixedNoise),
    /// [`Iae`].
    Iae(Iae),
    /// [`Afkf`].
    Afkf(Afkf),
    /// [`FusedDualWindow`].
    Fused(FusedDualWindow),
    /// [`Iakf`].
    Iakf(Iakf),
    /// [`SageHusa`].
    SageHusa(SageHusa),
    /// [`ChiSquareGate`].
    ChiSquareGate(ChiSquareGate),
}

/// `clone_from` refills the strategy in place when both are the same kind (see
/// `clone_in_place!`).
impl Clone for AnyStrategy {
    fn clone(&self) -> Self {
        match self {
            AnyStrategy::Fixed(s) => AnyStrategy::Fixed(*s),
            AnyStrategy::Iae(s) => AnyStrategy::Iae(s.clone()),
            AnyStrategy::Afkf(s) => AnyStrategy::Afkf(s.clone()),
            AnyStrategy::Fused(s) => AnyStrategy::Fused(s.clone()),
            AnyStrategy::Iakf(s) => AnyStrategy::Iakf(s.clone()),
            AnyStrategy::SageHusa(s) => AnyStrategy::SageHusa(s.clone()),
            AnyStrategy::ChiSquareGate(s) => AnyStrategy::ChiSquareGate(s.clone()),
        }
    }

    fn clone_from(&mut self, source: &Self) {
        use AnyStrategy as S;
        match (self, source) {
            (S::Fixed(a), S::Fixed(b)) => a.clone_from(b),
            (S::Iae(a), S::Iae(b)) => a.clone_from(b),
            (S::Afkf(a), S::Afkf(b)) => a.clone_from(b),
            (S::Fused(a), S::Fused(b)) => a.clone_from(b),
            (S::Iakf(a), S::Iakf(b)) => a.clone_from(b),
            (S::SageHusa(a), S::SageHusa(b)) => a.clone_from(b),
            (S::ChiSquareGate(a), S::ChiSquareGate(b)) => a.clone_from(b),
            (this, source) => *this = source.clone(),
        }
    }
}

/// The names [`AnyStrategy::from_str`] accepts.
pub const STRATEGY_NAMES: [&str; 18] = [
    "fixed",
    "iae",
    "iae-qr",
    "iae-qr-faithful",
    "afkf",
    "afkf-xia",
    "afkf-faithful",
    "afkf-xia-faithful",
    "fused",
    "fused-faithful",
    "fused-nominal",
    "fused-window-test",
    "fused-uncensored",
    "fused-nominal-uncensored",
    "iakf",
    "iakf-raw",
    "sage-husa",
    "chi2-gate",
];

/// An unknown strategy name.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownStrategy(pub String);

impl fmt::Display for UnknownStrategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown strategy `{}`; choose one of: {}", self.0, STRATEGY_NAMES.join(", "))
    }
}

impl std::error::Error for UnknownStrategy {}

impl FromStr for AnyStrategy {
    type Err = UnknownStrategy;

    /// `fixed`, `iae` (R only; also `iae-r`), `iae-qr` (Q and R: the paper's IAE
    /// baseline), `afkf` (λ on all of `P⁻`), `afkf-xia` (Xia's: λ on `Φ P Φᵀ` only), `fused` (the cumulative reading; also `fused-cumulative`) and its
    /// other readings (`fused-nominal`, `fused-window-test`, `fused-uncensored`,
    /// `fused-nominal-uncensored`; see [`FusedDualWindow`]), `iakf` (EpochScaled inflation, `1/k`; also `iakf-epoch`), `iakf-raw` (Raw),
    /// `sage-husa`, `chi2-gate` (plain χ² gate at α = 0.01); each with its paper defaults.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.trim().to_ascii_lowercase().as_str() {
            "fixed" | "kf" => AnyStrategy::Fixed(FixedNoise),
            "iae" | "iae-r" => AnyStrategy::Iae(Iae::default()),
            "iae-qr" => AnyStrategy::Iae(Iae::default().with_q_adaptation()),
            "afkf" => AnyStrategy::Afkf(Afkf::default()),
            "afkf-xia" => AnyStrategy::Afkf(Afkf::default().xia()),
            "afkf-faithful" => AnyStrategy::Afkf(Afkf::default().faithful()),
            "afkf-xia-faithful" => AnyStrategy::Afkf(Afkf::default().xia().faithful()),
            "fused-faithful" => AnyStrategy::Fused(FusedDualWindow::default().faithful()),
            "iae-qr-faithful" => AnyStrategy::Iae(Iae::default().with_q_adaptation().faithful()),
            "fused" | "fused-cumulative" => AnyStrategy::Fused(FusedDualWindow::default()),
            "fused-nominal" => {
                AnyStrategy::Fused(FusedDualWindow::default().with_r_reading(RReading::Nominal))
            }
            "fused-window-test" => {
                AnyStrategy::Fused(FusedDualWindow::default().with_gross_test(GrossTest::Window))
            }
            "fused-uncensored" => {
                AnyStrategy::Fused(FusedDualWindow::default().with_refused_in_windows(true))
            }
            "fused-nominal-uncensored" => AnyStrategy::Fused(
                FusedDualWindow::default()
                    .with_r_reading(RReading::Nominal)
                    .with_refused_in_windows(true),
            ),
            "iakf" | "iakf-epoch" => AnyStrategy::Iakf(Iakf::default()),
            "iakf-raw" => AnyStrategy::Iakf(Iakf::new(0.05, Inflation::Raw)),
            "sage-husa" | "sagehusa" | "akf" => AnyStrategy::SageHusa(SageHusa::default()),
            "chi2-gate" => AnyStrategy::ChiSquareGate(ChiSquareGate::default()),
            _ => return Err(UnknownStrategy(s.to_string())),
        })
    }
}

impl Default for AnyStrategy {
    fn default() -> Self {
        AnyStrategy::Fixed(FixedNoise)
    }
}

macro_rules! dispatch {
    ($self:ident, $s:ident => $e:expr) => {
        match $self {
            AnyStrategy::Fixed($s) => $e,
            AnyStrategy::Iae($s) => $e,
            AnyStrategy::Afkf($s) => $e,
            AnyStrategy::Fused($s) => $e,
            AnyStrategy::Iakf($s) => $e,
            AnyStrategy::SageHusa($s) => $e,
            AnyStrategy::ChiSquareGate($s) => $e,
        }
    };
}

impl NoiseStrategy for AnyStrategy {
    fn name(&self) -> &'static str {
        dispatch!(self, s => NoiseStrategy::<f64>::name(s))
    }

    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        dispatch!(self, s => s.adapt(a))
    }

    fn prediction_fading(&self) -> f64 {
        dispatch!(self, s => NoiseStrategy::<f64>::prediction_fading(s))
    }

    fn tracks_process_noise(&self) -> bool {
        dispatch!(self, s => NoiseStrategy::<f64>::tracks_process_noise(s))
    }

    fn after_update<N: DimName, M: DimName>(&mut self, p: &mut PostUpdate<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        dispatch!(self, s => s.after_update(p))
    }
}
