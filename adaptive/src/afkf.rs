//! Adaptive fading Kalman filter (AFKF).

use estimator_core::{Adaptation, FilterAlloc, NoiseStrategy, PriorScaling, StreamMap, Verdict};
use nalgebra::{DefaultAllocator, DimName};

use crate::guard::{FadingGuard, GuardStream, Judgement};
use crate::window::{trace_ratio, InnovationWindow};

/// How the AFKF estimates the innovation covariance `Ĉ_k`.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MismatchEstimate {
    /// Mean of `r rᵀ` over the last N innovations.
    Window(usize),
    /// `V_k = (ρ V_{k−1} + r_k r_kᵀ)/(1 + ρ)`, `V_0 = r_0 r_0ᵀ`, forgetting `ρ ∈ (0, 1]`.
    Recursive {
        /// Forgetting factor ρ (≈ 0.95).
        rho: f64,
    },
}

/// Where the AFKF applies its factor.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FadingAt {
    /// At the update epoch, `P⁻* = λ P⁻` (default; right for many predictions per update).
    #[default]
    Update,
    /// In every following prediction, `P⁻ = λ Φ P Φᵀ + Q_d` (the textbook single-rate
    /// form; with many predictions per update the factor compounds).
    Prediction,
}

/// AFKF: one fading factor `λ_k ≥ 1` inflates the prediction when the innovations are
/// larger than the filter expects.
///
/// ```text
/// λ_k = clamp( tr(Ĉ_k − R) / tr(H P⁻ Hᵀ), 1, λ_max )          P⁻* = λ_k P⁻
/// ```
///
/// Our reading for multi-rate systems (many predictions per update): by default
/// ([`FadingAt::Update`]) the factor is applied to the predicted covariance at the update
/// epoch, `P⁻* = λ P⁻`, rather than to each of the many `Φ P Φᵀ` products in between
/// (which would compound it); `H P⁻ Hᵀ` then plays the part of `H Φ P Φᵀ Hᵀ`.
/// [`FadingAt::Prediction`] applies the latest λ in every prediction instead.
/// `λ_max` (default 100) keeps `P` finite. With a fixed factor (`fixed_lambda`, always
/// applied in prediction) the strategy is the fading-memory filter
/// `P⁻ = α² Φ P Φᵀ + Q`: FilterPy's `FadingKalmanFilter` with memory α is `λ = α²`.
///
/// Default estimator: a window of N = 20 (as the paper's IAE window). On the crate's
/// constant-velocity scenario with an exactly right model (`cargo run --release -p
/// adaptive --features campaigns --example strategy_sweep`, 8 seeds, q = 0.002) the window costs +4.5 %
/// position RMS over the fixed filter and the recursive form with ρ = 0.95 (whose newest
/// sample weighs ≈ ½) +22 %. With a 10× under-stated Q (`cargo test -p adaptive --test
/// claims -- --nocapture`, 10 seeds) the mean NEES drops from 32.3 (fixed) to 29.1 with
/// the default measurement-subspace scaling, and to 13.1 with full scaling (measured
/// before subspace scaling became the default): full scaling also inflates the
/// velocity the position fixes cannot see — which is what makes it diverge in the INS.
/// AFKF amplifies outliers (it reads them as model mismatch and trusts the next
/// measurement more).
///
/// With [`xia`](Self::xia) (`afkf-xia`) the factor follows Xia's definition instead: it
/// scales `Φ P Φᵀ` only, and the process noise added since the previous update is taken
/// out of the mismatch before λ is formed (ALGORITHMS.md §2.3).
///
/// # Guarded (the default) and faithful
///
/// By default a [`FadingGuard`] decides whether to fade at all: λ is applied only while
/// the window's NIS is significantly above what a consistent filter gives and its
/// whitened innovations correlate from one update to the next (a state error, not
/// noise), and fading that has run for a window without making the innovations smaller is
/// held off and reported (`not_helping`). Xia's algorithm read faithfully (`afkf-faithful`,
/// `afkf-xia-faithful`; [`faithful`](Self::faithful)) fades whenever the estimate of λ
/// exceeds 1. On a user's attitude filter (gyro bias; gravity and magnetic directions,
/// `cargo run --release -p adaptive --features campaigns --example attitude_campaign`) the faithful reading
/// reads a magnetic disturbance — noise, not model mismatch — as a prior too confident,
/// trusts the disturbed magnetometer more with each update, and runs 15–18° off where the
/// fixed filter is 1°; on clean data it fades on noise. The guarded default stays within
/// the bounds `docs/history/results.md` lists.
///
/// Decisions: `Inflated` when `λ > 1`, otherwise `Accepted`. Never rejects, never
/// changes `R`.
///
/// # Reference
///
/// Q. Xia, M. Rao, Y. Ying, X. Shen, "Adaptive fading Kalman filter with an application",
/// *Automatica* 30(8), 1333–1338 (1994); the trace form as used in paper `fused-iae-afkf`
/// (section 3). Fading memory: Y. Bar-Shalom et al. (2001) §11.7; R. Labbe, FilterPy.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
pub struct Afkf {
    /// Estimator of `Ĉ`. Default `Window(20)`.
    pub estimate: MismatchEstimate,
    /// Upper bound on λ. Default 100.
    pub lambda_max: f64,
    /// A constant λ instead of the adaptive one (fading-memory filter). Default none.
    pub fixed_lambda: Option<f64>,
    /// Where the adaptive λ is applied. Default [`FadingAt::Update`].
    pub apply_at: FadingAt,
    /// Xia's form: λ scales the propagated part `Φ_Σ P Φ_Σᵀ = P⁻ − Q_Σ` only, and its
    /// numerator subtracts the process noise added since the previous update,
    /// `λ = tr(Ĉ − H Q_Σ Hᵀ − R) / tr(H Φ_Σ P Φ_Σᵀ Hᵀ)` (the filter accumulates `Q_Σ` for
    /// it, one more covariance propagation per prediction). Default `false`: λ scales all
    /// of `P⁻`, `λ = tr(Ĉ − R) / tr(H P⁻ Hᵀ)`. Applied at the update epoch in either case.
    pub xia: bool,
    /// How λ scales `P⁻` at the update. Default [`PriorScaling::MeasurementSubspace`]
    /// (same gain as full scaling; full scaling made the INS covariance overflow in our
    /// demo within 440 s, because GNSS cannot see every direction it inflates).
    pub scaling: PriorScaling,
    /// Whether and how fading is guarded. Default `Some(FadingGuard::default())`; `None`
    /// is Xia's algorithm as written ([`faithful`](Self::faithful)).
    pub guard: Option<FadingGuard>,
    streams: StreamMap<AfkfStream>,
    guards: StreamMap<GuardStream>,
    last_lambda: f64,
}

