//! Consistency statistics: NEES and NIS with χ² bounds (quantiles from `statrs`).
//!
//! For a consistent filter the NEES `ε = eᵀ P⁻¹ e` of an `n`-dimensional error is χ²(n);
//! averaged over `R` independent runs, `R·ε̄ ~ χ²(R n)`, so the two-sided band at
//! confidence `c` is `[χ²_{(1−c)/2}(Rn)/R, χ²_{(1+c)/2}(Rn)/R]`
//! (Bar-Shalom, Li & Kirubarajan 2001, §5.4.2).

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, OMatrix, OVector};
use statrs::distribution::{ChiSquared, ContinuousCDF};

use crate::error::FilterError;
use crate::linalg::{cholesky, whitened_norm_sq};

/// `eᵀ P⁻¹ e` through a Cholesky solve (NEES for a state error, NIS for an innovation).
pub fn normalized_squared<D: DimName>(
    e: &OVector<f64, D>,
    P: &OMatrix<f64, D, D>,
) -> Result<f64, FilterError>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    let chol = cholesky("covariance of the NEES/NIS", P.clone_owned())?;
    Ok(whitened_norm_sq(&chol, e))
}

/// The `p` quantile of χ²(`dof`).
pub fn chi2_quantile(p: f64, dof: f64) -> f64 {
    match ChiSquared::new(dof) {
        Ok(d) => d.inverse_cdf(p),
        Err(_) => f64::NAN,
    }
}

/// Two-sided band for the mean NEES/NIS of `dim`-dimensional quantities averaged over
/// `runs` independent runs, at confidence `confidence` (e.g. 0.95).
pub fn averaged_chi2_band(dim: usize, runs: usize, confidence: f64) -> (f64, f64) {
    let k = (dim * runs) as f64;
    let r = runs as f64;
    let tail = 0.5 * (1.0 - confidence);
    (chi2_quantile(tail, k) / r, chi2_quantile(1.0 - tail, k) / r)
}

/// One-sided gate: the `1 − alpha` quantile of χ²(`dim`) (e.g. α = 0.05 for a 95 % gate).
pub fn chi2_gate(dim: usize, alpha: f64) -> f64 {
    chi2_quantile(1.0 - alpha, dim as f64)
}

/// Fraction of `values` inside `[lo, hi]`.
pub fn fraction_inside(values: &[f64], lo: f64, hi: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.iter().filter(|v| **v >= lo && **v <= hi).count() as f64 / values.len() as f64
}
