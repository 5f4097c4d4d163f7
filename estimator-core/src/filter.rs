//! The error-state Kalman filter on a manifold state.
//!
//! The filter owns the nominal state `x̂` and the error covariance `P`; models are
//! stateless and passed to each call, so one filter takes any number of measurement
//! models. Steps, with the equation each implements:
//!
//! ```text
//! predict   x̂⁻ = f(x̂, u, dt)                 P⁻ = λ Φ P Φᵀ + Q_d   (λ = 1 unless fading)
//! innovate  r = z ⊖ h(x̂⁻)                    S = H P⁻ Hᵀ + R   (MeasurementModel::innovation)
//! adapt     (strategy) P⁻* = λ_P P⁻, R* , or reject
//! gain      K = P⁻* Hᵀ S*⁻¹                   (Cholesky solve of S* Kᵀ = H P⁻*)
//! update    δx = K r                          P = (I−KH) P⁻* (I−KH)ᵀ + K R* Kᵀ   (Joseph,
//!                                             multiplied out: see UpdateForm)
//! inject    x̂ ← x̂ ⊕ δx                        P ← G P Gᵀ,  G = ∂((x̂ ⊕ (δx+ε)) ⊖ (x̂ ⊕ δx))/∂ε
//! ```
//!
//! The Joseph form is Bar-Shalom, Li & Kirubarajan (2001) eq. 5.2.3-18; the reset
//! Jacobian `G` is, for a rotation block, `Jr(δθ) ≈ I − ½[δθ×]` (Solà 2017, §7.2;
//! paper `fused-iae-afkf` eq. 21–22).

#[cfg(feature = "std")]
use std::borrow::Cow;

// without `std`, `sqrt` and `ln` are nalgebra's (libm)
#[cfg(not(feature = "std"))]
use nalgebra::ComplexField as _;
use nalgebra::{DefaultAllocator, DimName, OMatrix};

use manifolds::{DimAlloc, Manifold};

use crate::adapt::{
    Adaptation, CovView, FixedNoise, NoiseStrategy, PostUpdate, PriorScaling, QAdjust, Verdict,
};
pub use crate::backend::UpdateForm;
use crate::backend::{CovBackend, StaticCov};
use crate::dims::{Cov, FilterAlloc, StateDim};
use crate::entries::Entries;
use crate::error::FilterError;
use crate::linalg::{check_covariance, check_finite, cholesky, symmetrize, whitened_norm_sq};
use crate::report::{NoObserver, Observer, UpdateReport};
use crate::scalar::FilterScalar;
use crate::traits::{MeasurementModel, ProcessModel};

/// How the covariance is reset after injecting the correction.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ResetMode {
    /// `P ← G P Gᵀ` with the exact reset Jacobian `G` from ⊕ (default).
    #[default]
    Exact,
    /// `G = I`, the common simplification.
    Identity,
}

/// What step *innovate* of an update finds at the prior, for the steps after it.
#[allow(non_snake_case)]
pub(crate) struct Innovated<N: DimName, M: DimName, T: FilterScalar>
where
    DefaultAllocator: FilterAlloc<N, M>,
{
    /// `r = z ⊖ h(x̂⁻)` and `H`.
    pub(crate) innovation: (nalgebra::OVector<T, M>, crate::traits::MeasurementJacobians<M, N, T>),
    pub(crate) PHt: OMatrix<T, N, M>,
    pub(crate) HPHt: OMatrix<T, M, M>,
    pub(crate) S: OMatrix<T, M, M>,
    pub(crate) chol_S: nalgebra::Cholesky<T, M>,
    /// `Q_Σ Hᵀ` and `H Q_Σ Hᵀ` (a strategy that tracks the process noise).
    pub(crate) QHt: Option<OMatrix<T, N, M>>,
    pub(crate) HQHt: Option<OMatrix<T, M, M>>,
    pub(crate) nis: f64,
}

impl<N: DimName, M: DimName, T: FilterScalar> Innovated<N, M, T>
where
    DefaultAllocator: FilterAlloc<N, M>,
{
    pub(crate) fn r(&self) -> &nalgebra::OVector<T, M> {
        &self.innovation.0
    }

    #[allow(non_snake_case)]
    pub(crate) fn H(&self) -> &OMatrix<T, M, N> {
        &self.innovation.1.H
    }
}

/// The strategy's decision on one measurement (step *adapt*).
pub(crate) struct Decision<N: DimName, M: DimName, T: FilterScalar>
where
    DefaultAllocator: FilterAlloc<N, M>,
{
    pub(crate) stream: crate::StreamId,
    pub(crate) epoch: u64,
    pub(crate) prior_scale: f64,
    pub(crate) prior_scaling: PriorScaling,
    /// `λ_P` scales the propagated part of `P⁻` only (and `Q_Σ` is tracked).
    pub(crate) propagated_only: bool,
    pub(crate) verdict: Verdict,
    pub(crate) reason: &'static str,
    pub(crate) factors: crate::adapt::Factors,
    pub(crate) q: QAdjust<N, T>,
    /// `R*`.
    pub(crate) R: OMatrix<T, M, M>,
}

