//! Covariance back-ends: where `P` lives and who does its O(N³) and O(N²M) products.
//!
//! The filter is generic over a [`CovBackend`] with the static nalgebra back-end as the
//! default; the same filter code runs on all three:
//!
//! | back-end | `P` | products | best for |
//! |---|---|---|---|
//! | [`StaticCov`] | `OMatrix<f64, N, N>` on the stack | the crate's column kernels (AVX2/FMA when available), or the model's structured propagation | small and medium states |
//! | [`DynamicCov`] | `DMatrix<f64>` on the heap | nalgebra dynamic (matrixmultiply) | large states without the faer dependency; keeps `P` off the stack |
//! | `FaerCov` (feature `faer`) | `faer::Mat<f64>` on the heap | faer (single-threaded; lower triangles of symmetric products) | large states |
//!
//! The dimension is always a compile-time type (the filter's state decides it); the heap
//! back-ends differ in where `P` lives and who multiplies, not in what sizes they accept.
//! Where each one wins is measured in `benches/README.md`.
//!
//! Each back-end owns its whole prediction ([`CovBackend::predict`]): the static one hands
//! `P` to the model's structured [`ProcessModel::step_covariance`], the heap ones ask the
//! model for `Φ` and `Q_d` and multiply densely. The filter never asks which one it has.
//!
//! # Example
//!
//! The same filter on two back-ends, one token apart:
//!
//! ```
//! use estimator_core::linear::{LinearMeasurement, LinearProcess};
//! use estimator_core::{CovBackend, DynamicCov, ErrorStateFilter, FixedNoise, StaticCov};
//! use nalgebra::{Matrix2, Vector1, Vector2};
//!
//! let process = LinearProcess { F: Matrix2::new(1.0, 0.1, 0.0, 1.0), Q: Matrix2::identity() * 1e-3 };
//! let sensor = LinearMeasurement::<1, 2>::new(nalgebra::Matrix1x2::new(1.0, 0.0));
//! let mut a = ErrorStateFilter::with_backend(Vector2::zeros(), Matrix2::identity(), FixedNoise, StaticCov).unwrap();
//! let mut b = ErrorStateFilter::with_backend(Vector2::zeros(), Matrix2::identity(), FixedNoise, DynamicCov::default()).unwrap();
//! for k in 0..10 {
//!     let z = Vector1::new(0.3 * k as f64);
//!     a.predict(&process, &(), 0.1).unwrap();
//!     b.predict(&process, &(), 0.1).unwrap();
//!     a.update(&sensor, &z, &nalgebra::Matrix1::new(0.01)).unwrap();
//!     b.update(&sensor, &z, &nalgebra::Matrix1::new(0.01)).unwrap();
//! }
//! assert!((a.covariance().into_owned() - b.covariance().into_owned()).norm() < 1e-12);
//! assert_eq!(<DynamicCov as CovBackend<nalgebra::U2>>::NAME, "nalgebra-dynamic");
//! ```
//!
//! Every operation writes into a caller-provided output so the filter stays unchanged
//! when a step fails. The dynamic back-ends allocate their scratch buffers once, on first
//! use; afterwards a step does not allocate.

use std::borrow::Cow;

#[cfg(feature = "faer")]
use faer::{Accum, Mat, Par};
use nalgebra::{DMatrix, DMatrixView, DefaultAllocator, DimName, OMatrix};

use manifolds::{DimAlloc, Manifold};

use crate::adapt::QAdjust;
use crate::dims::{Cov, FilterAlloc};
pub use crate::entries::Entries;
use crate::error::FilterError;
use crate::kernels;
use crate::linalg::{check_finite, check_process_noise, has_non_finite, symmetrize};
use crate::traits::{ProcessJacobians, ProcessModel};

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

