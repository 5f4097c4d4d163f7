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

fn symmetrize_dyn(m: &mut DMatrix<f64>) {
    let n = m.nrows();
    for c in 0..n {
        for r in (c + 1)..n {
            let v = 0.5 * (m[(r, c)] + m[(c, r)]);
            m[(r, c)] = v;
            m[(c, r)] = v;
        }
    }
}

fn to_dyn<R: DimName, C: DimName>(m: &OMatrix<f64, R, C>, out: &mut DMatrix<f64>)
where
    DefaultAllocator: nalgebra::allocator::Allocator<R, C>,
{
    if out.shape() != (R::DIM, C::DIM) {
        *out = DMatrix::zeros(R::DIM, C::DIM);
    }
    out.copy_from(m);
}

/// nalgebra `DMatrix` storage with its (matrixmultiply) products.
#[derive(Clone, Debug, Default)]
pub struct DynamicCov {
    phi: DMatrix<f64>,
    tmp: DMatrix<f64>,
    tmp2: DMatrix<f64>,
}

impl<N: DimName> CovBackend<N> for DynamicCov
where
    DefaultAllocator: DimAlloc<N>,
{
    type Cov = DMatrix<f64>;
    const NAME: &'static str = "nalgebra-dynamic";

    fn from_static(P: &Cov<N>) -> DMatrix<f64> {
        DMatrix::from_fn(N::DIM, N::DIM, |r, c| P[(r, c)])
    }

    fn as_static(P: &DMatrix<f64>) -> Cow<'_, Cov<N>> {
        Cow::Owned(Cov::<N>::from_fn(|r, c| P[(r, c)]))
    }

    fn diag(P: &DMatrix<f64>, i: usize) -> f64 {
        P[(i, i)]
    }

    fn propagate(
        &mut self,
        P: &DMatrix<f64>,
        Phi: &Cov<N>,
        Q: &Cov<N>,
        lambda: f64,
        out: &mut DMatrix<f64>,
    ) {
        let n = N::DIM;
        to_dyn(Phi, &mut self.phi);
        if self.tmp.shape() != (n, n) {
            self.tmp = DMatrix::zeros(n, n);
        }
        // tmp = Φ P; out = λ tmp Φᵀ + Q
        self.tmp.gemm(1.0, &self.phi, P, 0.0);
        to_dyn(Q, out);
        out.gemm(lambda, &self.tmp, &self.phi.transpose(), 1.0);
        symmetrize_dyn(out);
    }

    fn h_times_p<M: DimName>(
        &mut self,
        H: &OMatrix<f64, M, N>,
        P: &DMatrix<f64>,
    ) -> OMatrix<f64, M, N>
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        // (H P)_{ij} = Σ_k H_ik P_kj, with P symmetric: row i of H against columns of P.
        OMatrix::<f64, M, N>::from_fn(|i, j| (0..N::DIM).map(|k| H[(i, k)] * P[(k, j)]).sum())
    }

    fn scale_add<M: DimName>(
        &mut self,
        P: &DMatrix<f64>,
        a: f64,
        b: f64,
        U: &OMatrix<f64, M, N>,
        V: &OMatrix<f64, M, N>,
        out: &mut DMatrix<f64>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        out.copy_from(P);
        *out *= a;
        to_dyn(U, &mut self.tmp);
        to_dyn(V, &mut self.tmp2);
        out.gemm_tr(b, &self.tmp, &self.tmp2, 1.0);
        symmetrize_dyn(out);
    }

    fn update<M: DimName>(
        &mut self,
        P: &DMatrix<f64>,
        K: &OMatrix<f64, N, M>,
        H: &OMatrix<f64, M, N>,
        R: &OMatrix<f64, M, M>,
        short: bool,
        out: &mut DMatrix<f64>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let n = N::DIM;
        if short {
            let kh = K * H;
            to_dyn(&kh, &mut self.tmp);
            out.copy_from(P);
            out.gemm(-1.0, &self.tmp, P, 1.0);
        } else {
            // I − K H
            let ikh = Cov::<N>::identity() - K * H;
            to_dyn(&ikh, &mut self.phi);
            if self.tmp.shape() != (n, n) {
                self.tmp = DMatrix::zeros(n, n);
            }
            self.tmp.gemm(1.0, &self.phi, P, 0.0);
            let krk = K * R * K.transpose();
            to_dyn(&krk, out);
            out.gemm(1.0, &self.tmp, &self.phi.transpose(), 1.0);
        }
        symmetrize_dyn(out);
    }

    fn sandwich_in_place(&mut self, P: &mut DMatrix<f64>, G: &Cov<N>) {
        let n = N::DIM;
        to_dyn(G, &mut self.phi);
        if self.tmp.shape() != (n, n) {
            self.tmp = DMatrix::zeros(n, n);
        }
        self.tmp.gemm(1.0, &self.phi, P, 0.0);
        P.gemm(1.0, &self.tmp, &self.phi.transpose(), 0.0);
        symmetrize_dyn(P);
    }

    fn check_finite(what: &'static str, P: &DMatrix<f64>) -> Result<(), FilterError> {
        if P.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(FilterError::NonFinite { what })
        }
    }
}

