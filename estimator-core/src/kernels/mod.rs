//! Small dense kernels on column-major storage for the static back-end (crate-private;
//! each written once as an `#[inline(always)]` body and compiled by
//! [`fma_kernel!`](crate::fma_kernel) for AVX2/FMA and, where measured to pay, AVX-512VL,
//! with a portable twin). `benches/README.md` has their measured speed.

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, OMatrix};

use manifolds::DimAlloc;

use crate::dims::FilterAlloc;
use crate::entries::Entries;
use crate::fma_kernel;
use crate::simd::{madd, nmadd};

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
    /// The Joseph update multiplied out: `out ← P + V Kᵀ + K Vᵀ` with `V = K S/2 − U`,
    /// for a symmetric `N × N` `P`, the gain `K` and `U = P Hᵀ` (`N × M`) and a symmetric
    /// `S` (`M × M`); the result is made exactly symmetric by mirroring the lower triangle.
    /// `N M² + N(N+1)M` multiply-adds.
    ///
    /// With `S = H P Hᵀ + R` this is `(I − KH) P (I − KH)ᵀ + K R Kᵀ` for any `K` (see
    /// [`crate::UpdateForm::Joseph`]). Its register sums outgrow AVX2's 16 registers, so
    /// CPUs with AVX-512VL run it with 32 up to 24 states, the sizes where that was measured
    /// to pay (`benches/README.md`).
    pub fn joseph_update<N: DimName, M: DimName>(
        p: &Cov<N>,
        k: &OMatrix<f64, N, M>,
        s: &OMatrix<f64, M, M>,
        u: &OMatrix<f64, N, M>,
        out: &mut Cov<N>,
    ) = joseph_update_body / joseph_update_avx2 / joseph_update_portable
        + avx512 (N::DIM <= 24)
    where DefaultAllocator: FilterAlloc<N, M>
}

type Cov<N> = OMatrix<f64, N, N>;

#[inline(always)]
fn joseph_update_body<N: DimName, M: DimName, const FMA: bool>(
    p: &Cov<N>,
    k: &OMatrix<f64, N, M>,
    s: &OMatrix<f64, M, M>,
    u: &OMatrix<f64, N, M>,
    out: &mut Cov<N>,
) where
    DefaultAllocator: FilterAlloc<N, M>,
{
    let (n, m) = (N::DIM, M::DIM);
    // W = U − K S/2 = −V, column by column from U's (the coefficients −S/2 once, M² of
    // them; no scaled copies of U or S)
    let coef = s.map(|x| -0.5 * x);
    let mut w = OMatrix::<f64, N, M>::zeros();
    let (ks, cs, us) = (k.as_slice(), coef.as_slice(), u.as_slice());
    for (j, wcol) in w.as_mut_slice().chunks_exact_mut(n).enumerate() {
        lincomb::<1, FMA>([(ks, &cs[j * m..])], n, m, 1, 0, Some(&us[j * n..(j + 1) * n]), wcol);
    }
    // Lower triangle of P − K Wᵀ − W Kᵀ, four columns at a time from the multiple of four
    // at or above their first (the mirror overwrites the extra rows above the diagonal).
    let (ws, ps, o) = (w.as_slice(), p.as_slice(), out.as_mut_slice());
    let t = JosephTerms { k: ks, w: ws, p: ps, n, m };
    let mut c0 = 0;
    while c0 + 4 <= n {
        t.panel::<4, FMA>(c0, o);
        c0 += 4;
    }
    match n - c0 {
        1 => t.panel::<1, FMA>(c0, o),
        2 => t.panel::<2, FMA>(c0, o),
        3 => t.panel::<3, FMA>(c0, o),
        _ => {}
    }
    mirror_lower(o, n);
}

/// The operands of the Joseph update's second stage, `P − K Wᵀ − W Kᵀ` (column-major
/// slices, `K` and `W = −V` `n × m`).
struct JosephTerms<'a> {
    k: &'a [f64],
    w: &'a [f64],
    p: &'a [f64],
    n: usize,
    m: usize,
}

