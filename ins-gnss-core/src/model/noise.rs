//! The half-interval process noise `E = D dt/2` of the trapezoid, block diagonal.

use nalgebra::Matrix3;

use super::{Cols, Cols16, B_BA, B_BG, B_TH, B_V, M15};

/// The half-interval noise `E = D dt/2` of the trapezoid, block diagonal: θ, b_g and b_a
/// diagonal, v a full (exactly symmetric) 3×3 block.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct HalfNoise {
    pub(super) th: [f64; 3],
    pub(super) v: Matrix3<f64>,
    pub(super) bg: [f64; 3],
    pub(super) ba: [f64; 3],
}

impl HalfNoise {
    /// `E[row, c]`, or `None` where `E` is zero by its structure (so that, with constant
    /// indices, the zeros cost nothing). Exactly symmetric: the v block is.
    #[inline(always)]
    pub(super) fn entry(&self, row: usize, c: usize) -> Option<f64> {
        match (row / 3, c / 3) {
            (B_TH, B_TH) if row == c => Some(self.th[c]),
            (B_V, B_V) => Some(self.v[(row - 3, c - 3)]),
            (B_BG, B_BG) if row == c => Some(self.bg[c - 9]),
            (B_BA, B_BA) if row == c => Some(self.ba[c - 12]),
            _ => None,
        }
    }

    /// `P + E` as padded columns.
    pub(super) fn added_to(&self, P: &M15) -> Cols16 {
        each_column!(self.added_column(&P.data.0))
    }

    /// Column `J` of `P + E` from column `J` of `P`, built whole so that it is written as
    /// four vectors (adding `E` in memory afterwards made the kernel's whole-column reads
    /// wait for single-value writes).
    #[inline(always)]
    fn added_column<const J: usize>(&self, p: &Cols) -> [f64; 16] {
        let mut col = [0.0; 16];
        col[..15].copy_from_slice(&p[J]);
        for (row, x) in col.iter_mut().enumerate().take(15) {
            if let Some(e) = self.entry(row, J) {
                *x += e;
            }
        }
        col
    }

    /// `E v`: the diagonal blocks as they are, the velocity block as a 3 × 3 product.
    pub(super) fn times(&self, v: &[f64]) -> [f64; 15] {
        let mut out = [0.0; 15];
        for i in 0..3 {
            out[i] = self.th[i] * v[i];
            out[3 + i] = self.v[(i, 0)] * v[3] + self.v[(i, 1)] * v[4] + self.v[(i, 2)] * v[5];
            out[9 + i] = self.bg[i] * v[9 + i];
            out[12 + i] = self.ba[i] * v[12 + i];
        }
        out
    }

    pub(super) fn dense(&self) -> M15 {
        M15::from_fn(|r, c| self.entry(r, c).unwrap_or(0.0))
    }
}
