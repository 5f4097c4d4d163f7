//! Product states: tuples of manifolds and named composite states (the crate's "Products").

use core::marker::PhantomData;
use core::ops::Range;

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, DimNameAdd, DimNameSum, OMatrix, OVector};

pub(crate) use crate::blocks::{block_of, set_block, set_diagonal_block};
use crate::scalar::Real;
use crate::traits::{DimAlloc, Manifold, Tangent, TangentMatrix};

/// A typed handle on one block of a composite state's tangent space: its offset and
/// the manifold it belongs to. Composite states expose one per field (e.g.
/// `InsState::ATT`), so code names blocks instead of using bare indices.
pub struct Block<M> {
    offset: usize,
    _m: PhantomData<fn() -> M>,
}

impl<M> Clone for Block<M> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<M> Copy for Block<M> {}

impl<M> core::fmt::Debug for Block<M> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "Block({}..)", self.offset)
    }
}

impl<M> Block<M> {
    /// A block starting at `offset`.
    pub const fn new(offset: usize) -> Self {
        Self { offset, _m: PhantomData }
    }

    /// First tangent index of the block.
    pub const fn start(&self) -> usize {
        self.offset
    }

    /// Tangent dimension of the block.
    pub const fn len<T: Real>(&self) -> usize
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim>,
    {
        M::DIM
    }

    /// Blocks are never empty unless their manifold is zero-dimensional.
    pub const fn is_empty<T: Real>(&self) -> bool
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim>,
    {
        M::DIM == 0
    }

    /// The tangent index range of the block.
    pub const fn range<T: Real>(&self) -> Range<usize>
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim>,
    {
        self.offset..self.offset + M::DIM
    }

    /// The block's part of a full tangent vector (or of a gain column, a residual …).
    pub fn of<T: Real, D: DimName>(&self, v: &OVector<T, D>) -> Tangent<M, T>
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim> + Allocator<D>,
    {
        block_of::<D, M::Dim, T>(v, self.offset)
    }

    /// The block's diagonal sub-matrix of a full covariance.
    pub fn cov<T: Real, D: DimName>(&self, P: &OMatrix<T, D, D>) -> TangentMatrix<M, T>
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim> + Allocator<D, D>,
    {
        TangentMatrix::<M, T>::from_fn(|r, c| P[(self.offset + r, self.offset + c)])
    }

    /// 1σ of each component of the block from a full covariance.
    pub fn sigma<T: Real, D: DimName>(&self, P: &OMatrix<T, D, D>) -> Tangent<M, T>
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim> + Allocator<D, D>,
    {
        Tangent::<M, T>::from_fn(|r, _| P[(self.offset + r, self.offset + r)].max(T::zero()).sqrt())
    }
}

