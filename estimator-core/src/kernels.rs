//! Small dense kernels on column-major storage for the static back-end and for models
//! with structured products, plus the CPU-feature dispatch they share.
//!
//! Each kernel is written once as an `#[inline(always)]` body generic over a `FMA` flag:
//! on x86-64 CPUs with AVX2 and FMA it is compiled inside a `#[target_feature]` wrapper,
//! where `f64::mul_add` is one instruction and the loops use 256-bit vectors; elsewhere
//! it runs as plain multiply-then-add (`mul_add` without the instruction is a slow
//! library call). The two paths differ by one rounding per multiply-add.

use nalgebra::{DefaultAllocator, DimName, OMatrix};

use manifolds::DimAlloc;

use crate::traits::FilterAlloc;

/// Whether this CPU has AVX2 and FMA (cached by the standard library); always false off
/// x86-64.
#[inline(always)]
pub fn has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Defines a kernel from an `#[inline(always)]` body generic over a trailing
/// `const FMA: bool`: the public function runs the body compiled inside an AVX2+FMA
/// `#[target_feature]` wrapper when the CPU has those instructions (checked once and
/// cached, see [`has_avx2_fma`]), and the body with `FMA = false` otherwise; a second
/// public function runs the latter always (what CPUs without those instructions run), so
/// tests can compare both paths on any machine.
///
/// ```ignore
/// fma_kernel! {
///     /// docs
///     pub fn name<N: DimName>(a: &T, out: &mut U) = name_body / name_avx2 / name_portable
///     where DefaultAllocator: DimAlloc<N>
/// }
/// ```
#[macro_export]
macro_rules! fma_kernel {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident $(<$($g:ident : $b:path),*>)? ($($a:ident : $t:ty),* $(,)?)
            $(-> $r:ty)? = $body:ident / $fast:ident / $portable:ident
        $(where $($w:tt)*)?
    ) => {
        $(#[$meta])*
        $vis fn $name $(<$($g: $b),*>)? ($($a: $t),*) $(-> $r)? $(where $($w)*)? {
            #[cfg(target_arch = "x86_64")]
            {
                if $crate::kernels::has_avx2_fma() {
                    // SAFETY: the CPU has AVX2 and FMA (checked just above).
                    return unsafe { $fast $(::<$($g),*>)? ($($a),*) };
                }
            }
            $body::<$($($g,)*)? false>($($a),*)
        }

        #[doc = concat!("[`", stringify!($name), "`] without the AVX2/FMA path.")]
        $vis fn $portable $(<$($g: $b),*>)? ($($a: $t),*) $(-> $r)? $(where $($w)*)? {
            $body::<$($($g,)*)? false>($($a),*)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        unsafe fn $fast $(<$($g: $b),*>)? ($($a: $t),*) $(-> $r)? $(where $($w)*)? {
            $body::<$($($g,)*)? true>($($a),*)
        }
    };
}

/// `a·x + acc`, fused when `FMA`.
#[inline(always)]
pub fn madd<const FMA: bool>(x: f64, a: f64, acc: f64) -> f64 {
    if FMA {
        x.mul_add(a, acc)
    } else {
        acc + x * a
    }
}

fma_kernel! {
    /// The Joseph update multiplied out: `out ← P + V Kᵀ + K Vᵀ` with `V = K S/2 − U`,
    /// for a symmetric `N × N` `P`, the gain `K` and `U = P Hᵀ` (`N × M`) and a symmetric
    /// `S` (`M × M`); the result is made exactly symmetric by mirroring the lower triangle.
    /// `N M² + N(N+1)M` multiply-adds.
    ///
    /// With `S = H P Hᵀ + R` this is `(I − KH) P (I − KH)ᵀ + K R Kᵀ` for any `K` (see
    /// [`crate::UpdateForm::Joseph`]).
    pub fn joseph_update<N: DimName, M: DimName>(
        p: &Cov<N>,
        k: &OMatrix<f64, N, M>,
        s: &OMatrix<f64, M, M>,
        u: &OMatrix<f64, N, M>,
        out: &mut Cov<N>,
    ) = joseph_update_body / joseph_update_avx2 / joseph_update_portable
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
    // V = K (S/2) − U, column by column
    let half_s = s * 0.5;
    let minus_u = -u;
    let mut v = OMatrix::<f64, N, M>::zeros();
    let (ks, hs, mu) = (k.as_slice(), half_s.as_slice(), minus_u.as_slice());
    for (j, vcol) in v.as_mut_slice().chunks_exact_mut(n).enumerate() {
        lincomb::<FMA>(ks, n, m, &hs[j * m..], 1, 0, Some(&mu[j * n..(j + 1) * n]), vcol);
    }
    // Lower triangle of P + K Vᵀ + V Kᵀ, column c from row c: two combinations of M
    // columns each, then mirrored.
    let (vs, ps, o) = (v.as_slice(), p.as_slice(), out.as_mut_slice());
    let mut tmp = nalgebra::OVector::<f64, N>::zeros();
    for c in 0..n {
        let t = &mut tmp.as_mut_slice()[c..];
        lincomb::<FMA>(ks, n, m, &vs[c..], n, c, Some(&ps[c * n + c..(c + 1) * n]), t);
        lincomb::<FMA>(vs, n, m, &ks[c..], n, c, Some(t), &mut o[c * n + c..(c + 1) * n]);
    }
    mirror_lower(o, n);
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
        lincomb::<FMA>(f, n, n, &ps[j * n..], 1, 0, None, acol);
    }
    // out[j.., j] = Q[j.., j] + Σ_k A[j.., k] Φ[j, k]
    let (a, qs, o) = (a.as_slice(), q.as_slice(), out.as_mut_slice());
    for j in 0..n {
        let init = &qs[j * n + j..(j + 1) * n];
        lincomb::<FMA>(a, n, n, &f[j..], n, j, Some(init), &mut o[j * n + j..(j + 1) * n]);
    }
    mirror_lower(o, n);
}

