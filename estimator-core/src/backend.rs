//! Covariance back-ends: where `P` lives and who does its O(N³) and O(N²M) products.
//!
//! The filter is generic over a [`CovBackend`] with the static nalgebra back-end as the
//! default; the same filter code runs on all three:
//!
//! | back-end | `P` | products | best for |
//! |---|---|---|---|
//! | [`StaticCov`] | `OMatrix<f64, N, N>` on the stack | nalgebra static, or the model's structured propagation | small states (INS: 15) |
//! | [`DynamicCov`] | `DMatrix<f64>` | nalgebra dynamic (matrixmultiply) | medium states, sizes known at run time |
//! | [`FaerCov`] | `faer::Mat<f64>` | faer (single-threaded) | large states |
//!
//! Every operation writes into a caller-provided output so the filter stays unchanged
//! when a step fails. The dynamic back-ends allocate their scratch buffers once, on first
//! use; afterwards a step does not allocate.

use std::borrow::Cow;

use faer::{Accum, Mat, Par};
use nalgebra::{DMatrix, DefaultAllocator, DimName, OMatrix};

use manifolds::DimAlloc;

use crate::error::FilterError;
use crate::linalg::{check_finite, symmetrize};
use crate::traits::{Cov, FilterAlloc};

/// Storage and products of the covariance. See the [module docs](self).
pub trait CovBackend<N: DimName>: Clone + core::fmt::Debug + Default
where
    DefaultAllocator: DimAlloc<N>,
{
    /// The stored covariance.
    type Cov: Clone + core::fmt::Debug;

    /// Name for benches and logs.
    const NAME: &'static str;

    /// Convert from a static matrix.
    fn from_static(P: &Cov<N>) -> Self::Cov;

    /// The covariance as a static matrix (borrowed for the static back-end).
    fn as_static(P: &Self::Cov) -> Cow<'_, Cov<N>>;

    /// The static matrix inside, for the static back-end only (lets models propagate
    /// with their own structured products).
    fn static_mut(_P: &mut Self::Cov) -> Option<&mut Cov<N>> {
        None
    }

    /// `P[i, i]`.
    fn diag(P: &Self::Cov, i: usize) -> f64;

    /// `out ← λ Φ P Φᵀ + Q` (exactly symmetric).
    fn propagate(
        &mut self,
        P: &Self::Cov,
        Phi: &Cov<N>,
        Q: &Cov<N>,
        lambda: f64,
        out: &mut Self::Cov,
    );

    /// `H P` for an `M × N` matrix `H`.
    fn h_times_p<M: DimName>(
        &mut self,
        H: &OMatrix<f64, M, N>,
        P: &Self::Cov,
    ) -> OMatrix<f64, M, N>
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

    /// Joseph form `out ← (I − K H) P (I − K H)ᵀ + K R Kᵀ`, or the short form
    /// `out ← P − K (H P)` when `short` (exactly symmetric either way).
    #[allow(clippy::too_many_arguments)]
    fn update<M: DimName>(
        &mut self,
        P: &Self::Cov,
        K: &OMatrix<f64, N, M>,
        H: &OMatrix<f64, M, N>,
        R: &OMatrix<f64, M, M>,
        short: bool,
        out: &mut Self::Cov,
    ) where
        DefaultAllocator: FilterAlloc<N, M>;

    /// `P ← G P Gᵀ` in place (the reset).
    fn sandwich_in_place(&mut self, P: &mut Self::Cov, G: &Cov<N>);

    /// `Err(NonFinite)` when any entry is NaN or infinite.
    fn check_finite(what: &'static str, P: &Self::Cov) -> Result<(), FilterError>;
}

/// The default: a stack-allocated nalgebra matrix.
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

    fn static_mut(P: &mut Cov<N>) -> Option<&mut Cov<N>> {
        Some(P)
    }

    fn diag(P: &Cov<N>, i: usize) -> f64 {
        P[(i, i)]
    }

    fn propagate(&mut self, P: &Cov<N>, Phi: &Cov<N>, Q: &Cov<N>, lambda: f64, out: &mut Cov<N>) {
        // P⁻ = λ Φ P Φᵀ + Q_d
        *out = Phi * P * Phi.transpose() * lambda + Q;
        symmetrize(out);
    }

    fn h_times_p<M: DimName>(&mut self, H: &OMatrix<f64, M, N>, P: &Cov<N>) -> OMatrix<f64, M, N>
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        H * P
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
        R: &OMatrix<f64, M, M>,
        short: bool,
        out: &mut Cov<N>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        if short {
            // P = P⁻ − K H P⁻
            *out = P - K * (H * P);
        } else {
            // P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ   (Bar-Shalom et al. 2001, eq. 5.2.3-18)
            let IKH = Cov::<N>::identity() - K * H;
            *out = &IKH * P * IKH.transpose() + K * R * K.transpose();
        }
        symmetrize(out);
    }

    fn sandwich_in_place(&mut self, P: &mut Cov<N>, G: &Cov<N>) {
        *P = G * &*P * G.transpose();
        symmetrize(P);
    }

    fn check_finite(what: &'static str, P: &Cov<N>) -> Result<(), FilterError> {
        check_finite(what, P)
    }
}

