//! The filter's scalar: `f64` (the default of every type) or `f32`.
//!
//! [`FilterScalar`] extends [`manifolds::Real`] with the handful of products the filter
//! runs at every step. `f64` runs the crate's column kernels ([`crate::kernels`]: AVX2/FMA
//! when the CPU has them), exactly as before the scalar was a parameter; `f32` runs plain
//! loops over nalgebra's storage, which need neither the heap nor the standard library
//! (what a microcontroller's single-precision FPU runs).

use nalgebra::allocator::Allocator;
use nalgebra::{DMatrixView, DefaultAllocator, DimName, OMatrix, OVector};

use manifolds::{DimAlloc, Real};

use crate::dims::FilterAlloc;

/// A scalar the filter runs on: `f64` (the default of every type) or `f32`: the real
/// numbers of [`manifolds::Real`] with the handful of products the filter runs at every
/// step. `f64` runs the crate's column kernels (AVX2/FMA when the CPU has them); `f32` runs
/// plain loops over nalgebra's storage, which need neither the heap nor the standard
/// library (a microcontroller's single-precision FPU).
pub trait FilterScalar: Real {
    /// True when any value is NaN or infinite.
    fn non_finite_in(values: &[Self]) -> bool;

    /// `out ← A B`.
    fn mat_mul<R: DimName, K: DimName, C: DimName>(
        a: &OMatrix<Self, R, K>,
        b: &OMatrix<Self, K, C>,
        out: &mut OMatrix<Self, R, C>,
    ) where
        DefaultAllocator: Allocator<R, K> + Allocator<K, C> + Allocator<R, C>;

    /// `out ← Φ P Φᵀ + Q`, exactly symmetric.
    fn dense_sandwich<N: DimName>(
        phi: &OMatrix<Self, N, N>,
        p: &OMatrix<Self, N, N>,
        q: &OMatrix<Self, N, N>,
        out: &mut OMatrix<Self, N, N>,
    ) where
        DefaultAllocator: DimAlloc<N>;

