//! [`SigmaPoints`] and what serves it (the documentation is on the item).

use nalgebra::{DefaultAllocator, DimName, OMatrix};

use manifolds::{Manifold, Tangent};

use crate::adapt::NoiseStrategy;
use crate::backend::{adjusted_step, CovBackend};
use crate::dims::{Cov, FilterAlloc, StateDim};
use crate::error::FilterError;
use crate::filter::ErrorStateFilter;
use crate::linalg::{check_covariance, check_finite, cholesky, symmetrize};
use crate::report::{NoObserver, Observer, UpdateReport};
use crate::stream::StreamId;
use crate::traits::{JacobiansOf, MeasurementJacobians, MeasurementModel, ProcessModel};

/// The scaled sigma-point set and the manifold-mean iteration.
///
/// The unscented (sigma-point) error-state filter on a manifold: the same filter, models,
/// strategies, streams and reports as the error-state Kalman filter, with the prediction
/// and the update made through sigma points instead of Jacobians.
///
/// Sigma points are drawn in the tangent space of the estimate and mapped through `⊕`
/// (van der Merwe's scaled set, `2n + 1` points):
///
/// ```text
/// λ = α² (n + κ) − n,   L Lᵀ = (n + λ) P
/// χ₀ = x̂,  χᵢ = x̂ ⊕ Lᵢ,  χₙ₊ᵢ = x̂ ⊕ (−Lᵢ)            (Lᵢ: column i of L)
/// W₀ᵐ = λ / (n + λ),  W₀ᶜ = W₀ᵐ + 1 − α² + β,  Wᵢᵐ = Wᵢᶜ = 1 / (2 (n + λ))
/// ```
///
/// A mean on a manifold is found by the usual fixed-point iteration
/// `ȳ ← ȳ ⊕ Σ Wᵢᵐ (yᵢ ⊖ ȳ)` from `y₀` until the step is below
/// [`SigmaPoints::mean_tolerance`] (one step on a vector space); deviations are
/// `yᵢ ⊖ ȳ`. A model can give a mean of its own instead
/// ([`ProcessModel::sigma_mean`],
/// [`MeasurementModel::sigma_mean`]: FilterPy's
/// `x_mean_fn` and `z_mean_fn`), e.g. the `atan2` of weighted sines and cosines for an
/// angle.
///
/// **Prediction** ([`ErrorStateFilter::predict_unscented`]): the points go through the
/// model's `propagate`; `x̂⁻ = mean`, `P⁻ = λ_f Σ Wᵢᶜ dᵢ dᵢᵀ + Q_d`, where `Q_d` is the
/// model's discrete noise at `x̂` (with the strategy's adjustment) and `λ_f` the
/// strategy's prediction fading, as in [`ErrorStateFilter::predict`].
///
/// **Update** ([`ErrorStateFilter::update_unscented`]): points are drawn afresh from
/// `(x̂⁻, P⁻)`, go through the model's `predict`, and give `ẑ` (mean on the measurement
/// manifold), `P_zz = Σ Wᵢᶜ eᵢ eᵢᵀ` and `P_xz = Σ Wᵢᶜ (χᵢ ⊖ x̂⁻) eᵢᵀ` (`eᵢ = zᵢ ⊖ ẑ`). The
/// update is then the error-state update of the statistically linearised measurement
/// (statistical linear regression): `H̃ = P_xzᵀ P⁻⁻¹`, innovation `z ⊖ ẑ` and noise
/// `R + Ω` with `Ω = P_zz − H̃ P⁻ H̃ᵀ`, the linearisation error of the points. Its
/// `S = H̃ P⁻ H̃ᵀ + R + Ω = P_zz + R` and `K = P⁻ H̃ᵀ S⁻¹ = P_xz S⁻¹` are the unscented
/// filter's, and everything else — the strategy's adaptation (which sees `R + Ω` as the
/// nominal noise: an `R`-estimating strategy estimates the two together), refusals,
/// streams, reports, the Joseph covariance and the reset — is the error-state filter's
/// own path.
///
/// On a vector space with linear models the filter equals the Kalman filter (to 1e-12,
/// `tests/unscented.rs`); on the planar range-bearing robot it equals FilterPy's
/// `UnscentedKalmanFilter` with the same points and mean functions, the iterated one and,
/// through the hooks, FilterPy recipes' `atan2` one (to 1e-9, `tests/ukf_filterpy.rs`). Julier & Uhlmann (1997); Wan & van der Merwe (2000);
/// Hauberg, Lauze & Pedersen (2013) and Brossard, Barrau & Bonnabel (2020) for sigma
/// points on manifolds.
///
/// Each prediction and update allocates its `2n + 1` points (a `Vec`): the sigma-point
/// filter is not on the allocation-free path of the error-state filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigmaPoints {
    /// Spread `α` (`0 < α ≤ 1`).
    pub alpha: f64,
    /// Prior-knowledge term `β` of the centre's covariance weight (2 for a Gaussian).
    pub beta: f64,
    /// Secondary scaling `κ`.
    pub kappa: f64,
    /// The mean iteration stops when a step's largest component is at most this.
    pub mean_tolerance: f64,
    /// … or after this many steps (an error if it has not converged).
    pub max_mean_iterations: usize,
}

