//! Update reports and observers (design decision 8): telemetry goes to an observer the
//! caller chooses, never to stdout.

use nalgebra::{DefaultAllocator, DimName, OMatrix, OVector};

use manifolds::DimAlloc;

use crate::adapt::{Factors, StreamId, Verdict};

/// Everything about one measurement update.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct UpdateReport<M: DimName>
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
    pub innovation: OVector<f64, M>,
    /// Nominal innovation covariance `S = H P⁻ Hᵀ + R`.
    pub S: OMatrix<f64, M, M>,
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
}

impl<M: DimName> UpdateReport<M>
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
}

/// Receives telemetry from the filter.
pub trait Observer {
    /// After every update attempt that produced a verdict (accepted, inflated, rejected).
    fn on_update<M: DimName>(&mut self, _report: &UpdateReport<M>)
    where
        DefaultAllocator: DimAlloc<M>,
    {
    }
}

/// Discards everything (zero-sized).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoObserver;

impl Observer for NoObserver {}

/// Keeps a summary of every update.
#[derive(Clone, Debug, Default)]
pub struct UpdateLog {
    /// One entry per update, in order.
    pub entries: Vec<UpdateSummary>,
}

impl UpdateLog {
    /// Counts of (accepted, inflated, rejected).
    pub fn counts(&self) -> (usize, usize, usize) {
        self.entries.iter().fold((0, 0, 0), |(a, i, r), e| match e.verdict {
            Verdict::Accepted => (a + 1, i, r),
            Verdict::Inflated => (a, i + 1, r),
            Verdict::Rejected => (a, i, r + 1),
        })
    }
}

impl Observer for UpdateLog {
    fn on_update<M: DimName>(&mut self, report: &UpdateReport<M>)
    where
        DefaultAllocator: DimAlloc<M>,
    {
        self.entries.push(report.summary());
    }
}

impl<O: Observer> Observer for &mut O {
    fn on_update<M: DimName>(&mut self, report: &UpdateReport<M>)
    where
        DefaultAllocator: DimAlloc<M>,
    {
        (**self).on_update(report)
    }
}