    /// `out ← P + V Kᵀ + K Vᵀ`, `V = K S/2 − U` (the Joseph update multiplied out), exactly
    /// symmetric.
    fn joseph_update<N: DimName, M: DimName>(
        p: &OMatrix<Self, N, N>,
        k: &OMatrix<Self, N, M>,
        s: &OMatrix<Self, M, M>,
        u: &OMatrix<Self, N, M>,
        out: &mut OMatrix<Self, N, N>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>;

    /// `K ← K S⁻¹` for `S = L Lᵀ` (`L` lower triangular; its upper triangle is not read).
    fn right_solve_cholesky<N: DimName, M: DimName>(
        l: &OMatrix<Self, M, M>,
        k: &mut OMatrix<Self, N, M>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>;

    /// `P Hᵀ` (`N × M`, column-major into `out`) for a symmetric `P`.
    fn p_times_ht<N: DimName, M: DimName>(
        p: &OMatrix<Self, N, N>,
        h: &OMatrix<Self, M, N>,
        out: &mut [Self],
    ) where
        DefaultAllocator: DimAlloc<N> + Allocator<M, N>;

    /// `P ← G P Gᵀ` in place, `G` the identity but for the square block `b` at rows and
    /// columns `o..`; exactly symmetric.
    fn block_reset<N: DimName>(p: &mut OMatrix<Self, N, N>, o: usize, b: DMatrixView<'_, Self>)
    where
        DefaultAllocator: DimAlloc<N>;
}

impl FilterScalar for f64 {
    #[inline]
    fn non_finite_in(values: &[f64]) -> bool {
        crate::kernels::non_finite_in(values)
    }

    #[inline]
    fn mat_mul<R: DimName, K: DimName, C: DimName>(
        a: &OMatrix<f64, R, K>,
        b: &OMatrix<f64, K, C>,
        out: &mut OMatrix<f64, R, C>,
    ) where
        DefaultAllocator: Allocator<R, K> + Allocator<K, C> + Allocator<R, C>,
    {
        crate::kernels::mat_mul(a, b, out)
    }

    #[inline]
    fn dense_sandwich<N: DimName>(
        phi: &OMatrix<f64, N, N>,
        p: &OMatrix<f64, N, N>,
        q: &OMatrix<f64, N, N>,
        out: &mut OMatrix<f64, N, N>,
    ) where
        DefaultAllocator: DimAlloc<N>,
    {
        crate::kernels::dense_sandwich(phi, p, q, out)
    }

    #[inline]
    fn joseph_update<N: DimName, M: DimName>(
        p: &OMatrix<f64, N, N>,
        k: &OMatrix<f64, N, M>,
        s: &OMatrix<f64, M, M>,
        u: &OMatrix<f64, N, M>,
        out: &mut OMatrix<f64, N, N>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        crate::kernels::joseph_update(p, k, s, u, out)
    }

    #[inline]
    fn right_solve_cholesky<N: DimName, M: DimName>(
        l: &OMatrix<f64, M, M>,
        k: &mut OMatrix<f64, N, M>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        crate::kernels::right_solve_cholesky(l, k)
    }

    #[inline]
    fn p_times_ht<N: DimName, M: DimName>(
        p: &OMatrix<f64, N, N>,
        h: &OMatrix<f64, M, N>,
        out: &mut [f64],
    ) where
        DefaultAllocator: DimAlloc<N> + Allocator<M, N>,
    {
        crate::kernels::p_times_ht(p, h, out)
    }

    /// Blocks of up to 6 dimensions (rotations, positions, poses) need no scratch, up to
    /// 16 a small stack one; bigger blocks (custom manifolds only) an `N × N` one on the
    /// stack, beside `P`. Never the heap.
    #[inline]
    fn block_reset<N: DimName>(p: &mut OMatrix<f64, N, N>, o: usize, b: DMatrixView<'_, f64>)
    where
        DefaultAllocator: DimAlloc<N>,
    {
        use crate::kernels::block_reset_in_place;
        let d = b.nrows();
        if d <= 6 {
            block_reset_in_place(p, N::DIM, o, b, &mut [], &mut []);
        } else if d <= 16 {
            let (mut corner, mut row) = ([0.0; 16 * 16], [0.0; 16]);
            block_reset_in_place(p, N::DIM, o, b, &mut corner, &mut row);
        } else {
            let mut corner = OMatrix::<f64, N, N>::zeros();
            let mut row = OVector::<f64, N>::zeros();
            let (corner, row) = (corner.as_mut_slice(), row.as_mut_slice());
            block_reset_in_place(p, N::DIM, o, b, corner, row);
        }
    }
}

/// Mirror the lower triangle of a square matrix onto its upper one.
fn mirror_lower<T: Real, N: DimName>(m: &mut OMatrix<T, N, N>)
where
    DefaultAllocator: DimAlloc<N>,
{
    for c in 0..N::DIM {
        for r in (c + 1)..N::DIM {
            m[(c, r)] = m[(r, c)];
        }
    }
}

impl FilterScalar for f32 {
    fn non_finite_in(values: &[f32]) -> bool {
        values.iter().any(|v| !v.is_finite())
    }

    fn mat_mul<R: DimName, K: DimName, C: DimName>(
        a: &OMatrix<f32, R, K>,
        b: &OMatrix<f32, K, C>,
        out: &mut OMatrix<f32, R, C>,
    ) where
        DefaultAllocator: Allocator<R, K> + Allocator<K, C> + Allocator<R, C>,
    {
        a.mul_to(b, out);
    }

    fn dense_sandwich<N: DimName>(
        phi: &OMatrix<f32, N, N>,
        p: &OMatrix<f32, N, N>,
        q: &OMatrix<f32, N, N>,
        out: &mut OMatrix<f32, N, N>,
    ) where
        DefaultAllocator: DimAlloc<N>,
    {
        // A = Φ P, then the lower triangle of A Φᵀ + Q, mirrored
        let a = phi * p;
        let n = N::DIM;
        for c in 0..n {
            for r in c..n {
                let mut s = q[(r, c)];
                for k in 0..n {
                    s += a[(r, k)] * phi[(c, k)];
                }
                out[(r, c)] = s;
            }
        }
        mirror_lower(out);
    }

    fn joseph_update<N: DimName, M: DimName>(
        p: &OMatrix<f32, N, N>,
        k: &OMatrix<f32, N, M>,
        s: &OMatrix<f32, M, M>,
        u: &OMatrix<f32, N, M>,
        out: &mut OMatrix<f32, N, N>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        // V = K S/2 − U; out = P + V Kᵀ + K Vᵀ (lower triangle, mirrored)
        let v = k * s * 0.5 - u;
        let n = N::DIM;
        for c in 0..n {
            for r in c..n {
                let mut x = p[(r, c)];
                for j in 0..M::DIM {
                    x += v[(r, j)] * k[(c, j)] + k[(r, j)] * v[(c, j)];
                }
                out[(r, c)] = x;
            }
        }
        mirror_lower(out);
    }

    fn right_solve_cholesky<N: DimName, M: DimName>(
        l: &OMatrix<f32, M, M>,
        k: &mut OMatrix<f32, N, M>,
    ) where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let (n, m) = (N::DIM, M::DIM);
        // Y Lᵀ = U, column by column forward
        for j in 0..m {
            for i in 0..j {
                let lji = l[(j, i)];
                for r in 0..n {
                    let y = k[(r, i)];
                    k[(r, j)] -= y * lji;
                }
            }
            let d = 1.0 / l[(j, j)];
            for r in 0..n {
                k[(r, j)] *= d;
            }
        }
        // K L = Y, column by column backward
        for j in (0..m).rev() {
            for i in (j + 1)..m {
                let lij = l[(i, j)];
                for r in 0..n {
                    let x = k[(r, i)];
                    k[(r, j)] -= x * lij;
                }
            }
            let d = 1.0 / l[(j, j)];
            for r in 0..n {
                k[(r, j)] *= d;
            }
        }
    }

    fn p_times_ht<N: DimName, M: DimName>(
        p: &OMatrix<f32, N, N>,
        h: &OMatrix<f32, M, N>,
        out: &mut [f32],
    ) where
        DefaultAllocator: DimAlloc<N> + Allocator<M, N>,
    {
        let n = N::DIM;
        for (i, col) in out.chunks_exact_mut(n).enumerate().take(M::DIM) {
            col.fill(0.0);
            for k in 0..n {
                let hik = h[(i, k)];
                if hik != 0.0 {
                    for (r, x) in col.iter_mut().enumerate() {
                        *x += hik * p[(r, k)];
                    }
                }
            }
        }
    }

    fn block_reset<N: DimName>(p: &mut OMatrix<f32, N, N>, o: usize, b: DMatrixView<'_, f32>)
    where
        DefaultAllocator: DimAlloc<N>,
    {
        let (n, d) = (N::DIM, b.nrows());
        let mut t = OVector::<f32, N>::zeros();
        // P Gᵀ: the block's columns of every row
        for r in 0..n {
            for i in 0..d {
                t[i] = (0..d).map(|k| p[(r, o + k)] * b[(i, k)]).sum();
            }
            for i in 0..d {
                p[(r, o + i)] = t[i];
            }
        }
        // G (P Gᵀ): the block's rows of every column
        for c in 0..n {
            for i in 0..d {
                t[i] = (0..d).map(|k| b[(i, k)] * p[(o + k, c)]).sum();
            }
            for i in 0..d {
                p[(o + i, c)] = t[i];
            }
        }
        // exactly symmetric: the rows and columns outside the corner agree by construction
        // up to rounding; average the whole block's rows and columns
        for i in 0..d {
            for c in 0..n {
                let m = 0.5 * (p[(o + i, c)] + p[(c, o + i)]);
                p[(o + i, c)] = m;
                p[(c, o + i)] = m;
            }
        }
    }
}
