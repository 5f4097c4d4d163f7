//! Errors of GNSS fixes that persist over time, as states of the filter.
//!
//! A single-point receiver's position error is not white: ionosphere, troposphere, orbit
//! and multipath errors wander by metres over minutes. A filter that takes each fix as
//! independent averages that wander as if it were noise, and reports a σ that its error
//! leaves behind (DESIGN.md decision 11; the everyday-GNSS issue measured 46–77 % of the
//! epochs beyond the reported 99 % ellipse with the true σ declared). Here the fix error
//! is split into a first-order Gauss–Markov part per NED axis, a state `b`, and white
//! noise `v`:
//!
//! ```text
//! z = p_a ⊕ (b + v),       ḃ = −b/τ + w,   E[w wᵀ] = diag(2σ²/τ)
//! b_{k+1} = e^{−Δt/τ} b_k + w_k,            E[w_k w_kᵀ] = diag(σ² (1 − e^{−2Δt/τ}))
//! ```
//!
//! so the residual is `z ⊖ p̂_a − b̂` and `H = [H_nav, E]`, `E` the identity on the
//! position rows (Brown & Hwang, *Introduction to Random Signals and Applied Kalman
//! Filtering*, 4th ed., §9.3: the augmented state for coloured measurement noise;
//! Groves, *Principles of GNSS, Inertial and Multisensor Integrated Navigation
//! Systems*, 2nd ed., §14.3.1: the GNSS position-error states of loose coupling).
//!
//! [`InsStateFe`] is the 15-state INS with them (18 states), [`InsState21Fe`] the
//! 21-state one (24). The velocity rows of a position + velocity fix are left as they
//! are (a receiver's Doppler velocity has errors of centimetres per second that do not
//! wander).

use crate::augment::augmented_process;
use manifolds::{composite_state, R3};
use nalgebra::{SMatrix, Vector3};

use crate::model::InsModel;
use crate::scale::{InsModel21, InsState21};
use crate::state::InsState;

/// The Gauss–Markov part of the fixes' errors: its steady-state σ per NED axis and its
/// correlation time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixErrorModel {
    /// Steady-state σ of the persisting error, north, east, down, m.
    pub sigma: Vector3<f64>,
    /// Correlation time, s.
    pub tau: f64,
}

impl FixErrorModel {
    /// The decay `e^{−Δt/τ}` of the persisting error over `dt`.
    pub fn decay(&self, dt: f64) -> f64 {
        if self.tau > 0.0 && self.tau.is_finite() {
            (-dt / self.tau).exp()
        } else {
            1.0
        }
    }

    /// The variance its driving noise adds over `dt` per axis, `σ² (1 − e^{−2Δt/τ})`
    /// (exact for the discrete process, whatever `Δt`).
    pub fn added_variance(&self, dt: f64) -> Vector3<f64> {
        let a = self.decay(dt);
        self.sigma.map(|s| s * s * (1.0 - a * a))
    }

    /// Whether the model is usable: finite non-negative σ and a positive correlation time.
    pub fn is_valid(&self) -> bool {
        self.sigma.iter().all(|s| s.is_finite() && *s >= 0.0) && self.tau > 0.0
    }
}

composite_state! {
    /// The 15-state INS state and the persisting error of the GNSS fixes (NED, m): the
    /// nominal state of the 18-state loosely coupled filter. Blocks `NAV` (15), `FIX`.
    pub struct InsStateFe {
        /// Attitude, velocity, position, biases.
        pub nav: InsState => NAV,
        /// The fixes' persisting error (north, east, down), m.
        pub fix: R3 => FIX,
    }
}

composite_state! {
    /// The 21-state INS state (with the scale factors) and the persisting error of the
    /// GNSS fixes: the nominal state of the 24-state loosely coupled filter. Blocks `NAV`
    /// (21), `FIX`.
    pub struct InsState21Fe {
        /// Attitude, velocity, position, biases, scale factors.
        pub nav: InsState21 => NAV,
        /// The fixes' persisting error (north, east, down), m.
        pub fix: R3 => FIX,
    }
}

