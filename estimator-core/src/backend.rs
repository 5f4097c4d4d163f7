//! [`CovBackend`] and what serves it (the documentation is on the item).

#[cfg(feature = "std")]
use std::borrow::Cow;

use nalgebra::{DMatrixView, DefaultAllocator, DimName, OMatrix};

use manifolds::{DimAlloc, Manifold};

use crate::adapt::QAdjust;
use crate::dims::{Cov, FilterAlloc};
use crate::entries::Entries;
use crate::error::FilterError;
use crate::linalg::{check_finite, check_process_noise, symmetrize};
use crate::scalar::FilterScalar;
use crate::traits::{ProcessJacobians, ProcessModel};

#[cfg(feature = "std")]
mod dense;
#[doc(hidden)]
#[cfg(feature = "std")]
pub use dense::Dense;
#[cfg(feature = "faer")]
pub use dense::FaerCov;
#[cfg(feature = "std")]
pub use dense::{DenseCov, DynamicCov};

/// Covariance update formula.
///
/// The two Joseph variants compute the same function of `K`, so both keep the Joseph
/// form's first-order insensitivity to errors in the gain; they differ in cost and in
/// rounding.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UpdateForm {
    /// The Joseph form multiplied out, `P + V Kᵀ + K Vᵀ` with `V = K S/2 − P Hᵀ` and
    /// `S = H P Hᵀ + R`: `(I−KH) P (I−KH)ᵀ + K R Kᵀ` for any gain, exactly symmetric,
    /// about `N²M` multiply-adds instead of `2N³` (default). Against
    /// [`JosephFactored`](Self::JosephFactored) with measurements up to 1e12 times more
    /// precise than the prior: the same `P` to 6e-15 relative, both positive definite
    /// (`estimator-core/tests/update_kernels.rs`).
    #[default]
    Joseph,
    /// The textbook product `(I−KH) P (I−KH)ᵀ + K R Kᵀ` (Bar-Shalom et al. 2001,
    /// eq. 5.2.3-18): a sum of two positive semi-definite products, `O(N³)`; the
    /// reference the default is tested against.
    JosephFactored,
    /// `P − K H P` (symmetrised): cheapest, exact only for the optimal gain.
    Short,
}

/// Storage and products of the covariance.
///
/// Covariance back-ends: where `P` lives and who does its O(N³) and O(N²M) products.
///
/// The filter is generic over a [`CovBackend`] with the static nalgebra back-end as the
/// default; the same filter code runs on all three:
///
/// | back-end | `P` | products | best for |
/// |---|---|---|---|
/// | [`StaticCov`] | `OMatrix<f64, N, N>` on the stack | the crate's column kernels (AVX2/FMA when available), or the model's structured propagation | small and medium states |
/// | [`DynamicCov`] | `DMatrix<f64>` on the heap | nalgebra dynamic (matrixmultiply) | large states without the faer dependency; keeps `P` off the stack |
/// | `FaerCov` (feature `faer`) | `faer::Mat<f64>` on the heap | faer (single-threaded; lower triangles of symmetric products) | large states |
///
/// The dimension is always a compile-time type (the filter's state decides it); the heap
/// back-ends differ in where `P` lives and who multiplies, not in what sizes they accept.
/// Where each one wins is measured in `docs/history/benches.md`.
///
/// Each back-end owns its whole prediction ([`CovBackend::predict`]): the static one hands
/// `P` to the model's structured [`ProcessModel::step_covariance`], the heap ones ask the
/// model for `Φ` and `Q_d` and multiply densely. The filter never asks which one it has.
///
/// # Example
///
/// The same filter on two back-ends, one token apart:
///
/// ```
/// use estimator_core::linear::{LinearMeasurement, LinearProcess};
/// use estimator_core::{CovBackend, DynamicCov, ErrorStateFilter, FixedNoise, StaticCov};
/// use nalgebra::{Matrix2, Vector1, Vector2};
///
/// let process = LinearProcess { F: Matrix2::new(1.0, 0.1, 0.0, 1.0), Q: Matrix2::identity() * 1e-3 };
/// let sensor = LinearMeasurement::<1, 2>::new(nalgebra::Matrix1x2::new(1.0, 0.0));
/// let mut a = ErrorStateFilter::with_backend(Vector2::zeros(), Matrix2::identity(), FixedNoise, StaticCov).unwrap();
/// let mut b = ErrorStateFilter::with_backend(Vector2::zeros(), Matrix2::identity(), FixedNoise, DynamicCov::default()).unwrap();
/// for k in 0..10 {
///     let z = Vector1::new(0.3 * k as f64);
///     a.predict(&process, &(), 0.1).unwrap();
///     b.predict(&process, &(), 0.1).unwrap();
///     a.update(&sensor, &z, &nalgebra::Matrix1::new(0.01)).unwrap();
///     b.update(&sensor, &z, &nalgebra::Matrix1::new(0.01)).unwrap();
/// }
/// assert!((a.covariance().into_owned() - b.covariance().into_owned()).norm() < 1e-12);
/// assert_eq!(<DynamicCov as CovBackend<nalgebra::U2>>::NAME, "nalgebra-dynamic");
/// ```
///
/// Every operation writes into a caller-provided output so the filter stays unchanged
/// when a step fails. The dynamic back-ends allocate their scratch buffers once, on first
/// use; afterwards a step does not allocate.
pub trait CovBackend<N: DimName, T: FilterScalar = f64>:
    Clone + core::fmt::Debug + Default
