//! The values a smoother stores exactly as numbers ([`Spill`]).

/// A value stored exactly as `LEN` numbers (states and inputs a
/// [`SegmentSmoother`](super::SegmentSmoother) writes to its storage). States need no
/// code: every [`Coeffs`](manifolds::Coeffs) type is stored as its coefficients (below).
pub trait Spill: Sized {
    /// How many numbers.
    const LEN: usize;
    /// Write the value into `out` (`out.len() == LEN`).
    fn spill(&self, out: &mut [f64]);
    /// Read it back from `v` (`v.len() == LEN`).
    fn unspill(v: &[f64]) -> Self;
    /// The most numbers [`spill_after`](Self::spill_after) writes (`≤ LEN`).
    const AFTER_LEN: usize = Self::LEN;
    /// Write the value, which follows `before` (the previous step's input), in fewer
    /// numbers when `before` and those numbers rebuild it exactly: returns the *form* of
    /// what was written (below [`AFTER_FORMS`]; [`after_len`](Self::after_len) numbers),
    /// or `None` (nothing written). An IMU input that repeats the previous sample stores
    /// only the new one, and of it only what the previous one does not give. The default
    /// never shortens.
    fn spill_after(&self, before: &Self, out: &mut [f64]) -> Option<u8> {
        let _ = (before, out);
        None
    }
    /// How many numbers [`spill_after`](Self::spill_after) writes in `form`.
    fn after_len(form: u8) -> usize {
        let _ = form;
        Self::AFTER_LEN
    }
    /// Rebuild a value from what [`spill_after`](Self::spill_after) wrote in `form`.
    fn unspill_after(v: &[f64], form: u8, before: &Self) -> Self {
        let _ = (before, form);
        Self::unspill(v)
    }
    /// The end time and the interval of the step this input drives, when the input
    /// carries them: a step whose own are the same bits is stored without them. Default:
    /// `None`.
    fn stamp(&self) -> Option<(f64, f64)> {
        None
    }
}

/// Forms of [`Spill::spill_after`] (they share a step's flags with the smoother's own).
pub const AFTER_FORMS: u8 = 16;

/// Every value with a flat coefficient view ([`manifolds::Coeffs`]: vectors, rotations,
/// tuples, `composite_state!` states, `f64`, `()`) is stored as its coefficients.
impl<M: manifolds::Coeffs<f64>> Spill for M {
    const LEN: usize = M::LEN;
    fn spill(&self, out: &mut [f64]) {
        self.coeffs(out);
    }
    fn unspill(v: &[f64]) -> Self {
        M::from_coeffs(v)
    }
}