macro_rules! impl_tuple_manifold {
    (
        dim = $Dim:ty;
        bounds = [$($bound:tt)*];
        $($T:ident . $idx:tt),+
    ) => {
        impl<Sc: Real, $($T: Manifold<Sc>),+> Manifold<Sc> for ($($T,)+)
        where
            $($bound)*
            DefaultAllocator: $(DimAlloc<$T::Dim> +)+ DimAlloc<$Dim>,
        {
            type Dim = $Dim;

            fn origin() -> Self {
                ($($T::origin(),)+)
            }

            fn oplus(&self, delta: &Tangent<Self, Sc>) -> Self {
                let mut _off = 0usize;
                ($({
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    _off += $T::DIM;
                    self.$idx.oplus(&d)
                },)+)
            }

            fn ominus(&self, origin: &Self) -> Tangent<Self, Sc> {
                let mut out = Tangent::<Self, Sc>::zeros();
                let mut _off = 0usize;
                $(
                    set_block(&mut out, _off, &self.$idx.ominus(&origin.$idx));
                    _off += $T::DIM;
                )+
                out
            }

            fn is_finite(&self) -> bool {
                true $(&& self.$idx.is_finite())+
            }

            fn oplus_jacobians(&self, delta: &Tangent<Self, Sc>) -> crate::OplusJacobians<Self, Sc> {
                let mut J_y_x = TangentMatrix::<Self, Sc>::zeros();
                let mut J_y_delta = TangentMatrix::<Self, Sc>::zeros();
                let mut _off = 0usize;
                $(
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    let j = self.$idx.oplus_jacobians(&d);
                    set_diagonal_block(&mut J_y_x, _off, &j.J_y_x);
                    set_diagonal_block(&mut J_y_delta, _off, &j.J_y_delta);
                    _off += $T::DIM;
                )+
                crate::OplusJacobians { J_y_x, J_y_delta }
            }

            fn oplus_jacobian_delta(&self, delta: &Tangent<Self, Sc>) -> TangentMatrix<Self, Sc> {
                let mut J_y_delta = TangentMatrix::<Self, Sc>::zeros();
                let mut _off = 0usize;
                $(
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    set_diagonal_block(&mut J_y_delta, _off, &self.$idx.oplus_jacobian_delta(&d));
                    _off += $T::DIM;
                )+
                J_y_delta
            }

            fn reset_blocks(
                &self,
                delta: &Tangent<Self, Sc>,
                visit: &mut dyn FnMut(usize, nalgebra::DMatrixView<'_, Sc>),
            ) {
                let mut _off = 0usize;
                $(
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    self.$idx.reset_blocks(&d, &mut |o, b| visit(_off + o, b));
                    _off += $T::DIM;
                )+
            }

            fn oplus_reset(
                &self,
                delta: &Tangent<Self, Sc>,
                visit: &mut dyn FnMut(usize, nalgebra::DMatrixView<'_, Sc>),
            ) -> Self {
                let mut _off = 0usize;
                ($({
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    let off = _off;
                    _off += $T::DIM;
                    self.$idx.oplus_reset(&d, &mut |o, b| visit(off + o, b))
                },)+)
            }

            fn ominus_jacobians(&self, origin: &Self) -> crate::OminusJacobians<Self, Sc> {
                let mut J_d_y = TangentMatrix::<Self, Sc>::zeros();
                let mut J_d_x = TangentMatrix::<Self, Sc>::zeros();
                let mut _off = 0usize;
                $(
                    let j = self.$idx.ominus_jacobians(&origin.$idx);
                    set_diagonal_block(&mut J_d_y, _off, &j.J_d_y);
                    set_diagonal_block(&mut J_d_x, _off, &j.J_d_x);
                    _off += $T::DIM;
                )+
                crate::OminusJacobians { J_d_y, J_d_x }
            }
        }
    };
}

type S2<A, B, Sc> = DimNameSum<<A as Manifold<Sc>>::Dim, <B as Manifold<Sc>>::Dim>;
type S3<A, B, C, Sc> = DimNameSum<S2<A, B, Sc>, <C as Manifold<Sc>>::Dim>;
type S4<A, B, C, D, Sc> = DimNameSum<S3<A, B, C, Sc>, <D as Manifold<Sc>>::Dim>;
type S5<A, B, C, D, E, Sc> = DimNameSum<S4<A, B, C, D, Sc>, <E as Manifold<Sc>>::Dim>;
type S6<A, B, C, D, E, F, Sc> = DimNameSum<S5<A, B, C, D, E, Sc>, <F as Manifold<Sc>>::Dim>;

impl_tuple_manifold!(
    dim = S2<A, B, Sc>;
    bounds = [A::Dim: DimNameAdd<B::Dim>,];
    A.0, B.1
);
impl_tuple_manifold!(
    dim = S3<A, B, C, Sc>;
    bounds = [A::Dim: DimNameAdd<B::Dim>, S2<A, B, Sc>: DimNameAdd<C::Dim>,];
    A.0, B.1, C.2
);
impl_tuple_manifold!(
    dim = S4<A, B, C, D, Sc>;
    bounds = [
        A::Dim: DimNameAdd<B::Dim>,
        S2<A, B, Sc>: DimNameAdd<C::Dim>,
        S3<A, B, C, Sc>: DimNameAdd<D::Dim>,
    ];
    A.0, B.1, C.2, D.3
);
impl_tuple_manifold!(
    dim = S5<A, B, C, D, E, Sc>;
    bounds = [
        A::Dim: DimNameAdd<B::Dim>,
        S2<A, B, Sc>: DimNameAdd<C::Dim>,
        S3<A, B, C, Sc>: DimNameAdd<D::Dim>,
        S4<A, B, C, D, Sc>: DimNameAdd<E::Dim>,
    ];
    A.0, B.1, C.2, D.3, E.4
);
impl_tuple_manifold!(
    dim = S6<A, B, C, D, E, F, Sc>;
    bounds = [
        A::Dim: DimNameAdd<B::Dim>,
        S2<A, B, Sc>: DimNameAdd<C::Dim>,
        S3<A, B, C, Sc>: DimNameAdd<D::Dim>,
        S4<A, B, C, D, Sc>: DimNameAdd<E::Dim>,
        S5<A, B, C, D, E, Sc>: DimNameAdd<F::Dim>,
    ];
    A.0, B.1, C.2, D.3, E.4, F.5
);

// the macros of `composite_state!` (exported at the crate root)
mod composite;