/// A user-supplied covariance, checked (finite, symmetric within the tolerance, positive
/// definite) and stored exactly symmetric: the products assume `P = Pᵀ`.
fn checked_symmetric<T: FilterScalar, N: nalgebra::DimName>(
    what: &'static str,
    mut P: Cov<N, T>,
) -> Result<Cov<N, T>, FilterError>
where
    DefaultAllocator: DimAlloc<N>,
{
    check_covariance(what, &P)?;
    symmetrize(&mut P);
    Ok(P)
}

/// An error-state Kalman filter on the manifold state `X` with noise strategy `A` and
/// covariance back-end `B` (default: stack-allocated nalgebra, see [`crate::backend`]).
///
/// ```
/// use estimator_core::{ErrorStateFilter, FixedNoise, MeasurementJacobians, MeasurementModel};
/// use nalgebra::{Matrix1x2, Matrix2, Vector1, Vector2};
///
/// struct PosSensor;
/// impl MeasurementModel for PosSensor {
///     type State = Vector2<f64>;
///     type Measurement = Vector1<f64>;
///     fn predict(&self, x: &Vector2<f64>) -> Vector1<f64> { Vector1::new(x[0]) }
///     fn jacobian(&self, _: &Vector2<f64>) -> MeasurementJacobians<nalgebra::U1, nalgebra::U2> {
///         MeasurementJacobians { H: Matrix1x2::new(1.0, 0.0) }
///     }
/// }
///
/// let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), FixedNoise).unwrap();
/// let report = f.update(&PosSensor, &Vector1::new(1.0), &nalgebra::Matrix1::new(1.0)).unwrap();
/// assert!((f.state()[0] - 0.5).abs() < 1e-12);
/// assert!((report.nis - 0.5).abs() < 1e-12);
/// ```
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(bound(
        serialize = "X: serde::Serialize, A: serde::Serialize, B: serde::Serialize, \
                     B::Cov: serde::Serialize, QAdjust<X::Dim, T>: serde::Serialize",
        deserialize = "X: serde::Deserialize<'de>, A: serde::Deserialize<'de>, \
                       B: serde::Deserialize<'de>, B::Cov: serde::Deserialize<'de>, \
                       QAdjust<X::Dim, T>: serde::Deserialize<'de>"
    ))
)]
pub struct ErrorStateFilter<
    X: Manifold<T>,
    A: NoiseStrategy<T> = FixedNoise,
    B: CovBackend<X::Dim, T> = StaticCov,
    T: FilterScalar = f64,
> where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    x: X,
    /// Three covariance buffers: the current one, the next one (made current when a step
    /// succeeds, by swapping indices, not data) and the scaled prior of an update.
    bufs: [B::Cov; 3],
    /// Index of the current covariance in `bufs`; the next is `(cur + 1) % 3`, the
    /// auxiliary `(cur + 2) % 3`.
    cur: usize,
    backend: B,
    strategy: A,
    reset: ResetMode,
    form: UpdateForm,
    time: f64,
    epoch: u64,
    q_adjust: QAdjust<X::Dim, T>,
    /// `Q_Σ`, the process noise accumulated since the previous update, kept only for a
    /// strategy that [tracks](NoiseStrategy::tracks_process_noise) it.
    q_sum: Option<B::Cov>,
    /// The strategy as it was before the last update's `adapt`, put back when the update
    /// fails after it. Kept from one update to the next and refilled in place
    /// ([`Clone::clone_from`]): a fresh copy per update allocated whatever the strategy
    /// holds on the heap (the program's default strategy, its per-stream windows).
    #[cfg_attr(feature = "serde", serde(skip))]
    saved: Option<A>,
}

#[allow(non_snake_case)]
impl<T: FilterScalar, X: Manifold<T>, A: NoiseStrategy<T>> ErrorStateFilter<X, A, StaticCov, T>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// A filter at `x0` with covariance `P0` (checked: finite, symmetric, positive
    /// definite) and the given strategy, on the default (static) back-end.
    pub fn new(x0: X, P0: Cov<X::Dim, T>, strategy: A) -> Result<Self, FilterError> {
        Self::with_backend(x0, P0, strategy, StaticCov)
    }
}

