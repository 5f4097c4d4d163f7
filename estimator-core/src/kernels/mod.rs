//! Small dense kernels on column-major storage for the static back-end (crate-private;
//! each written once as an `#[inline(always)]` body and compiled by
//! [`fma_kernel!`](crate::fma_kernel) for AVX2/FMA and, where measured to pay, AVX-512VL,
//! with a portable twin). `docs/history/benches.md` has their measured speed.

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, OMatrix};

use manifolds::DimAlloc;

use crate::dims::FilterAlloc;
use crate::entries::Entries;
use crate::fma_kernel;
use crate::simd::{madd, nmadd};

mod reset;
mod update;

pub use reset::*;
pub use update::*;

type Cov<N> = OMatrix<f64, N, N>;

fma_kernel! {
    /// True when any value is NaN or infinite. `v − v` is `0` for a finite `v` and NaN
    /// otherwise (IEEE arithmetic: the compiler may not fold it), so sixteen running sums
    /// of it, which vectorise without any reordering, end NaN exactly when some value is
    /// not finite. With AVX2 that is about eight values per cycle, which matters for the
    /// dense back-ends' 14,400 entries at 120 states.
    pub fn non_finite_in(values: &[f64]) -> bool =
        non_finite_body / non_finite_avx2 / non_finite_in_portable
}

#[inline(always)]
#[allow(clippy::eq_op)] // `v - v` is the point: NaN for NaN and ±∞
fn non_finite_body<const FMA: bool>(values: &[f64]) -> bool {
    let mut acc = [0.0f64; 16];
    let chunks = values.chunks_exact(16);
    let rest = chunks.remainder();
    for c in chunks {
        for (a, &v) in acc.iter_mut().zip(c) {
            *a += v - v;
        }
    }
    rest.iter().any(|v| !v.is_finite()) || acc.iter().any(|a| a.is_nan())
}

fma_kernel! {
    /// `out ← A B` for small column-major matrices (`R × K` times `K × C`), each column a
    /// register-accumulated combination of `A`'s columns (nalgebra's generic product is
    /// several times slower at these sizes).
    pub fn mat_mul<R: DimName, K: DimName, C: DimName>(
        a: &OMatrix<f64, R, K>,
        b: &OMatrix<f64, K, C>,
        out: &mut OMatrix<f64, R, C>,
    ) = mat_mul_body / mat_mul_avx2 / mat_mul_portable
    where DefaultAllocator: Allocator<R, K> + Allocator<K, C> + Allocator<R, C>
}

#[inline(always)]
fn mat_mul_body<R: DimName, K: DimName, C: DimName, const FMA: bool>(
    a: &OMatrix<f64, R, K>,
    b: &OMatrix<f64, K, C>,
    out: &mut OMatrix<f64, R, C>,
) where
    DefaultAllocator: Allocator<R, K> + Allocator<K, C> + Allocator<R, C>,
{
    let (r, k) = (R::DIM, K::DIM);
    let (a, b) = (a.as_slice(), b.as_slice());
    let mut cols = out.as_mut_slice().chunks_exact_mut(r).enumerate();
    if (9..=16).contains(&r) {
        // two output columns at a time: eight independent sums instead of four, so the
        // multiply-adds are not waiting on each other's latency (the same sums, in the same
        // order, as one column at a time)
        while let (Some((j, c0)), Some((_, c1))) = (cols.next(), cols.next()) {
            two_columns::<FMA>(a, r, k, [&b[j * k..], &b[(j + 1) * k..]], [c0, c1]);
        }
        // (an odd last column was consumed by the loop's first `next`)
        if C::DIM % 2 == 1 {
            let j = C::DIM - 1;
            let col = &mut out.as_mut_slice()[j * r..(j + 1) * r];
            lincomb::<1, FMA>([(a, &b[j * k..])], r, k, 1, 0, None, col);
        }
        return;
    }
    for (j, col) in cols {
        lincomb::<1, FMA>([(a, &b[j * k..])], r, k, 1, 0, None, col);
    }
}