where
    DefaultAllocator: DimAlloc<N>,
{
    /// The stored covariance.
    type Cov: Clone + core::fmt::Debug + Entries<T>;

    /// Name for benches and logs.
    const NAME: &'static str;

    /// Convert from a static matrix.
    fn from_static(P: &Cov<N, T>) -> Self::Cov;

    /// The covariance as a static matrix (borrowed for the static back-end; feature `std`).
    #[cfg(feature = "std")]
    fn as_static(P: &Self::Cov) -> Cow<'_, Cov<N, T>>;

    /// `P[i, i]`.
    fn diag(P: &Self::Cov, i: usize) -> T;

    /// The whole prediction of the filter: returns `x⁺ = f(x, u, dt)` and writes
    /// `out ← λ Φ P Φᵀ + Q_d`, `Q_d` adjusted as the strategy asked (`q`), exactly
    /// symmetric. `Q_d` is checked (`check_process_noise`) wherever it is formed; on
    /// `Err` nothing but `out` may have changed.
    ///
    /// Default: the model's `Φ` and `Q_d` (`adjusted_step`) and
    /// [`propagate`](Self::propagate). The static back-end overrides it with the model's
    /// structured [`ProcessModel::step_covariance`].
    #[allow(clippy::too_many_arguments)]
    fn predict<PM: ProcessModel<T>>(
        &mut self,
        model: &PM,
        x: &PM::State,
        u: &PM::Input,
        dt: T,
        P: &Self::Cov,
        lambda: T,
        q: &QAdjust<N, T>,
        out: &mut Self::Cov,
    ) -> Result<PM::State, FilterError>
    where
        PM::State: Manifold<T, Dim = N>,
    {
        let (x_next, jac) = adjusted_step(model, q, x, u, dt)?;
        self.propagate(P, &jac.Phi, &jac.Q, lambda, out);
        Ok(x_next)
    }

    /// `out ← λ Φ P Φᵀ + Q` (exactly symmetric).
    fn propagate(
        &mut self,
        P: &Self::Cov,
        Phi: &Cov<N, T>,
        Q: &Cov<N, T>,
        lambda: T,
        out: &mut Self::Cov,
    );

    /// `P Hᵀ` (`N × M`) for an `M × N` matrix `H` (the transpose of `H P`, `P` being
    /// symmetric).
    fn p_times_ht<M: DimName>(&mut self, H: &OMatrix<T, M, N>, P: &Self::Cov) -> OMatrix<T, N, M>
    where
        DefaultAllocator: FilterAlloc<N, M>;

    /// `out ← a P + b Uᵀ V` for `M × N` matrices `U`, `V` (prior scaling along a subspace).
    fn scale_add<M: DimName>(
        &mut self,
        P: &Self::Cov,
        a: T,
        b: T,
        U: &OMatrix<T, M, N>,
        V: &OMatrix<T, M, N>,
        out: &mut Self::Cov,
    ) where
        DefaultAllocator: FilterAlloc<N, M>;

    /// The covariance update in the given [`UpdateForm`], exactly symmetric:
    /// `out ← (I − K H) P (I − K H)ᵀ + K R Kᵀ` (Joseph, multiplied out or factored) or
    /// `out ← P − K (H P)` (short). `PHt = P Hᵀ` and `S = H P Hᵀ + R` are the caller's.
    #[allow(clippy::too_many_arguments)]
    fn update<M: DimName>(
        &mut self,
        P: &Self::Cov,
        K: &OMatrix<T, N, M>,
        H: &OMatrix<T, M, N>,
        PHt: &OMatrix<T, N, M>,
        R: &OMatrix<T, M, M>,
        S: &OMatrix<T, M, M>,
        form: UpdateForm,
        out: &mut Self::Cov,
    ) where
        DefaultAllocator: FilterAlloc<N, M>;

    /// `P ← G P Gᵀ` in place (the reset), `G` being the identity but for the square
    /// `block` at rows and columns `offset..` (one of the state's
    /// [`reset_blocks`](manifolds::Manifold::reset_blocks)); `O(d² N)` for a `d × d` block
    /// (see `block_reset_in_place`).
    fn reset_block(&mut self, P: &mut Self::Cov, offset: usize, block: DMatrixView<'_, T>);

    /// `Err(NonFinite)` when any entry is NaN or infinite.
    fn check_finite(what: &'static str, P: &Self::Cov) -> Result<(), FilterError>;
}

/// The model's `x⁺`, `Φ` and `Q_d` for one step, `Q_d` adjusted as the strategy asked
/// (`Scale(s)`: `s Q_d`; `AddRate(q)`: `Q_d + q dt`) and checked by
/// [`check_process_noise`], which names the model.
pub(crate) fn adjusted_step<T: FilterScalar, PM: ProcessModel<T>, N: DimName>(
    model: &PM,
    q: &QAdjust<N, T>,
    x: &PM::State,
    u: &PM::Input,
    dt: T,
) -> Result<(PM::State, ProcessJacobians<N, T>), FilterError>
where
    PM::State: Manifold<T, Dim = N>,
    DefaultAllocator: DimAlloc<N>,
{
    let (x_next, mut jac) = model.step(x, u, dt);
    // a non-finite input (a NaN gyro sample) shows first in the propagated state and Φ:
    // named as such, not as the model's noise
    if !x_next.is_finite() || T::non_finite_in(jac.Phi.as_slice()) {
        return Err(FilterError::NonFinite {
            what: "propagated state or transition Φ (a NaN or infinite input sample?)",
        });
    }
    match q {
        QAdjust::Keep | QAdjust::Model => {}
        QAdjust::Scale(s) => jac.Q *= *s,
        QAdjust::AddRate(q) => jac.Q += q * dt,
    }
    check_process_noise(crate::stream::short_type_name::<PM>(), &jac.Q)?;
    Ok((x_next, jac))
}

/// The static back-end's prediction ([`CovBackend::predict`] of [`StaticCov`]), with the
/// transition's transpose `Φᵀ` written into `phi_t` when asked (a smoother's replay: the
/// same `x⁺` and `P⁺` bit for bit, and the `Φ` of the step).
#[allow(clippy::too_many_arguments, non_snake_case)]
pub(crate) fn static_predict<T: FilterScalar, PM: ProcessModel<T>, N: DimName>(
    model: &PM,
    x: &PM::State,
    u: &PM::Input,
    dt: T,
    P: &Cov<N, T>,
    lambda: T,
    q: &QAdjust<N, T>,
    out: &mut Cov<N, T>,
    phi_t: Option<&mut Cov<N, T>>,
) -> Result<PM::State, FilterError>
where
    PM::State: Manifold<T, Dim = N>,
    DefaultAllocator: DimAlloc<N>,
{
    let scaled;
    let P = if lambda == T::one() {
        P
    } else {
        // λ Φ P Φᵀ = Φ (λ P) Φᵀ
        scaled = P * lambda;
        &scaled
    };
    let x_next = match (q, phi_t) {
        (QAdjust::Keep | QAdjust::Model, None) if PM::FUSED_STEP_COVARIANCE => {
            model.step_covariance(x, u, dt, P, out)
        }
        (QAdjust::Keep | QAdjust::Model, Some(phi_t)) if PM::FUSED_STEP_COVARIANCE => {
            model.step_covariance_adjoint(x, u, dt, P, out, phi_t)
        }
        (q, phi_t) => {
            let (x_next, jac) = adjusted_step(model, q, x, u, dt)?;
            model.propagate_covariance(P, &jac, out);
            if let Some(phi_t) = phi_t {
                jac.Phi.transpose_to(phi_t);
            }
            x_next
        }
    };
    if !PM::SYMMETRIC_PROPAGATION {
        symmetrize(out);
    }
    Ok(x_next)
}

/// The default: a stack-allocated nalgebra matrix.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StaticCov;

impl<N: DimName, T: FilterScalar> CovBackend<N, T> for StaticCov
where
    DefaultAllocator: DimAlloc<N>,
{
    type Cov = Cov<N, T>;
    const NAME: &'static str = "nalgebra-static";

    fn from_static(P: &Cov<N, T>) -> Cov<N, T> {
        P.clone()
    }

    #[cfg(feature = "std")]
    fn as_static(P: &Cov<N, T>) -> Cow<'_, Cov<N, T>> {
        Cow::Borrowed(P)
    }

    fn diag(P: &Cov<N, T>, i: usize) -> T {
        P[(i, i)]
    }

    /// A model with a fused [`ProcessModel::step_covariance`]
    /// ([`ProcessModel::FUSED_STEP_COVARIANCE`]) propagates through it (no `Φ` or `Q_d`
    /// formed) unless the strategy adjusted `Q_d`; otherwise `Φ` and the (adjusted) `Q_d`,
    /// checked, go through [`ProcessModel::propagate_covariance`]. A fading factor scales
    /// `P` first.
    fn predict<PM: ProcessModel<T>>(
        &mut self,
        model: &PM,
        x: &PM::State,
        u: &PM::Input,
        dt: T,
        P: &Cov<N, T>,
        lambda: T,
        q: &QAdjust<N, T>,
        out: &mut Cov<N, T>,
    ) -> Result<PM::State, FilterError>
    where
        PM::State: Manifold<T, Dim = N>,
    {
        static_predict(model, x, u, dt, P, lambda, q, out, None)
    }

    fn propagate(
        &mut self,
        P: &Cov<N, T>,
        Phi: &Cov<N, T>,
        Q: &Cov<N, T>,
        lambda: T,
        out: &mut Cov<N, T>,
    ) {
        // P⁻ = λ Φ P Φᵀ + Q_d = Φ (λ P) Φᵀ + Q_d
        if lambda == T::one() {
            T::dense_sandwich(Phi, P, Q, out);
        } else {
            T::dense_sandwich(Phi, &(P * lambda), Q, out);
        }
    }

    fn p_times_ht<M: DimName>(&mut self, H: &OMatrix<T, M, N>, P: &Cov<N, T>) -> OMatrix<T, N, M>
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        // over the non-zero entries of H only
        let mut PHt = OMatrix::<T, N, M>::zeros();
        T::p_times_ht(P, H, PHt.as_mut_slice());
        PHt
    }

    fn scale_add<M: DimName>(
        &mut self,
        P: &Cov<N, T>,
        a: T,
        b: T,
        U: &OMatrix<T, M, N>,
        V: &OMatrix<T, M, N>,
        out: &mut Cov<N, T>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        *out = P * a + U.transpose() * V * b;
        symmetrize(out);
    }

    fn update<M: DimName>(
        &mut self,
        P: &Cov<N, T>,
        K: &OMatrix<T, N, M>,
        H: &OMatrix<T, M, N>,
        PHt: &OMatrix<T, N, M>,
        R: &OMatrix<T, M, M>,
        S: &OMatrix<T, M, M>,
        form: UpdateForm,
        out: &mut Cov<N, T>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        match form {
            UpdateForm::Joseph => {
                // P + V Kᵀ + K Vᵀ, V = K S/2 − P Hᵀ
                T::joseph_update(P, K, S, PHt, out);
            }
            UpdateForm::JosephFactored => {
                // P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ   (Bar-Shalom et al. 2001, eq. 5.2.3-18)
                let IKH = Cov::<N, T>::identity() - K * H;
                *out = &IKH * P * IKH.transpose() + K * R * K.transpose();
                symmetrize(out);
            }
            UpdateForm::Short => {
                // P = P⁻ − K H P⁻
                *out = P - K * PHt.transpose();
                symmetrize(out);
            }
        }
    }

    /// By [`FilterScalar::block_reset`]: in `f64` the crate's kernel (blocks of up to 6
    /// dimensions need no scratch, up to 16 a small stack one, bigger ones an `N × N` one on
    /// the stack); never the heap.
    fn reset_block(&mut self, P: &mut Cov<N, T>, offset: usize, block: DMatrixView<'_, T>) {
        T::block_reset(P, offset, block);
    }

    fn check_finite(what: &'static str, P: &Cov<N, T>) -> Result<(), FilterError> {
        check_finite(what, P)
    }
}