clone_in_place!(Afkf {
    estimate,
    lambda_max,
    fixed_lambda,
    apply_at,
    xia,
    scaling,
    guard,
    streams,
    guards,
    last_lambda
});

#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
enum AfkfStream {
    Window(InnovationWindow),
    Recursive { v: Vec<f64>, started: bool },
}

/// (`clone_from` in place: see `clone_in_place!`)
impl Clone for AfkfStream {
    fn clone(&self) -> Self {
        match self {
            Self::Window(w) => Self::Window(w.clone()),
            Self::Recursive { v, started } => Self::Recursive { v: v.clone(), started: *started },
        }
    }

    fn clone_from(&mut self, source: &Self) {
        match (self, source) {
            (Self::Window(w), Self::Window(s)) => w.clone_from(s),
            (Self::Recursive { v, started }, Self::Recursive { v: sv, started: ss }) => {
                v.clone_from(sv);
                *started = *ss;
            }
            (this, source) => *this = source.clone(),
        }
    }
}

impl Default for Afkf {
    fn default() -> Self {
        Self {
            estimate: MismatchEstimate::Window(20),
            lambda_max: 100.0,
            fixed_lambda: None,
            apply_at: FadingAt::Update,
            xia: false,
            scaling: PriorScaling::default(),
            guard: Some(FadingGuard::default()),
            streams: StreamMap::new(),
            guards: StreamMap::new(),
            last_lambda: 1.0,
        }
    }
}

impl Afkf {
    /// AFKF with a window of N innovations.
    pub fn windowed(n: usize) -> Self {
        Self { estimate: MismatchEstimate::Window(n), ..Self::default() }
    }

    /// AFKF with the recursive estimate and forgetting `rho`.
    pub fn recursive(rho: f64) -> Self {
        Self { estimate: MismatchEstimate::Recursive { rho }, ..Self::default() }
    }

    /// Apply the adaptive λ at the update (default) or in the following predictions.
    pub fn applied_at(mut self, at: FadingAt) -> Self {
        self.apply_at = at;
        self
    }

    /// Xia's form (see [`xia`](Self::xia)): the fading factor leaves the process noise
    /// since the previous update unscaled.
    pub fn xia(mut self) -> Self {
        self.xia = true;
        self.apply_at = FadingAt::Update;
        self
    }

    /// Scale `P⁻` along the measurement subspace (default) or in full.
    pub fn with_scaling(mut self, scaling: PriorScaling) -> Self {
        self.scaling = scaling;
        self
    }

    /// Xia's algorithm as written: fade whenever the estimated λ exceeds 1, unguarded (see
    /// [the type's documentation](Self)).
    pub fn faithful(mut self) -> Self {
        self.guard = None;
        self
    }

