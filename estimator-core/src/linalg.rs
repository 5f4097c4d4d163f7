//! Small numerical helpers shared by the filter and the strategies: checks that name the
//! offending matrix, symmetrisation, Cholesky with a typed error.

use nalgebra::allocator::Allocator;
#[cfg(feature = "std")]
use nalgebra::DMatrix;
use nalgebra::{Cholesky, DefaultAllocator, DimName, OMatrix, OVector};

use crate::error::FilterError;
use crate::scalar::FilterScalar;

/// Relative tolerance of the symmetry check on user-supplied covariances (in `f64`; a
/// coarser scalar's is `100 ε` when that is larger, see [`symmetry_tolerance`]).
pub const SYMMETRY_TOLERANCE: f64 = 1e-9;

/// The relative symmetry tolerance of the scalar `T`: [`SYMMETRY_TOLERANCE`] in `f64`,
/// `100 ε` in `f32` (1.2e-5).
pub fn symmetry_tolerance<T: FilterScalar>() -> f64 {
    SYMMETRY_TOLERANCE.max(100.0 * T::EPS_F64)
}

/// `Err(NonFinite)` when any entry of `m` is NaN or infinite.
pub fn check_finite<T: FilterScalar, R: DimName, C: DimName>(
    what: &'static str,
    m: &OMatrix<T, R, C>,
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

/// True when any value is NaN or infinite
/// ([`kernels::non_finite_in`](crate::kernels::non_finite_in)).
pub fn has_non_finite<T: FilterScalar>(values: &[T]) -> bool {
    T::non_finite_in(values)
}

/// Replace `A` by `(A + Aᵀ)/2` in place.
pub fn symmetrize<T: FilterScalar, D: DimName>(a: &mut OMatrix<T, D, D>)
where
    DefaultAllocator: Allocator<D, D>,
{
    let n = D::DIM;
    let half = T::lit(0.5);
    for c in 0..n {
        for r in (c + 1)..n {
            let m = half * (a[(r, c)] + a[(c, r)]);
            a[(r, c)] = m;
            a[(c, r)] = m;
        }
    }
}

/// Cholesky factor of `a`, or `Err(NotPositiveDefinite { what })`.
pub fn cholesky<T: FilterScalar, D: DimName>(
    what: &'static str,
    a: OMatrix<T, D, D>,
) -> Result<Cholesky<T, D>, FilterError>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    Cholesky::new(a).ok_or(FilterError::NotPositiveDefinite { what })
}

/// `eᵀ A⁻¹ e` for `A = L Lᵀ` given by its Cholesky factor: `|L⁻¹ e|²`, one forward
/// substitution (half the work of solving `A x = e`).
pub fn whitened_norm_sq<T: FilterScalar, D: DimName>(chol: &Cholesky<T, D>, e: &OVector<T, D>) -> T
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    let l = chol.l_dirty();
    // The reciprocals of the diagonal first: independent divisions, off the substitution's
    // chain of dependent steps.
    let inv_diag = OVector::<T, D>::from_fn(|i, _| T::one() / l[(i, i)]);
    let mut y = e.clone_owned();
    for i in 0..D::DIM {
        let v = (0..i).fold(y[i], |v, k| v - l[(i, k)] * y[k]);
        y[i] = v * inv_diag[i];
    }
    y.norm_squared()
}

/// What one pass over a finite square matrix finds: its largest magnitude (`scale`, at
/// least the smallest positive number), its largest off-diagonal one, its largest
/// `|A − Aᵀ|` entry and whether its diagonal is positive.
struct Symmetry {
    scale: f64,
    off_diagonal: f64,
    asymmetry: f64,
    diagonal_positive: bool,
}

/// [`Symmetry`] of the column-major `n × n` matrix `s`, in one pass over the strict lower
/// triangle and its mirror (slices, not nalgebra's strided indexing: this runs on every
/// update's `R`). The values are finite here, so a plain comparison serves as the
/// maximum: `f64::max` spends more instructions on NaN than this whole check on the
/// numbers.
fn symmetry_of<T: FilterScalar>(s: &[T], n: usize) -> Symmetry {
    let max = |m: f64, x: f64| if x > m { x } else { m };
    let (mut diagonal, mut asym, mut off_diagonal) = (f64::MIN_POSITIVE, 0.0_f64, 0.0_f64);
    let mut diagonal_positive = true;
    for c in 0..n {
        let d = s[c * n + c].to_f64();
        diagonal = max(diagonal, d.abs());
        diagonal_positive &= d > 0.0;
        for r in (c + 1)..n {
            let (lo, up) = (s[c * n + r].to_f64(), s[r * n + c].to_f64());
            off_diagonal = max(max(off_diagonal, lo.abs()), up.abs());
            asym = max(asym, (lo - up).abs());
        }
    }
    Symmetry {
        scale: max(diagonal, off_diagonal),
        off_diagonal,
        asymmetry: asym,
        diagonal_positive,
    }
}

