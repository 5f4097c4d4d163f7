//! The error state's reset `P ← G P Gᵀ` for one block of `G`, in place.

use super::*;

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
