//! The update's kernels: the gain by a right Cholesky solve, `P Hᵀ` over sparse rows, and
//! the Joseph form multiplied out.

use super::*;

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
    /// The Joseph update multiplied out: `out ← P + V Kᵀ + K Vᵀ` with `V = K S/2 − U`,
    /// for a symmetric `N × N` `P`, the gain `K` and `U = P Hᵀ` (`N × M`) and a symmetric
    /// `S` (`M × M`); the result is made exactly symmetric by mirroring the lower triangle.
    /// `N M² + N(N+1)M` multiply-adds.
    ///
    /// With `S = H P Hᵀ + R` this is `(I − KH) P (I − KH)ᵀ + K R Kᵀ` for any `K` (see
    /// [`crate::UpdateForm::Joseph`]). Its register sums outgrow AVX2's 16 registers, so
    /// CPUs with AVX-512VL run it with 32 up to 24 states, the sizes where that was measured
    /// to pay (`docs/history/benches.md`).
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
