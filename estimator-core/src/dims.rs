//! Dimension vocabulary shared by every module: the allocator bundle of a filter and the
//! covariance alias.

use nalgebra::allocator::Allocator;
use nalgebra::{DimName, OMatrix};

use manifolds::{DimAlloc, Manifold};

/// Every allocator bound that generic code over a state dimension `N` and a measurement
/// dimension `M` needs, in one trait (design decision 2). Concrete `Const` dimensions
/// satisfy it automatically.
pub trait FilterAlloc<N: DimName, M: DimName>:
    DimAlloc<N> + DimAlloc<M> + Allocator<N, M> + Allocator<M, N>
{
}

impl<N: DimName, M: DimName, T> FilterAlloc<N, M> for T where
    T: DimAlloc<N> + DimAlloc<M> + Allocator<N, M> + Allocator<M, N>
{
}

/// Tangent dimension of a state type (over the scalar `T`, `f64` unless named).
pub type StateDim<X, T = f64> = <X as Manifold<T>>::Dim;

/// A square matrix over a tangent space of dimension `N` (covariances, Φ, Q), over `f64`
/// unless named.
pub type Cov<N, T = f64> = OMatrix<T, N, N>;
