//! [`ErrorStateFilter`] and what serves it (the documentation is on the item).

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
use crate::backend::UpdateForm;
use crate::backend::{CovBackend, StaticCov};
use crate::dims::{Cov, FilterAlloc, StateDim};
use crate::entries::Entries;
use crate::error::FilterError;
use crate::linalg::{check_covariance, check_finite, cholesky, symmetrize, whitened_norm_sq};
use crate::report::{NoObserver, Observer, UpdateReport};
use crate::scalar::FilterScalar;
use crate::traits::{MeasurementModel, ProcessModel};

mod predict;
mod update;

#[cfg(feature = "std")]
pub(crate) use predict::fading_over;

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
    /// The strategy holds its adaptation off: it was not helping.
    pub(crate) not_helping: bool,
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
/// covariance back-end `B` (default: stack-allocated nalgebra, see [`CovBackend`](crate::CovBackend)).
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
///
/// The error-state Kalman filter on a manifold state.
///
/// The filter owns the nominal state `x̂` and the error covariance `P`; models are
/// stateless and passed to each call, so one filter takes any number of measurement
/// models. Steps, with the equation each implements:
///
/// ```text
/// predict   x̂⁻ = f(x̂, u, dt)                 P⁻ = λ Φ P Φᵀ + Q_d   (λ = 1 unless fading)
/// innovate  r = z ⊖ h(x̂⁻)                    S = H P⁻ Hᵀ + R   (MeasurementModel::innovation)
/// adapt     (strategy) P⁻* = λ_P P⁻, R* , or reject
/// gain      K = P⁻* Hᵀ S*⁻¹                   (Cholesky solve of S* Kᵀ = H P⁻*)
/// update    δx = K r                          P = (I−KH) P⁻* (I−KH)ᵀ + K R* Kᵀ   (Joseph,
///                                             multiplied out: see UpdateForm)
/// inject    x̂ ← x̂ ⊕ δx                        P ← G P Gᵀ,  G = ∂((x̂ ⊕ (δx+ε)) ⊖ (x̂ ⊕ δx))/∂ε
/// ```
///
/// The Joseph form is Bar-Shalom, Li & Kirubarajan (2001) eq. 5.2.3-18; the reset
/// Jacobian `G` is, for a rotation block, `Jr(δθ) ≈ I − ½[δθ×]` (Solà 2017, §7.2;
/// paper `fused-iae-afkf` eq. 21–22).
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

    /// The invariant after a step: the covariance `P` (the step's result, not yet
    /// committed) has a Cholesky factor; otherwise [`FilterError::CovarianceLost`] naming
    /// the step and the strategy `name`. `full = false` checks only that the diagonal is
    /// positive (`O(N)`), for a step no strategy touched: `Φ P Φᵀ + Q_d` with `P` positive
    /// definite and `Q_d` checked positive semi-definite, and a Joseph update of a positive
    /// definite prior with a positive definite `R`, lose nothing but by rounding. (A full
    /// check after every plain update cost a 15-state GNSS update half its time: criterion
    /// `gnss_update/pos_vel_15_states` 1.51–1.75 µs against 1.02–1.20 µs. A model's own
    /// `propagate_covariance` or `step_covariance` is checked by
    /// `harness::check_combined_calls`, not here.)
    pub(crate) fn check_positive_definite(
        P: &B::Cov,
        full: bool,
        step: &'static str,
        strategy: &A,
    ) -> Result<(), FilterError> {
        let lost = if full {
            // (a static copy from the entries: the back-ends' `as_static` needs `std`)
            Cov::<X::Dim, T>::from_fn(|r, c| P.at(r, c)).cholesky().is_none()
        } else {
            (0..X::Dim::DIM).any(|i| {
                B::diag(P, i).partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater)
            })
        };
        if lost {
            return Err(FilterError::CovarianceLost { step, strategy: strategy.name() });
        }
        Ok(())
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
}
