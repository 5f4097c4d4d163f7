//! Per-stream innovation statistics shared by the strategies: a fixed-capacity window of
//! innovations, a running mean, and the projection that keeps an estimated `R` symmetric
//! positive definite. All storage is allocated when a stream first appears; updates do not
//! allocate.

use estimator_core::symmetrize;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, OMatrix, OVector};

/// The last `capacity` innovations of one stream (fewer at start-up: statistics use what
/// there is, and report how many).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
pub struct InnovationWindow {
    capacity: usize,
    dim: usize,
    buf: Vec<f64>,
    len: usize,
    next: usize,
}

clone_in_place!(InnovationWindow { capacity, dim, buf, len, next });

impl InnovationWindow {
    /// A window of `capacity ≥ 1` innovations of dimension `dim`.
    pub fn new(capacity: usize, dim: usize) -> Self {
        let capacity = capacity.max(1);
        Self { capacity, dim, buf: vec![0.0; capacity * dim], len: 0, next: 0 }
    }

    /// Add an innovation (the oldest drops out when full). Ignores a wrong-sized slice.
    pub fn push(&mut self, r: &[f64]) {
        if r.len() != self.dim {
            return;
        }
        let start = self.next * self.dim;
        self.buf[start..start + self.dim].copy_from_slice(r);
        self.next = (self.next + 1) % self.capacity;
        self.len = (self.len + 1).min(self.capacity);
    }

    /// Number of innovations held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `Ĉ = (1/n) Σ r rᵀ` over the held innovations (zero when empty).
    pub fn covariance<M: DimName>(&self) -> OMatrix<f64, M, M>
    where
        DefaultAllocator: Allocator<M, M>,
    {
        let mut c = OMatrix::<f64, M, M>::zeros();
        if self.len == 0 || M::DIM != self.dim {
            return c;
        }
        for k in 0..self.len {
            let r = &self.buf[k * self.dim..(k + 1) * self.dim];
            for j in 0..self.dim {
                for i in j..self.dim {
                    c[(i, j)] += r[i] * r[j];
                }
            }
        }
        let inv = 1.0 / self.len as f64;
        for j in 0..self.dim {
            for i in j..self.dim {
                let v = c[(i, j)] * inv;
                c[(i, j)] = v;
                c[(j, i)] = v;
            }
        }
        c
    }

    /// `tr(Ĉ) = (1/n) Σ |r|²` (zero when empty).
    pub fn trace(&self) -> f64 {
        if self.len == 0 {
            return 0.0;
        }
        self.buf[..self.len * self.dim].iter().map(|v| v * v).sum::<f64>() / self.len as f64
    }

    /// `tr Ĉ` as it would be after [`push`](Self::push)ing `r`, without changing the
    /// window (the oldest innovation drops out of a full one).
    pub fn trace_with(&self, r: &[f64]) -> f64 {
        if r.len() != self.dim {
            return self.trace();
        }
        let held = self.buf[..self.len * self.dim].iter().map(|v| v * v).sum::<f64>();
        let new = r.iter().map(|v| v * v).sum::<f64>();
        if self.len < self.capacity {
            (held + new) / (self.len + 1) as f64
        } else {
            let start = self.next * self.dim;
            let oldest = self.buf[start..start + self.dim].iter().map(|v| v * v).sum::<f64>();
            (held - oldest + new) / self.capacity as f64
        }
    }
}

/// Running mean of every innovation of a stream so far, `r̄_k = (1/k) Σ_{i≤k} r_i`.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
pub struct RunningMean {
    count: u64,
    mean: Vec<f64>,
}

clone_in_place!(RunningMean { count, mean });

impl RunningMean {
    /// Empty mean of dimension `dim`.
    pub fn new(dim: usize) -> Self {
        Self { count: 0, mean: vec![0.0; dim] }
    }

