//! The covariance at a lower rate than the state ([`Navigator::with_covariance_interval`]):
//! the mechanization at every IMU sample, the covariance once per interval over the
//! samples' increments combined, and always before an update; and the covariance widened
//! from outside ([`Navigator::widen`]).
//!
//! PX4's EKF2 propagates its covariance this way (at the filter's rate, not the IMU's).
//! Over a stretch of samples `k = 1 … n` the step is taken at the state where the stretch
//! began, with the interval `Σ dt_k`, the angle increment `Σ Δθ_k` and the velocity
//! increment `Σ (I + [θ_{<k}]×) Δv_k` (each sample's `Δv` turned into the stretch's first
//! body frame by the angle turned before it, to first order). `Φ = I + F Σdt` is then
//! first-order over the stretch where the exact mode multiplies `n` first-order steps:
//! they differ by `O((F dt)² n²)`, which the campaigns of `docs/history/benches.md` measure.

use super::*;

/// The pending stretch of a rate-reduced covariance.
#[derive(Clone, Debug)]
pub(super) struct Coarse<S> {
    /// The covariance interval, s.
    pub(super) interval: f64,
    /// The stretch not yet in the covariance: the state where it began, the samples'
    /// increments combined (in that state's body frame) and their number.
    pub(super) pending: Option<(S, ImuSample, u32)>,
}

impl<S: Clone> Coarse<S> {
    pub(super) fn new(interval: f64) -> Self {
        Self { interval, pending: None }
    }

    /// Add sample `s`, taken from state `x` (used when it opens a stretch). Returns whether
    /// the stretch has reached the interval.
    pub(super) fn add(&mut self, x: &S, s: &ImuSample) -> bool {
        let (_, sum, n) = self.pending.get_or_insert_with(|| (x.clone(), s.stretch_opening(), 0));
        *n += 1;
        sum.add_to_stretch(s);
        sum.dt >= self.interval - TIME_EPSILON
    }
}

impl<A: NoiseStrategy, S: NavState> Navigator<A, S>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    /// Propagate the covariance at most once per `interval` seconds (`0`: at every sample,
    /// the exact mode and the default), over the samples' increments combined, and
    /// always before an update. The state is propagated at every sample either way.
    /// Between covariance steps [`covariance`](Self::covariance) and
    /// [`sigma`](Self::sigma) are those of the last step (call
    /// [`settle_covariance`](Self::settle_covariance) to bring them to now; do before a
    /// smoother's backward pass). A run recorded for a smoother
    /// ([`process_recorded`](Self::process_recorded)) records every sample and brings the
    /// covariance to now wherever the recorder reads it
    /// ([`StepRecorder::reads_covariance`]: where a stretch opens, after an update, a
    /// variance epoch or a full segment), and tells it where a stretch goes on past a
    /// sample ([`StepRecorder::covariance_continues`]): the backward pass takes the same
    /// stretches.
    pub fn with_covariance_interval(mut self, interval: f64) -> Self {
        self.coarse = (interval > 0.0).then(|| Coarse::new(interval));
        self
    }

    /// The covariance interval, s (0: every sample).
    pub fn covariance_interval(&self) -> f64 {
        self.coarse.as_ref().map_or(0.0, |c| c.interval)
    }

    /// Take the pending stretch of a rate-reduced covariance into the covariance (nothing
    /// in the exact mode).
    pub fn settle_covariance(&mut self) -> Result<(), NavError> {
        settle(&mut self.coarse, &mut self.filter, &self.model)
    }
}

/// [`Navigator::settle_covariance`] on the navigator's fields (callable while another
/// field is borrowed).
pub(super) fn settle<A: NoiseStrategy, S: NavState>(
    coarse: &mut Option<Coarse<S>>,
    filter: &mut ErrorStateFilter<S, A>,
    model: &S::Model,
) -> Result<(), NavError>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let Some((x0, sum, n)) = coarse.as_mut().and_then(|c| c.pending.take()) else {
        return Ok(());
    };
    let input = ImuInput { prev: None, cur: sum };
    filter
        .predict_covariance(model, &x0, &input, sum.dt, n)
        .map_err(|source| NavError::Filter { t: sum.t, source })
}

/// The covariance widened from outside the filter.
impl<A: NoiseStrategy, S: NavState> Navigator<A, S>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    /// Adds `pos` (N, E, D, m²) to the position error's variances and `vel` (m²/s²) to
    /// the velocity's: evidence from outside the filter that its position is less certain
    /// than its covariance says (RTK: an independent fix contradicting the INS by metres,
    /// which a velocity error may have made). The smoother takes the step as process
    /// noise. Refused (the navigator unchanged) when a variance is negative or not finite.
    pub fn widen(
        &mut self,
        pos: &nalgebra::Vector3<f64>,
        vel: &nalgebra::Vector3<f64>,
    ) -> Result<(), NavError> {
        let t = self.time();
        let bad = |what| NavError::BadSample { t, what };
        if !pos.iter().chain(vel.iter()).all(|v| v.is_finite() && *v >= 0.0) {
            return Err(bad("a variance to add must be finite and not negative"));
        }
        let mut p = self.filter.covariance().into_owned();
        for i in 0..3 {
            p[(3 + i, 3 + i)] += vel[i];
            p[(6 + i, 6 + i)] += pos[i];
        }
        self.filter.set_covariance(p).map_err(|source| NavError::Filter { t, source })
    }
}