/// `out[r − lo] = init[r − lo] + Σ_k m[k n + r] · coef[k · stride]` for `r ∈ lo..n`,
/// `k < kcols` (a combination of the columns of the column-major `n × kcols` matrix `m`,
/// rows `lo..`),
/// accumulated eight and four rows at a time in registers: accumulating in memory
/// instead chains every multiply-add through a store and a reload.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn lincomb<const FMA: bool>(
    m: &[f64],
    n: usize,
    kcols: usize,
    coef: &[f64],
    stride: usize,
    lo: usize,
    init: Option<&[f64]>,
    out: &mut [f64],
) {
    let c = Combination { m, n, kcols, coef, stride, lo, init };
    let mut r0 = lo;
    while r0 + 8 <= n {
        c.rows::<8, FMA>(r0, out);
        r0 += 8;
    }
    while r0 + 4 <= n {
        c.rows::<4, FMA>(r0, out);
        r0 += 4;
    }
    for r in r0..n {
        c.rows::<1, FMA>(r, out);
    }
}

/// The arguments of one [`lincomb`].
struct Combination<'a> {
    m: &'a [f64],
    n: usize,
    kcols: usize,
    coef: &'a [f64],
    stride: usize,
    lo: usize,
    init: Option<&'a [f64]>,
}