/// 18×18 matrices of the 15-state error state with the fixes' errors.
pub type M18 = SMatrix<f64, 18, 18>;
/// 24×24 matrices of the 21-state error state with the fixes' errors.
pub type M24 = SMatrix<f64, 24, 24>;

/// The process model of an INS with the fixes' persisting error: the base model on the
/// navigation block, the Gauss–Markov decay on the fix block.
#[derive(Clone, Debug)]
pub struct FixErrorProcess<M> {
    /// The INS model.
    pub base: M,
    /// The fixes' persisting error.
    pub fix: FixErrorModel,
}

/// The 18-state model.
pub type InsModelFe = FixErrorProcess<InsModel>;
/// The 24-state model.
pub type InsModel21Fe = FixErrorProcess<InsModel21>;

augmented_process!(
    InsModelFe,
    InsStateFe,
    fix,
    15,
    3,
    18,
    decay: |m: &InsModelFe, h| Vector3::repeat(m.fix.decay(h)),
    added: |m: &InsModelFe, h| m.fix.added_variance(h)
);
augmented_process!(
    InsModel21Fe,
    InsState21Fe,
    fix,
    21,
    3,
    24,
    decay: |m: &InsModel21Fe, h| Vector3::repeat(m.fix.decay(h)),
    added: |m: &InsModel21Fe, h| m.fix.added_variance(h)
);

/// The initial covariance of the fix block: the model's steady state.
pub fn initial_fix_covariance(model: &FixErrorModel) -> nalgebra::Matrix3<f64> {
    nalgebra::Matrix3::from_diagonal(&model.sigma.map(|s| s * s))
}

/// The fix error's 1σ of a covariance (its `FIX` block's diagonal).
pub fn fix_sigma<const N: usize>(p: &SMatrix<f64, N, N>, start: usize) -> R3 {
    Vector3::new(p[(start, start)], p[(start + 1, start + 1)], p[(start + 2, start + 2)])
        .map(|v| v.max(0.0).sqrt())
}

/// Fix updates over which [`FixSplitLearner`] settles (its gain is the inverse).
pub const SPLIT_WINDOW: f64 = 25.0;

/// Fix updates a [`FixSplitLearner`] waits before it learns (the filter's first fixes
/// pull its start in).
pub const SPLIT_WARM_UP: u64 = 20;

/// How far [`FixSplitLearner`] may raise the declared ratio of the persisting variance to
/// the white one: with the default share (0.9, a ratio of 9), to 90 (σ_b up to 9.5× the
/// white σ). A persisting error is not learned without bound: innovations that keep
/// their direction are also the mark of a state error the filter is still pulling in,
/// and a persisting part grown without bound would keep it from ever being pulled in.
pub const SPLIT_UP: f64 = 10.0;

/// How far [`FixSplitLearner`] may lower the declared ratio: to 0.09 with the default
/// share (σ_b down to 0.3× the white σ).
pub const SPLIT_DOWN: f64 = 1.0;

/// The squared whitened innovation per degree of freedom beyond which a fix is taken for a
/// transient by [`FixSplitLearner::push`] (3σ).
pub const SPLIT_TRANSIENT: f64 = 9.0;

/// Bound on the learned ratio of the persisting variance to the white one, and on the
/// white part's factor, either way.
pub const SPLIT_BOUND: f64 = 1e4;

/// The declared white noise's weight in [`FixSplitLearner::white`], in fixes.
pub const WHITE_PRIOR: f64 = 5.0;

/// Fixes over which [`FixSplitLearner::white`] forgets.
pub const WHITE_WINDOW: f64 = 30.0;

/// The most one fix's `q` counts in [`FixSplitLearner::white`], in units of the factor
/// learned so far.
pub const WHITE_CAP: f64 = 4.0;

