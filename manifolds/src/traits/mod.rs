//! The [`Manifold`] trait, its tangent-space aliases and the allocator bundle.

use core::fmt::Debug;

use nalgebra::allocator::Allocator;
use nalgebra::{DMatrixView, DefaultAllocator, DimName, OMatrix, OVector, U1};

use crate::scalar::Real;

pub mod numdiff;

/// Every allocator bound that generic code over one tangent dimension `D` needs, in one
/// trait: vectors, square matrices and row vectors of size `D`.
///
/// Generic items carry the single bound `DefaultAllocator: DimAlloc<M::Dim>`; concrete
/// dimensions (`Const<N>`) satisfy it automatically, so users writing concrete models
/// never see it.
pub trait DimAlloc<D: DimName>: Allocator<D> + Allocator<D, D> + Allocator<U1, D> {}

impl<D: DimName, T> DimAlloc<D> for T where T: Allocator<D> + Allocator<D, D> + Allocator<U1, D> {}

/// A tangent vector of manifold `M` over the scalar `T` (stack-allocated for constant
/// dimensions).
pub type Tangent<M, T = f64> = OVector<T, <M as Manifold<T>>::Dim>;

/// A square matrix over the tangent space of `M` (covariances, Jacobians of ⊕/⊖).
pub type TangentMatrix<M, T = f64> = OMatrix<T, <M as Manifold<T>>::Dim, <M as Manifold<T>>::Dim>;

/// Jacobians of `y = x ⊕ δ`, each taken through ⊕/⊖ at zero perturbation:
/// `J_y_x = ∂((x ⊕ ε) ⊕ δ ⊖ y)/∂ε` and `J_y_delta = ∂((x ⊕ (δ + ε)) ⊖ y)/∂ε`.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct OplusJacobians<M: Manifold<T>, T: Real = f64>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    /// `∂(x ⊕ δ)/∂x`.
    pub J_y_x: TangentMatrix<M, T>,
    /// `∂(x ⊕ δ)/∂δ`; at the injected correction this is the exact reset Jacobian.
    pub J_y_delta: TangentMatrix<M, T>,
}

/// Jacobians of `δ = y ⊖ x`: `J_d_y = ∂((y ⊕ ε) ⊖ x)/∂ε`, `J_d_x = ∂(y ⊖ (x ⊕ ε))/∂ε`.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct OminusJacobians<M: Manifold<T>, T: Real = f64>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    /// `∂(y ⊖ x)/∂y`.
    pub J_d_y: TangentMatrix<M, T>,
    /// `∂(y ⊖ x)/∂x`.
    pub J_d_x: TangentMatrix<M, T>,
}