impl Combination<'_> {
    /// Rows `r0..r0 + W`, with the `W` sums held in registers.
    #[inline(always)]
    fn rows<const W: usize, const FMA: bool>(&self, r0: usize, out: &mut [f64]) {
        let (n, i) = (self.n, r0 - self.lo);
        let mut acc = [0.0f64; W];
        if let Some(init) = self.init {
            acc.copy_from_slice(&init[i..i + W]);
        }
        for k in 0..self.kcols {
            let (c, col) = (self.coef[k * self.stride], &self.m[k * n + r0..k * n + r0 + W]);
            for t in 0..W {
                acc[t] = madd::<FMA>(col[t], c, acc[t]);
            }
        }
        out[i..i + W].copy_from_slice(&acc);
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
    let ks = k.as_mut_slice();
    // Y Lᵀ = U:  Y[:, j] = (U[:, j] − Σ_{i<j} Y[:, i] L[j, i]) / L[j, j]
    for j in 0..m {
        let (done, rest) = ks.split_at_mut(j * n);
        let kj = &mut rest[..n];
        for i in 0..j {
            let a = -l[(j, i)];
            let yi = &done[i * n..(i + 1) * n];
            for r in 0..n {
                kj[r] = madd::<FMA>(yi[r], a, kj[r]);
            }
        }
        let d = 1.0 / l[(j, j)];
        for x in kj.iter_mut() {
            *x *= d;
        }
    }
    // K L = Y:  K[:, j] = (Y[:, j] − Σ_{i>j} K[:, i] L[i, j]) / L[j, j]
    for j in (0..m).rev() {
        let (head, done) = ks.split_at_mut((j + 1) * n);
        let kj = &mut head[j * n..];
        for i in (j + 1)..m {
            let a = -l[(i, j)];
            let ki = &done[(i - j - 1) * n..(i - j) * n];
            for r in 0..n {
                kj[r] = madd::<FMA>(ki[r], a, kj[r]);
            }
        }
        let d = 1.0 / l[(j, j)];
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
    for i in 0..m {
        let col = &mut out[i * n..(i + 1) * n];
        col.fill(0.0);
        for kk in 0..n {
            let a = hs[kk * m + i];
            if a != 0.0 {
                let pk = &p[kk * n..(kk + 1) * n];
                for r in 0..n {
                    col[r] = madd::<FMA>(pk[r], a, col[r]);
                }
            }
        }
    }
}

/// Column access to a square column-major matrix, so the structured reset
/// ([`sparse_sandwich_in_place`]) is written once for every back-end.
pub trait Entries {
    /// Entry `(r, c)`.
    fn at(&self, r: usize, c: usize) -> f64;
    /// Set entry `(r, c)`.
    fn put(&mut self, r: usize, c: usize, v: f64);
    /// Column `c`, contiguous.
    fn col(&self, c: usize) -> &[f64];
    /// Column `c`, contiguous and mutable.
    fn col_mut(&mut self, c: usize) -> &mut [f64];
}

impl<R: nalgebra::Dim, C: nalgebra::Dim, S> Entries for nalgebra::Matrix<f64, R, C, S>
where
    S: nalgebra::RawStorageMut<f64, R, C> + nalgebra::IsContiguous,
{
    #[inline(always)]
    fn at(&self, r: usize, c: usize) -> f64 {
        self[(r, c)]
    }
    #[inline(always)]
    fn put(&mut self, r: usize, c: usize, v: f64) {
        self[(r, c)] = v;
    }
    #[inline(always)]
    fn col(&self, c: usize) -> &[f64] {
        let n = self.nrows();
        &self.as_slice()[c * n..(c + 1) * n]
    }
    #[inline(always)]
    fn col_mut(&mut self, c: usize) -> &mut [f64] {
        let n = self.nrows();
        &mut self.as_mut_slice()[c * n..(c + 1) * n]
    }
}

/// Most non-identity entries of `G` the structured reset handles (a rotation block has 9).
const MAX_TERMS: usize = 48;
/// Most rows of `G` that differ from the identity for the structured reset.
const MAX_ROWS: usize = 12;

/// What [`sparse_sandwich_in_place`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sandwich {
    /// `G` is the identity: nothing to do.
    Identity,
    /// `G` differs from the identity in a few rows: done in place.
    Done,
    /// `G` is too dense for the structured path: the caller must do the dense product.
    Dense,
}