/// Two columns of `A B` for an `n × k` `A` with 9 to 16 rows: rows `0..8` and `n − 8..n`
/// (overlapping) of each, as [`Combination::run`] does for one column, all 32 sums in
/// registers.
#[inline(always)]
fn two_columns<const FMA: bool>(
    a: &[f64],
    n: usize,
    k: usize,
    coefs: [&[f64]; 2],
    out: [&mut [f64]; 2],
) {
    let starts = [0, n - 8];
    let mut acc = [[[0.0f64; 8]; 2]; 2];
    for kk in 0..k {
        let col = &a[kk * n..(kk + 1) * n];
        let c = [coefs[0][kk], coefs[1][kk]];
        for (b, &r) in starts.iter().enumerate() {
            let seg = &col[r..r + 8];
            for t in 0..8 {
                acc[0][b][t] = madd::<FMA>(seg[t], c[0], acc[0][b][t]);
                acc[1][b][t] = madd::<FMA>(seg[t], c[1], acc[1][b][t]);
            }
        }
    }
    for (o, a) in out.into_iter().zip(&acc) {
        for (b, &r) in starts.iter().enumerate() {
            o[r..r + 8].copy_from_slice(&a[b]);
        }
    }
}

fma_kernel! {
    /// `out ← Φ P Φᵀ + Q` for square `N × N` matrices with symmetric `P` and `Q`, exactly
    /// symmetric: `A = Φ P` by column axpys, then the lower triangle of `A Φᵀ + Q` and its
    /// mirror. `N³ + N²(N+1)/2` multiply-adds, vectorised along the columns. The default
    /// [`ProcessModel::propagate_covariance`](crate::ProcessModel::propagate_covariance).
    pub fn dense_sandwich<N: DimName>(
        phi: &Cov<N>,
        p: &Cov<N>,
        q: &Cov<N>,
        out: &mut Cov<N>,
    ) = dense_sandwich_body / dense_sandwich_avx2 / dense_sandwich_portable
    where DefaultAllocator: DimAlloc<N>
}

#[inline(always)]
fn dense_sandwich_body<N: DimName, const FMA: bool>(
    phi: &Cov<N>,
    p: &Cov<N>,
    q: &Cov<N>,
    out: &mut Cov<N>,
) where
    DefaultAllocator: DimAlloc<N>,
{
    let n = N::DIM;
    let mut a = Cov::<N>::zeros();
    let (f, ps) = (phi.as_slice(), p.as_slice());
    // A[:, j] = Σ_k Φ[:, k] P[k, j]
    for (j, acol) in a.as_mut_slice().chunks_exact_mut(n).enumerate() {
        lincomb::<1, FMA>([(f, &ps[j * n..])], n, n, 1, 0, None, acol);
    }
    // out[j.., j] = Q[j.., j] + Σ_k A[j.., k] Φ[j, k]
    let (a, qs, o) = (a.as_slice(), q.as_slice(), out.as_mut_slice());
    for j in 0..n {
        let init = &qs[j * n..(j + 1) * n];
        lincomb::<1, FMA>([(a, &f[j..])], n, n, n, j, Some(init), &mut o[j * n..(j + 1) * n]);
    }
    mirror_lower(o, n);
}

/// `out[r] = init[r] + Σ_(m, coef) Σ_k m[k n + r] · coef[k · stride]` for `r ∈ lo..n`,
/// `k < kcols`: rows `lo..` of a combination of the columns of one or more column-major
/// `n × kcols` matrices `m` (the `sources`, each with its coefficients); `init` and `out`
/// are whole columns. The sums are accumulated eight and four rows at a time in
/// registers (accumulating in memory instead chains every multiply-add through a store
/// and a reload). A remainder of fewer than four rows is done as the last four rows of
/// the column, so up to three rows above `lo` may be written too, with their own sums:
/// callers overwrite or mirror those rows.
#[inline(always)]
fn lincomb<const T: usize, const FMA: bool>(
    sources: [(&[f64], &[f64]); T],
    n: usize,
    kcols: usize,
    stride: usize,
    lo: usize,
    init: Option<&[f64]>,
    out: &mut [f64],
) {
    Combination { sources, n, kcols, stride, init, cols: None }.run::<FMA>(lo, out);
}

