//! Small numerical helpers shared by the filter and the strategies: checks that name the
//! offending matrix, symmetrisation, Cholesky with a typed error.

use nalgebra::allocator::Allocator;
use nalgebra::{Cholesky, DMatrix, DefaultAllocator, DimName, OMatrix};

use crate::error::FilterError;

/// Relative tolerance of the symmetry check on user-supplied covariances.
pub const SYMMETRY_TOLERANCE: f64 = 1e-9;

/// `Err(NonFinite)` when any entry of `m` is NaN or infinite.
pub fn check_finite<R: DimName, C: DimName>(
    what: &'static str,
    m: &OMatrix<f64, R, C>,
) -> Result<(), FilterError>
where
    DefaultAllocator: Allocator<R, C>,
{
    if has_non_finite(m.as_slice()) {
        Err(FilterError::NonFinite { what })
    } else {
        Ok(())
    }
}

/// True when any value is NaN or infinite. Branch-free: a value is NaN or ±∞ exactly
/// when its exponent bits are all ones, and an integer OR-reduction of that flag over a
/// contiguous slice vectorises (a float sum would not, nor would nalgebra's strided
/// iterator).
pub fn has_non_finite(values: &[f64]) -> bool {
    const EXP: u64 = 0x7ff0_0000_0000_0000;
    values.iter().fold(0u64, |acc, v| acc | u64::from(v.to_bits() & EXP == EXP)) != 0
}

/// Replace `A` by `(A + Aᵀ)/2` in place.
pub fn symmetrize<D: DimName>(a: &mut OMatrix<f64, D, D>)
where
    DefaultAllocator: Allocator<D, D>,
{
    let n = D::DIM;
    for c in 0..n {
        for r in (c + 1)..n {
            let m = 0.5 * (a[(r, c)] + a[(c, r)]);
            a[(r, c)] = m;
            a[(c, r)] = m;
        }
    }
}

/// Cholesky factor of `a`, or `Err(NotPositiveDefinite { what })`.
pub fn cholesky<D: DimName>(
    what: &'static str,
    a: OMatrix<f64, D, D>,
) -> Result<Cholesky<f64, D>, FilterError>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    Cholesky::new(a).ok_or(FilterError::NotPositiveDefinite { what })
}

/// Validate a user-supplied covariance: finite, symmetric within
/// [`SYMMETRY_TOLERANCE`] (relative), positive definite.
pub fn check_covariance<D: DimName>(
    what: &'static str,
    a: &OMatrix<f64, D, D>,
) -> Result<(), FilterError>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    check_finite(what, a)?;
    let scale = a.iter().fold(0.0_f64, |m, v| m.max(v.abs())).max(f64::MIN_POSITIVE);
    let mut asym = 0.0_f64;
    for c in 0..D::DIM {
        for r in (c + 1)..D::DIM {
            asym = asym.max((a[(r, c)] - a[(c, r)]).abs());
        }
    }
    if asym > SYMMETRY_TOLERANCE * scale {
        return Err(FilterError::NotSymmetric { what, asymmetry: asym });
    }
    cholesky(what, a.clone_owned()).map(|_| ())
}

/// Convert a runtime-sized matrix (from a file or a config) to a fixed-size one,
/// `Err(DimensionMismatch)` when the shape is wrong.
pub fn fixed_from_dynamic<R: DimName, C: DimName>(
    what: &'static str,
    m: &DMatrix<f64>,
) -> Result<OMatrix<f64, R, C>, FilterError>
where
    DefaultAllocator: Allocator<R, C>,
{
    if m.nrows() != R::DIM || m.ncols() != C::DIM {
        return Err(FilterError::DimensionMismatch {
            what,
            expected: (R::DIM, C::DIM),
            found: (m.nrows(), m.ncols()),
        });
    }
    Ok(OMatrix::<f64, R, C>::from_fn(|r, c| m[(r, c)]))
}
