//! The RTK filter's settings and their defaults.

use super::super::spp::{Ionosphere, SppOptions, Troposphere};

/// The variance (cycles²) of a held fix's double-differenced ambiguities as measurements
/// ([`RtkOptions::hold`]; RTKLIB's `VAR_HOLDAMB`).
pub const HOLD_VARIANCE: f64 = 0.001;

/// The least bootstrapped success rate of the float ambiguities for a fix to be held
/// ([`RtkOptions::hold`]): a fix the ratio test passes on a covariance that promises less
/// is used, not held. On the simulated drives, single frequency, holding every fix the
/// ratio test passed (after 5 in a row) turned 27 wrong fixes into 452.
pub const HOLD_SUCCESS_RATE: f64 = 0.999;

/// The σ (m) a new single-differenced ambiguity starts with.
pub const AMBIGUITY_SIGMA0: f64 = 30.0;

/// The σ (m) the rover's position restarts with each epoch in kinematic mode (around its
/// single point) and starts with in static mode.
pub const POSITION_SIGMA0: f64 = 30.0;

/// How the rover moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RtkMode {
    /// It does not: the position is a constant state.
    Static,
    /// Anyhow: the position restarts each epoch from the single point.
    Kinematic,
}

/// The solution's settings.
#[derive(Clone, Debug)]
pub struct RtkOptions {
    /// Static or kinematic.
    pub mode: RtkMode,
    /// Frequencies used: 1 (L1) or 2 (L1 and L2).
    pub frequencies: usize,
    /// Elevation mask at the base, rad.
    pub elevation_mask: f64,
    /// The ratio test's threshold (RTKLIB's default 3).
    pub ratio: f64,
    /// The least success rate of integer bootstrapping the float ambiguities' covariance
    /// must promise before the ratio test is asked (0: the ratio test alone, as RTKLIB).
    pub min_success_rate: f64,
    /// When all the ambiguities cannot be fixed, fix the largest decorrelated subset that
    /// promises [`min_success_rate`](Self::min_success_rate) (or 0.999 when that is 0) and
    /// passes the ratio test ([`crate::lambda::solve_partial`]). Off by default: on the simulated
    /// drives it fixed single-frequency runs earlier but wrongly more often (RTK alone
    /// 110 → 171 wrong fixes over 20 seeds; with an INS 0 → 9 over 10, `docs/results.md`).
    pub partial: bool,
    /// Phase noise of one receiver, `a + b / sin el` in quadrature, m.
    pub phase_sigma: (f64, f64),
    /// The code's noise over the phase's.
    pub code_over_phase: f64,
    /// σ (m) of each satellite and frequency's single-differenced code bias (the two
    /// receivers' multipath and code biases, persisting from epoch to epoch), a state of
    /// the filter beside the ambiguities; 0: none, the code's errors taken as white.
    pub code_bias_sigma: f64,
    /// The code biases' correlation time (s; a first-order Gauss–Markov process;
    /// infinite: constant).
    pub code_bias_tau: f64,
    /// Fix-and-hold: after this many consecutive fixed epochs, each fix whose float
    /// covariance promised a success rate of [`HOLD_SUCCESS_RATE`] goes back into the float
    /// filter as measurements of its ambiguities (variance [`HOLD_VARIANCE`] cycles²), which
    /// then keep them; with two frequencies only (`None`: never, as RTKLIB's `continuous`
    /// mode).
    pub hold: Option<usize>,
    /// The oldest a base epoch may be against the rover's (s; default 1, RTKLIB's 30): the
    /// satellites' clocks are modelled at each receiver's own transmission time, the
    /// receivers' cancel in the double differences, but what is left grows with the age
    /// (the atmosphere's change over the interval): on the shipped baseline with the base
    /// at half the rover's rate (pairs 30 s apart), kinematic runs fixed 96.7 % of the
    /// epochs with 6 of them more than 10 cm off (`tests/rtk.rs`).
    pub max_age: f64,
    /// The troposphere's model at each receiver (its height and elevation): the double
    /// differences keep what the receivers' heights and elevations make of it, several
    /// centimetres when one of them drives 40 m up a hill.
    pub troposphere: Troposphere,
    /// The single point's settings (the rover's first position, the satellites' states).
    pub spp: SppOptions,
}

/// The least success rate [`RtkOptions::for_frequencies`] asks of a single-frequency fix.
/// On the simulated drives (20 seeds, the code biases as states), single frequency: the
/// ratio test alone 76.4 % fixed with 27 wrong fixes; with 0.99, 75.7 % and 1; with 0.999,
/// 75.1 % and none (the first fix later: median 25 → 162 s). Two frequencies had no wrong
/// fix with the ratio test alone, and asking 0.999 left the shipped baseline's first epoch
/// unfixed.
pub const SINGLE_FREQUENCY_SUCCESS_RATE: f64 = 0.999;

impl RtkOptions {
    /// The defaults for `mode` and `frequencies`: with one frequency a fix must also
    /// promise [`SINGLE_FREQUENCY_SUCCESS_RATE`] (with two, the ratio test alone, as
    /// RTKLIB's).
    pub fn for_frequencies(mode: RtkMode, frequencies: usize) -> Self {
        let min_success_rate = if frequencies == 1 { SINGLE_FREQUENCY_SUCCESS_RATE } else { 0.0 };
        Self { mode, frequencies, min_success_rate, ..Self::default() }
    }
}

impl Default for RtkOptions {
    fn default() -> Self {
        // RTKLIB's single point inside its RTK: the broadcast ionosphere and Saastamoinen's
        // troposphere (the first frequency's code: the satellites' transmission times; the
        // rover's height, where its troposphere is modelled, metres off without them)
        let spp = SppOptions {
            ionosphere: Ionosphere::Klobuchar,
            troposphere: Troposphere::Saastamoinen,
            ..SppOptions::rtklib_default()
        };
        Self {
            mode: RtkMode::Kinematic,
            frequencies: 2,
            elevation_mask: 15f64.to_radians(),
            ratio: 3.0,
            min_success_rate: 0.0,
            partial: false,
            phase_sigma: (0.003, 0.003),
            code_over_phase: 100.0,
            code_bias_sigma: 0.3,
            code_bias_tau: 60.0,
            hold: Some(5),
            max_age: 1.0,
            troposphere: Troposphere::Saastamoinen,
            spp,
        }
    }
}
