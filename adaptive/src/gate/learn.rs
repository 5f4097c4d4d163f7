//! The noise each stream's innovations show, learned online behind the gate: the declared
//! `R` is a prior, not a fact (DESIGN.md decision 11).
//!
//! Per stream, a variance factor `λ` on the declared `R₀` (`R = λ R₀`) is estimated by
//! the residual-based fixed point of covariance matching (Mohamed & Schwarz 1999; the
//! scalar inverse-gamma reading of Särkkä & Nummenmaa 2009 with one iteration per update):
//! for an update with the applied noise `R = c R₀` and `S = HP⁻Hᵀ + R`, the post-fit
//! residual `ε = R S⁻¹ r` and the posterior's `HP⁺Hᵀ = HP⁻Hᵀ S⁻¹ R` give
//!
//! `q = tr(R₀⁻¹ (ε εᵀ + HP⁺Hᵀ)) / m = c (uᵀ R u + tr(S⁻¹ HP⁻Hᵀ)) / m`, `u = S⁻¹ r`,
//!
//! whose expectation is `λ` when `R = λ R₀` is the stream's noise. `λ̂` is the mean of `q`
//! with exponential forgetting over [`LEARN_WINDOW`] updates, starting from the prior
//! `λ = 1` held as [`PRIOR_WEIGHT`] updates' worth (forgotten like the data). Only the
//! updates the gate passes at the learned scale feed it, so gross errors never do.
//!
//! What is learned is applied as far as the innovations' whiteness allows. Errors that
//! persist over minutes (a single-point receiver's, an RTK solution's) leave innovations
//! smaller than the error itself — the filter follows them — and correlated from one
//! update to the next; a noise learned all the way down from them makes the reported σ
//! overconfident. So the declared σ is trusted within a factor of what the data show:
//! for white innovations (lag-one autocorrelation up to [`WHITE_LAG`]) it is raised
//! exactly to what they show and lowered only when they show it more than [`TRUST_DOWN`]×
//! too large, to [`TRUST_DOWN`]× what they show; for correlated ones (from
//! [`CORRELATED`]) it is kept within [`TRUST`]× either way; linear between. The
//! autocorrelation starts from the prior "correlated" (`LAG_PRIOR` updates' worth).
//!
//! Measured (`cargo run --release --features campaigns --example everyday_noise`, 20 seeds of the simulated
//! drive, `docs/history/results.md`): white fixes declared 0.1×, 3×, 10× and 30× their σ go from
//! 7.01, 0.75, 1.57 and 3.79 m to 1.60, 0.66, 0.74 and 1.89 m (0.62 m with the true σ);
//! wandering fixes keep their coverage (46.0 % beyond the 99 % ellipse with the true σ
//! declared, on and off: that needs the errors as states). On the shipped RTK data no
//! figure moves by more than 0.6 % (`python3 benches/learned_noise.py`).

use super::*;

/// Updates over which the learned factor forgets (`ρ = 1 − 1/LEARN_WINDOW`).
pub const LEARN_WINDOW: f64 = 100.0;

/// The declared noise's weight in the learned factor at the start, in updates.
pub(super) const PRIOR_WEIGHT: f64 = 5.0;

/// Updates a stream's learned factor must have seen before it is applied.
pub(super) const LEARN_MIN: f64 = 20.0;

/// The weight of the prior "correlated" in the lag-one autocorrelation, in updates.
pub(super) const LAG_PRIOR: f64 = 20.0;

/// How far (σ ratio) the declared noise is trusted above what the data show when the
/// innovations are correlated from one update to the next (lag-one autocorrelation
/// [`CORRELATED`] or more).
pub const TRUST: f64 = 5.0;

/// Lag-one autocorrelation of the whitened innovations up to which they are taken for
/// white (the declared noise is then not trusted above what they show).
pub const WHITE_LAG: f64 = 0.3;

/// Lag-one autocorrelation from which the innovations are taken for correlated (the
/// declared noise is then trusted up to [`TRUST`]× what they show).
pub const CORRELATED: f64 = 0.6;

/// How far (σ ratio) the declared noise is trusted above what white innovations show:
/// a stream is lowered only when its data show it more than this much too large (a
/// static start's RTK fixes show σ about half their declared one for half a minute, and
/// following them changed drive-0708 `aided.toml`'s outage score by +4 %).
pub const TRUST_DOWN: f64 = 2.0;

/// How correlated innovations with a lag-one autocorrelation `rho` are: 0 up to
/// [`WHITE_LAG`], 1 from [`CORRELATED`], linear between.
pub(super) fn correlation_weight(rho: f64) -> f64 {
    ((rho - WHITE_LAG) / (CORRELATED - WHITE_LAG)).clamp(0.0, 1.0)
}

