//! The heap back-ends (feature `std`): one dense implementation, [`DenseCov`], over
//! nalgebra's `DMatrix` ([`DynamicCov`]) and faer's `Mat` (`FaerCov`, feature `faer`).

use std::borrow::Cow;

#[cfg(feature = "faer")]
use faer::{Accum, Mat, Par};
use nalgebra::{DMatrix, DMatrixView, DefaultAllocator, DimName, OMatrix};

use manifolds::DimAlloc;

use super::{CovBackend, UpdateForm};
use crate::dims::{Cov, FilterAlloc};
use crate::entries::Entries;
use crate::error::FilterError;
use crate::kernels;
use crate::linalg::has_non_finite;

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
        let (corner, row) = self.scratch.split_at_mut(need - block.nrows());
        kernels::block_reset_in_place(P, N::DIM, offset, block, corner, row);
    }

    fn check_finite(what: &'static str, P: &D) -> Result<(), FilterError> {
        if (0..P.cols()).any(|c| has_non_finite(P.col(c))) {
            Err(FilterError::NonFinite { what })
        } else {
            Ok(())
        }
    }
}