/// The fixes whose median `q` raises [`FixSplitLearner::white`] at once when
/// [`WHITE_ATTACK_RATIO`] times above it.
pub const WHITE_ATTACK: usize = 5;

/// How far above [`FixSplitLearner::white`] the median of the last [`WHITE_ATTACK`]
/// fixes' `q` must be to raise it at once: a consistent stream's median of five passes 2
/// one time in a hundred.
pub const WHITE_ATTACK_RATIO: f64 = 2.0;

/// The split of the fixes' error between its persisting part and its white part, learned
/// from the whiteness of the filter's innovations (Mehra 1970, *On the identification of
/// variances and adaptive Kalman filtering*, IEEE TAC 15: a filter whose noise model is
/// right has white innovations). With the white part's variance `r` (declared, scaled by
/// what the gate learned from the residuals) and the persisting part's `σ_b² = κ r`:
///
/// - a `κ` too small leaves the persisting error unmodelled: the filter follows the fixes
///   too little in the long run and too much in the short, and successive innovations
///   point the same way (lag-one autocorrelation above 0);
/// - a `κ` too large takes white noise for a persisting error: the filter's persisting
///   states chase each fix's noise and the next innovation undoes it (below 0).
///
/// Whiteness is judged over the persisting part's time scale, not from one fix to the
/// next (at five fixes a second a persisting error moves too little between two fixes
/// for a lag-one test to see it): `ln κ` moves by the cosine of each whitened position
/// innovation `w_k` with the exponentially weighted mean of those before it,
/// `m_k = β m_{k−1} + (1 − β) w_{k−1}`, `β = e^{−4Δt/τ}` (a memory of a quarter of the
/// correlation time), `ln κ ← ln κ + cos(w_k, m_k) / W`, `W = SPLIT_WINDOW`, from
/// the declared split (`κ₀ = share / (1 − share)`), after [`SPLIT_WARM_UP`] fixes, on fixes
/// the gate did not refuse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixSplitLearner {
    /// `ln κ` less its prior's.
    log_factor: f64,
    /// Forgotten sum of the white part's per-fix `q` and its weight (the declared noise's
    /// prior included).
    white: (f64, f64),
    /// The last [`WHITE_ATTACK`] fixes' `q` (NaN where none yet), oldest first.
    recent: [f64; WHITE_ATTACK],
    /// The weighted mean of the past fixes' whitened position innovations.
    last: Option<Vector3<f64>>,
    /// Fixes seen.
    seen: u64,
    /// Forgotten sum of the lag-one products per degree of freedom, and its weight: the
    /// innovations' lag-one autocorrelation (for the summary).
    lag: (f64, f64),
}

impl Default for FixSplitLearner {
    fn default() -> Self {
        Self {
            log_factor: 0.0,
            white: (WHITE_PRIOR, WHITE_PRIOR),
            recent: [f64::NAN; WHITE_ATTACK],
            last: None,
            seen: 0,
            lag: (0.0, 0.0),
        }
    }
}

impl FixSplitLearner {
    /// A learner whose white factor starts at `factor` (bounded to
    /// `[1/SPLIT_BOUND, SPLIT_BOUND]`; not finite or not positive: 1).
    pub fn with_white_prior(factor: f64) -> Self {
        let f = if factor.is_finite() && factor > 0.0 {
            factor.clamp(1.0 / SPLIT_BOUND, SPLIT_BOUND)
        } else {
            1.0
        };
        Self { white: (WHITE_PRIOR * f, WHITE_PRIOR), ..Self::default() }
    }

    /// The factor learned on the declared ratio `κ₀` of the persisting variance to the
    /// white one.
    pub fn factor(&self) -> f64 {
        self.log_factor.exp()
    }

    /// Fixes seen.
    pub fn fixes(&self) -> u64 {
        self.seen
    }

