//! The INS covariance kernels: `Φ M Φᵀ (+ E)` over the non-zero blocks of the INS `Φ`,
//! on columns padded to 16 rows, compiled by [`fma_kernel!`] for AVX2/FMA with a
//! portable twin.

use estimator_core::fma_kernel;
use estimator_core::simd::madd;

use super::noise::HalfNoise;
use super::M15;

pub(super) type Cols = [[f64; 15]; 15];

/// Columns padded to 16 rows: four 4-wide vectors each.
pub(super) type Cols16 = [[f64; 16]; 15];

/// `acc[r] += a·x[r]` for `r` in `max(lo, LO)..hi`; fused in the AVX2+FMA path (without
/// the instruction `mul_add` is a slow library call). Every caller passes literal bounds
/// that are multiples of 4, so after inlining the loop is whole vectors.
#[inline(always)]
fn axpy<const FMA: bool, const LO: usize>(
    acc: &mut [f64; 16],
    x: &[f64; 16],
    a: f64,
    lo: usize,
    hi: usize,
) {
    for r in lo.max(LO)..hi {
        acc[r] = madd::<FMA>(x[r], a, acc[r]);
    }
}

/// `Σ_k Φ[:, k] m[k]` from row `LO` (a multiple of 4) down, over the non-zero rows of
/// each column of `Φ` only: the θ columns have rows θ and v (0..6), the v and p columns
/// rows θ v p (0..9), the b_g columns one θ row and their diagonal, the b_a columns the v
/// rows and their diagonal. The sum stays in registers (plain loops, no closures: a
/// closure does not inherit the caller's `target_feature`, and `mul_add` outside it is a
/// library call).
#[inline(always)]
fn phi_combination<const FMA: bool, const LO: usize>(phi: &Cols16, m: &[f64; 16]) -> [f64; 16] {
    let mut acc = [0.0_f64; 16];
    for k in 0..3 {
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 0, 8);
    }
    for k in 3..9 {
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 0, 12);
    }
    for k in 9..12 {
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 0, 4);
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 8, 12);
    }
    for k in 12..15 {
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 0, 8);
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 12, 16);
    }
    acc
}

/// `Σ_k M[:, k] Φ[j, k]`, column `j` of `M Φᵀ`, over the non-zero entries of row `j` of
/// `Φ` only (θ rows: θ v p and one b_g; v rows: θ v p b_a; p rows: v p; bias rows: the
/// diagonal).
#[inline(always)]
fn times_row<const FMA: bool>(m: &Cols16, phi: &Cols16, j: usize) -> [f64; 16] {
    let mut acc = [0.0_f64; 16];
    let (first, second) = match j / 3 {
        0 => ((0, 9), (j + 9, j + 10)),
        1 => ((0, 9), (12, 15)),
        2 => ((3, 9), (0, 0)),
        _ => ((j, j + 1), (0, 0)),
    };
    for (lo, hi) in [first, second] {
        for k in lo..hi {
            axpy::<FMA, 0>(&mut acc, &m[k], phi[k][j], 0, 16);
        }
    }
    acc
}

/// Fill the 15 columns of `buf` with `column(j)` without zeroing them first, and return
/// them. (Zeroing the arrays and returning them by value cost 6 % of an INS epoch.)
macro_rules! fill_columns {
    ($buf:expr, |$j:ident| $column:expr) => {{
        let cols = $buf.as_mut_ptr().cast::<[f64; 16]>();
        for $j in 0..15 {
            let column: [f64; 16] = $column;
            // SAFETY: `$j < 15`, a column of the array.
            unsafe { cols.add($j).write(column) };
        }
        // SAFETY: all 15 columns were written.
        unsafe { $buf.assume_init_ref() }
    }};
}

/// The non-zero pattern of a transition in padded columns: `Φ` itself (the prediction)
/// or `Ψ = Φᵀ` (a smoother's adjoint step `Φᵀ Λ Φ = Ψ Λ Ψᵀ`).
trait Pattern {
    /// `Σ_k A[:, k] m[k]` from row `LO` down, over the non-zero rows of `A`'s columns.
    fn combination<const FMA: bool, const LO: usize>(a: &Cols16, m: &[f64; 16]) -> [f64; 16];
    /// `Σ_k M[:, k] A[j, k]`, column `j` of `M Aᵀ`, over the non-zeros of `A`'s row `j`.
    fn times_row<const FMA: bool>(m: &Cols16, a: &Cols16, j: usize) -> [f64; 16];
}