/// Validate a user-supplied covariance: finite, symmetric within
/// [`SYMMETRY_TOLERANCE`] (relative), positive definite.
pub fn check_covariance<T: FilterScalar, D: DimName>(
    what: &'static str,
    a: &OMatrix<T, D, D>,
) -> Result<(), FilterError>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    check_finite(what, a)?;
    let s = symmetry_of(a.as_slice(), D::DIM);
    if s.asymmetry > symmetry_tolerance::<T>() * s.scale {
        return Err(FilterError::NotSymmetric { what, asymmetry: s.asymmetry });
    }
    let (off_diagonal, diagonal_positive) = (s.off_diagonal, s.diagonal_positive);
    // A diagonal matrix (the usual measurement noise) is positive definite exactly when
    // its diagonal is positive: no factorisation needed.
    if off_diagonal == 0.0 {
        return if diagonal_positive {
            Ok(())
        } else {
            Err(FilterError::NotPositiveDefinite { what })
        };
    }
    cholesky(what, a.clone_owned()).map(|_| ())
}

/// Validate a process model's discrete noise `Q_d`: finite, symmetric within
/// [`SYMMETRY_TOLERANCE`] (relative), and positive semi-definite within the tolerance
/// `1e-12 · max|Q_ij|` on the pivots of an LDLᵀ factorisation (zero rows, such as a
/// position block without noise of its own, are allowed). `O(N³/6)`.
pub fn check_process_noise<T: FilterScalar, D: DimName>(
    model: &'static str,
    q: &OMatrix<T, D, D>,
) -> Result<(), FilterError>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    let err = |problem, value| FilterError::InvalidProcessNoise { model, problem, value };
    if has_non_finite(q.as_slice()) {
        return Err(err("not finite", f64::NAN));
    }
    let n = D::DIM;
    let sym = symmetry_of(q.as_slice(), n);
    if sym.asymmetry > symmetry_tolerance::<T>() * sym.scale {
        return Err(err("not symmetric", sym.asymmetry));
    }
    let scale = sym.scale;
    if scale <= f64::MIN_POSITIVE {
        return Ok(());
    }
    // LDLᵀ of the lower triangle (Q = L D Lᵀ, unit L): a negative pivot beyond the
    // tolerance means an indefinite Q; a pivot within it is a zero direction, whose column
    // must then vanish too.
    // (in f64 whatever the scalar: these are the checks' own numbers; a coarser scalar's
    // pivot tolerance is 10 ε when that is larger)
    let tol = 1e-12f64.max(10.0 * T::EPS_F64) * scale;
    let mut a = OMatrix::<f64, D, D>::from_fn(|r, c| q[(r, c)].to_f64());
    let mut col = OVector::<f64, D>::zeros();
    for j in 0..n {
        let d = a[(j, j)];
        if d < -tol {
            return Err(err("not positive semi-definite", d));
        }
        if d <= tol {
            // a (numerically) zero variance: for a semi-definite Q its whole row is zero
            // (|Q_ij|² ≤ Q_ii Q_jj)
            let row_tol = 1e-6f64.max(100.0 * T::EPS_F64) * scale;
            if let Some(i) = ((j + 1)..n).find(|&i| a[(i, j)].abs() > row_tol) {
                return Err(err("not positive semi-definite", -a[(i, j)].abs()));
            }
            continue;
        }
        for (i, c) in col.iter_mut().enumerate().skip(j + 1) {
            *c = a[(i, j)];
        }
        // Schur complement of the pivot, lower triangle
        for i in (j + 1)..n {
            for k in (j + 1)..=i {
                a[(i, k)] -= col[i] * col[k] / d;
            }
        }
    }
    Ok(())
}

/// Convert a runtime-sized matrix (from a file or a config) to a fixed-size one,
/// `Err(DimensionMismatch)` when the shape is wrong.
#[cfg(feature = "std")]
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

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix4, Vector4};

    #[test]
    fn non_finite_values_are_found_anywhere() {
        for len in [0usize, 1, 15, 16, 17, 40] {
            let clean = vec![1e300; len];
            assert!(!has_non_finite(&clean), "len {len}");
            assert!(!crate::kernels::non_finite_in_portable(&clean), "len {len}");
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                for at in 0..len {
                    let mut v = clean.clone();
                    v[at] = bad;
                    assert!(has_non_finite(&v), "len {len}, {bad} at {at}");
                    assert!(crate::kernels::non_finite_in_portable(&v), "len {len}, {bad} at {at}");
                }
            }
        }
    }

    #[test]
    fn whitened_norm_equals_quadratic_form_with_the_inverse() {
        for seed in 0..20u32 {
            let f = |i: usize, j: usize| {
                (((i * 7 + j * 3 + seed as usize * 5) % 11) as f64 - 5.0) * 0.3
            };
            let a = Matrix4::from_fn(f);
            let s = a * a.transpose() + Matrix4::identity() * 0.1;
            let e = Vector4::from_fn(|i, _| f(i, 9) + 0.5);
            let chol = cholesky("test", s).unwrap();
            let direct = e.dot(&(s.try_inverse().unwrap() * e));
            assert!((whitened_norm_sq(&chol, &e) - direct).abs() <= 1e-10 * direct.max(1.0));
        }
    }
}