impl SigmaPoints {
    /// Van der Merwe's scaled points with `α`, `β`, `κ`, and a mean iteration to 1e-12
    /// in at most 50 steps.
    pub fn merwe(alpha: f64, beta: f64, kappa: f64) -> Self {
        Self { alpha, beta, kappa, mean_tolerance: 1e-12, max_mean_iterations: 50 }
    }

    /// The weights for an `n`-dimensional tangent space.
    pub fn weights(&self, n: usize) -> SigmaWeights {
        let n = n as f64;
        let lambda = self.alpha * self.alpha * (n + self.kappa) - n;
        let mean0 = lambda / (n + lambda);
        SigmaWeights {
            spread: n + lambda,
            mean0,
            cov0: mean0 + 1.0 - self.alpha * self.alpha + self.beta,
            other: 0.5 / (n + lambda),
        }
    }
}

impl Default for SigmaPoints {
    /// `α = 1, β = 2, κ = 0`: points at `±√n σ`, all mean weights non-negative (the centre's
    /// is 0), which keeps every covariance a sum of non-negative terms plus `β` at the
    /// centre. Small `α` keeps the points closer on a strongly curved state but gives the
    /// centre a large negative weight.
    fn default() -> Self {
        Self::merwe(1.0, 2.0, 0.0)
    }
}

/// The weights of a [`SigmaPoints`] set for one dimension.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigmaWeights {
    /// `n + λ`: the points are `±` the columns of the Cholesky factor of `(n + λ) P`.
    pub spread: f64,
    /// `W₀ᵐ`.
    pub mean0: f64,
    /// `W₀ᶜ`.
    pub cov0: f64,
    /// `Wᵢᵐ = Wᵢᶜ`, `i ≥ 1`.
    pub other: f64,
}

impl SigmaWeights {
    /// The mean weight of point `i`.
    pub fn mean(&self, i: usize) -> f64 {
        if i == 0 {
            self.mean0
        } else {
            self.other
        }
    }

    /// The covariance weight of point `i`.
    pub fn cov(&self, i: usize) -> f64 {
        if i == 0 {
            self.cov0
        } else {
            self.other
        }
    }
}

/// The weighted mean of `points` on their manifold by the fixed-point iteration
/// `ȳ ← ȳ ⊕ Σ wᵢ (yᵢ ⊖ ȳ)` from `points[0]`.
pub fn manifold_mean<M: Manifold>(
    points: &[M],
    weights: &SigmaWeights,
    sp: &SigmaPoints,
) -> Result<M, FilterError>
where
    DefaultAllocator: manifolds::DimAlloc<M::Dim>,
{
    let mut mean = points.first().ok_or(FilterError::NonFinite { what: "sigma points" })?.clone();
    for _ in 0..sp.max_mean_iterations.max(1) {
        let mut step = Tangent::<M>::zeros();
        for (i, p) in points.iter().enumerate() {
            step += p.ominus(&mean) * weights.mean(i);
        }
        check_finite("sigma-point mean step", &step)?;
        mean = mean.oplus(&step);
        if step.amax() <= sp.mean_tolerance {
            return Ok(mean);
        }
    }
    Err(FilterError::NotConverged { what: "sigma-point mean on the manifold" })
}

/// The mean of `points` by a model's hook (`hook(points, weights)`, checked finite), or
/// else on the manifold ([`manifold_mean`]).
fn sigma_mean<M: Manifold>(
    points: &[M],
    weights: &SigmaWeights,
    sp: &SigmaPoints,
    hook: impl FnOnce(&[M], &[f64]) -> Option<M>,
) -> Result<M, FilterError>
where
    DefaultAllocator: manifolds::DimAlloc<M::Dim>,
{
    let w: Vec<f64> = (0..points.len()).map(|i| weights.mean(i)).collect();
    match hook(points, &w) {
        Some(m) if m.is_finite() => Ok(m),
        Some(_) => Err(FilterError::NonFinite { what: "the model's sigma-point mean" }),
        None => manifold_mean(points, weights, sp),
    }
}