#[allow(non_snake_case)]
impl<T: FilterScalar, X: Manifold<T>, A: NoiseStrategy<T>, B: CovBackend<X::Dim, T>>
    ErrorStateFilter<X, A, B, T>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// A filter on the back-end `backend` (e.g. `DynamicCov::default()`, `FaerCov::default()`).
    pub fn with_backend(
        x0: X,
        P0: Cov<X::Dim, T>,
        strategy: A,
        backend: B,
    ) -> Result<Self, FilterError> {
        if !x0.is_finite() {
            return Err(FilterError::NonFinite { what: "initial state x0" });
        }
        let P = B::from_static(&checked_symmetric("initial covariance P0", P0)?);
        Ok(Self {
            x: x0,
            bufs: [P.clone(), P.clone(), P],
            cur: 2,
            backend,
            strategy,
            reset: ResetMode::default(),
            form: UpdateForm::default(),
            time: 0.0,
            epoch: 0,
            q_adjust: QAdjust::Keep,
            q_sum: None,
            saved: None,
        })
    }

    /// Choose the reset Jacobian.
    pub fn with_reset(mut self, reset: ResetMode) -> Self {
        self.reset = reset;
        self
    }

    /// Choose the covariance update formula.
    pub fn with_update_form(mut self, form: UpdateForm) -> Self {
        self.form = form;
        self
    }

    /// Start the filter clock at `t` seconds.
    pub fn with_time(mut self, t: f64) -> Self {
        self.time = t;
        self
    }

    /// Set the filter clock to `t` seconds: a caller whose inputs carry their own time
    /// stamps keeps the clock on them (a prediction adds its interval, which need not
    /// start where the clock stands: the first IMU interval of a run may begin before the
    /// start time).
    pub fn set_time(&mut self, t: f64) {
        self.time = t;
    }

    /// The nominal state.
    pub fn state(&self) -> &X {
        &self.x
    }

    /// The error covariance as a static matrix, on every back-end: borrowed on the static
    /// one, copied out of the heap storage on the others (use
    /// [`covariance_raw`](Self::covariance_raw) to read it in place there).
    #[cfg(feature = "std")]
    pub fn covariance(&self) -> Cow<'_, Cov<X::Dim, T>> {
        B::as_static(&self.bufs[self.cur])
    }

    /// The covariance in the back-end's own storage (`Cov<N>` on the static back-end, a
    /// heap matrix on the others).
    pub fn covariance_raw(&self) -> &B::Cov {
        &self.bufs[self.cur]
    }

    /// The current, next and auxiliary buffers of `bufs` with current index `cur`.
    fn split(bufs: &mut [B::Cov; 3], cur: usize) -> (&B::Cov, &mut B::Cov, &mut B::Cov) {
        let [a, b, c] = bufs;
        match cur {
            0 => (a, b, c),
            1 => (b, c, a),
            _ => (c, a, b),
        }
    }

    /// Make the next buffer the current one.
    fn commit(&mut self) {
        self.cur = (self.cur + 1) % 3;
    }

    /// How the covariance follows an injected correction.
    pub fn reset_mode(&self) -> ResetMode {
        self.reset
    }

    /// The strategy (to read its diagnostics).
    pub fn strategy(&self) -> &A {
        &self.strategy
    }

    /// The strategy, mutably (to retune it).
    pub fn strategy_mut(&mut self) -> &mut A {
        &mut self.strategy
    }

    /// Filter time in seconds (advanced by `predict`).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Number of updates that produced a verdict so far.
    pub fn epoch(&self) -> u64 {
        self.epoch
    }

    /// The current process-noise adjustment requested by the strategy.
    pub fn process_noise_adjustment(&self) -> &QAdjust<X::Dim, T> {
        &self.q_adjust
    }

    /// Replace the nominal state (e.g. after an external re-initialisation).
    pub fn set_state(&mut self, x: X) -> Result<(), FilterError> {
        if !x.is_finite() {
            return Err(FilterError::NonFinite { what: "state x" });
        }
        self.x = x;
        Ok(())
    }

    /// Replace the covariance (checked like `P0`).
    pub fn set_covariance(&mut self, P: Cov<X::Dim, T>) -> Result<(), FilterError> {
        self.bufs[self.cur] = B::from_static(&checked_symmetric("covariance P", P)?);
        Ok(())
    }

    /// The 1σ of every error-state component.
    pub fn sigma(&self) -> OMatrix<T, X::Dim, nalgebra::U1> {
        OMatrix::<T, X::Dim, nalgebra::U1>::from_fn(|i, _| {
            B::diag(&self.bufs[self.cur], i).max(T::zero()).sqrt()
        })
    }

    /// Propagate to the absolute time `t` (s): [`predict`](Self::predict) over
    /// `t − time()`, after which the filter's time is `t` exactly — stamps compare equal
    /// however many steps led there (a sum of steps drifts: 200 steps of 0.1 s sum to
    /// 20.000000000000014). A `t` before the filter's time is an error; on `Err` the
    /// filter is unchanged.
    pub fn predict_to<PM>(&mut self, model: &PM, u: &PM::Input, t: f64) -> Result<(), FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        let dt = t - self.time;
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(FilterError::InvalidTimeStep { dt });
        }
        self.predict(model, u, T::lit(dt))?;
        self.time = t;
        Ok(())
    }

    /// Propagate over `dt ≥ 0` seconds with `model` and input `u`:
    /// `x̂⁻ = f(x̂, u, dt)`, `P⁻ = λ Φ P Φᵀ + Q_d` (λ = 1 unless the strategy fades), by the
    /// back-end's [`CovBackend::predict`]. `Q_d` is checked (finite, symmetric, positive
    /// semi-definite) whenever it is formed; on `Err` the filter is unchanged.
    pub fn predict<PM>(&mut self, model: &PM, u: &PM::Input, dt: T) -> Result<(), FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        let x_next = self.propagate_covariance_at(model, None, u, dt)?;
        self.x = x_next;
        self.commit();
        self.time += dt.to_f64();
        Ok(())
    }

    /// The state's half of a prediction: `x̂⁻ = f(x̂, u, dt)` and the clock advanced by
    /// `dt`, the covariance left as it is. With
    /// [`predict_covariance`](Self::predict_covariance) this propagates the covariance
    /// at a lower rate than the state (PX4's EKF2 does so): several state steps, then one
    /// covariance step over their whole interval with their inputs combined, taken before
    /// any update. Between the two the covariance is that of the last covariance step.
    /// On `Err` the filter is unchanged.
    pub fn predict_state<PM>(&mut self, model: &PM, u: &PM::Input, dt: T) -> Result<(), FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        if !(dt.is_finite() && dt >= T::zero()) {
            return Err(FilterError::InvalidTimeStep { dt: dt.to_f64() });
        }
        let x_next = model.propagate(&self.x, u, dt);
        if !x_next.is_finite() {
            return Err(FilterError::NonFinite { what: "propagated state" });
        }
        self.x = x_next;
        self.time += dt.to_f64();
        Ok(())
    }

    /// The covariance's half of a prediction: `P⁻ = λⁿ Φ P Φᵀ + Q_d` with `Φ` and `Q_d`
    /// of `model` at the state `x_ref` (the state where the interval began), input `u` and
    /// interval `dt`, as [`predict`](Self::predict) forms them; `n = steps`, the state
    /// steps this covariance step stands for (a strategy's fading λ is per prediction).
    /// The state and the clock are left as they are (see
    /// [`predict_state`](Self::predict_state)). On `Err` the filter is unchanged.
    pub fn predict_covariance<PM>(
        &mut self,
        model: &PM,
        x_ref: &X,
        u: &PM::Input,
        dt: T,
        steps: u32,
    ) -> Result<(), FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        self.propagate_covariance_at(model, Some((x_ref, steps)), u, dt)?;
        self.commit();
        Ok(())
    }

    /// `λⁿ Φ P Φᵀ + Q_d` at `x_ref` and over `n` steps (default: the filter's state, one
    /// step) into the next buffer (committed by the caller), `Q_Σ` carried along; returns
    /// `f(x_ref, u, dt)`.
    fn propagate_covariance_at<PM>(
        &mut self,
        model: &PM,
        x_ref: Option<(&X, u32)>,
        u: &PM::Input,
        dt: T,
    ) -> Result<X, FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        if !(dt.is_finite() && dt >= T::zero()) {
            return Err(FilterError::InvalidTimeStep { dt: dt.to_f64() });
        }
        let fading = self.strategy.prediction_fading();
        if !(fading.is_finite() && fading > 0.0) {
            return Err(FilterError::NonFinite { what: "strategy prediction fading λ" });
        }
        let (x, fading) = match x_ref {
            Some((x, steps)) if fading != 1.0 => (x, T::lit(fading.powi(steps.max(1) as i32))),
            Some((x, _)) => (x, T::lit(fading)),
            None => (&self.x, T::lit(fading)),
        };
        let (P, next, aux) = Self::split(&mut self.bufs, self.cur);
        // the back-end owns the path: the model's structured products on the static one,
        // dense products on the heap ones
        let x_next = self.backend.predict(model, x, u, dt, P, fading, &self.q_adjust, next)?;
        if !x_next.is_finite() {
            return Err(FilterError::NonFinite { what: "propagated state" });
        }
        B::check_finite("propagated covariance P", next)?;
        if self.strategy.tracks_process_noise() {
            // Q_Σ ← Φ Q_Σ Φᵀ + Q_d, by the same path (into the auxiliary buffer, swapped in
            // only when it succeeded, so that `Err` leaves Q_Σ as it was)
            let q_sum =
                self.q_sum.get_or_insert_with(|| B::from_static(&Cov::<X::Dim, T>::zeros()));
            self.backend.predict(model, x, u, dt, q_sum, T::one(), &self.q_adjust, aux)?;
            B::check_finite("accumulated process noise Q_Σ", aux)?;
            core::mem::swap(q_sum, aux);
        }
        Ok(x_next)
    }

    /// Take up a prediction made outside [`predict`](Self::predict) (the sigma-point
    /// one): the propagated state and covariance (checked), the interval, and the
    /// transition and process noise that carry `Q_Σ` for a strategy that tracks it. On
    /// `Err` the filter is unchanged.
    #[cfg(feature = "std")]
    pub(crate) fn finish_prediction(
        &mut self,
        x: X,
        P: Cov<X::Dim, T>,
        dt: f64,
        Phi: &Cov<X::Dim, T>,
        Q: &Cov<X::Dim, T>,
    ) -> Result<(), FilterError> {
        if !x.is_finite() {
            return Err(FilterError::NonFinite { what: "propagated state" });
        }
        let P = B::from_static(&checked_symmetric("propagated covariance P⁻", P)?);
        if self.strategy.tracks_process_noise() {
            let q_sum =
                self.q_sum.get_or_insert_with(|| B::from_static(&Cov::<X::Dim, T>::zeros()));
            let mut next = Phi * B::as_static(q_sum).as_ref() * Phi.transpose() + Q;
            symmetrize(&mut next);
            check_finite("accumulated process noise Q_Σ", &next)?;
            *q_sum = B::from_static(&next);
        }
        let next = (self.cur + 1) % 3;
        self.bufs[next] = P;
        self.x = x;
        self.commit();
        self.time += dt;
        Ok(())
    }

    /// Update with measurement `z` of `model` and noise `R` (checked: finite, symmetric,
    /// positive definite). Returns the report; a rejected measurement is `Ok` with
    /// `verdict = Rejected`. On `Err` the state and covariance are unchanged.
    pub fn update<MM>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement, T>, T>,
    ) -> Result<UpdateReport<StateDim<MM::Measurement, T>, T>, FilterError>
    where
        MM: MeasurementModel<T, State = X>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement, T>>,
    {
        self.update_observed(model, z, R, &mut NoObserver)
    }

    /// [`update`](Self::update) with an observer that receives the report.
    pub fn update_observed<MM, O>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement, T>, T>,
        observer: &mut O,
    ) -> Result<UpdateReport<StateDim<MM::Measurement, T>, T>, FilterError>
    where
        MM: MeasurementModel<T, State = X>,
        O: Observer<T>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement, T>>,
    {
        self.update_with_gain(model, z, R, observer).map(|(report, _)| report)
    }

    /// [`update_observed`](Self::update_observed) that also returns the gain actually
    /// used, `K = P⁻* Hᵀ S*⁻¹` (`N × M`; `None` when the measurement was rejected).
    #[allow(clippy::type_complexity)]
    pub fn update_with_gain<MM, O>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement, T>, T>,
        observer: &mut O,
    ) -> Result<
        (
            UpdateReport<StateDim<MM::Measurement, T>, T>,
            Option<OMatrix<T, X::Dim, StateDim<MM::Measurement, T>>>,
        ),
        FilterError,
    >
    where
        MM: MeasurementModel<T, State = X>,
        O: Observer<T>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement, T>>,
    {
        let inn = self.innovate(model, z, R)?;
        let decision = self.adapt(model.stream(), &inn, R);
        let mut report = self.report_of(&inn, &decision);
        if decision.verdict == Verdict::Rejected {
            self.reject(&decision, &report, observer);
            return Ok((report, None));
        }
        let (x_new, K) = match self.correct(&inn, &decision, R, &mut report) {
            Ok(v) => v,
            Err(e) => {
                self.restore_strategy();
                return Err(e);
            }
        };
        self.finish(x_new, &K, &decision, &report, observer);
        Ok((report, Some(K)))
    }

    /// Put back the strategy as it was before step *adapt* (an update that fails after it
    /// leaves the strategy unchanged too).
    pub(crate) fn restore_strategy(&mut self) {
        if let Some(saved) = &mut self.saved {
            core::mem::swap(&mut self.strategy, saved);
        }
    }

    /// The report of an update as the strategy decided it (the adapted NIS follows in
    /// [`correct`](Self::correct)).
    pub(crate) fn report_of<M: DimName>(
        &self,
        inn: &Innovated<X::Dim, M, T>,
        d: &Decision<X::Dim, M, T>,
    ) -> UpdateReport<M, T>
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        UpdateReport {
            stream: d.stream,
            epoch: d.epoch,
            time: self.time,
            innovation: inn.r().clone(),
            S: inn.S.clone(),
            nis: inn.nis,
            nis_adapted: f64::NAN,
            verdict: d.verdict,
            reason: d.reason,
            factors: d.factors,
            prior_scaling_fallback: false,
            log_likelihood: log_likelihood(&inn.chol_S, inn.nis),
        }
    }

    /// A rejected measurement: counted, the strategy's process-noise request taken up,
    /// the observer told; state and covariance unchanged.
    pub(crate) fn reject<M: DimName, O: Observer<T>>(
        &mut self,
        d: &Decision<X::Dim, M, T>,
        report: &UpdateReport<M, T>,
        observer: &mut O,
    ) where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        self.epoch = d.epoch;
        self.apply_q(&d.q);
        observer.on_update(report);
    }

    /// Step *innovate*: `r = z ⊖ h(x̂⁻)` and `H` (checked finite), `P⁻ Hᵀ`,
    /// `S = H P⁻ Hᵀ + R` and its Cholesky factor, the NIS `rᵀ S⁻¹ r`, and `H Q_Σ Hᵀ` for a
    /// strategy that tracks the process noise since the last update.
    #[allow(non_snake_case, clippy::type_complexity)]
    pub(crate) fn innovate<MM>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement, T>, T>,
    ) -> Result<Innovated<X::Dim, StateDim<MM::Measurement, T>, T>, FilterError>
    where
        MM: MeasurementModel<T, State = X>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement, T>>,
    {
        if !z.is_finite() {
            return Err(FilterError::NonFinite { what: "measurement z" });
        }
        check_covariance("measurement noise R", R)?;
        // (kept as the returned pair: destructuring it would copy `H`)
        let innovation = model.innovation(&self.x, z);
        check_finite("innovation r = z ⊖ h(x)", &innovation.0)?;
        check_finite("measurement Jacobian H", &innovation.1.H)?;
        let H = &innovation.1.H;
        // S = H P⁻ Hᵀ + R
        let PHt = self.backend.p_times_ht(H, &self.bufs[self.cur]);
        let mut HPHt =
            OMatrix::<T, StateDim<MM::Measurement, T>, StateDim<MM::Measurement, T>>::zeros();
        T::mat_mul(H, &PHt, &mut HPHt);
        let mut S = &HPHt + R;
        symmetrize(&mut S);
        // H Q_Σ Hᵀ for a strategy that tracks the process noise since the last update
        let QHt = match (&self.q_sum, self.strategy.tracks_process_noise()) {
            (Some(q_sum), true) => Some(self.backend.p_times_ht(H, q_sum)),
            _ => None,
        };
        let HQHt = QHt.as_ref().map(|QHt| {
            let mut m =
                OMatrix::<T, StateDim<MM::Measurement, T>, StateDim<MM::Measurement, T>>::zeros();
            T::mat_mul(H, QHt, &mut m);
            symmetrize(&mut m);
            m
        });
        let chol_S = cholesky("innovation covariance S = H P Hᵀ + R", S.clone())?;
        // NIS = rᵀ S⁻¹ r
        let nis = whitened_norm_sq(&chol_S, &innovation.0).to_f64();
        Ok(Innovated { innovation, PHt, HPHt, S, chol_S, QHt, HQHt, nis })
    }

    /// Step *adapt*: the strategy's decision on the innovation — the verdict, the prior's
    /// scale `λ_P`, the noise `R*`, a process-noise request. The strategy as it was is
    /// kept, so that a later failure can restore it.
    #[allow(non_snake_case)]
    pub(crate) fn adapt<M: DimName>(
        &mut self,
        stream: crate::StreamId,
        inn: &Innovated<X::Dim, M, T>,
        R: &Cov<M, T>,
    ) -> Decision<X::Dim, M, T>
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        let epoch = self.epoch + 1;
        let mut a = Adaptation {
            stream,
            epoch,
            time: self.time,
            innovation: inn.r(),
            H: inn.H(),
            P_prior: CovView::new(&self.bufs[self.cur]),
            HPHt: &inn.HPHt,
            HQHt: inn.HQHt.as_ref(),
            R_nominal: R,
            S: &inn.S,
            nis: inn.nis,
            prior_scale: 1.0,
            prior_scaling: PriorScaling::default(),
            scale_propagated_only: false,
            R: R.clone(),
            verdict: Verdict::Accepted,
            reason: "",
            factors: Default::default(),
            q: QAdjust::Keep,
        };
        // The strategy's windows change in `adapt`; a failure after it restores them, so that
        // `Err` leaves the strategy unchanged too (a copy of a zero-sized strategy is free;
        // the copy is refilled in place, see `saved`).
        match &mut self.saved {
            Some(saved) => saved.clone_from(&self.strategy),
            None => self.saved = Some(self.strategy.clone()),
        }
        self.strategy.adapt(&mut a);
        // The outputs are copied out field by field: moving the whole `Adaptation`, or its
        // `q` by value, copies a whole covariance (the `AddRate` variant's room) each time,
        // which cost more than the update's own products. `clone` of `q` copies only the
        // variant present.
        Decision {
            stream: a.stream,
            epoch,
            prior_scale: a.prior_scale,
            prior_scaling: a.prior_scaling,
            propagated_only: a.scale_propagated_only && inn.QHt.is_some(),
            verdict: a.verdict,
            reason: a.reason,
            factors: a.factors,
            q: a.q.clone(),
            R: a.R,
        }
    }

    /// Steps *gain*, *update* and *inject* for an accepted (or adapted) measurement: `S*`
    /// and the adapted NIS, the prior `P⁻*`, `K = P⁻* Hᵀ S*⁻¹` and `δx = K r`, the updated
    /// covariance into the next buffer (Joseph or the chosen form), then `x̂ ⊕ δx` with the
    /// reset `G P Gᵀ`. Returns the new state and the gain; the current buffer is untouched.
    #[allow(non_snake_case, clippy::type_complexity)]
    fn correct<M: DimName>(
        &mut self,
        inn: &Innovated<X::Dim, M, T>,
        d: &Decision<X::Dim, M, T>,
        R: &Cov<M, T>,
        report: &mut UpdateReport<M, T>,
    ) -> Result<(X, OMatrix<T, X::Dim, M>), FilterError>
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        let prior_scale = d.prior_scale;
        if !(prior_scale.is_finite() && prior_scale > 0.0) {
            return Err(FilterError::NonFinite { what: "strategy prior scale λ_P" });
        }
        let Innovated { PHt, HPHt, QHt, HQHt, .. } = inn;
        let (r, H) = (inn.r(), inn.H());
        // The scaled part B of P⁻: P⁻ itself, or Φ_Σ P Φ_Σᵀ = P⁻ − Q_Σ (Xia), and
        // P⁻* = P⁻ + (λ − 1) B (or its restriction to the measurement subspace), so
        // S* = H P⁻ Hᵀ + (λ − 1) H B Hᵀ + R*, P⁻* Hᵀ = P⁻ Hᵀ + (λ − 1) B Hᵀ.
        let differences = match (&QHt, &HQHt) {
            (Some(QHt), Some(HQHt)) if d.propagated_only => Some((PHt - QHt, HPHt - HQHt)),
            _ => None,
        };
        let (BHt, HBHt) = match &differences {
            Some((BHt, HBHt)) => (BHt, HBHt),
            None => (PHt, HPHt),
        };
        let adapted = Self::adapted_innovation(d, R, inn, HBHt, report)?;
        let (chol, S_used) = match &adapted {
            Some((chol, S)) => (chol, S),
            None => (&inn.chol_S, &report.S),
        };

        let mut backend = core::mem::take(&mut self.backend);
        let form = self.form;
        let (P, next, aux) = Self::split(&mut self.bufs, self.cur);
        let (scaled, fallback) =
            Self::scale_prior(&mut backend, (P, aux), d, (BHt, HBHt), self.q_sum.as_ref());
        report.prior_scaling_fallback = fallback;
        // P⁻* Hᵀ = P⁻ Hᵀ + (λ − 1) B Hᵀ (both scalings)
        let scaled_PHt = (prior_scale != 1.0).then(|| PHt + BHt * T::lit(prior_scale - 1.0));
        let PHt_used = scaled_PHt.as_ref().unwrap_or(PHt);
        // K = P⁻* Hᵀ S*⁻¹ (S* = L Lᵀ; two substitutions over the columns of P⁻* Hᵀ)
        let mut K = PHt_used.clone();
        T::right_solve_cholesky(chol.l_dirty(), &mut K);
        let mut dx = OMatrix::<T, X::Dim, nalgebra::U1>::zeros();
        T::mat_mul(&K, r, &mut dx);

        let prior: &B::Cov = if scaled { aux } else { P };
        // Joseph: P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ, or short: P = P⁻ − K H P⁻
        backend.update(prior, &K, H, PHt_used, &d.R, S_used, form, next);
        let x_new = if self.reset == ResetMode::Exact {
            // P ← G P Gᵀ with G = ∂(x ⊕ δ)/∂δ at the injected δx, block by block
            let next = &mut self.bufs[(self.cur + 1) % 3];
            self.x.oplus_reset(&dx, &mut |o, b| backend.reset_block(next, o, b))
        } else {
            self.x.oplus(&dx)
        };
        self.backend = backend;
        check_finite("state correction δx", &dx)?;
        if !x_new.is_finite() {
            return Err(FilterError::NonFinite { what: "updated state" });
        }
        B::check_finite("updated covariance P", &self.bufs[(self.cur + 1) % 3])?;
        Ok((x_new, K))
    }

    /// `S* = λ_P H P⁻ Hᵀ + R*` and its factor when the strategy changed `λ_P` or `R`
    /// (both scalings give `H P⁻* = λ_P H P⁻`); `None` when it changed neither (then `S`
    /// and its factor stand). Sets the report's adapted NIS, log-likelihood and a
    /// deflation verdict.
    #[allow(non_snake_case, clippy::type_complexity)]
    pub(crate) fn adapted_innovation<M: DimName>(
        d: &Decision<X::Dim, M, T>,
        R: &Cov<M, T>,
        inn: &Innovated<X::Dim, M, T>,
        HBHt: &OMatrix<T, M, M>,
        report: &mut UpdateReport<M, T>,
    ) -> Result<Option<(nalgebra::Cholesky<T, M>, OMatrix<T, M, M>)>, FilterError>
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        // (compared as slices: nalgebra's `!=` walks a strided iterator, several times slower)
        let adapted = d.prior_scale != 1.0 || d.R.as_slice() != R.as_slice();
        if !adapted {
            report.nis_adapted = inn.nis;
            return Ok(None);
        }
        check_covariance("adapted measurement noise R*", &d.R)?;
        let mut S_used = &inn.HPHt + HBHt * T::lit(d.prior_scale - 1.0) + &d.R;
        symmetrize(&mut S_used);
        let chol = cholesky("adapted innovation covariance S*", S_used.clone())?;
        report.nis_adapted = whitened_norm_sq(&chol, inn.r()).to_f64();
        // an adaptation that made S smaller along the innovation deflated it
        if report.verdict == Verdict::Inflated && report.nis_adapted > inn.nis {
            report.verdict = Verdict::Deflated;
        }
        report.log_likelihood = log_likelihood(&chol, report.nis_adapted);
        Ok(Some((chol, S_used)))
    }

    /// `P⁻* = P⁻ + (λ_P − 1) B` into `aux`, whole or along the measurement subspace
    /// `(HB)ᵀ (HBHᵀ)⁻¹ (HB)` (`B = P⁻`, or `P⁻ − Q_Σ` when the strategy scales the
    /// propagated part only). Returns whether the prior was scaled and whether the
    /// subspace scaling fell back to the whole of `B`.
    #[allow(non_snake_case, clippy::type_complexity)]
    fn scale_prior<M: DimName>(
        backend: &mut B,
        (P, aux): (&B::Cov, &mut B::Cov),
        d: &Decision<X::Dim, M, T>,
        (BHt, HBHt): (&OMatrix<T, X::Dim, M>, &OMatrix<T, M, M>),
        q_sum: Option<&B::Cov>,
    ) -> (bool, bool)
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        let prior_scale = d.prior_scale;
        if prior_scale == 1.0 {
            return (false, false);
        }
        let HB = BHt.transpose();
        let subspace = match d.prior_scaling {
            PriorScaling::MeasurementSubspace => HBHt.clone().cholesky().map(|c| c.solve(&HB)),
            PriorScaling::Full => None,
        };
        let mut fallback = false;
        match subspace {
            Some(A) => backend.scale_add(P, T::one(), T::lit(prior_scale - 1.0), &HB, &A, aux),
            None => {
                // H B Hᵀ has no Cholesky factor (a measurement direction the prior does not
                // constrain): the whole of B is scaled, and the report says so.
                fallback = d.prior_scaling == PriorScaling::MeasurementSubspace;
                backend.scale_add(P, T::lit(prior_scale), T::zero(), &HB, &HB, aux);
                if let (true, Some(q_sum)) = (d.propagated_only, q_sum) {
                    // λ P⁻ − (λ − 1) Q_Σ = P⁻ + (λ − 1)(P⁻ − Q_Σ)
                    sub_scaled(aux, T::lit(prior_scale - 1.0), q_sum, X::Dim::DIM);
                }
            }
        }
        (true, fallback)
    }

    /// The last step: the new state and covariance become current, the process noise
    /// accumulated since the last update starts again, the strategy sees the gain used
    /// and the observer the report.
    #[allow(non_snake_case)]
    fn finish<M: DimName, O: Observer<T>>(
        &mut self,
        x_new: X,
        K: &OMatrix<T, X::Dim, M>,
        d: &Decision<X::Dim, M, T>,
        report: &UpdateReport<M, T>,
        observer: &mut O,
    ) where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        self.x = x_new;
        self.commit();
        self.after_correction(K, d, report, observer);
    }

    /// After the state and covariance of an accepted update are in place: the process
    /// noise accumulated since the last update starts again, the strategy sees the gain
    /// used (and may request process noise), the observer gets the report.
    #[allow(non_snake_case)]
    pub(crate) fn after_correction<M: DimName, O: Observer<T>>(
        &mut self,
        K: &OMatrix<T, X::Dim, M>,
        d: &Decision<X::Dim, M, T>,
        report: &UpdateReport<M, T>,
        observer: &mut O,
    ) where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        if let Some(q_sum) = &mut self.q_sum {
            // the next update's propagated part starts from this posterior
            for c in 0..X::Dim::DIM {
                q_sum.col_mut(c).fill(T::zero());
            }
        }
        self.epoch = d.epoch;
        self.apply_q(&d.q);
        let innovation = &report.innovation;
        let mut post =
            PostUpdate { stream: d.stream, time: self.time, K, innovation, q: QAdjust::Keep };
        self.strategy.after_update(&mut post);
        self.apply_q(&post.q);
        observer.on_update(report);
    }

    /// Take up the strategy's process-noise request (by reference, for the reason given
    /// in `update_observed`).
    fn apply_q(&mut self, q: &QAdjust<X::Dim, T>) {
        match q {
            QAdjust::Keep => {}
            QAdjust::Model => self.q_adjust = QAdjust::Keep,
            other => self.q_adjust = other.clone(),
        }
    }
}

/// `out ← out − a Q` for two `n × n` column-major covariances.
fn sub_scaled<T: FilterScalar, C: Entries<T>>(out: &mut C, a: T, q: &C, n: usize) {
    for c in 0..n {
        for (o, v) in out.col_mut(c).iter_mut().zip(q.col(c)) {
            *o -= a * *v;
        }
    }
}

/// `ln N(r; 0, S) = −½ (m ln 2π + ln det S + rᵀ S⁻¹ r)` from the Cholesky factor of `S` and
/// the NIS.
fn log_likelihood<T: FilterScalar, M: nalgebra::DimName>(
    chol: &nalgebra::Cholesky<T, M>,
    nis: f64,
) -> f64
where
    DefaultAllocator: nalgebra::allocator::Allocator<M, M>,
{
    let l = chol.l_dirty();
    let log_det = (0..M::DIM).map(|i| l[(i, i)].to_f64().ln()).sum::<f64>() * 2.0;
    -0.5 * (M::DIM as f64 * (2.0 * core::f64::consts::PI).ln() + log_det + nis)
}
