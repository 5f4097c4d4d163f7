//! Euclidean blocks: `R^N` as `nalgebra::SVector<f64, N>`, with `⊕ = +` and `⊖ = −`.

use nalgebra::{Const, DMatrixView, SMatrix, SVector};

use crate::traits::{Manifold, OminusJacobians, OplusJacobians};

/// `R^N`: a plain vector block (velocity, position, biases …).
pub type Rn<const N: usize> = SVector<f64, N>;
/// `R^1`.
pub type R1 = Rn<1>;
/// `R^2`.
pub type R2 = Rn<2>;
/// `R^3`.
pub type R3 = Rn<3>;

impl<const N: usize> Manifold for SVector<f64, N> {
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

    fn oplus_jacobians(&self, _delta: &Self) -> OplusJacobians<Self> {
        OplusJacobians { J_y_x: SMatrix::identity(), J_y_delta: SMatrix::identity() }
    }

    fn oplus_jacobian_delta(&self, _delta: &Self) -> SMatrix<f64, N, N> {
        SMatrix::identity()
    }

    /// `G = I`: no blocks.
    fn reset_blocks(&self, _delta: &Self, _visit: &mut dyn FnMut(usize, DMatrixView<'_, f64>)) {}

    fn ominus_jacobians(&self, _origin: &Self) -> OminusJacobians<Self> {
        OminusJacobians { J_d_y: SMatrix::identity(), J_d_x: -SMatrix::<f64, N, N>::identity() }
    }
}