/// The INS `Φ`.
struct Phi;

impl Pattern for Phi {
    #[inline(always)]
    fn combination<const FMA: bool, const LO: usize>(a: &Cols16, m: &[f64; 16]) -> [f64; 16] {
        phi_combination::<FMA, LO>(a, m)
    }
    #[inline(always)]
    fn times_row<const FMA: bool>(m: &Cols16, a: &Cols16, j: usize) -> [f64; 16] {
        times_row::<FMA>(m, a, j)
    }
}

/// `Ψ = Φᵀ` for the INS `Φ`: column `k` of `Ψ` is row `k` of `Φ` (θ: θ v p and one b_g
/// row; v: θ v p b_a; p: v p; bias: the diagonal), row `j` of `Ψ` is column `j` of `Φ`
/// (θ: θ v; v and p: θ v p; b_g: one θ and the diagonal; b_a: v and the diagonal).
struct PhiTransposed;

impl Pattern for PhiTransposed {
    #[inline(always)]
    fn combination<const FMA: bool, const LO: usize>(a: &Cols16, m: &[f64; 16]) -> [f64; 16] {
        let mut acc = [0.0_f64; 16];
        for k in 0..3 {
            axpy::<FMA, LO>(&mut acc, &a[k], m[k], 0, 12);
        }
        for k in 3..6 {
            axpy::<FMA, LO>(&mut acc, &a[k], m[k], 0, 16);
        }
        for k in 6..9 {
            axpy::<FMA, LO>(&mut acc, &a[k], m[k], 0, 12);
        }
        for k in 9..12 {
            axpy::<FMA, LO>(&mut acc, &a[k], m[k], 8, 12);
        }
        for k in 12..15 {
            axpy::<FMA, LO>(&mut acc, &a[k], m[k], 12, 16);
        }
        acc
    }
    #[inline(always)]
    fn times_row<const FMA: bool>(m: &Cols16, a: &Cols16, j: usize) -> [f64; 16] {
        let mut acc = [0.0_f64; 16];
        let (first, second) = match j / 3 {
            0 => ((0, 6), (0, 0)),
            1 | 2 => ((0, 9), (0, 0)),
            3 => ((j - 9, j - 8), (j, j + 1)),
            _ => ((3, 6), (j, j + 1)),
        };
        for (lo, hi) in [first, second] {
            for k in lo..hi {
                axpy::<FMA, 0>(&mut acc, &m[k], a[k][j], 0, 16);
            }
        }
        acc
    }
}

/// `out ← A M Aᵀ` for `M` (symmetric) in padded columns and `A` of pattern `P`:
/// `Bᵀ = M Aᵀ` over the non-zeros of `A`'s rows (90 of 225 for the INS `Φ`), then
/// `R = A Bᵀ` over the non-zero rows of `A`'s columns, lower triangle only, mirrored, so
/// the result is exactly symmetric. About 670 four-wide multiply-adds.
#[inline(always)]
fn sandwich_body<const FMA: bool, P: Pattern, A: Addend>(
    a: &Cols16,
    m: &Cols16,
    add: &A,
    out: &mut Cols,
) {
    let mut buf = core::mem::MaybeUninit::<Cols16>::uninit();
    let bt = fill_columns!(buf, |j| P::times_row::<FMA>(m, a, j));
    let mut buf = core::mem::MaybeUninit::<Cols16>::uninit();
    let r = fill_columns!(buf, |j| match j {
        0..=3 => P::combination::<FMA, 0>(a, &bt[j]),
        4..=7 => P::combination::<FMA, 4>(a, &bt[j]),
        8..=11 => P::combination::<FMA, 8>(a, &bt[j]),
        _ => P::combination::<FMA, 12>(a, &bt[j]),
    });
    mirror_blocks(r, add, out);
}

/// A symmetric matrix added to the sandwich as its blocks are written.
trait Addend {
    /// Rows `r0..r0 + 4` of column `c` (row 15, past the end, as zero).
    fn segment(&self, r0: usize, c: usize) -> [f64; 4];
}