    /// The fading-memory filter with constant `λ = alpha²`.
    pub fn fading_memory(alpha: f64) -> Self {
        Self { fixed_lambda: Some(alpha * alpha), ..Self::default() }
    }
}

impl NoiseStrategy for Afkf {
    fn name(&self) -> &'static str {
        match (self.xia, self.guard.is_some()) {
            (true, true) => "afkf-xia",
            (false, true) => "afkf",
            (true, false) => "afkf-xia-faithful",
            (false, false) => "afkf-faithful",
        }
    }

    fn tracks_process_noise(&self) -> bool {
        self.xia && self.fixed_lambda.is_none()
    }

    fn prediction_fading(&self) -> f64 {
        match (self.fixed_lambda, self.apply_at) {
            (Some(l), _) if l.is_finite() && l > 0.0 => l,
            (Some(_), _) => 1.0,
            (None, FadingAt::Prediction) => self.last_lambda,
            (None, FadingAt::Update) => 1.0,
        }
    }

    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        if let Some(l) = self.fixed_lambda {
            a.factors.lambda_p = l;
            a.reason = "fading memory: fixed λ in prediction";
            return;
        }
        let estimate = self.estimate;
        let s = self.streams.get_or_insert_with(a.stream, || match estimate {
            MismatchEstimate::Window(n) => AfkfStream::Window(InnovationWindow::new(n, M::DIM)),
            MismatchEstimate::Recursive { .. } => {
                AfkfStream::Recursive { v: vec![0.0; M::DIM * M::DIM], started: false }
            }
        });
        let r = a.innovation;
        let c = match s {
            AfkfStream::Window(w) => {
                w.push(r.as_slice());
                w.covariance::<M>()
            }
            AfkfStream::Recursive { v, started } => {
                let rho = match estimate {
                    MismatchEstimate::Recursive { rho } => rho.clamp(0.0, 1.0),
                    MismatchEstimate::Window(_) => 0.95,
                };
                let m = M::DIM;
                for j in 0..m {
                    for i in 0..m {
                        let rr = r[i] * r[j];
                        // V_k = (ρ V_{k−1} + r rᵀ)/(1 + ρ), V_0 = r₀ r₀ᵀ
                        v[j * m + i] =
                            if *started { (rho * v[j * m + i] + rr) / (1.0 + rho) } else { rr };
                    }
                }
                *started = true;
                nalgebra::OMatrix::<f64, M, M>::from_column_slice(v)
            }
        };
        a.factors.dom = trace_ratio(&c, a.S);
        // λ = tr(Ĉ − R) / tr(H P⁻ Hᵀ), or with Xia's process-noise term
        // λ = tr(Ĉ − H Q_Σ Hᵀ − R) / tr(H (P⁻ − Q_Σ) Hᵀ)
        let hqh = match (self.xia, a.HQHt) {
            (true, Some(m)) => m.trace(),
            _ => 0.0,
        };
        let denom = a.HPHt.trace() - hqh;
        let raw = if denom > 0.0 { (c.trace() - hqh - a.R_nominal.trace()) / denom } else { 1.0 };
        let mut lambda =
            if raw.is_finite() { raw.clamp(1.0, self.lambda_max.max(1.0)) } else { 1.0 };
        let judgement = match &self.guard {
            Some(guard) => self
                .guards
                .get_or_insert_with(a.stream, || GuardStream::new(window_len(estimate), M::DIM))
                .judge(guard, &crate::guard::Epoch::of(a), M::DIM),
            None => Judgement::Adapt,
        };
        if judgement != Judgement::Adapt {
            lambda = 1.0;
        }
        a.factors.lambda_p = lambda;
        match self.apply_at {
            FadingAt::Update => {
                a.prior_scale = lambda;
                a.prior_scaling = self.scaling;
                a.scale_propagated_only = self.xia;
            }
            FadingAt::Prediction => self.last_lambda = lambda,
        }
        if lambda > 1.0 {
            a.verdict = Verdict::Inflated;
            a.reason = "afkf: fading λ > 1";
        } else if judgement == Judgement::NotHelping {
            a.not_helping = true;
            a.reason = "afkf: fading did not make the innovations smaller; held off";
        }
    }
}

/// The guard's window: the estimator's window, or the recursive form's effective length
/// `(1 + ρ)/(1 − ρ)` (20 at ρ = 0.9, 39 at 0.95).
fn window_len(e: MismatchEstimate) -> usize {
    match e {
        MismatchEstimate::Window(n) => n.max(1),
        MismatchEstimate::Recursive { rho } => {
            let rho = rho.clamp(0.0, 0.99);
            ((1.0 + rho) / (1.0 - rho)).round().max(1.0) as usize
        }
    }
}