fn to_faer<R: DimName, C: DimName>(m: &OMatrix<f64, R, C>, out: &mut Mat<f64>)
where
    DefaultAllocator: nalgebra::allocator::Allocator<R, C>,
{
    if out.nrows() != R::DIM || out.ncols() != C::DIM {
        *out = Mat::zeros(R::DIM, C::DIM);
    }
    for c in 0..C::DIM {
        for r in 0..R::DIM {
            out[(r, c)] = m[(r, c)];
        }
    }
}

fn symmetrize_faer(m: &mut Mat<f64>) {
    let n = m.nrows();
    for c in 0..n {
        for r in (c + 1)..n {
            let v = 0.5 * (m[(r, c)] + m[(c, r)]);
            m[(r, c)] = v;
            m[(c, r)] = v;
        }
    }
}

/// `faer::Mat` storage with faer's single-threaded products.
#[derive(Clone, Debug)]
pub struct FaerCov {
    phi: Mat<f64>,
    tmp: Mat<f64>,
    tmp2: Mat<f64>,
}

impl Default for FaerCov {
    fn default() -> Self {
        Self { phi: Mat::zeros(0, 0), tmp: Mat::zeros(0, 0), tmp2: Mat::zeros(0, 0) }
    }
}

impl<N: DimName> CovBackend<N> for FaerCov
where
    DefaultAllocator: DimAlloc<N>,
{
    type Cov = Mat<f64>;
    const NAME: &'static str = "faer";

    fn from_static(P: &Cov<N>) -> Mat<f64> {
        Mat::from_fn(N::DIM, N::DIM, |r, c| P[(r, c)])
    }

    fn as_static(P: &Mat<f64>) -> Cow<'_, Cov<N>> {
        Cow::Owned(Cov::<N>::from_fn(|r, c| P[(r, c)]))
    }

    fn diag(P: &Mat<f64>, i: usize) -> f64 {
        P[(i, i)]
    }

    fn propagate(
        &mut self,
        P: &Mat<f64>,
        Phi: &Cov<N>,
        Q: &Cov<N>,
        lambda: f64,
        out: &mut Mat<f64>,
    ) {
        let n = N::DIM;
        to_faer(Phi, &mut self.phi);
        if self.tmp.nrows() != n {
            self.tmp = Mat::zeros(n, n);
        }
        faer::linalg::matmul::matmul(
            self.tmp.as_mut(),
            Accum::Replace,
            self.phi.as_ref(),
            P.as_ref(),
            1.0,
            Par::Seq,
        );
        to_faer(Q, out);
        faer::linalg::matmul::matmul(
            out.as_mut(),
            Accum::Add,
            self.tmp.as_ref(),
            self.phi.as_ref().transpose(),
            lambda,
            Par::Seq,
        );
        symmetrize_faer(out);
    }

    fn h_times_p<M: DimName>(&mut self, H: &OMatrix<f64, M, N>, P: &Mat<f64>) -> OMatrix<f64, M, N>
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        OMatrix::<f64, M, N>::from_fn(|i, j| (0..N::DIM).map(|k| H[(i, k)] * P[(k, j)]).sum())
    }

    fn scale_add<M: DimName>(
        &mut self,
        P: &Mat<f64>,
        a: f64,
        b: f64,
        U: &OMatrix<f64, M, N>,
        V: &OMatrix<f64, M, N>,
        out: &mut Mat<f64>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let n = N::DIM;
        if out.nrows() != n {
            *out = Mat::zeros(n, n);
        }
        for c in 0..n {
            for r in 0..n {
                out[(r, c)] = a * P[(r, c)];
            }
        }
        to_faer(U, &mut self.tmp);
        to_faer(V, &mut self.tmp2);
        faer::linalg::matmul::matmul(
            out.as_mut(),
            Accum::Add,
            self.tmp.as_ref().transpose(),
            self.tmp2.as_ref(),
            b,
            Par::Seq,
        );
        symmetrize_faer(out);
    }

    fn update<M: DimName>(
        &mut self,
        P: &Mat<f64>,
        K: &OMatrix<f64, N, M>,
        H: &OMatrix<f64, M, N>,
        R: &OMatrix<f64, M, M>,
        short: bool,
        out: &mut Mat<f64>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let n = N::DIM;
        if out.nrows() != n {
            *out = Mat::zeros(n, n);
        }
        if short {
            to_faer(&(K * H), &mut self.tmp);
            for c in 0..n {
                for r in 0..n {
                    out[(r, c)] = P[(r, c)];
                }
            }
            faer::linalg::matmul::matmul(
                out.as_mut(),
                Accum::Add,
                self.tmp.as_ref(),
                P.as_ref(),
                -1.0,
                Par::Seq,
            );
        } else {
            to_faer(&(Cov::<N>::identity() - K * H), &mut self.phi);
            if self.tmp.nrows() != n {
                self.tmp = Mat::zeros(n, n);
            }
            faer::linalg::matmul::matmul(
                self.tmp.as_mut(),
                Accum::Replace,
                self.phi.as_ref(),
                P.as_ref(),
                1.0,
                Par::Seq,
            );
            to_faer(&(K * R * K.transpose()), out);
            faer::linalg::matmul::matmul(
                out.as_mut(),
                Accum::Add,
                self.tmp.as_ref(),
                self.phi.as_ref().transpose(),
                1.0,
                Par::Seq,
            );
        }
        symmetrize_faer(out);
    }

    fn sandwich_in_place(&mut self, P: &mut Mat<f64>, G: &Cov<N>) {
        let n = N::DIM;
        to_faer(G, &mut self.phi);
        if self.tmp.nrows() != n {
            self.tmp = Mat::zeros(n, n);
        }
        faer::linalg::matmul::matmul(
            self.tmp.as_mut(),
            Accum::Replace,
            self.phi.as_ref(),
            P.as_ref(),
            1.0,
            Par::Seq,
        );
        faer::linalg::matmul::matmul(
            P.as_mut(),
            Accum::Replace,
            self.tmp.as_ref(),
            self.phi.as_ref().transpose(),
            1.0,
            Par::Seq,
        );
        symmetrize_faer(P);
    }

    fn check_finite(what: &'static str, P: &Mat<f64>) -> Result<(), FilterError> {
        let n = P.nrows();
        for c in 0..n {
            for r in 0..n {
                if !P[(r, c)].is_finite() {
                    return Err(FilterError::NonFinite { what });
                }
            }
        }
        Ok(())
    }
}
