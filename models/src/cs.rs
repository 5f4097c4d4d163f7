//! The variance law of the current statistical model and the membership-function
//! adaptation of its acceleration limits (paper `cs-maekf-ahrs`, section 2).
//!
//! Modified Rayleigh law (Zhou & Kumar 1984): for a current mean acceleration `ā`,
//!
//! ```text
//! σ_a² = (4 − π)/π · (a_max − ā)²     ā > 0
//! σ_a² = (4 − π)/π · (a_−max − ā)²    ā < 0        (a_−max < 0)
//! ```
//!
//! The paper adapts `a_max`, `a_−max` each step with a Gaussian membership function of
//! `ā`. **The extracted text lost both formulas**; this is our reconstruction (as
//! `ALGORITHMS.md` §4 prescribes), kept swappable through [`Membership`] and
//! [`LimitRule`]:
//!
//! ```text
//! M(ā) = 1 − exp(−ā²/k)            k = k₁ for ā ≥ 0, k₂ otherwise      (small near 0, → 1)
//! a_max(ā)  = |ā| + M(ā)·(a_th  − |ā|)                                 ā ≥ 0
//! a_−max(ā) = −(|ā| + M(ā)·(|a_−th| − |ā|))                            ā < 0
//! σ_a² ← max(σ_a², floor)        so that a maneuver onset can still be followed
//! ```
//!
//! Paper values: `k₁ = k₂ = 23` (useful range 20–25), `a_th = 10`, `a_−th = −10` m/s².

use core::f64::consts::PI;
#[cfg(feature = "std")]
use std::sync::Arc;

// without `std`, `exp` and `powi` are nalgebra's (libm)
#[cfg(not(feature = "std"))]
use nalgebra::ComplexField as _;

/// How [`CsVariance`] holds its membership function and limit rule: shared (`Arc`) with
/// the standard library; a `&'static` reference without it (no allocator), e.g.
/// `&DEFAULT_MEMBERSHIP`.
#[cfg(feature = "std")]
pub type Shared<T> = Arc<T>;
/// How [`CsVariance`] holds its membership function and limit rule: shared (`Arc`) with
/// the standard library; a `&'static` reference without it (no allocator), e.g.
/// `&DEFAULT_MEMBERSHIP`.
#[cfg(not(feature = "std"))]
pub type Shared<T> = &'static T;

/// The paper's membership function, `k₁ = k₂ = 23` (what `GaussianMembership::default()`
/// gives).
pub static DEFAULT_MEMBERSHIP: GaussianMembership = GaussianMembership { k_pos: 23.0, k_neg: 23.0 };
/// The paper's limit rule, `a_th = ±10 m/s²` (what `InterpolatedLimits::default()` gives).
pub static DEFAULT_LIMITS: InterpolatedLimits = InterpolatedLimits { a_th: 10.0, a_neg_th: -10.0 };

/// A membership grade `M(ā) ∈ [0, 1]`.
pub trait Membership: Send + Sync + core::fmt::Debug {
    /// The grade of the current mean acceleration `abar` (m/s²).
    fn grade(&self, abar: f64) -> f64;
}

/// The acceleration limits `(a_max, a_−max)` from `ā` and its membership grade.
pub trait LimitRule: Send + Sync + core::fmt::Debug {
    /// `(a_max > 0, a_−max < 0)`, m/s².
    fn limits(&self, abar: f64, grade: f64) -> (f64, f64);
}

/// `M(ā) = 1 − exp(−ā²/k)`, with `k = k_pos` for `ā ≥ 0` and `k_neg` otherwise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianMembership {
    /// Width for positive ā, (m/s²)². Paper: 23.
    pub k_pos: f64,
    /// Width for negative ā. Paper: 23.
    pub k_neg: f64,
}

impl Default for GaussianMembership {
    fn default() -> Self {
        DEFAULT_MEMBERSHIP
    }
}

impl Membership for GaussianMembership {
    fn grade(&self, abar: f64) -> f64 {
        let k = if abar >= 0.0 { self.k_pos } else { self.k_neg };
        1.0 - (-abar * abar / k.max(f64::MIN_POSITIVE)).exp()
    }
}