/// `out[r] = Σ_t m[cols[t] n + r] · coefs[t]` for every row `r < n`: a combination of the
/// columns `cols` of the column-major matrix `m` (a sparse row times a matrix).
#[inline(always)]
fn lincomb_cols<const FMA: bool>(
    m: &[f64],
    n: usize,
    cols: &[usize],
    coefs: &[f64],
    out: &mut [f64],
) {
    let kcols = cols.len();
    let c =
        Combination { sources: [(m, coefs)], n, kcols, stride: 1, init: None, cols: Some(cols) };
    c.run::<FMA>(0, out);
}

/// The arguments of one [`lincomb`] or [`lincomb_cols`].
struct Combination<'a, const T: usize> {
    sources: [(&'a [f64], &'a [f64]); T],
    n: usize,
    kcols: usize,
    stride: usize,
    init: Option<&'a [f64]>,
    /// The columns of the sources to combine (`0..kcols` when `None`).
    cols: Option<&'a [usize]>,
}

impl<const T: usize> Combination<'_, T> {
    /// Rows `lo..n` (and possibly up to three above, see [`lincomb`]).
    #[inline(always)]
    fn run<const FMA: bool>(&self, lo: usize, out: &mut [f64]) {
        let (c, n) = (self, self.n);
        let mut r0 = lo;
        if n - lo > 8 && n - lo <= 16 {
            // Nine to sixteen rows: two overlapping blocks of eight in one pass, four
            // independent sums per column read instead of two.
            c.rows::<8, 2, FMA>([lo, n - 8], out);
            return;
        }
        while r0 + 8 <= n {
            c.rows::<8, 1, FMA>([r0], out);
            r0 += 8;
        }
        while r0 + 4 <= n {
            c.rows::<4, 1, FMA>([r0], out);
            r0 += 4;
        }
        if r0 < n && n >= 4 {
            c.rows::<4, 1, FMA>([n - 4], out);
        } else {
            for r in r0..n {
                c.rows::<1, 1, FMA>([r], out);
            }
        }
    }

    /// Rows `r..r + W` for each start `r` in `starts` (the blocks may overlap: shared rows
    /// get the same sums twice), all `B W` sums in registers.
    #[inline(always)]
    fn rows<const W: usize, const B: usize, const FMA: bool>(
        &self,
        starts: [usize; B],
        out: &mut [f64],
    ) {
        let n = self.n;
        let mut acc = [[0.0f64; W]; B];
        if let Some(init) = self.init {
            for (a, &r) in acc.iter_mut().zip(&starts) {
                a.copy_from_slice(&init[r..r + W]);
            }
        }
        for (m, coef) in self.sources {
            for k in 0..self.kcols {
                let kc = match self.cols {
                    Some(cols) => cols[k],
                    None => k,
                };
                let (c, col) = (coef[k * self.stride], &m[kc * n..(kc + 1) * n]);
                for (a, &r) in acc.iter_mut().zip(&starts) {
                    let seg = &col[r..r + W];
                    for t in 0..W {
                        a[t] = madd::<FMA>(seg[t], c, a[t]);
                    }
                }
            }
        }
        for (a, &r) in acc.iter().zip(&starts) {
            out[r..r + W].copy_from_slice(a);
        }
    }
}

/// Copy the lower triangle of the column-major `n × n` matrix `o` onto its upper one.
#[inline(always)]
fn mirror_lower(o: &mut [f64], n: usize) {
    for c in 0..n {
        for r in (c + 1)..n {
            o[r * n + c] = o[c * n + r];
        }
    }
}

#[cfg(all(test, feature = "faer"))]
mod tests;
