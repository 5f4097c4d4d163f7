//! The scale tests: whether a stream's innovations are all too large for their noise, or keep their direction.

use super::*;

/// The order-statistic test of a window of `n` NIS values of dimension `m`: the `k`-th
/// smallest (`k = max(1, n/2)`, the window's median) is compared with `χ²_{q_d}(m)`, `q_d` chosen so that a consistent stream
/// exceeds it with probability [`SCALE_FALSE_ALARM`] (`P(Bin(n, q_d) ≤ k − 1) = α`);
/// beyond it, the factor is the `k`-th smallest over its median-unbiased quantile
/// `χ²_{(k − 0.3)/(n + 0.4)}(m)`.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug)]
pub(super) struct ScaleTest {
    pub(super) k: usize,
    pub(super) detect: f64,
    pub(super) reference: f64,
    /// `χ²_{1e-3}(m)`.
    pub(super) floor: f64,
    /// The lower quartile's rank (`max(1, n/4)`) and its median-unbiased quantile: the
    /// scale a window shows whatever gross errors hold its upper half.
    pub(super) low_k: usize,
    /// See [`low_k`](Self::low_k).
    pub(super) low_reference: f64,
}

impl ScaleTest {
    pub(super) fn new(m: usize, n: usize) -> Self {
        let k = (n / 2).max(1);
        // P(Bin(n, q) ≤ k − 1) falls from 1 to 0 as q goes from 0 to 1: bisection
        let tail = |q: f64| -> f64 {
            let mut c = 1.0; // C(n, j)
            let mut sum = 0.0;
            for j in 0..k {
                if j > 0 {
                    c *= (n - j + 1) as f64 / j as f64;
                }
                sum += c * q.powi(j as i32) * (1.0 - q).powi((n - j) as i32);
            }
            sum
        };
        let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if tail(mid) > SCALE_FALSE_ALARM {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let m = m as f64;
        let low_k = (n / 4).max(1);
        Self {
            k,
            detect: chi2_quantile(hi, m),
            reference: chi2_quantile((k as f64 - 0.3) / (n as f64 + 0.4), m),
            floor: chi2_quantile(SCALE_FALSE_ALARM, m),
            low_k,
            low_reference: chi2_quantile((low_k as f64 - 0.3) / (n as f64 + 0.4), m),
        }
    }
}

/// Probability that two independent isotropic directions in `m` dimensions have a cosine
/// above `c` (the cosine's density is proportional to `(1 − x²)^{(m−3)/2}`), by the
/// midpoint rule.
pub(super) fn cosine_tail(m: usize, c: f64) -> f64 {
    if m <= 1 {
        return 0.5;
    }
    let e = (m as f64 - 3.0) / 2.0;
    let integral = |a: f64, b: f64| -> f64 {
        const N: usize = 2000;
        let h = (b - a) / N as f64;
        (0..N).map(|i| (1.0 - (a + (i as f64 + 0.5) * h).powi(2)).powf(e)).sum::<f64>() * h
    };
    integral(c, 1.0) / integral(-1.0, 1.0)
}

/// Pairs of successive whitened innovations of dimension `m` that must all keep their
/// direction (cosine above [`SAME_WAY_COS`]) for white innovations to do so with
/// probability at most [`SCALE_FALSE_ALARM`]: 4 in the plane, 3 in space, 2 for a
/// position + velocity fix.
pub(super) fn same_way_pairs(m: usize) -> usize {
    let p = cosine_tail(m, SAME_WAY_COS);
    let k = (SCALE_FALSE_ALARM.ln() / p.ln()).ceil() as usize;
    k.clamp(1, GATE_WINDOW - 1)
}

/// [`same_way_pairs`] per measurement dimension, computed once (0: not yet).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Debug, Default)]
pub(super) struct PairCounts(pub(super) [usize; CACHED_DIMS + 1]);

impl PairCounts {
    pub(super) fn get(&mut self, m: usize) -> usize {
        match self.0.get_mut(m) {
            Some(k) => {
                if *k == 0 {
                    *k = same_way_pairs(m);
                }
                *k
            }
            None => same_way_pairs(m),
        }
    }
}

/// Smallest window the scale test judges.
pub(super) const MIN_WINDOW: usize = 3;

/// The scale tests per measurement dimension and window size, computed once.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Default)]
pub(super) struct ScaleTests(pub(super) Vec<Option<ScaleTest>>);

impl Clone for ScaleTests {
    fn clone(&self) -> Self {
        Self(self.0.clone())
    }

    fn clone_from(&mut self, source: &Self) {
        self.0.clone_from(&source.0);
    }
}

impl ScaleTests {
    pub(super) fn get(&mut self, m: usize, n: usize) -> ScaleTest {
        let i = m * (GATE_WINDOW + 1) + n;
        if self.0.len() <= i {
            self.0.resize(i + 1, None);
        }
        *self.0[i].get_or_insert_with(|| ScaleTest::new(m, n))
    }
}
