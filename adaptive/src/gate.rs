//! A gross-error gate in front of any strategy.

use estimator_core::consistency::chi2_gate;
use estimator_core::{
    Adaptation, FilterAlloc, NoiseStrategy, PostUpdate, PriorScaling, StreamMap, Verdict,
};
use nalgebra::{DefaultAllocator, DimName};

/// Largest measurement dimension whose gate threshold is cached (larger ones are computed
/// at every update).
const CACHED_DIMS: usize = 16;

/// `χ²_{1−p}(m)` for every measurement dimension, computed once per dimension (the
/// quantile is an iterative inverse of the χ² distribution).
#[derive(Clone, Debug)]
struct Thresholds([f64; CACHED_DIMS + 1]);

impl Thresholds {
    fn new() -> Self {
        Self([f64::NAN; CACHED_DIMS + 1])
    }

    fn get(&mut self, m: usize, probability: f64) -> f64 {
        match self.0.get_mut(m) {
            Some(t) => {
                if t.is_nan() {
                    *t = chi2_gate(m, probability);
                }
                *t
            }
            None => chi2_gate(m, probability),
        }
    }
}

/// Refuses an innovation far outside anything the filter believes, whatever the strategy
/// behind it: when `NIS = rᵀ S⁻¹ r` (nominal `S`) exceeds the χ² quantile
/// `χ²_{1−p}(m)`, the update is rejected and the inner strategy does not see it (its
/// windows stay free of gross errors). So that an outage, a diverged heading or a
/// converging filter can never lock a stream out, after `readmit_after` refusals in a row
/// the next gated measurement is admitted down-weighted: `R* = R + (NIS/gate − 1) S`, so
/// that its NIS with `S*` equals the gate (a Huber-like bounded influence), and the count
/// starts again. Innovations inside the gate go to the inner strategy unchanged.
///
/// With `p = 1e-6` (the program's default) a consistent filter refuses one update in a
/// million; a 1 km error on a 5 m fix is refused at once.
///
/// Decisions: `Rejected` with reason `"gate: NIS beyond the χ² gate"`; `Inflated` with
/// reason `"gate: re-admitted, down-weighted to the gate"`. The factor `dom` reports
/// `NIS / gate` on both.
///
/// ```
/// use adaptive::GrossErrorGate;
/// use estimator_core::linear::LinearMeasurement;
/// use estimator_core::{ErrorStateFilter, FixedNoise, Verdict};
/// use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
///
/// let gate = GrossErrorGate::new(FixedNoise, 1e-6, 10);
/// let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), gate).unwrap();
/// let gps = LinearMeasurement::<1, 2>::new(Matrix1x2::new(1.0, 0.0));
/// let r = f.update(&gps, &Vector1::new(1000.0), &Matrix1::new(1.0)).unwrap();
/// assert_eq!(r.verdict, Verdict::Rejected);
/// assert_eq!(f.state()[0], 0.0);
/// ```
#[derive(Clone, Debug)]
pub struct GrossErrorGate<A> {
    /// The strategy behind the gate.
    pub inner: A,
    /// Probability that a consistent innovation is refused (the gate is the
    /// `1 − probability` quantile of χ²(m)); 0 disables the gate.
    pub probability: f64,
    /// Refusals in a row after which the next gated measurement is admitted
    /// down-weighted.
    pub readmit_after: u32,
    refusals: StreamMap<u32>,
    thresholds: Thresholds,
    /// The last update was decided by the gate, not by `inner`.
    bypassed: bool,
}

impl<A: NoiseStrategy> GrossErrorGate<A> {
    /// `inner` behind a gate at `χ²_{1−probability}(m)`, re-admitting after
    /// `readmit_after` refusals in a row.
    pub fn new(inner: A, probability: f64, readmit_after: u32) -> Self {
        Self {
            inner,
            probability,
            readmit_after: readmit_after.max(1),
            refusals: StreamMap::new(),
            thresholds: Thresholds::new(),
            bypassed: false,
        }
    }

    /// `inner` with the gate open (every innovation goes to `inner`): KF-GINS's
    /// behaviour.
    pub fn disabled(inner: A) -> Self {
        Self::new(inner, 0.0, 1)
    }

    /// Whether the gate refuses anything.
    pub fn is_enabled(&self) -> bool {
        self.probability > 0.0
    }

    /// The gate for an `m`-dimensional innovation.
    pub fn threshold(&mut self, m: usize) -> f64 {
        self.thresholds.get(m, self.probability)
    }
}

impl<A: NoiseStrategy> NoiseStrategy for GrossErrorGate<A> {
    /// The inner strategy's name.
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        self.bypassed = false;
        if !self.is_enabled() {
            return self.inner.adapt(a);
        }
        let gate = self.threshold(M::DIM);
        let refusals = self.refusals.get_or_insert_with(a.stream, || 0);
        if a.nis.is_nan() || a.nis <= gate {
            *refusals = 0;
            return self.inner.adapt(a);
        }
        self.bypassed = true;
        a.factors.dom = a.nis / gate;
        if *refusals < self.readmit_after {
            *refusals += 1;
            a.verdict = Verdict::Rejected;
            a.reason = "gate: NIS beyond the χ² gate";
            return;
        }
        // Re-admit, doubting the prior: P⁻* = P⁻ + (λ − 1) P⁻Hᵀ(HP⁻Hᵀ)⁻¹HP⁻, λ = NIS/gate.
        *refusals = 0;
        let k = a.nis / gate;
        a.prior_scale = k;
        a.prior_scaling = PriorScaling::MeasurementSubspace;
        a.factors.lambda_p = k;
        a.verdict = Verdict::Inflated;
        a.reason = "gate: re-admitted after refusals in a row, prior inflated";
    }

    fn prediction_fading(&self) -> f64 {
        self.inner.prediction_fading()
    }

    fn tracks_process_noise(&self) -> bool {
        self.inner.tracks_process_noise()
    }

    fn after_update<N: DimName, M: DimName>(&mut self, p: &mut PostUpdate<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        // a gross error the gate re-admitted is not the inner strategy's to learn from
        if !self.bypassed {
            self.inner.after_update(p)
        }
    }
}

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
#[derive(Clone, Debug)]
pub struct ChiSquareGate {
    /// Probability that a consistent innovation is refused (α).
    pub probability: f64,
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