impl Addend for HalfNoise {
    #[inline(always)]
    fn segment(&self, r0: usize, c: usize) -> [f64; 4] {
        // (a plain loop: a closure does not inherit the kernel's `target_feature`)
        let mut seg = [0.0; 4];
        for (i, x) in seg.iter_mut().enumerate() {
            *x = self.entry(r0 + i, c).unwrap_or(0.0);
        }
        seg
    }
}

impl Addend for M15 {
    #[inline(always)]
    fn segment(&self, r0: usize, c: usize) -> [f64; 4] {
        let mut seg = [0.0; 4];
        let col = &self.data.0[c];
        let n = (15 - r0).min(4);
        seg[..n].copy_from_slice(&col[r0..r0 + n]);
        seg
    }
}

/// `out = L + Lᵀ − diag(L) + A` from the lower triangle `L` of `r` (valid from row
/// `4⌊c/4⌋` of column `c` down) and a symmetric addend `A`, written in 4×4 blocks of
/// whole vectors: blocks below the diagonal copied, blocks above it transposed from
/// their mirror images, diagonal blocks blended from both, the addend added on the way.
/// (Mirroring value by value, 240 single stores, then adding `E` in memory was measured
/// slower: `docs/history/benches.md`.)
#[inline(always)]
fn mirror_blocks<A: Addend>(r: &Cols16, add: &A, out: &mut Cols) {
    let flat = out.as_flattened_mut();
    // Column block by column block, the bottom block first: its four-row stores reach one
    // row into the next column, whose top block is written afterwards.
    macro_rules! blocks {
        ($($cb:literal: $($rb:literal)*;)*) => {
            $($(mirror_block::<$cb, $rb, A>(r, add, flat);)*)*
        };
    }
    blocks! { 0: 3 2 1 0; 1: 3 2 1 0; 2: 3 2 1 0; 3: 3 2 1 0; }
}

/// Block `(RB, CB)` of [`mirror_blocks`] (rows `4 RB..`, columns `4 CB..`).
#[inline(always)]
fn mirror_block<const CB: usize, const RB: usize, A: Addend>(
    r: &Cols16,
    add: &A,
    flat: &mut [f64],
) {
    let (c0, r0) = (4 * CB, 4 * RB);
    let w = if CB == 3 { 3 } else { 4 };
    let mut blk = [[0.0f64; 4]; 4];
    if RB > CB {
        for (j, b) in blk.iter_mut().enumerate().take(w) {
            b.copy_from_slice(&r[c0 + j][r0..r0 + 4]);
        }
    } else {
        let mut a = [[0.0f64; 4]; 4];
        let (src, rows) = if RB < CB { (r0, 4) } else { (c0, w) };
        for (i, x) in a.iter_mut().enumerate().take(rows) {
            x.copy_from_slice(&r[src + i][c0..c0 + 4]);
        }
        for (j, b) in blk.iter_mut().enumerate() {
            for (i, x) in b.iter_mut().enumerate() {
                // above the diagonal (the whole block, or the diagonal block's upper
                // part): the mirror image
                *x = if RB < CB || i < j { a[i][j] } else { a[j][i] };
            }
        }
    }
    for (j, b) in blk.iter().enumerate().take(w) {
        let e = add.segment(r0, c0 + j);
        let mut v = [0.0; 4];
        for i in 0..4 {
            v[i] = b[i] + e[i];
        }
        let at = (c0 + j) * 15 + r0;
        if at + 4 <= 225 {
            flat[at..at + 4].copy_from_slice(&v);
        } else {
            flat[at..225].copy_from_slice(&v[..225 - at]);
        }
    }
}

fma_kernel! {
    /// `out ← M Φ` for the INS `Φ`, given `Φᵀ` (`phi_t`), and any `M`: column `j` over the
    /// non-zeros of `Φ`'s column `j` only (90 of 225 entries), the smoother's product of a
    /// segment's transitions.
    pub fn times_phi_into(m: &M15, phi_t: &M15, out: &mut M15) =
        times_phi_kernel / times_phi_avx2 / times_phi_portable
}