/// `P ← G P Gᵀ` in place for a symmetric `P` when `G` differs from the identity in at
/// most 12 rows (the set `T`) with at most 48 non-zero entries among them (an
/// error-state reset touches the rotation blocks only). With `t_i = Σ_k G[i, k] P[:, k]`
/// for `i ∈ T` (column axpys), the result is `P` outside the rows and columns of `T`,
/// `t_i` in row and column `i`, and `Σ_k G[i, k] t_j[k]` at `(i, j) ∈ T × T`; it is
/// exactly symmetric. About `N · nnz` multiply-adds instead of `2N³`. Returns
/// [`Sandwich::Dense`] (and leaves `P` unchanged) when `G` has more structure than that.
pub fn sparse_sandwich_in_place<E: Entries, N: DimName>(p: &mut E, g: &Cov<N>) -> Sandwich
where
    DefaultAllocator: DimAlloc<N>,
{
    let n = N::DIM;
    // The rows of G that are not e_i (found in one pass over the column-major storage),
    // then their non-zero entries (column, value): row t's are terms[start[t]..start[t + 1]].
    let gs = g.as_slice();
    let mut rows = [0usize; MAX_ROWS];
    let mut nr = 0;
    for (c, col) in gs.chunks_exact(n).enumerate() {
        // A branch-free test of the whole column first (it vectorises): most columns of
        // a reset Jacobian are those of the identity.
        // (v − δ_rc with its sign bit shifted out is 0 exactly when v = δ_rc.)
        let off_identity = col
            .iter()
            .enumerate()
            .fold(0u64, |a, (r, &v)| a | ((v - if r == c { 1.0 } else { 0.0 }).to_bits() << 1));
        if off_identity == 0 {
            continue;
        }
        for (r, &v) in col.iter().enumerate() {
            if v != if r == c { 1.0 } else { 0.0 } && !rows[..nr].contains(&r) {
                if nr == MAX_ROWS {
                    return Sandwich::Dense;
                }
                rows[nr] = r;
                nr += 1;
            }
        }
    }
    if nr == 0 {
        return Sandwich::Identity;
    }
    rows[..nr].sort_unstable();
    let mut terms = [(0usize, 0.0f64); MAX_TERMS];
    let mut start = [0usize; MAX_ROWS + 1];
    let mut nt = 0;
    for (t, &i) in rows[..nr].iter().enumerate() {
        for c in 0..n {
            let v = gs[c * n + i];
            if v != 0.0 {
                if nt == MAX_TERMS {
                    return Sandwich::Dense;
                }
                terms[nt] = (c, v);
                nt += 1;
            }
        }
        start[t + 1] = nt;
    }
    let rows = &rows[..nr];
    let row_terms = |t: usize| &terms[start[t]..start[t + 1]];
    // t_i = Σ_k G[i, k] P[:, k]  (row i of G P, as P is symmetric)
    let mut tv: [nalgebra::OVector<f64, N>; MAX_ROWS] =
        core::array::from_fn(|_| nalgebra::OVector::<f64, N>::zeros());
    for (t, ti) in tv.iter_mut().enumerate().take(nr) {
        let ti = ti.as_mut_slice();
        for &(k, gk) in row_terms(t) {
            for (x, &pk) in ti.iter_mut().zip(p.col(k)) {
                *x += gk * pk;
            }
        }
    }
    // (G P Gᵀ)[i, j] on T × T = Σ_k G[i, k] t_j[k]
    let mut w = [[0.0f64; MAX_ROWS]; MAX_ROWS];
    for (a, wa) in w.iter_mut().enumerate().take(nr) {
        for (b, wab) in wa.iter_mut().enumerate().take(nr) {
            *wab = row_terms(a).iter().map(|&(k, gk)| gk * tv[b][k]).sum();
        }
    }
    for (t, &i) in rows.iter().enumerate() {
        p.col_mut(i).copy_from_slice(tv[t].as_slice());
        for (r, &v) in tv[t].iter().enumerate() {
            p.put(i, r, v);
        }
    }
    for (a, &i) in rows.iter().enumerate() {
        for (b, &j) in rows.iter().enumerate().skip(a) {
            // one value for both (i, j) and (j, i): exactly symmetric
            p.put(i, j, w[a][b]);
            p.put(j, i, w[a][b]);
        }
    }
    Sandwich::Done
}