    /// Add a sample (ignored when the size is wrong or a value is not finite).
    pub fn push(&mut self, r: &[f64]) {
        if r.len() != self.mean.len() || !r.iter().all(|v| v.is_finite()) {
            return;
        }
        self.count += 1;
        let w = 1.0 / self.count as f64;
        for (m, v) in self.mean.iter_mut().zip(r) {
            *m += (v - *m) * w;
        }
    }

    /// Number of samples.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The mean as a vector of dimension `M`.
    pub fn get<M: DimName>(&self) -> OVector<f64, M>
    where
        DefaultAllocator: Allocator<M>,
    {
        OVector::<f64, M>::from_fn(|i, _| self.mean.get(i).copied().unwrap_or(0.0))
    }
}

/// Bounds that keep an estimated noise matrix usable, relative to the nominal `R` the
/// caller gave: the diagonal of the result lies in `[floor·R₀ᵢᵢ, ceiling·R₀ᵢᵢ]`.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseBounds {
    /// Lower bound as a fraction of the nominal diagonal (> 0).
    pub floor: f64,
    /// Upper bound as a multiple of the nominal diagonal.
    pub ceiling: f64,
}

impl Default for NoiseBounds {
    fn default() -> Self {
        Self { floor: 0.1, ceiling: 1e4 }
    }
}

/// Project an estimated `R̂` back to a symmetric positive-definite matrix:
///
/// 1. symmetrise; non-finite entries make the whole estimate fall back to `R₀`;
/// 2. if `R̂ − floor·diag(R₀)` has a Cholesky factor and every diagonal entry is below
///    `ceiling·R₀ᵢᵢ`, keep `R̂` as it is (full matrix, correlations included);
/// 3. otherwise keep only the diagonal, clamped to `[floor·R₀ᵢᵢ, ceiling·R₀ᵢᵢ]`.
///
/// Returns the matrix and whether step 3 (or the fallback) was needed.
pub fn project_noise<M: DimName>(
    mut r_hat: OMatrix<f64, M, M>,
    r0: &OMatrix<f64, M, M>,
    bounds: NoiseBounds,
) -> (OMatrix<f64, M, M>, bool)
where
    DefaultAllocator: Allocator<M, M> + Allocator<M>,
{
    if !r_hat.iter().all(|v| v.is_finite()) {
        return (r0.clone_owned(), true);
    }
    symmetrize(&mut r_hat);
    let n = M::DIM;
    let within_ceiling = (0..n).all(|i| r_hat[(i, i)] <= bounds.ceiling * r0[(i, i)]);
    if within_ceiling {
        let mut shifted = r_hat.clone_owned();
        for i in 0..n {
            shifted[(i, i)] -= bounds.floor * r0[(i, i)];
        }
        if shifted.cholesky().is_some() {
            return (r_hat, false);
        }
    }
    let mut d = OMatrix::<f64, M, M>::zeros();
    for i in 0..n {
        d[(i, i)] = r_hat[(i, i)].clamp(bounds.floor * r0[(i, i)], bounds.ceiling * r0[(i, i)]);
    }
    (d, true)
}

/// `tr(a) / tr(b)`, or 1 when `tr(b)` is not positive.
pub fn trace_ratio<M: DimName>(a: &OMatrix<f64, M, M>, b: &OMatrix<f64, M, M>) -> f64
where
    DefaultAllocator: Allocator<M, M>,
{
    let tb = b.trace();
    if tb > 0.0 {
        a.trace() / tb
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::InnovationWindow;

    #[test]
    fn trace_with_equals_pushing_a_copy() {
        let mut w = InnovationWindow::new(5, 3);
        for k in 0..23 {
            let r = [(k as f64 * 0.7).sin(), k as f64 * 0.1, -(k as f64).sqrt()];
            let mut copy = w.clone();
            copy.push(&r);
            let expected = copy.trace();
            let got = w.trace_with(&r);
            assert!(
                (got - expected).abs() <= 1e-12 * expected.max(1.0),
                "at {k}: {got} vs {expected}"
            );
            w.push(&r);
        }
    }
}