#[inline(always)]
fn times_phi_kernel<const FMA: bool>(m: &M15, phi_t: &M15, out: &mut M15) {
    let (m, phi_t) = (padded(m), padded(phi_t));
    for (j, col) in out.data.0.iter_mut().enumerate() {
        let c = PhiTransposed::times_row::<FMA>(&m, &phi_t, j);
        col.copy_from_slice(&c[..15]);
    }
}

fma_kernel! {
    /// `out ← Φ M Φᵀ + E` for `Φ` and `M` in padded columns.
    pub(super) fn sandwich_padded(phi: &Cols16, m: &Cols16, e: &HalfNoise, out: &mut M15) =
        sandwich_padded_kernel / sandwich_padded_avx2 / sandwich_padded_portable
}

#[inline(always)]
fn sandwich_padded_kernel<const FMA: bool>(phi: &Cols16, m: &Cols16, e: &HalfNoise, out: &mut M15) {
    sandwich_body::<FMA, Phi, _>(phi, m, e, &mut out.data.0);
}

/// A matrix as padded columns, each written once (zeroing the whole block first and then
/// copying the columns into it was a `memset` and a `memmove` per call: 1.8 % of a
/// smoothed run's samples, on the backward recursion's thread).
#[inline(always)]
fn padded(m: &M15) -> Cols16 {
    #[inline(always)]
    fn col(s: &[f64; 15]) -> [f64; 16] {
        let mut d = [0.0; 16];
        d[..15].copy_from_slice(s);
        d
    }
    m.data.0.each_ref().map(col)
}

fma_kernel! {
    /// `Φ M` for the INS `Φ` (its zero blocks skipped), on nalgebra's column arrays.
    pub fn phi_times(phi: &M15, m: &M15) -> M15 =
        phi_times_kernel / phi_times_avx2 / phi_times_portable
}

#[inline(always)]
fn phi_times_kernel<const FMA: bool>(phi: &M15, m: &M15) -> M15 {
    let (phi, m) = (padded(phi), padded(m));
    let mut buf = core::mem::MaybeUninit::<Cols16>::uninit();
    let a = fill_columns!(buf, |c| phi_combination::<FMA, 0>(&phi, &m[c]));
    M15::from_fn(|r, c| a[c][r])
}

/// `Φ M Φᵀ` for the INS `Φ` and a symmetric `M`: both products run over the non-zeros of
/// `Φ` only (about 2,700 multiply-adds, many of them on padding, instead of 6,750), with
/// compile-time lengths so the loops vectorise.
pub fn phi_sandwich(phi: &M15, m: &M15) -> M15 {
    let mut out = M15::zeros();
    phi_sandwich_into(phi, m, &M15::zeros(), &mut out);
    out
}

fma_kernel! {
    /// `out ← Φ M Φᵀ + Q`, the product's lower triangle mirrored (exactly symmetric when
    /// `Q` is).
    pub fn phi_sandwich_into(phi: &M15, m: &M15, q: &M15, out: &mut M15) =
        phi_sandwich_kernel / phi_sandwich_avx2 / phi_sandwich_portable
}

#[inline(always)]
fn phi_sandwich_kernel<const FMA: bool>(phi: &M15, m: &M15, q: &M15, out: &mut M15) {
    sandwich_body::<FMA, Phi, _>(&padded(phi), &padded(m), q, &mut out.data.0);
}

/// Nothing added to a sandwich.
struct Zero;

impl Addend for Zero {
    #[inline(always)]
    fn segment(&self, _: usize, _: usize) -> [f64; 4] {
        [0.0; 4]
    }
}

fma_kernel! {
    /// `out ← Φᵀ Λ Φ` for the INS `Φ`, given `Φᵀ` (`phi_t`), and a symmetric `Λ`: the
    /// smoother's adjoint step over the non-zeros of `Φ` only (the prediction's kernel on
    /// the transposed pattern), exactly symmetric.
    pub fn adjoint_sandwich_into(phi_t: &M15, lambda: &M15, out: &mut M15) =
        adjoint_sandwich_kernel / adjoint_sandwich_avx2 / adjoint_sandwich_portable
}

#[inline(always)]
fn adjoint_sandwich_kernel<const FMA: bool>(phi_t: &M15, lambda: &M15, out: &mut M15) {
    sandwich_body::<FMA, PhiTransposed, _>(&padded(phi_t), &padded(lambda), &Zero, &mut out.data.0);
}
