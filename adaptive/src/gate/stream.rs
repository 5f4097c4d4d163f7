//! One stream's gate: its window of innovations, its refusals, the scale it has matched to them.

use super::*;

#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Debug)]
pub(super) struct GateStream {
    pub(super) refusals: u32,
    /// Nominal NIS of the last innovations (ring).
    pub(super) nis: [f64; GATE_WINDOW],
    /// Cosines between successive whitened innovations (ring).
    pub(super) cos: [f64; GATE_WINDOW],
    /// Whether successive whitened innovations lie close ([`AGREE_FRACTION`]; ring, as
    /// `cos`).
    pub(super) agree: [bool; GATE_WINDOW],
    pub(super) filled: usize,
    pub(super) cos_filled: usize,
    pub(super) head: usize,
    /// The previous whitened innovation (`L⁻¹ r`, `S = L Lᵀ`).
    pub(super) white: [f64; WHITE_DIMS],
    pub(super) has_white: bool,
    /// `R` is being matched to the innovations.
    pub(super) matching: bool,
    /// The state is being doubted.
    pub(super) doubting: bool,
    /// The noise its inliers show.
    pub(super) learned: Learned,
    /// The last push's whitened innovation's dot product with the one before, its own
    /// squared norm and the one before's (NaN when there was none before).
    pub(super) last_pair: (f64, f64, f64),
    /// Whether the update before the last push was learned from.
    pub(super) learned_before: bool,
}

impl GateStream {
    pub(super) fn new() -> Self {
        Self {
            refusals: 0,
            nis: [0.0; GATE_WINDOW],
            cos: [0.0; GATE_WINDOW],
            agree: [false; GATE_WINDOW],
            filled: 0,
            cos_filled: 0,
            head: 0,
            white: [0.0; WHITE_DIMS],
            has_white: false,
            matching: false,
            doubting: false,
            learned: Learned::default(),
            last_pair: (f64::NAN, f64::NAN, f64::NAN),
            learned_before: false,
        }
    }

    /// Remember one innovation: its nominal NIS and, when `white` is given, the cosine
    /// with the previous whitened innovation.
    pub(super) fn push(&mut self, nis: f64, white: Option<&[f64]>) {
        let i = self.head;
        self.nis[i] = nis;
        self.filled = (self.filled + 1).min(GATE_WINDOW);
        match white {
            Some(w) => {
                if self.has_white {
                    let prev = &self.white[..w.len()];
                    let dot: f64 = w.iter().zip(prev).map(|(a, b)| a * b).sum();
                    let na = w.iter().map(|a| a * a).sum::<f64>().sqrt();
                    let nb = prev.iter().map(|a| a * a).sum::<f64>().sqrt();
                    self.cos[i] = if na > 0.0 && nb > 0.0 { dot / (na * nb) } else { 0.0 };
                    self.last_pair = (dot, na * na, nb * nb);
                    let d2: f64 = w.iter().zip(prev).map(|(a, b)| (a - b) * (a - b)).sum();
                    self.agree[i] =
                        d2 <= (AGREE_FRACTION * na).powi(2) + AGREE_NOISE * w.len() as f64;
                    self.cos_filled = (self.cos_filled + 1).min(GATE_WINDOW);
                } else {
                    self.cos[i] = 0.0;
                    self.agree[i] = false;
                    self.last_pair = (f64::NAN, f64::NAN, f64::NAN);
                }
                self.white[..w.len()].copy_from_slice(w);
                self.has_white = true;
            }
            None => {
                self.last_pair = (f64::NAN, f64::NAN, f64::NAN);
                self.has_white = false;
                self.cos_filled = 0;
            }
        }
        self.head = (i + 1) % GATE_WINDOW;
    }

    /// Smallest cosine of the last `pairs` pairs (−1 until there are that many).
    pub(super) fn same_way(&self, pairs: usize) -> f64 {
        if self.cos_filled < pairs {
            return -1.0;
        }
        (1..=pairs)
            .map(|j| self.cos[(self.head + GATE_WINDOW - j) % GATE_WINDOW])
            .fold(f64::INFINITY, f64::min)
    }

    /// Whether each of the last `pairs` pairs lies close (false until there are that
    /// many).
    pub(super) fn agree(&self, pairs: usize) -> bool {
        self.cos_filled >= pairs
            && (1..=pairs).all(|j| self.agree[(self.head + GATE_WINDOW - j) % GATE_WINDOW])
    }

    /// Mean cosine of the window's pairs (0 when there is none).
    pub(super) fn mean_cos(&self) -> f64 {
        if self.cos_filled == 0 {
            return 0.0;
        }
        let n = self.cos_filled;
        (1..=n).map(|j| self.cos[(self.head + GATE_WINDOW - j) % GATE_WINDOW]).sum::<f64>()
            / n as f64
    }

    /// Whether the last `k` NIS all exceed `gate`.
    pub(super) fn all_beyond(&self, k: usize, gate: f64) -> bool {
        self.filled >= k
            && (1..=k).all(|j| self.nis[(self.head + GATE_WINDOW - j) % GATE_WINDOW] > gate)
    }

    /// How many NIS of the window are at most `level`.
    pub(super) fn count_below(&self, level: f64) -> usize {
        self.nis[..self.filled].iter().filter(|&&x| x <= level).count()
    }

    /// The smallest NIS of the window.
    pub(super) fn smallest(&self) -> f64 {
        self.nis[..self.filled].iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// The `k`-th smallest NIS of the window (1-based).
    pub(super) fn order_statistic(&self, k: usize) -> f64 {
        let mut v = [0.0; GATE_WINDOW];
        let n = self.filled;
        v[..n].copy_from_slice(&self.nis[..n]);
        let v = &mut v[..n];
        v.sort_unstable_by(f64::total_cmp);
        v[k - 1]
    }
}
