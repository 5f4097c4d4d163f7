//! What keeps a fading (or process-noise) adaptation from running away on a model it does
//! not suit: adapt only when the innovations say the filter is over-confident, and stop
//! when adapting does not make them smaller.

use estimator_core::consistency::chi2_quantile;
use estimator_core::{Adaptation, FilterAlloc};
use nalgebra::{DefaultAllocator, DimName};

use crate::gate::{whiten, WHITE_DIMS};

/// What the guard reads of one epoch: the nominal NIS, `|r|² / tr R` with the declared
/// `R` (the innovation's size in the measurement's own units, which no scaling of the
/// prior changes), and the whitened innovation `L⁻¹ r` (`S = L Lᵀ`, nominal; the gate's
/// own whitening, for streams of up to [`WHITE_DIMS`] rows).
pub(crate) struct Epoch {
    nis: f64,
    raw: f64,
    white: [f64; WHITE_DIMS],
    whitened: bool,
}

impl Epoch {
    pub(crate) fn of<N: DimName, M: DimName>(a: &Adaptation<'_, N, M>) -> Self
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let raw = a.innovation.norm_squared() / a.R_nominal.trace();
        let mut white = [0.0; WHITE_DIMS];
        let whitened =
            whiten(a.S, a.innovation, &mut white).is_some_and(|w| w.iter().all(|v| v.is_finite()));
        Self { nis: a.nis, raw, white, whitened }
    }
}

/// The guard's judgement on one epoch of one stream.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Judgement {
    /// The window's innovations are consistent with `S`: use the nominal prior.
    Consistent,
    /// Significantly too large, and adapting is (still) allowed.
    Adapt,
    /// Adapting has run for a whole window without making the innovations smaller: the
    /// adaptation is not helping and is held off until the stream is consistent again.
    NotHelping,
}

/// A fading guard: three tests on a window of the stream's innovations (with the nominal,
/// un-adapted `S`).
///
/// - **Significance.** The window's mean NIS per degree of freedom,
///   `μ = Σ NISⱼ / (n m)`, is `χ²(n m)/(n m)` for a consistent filter. The strategy adapts
///   only while `μ` exceeds that distribution's `1 − alpha` quantile (default
///   `alpha = 0.01`: a consistent stream is adapted on 1 % of its epochs). An estimate of
///   a fading factor from 20 innovations of noise scatters widely (on the attitude
///   campaign the unguarded AFKF inflated a consistent filter's prior on half of its
///   epochs); the test adapts only to a mismatch the window can tell from noise.
/// - **A state error, not noise.** Inflating `P⁻` is the cure for a prior that is wrong
///   (a model that misses a motion, a `Q` too small); such an error persists from one
///   update to the next, so successive whitened innovations `wⱼ = L⁻¹ rⱼ` (`S = L Lᵀ`)
///   correlate. Noise larger than declared is white. The strategy adapts only while the
///   window's lag-one correlation `Σ wⱼ·wⱼ₋₁ / Σ |wⱼ|²` exceeds the `1 − alpha` point of
///   its distribution for white innovations, `z_{1−α} / √(n m)` (normal approximation;
///   0.30 for 20 three-dimensional innovations at α = 0.01). A stream of more than 16
///   rows is judged without this test.
/// - **Helping.** Once adapting, the window is judged again after `n` epochs (a window
///   wholly inside the adaptation): if the innovations' own size, `ρ = mean |r|²/tr R`
///   (with the declared `R`: not the NIS, which an inflated `P⁻` lowers by itself), has not
///   fallen to half of what it was when adapting began, the adaptation is not helping — the
///   innovations are large for a reason inflating `P⁻` does not cure (noise larger than
///   declared, read as model mismatch: the AFKF then trusts the noisy measurement more,
///   and on the attitude campaign's magnetic disturbance drove the attitude 15–90° off).
///   The strategy is held at the nominal prior and says so (`not_helping` in the report)
///   until a whole window of epochs in a row is consistent again (a window that flickers
///   about the quantile neither restarts the test nor re-arms the strategy).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FadingGuard {
    /// Probability that a consistent window is taken for a mismatch. Default 0.01.
    pub alpha: f64,
}

impl Default for FadingGuard {
    fn default() -> Self {
        Self { alpha: 0.01 }
    }
}

/// Per stream: the last NIS values and the guard's phase.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
pub(crate) struct GuardStream {
    nis: Vec<f64>,
    /// `|r|² / tr R` of the same epochs.
    raw: Vec<f64>,
    /// `wⱼ·wⱼ₋₁` and `|wⱼ|²` of the same epochs (whitened innovations), and `wⱼ` itself.
    dots: Vec<f64>,
    norms: Vec<f64>,
    last_white: Vec<f64>,
    next: usize,
    len: usize,
    phase: Phase,
    /// `χ²_{1−α}(d)/d` for `d = 1 … capacity · m`, filled as needed (NaN until then).
    quantiles: Vec<f64>,
}

