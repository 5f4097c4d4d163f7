//! Innovation-based adaptive estimation (IAE).

use estimator_core::{
    Adaptation, FilterAlloc, NoiseStrategy, PostUpdate, QAdjust, StreamMap, Verdict,
};
use nalgebra::{DefaultAllocator, DimName};

use crate::window::{project_noise, trace_ratio, InnovationWindow, NoiseBounds};

/// IAE: estimate `R` (and optionally `Q`) from a window of innovations.
///
/// Per stream, with `Ĉ_k = (1/n) Σ r_j r_jᵀ` over the last `n ≤ N` innovations:
///
/// ```text
/// R̂_k = Ĉ_k − H P⁻ Hᵀ                   (measurement loop)
/// Q̂_k = K_k Ĉ_k K_kᵀ                    (process loop, optional)
/// ```
///
/// `R̂_k` is not positive definite in general (the known weakness of IAE); it is
/// projected back with `project_noise` (full matrix when `R̂ − floor·R₀` is PD, otherwise
/// the diagonal clamped to `[floor, ceiling]·R₀`). Until the window holds `warmup`
/// innovations the nominal `R` is used (start-up: fewer samples than N are used as they
/// come once `warmup` is reached).
///
/// `Q̂` deviates from Mohamed & Schwarz on purpose: they *replace* `Q` by `Q̂`, which has
/// rank ≤ m, so the directions the gain does not excite get no process noise and `P`
/// becomes singular (our adversarial tests in `tests/safety.rs` reproduce this). Here
/// `Q̂ / Δt` (Δt: time since the stream's previous update) is *added* to the model's `Q`
/// in the following predictions, and `Ĉ` is capped at `ceiling · tr(R₀)` first so that
/// huge innovations cannot make `P` overflow.
///
/// Decisions: `Inflated` with `λ_R = tr(R̂)/tr(R₀)` once adapting, `Accepted` during
/// warm-up. Never rejects.
///
/// # Reference
///
/// A. H. Mohamed and K. P. Schwarz, "Adaptive Kalman filtering for INS/GPS", *Journal of
/// Geodesy* 73, 193–203 (1999); window N = 20 as in paper `fused-iae-afkf`.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
pub struct Iae {
    /// Window length N (innovations). Default 20.
    pub window: usize,
    /// Innovations needed before adapting. Default 5.
    pub warmup: usize,
    /// Also adapt `Q` (`Q̂ = K Ĉ Kᵀ`). Default false.
    pub adapt_q: bool,
    /// Bounds on `R̂` relative to the nominal `R`. Default `[0.1, 1e4]`.
    pub bounds: NoiseBounds,
    streams: StreamMap<IaeStream>,
}

clone_in_place!(Iae { window, warmup, adapt_q, bounds, streams });

#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
struct IaeStream {
    window: InnovationWindow,
    last_time: Option<f64>,
    /// `ceiling · tr(R₀)` from the latest update: cap on `tr(Ĉ)` for `Q̂`.
    c_cap: f64,
}

clone_in_place!(IaeStream { window, last_time, c_cap });

impl Default for Iae {
    fn default() -> Self {
        Self {
            window: 20,
            warmup: 5,
            adapt_q: false,
            bounds: NoiseBounds::default(),
            streams: StreamMap::new(),
        }
    }
}

impl Iae {
    /// IAE with window `n`.
    pub fn new(window: usize) -> Self {
        Self { window, ..Self::default() }
    }

    /// Also adapt `Q`.
    pub fn with_q_adaptation(mut self) -> Self {
        self.adapt_q = true;
        self
    }
}

impl NoiseStrategy for Iae {
    fn name(&self) -> &'static str {
        "iae"
    }

    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let cap = self.window;
        let s = self.streams.get_or_insert_with(a.stream, || IaeStream {
            window: InnovationWindow::new(cap, M::DIM),
            last_time: None,
            c_cap: f64::INFINITY,
        });
        s.window.push(a.innovation.as_slice());
        s.c_cap = self.bounds.ceiling * a.R_nominal.trace();
        let c = s.window.covariance::<M>();
        a.factors.dom = trace_ratio(&c, a.S);
        if s.window.len() < self.warmup.max(1) {
            a.reason = "iae warm-up: nominal R";
            return;
        }
        // R̂ = Ĉ − H P⁻ Hᵀ, projected to SPD
        let (r_hat, projected) = project_noise(c - a.HPHt, a.R_nominal, self.bounds);
        a.factors.lambda_r = trace_ratio(&r_hat, a.R_nominal);
        a.R = r_hat;
        a.verdict = Verdict::Inflated;
        a.reason =
            if projected { "iae: R estimate projected to bounds" } else { "iae: R from window" };
    }

    fn after_update<N: DimName, M: DimName>(&mut self, p: &mut PostUpdate<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        if !self.adapt_q {
            return;
        }
        let cap = self.window;
        let s = self.streams.get_or_insert_with(p.stream, || IaeStream {
            window: InnovationWindow::new(cap, M::DIM),
            last_time: None,
            c_cap: f64::INFINITY,
        });
        let previous = s.last_time.replace(p.time);
        if s.window.len() < self.warmup.max(1) {
            return;
        }
        let Some(t0) = previous else { return };
        let dt = p.time - t0;
        if dt.is_nan() || dt <= 0.0 {
            return;
        }
        // Q̂ = K Ĉ Kᵀ over the interval since the stream's previous update, as a rate
        let mut c = s.window.covariance::<M>();
        let tr = c.trace();
        if tr > s.c_cap {
            c *= s.c_cap / tr;
        }
        let mut q = p.K * c * p.K.transpose() / dt;
        // Exactly symmetric (models may rely on a symmetric Q, see SYMMETRIC_PROPAGATION).
        estimator_core::symmetrize(&mut q);
        if q.iter().all(|v| v.is_finite()) {
            p.q = QAdjust::AddRate(q);
        }
    }
}