    /// The white part's variance factor `λ` on its declared share: the residual-based fixed point of covariance matching
    /// (Mohamed & Schwarz 1999; the gate's learner, `adaptive`), the mean of the per-fix
    /// `q = λ (λ uᵀ R_w u + tr(S⁻¹ HP⁻Hᵀ)) / 3`, `S = HP⁻Hᵀ + λ R_w`, `u = S⁻¹ ν`, whose
    /// expectation is the true factor when `λ` is, forgotten over [`WHITE_WINDOW`] fixes,
    /// from the declared noise worth [`WHITE_PRIOR`] fixes; bounded to
    /// `[1/SPLIT_BOUND, SPLIT_BOUND]`.
    pub fn white(&self) -> f64 {
        self.learned_white()
    }

    /// [`white`](Self::white): the factor the next `q` is computed at.
    pub fn learned_white(&self) -> f64 {
        (self.white.0 / self.white.1).clamp(1.0 / SPLIT_BOUND, SPLIT_BOUND)
    }

    /// Learn the white part's scale from one fix's `q` (see [`white`](Self::white);
    /// `None`: refused by the gate).
    pub fn push_white(&mut self, q: Option<f64>) {
        if let Some(q) = q.filter(|q| q.is_finite() && *q >= 0.0) {
            let rho = 1.0 - 1.0 / WHITE_WINDOW;
            // bounded influence: one fix moves the factor by at most (WHITE_CAP − 1) /
            // WHITE_WINDOW of itself, so a gross error the gate refused leaves little,
            // and a stream whose noise is far too small is followed within tens of fixes
            let capped = q.min(WHITE_CAP * self.learned_white());
            self.white = (rho * self.white.0 + capped, rho * self.white.1 + 1.0);
            // fast attack: when the last WHITE_ATTACK fixes say the noise is much larger
            // than learned, their median stands (one gross error never moves a median)
            self.recent.rotate_left(1);
            self.recent[WHITE_ATTACK - 1] = q;
            let mut r = self.recent;
            if r.iter().all(|v| !v.is_nan()) {
                r.sort_by(f64::total_cmp);
                let median = r[WHITE_ATTACK / 2].min(SPLIT_BOUND);
                if median > WHITE_ATTACK_RATIO * self.learned_white() {
                    self.white.0 = median * self.white.1;
                }
            }
        }
    }

    /// The whitened innovations' lag-one autocorrelation, forgotten over
    /// [`SPLIT_WINDOW`] fixes (0 before a pair).
    pub fn lag_one(&self) -> f64 {
        if self.lag.1 > 0.0 {
            self.lag.0 / self.lag.1
        } else {
            0.0
        }
    }

    /// Learn from one fix's whitened position innovation (`None`: not available), with
    /// `memory` the decay per fix of the past innovations' weighted mean (see the type).
    /// An innovation beyond [`SPLIT_TRANSIENT`] per degree of freedom is a transient (the
    /// filter's state or the white part's scale still far off), which says nothing of
    /// the split: it is left out.
    pub fn push(&mut self, white: Option<Vector3<f64>>, memory: f64) {
        self.seen += 1;
        let Some(w) = white.filter(|w| {
            w.iter().all(|v| v.is_finite()) && w.norm_squared() <= 3.0 * SPLIT_TRANSIENT
        }) else {
            return;
        };
        if let Some(m) = self.last.filter(|m| m.norm() > 0.0) {
            // the cosine of the innovation with its predecessors' weighted mean: bounded,
            // and as noisy for a stream whose noise is still far off as for one whose
            // noise is right
            let c = w.dot(&m) / (w.norm() * m.norm()).max(1e-300);
            let rho = 1.0 - 1.0 / SPLIT_WINDOW;
            self.lag = (rho * self.lag.0 + c, rho * self.lag.1 + 1.0);
            if self.seen > SPLIT_WARM_UP {
                self.log_factor =
                    (self.log_factor + c / SPLIT_WINDOW).clamp(-SPLIT_DOWN.ln(), SPLIT_UP.ln());
            }
        }
        let m = self.last.unwrap_or_else(Vector3::zeros);
        self.last = Some(m * memory + w * (1.0 - memory));
    }
}