impl JosephTerms<'_> {
    /// Columns `c0..c0 + C`, rows from `c0` down (and up to three rows above it when `n`
    /// is not a multiple of four, like [`lincomb`]).
    #[inline(always)]
    fn panel<const C: usize, const FMA: bool>(&self, c0: usize, out: &mut [f64]) {
        let n = self.n;
        let mut r0 = c0;
        while r0 + 8 <= n {
            self.tile::<C, 8, FMA>(c0, r0, out);
            r0 += 8;
        }
        while r0 + 4 <= n {
            self.tile::<C, 4, FMA>(c0, r0, out);
            r0 += 4;
        }
        if r0 < n && n >= 4 {
            self.tile::<C, 4, FMA>(c0, n - 4, out);
        } else {
            for r in r0..n {
                self.tile::<C, 1, FMA>(c0, r, out);
            }
        }
    }

    /// The `W × C` tile at rows `r0..`, columns `c0..`, its sums in registers: each
    /// segment of a column of `K` or `V` read once serves all `C` columns (one column at a
    /// time reads it `C` times, and the loads, not the multiply-adds, bound this stage).
    #[inline(always)]
    fn tile<const C: usize, const W: usize, const FMA: bool>(
        &self,
        c0: usize,
        r0: usize,
        out: &mut [f64],
    ) {
        let n = self.n;
        let mut acc = [[0.0f64; W]; C];
        for (j, a) in acc.iter_mut().enumerate() {
            a.copy_from_slice(&self.p[(c0 + j) * n + r0..][..W]);
        }
        for k in 0..self.m {
            let (kcol, wcol) = (&self.k[k * n..(k + 1) * n], &self.w[k * n..(k + 1) * n]);
            let (kseg, wseg) = (&kcol[r0..r0 + W], &wcol[r0..r0 + W]);
            for (j, a) in acc.iter_mut().enumerate() {
                let (wc, kc) = (wcol[c0 + j], kcol[c0 + j]);
                for i in 0..W {
                    a[i] = nmadd::<FMA>(kseg[i], wc, a[i]);
                }
                for i in 0..W {
                    a[i] = nmadd::<FMA>(wseg[i], kc, a[i]);
                }
            }
        }
        for (j, a) in acc.iter().enumerate() {
            out[(c0 + j) * n + r0..][..W].copy_from_slice(a);
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

fma_kernel! {
    /// `K ← K S⁻¹` in place for `S = L Lᵀ` (`L` the lower-triangular Cholesky factor; its
    /// upper triangle is not read): the gain `K = P Hᵀ S⁻¹` from `U = P Hᵀ` by a forward
    /// and a back substitution over whole columns, `N M²` multiply-adds.
    pub fn right_solve_cholesky<N: DimName, M: DimName>(
        l: &OMatrix<f64, M, M>,
        k: &mut OMatrix<f64, N, M>,
    ) = right_solve_body / right_solve_avx2 / right_solve_cholesky_portable
    where DefaultAllocator: FilterAlloc<N, M>
}

#[inline(always)]
fn right_solve_body<N: DimName, M: DimName, const FMA: bool>(
    l: &OMatrix<f64, M, M>,
    k: &mut OMatrix<f64, N, M>,
) where
    DefaultAllocator: FilterAlloc<N, M>,
{
    let (n, m) = (N::DIM, M::DIM);
    let minus_l = l * -1.0;
    let ml = minus_l.as_slice();
    let ks = k.as_mut_slice();
    let mut col = nalgebra::OVector::<f64, N>::zeros();
    let col = col.as_mut_slice();
    // The reciprocals of the diagonal up front: each substitution step depends on the one
    // before, and a division inside it would lengthen that chain every step.
    let inv_diag = nalgebra::OVector::<f64, M>::from_fn(|j, _| 1.0 / l[(j, j)]);
    // Y Lᵀ = U:  Y[:, j] = (U[:, j] − Σ_{i<j} Y[:, i] L[j, i]) / L[j, j]
    for j in 0..m {
        let (done, rest) = ks.split_at_mut(j * n);
        let kj = &mut rest[..n];
        col.copy_from_slice(kj);
        lincomb::<1, FMA>([(done, &ml[j..])], n, j, m, 0, Some(col), kj);
        let d = inv_diag[j];
        for x in kj.iter_mut() {
            *x *= d;
        }
    }
    // K L = Y:  K[:, j] = (Y[:, j] − Σ_{i>j} K[:, i] L[i, j]) / L[j, j]
    for j in (0..m).rev() {
        let (head, done) = ks.split_at_mut((j + 1) * n);
        let kj = &mut head[j * n..];
        col.copy_from_slice(kj);
        lincomb::<1, FMA>([(done, &ml[j * m + j + 1..])], n, m - j - 1, 1, 0, Some(col), kj);
        let d = inv_diag[j];
        for x in kj.iter_mut() {
            *x *= d;
        }
    }
}

fma_kernel! {
    /// `P Hᵀ` (`N × M`, column-major into `out`) for a symmetric `P`, skipping the zero
    /// entries of `H`: column `i` of the result is `Σ_k H[i, k] P[:, k]` over the non-zero
    /// `H[i, k]` only (a GNSS or magnetometer `H` touches a few states).
    pub fn p_times_ht<N: DimName, M: DimName>(
        p: &Cov<N>,
        h: &OMatrix<f64, M, N>,
        out: &mut [f64],
    ) = p_times_ht_body / p_times_ht_avx2 / p_times_ht_portable
    where DefaultAllocator: DimAlloc<N> + nalgebra::allocator::Allocator<M, N>
}

#[inline(always)]
fn p_times_ht_body<N: DimName, M: DimName, const FMA: bool>(
    p: &Cov<N>,
    h: &OMatrix<f64, M, N>,
    out: &mut [f64],
) where
    DefaultAllocator: DimAlloc<N> + nalgebra::allocator::Allocator<M, N>,
{
    let (n, m) = (N::DIM, M::DIM);
    let (p, hs) = (p.as_slice(), h.as_slice());
    // Column i of P Hᵀ combines the columns of P at the non-zero entries of row i of H
    // (all of them for rows with more than 64 non-zeros).
    let mut cols = [0usize; 64];
    let mut coefs = [0.0f64; 64];
    for i in 0..m {
        let out_i = &mut out[i * n..(i + 1) * n];
        let mut nz = 0;
        for kk in 0..n {
            let a = hs[kk * m + i];
            if a != 0.0 {
                if nz == cols.len() {
                    nz = usize::MAX;
                    break;
                }
                (cols[nz], coefs[nz]) = (kk, a);
                nz += 1;
            }
        }
        if nz == usize::MAX {
            lincomb::<1, FMA>([(p, &hs[i..])], n, n, m, 0, None, out_i);
        } else {
            lincomb_cols::<FMA>(p, n, &cols[..nz], &coefs[..nz], out_i);
        }
    }
}

fma_kernel! {
    /// `P ← G P Gᵀ` in place for a symmetric `n × n` `P`, where `G` is the identity except
    /// for the square block `b` at rows and columns `o..o + d` (one block of
    /// [`Manifold::reset_blocks`](manifolds::Manifold::reset_blocks)). `corner` must hold at
    /// least `d²` values and `row` `d` (neither is used for `d ≤ 6`); see
    /// [`block_reset_scratch`].
    ///
    /// Only the rows and columns of the block change. With `T = P[:, o..o+d] bᵀ`, row `r`
    /// outside the block gets `T[r, :]` in columns `o..o + d`, and by symmetry so do those
    /// columns' rows; the `d × d` corner becomes `b T[o..o+d, :]`, averaged with its
    /// transpose so that `P` stays exactly symmetric. `T` is formed four rows at a time from
    /// contiguous column segments. About `2 d² n` multiply-adds, no allocation. Blocks of up
    /// to 6 dimensions (rotations, positions, poses) run a copy specialised to their size,
    /// whose accumulators stay in registers.
    pub fn block_reset_in_place<E: Entries>(
        p: &mut E,
        n: usize,
        o: usize,
        b: nalgebra::DMatrixView<'_, f64>,
        corner: &mut [f64],
        row: &mut [f64],
    ) = block_reset_body / block_reset_avx2 / block_reset_portable
}

#[inline(always)]
fn block_reset_body<E: Entries, const FMA: bool>(
    p: &mut E,
    n: usize,
    o: usize,
    b: nalgebra::DMatrixView<'_, f64>,
    corner: &mut [f64],
    row: &mut [f64],
) {
    let b = &b;
    match b.nrows() {
        1 => block_reset_fixed::<1, E, FMA>(p, n, o, b),
        2 => block_reset_fixed::<2, E, FMA>(p, n, o, b),
        3 => block_reset_fixed::<3, E, FMA>(p, n, o, b),
        4 => block_reset_fixed::<4, E, FMA>(p, n, o, b),
        5 => block_reset_fixed::<5, E, FMA>(p, n, o, b),
        6 => block_reset_fixed::<6, E, FMA>(p, n, o, b),
        _ => block_reset_any::<E, FMA>(p, n, o, b, corner, row),
    }
}

/// [`block_reset_in_place`] for a `D × D` block.
#[inline(always)]
fn block_reset_fixed<const D: usize, E: Entries, const FMA: bool>(
    p: &mut E,
    n: usize,
    o: usize,
    b: &nalgebra::DMatrixView<'_, f64>,
) {
    let b: [[f64; D]; D] = core::array::from_fn(|i| core::array::from_fn(|k| b[(i, k)]));
    for rows in [0..o, o + D..n] {
        let mut r = rows.start;
        while r + 4 <= rows.end {
            fixed_rows::<D, 4, E, FMA>(p, &b, o, r);
            r += 4;
        }
        for r in r..rows.end {
            fixed_rows::<D, 1, E, FMA>(p, &b, o, r);
        }
    }
    // corner[i][j] = Σ_k b[i][k] t[j][k] with t[j][k] = Σ_l P[o + k, o + l] b[j][l]
    let mut t = [[0.0; D]; D];
    for l in 0..D {
        let col = &p.col(o + l)[o..o + D];
        for (tj, bj) in t.iter_mut().zip(&b) {
            for (x, &v) in tj.iter_mut().zip(col) {
                *x = madd::<FMA>(v, bj[l], *x);
            }
        }
    }
    for i in 0..D {
        for j in i..D {
            let (mut cij, mut cji) = (0.0, 0.0);
            for k in 0..D {
                cij = madd::<FMA>(b[i][k], t[j][k], cij);
                cji = madd::<FMA>(b[j][k], t[i][k], cji);
            }
            let v = 0.5 * (cij + cji);
            p.put(o + i, o + j, v);
            p.put(o + j, o + i, v);
        }
    }
}

/// Rows `r..r + W` (outside the block) of [`block_reset_fixed`]: `T` for those rows,
/// written to columns `o..o + D` and, transposed, to rows `o..o + D`.
#[inline(always)]
fn fixed_rows<const D: usize, const W: usize, E: Entries, const FMA: bool>(
    p: &mut E,
    b: &[[f64; D]; D],
    o: usize,
    r: usize,
) {
    let mut t = [[0.0; W]; D];
    for k in 0..D {
        let mut seg = [0.0; W];
        seg.copy_from_slice(&p.col(o + k)[r..r + W]);
        for (ti, bi) in t.iter_mut().zip(b) {
            for (x, &v) in ti.iter_mut().zip(&seg) {
                *x = madd::<FMA>(v, bi[k], *x);
            }
        }
    }
    for (i, ti) in t.iter().enumerate() {
        p.col_mut(o + i)[r..r + W].copy_from_slice(ti);
        for (w, &v) in ti.iter().enumerate() {
            p.put(o + i, r + w, v);
        }
    }
}

/// [`block_reset_in_place`] for a block of any size, with `scratch` for `T`'s rows and
/// the corner.
#[inline(always)]
fn block_reset_any<E: Entries, const FMA: bool>(
    p: &mut E,
    n: usize,
    o: usize,
    b: &nalgebra::DMatrixView<'_, f64>,
    corner: &mut [f64],
    row: &mut [f64],
) {
    let d = b.nrows();
    let corner = &mut corner[..d * d];
    let t = &mut row[..d];
    for r in (0..o).chain(o + d..n) {
        t.fill(0.0);
        for k in 0..d {
            let v = p.at(r, o + k);
            for (i, x) in t.iter_mut().enumerate() {
                *x = madd::<FMA>(v, b[(i, k)], *x);
            }
        }
        for (i, &v) in t.iter().enumerate() {
            p.put(r, o + i, v);
            p.put(o + i, r, v);
        }
    }
    for j in 0..d {
        t.fill(0.0);
        for l in 0..d {
            let g = b[(j, l)];
            for (x, &v) in t.iter_mut().zip(&p.col(o + l)[o..o + d]) {
                *x = madd::<FMA>(v, g, *x);
            }
        }
        for i in 0..d {
            let mut c = 0.0;
            for (k, &tk) in t.iter().enumerate() {
                c = madd::<FMA>(b[(i, k)], tk, c);
            }
            corner[i * d + j] = c;
        }
    }
    for i in 0..d {
        for j in i..d {
            let v = 0.5 * (corner[i * d + j] + corner[j * d + i]);
            p.put(o + i, o + j, v);
            p.put(o + j, o + i, v);
        }
    }
}

/// Scratch length [`block_reset_in_place`] needs for a `d × d` block: `d²` for the corner
/// and `d` for a row.
#[cfg(feature = "std")]
pub const fn block_reset_scratch(d: usize) -> usize {
    d * (d + 1)
}

#[cfg(all(test, feature = "faer"))]
mod tests;