clone_in_place!(GuardStream { nis, raw, dots, norms, last_white, next, len, phase, quantiles });

#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    Idle,
    /// Adapting for `epochs` epochs, since the window's mean `|r|²/tr R` was `rho0`;
    /// `calm` consistent epochs in a row.
    Adapting {
        epochs: usize,
        rho0: f64,
        calm: usize,
    },
    /// Held off; `calm` consistent epochs in a row.
    NotHelping {
        calm: usize,
    },
}

impl GuardStream {
    /// A stream with a window of `capacity` NIS values of an `m`-dimensional measurement.
    pub(crate) fn new(capacity: usize, m: usize) -> Self {
        let capacity = capacity.max(1);
        Self {
            nis: vec![0.0; capacity],
            raw: vec![0.0; capacity],
            dots: vec![0.0; capacity],
            norms: vec![0.0; capacity],
            last_white: Vec::with_capacity(m.min(WHITE_DIMS)),
            next: 0,
            len: 0,
            phase: Phase::Idle,
            quantiles: vec![f64::NAN; capacity * m.max(1) + 1],
        }
    }

    fn quantile(&mut self, dof: usize, alpha: f64) -> f64 {
        match self.quantiles.get_mut(dof) {
            Some(q) => {
                if q.is_nan() {
                    *q = chi2_quantile(1.0 - alpha, dof as f64) / dof as f64;
                }
                *q
            }
            None => chi2_quantile(1.0 - alpha, dof as f64) / dof as f64,
        }
    }

    /// Take one epoch and judge the stream.
    pub(crate) fn judge(&mut self, guard: &FadingGuard, e: &Epoch, m: usize) -> Judgement {
        let (nis, raw) = (e.nis, e.raw);
        if !(nis.is_finite() && raw.is_finite()) {
            return Judgement::Consistent;
        }
        let cap = self.nis.len();
        self.nis[self.next] = nis;
        self.raw[self.next] = raw;
        // lag one: this whitened innovation against the previous one
        let white = &e.white[..m.min(WHITE_DIMS)];
        let correlates = e.whitened && m <= WHITE_DIMS;
        let dot = if correlates && self.last_white.len() == white.len() {
            white.iter().zip(&self.last_white).map(|(a, b)| a * b).sum()
        } else {
            0.0
        };
        self.dots[self.next] = dot;
        self.norms[self.next] = white.iter().map(|v| v * v).sum();
        self.last_white.clear();
        if correlates {
            self.last_white.extend_from_slice(white);
        }
        self.next = (self.next + 1) % cap;
        self.len = (self.len + 1).min(cap);
        let dof = self.len * m.max(1);
        let mu = self.nis[..self.len].iter().sum::<f64>() / dof as f64;
        let limit = self.quantile(dof, guard.alpha);
        let norms = self.norms[..self.len].iter().sum::<f64>();
        let lag_one = self.dots[..self.len].iter().sum::<f64>() / norms;
        // z_{1−α} / √(n m): the white innovations' lag-one correlation exceeds it with
        // probability α
        let white_limit = normal_quantile(1.0 - guard.alpha) / (dof as f64).sqrt();
        let persists = !correlates || lag_one > white_limit;
        let significant = mu > limit && persists;
        let rho = self.raw[..self.len].iter().sum::<f64>() / self.len as f64;
        // a phase ends only after a whole window of consistent epochs: a window that
        // flickers about the quantile neither restarts the helping test nor re-arms a
        // strategy held off
        let calm_after = |calm: usize| if significant { 0 } else { calm + 1 };
        self.phase = match self.phase {
            Phase::Idle if significant => Phase::Adapting { epochs: 0, rho0: rho, calm: 0 },
            Phase::Idle => Phase::Idle,
            Phase::Adapting { epochs, rho0, calm } => {
                let (epochs, calm) = (epochs + 1, calm_after(calm));
                if calm >= cap {
                    Phase::Idle
                } else if epochs < cap {
                    Phase::Adapting { epochs, rho0, calm }
                } else if rho <= 0.5 * rho0 {
                    // improving: judged again after another window
                    Phase::Adapting { epochs: 0, rho0: rho, calm }
                } else {
                    Phase::NotHelping { calm }
                }
            }
            Phase::NotHelping { calm } => {
                let calm = calm_after(calm);
                if calm >= cap {
                    Phase::Idle
                } else {
                    Phase::NotHelping { calm }
                }
            }
        };
        match self.phase {
            Phase::NotHelping { .. } => Judgement::NotHelping,
            Phase::Adapting { .. } if significant => Judgement::Adapt,
            _ => Judgement::Consistent,
        }
    }
}

/// The standard normal's quantile, from the χ² of one degree of freedom:
/// `z_p² = χ²_{2p−1}(1)` for `p > ½`.
fn normal_quantile(p: f64) -> f64 {
    if p <= 0.5 {
        return 0.0;
    }
    chi2_quantile(2.0 * p - 1.0, 1.0).sqrt()
}
