//! Euclidean blocks: `R^N` as `nalgebra::SVector<T, N>`, with `⊕ = +` and `⊖ = −`.

use nalgebra::{Const, DMatrixView, SMatrix, SVector};

use crate::scalar::Real;
use crate::traits::{Manifold, OminusJacobians, OplusJacobians};

/// `R^N`: a plain vector block (velocity, position, biases …), over `f64` unless named.
pub type Rn<const N: usize, T = f64> = SVector<T, N>;
/// `R^1`.
pub type R1<T = f64> = Rn<1, T>;
/// `R^2`.
pub type R2<T = f64> = Rn<2, T>;
/// `R^3`.
pub type R3<T = f64> = Rn<3, T>;

impl<T: Real, const N: usize> Manifold<T> for SVector<T, N> {
    type Dim = Const<N>;

    fn origin() -> Self {
        Self::zeros()
    }

    fn oplus(&self, delta: &Self) -> Self {
        self + delta
    }

    fn ominus(&self, origin: &Self) -> Self {
        self - origin
    }

    fn is_finite(&self) -> bool {
        self.iter().all(|v| v.is_finite())
    }

    fn oplus_jacobians(&self, _delta: &Self) -> OplusJacobians<Self, T> {
        OplusJacobians { J_y_x: SMatrix::identity(), J_y_delta: SMatrix::identity() }
    }

    fn oplus_jacobian_delta(&self, _delta: &Self) -> SMatrix<T, N, N> {
        SMatrix::identity()
    }

    /// `G = I`: no blocks.
    fn reset_blocks(&self, _delta: &Self, _visit: &mut dyn FnMut(usize, DMatrixView<'_, T>)) {}

    fn ominus_jacobians(&self, _origin: &Self) -> OminusJacobians<Self, T> {
        OminusJacobians { J_d_y: SMatrix::identity(), J_d_x: -SMatrix::<T, N, N>::identity() }
    }
}