/// A smooth manifold with a retraction `⊕` and its local inverse `⊖`.
///
/// # Contract
///
/// For every point `x`, every `y` near `x` and every tangent `δ` inside the chart
/// (for rotations: `|δ| < π`):
///
/// ```text
/// x ⊕ 0        = x
/// x ⊕ (y ⊖ x)  = y
/// (x ⊕ δ) ⊖ x  = δ
/// ```
///
/// # Perturbation side
///
/// One convention, stated once for the whole project: **right (body-frame)
/// perturbation**. For a rotation, `R ⊕ δθ = R · Exp(δθ)` and `S ⊖ R = Log(R⁻¹ · S)`;
/// Euclidean blocks are additive. A true state is `nominal ⊕ δx` everywhere, with no
/// per-block sign flips. A different side would be a different type, never a flag.
///
/// # Scalar
///
/// `T` is the scalar of the representation and of the tangents, `f64` unless named:
/// `impl Manifold for MyState` is `Manifold<f64>`; the built-in types implement
/// `Manifold<T>` for both [`Real`] scalars (`So3<f32>: Manifold<f32>`).
///
/// # Jacobians
///
/// [`oplus_jacobians`](Manifold::oplus_jacobians) and
/// [`ominus_jacobians`](Manifold::ominus_jacobians) default to central differences taken
/// through ⊕/⊖; built-in types override them with analytic forms, and the law harness
/// (`manifolds::testing`, feature `testing`) checks every override against differences.
///
/// # Example
///
/// ```
/// use manifolds::{Manifold, So3, Tangent};
/// use nalgebra::Vector3;
///
/// let x = So3::exp(&Vector3::new(0.1, -0.2, 0.3));
/// let d = Vector3::new(0.01, 0.02, -0.03);
/// let y = x.oplus(&d);
/// assert!((y.ominus(&x) - d).norm() < 1e-12);           // (x ⊕ δ) ⊖ x = δ
/// assert!(x.oplus(&y.ominus(&x)).ominus(&y).norm() < 1e-12); // x ⊕ (y ⊖ x) = y
/// ```
pub trait Manifold<T: Real = f64>: Clone + Debug
where
    DefaultAllocator: DimAlloc<Self::Dim>,
{
    /// Dimension of the tangent space (`Const<N>` for concrete types).
    type Dim: DimName;

    /// The tangent dimension as a value.
    const DIM: usize = <Self::Dim as DimName>::DIM;

    /// A distinguished point: the identity of a group, the zero of a vector space.
    fn origin() -> Self;

    /// `self ⊕ delta`.
    fn oplus(&self, delta: &Tangent<Self, T>) -> Self;

    /// `self ⊖ origin`: the tangent at `origin` that carries it to `self`.
    fn ominus(&self, origin: &Self) -> Tangent<Self, T>;

    /// True when every number in the representation is finite.
    fn is_finite(&self) -> bool;

    /// Jacobians of `self ⊕ delta`. Default: central differences through ⊕/⊖.
    fn oplus_jacobians(&self, delta: &Tangent<Self, T>) -> OplusJacobians<Self, T> {
        let y = self.oplus(delta);
        OplusJacobians {
            J_y_x: numdiff::jacobian(self, |x| x.oplus(delta).ominus(&y), T::DIFF_STEP),
            J_y_delta: numdiff::jacobian_of_tangent::<Self, Self::Dim, T>(
                delta,
                |d| self.oplus(d).ominus(&y),
                T::DIFF_STEP,
            ),
        }
    }

    /// `∂(self ⊕ δ)/∂δ` alone: the reset Jacobian of an error-state filter, needed at every
    /// update. Default: `oplus_jacobians(delta).J_y_delta`; override it when `J_y_x` is
    /// costly (the product manifolds and the geodetic position do).
    fn oplus_jacobian_delta(&self, delta: &Tangent<Self, T>) -> TangentMatrix<Self, T> {
        self.oplus_jacobians(delta).J_y_delta
    }

    /// The reset Jacobian `G = ∂(self ⊕ δ)/∂δ` by its diagonal blocks that differ from the
    /// identity: `visit(offset, block)` is called once per block, in increasing `offset`,
    /// with a square `block` whose first row and column are `offset`; `G` is the identity
    /// outside those blocks. An error-state filter applies `P ← G P Gᵀ` to those rows and
    /// columns only: nothing for a vector state, two 3×3 blocks for an INS state.
    ///
    /// Default: [`oplus_jacobian_delta`](Self::oplus_jacobian_delta) as one block, not
    /// reported when it is exactly the identity. Products report their parts' blocks at the
    /// parts' offsets; vector spaces report none. The law harness checks that the blocks
    /// assemble to `oplus_jacobian_delta`.
    fn reset_blocks(
        &self,
        delta: &Tangent<Self, T>,
        visit: &mut dyn FnMut(usize, DMatrixView<'_, T>),
    ) {
        let g = self.oplus_jacobian_delta(delta);
        if g != TangentMatrix::<Self, T>::identity() {
            visit(0, DMatrixView::from_slice(g.as_slice(), Self::DIM, Self::DIM));
        }
    }

    /// `self ⊕ δ` and its reset blocks ([`reset_blocks`](Self::reset_blocks)) in one
    /// call, as an error-state filter needs them when it injects a correction: some
    /// manifolds share work between the two (a geodetic position's metric). Default:
    /// `reset_blocks` then `oplus`. The law harness checks that an override gives the
    /// same point and the same blocks.
    fn oplus_reset(
        &self,
        delta: &Tangent<Self, T>,
        visit: &mut dyn FnMut(usize, DMatrixView<'_, T>),
    ) -> Self {
        self.reset_blocks(delta, visit);
        self.oplus(delta)
    }

    /// Jacobians of `self ⊖ origin`. Default: central differences through ⊕/⊖.
    fn ominus_jacobians(&self, origin: &Self) -> OminusJacobians<Self, T> {
        OminusJacobians {
            J_d_y: numdiff::jacobian(self, |y| y.ominus(origin), T::DIFF_STEP),
            J_d_x: numdiff::jacobian(origin, |x| self.ominus(x), T::DIFF_STEP),
        }
    }
}