/// The sigma points drawn from `(x, P)`.
struct Drawn<X: Manifold>
where
    DefaultAllocator: manifolds::DimAlloc<X::Dim>,
{
    /// `x ⊕ 0, x ⊕ Lᵢ, x ⊕ −Lᵢ` for `L Lᵀ = (n + λ) P`.
    points: Vec<X>,
    /// Their tangent offsets `0, Lᵢ, −Lᵢ`.
    offsets: Vec<Tangent<X>>,
    /// The Cholesky factor of `P` itself, for the regressions `(·) P⁻¹`.
    chol: nalgebra::Cholesky<f64, X::Dim>,
}

/// Draw the points around `x` from one Cholesky factor of `P` (the columns of
/// `√(n + λ) L`, `L Lᵀ = P`).
fn draw<X: Manifold>(x: &X, P: Cov<X::Dim>, w: &SigmaWeights) -> Result<Drawn<X>, FilterError>
where
    DefaultAllocator: manifolds::DimAlloc<X::Dim>,
{
    let n = X::Dim::DIM;
    if !(w.spread.is_finite() && w.spread > 0.0) {
        return Err(FilterError::NotPositiveDefinite {
            what: "sigma-point spread n + λ (from α and κ)",
        });
    }
    let chol = cholesky("covariance P", P)?;
    let l = chol.l() * w.spread.sqrt();
    let mut offsets = Vec::with_capacity(2 * n + 1);
    offsets.push(Tangent::<X>::zeros());
    for sign in [1.0, -1.0] {
        for i in 0..n {
            offsets.push(l.column(i) * sign);
        }
    }
    let points = offsets.iter().map(|d| x.oplus(d)).collect();
    Ok(Drawn { points, offsets, chol })
}

/// A measurement linearised by its sigma points: a fixed innovation and `H̃`, for the
/// error-state filter's update path.
struct Regressed<'a, MM: MeasurementModel>
where
    DefaultAllocator: FilterAlloc<StateDim<MM::State>, StateDim<MM::Measurement>>,
{
    model: &'a MM,
    innovation: Tangent<MM::Measurement>,
    H: OMatrix<f64, StateDim<MM::Measurement>, StateDim<MM::State>>,
}

impl<MM: MeasurementModel> MeasurementModel for Regressed<'_, MM>
where
    DefaultAllocator: FilterAlloc<StateDim<MM::State>, StateDim<MM::Measurement>>,
{
    type State = MM::State;
    type Measurement = MM::Measurement;

    fn predict(&self, x: &MM::State) -> MM::Measurement {
        self.model.predict(x)
    }

    fn jacobian(
        &self,
        _: &MM::State,
    ) -> MeasurementJacobians<StateDim<MM::Measurement>, StateDim<MM::State>> {
        MeasurementJacobians { H: self.H.clone() }
    }

    fn innovation(
        &self,
        _: &MM::State,
        _: &MM::Measurement,
    ) -> (Tangent<MM::Measurement>, JacobiansOf<Self>) {
        (self.innovation.clone(), MeasurementJacobians { H: self.H.clone() })
    }

    fn stream(&self) -> StreamId {
        self.model.stream()
    }
}