/// Interpolate between the current acceleration and the thresholds by the grade.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InterpolatedLimits {
    /// Upper threshold `a_th` > 0, m/s². Paper: 10.
    pub a_th: f64,
    /// Lower threshold `a_−th` < 0, m/s². Paper: −10.
    pub a_neg_th: f64,
}

impl Default for InterpolatedLimits {
    fn default() -> Self {
        DEFAULT_LIMITS
    }
}

impl LimitRule for InterpolatedLimits {
    fn limits(&self, abar: f64, grade: f64) -> (f64, f64) {
        let m = abar.abs();
        (m + grade * (self.a_th - m).max(0.0), -(m + grade * (self.a_neg_th.abs() - m).max(0.0)))
    }
}

/// A second reading of the paper's rule: the limits move from the "probable range"
/// `[a_−up, a_up]` (paper §2: `a_th > a_up`, `a_−th < a_−up`) towards the thresholds as
/// the grade grows: `a_max = a_up + M(ā)(a_th − a_up)`, mirrored for negative `ā`. At
/// `ā = 0` the limit is `a_up`, not 0, so the filter keeps enough noise to follow a
/// maneuver onset. The paper's `a_up` value was lost with its formulas.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RangeLimits {
    /// `a_up` > 0, m/s².
    pub a_up: f64,
    /// `a_−up` < 0, m/s².
    pub a_neg_up: f64,
    /// `a_th` > `a_up`, m/s².
    pub a_th: f64,
    /// `a_−th` < `a_−up`, m/s².
    pub a_neg_th: f64,
}

impl LimitRule for RangeLimits {
    fn limits(&self, _abar: f64, grade: f64) -> (f64, f64) {
        (
            self.a_up + grade * (self.a_th - self.a_up),
            self.a_neg_up + grade * (self.a_neg_th - self.a_neg_up),
        )
    }
}

/// Fixed limits (the plain CS model without adaptation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedLimits {
    /// `a_max`, m/s².
    pub a_max: f64,
    /// `a_−max` (< 0), m/s².
    pub a_neg_max: f64,
}

impl LimitRule for FixedLimits {
    fn limits(&self, _abar: f64, _grade: f64) -> (f64, f64) {
        (self.a_max, self.a_neg_max)
    }
}

/// The CS variance law with a membership function and a limit rule (shared, so the law
/// clones cheaply).
#[derive(Clone, Debug)]
pub struct CsVariance {
    /// Membership function.
    pub membership: Shared<dyn Membership>,
    /// Limit rule.
    pub limits: Shared<dyn LimitRule>,
    /// Lower bound on σ_a², (m/s²)².
    pub floor: f64,
}

impl Default for CsVariance {
    /// The paper's values (k₁ = k₂ = 23, a_th = ±10 m/s²) with our reconstruction and a
    /// floor of 1 (m/s²)². The floor matters: with this reconstruction `σ_a² → 0` as
    /// `ā → 0`, and on the loitering flight (`cargo run --release -p models --example
    /// cs_readings`, 10 seeds) a floor of 0.01 gives max roll/pitch/yaw errors of
    /// 12.4/10.9/28.3°, 0.1 gives 8.2/6.6/18.2°, 1 gives 4.06/3.59/7.41° (the modified
    /// filter: 4.06/3.29/7.30°).
    fn default() -> Self {
        #[cfg(feature = "std")]
        let (membership, limits): (Shared<dyn Membership>, Shared<dyn LimitRule>) =
            (Arc::new(DEFAULT_MEMBERSHIP), Arc::new(DEFAULT_LIMITS));
        #[cfg(not(feature = "std"))]
        let (membership, limits): (Shared<dyn Membership>, Shared<dyn LimitRule>) =
            (&DEFAULT_MEMBERSHIP, &DEFAULT_LIMITS);
        Self { membership, limits, floor: 1.0 }
    }
}

impl CsVariance {
    /// `σ_a²(ā)` with adapted limits and the floor.
    pub fn variance(&self, abar: f64) -> f64 {
        let m = self.membership.grade(abar);
        let (hi, lo) = self.limits.limits(abar, m);
        let edge = if abar >= 0.0 { hi } else { lo };
        ((4.0 - PI) / PI * (edge - abar).powi(2)).max(self.floor)
    }
}
