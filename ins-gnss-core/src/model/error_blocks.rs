//! The non-zero blocks of the continuous error dynamics `F`, and `Φ = I + F dt` built from
//! them as padded columns.

use nalgebra::Matrix3;

use super::{Cols16, B_BG, B_P, B_TH, B_V, M15};

/// The non-zero 3×3 blocks of the continuous error dynamics `F` at one epoch, besides the
/// constant `F_θ,bg = −I` and `F_p,v = I` (the flat-earth model leaves the WGS-84 terms
/// zero).
#[derive(Clone, Copy, Debug)]
pub(super) struct ErrorBlocks {
    pub(super) th_th: Matrix3<f64>,
    pub(super) th_v: Matrix3<f64>,
    pub(super) th_p: Matrix3<f64>,
    pub(super) v_th: Matrix3<f64>,
    pub(super) v_v: Matrix3<f64>,
    pub(super) v_p: Matrix3<f64>,
    pub(super) v_ba: Matrix3<f64>,
    pub(super) p_p: Matrix3<f64>,
    /// `−1/τ` on both bias diagonals (0 for a random walk).
    pub(super) bias: f64,
}

impl ErrorBlocks {
    /// Column `J` of `F s`, padded to 16 rows, plus `diag` on the diagonal (the first
    /// value on 0..9, the second on the biases). Built whole, zeros included, so that it
    /// is written as four vectors.
    #[inline(always)]
    fn column<const J: usize>(&self, s: f64, diag: [f64; 2]) -> [f64; 16] {
        let j = J;
        let mut col = [0.0; 16];
        let i = j % 3;
        let mut put = |row_block: usize, b: &Matrix3<f64>| {
            for r in 0..3 {
                col[3 * row_block + r] = b[(r, i)] * s;
            }
        };
        match j / 3 {
            B_TH => {
                put(B_TH, &self.th_th);
                put(B_V, &self.v_th);
            }
            B_V => {
                put(B_TH, &self.th_v);
                put(B_V, &self.v_v);
            }
            B_P => {
                put(B_TH, &self.th_p);
                put(B_V, &self.v_p);
                put(B_P, &self.p_p);
            }
            B_BG => {}
            _ => put(B_V, &self.v_ba),
        }
        match j / 3 {
            B_V => col[6 + i] = s, // F_p,v = I
            B_BG => col[i] = -s,   // F_θ,bg = −I
            _ => {}
        }
        col[j] += if j < 9 { diag[0] } else { diag[1] };
        col
    }

    /// The 15 columns of `F s` plus `diag` (see [`column`](Self::column)).
    #[inline(always)]
    fn columns(&self, s: f64, diag: [f64; 2]) -> Cols16 {
        each_column!(self.column(s, diag))
    }

    /// `Φ = I + F dt` (with `1 + bias·dt` on the bias diagonal) as padded columns.
    #[inline(always)]
    pub(super) fn phi(&self, dt: f64) -> Cols16 {
        self.columns(dt, self.phi_diagonal(dt))
    }

    /// What `Φ = I + F dt` adds on the diagonal: 1 on the first nine states, `1 + bias·dt`
    /// on the biases (the `diag` of [`column`](Self::column)).
    #[inline(always)]
    fn phi_diagonal(&self, dt: f64) -> [f64; 2] {
        [1.0, 1.0 + self.bias * dt]
    }

    /// `Φᵀ` (see [`phi`](Self::phi)) written straight into `out`: each column of `Φ`,
    /// formed in registers, stored as a row of `Φᵀ`, with no padded copy of `Φ` to
    /// transpose afterwards. The same numbers as `phi`'s.
    pub(super) fn phi_transposed_into(&self, dt: f64, out: &mut M15) {
        let diag = self.phi_diagonal(dt);
        let rows = &mut out.data.0;
        macro_rules! rows_of_phi_t {
            ($($j:literal)*) => {$(
                let col = self.column::<$j>(dt, diag);
                for (r, row) in rows.iter_mut().enumerate() {
                    row[$j] = col[r];
                }
            )*};
        }
        rows_of_phi_t!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14);
    }

    /// `F` as a dense matrix.
    pub(super) fn dense(&self) -> M15 {
        let cols = self.columns(1.0, [0.0, self.bias]);
        M15::from_fn(|r, c| cols[c][r])
    }
}