/// The dense matrix operations the dynamic back-ends need; implemented for nalgebra's
/// `DMatrix` and faer's `Mat`, so [`DenseCov`] is written once.
pub trait Dense: Clone + core::fmt::Debug {
    /// Name of the back-end.
    const NAME: &'static str;
    /// An `r × c` zero matrix.
    fn zeros(r: usize, c: usize) -> Self;
    /// Rows.
    fn rows(&self) -> usize;
    /// Columns.
    fn cols(&self) -> usize;
    /// Entry `(r, c)`.
    fn get(&self, r: usize, c: usize) -> f64;
    /// Set entry `(r, c)`.
    fn set(&mut self, r: usize, c: usize, v: f64);
    /// `out ← β out + α op(a) op(b)` with `op` the transpose when the flag is set
    /// (`DMatrix` allocates for a transposed `b`; the back-end never asks for one).
    #[allow(clippy::too_many_arguments)]
    fn gemm(out: &mut Self, beta: f64, alpha: f64, a: &Self, at: bool, b: &Self, bt: bool);
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
    fn get(&self, r: usize, c: usize) -> f64 {
        self[(r, c)]
    }
    fn set(&mut self, r: usize, c: usize, v: f64) {
        self[(r, c)] = v;
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
    fn get(&self, r: usize, c: usize) -> f64 {
        self[(r, c)]
    }
    fn set(&mut self, r: usize, c: usize, v: f64) {
        self[(r, c)] = v;
    }
    fn gemm(out: &mut Self, beta: f64, alpha: f64, a: &Self, at: bool, b: &Self, bt: bool) {
        // faer accumulates or replaces: scale the output first when 0 < β ≠ 1.
        let accum = if beta == 0.0 {
            Accum::Replace
        } else {
            if beta != 1.0 {
                for c in 0..out.ncols() {
                    for r in 0..out.nrows() {
                        out[(r, c)] *= beta;
                    }
                }
            }
            Accum::Add
        };
        let (a, b) = (a.as_ref(), b.as_ref());
        let a = if at { a.transpose() } else { a };
        let b = if bt { b.transpose() } else { b };
        faer::linalg::matmul::matmul(out.as_mut(), accum, a, b, alpha, Par::Seq);
    }
}

fn symmetrize_dense<D: Dense>(m: &mut D) {
    let n = m.rows();
    for c in 0..n {
        for r in (c + 1)..n {
            let v = 0.5 * (m.get(r, c) + m.get(c, r));
            m.set(r, c, v);
            m.set(c, r, v);
        }
    }
}

/// Copy a static matrix into a dense one (reshaped when the size differs).
fn to_dense<D: Dense, R: DimName, C: DimName>(m: &OMatrix<f64, R, C>, out: &mut D)
where
    DefaultAllocator: nalgebra::allocator::Allocator<R, C>,
{
    if out.rows() != R::DIM || out.cols() != C::DIM {
        *out = D::zeros(R::DIM, C::DIM);
    }
    for c in 0..C::DIM {
        for r in 0..R::DIM {
            out.set(r, c, m[(r, c)]);
        }
    }
}

fn ensure<D: Dense>(m: &mut D, n: usize) {
    if m.rows() != n || m.cols() != n {
        *m = D::zeros(n, n);
    }
}

/// A heap-allocated dense covariance with scratch buffers (allocated on first use).
#[derive(Clone, Debug)]
pub struct DenseCov<D: Dense> {
    phi: D,
    tmp: D,
    tmp2: D,
}

impl<D: Dense> Default for DenseCov<D> {
    fn default() -> Self {
        Self { phi: D::zeros(0, 0), tmp: D::zeros(0, 0), tmp2: D::zeros(0, 0) }
    }
}

/// nalgebra `DMatrix` storage with its (matrixmultiply) products.
pub type DynamicCov = DenseCov<DMatrix<f64>>;

/// `faer::Mat` storage with faer's single-threaded products.
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
        Cow::Owned(Cov::<N>::from_fn(|r, c| P.get(r, c)))
    }

    fn diag(P: &D, i: usize) -> f64 {
        P.get(i, i)
    }

    fn propagate(&mut self, P: &D, Phi: &Cov<N>, Q: &Cov<N>, lambda: f64, out: &mut D) {
        ensure(&mut self.tmp, N::DIM);
        to_dense(Phi, &mut self.phi);
        to_dense(&Phi.transpose(), &mut self.tmp2);
        // tmp = Φ P; out = λ tmp Φᵀ + Q (Φᵀ copied, so no product allocates)
        D::gemm(&mut self.tmp, 0.0, 1.0, &self.phi, false, P, false);
        to_dense(Q, out);
        D::gemm(out, 1.0, lambda, &self.tmp, false, &self.tmp2, false);
        symmetrize_dense(out);
    }

    fn h_times_p<M: DimName>(&mut self, H: &OMatrix<f64, M, N>, P: &D) -> OMatrix<f64, M, N>
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        OMatrix::<f64, M, N>::from_fn(|i, j| (0..N::DIM).map(|k| H[(i, k)] * P.get(k, j)).sum())
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
                out.set(r, c, a * P.get(r, c));
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
        R: &OMatrix<f64, M, M>,
        short: bool,
        out: &mut D,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let n = N::DIM;
        ensure(out, n);
        if short {
            // P = P⁻ − (K H) P⁻
            to_dense(&(K * H), &mut self.tmp);
            for c in 0..n {
                for r in 0..n {
                    out.set(r, c, P.get(r, c));
                }
            }
            D::gemm(out, 1.0, -1.0, &self.tmp, false, P, false);
        } else {
            // P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ
            let ikh = Cov::<N>::identity() - K * H;
            to_dense(&ikh, &mut self.phi);
            to_dense(&ikh.transpose(), &mut self.tmp2);
            ensure(&mut self.tmp, n);
            D::gemm(&mut self.tmp, 0.0, 1.0, &self.phi, false, P, false);
            to_dense(&(K * R * K.transpose()), out);
            D::gemm(out, 1.0, 1.0, &self.tmp, false, &self.tmp2, false);
        }
        symmetrize_dense(out);
    }

    fn sandwich_in_place(&mut self, P: &mut D, G: &Cov<N>) {
        ensure(&mut self.tmp, N::DIM);
        to_dense(G, &mut self.phi);
        to_dense(&G.transpose(), &mut self.tmp2);
        D::gemm(&mut self.tmp, 0.0, 1.0, &self.phi, false, P, false);
        D::gemm(P, 0.0, 1.0, &self.tmp, false, &self.tmp2, false);
        symmetrize_dense(P);
    }

    fn check_finite(what: &'static str, P: &D) -> Result<(), FilterError> {
        for c in 0..P.cols() {
            for r in 0..P.rows() {
                if !P.get(r, c).is_finite() {
                    return Err(FilterError::NonFinite { what });
                }
            }
        }
        Ok(())
    }
}