/// Storage and products of the covariance. See the [module docs](self).
pub trait CovBackend<N: DimName>: Clone + core::fmt::Debug + Default
where
    DefaultAllocator: DimAlloc<N>,
{
    /// The stored covariance.
    type Cov: Clone + core::fmt::Debug + Entries;

    /// Name for benches and logs.
    const NAME: &'static str;

    /// Convert from a static matrix.
    fn from_static(P: &Cov<N>) -> Self::Cov;

    /// The covariance as a static matrix (borrowed for the static back-end).
    fn as_static(P: &Self::Cov) -> Cow<'_, Cov<N>>;

    /// `P[i, i]`.
    fn diag(P: &Self::Cov, i: usize) -> f64;

    /// The whole prediction of the filter: returns `x⁺ = f(x, u, dt)` and writes
    /// `out ← λ Φ P Φᵀ + Q_d`, `Q_d` adjusted as the strategy asked (`q`), exactly
    /// symmetric. `Q_d` is checked ([`check_process_noise`]) wherever it is formed; on
    /// `Err` nothing but `out` may have changed.
    ///
    /// Default: the model's `Φ` and `Q_d` ([`adjusted_step`]) and
    /// [`propagate`](Self::propagate). The static back-end overrides it with the model's
    /// structured [`ProcessModel::step_covariance`].
    #[allow(clippy::too_many_arguments)]
    fn predict<PM: ProcessModel>(
        &mut self,
        model: &PM,
        x: &PM::State,
        u: &PM::Input,
        dt: f64,
        P: &Self::Cov,
        lambda: f64,
        q: &QAdjust<N>,
        out: &mut Self::Cov,
    ) -> Result<PM::State, FilterError>
    where
        PM::State: Manifold<Dim = N>,
    {
        let (x_next, jac) = adjusted_step(model, q, x, u, dt)?;
        self.propagate(P, &jac.Phi, &jac.Q, lambda, out);
        Ok(x_next)
    }

    /// `out ← λ Φ P Φᵀ + Q` (exactly symmetric).
    fn propagate(
        &mut self,
        P: &Self::Cov,
        Phi: &Cov<N>,
        Q: &Cov<N>,
        lambda: f64,
        out: &mut Self::Cov,
    );

    /// `P Hᵀ` (`N × M`) for an `M × N` matrix `H` (the transpose of `H P`, `P` being
    /// symmetric).
    fn p_times_ht<M: DimName>(
        &mut self,
        H: &OMatrix<f64, M, N>,
        P: &Self::Cov,
    ) -> OMatrix<f64, N, M>
    where
        DefaultAllocator: FilterAlloc<N, M>;

    /// `out ← a P + b Uᵀ V` for `M × N` matrices `U`, `V` (prior scaling along a subspace).
    fn scale_add<M: DimName>(
        &mut self,
        P: &Self::Cov,
        a: f64,
        b: f64,
        U: &OMatrix<f64, M, N>,
        V: &OMatrix<f64, M, N>,
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
        K: &OMatrix<f64, N, M>,
        H: &OMatrix<f64, M, N>,
        PHt: &OMatrix<f64, N, M>,
        R: &OMatrix<f64, M, M>,
        S: &OMatrix<f64, M, M>,
        form: UpdateForm,
        out: &mut Self::Cov,
    ) where
        DefaultAllocator: FilterAlloc<N, M>;

    /// `P ← G P Gᵀ` in place (the reset), `G` being the identity but for the square
    /// `block` at rows and columns `offset..` (one of the state's
    /// [`reset_blocks`](manifolds::Manifold::reset_blocks)); `O(d² N)` for a `d × d` block
    /// (see [`block_reset_in_place`](crate::kernels::block_reset_in_place)).
    fn reset_block(&mut self, P: &mut Self::Cov, offset: usize, block: DMatrixView<'_, f64>);

    /// `Err(NonFinite)` when any entry is NaN or infinite.
    fn check_finite(what: &'static str, P: &Self::Cov) -> Result<(), FilterError>;
}

/// The model's `x⁺`, `Φ` and `Q_d` for one step, `Q_d` adjusted as the strategy asked
/// (`Scale(s)`: `s Q_d`; `AddRate(q)`: `Q_d + q dt`) and checked by
/// [`check_process_noise`], which names the model.
pub(crate) fn adjusted_step<PM: ProcessModel, N: DimName>(
    model: &PM,
    q: &QAdjust<N>,
    x: &PM::State,
    u: &PM::Input,
    dt: f64,
) -> Result<(PM::State, ProcessJacobians<N>), FilterError>
where
    PM::State: Manifold<Dim = N>,
    DefaultAllocator: DimAlloc<N>,
{
    let (x_next, mut jac) = model.step(x, u, dt);
    match q {
        QAdjust::Keep | QAdjust::Model => {}
        QAdjust::Scale(s) => jac.Q *= *s,
        QAdjust::AddRate(q) => jac.Q += q * dt,
    }
    check_process_noise(crate::stream::short_type_name::<PM>(), &jac.Q)?;
    Ok((x_next, jac))
}

/// The default: a stack-allocated nalgebra matrix.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StaticCov;

impl<N: DimName> CovBackend<N> for StaticCov
where
    DefaultAllocator: DimAlloc<N>,
{
    type Cov = Cov<N>;
    const NAME: &'static str = "nalgebra-static";

    fn from_static(P: &Cov<N>) -> Cov<N> {
        P.clone()
    }

    fn as_static(P: &Cov<N>) -> Cow<'_, Cov<N>> {
        Cow::Borrowed(P)
    }

    fn diag(P: &Cov<N>, i: usize) -> f64 {
        P[(i, i)]
    }

    /// A model with a fused [`ProcessModel::step_covariance`]
    /// ([`ProcessModel::FUSED_STEP_COVARIANCE`]) propagates through it (no `Φ` or `Q_d`
    /// formed) unless the strategy adjusted `Q_d`; otherwise `Φ` and the (adjusted) `Q_d`,
    /// checked, go through [`ProcessModel::propagate_covariance`]. A fading factor scales
    /// `P` first.
    fn predict<PM: ProcessModel>(
        &mut self,
        model: &PM,
        x: &PM::State,
        u: &PM::Input,
        dt: f64,
        P: &Cov<N>,
        lambda: f64,
        q: &QAdjust<N>,
        out: &mut Cov<N>,
    ) -> Result<PM::State, FilterError>
    where
        PM::State: Manifold<Dim = N>,
    {
        let scaled;
        let P = if lambda == 1.0 {
            P
        } else {
            // λ Φ P Φᵀ = Φ (λ P) Φᵀ
            scaled = P * lambda;
            &scaled
        };
        let x_next = match q {
            QAdjust::Keep | QAdjust::Model if PM::FUSED_STEP_COVARIANCE => {
                model.step_covariance(x, u, dt, P, out)
            }
            q => {
                let (x_next, jac) = adjusted_step(model, q, x, u, dt)?;
                model.propagate_covariance(P, &jac, out);
                x_next
            }
        };
        if !PM::SYMMETRIC_PROPAGATION {
            symmetrize(out);
        }
        Ok(x_next)
    }

    fn propagate(&mut self, P: &Cov<N>, Phi: &Cov<N>, Q: &Cov<N>, lambda: f64, out: &mut Cov<N>) {
        // P⁻ = λ Φ P Φᵀ + Q_d = Φ (λ P) Φᵀ + Q_d
        if lambda == 1.0 {
            kernels::dense_sandwich(Phi, P, Q, out);
        } else {
            kernels::dense_sandwich(Phi, &(P * lambda), Q, out);
        }
    }

    fn p_times_ht<M: DimName>(&mut self, H: &OMatrix<f64, M, N>, P: &Cov<N>) -> OMatrix<f64, N, M>
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        // over the non-zero entries of H only
        let mut PHt = OMatrix::<f64, N, M>::zeros();
        kernels::p_times_ht(P, H, PHt.as_mut_slice());
        PHt
    }

    fn scale_add<M: DimName>(
        &mut self,
        P: &Cov<N>,
        a: f64,
        b: f64,
        U: &OMatrix<f64, M, N>,
        V: &OMatrix<f64, M, N>,
        out: &mut Cov<N>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        *out = P * a + U.transpose() * V * b;
        symmetrize(out);
    }

    fn update<M: DimName>(
        &mut self,
        P: &Cov<N>,
        K: &OMatrix<f64, N, M>,
        H: &OMatrix<f64, M, N>,
        PHt: &OMatrix<f64, N, M>,
        R: &OMatrix<f64, M, M>,
        S: &OMatrix<f64, M, M>,
        form: UpdateForm,
        out: &mut Cov<N>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        match form {
            UpdateForm::Joseph => {
                // P + V Kᵀ + K Vᵀ, V = K S/2 − P Hᵀ
                kernels::joseph_update(P, K, S, PHt, out);
            }
            UpdateForm::JosephFactored => {
                // P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ   (Bar-Shalom et al. 2001, eq. 5.2.3-18)
                let IKH = Cov::<N>::identity() - K * H;
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

    /// Blocks of up to 6 dimensions (rotations, positions, poses) need no scratch, up to
    /// 16 a stack one; bigger blocks (custom manifolds only) allocate it.
    fn reset_block(&mut self, P: &mut Cov<N>, offset: usize, block: DMatrixView<'_, f64>) {
        let need = kernels::block_reset_scratch(block.nrows());
        if block.nrows() <= 6 {
            kernels::block_reset_in_place(P, N::DIM, offset, block, &mut []);
        } else if need <= kernels::block_reset_scratch(16) {
            let mut stack = [0.0; kernels::block_reset_scratch(16)];
            kernels::block_reset_in_place(P, N::DIM, offset, block, &mut stack);
        } else {
            kernels::block_reset_in_place(P, N::DIM, offset, block, &mut vec![0.0; need]);
        }
    }

    fn check_finite(what: &'static str, P: &Cov<N>) -> Result<(), FilterError> {
        check_finite(what, P)
    }
}

/// The dense matrix operations the dynamic back-ends need; implemented for nalgebra's
/// `DMatrix` and faer's `Mat`, so [`DenseCov`] is written once.
#[doc(hidden)]
pub trait Dense: Clone + core::fmt::Debug + Entries {
    /// Name of the back-end.
    const NAME: &'static str;
    /// An `r × c` zero matrix.
    fn zeros(r: usize, c: usize) -> Self;
    /// Rows.
    fn rows(&self) -> usize;
    /// Columns.
    fn cols(&self) -> usize;
    /// `out ← β out + α op(a) op(b)` with `op` the transpose when the flag is set
    /// (`DMatrix` allocates for a transposed `b`; the back-end never asks for one).
    #[allow(clippy::too_many_arguments)]
    fn gemm(out: &mut Self, beta: f64, alpha: f64, a: &Self, at: bool, b: &Self, bt: bool);
    /// `out ← β out + α a b` where only the lower triangle of `out` (diagonal included)
    /// is needed: the caller mirrors it. Default: the full product.
    fn gemm_lower(out: &mut Self, beta: f64, alpha: f64, a: &Self, b: &Self) {
        Self::gemm(out, beta, alpha, a, false, b, false)
    }
    /// `out ← P B` for a symmetric `N × N` `P` and a thin `N × M` `B`. Default: that
    /// product.
    fn sym_times_thin(out: &mut Self, p: &Self, b: &Self) {
        Self::gemm(out, 0.0, 1.0, p, false, b, false)
    }
}

impl Dense for DMatrix<f64> {
    const NAME: &'static str = "nalgebra-dynamic";
    fn zeros(r: usize, c: usize) -> Self {
        DMatrix::zeros(r, c)
    }
    fn rows(&self) -> usize {
        self.nrows()
    }
    fn cols(&self) -> usize {
        self.ncols()
    }
    fn gemm(out: &mut Self, beta: f64, alpha: f64, a: &Self, at: bool, b: &Self, bt: bool) {
        match (at, bt) {
            (false, false) => out.gemm(alpha, a, b, beta),
            (false, true) => out.gemm(alpha, a, &b.transpose(), beta),
            (true, false) => out.gemm_tr(alpha, a, b, beta),
            (true, true) => out.gemm_tr(alpha, a, &b.transpose(), beta),
        }
    }
}

/// faer accumulates or replaces: `out ← β out` first when `β ∉ {0, 1}`, and the
/// accumulation mode for `out ← β out + α a b`.
#[cfg(feature = "faer")]
fn faer_accum(out: &mut Mat<f64>, beta: f64) -> Accum {
    if beta == 0.0 {
        return Accum::Replace;
    }
    if beta != 1.0 {
        for c in 0..out.ncols() {
            for v in out.col_as_slice_mut(c) {
                *v *= beta;
            }
        }
    }
    Accum::Add
}

#[cfg(feature = "faer")]
impl Dense for Mat<f64> {
    const NAME: &'static str = "faer";
    fn zeros(r: usize, c: usize) -> Self {
        Mat::zeros(r, c)
    }
    fn rows(&self) -> usize {
        self.nrows()
    }
    fn cols(&self) -> usize {
        self.ncols()
    }
    fn gemm(out: &mut Self, beta: f64, alpha: f64, a: &Self, at: bool, b: &Self, bt: bool) {
        let accum = faer_accum(out, beta);
        let (a, b) = (a.as_ref(), b.as_ref());
        let a = if at { a.transpose() } else { a };
        let b = if bt { b.transpose() } else { b };
        faer::linalg::matmul::matmul(out.as_mut(), accum, a, b, alpha, Par::Seq);
    }
    /// As `(Bᵀ P)ᵀ` written through a transposed view: faer's kernels are several times
    /// faster for the wide `M × N` product than for the thin `N × M` one.
    fn sym_times_thin(out: &mut Self, p: &Self, b: &Self) {
        let (p, b) = (p.as_ref(), b.as_ref());
        faer::linalg::matmul::matmul(
            out.as_mut().transpose_mut(),
            Accum::Replace,
            b.transpose(),
            p,
            1.0,
            Par::Seq,
        );
    }
    /// faer computes the lower triangle only (half the multiply-adds of a square result).
    fn gemm_lower(out: &mut Self, beta: f64, alpha: f64, a: &Self, b: &Self) {
        use faer::linalg::matmul::triangular::{matmul, BlockStructure};
        let accum = faer_accum(out, beta);
        let rect = BlockStructure::Rectangular;
        matmul(
            out.as_mut(),
            BlockStructure::TriangularLower,
            accum,
            a.as_ref(),
            rect,
            b.as_ref(),
            rect,
            alpha,
            Par::Seq,
        );
    }
}

/// Columns `j0..j0 + M` of `wide` ← `a`, rows `j0..j0 + M` of `tall` ← `bᵀ` (`a`, `b`
/// both `N × M`): the factors of a product `wide · tall = … + a bᵀ`.
fn set_factors<D: Dense, N: DimName, M: DimName>(
    wide: &mut D,
    tall: &mut D,
    j0: usize,
    a: &OMatrix<f64, N, M>,
    b: &OMatrix<f64, N, M>,
) where
    DefaultAllocator: nalgebra::allocator::Allocator<N, M>,
{
    for j in 0..M::DIM {
        for r in 0..N::DIM {
            wide.put(r, j0 + j, a[(r, j)]);
            tall.put(j0 + j, r, b[(r, j)]);
        }
    }
}

fn symmetrize_dense<D: Dense>(m: &mut D) {
    mirror_tiles(m, |lower, upper| 0.5 * (lower + upper));
}

/// Copy a static matrix into a dense one (reshaped when the size differs).
fn to_dense<D: Dense, R: DimName, C: DimName>(m: &OMatrix<f64, R, C>, out: &mut D)
where
    DefaultAllocator: nalgebra::allocator::Allocator<R, C>,
{
    ensure_shape(out, R::DIM, C::DIM);
    for (c, col) in m.as_slice().chunks_exact(R::DIM).enumerate() {
        out.col_mut(c).copy_from_slice(col);
    }
}

fn ensure<D: Dense>(m: &mut D, n: usize) {
    ensure_shape(m, n, n);
}

fn ensure_shape<D: Dense>(m: &mut D, r: usize, c: usize) {
    if m.rows() != r || m.cols() != c {
        *m = D::zeros(r, c);
    }
}

fn copy_dense<D: Dense>(from: &D, to: &mut D) {
    ensure_shape(to, from.rows(), from.cols());
    for c in 0..from.cols() {
        to.col_mut(c).copy_from_slice(from.col(c));
    }
}

/// Make `m` exactly symmetric by copying its lower triangle onto the upper one.
fn mirror_lower<D: Dense>(m: &mut D) {
    mirror_tiles(m, |lower, _| lower);
}

/// For every pair `r < c` of a square matrix, `v = f(m[c, r], m[r, c])` (lower, upper)
/// written to both. Eight columns at a time: the lower entries of rows `c0..c0 + 8` are one
/// contiguous segment of each column `r`, and the upper ones are row `r` of the eight
/// columns, so every access runs along a column (entry-wise access strides through
/// memory and costs several times more at 120 states).
fn mirror_tiles<D: Dense>(m: &mut D, f: impl Fn(f64, f64) -> f64) {
    let n = m.rows();
    let mut c0 = 0;
    while c0 + 8 <= n {
        mirror_tile::<8, D>(m, c0, &f);
        c0 += 8;
    }
    for c in c0..n {
        mirror_tile::<1, D>(m, c, &f);
    }
}

/// Columns `c0..c0 + W` of [`mirror_tiles`].
#[inline(always)]
fn mirror_tile<const W: usize, D: Dense>(m: &mut D, c0: usize, f: &impl Fn(f64, f64) -> f64) {
    for r in 0..c0 + W {
        let mut seg = [0.0; W];
        seg.copy_from_slice(&m.col(r)[c0..c0 + W]);
        for (i, lower) in seg.iter_mut().enumerate() {
            if c0 + i > r {
                let upper = &mut m.col_mut(c0 + i)[r];
                *lower = f(*lower, *upper);
                *upper = *lower;
            }
        }
        m.col_mut(r)[c0..c0 + W].copy_from_slice(&seg);
    }
}

#[cfg(feature = "faer")]
impl Entries for Mat<f64> {
    #[inline(always)]
    fn col(&self, c: usize) -> &[f64] {
        self.col_as_slice(c)
    }
    #[inline(always)]
    fn col_mut(&mut self, c: usize) -> &mut [f64] {
        self.col_as_slice_mut(c)
    }
}

/// A heap-allocated dense covariance with scratch buffers (allocated on first use).
#[derive(Clone, Debug)]
pub struct DenseCov<D: Dense> {
    phi: D,
    tmp: D,
    tmp2: D,
    /// `N × 2M` and `2M × N` factors of the multiplied-out Joseph update, `M × N` `H`.
    wide: D,
    tall: D,
    h: D,
    /// Scratch of the block reset.
    scratch: Vec<f64>,
}

impl<D: Dense> Default for DenseCov<D> {
    fn default() -> Self {
        let z = || D::zeros(0, 0);
        Self { phi: z(), tmp: z(), tmp2: z(), wide: z(), tall: z(), h: z(), scratch: Vec::new() }
    }
}

/// nalgebra `DMatrix` storage with its (matrixmultiply) products: `P` on the heap, for
/// any compile-time state dimension.
pub type DynamicCov = DenseCov<DMatrix<f64>>;

/// `faer::Mat` storage with faer's single-threaded products (feature `faer`).
#[cfg(feature = "faer")]
pub type FaerCov = DenseCov<Mat<f64>>;

impl<N: DimName, D: Dense> CovBackend<N> for DenseCov<D>
where
    DefaultAllocator: DimAlloc<N>,
{
    type Cov = D;
    const NAME: &'static str = D::NAME;

    fn from_static(P: &Cov<N>) -> D {
        let mut out = D::zeros(N::DIM, N::DIM);
        to_dense(P, &mut out);
        out
    }

    fn as_static(P: &D) -> Cow<'_, Cov<N>> {
        let mut out = Cov::<N>::zeros();
        for (c, col) in out.as_mut_slice().chunks_exact_mut(N::DIM).enumerate() {
            col.copy_from_slice(P.col(c));
        }
        Cow::Owned(out)
    }

    fn diag(P: &D, i: usize) -> f64 {
        P.at(i, i)
    }

    fn propagate(&mut self, P: &D, Phi: &Cov<N>, Q: &Cov<N>, lambda: f64, out: &mut D) {
        ensure(&mut self.tmp, N::DIM);
        to_dense(Phi, &mut self.phi);
        to_dense(&Phi.transpose(), &mut self.tmp2);
        // tmp = Φ P; out = λ tmp Φᵀ + Q (Φᵀ copied, so no product allocates)
        D::gemm(&mut self.tmp, 0.0, 1.0, &self.phi, false, P, false);
        to_dense(Q, out);
        D::gemm_lower(out, 1.0, lambda, &self.tmp, &self.tmp2);
        mirror_lower(out);
    }

    fn p_times_ht<M: DimName>(&mut self, H: &OMatrix<f64, M, N>, P: &D) -> OMatrix<f64, N, M>
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        to_dense(&H.transpose(), &mut self.h);
        ensure_shape(&mut self.wide, N::DIM, M::DIM);
        D::sym_times_thin(&mut self.wide, P, &self.h);
        let mut out = OMatrix::<f64, N, M>::zeros();
        for (c, col) in out.as_mut_slice().chunks_exact_mut(N::DIM).enumerate() {
            col.copy_from_slice(self.wide.col(c));
        }
        out
    }

    fn scale_add<M: DimName>(
        &mut self,
        P: &D,
        a: f64,
        b: f64,
        U: &OMatrix<f64, M, N>,
        V: &OMatrix<f64, M, N>,
        out: &mut D,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        ensure(out, N::DIM);
        for c in 0..N::DIM {
            for r in 0..N::DIM {
                out.put(r, c, a * P.at(r, c));
            }
        }
        to_dense(U, &mut self.tmp);
        to_dense(V, &mut self.tmp2);
        // out += b Uᵀ V
        D::gemm(out, 1.0, b, &self.tmp, true, &self.tmp2, false);
        symmetrize_dense(out);
    }

    fn update<M: DimName>(
        &mut self,
        P: &D,
        K: &OMatrix<f64, N, M>,
        H: &OMatrix<f64, M, N>,
        PHt: &OMatrix<f64, N, M>,
        R: &OMatrix<f64, M, M>,
        S: &OMatrix<f64, M, M>,
        form: UpdateForm,
        out: &mut D,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let (n, m) = (N::DIM, M::DIM);
        match form {
            UpdateForm::Joseph => {
                // P + V Kᵀ + K Vᵀ = P + [V K] [K V]ᵀ, V = K S/2 − (H P)ᵀ: one N × 2M × N product
                let V = K * (S * 0.5) - PHt;
                ensure_shape(&mut self.wide, n, 2 * m);
                ensure_shape(&mut self.tall, 2 * m, n);
                set_factors(&mut self.wide, &mut self.tall, 0, &V, K);
                set_factors(&mut self.wide, &mut self.tall, m, K, &V);
                // only the lower triangle of P is needed: the upper one is mirrored after
                ensure(out, n);
                for c in 0..n {
                    out.col_mut(c)[c..].copy_from_slice(&P.col(c)[c..]);
                }
                D::gemm_lower(out, 1.0, 1.0, &self.wide, &self.tall);
                mirror_lower(out);
            }
            UpdateForm::JosephFactored => {
                // P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ, with I − K H and its transpose
                // written straight into the dense buffers.
                ensure(&mut self.phi, n);
                ensure(&mut self.tmp2, n);
                for c in 0..n {
                    for r in 0..n {
                        let kh: f64 = (0..m).map(|j| K[(r, j)] * H[(j, c)]).sum();
                        let v = if r == c { 1.0 - kh } else { -kh };
                        self.phi.put(r, c, v);
                        self.tmp2.put(c, r, v);
                    }
                }
                ensure(&mut self.tmp, n);
                D::gemm(&mut self.tmp, 0.0, 1.0, &self.phi, false, P, false);
                // K R Kᵀ as (K R) (Kᵀ)
                let KR = K * R;
                ensure_shape(&mut self.wide, n, m);
                ensure_shape(&mut self.tall, m, n);
                set_factors(&mut self.wide, &mut self.tall, 0, &KR, K);
                ensure(out, n);
                D::gemm(out, 0.0, 1.0, &self.wide, false, &self.tall, false);
                D::gemm(out, 1.0, 1.0, &self.tmp, false, &self.tmp2, false);
                symmetrize_dense(out);
            }
            UpdateForm::Short => {
                // P = P⁻ − K (H P⁻)
                ensure_shape(&mut self.wide, n, m);
                ensure_shape(&mut self.tall, m, n);
                set_factors(&mut self.wide, &mut self.tall, 0, K, PHt);
                copy_dense(P, out);
                D::gemm(out, 1.0, -1.0, &self.wide, false, &self.tall, false);
                symmetrize_dense(out);
            }
        }
    }

    fn reset_block(&mut self, P: &mut D, offset: usize, block: DMatrixView<'_, f64>) {
        let need = kernels::block_reset_scratch(block.nrows());
        if self.scratch.len() < need {
            self.scratch.resize(need, 0.0);
        }
        kernels::block_reset_in_place(P, N::DIM, offset, block, &mut self.scratch);
    }

    fn check_finite(what: &'static str, P: &D) -> Result<(), FilterError> {
        if (0..P.cols()).any(|c| has_non_finite(P.col(c))) {
            Err(FilterError::NonFinite { what })
        } else {
            Ok(())
        }
    }
}
