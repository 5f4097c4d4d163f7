//! Reading and writing a block of rows of a vector, or a block on a matrix's diagonal:
//! what the products' ⊕/⊖ (and the code `composite_state!` generates) and the samplers of
//! `testing` assemble their vectors and matrices with.

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, OMatrix, OVector};

use crate::scalar::Real;

/// Copy of the block of `v` that starts at `offset` and has `B::DIM` rows.
pub(crate) fn block_of<D, B, T: Real>(v: &OVector<T, D>, offset: usize) -> OVector<T, B>
where
    D: DimName,
    B: DimName,
    DefaultAllocator: Allocator<D> + Allocator<B>,
{
    OVector::<T, B>::from_fn(|i, _| v[offset + i])
}

/// Write `b` into `v` from row `offset` on.
#[doc(hidden)]
pub fn set_block<D, B, T: Real>(v: &mut OVector<T, D>, offset: usize, b: &OVector<T, B>)
where
    D: DimName,
    B: DimName,
    DefaultAllocator: Allocator<D> + Allocator<B>,
{
    for i in 0..B::DIM {
        v[offset + i] = b[i];
    }
}

/// Write the square block `b` on the diagonal of `m` at `(offset, offset)`.
#[doc(hidden)]
pub fn set_diagonal_block<D, B, T: Real>(
    m: &mut OMatrix<T, D, D>,
    offset: usize,
    b: &OMatrix<T, B, B>,
) where
    D: DimName,
    B: DimName,
    DefaultAllocator: Allocator<D, D> + Allocator<B, B>,
{
    for c in 0..B::DIM {
        for r in 0..B::DIM {
            m[(offset + r, offset + c)] = b[(r, c)];
        }
    }
}
