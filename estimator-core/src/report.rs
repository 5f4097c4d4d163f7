//! Update reports and observers (design decision 8): telemetry goes to an observer the
//! caller chooses, never to stdout.

use nalgebra::{DefaultAllocator, DimName, OMatrix, OVector};

use manifolds::DimAlloc;

use crate::adapt::{Factors, Verdict};
use crate::scalar::FilterScalar;
use crate::stream::StreamId;

/// Everything about one measurement update.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct UpdateReport<M: DimName, T: FilterScalar = f64>
where
    DefaultAllocator: DimAlloc<M>,
{
    /// The stream.
    pub stream: StreamId,
    /// Filter update counter (all streams).
    pub epoch: u64,
    /// Filter time in seconds.
    pub time: f64,
    /// Innovation `r = z ⊖ h(x̂⁻)`.
    pub innovation: OVector<T, M>,
    /// Nominal innovation covariance `S = H P⁻ Hᵀ + R`.
    pub S: OMatrix<T, M, M>,
    /// `rᵀ S⁻¹ r` with the nominal `S`.
    pub nis: f64,
    /// `rᵀ S*⁻¹ r` with the innovation covariance actually used,
    /// `S* = λ_P H P⁻ Hᵀ + R*` (equal to `nis` for a plain accept; NaN when rejected).
    pub nis_adapted: f64,
    /// Accepted, inflated or rejected.
    pub verdict: Verdict,
    /// Why (from the strategy; `""` for a plain accept).
    pub reason: &'static str,
    /// The strategy's factors.
    pub factors: Factors,
    /// True when the strategy asked for
    /// [`MeasurementSubspace`](crate::PriorScaling::MeasurementSubspace) scaling but the
    /// prior has no variance the measurement sees (`H P⁻ Hᵀ` zero to rounding), so there
    /// was nothing to scale: the prior was used as it is. (A rank-deficient `H P⁻ Hᵀ`, a
    /// unit vector's measurement, is scaled along the directions it has; it is no
    /// fallback.)
    pub prior_scaling_fallback: bool,
    /// True when the strategy held its adaptation off because adapting had not made the
    /// innovations smaller (see `adaptive`'s fading guard): the update used the nominal
    /// prior, and the stream's innovations are larger than the filter expects for a
    /// reason the strategy cannot cure.
    pub not_helping: bool,
    /// Gaussian log-likelihood of the innovation, `ln N(r; 0, S) = −½ (m ln 2π + ln det S
    /// + rᵀ S⁻¹ r)`, with the innovation covariance actually used (`S*` when the strategy
    /// adapted it; the nominal `S` for a plain accept and for a rejected measurement,
    /// whose likelihood under the prior is reported). FilterPy's `log_likelihood`.
    pub log_likelihood: f64,
}

impl<M: DimName, T: FilterScalar> UpdateReport<M, T>
where
    DefaultAllocator: DimAlloc<M>,
{
    /// A dimension-free copy for logs.
    pub fn summary(&self) -> UpdateSummary {
        UpdateSummary {
            stream: self.stream,
            epoch: self.epoch,
            time: self.time,
            dim: M::DIM,
            nis: self.nis,
            nis_adapted: self.nis_adapted,
            verdict: self.verdict,
            reason: self.reason,
            factors: self.factors,
            prior_scaling_fallback: self.prior_scaling_fallback,
            not_helping: self.not_helping,
            log_likelihood: self.log_likelihood,
        }
    }
}

/// The dimension-free part of an [`UpdateReport`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateSummary {
    /// The stream.
    pub stream: StreamId,
    /// Filter update counter.
    pub epoch: u64,
    /// Filter time in seconds.
    pub time: f64,
    /// Measurement dimension (degrees of freedom of the NIS).
    pub dim: usize,
    /// Normalised innovation squared (nominal `S`).
    pub nis: f64,
    /// NIS with the adapted `S*` (NaN when rejected).
    pub nis_adapted: f64,
    /// The verdict.
    pub verdict: Verdict,
    /// Why.
    pub reason: &'static str,
    /// The strategy's factors.
    pub factors: Factors,
    /// See [`UpdateReport::prior_scaling_fallback`].
    pub prior_scaling_fallback: bool,
    /// See [`UpdateReport::not_helping`].
    pub not_helping: bool,
    /// See [`UpdateReport::log_likelihood`].
    pub log_likelihood: f64,
}