impl<X, A, B> ErrorStateFilter<X, A, B>
where
    X: Manifold,
    A: NoiseStrategy,
    B: CovBackend<X::Dim>,
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    /// The unscented prediction over `dt ≥ 0` (see [`SigmaPoints`](crate::SigmaPoints)). On
    /// `Err` the filter is unchanged.
    pub fn predict_unscented<PM>(
        &mut self,
        model: &PM,
        u: &PM::Input,
        dt: f64,
        sp: &SigmaPoints,
    ) -> Result<(), FilterError>
    where
        PM: ProcessModel<State = X>,
    {
        self.predict_unscented_transition(model, u, dt, sp).map(|_| ())
    }

    /// [`predict_unscented`](Self::predict_unscented), returning the statistically
    /// linearised transition `Φ̃ = P_yx P⁻¹` of the step (what a smoother records: with it
    /// the RTS gain `P Φ̃ᵀ P⁻⁻¹` is the unscented smoother's `P_xy P⁻⁻¹`).
    pub fn predict_unscented_transition<PM>(
        &mut self,
        model: &PM,
        u: &PM::Input,
        dt: f64,
        sp: &SigmaPoints,
    ) -> Result<Cov<X::Dim>, FilterError>
    where
        PM: ProcessModel<State = X>,
    {
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(FilterError::InvalidTimeStep { dt });
        }
        let fading = self.strategy().prediction_fading();
        if !(fading.is_finite() && fading > 0.0) {
            return Err(FilterError::NonFinite { what: "strategy prediction fading λ" });
        }
        let n = X::Dim::DIM;
        let w = sp.weights(n);
        let drawn = draw(self.state(), self.covariance().into_owned(), &w)?;
        let moved: Vec<X> = drawn.points.iter().map(|p| model.propagate(p, u, dt)).collect();
        if moved.iter().any(|p| !p.is_finite()) {
            return Err(FilterError::NonFinite { what: "propagated sigma point" });
        }
        let mean = sigma_mean(&moved, &w, sp, |p, wm| model.sigma_mean(p, wm))?;
        let (_, jac) = adjusted_step(model, self.process_noise_adjustment(), self.state(), u, dt)?;
        let mut spread = Cov::<X::Dim>::zeros();
        let mut cross = Cov::<X::Dim>::zeros(); // Σ Wᶜ (yᵢ ⊖ ȳ)(χᵢ ⊖ x̂)ᵀ
        for (i, (y, d)) in moved.iter().zip(&drawn.offsets).enumerate() {
            let e = y.ominus(&mean);
            spread.ger(w.cov(i), &e, &e, 1.0);
            cross.ger(w.cov(i), &e, d, 1.0);
        }
        let mut P_next = spread * fading + &jac.Q;
        symmetrize(&mut P_next);
        // the statistically linearised transition Φ̃ = P_yx P⁻¹, for a strategy that
        // tracks the process noise since the last update
        let phi = drawn.chol.solve(&cross.transpose()).transpose();
        self.finish_prediction(mean, P_next, dt, &phi, &jac.Q)?;
        Ok(phi)
    }

    /// The unscented update (see [`SigmaPoints`](crate::SigmaPoints)) with measurement `z` of
    /// `model` and noise `R`. Returns the report; a rejected measurement is `Ok` with
    /// `verdict = Rejected`. On `Err` the state, covariance and strategy are unchanged.
    pub fn update_unscented<MM>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement>>,
        sp: &SigmaPoints,
    ) -> Result<UpdateReport<StateDim<MM::Measurement>>, FilterError>
    where
        MM: MeasurementModel<State = X>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement>>,
    {
        self.update_unscented_observed(model, z, R, sp, &mut NoObserver)
    }

    /// [`update_unscented`](Self::update_unscented) with an observer that receives the
    /// report.
    pub fn update_unscented_observed<MM, O>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement>>,
        sp: &SigmaPoints,
        observer: &mut O,
    ) -> Result<UpdateReport<StateDim<MM::Measurement>>, FilterError>
    where
        MM: MeasurementModel<State = X>,
        O: Observer,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement>>,
    {
        if !z.is_finite() {
            return Err(FilterError::NonFinite { what: "measurement z" });
        }
        check_covariance("measurement noise R", R)?;
        let w = sp.weights(X::Dim::DIM);
        let drawn = draw(self.state(), self.covariance().into_owned(), &w)?;
        let zs: Vec<MM::Measurement> = drawn.points.iter().map(|p| model.predict(p)).collect();
        if zs.iter().any(|z| !z.is_finite()) {
            return Err(FilterError::NonFinite { what: "predicted measurement of a sigma point" });
        }
        let z_hat = sigma_mean(&zs, &w, sp, |p, wm| model.sigma_mean(p, wm))?;
        type M<MM> = StateDim<<MM as MeasurementModel>::Measurement>;
        let mut Pzz = Cov::<M<MM>>::zeros();
        let mut Pxz = OMatrix::<f64, X::Dim, M<MM>>::zeros();
        for (i, (zi, d)) in zs.iter().zip(&drawn.offsets).enumerate() {
            let e = model.residual(zi, &z_hat);
            Pzz.ger(w.cov(i), &e, &e, 1.0);
            Pxz.ger(w.cov(i), d, &e, 1.0);
        }
        // H̃ = P_xzᵀ P⁻¹, Ω = P_zz − H̃ P H̃ᵀ = P_zz − H̃ P_xz
        let H = drawn.chol.solve(&Pxz).transpose();
        let mut R_total = Pzz - &H * &Pxz + R;
        symmetrize(&mut R_total);
        // (checked here, under its own name: a centre weight below zero can take the
        // points' linearisation error Ω below −R)
        check_covariance("R + Ω (the noise and the sigma points' linearisation error)", &R_total)?;
        let innovation = model.residual(z, &z_hat);
        check_finite("innovation z ⊖ ẑ", &innovation)?;
        let regressed = Regressed { model, innovation, H };
        self.update_with_gain(&regressed, z, &R_total, observer).map(|(report, _)| report)
    }
}