/// One stream's learned variance factor.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug)]
pub(super) struct Learned {
    /// Forgotten sum of `q` (the prior's included).
    sum: f64,
    /// Forgotten weight (the prior's included).
    weight: f64,
    /// Updates seen.
    seen: u64,
    /// Forgotten sums of successive whitened innovations' dot products and of the two
    /// sides' squared norms: `Σ a·b / √(Σ|a|² Σ|b|²)` is the innovations' lag-one
    /// autocorrelation (in [−1, 1] by Cauchy–Schwarz).
    lag: (f64, f64, f64),
}

impl Default for Learned {
    fn default() -> Self {
        Self { sum: PRIOR_WEIGHT, weight: PRIOR_WEIGHT, seen: 0, lag: (0.0, 0.0, 0.0) }
    }
}

impl Learned {
    /// `λ̂`, the variance factor the data show on the declared `R`.
    pub(super) fn factor(&self) -> f64 {
        self.sum / self.weight
    }

    /// Updates seen.
    pub(super) fn seen(&self) -> u64 {
        self.seen
    }

    /// The factor applied on the declared `R` (1 until [`LEARN_MIN`] updates): the
    /// declared noise is trusted within a factor (σ) of what the data show — up to
    /// [`TRUST_DOWN`]× above and exactly below for white innovations, [`TRUST`]× either
    /// way for correlated ones ([`correlation_weight`]): `λ̂ T↓²` when that is below 1,
    /// `λ̂ / T↑²` when that is above 1, else 1.
    pub(super) fn applied(&self) -> f64 {
        if (self.seen as f64) < LEARN_MIN {
            return 1.0;
        }
        let l = self.factor();
        let w = correlation_weight(self.lag_one());
        let down = (TRUST_DOWN + (TRUST - TRUST_DOWN) * w).powi(2);
        let up = (1.0 + (TRUST - 1.0) * w).powi(2);
        if l * down < 1.0 && (self.seen as f64) >= LEARN_WINDOW {
            (l * down).max(1.0 / MAX_R_FACTOR)
        } else if l > up {
            (l / up).min(MAX_R_FACTOR)
        } else {
            1.0
        }
    }

    /// The innovations' lag-one autocorrelation (0 before any pair).
    pub(super) fn lag_one(&self) -> f64 {
        let d = (self.lag.1 * self.lag.2).sqrt();
        if d > 0.0 {
            self.lag.0 / d
        } else {
            0.0
        }
    }

    /// Learn from one update's `q` and its whitened innovation's pair with the one before
    /// (`(dot, its squared norm, the one before's)`; `None` when the one before was not
    /// learned from).
    pub(super) fn push(&mut self, q: f64, pair: Option<(f64, f64, f64)>) {
        if !q.is_finite() || q < 0.0 {
            return;
        }
        let rho = 1.0 - 1.0 / LEARN_WINDOW;
        if let Some((dot, a, b)) = pair.filter(|p| p.0.is_finite() && p.1 > 0.0 && p.2 > 0.0) {
            if self.lag.1 == 0.0 {
                // the prior: correlated, worth LAG_PRIOR updates (the declared noise is
                // trusted until the innovations show themselves white)
                let e = (a * b).sqrt();
                self.lag = (CORRELATED * LAG_PRIOR * e, LAG_PRIOR * e, LAG_PRIOR * e);
            }
            self.lag = (rho * self.lag.0 + dot, rho * self.lag.1 + a, rho * self.lag.2 + b);
        }
        self.sum = rho * self.sum + q;
        self.weight = rho * self.weight + 1.0;
        self.seen += 1;
    }
}

/// `q` of one update (see the module): `c (uᵀ R u + tr(S⁻¹ HP⁻Hᵀ)) / m`, with `R = c R₀`
/// and `S = HP⁻Hᵀ + R`; `None` when `S` is not positive definite.
pub(super) fn residual_factor<M: DimName>(
    r: &OVector<f64, M>,
    hpht: &nalgebra::OMatrix<f64, M, M>,
    s: &nalgebra::OMatrix<f64, M, M>,
    applied_r: &nalgebra::OMatrix<f64, M, M>,
    c: f64,
) -> Option<f64>
where
    DefaultAllocator: nalgebra::allocator::Allocator<M, M> + nalgebra::allocator::Allocator<M>,
{
    let chol = s.clone().cholesky()?;
    let u = chol.solve(r);
    let quad = u.dot(&(applied_r * &u));
    let tr = chol.solve(hpht).trace();
    Some(c * (quad + tr) / M::DIM as f64)
}