/// Receives telemetry from the filter:
/// [`update_observed`](crate::ErrorStateFilter::update_observed) calls [`on_update`](Self::on_update) once per
/// update that produced a verdict, rejected ones included.
///
/// # Example
///
/// Count the refused updates and keep the largest NIS, per stream name:
///
/// ```
/// use std::collections::BTreeMap;
///
/// use estimator_core::linear::LinearMeasurement;
/// use estimator_core::{ErrorStateFilter, FixedNoise, Observer, UpdateReport, Verdict};
/// use nalgebra::{DefaultAllocator, DimName, Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
/// use manifolds::DimAlloc;
///
/// #[derive(Default)]
/// struct Worst(BTreeMap<&'static str, (f64, usize)>);
///
/// impl Observer for Worst {
///     fn on_update<M: DimName>(&mut self, r: &UpdateReport<M>)
///     where
///         DefaultAllocator: DimAlloc<M>,
///     {
///         let e = self.0.entry(r.stream.name()).or_insert((0.0, 0));
///         e.0 = e.0.max(r.nis);
///         e.1 += usize::from(r.verdict == Verdict::Rejected);
///     }
/// }
///
/// let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), FixedNoise).unwrap();
/// let gps = LinearMeasurement::<1, 2>::new(Matrix1x2::new(1.0, 0.0)).on_stream("gps");
/// let mut worst = Worst::default();
/// for z in [0.5, -0.2, 3.0] {
///     f.update_observed(&gps, &Vector1::new(z), &Matrix1::new(1.0), &mut worst).unwrap();
/// }
/// assert_eq!(worst.0["gps"].1, 0);
/// assert!(worst.0["gps"].0 > 1.0);
/// ```
///
/// `impl Observer for O` observes `f64` filters (`Observer<f64>`); [`NoObserver`] and
/// `&mut O` serve every scalar.
pub trait Observer<T: FilterScalar = f64> {
    /// After every update attempt that produced a verdict (accepted, inflated, rejected).
    fn on_update<M: DimName>(&mut self, _report: &UpdateReport<M, T>)
    where
        DefaultAllocator: DimAlloc<M>,
    {
    }
}

/// Discards everything (zero-sized).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoObserver;

impl<T: FilterScalar> Observer<T> for NoObserver {}

/// Keeps a summary of every update (feature `std`).
#[cfg(feature = "std")]
#[derive(Clone, Debug, Default)]
pub struct UpdateLog {
    /// One entry per update, in order.
    pub entries: Vec<UpdateSummary>,
}

#[cfg(feature = "std")]
impl UpdateLog {
    /// Counts of (accepted, adapted — inflated or deflated —, rejected).
    pub fn counts(&self) -> (usize, usize, usize) {
        self.entries.iter().fold((0, 0, 0), |(a, i, r), e| match e.verdict {
            Verdict::Accepted => (a + 1, i, r),
            Verdict::Inflated | Verdict::Deflated => (a, i + 1, r),
            Verdict::Rejected => (a, i, r + 1),
        })
    }

    /// Updates whose adapted noise was smaller than the nominal ([`Verdict::Deflated`]).
    pub fn deflated(&self) -> usize {
        self.entries.iter().filter(|e| e.verdict == Verdict::Deflated).count()
    }
}

#[cfg(feature = "std")]
impl Observer for UpdateLog {
    fn on_update<M: DimName>(&mut self, report: &UpdateReport<M>)
    where
        DefaultAllocator: DimAlloc<M>,
    {
        self.entries.push(report.summary());
    }
}

impl<T: FilterScalar, O: Observer<T>> Observer<T> for &mut O {
    fn on_update<M: DimName>(&mut self, report: &UpdateReport<M, T>)
    where
        DefaultAllocator: DimAlloc<M>,
    {
        (**self).on_update(report)
    }
}
