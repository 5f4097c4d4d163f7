//! The plain χ² gate (a strategy that refuses beyond the quantile and adapts nothing).

use super::*;

/// The plain χ² gate (FilterPy users write it by hand): an innovation whose NIS exceeds
/// `χ²_{1−probability}(m)` is refused and the posterior keeps the prior; every other
/// measurement is used with its nominal noise. Never re-admits — in front of a filter that
/// can diverge prefer [`GrossErrorGate`], which does.
///
/// Decisions: `Rejected` (reason `"χ² gate: NIS beyond χ²_{1−α}(m)"`, `dom` = NIS / gate)
/// or `Accepted`.
///
/// ```
/// use adaptive::ChiSquareGate;
/// use estimator_core::linear::LinearMeasurement;
/// use estimator_core::{ErrorStateFilter, Verdict};
/// use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
///
/// let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), ChiSquareGate::new(0.01)).unwrap();
/// let gps = LinearMeasurement::<1, 2>::new(Matrix1x2::new(1.0, 0.0));
/// let r = f.update(&gps, &Vector1::new(10.0), &Matrix1::new(1.0)).unwrap(); // NIS 50 > 6.63
/// assert_eq!(r.verdict, Verdict::Rejected);
/// assert_eq!(f.covariance()[(0, 0)], 1.0);
/// ```
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Debug)]
pub struct ChiSquareGate {
    /// Probability that a consistent innovation is refused (α).
    pub probability: f64,
    #[cfg_attr(feature = "serde", serde(skip))]
    thresholds: Thresholds,
}

impl ChiSquareGate {
    /// A gate at the `1 − probability` quantile.
    pub fn new(probability: f64) -> Self {
        Self { probability, thresholds: Thresholds::new() }
    }

    /// The gate for an `m`-dimensional innovation.
    pub fn threshold(&mut self, m: usize) -> f64 {
        self.thresholds.get(m, self.probability)
    }
}

impl Default for ChiSquareGate {
    /// α = 0.01.
    fn default() -> Self {
        Self::new(0.01)
    }
}

impl NoiseStrategy for ChiSquareGate {
    fn name(&self) -> &'static str {
        "chi2-gate"
    }

    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let gate = self.threshold(M::DIM);
        a.factors.dom = a.nis / gate;
        if a.nis > gate {
            a.verdict = Verdict::Rejected;
            a.reason = "χ² gate: NIS beyond χ²_{1−α}(m)";
        }
    }
}
