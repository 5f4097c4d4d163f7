//! What a forward pass tells a recorder ([`StepRecorder`]).

use super::*;

/// What a forward pass tells a recorder: the filter before each prediction, with the
/// prediction's input and interval. `()` records nothing.
pub trait StepRecorder<X: Manifold, U>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// Called with the filter just before `filter.predict(model, u, dt)`; `mark` says that
    /// the prediction ends at an output epoch.
    fn before_predict<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
        u: &U,
        dt: f64,
        mark: bool,
    );

    /// Called with the filter just before an update (or the first of several at one
    /// time): a recorder that stores the covariance a stretch of predictions ends with
    /// takes it here. Without this call the backward pass rebuilds that covariance by
    /// replaying the stretch. Default: nothing.
    fn before_update<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
    ) {
        let _ = filter;
    }

    /// The end of the last recorded prediction is an epoch at which the smoothed
    /// variances are wanted too (the prediction is marked as well). Default: nothing.
    fn mark_variances(&mut self) {}

    /// The caller did not propagate the covariance at the end of the last recorded
    /// prediction, but takes it over a stretch of predictions that goes on past it, as
    /// one step of the inputs folded ([`ProcessModel::fold_input`],
    /// [`ErrorStateFilter::predict_covariance`]); a stretch also ends wherever a recorder
    /// reads the covariance ([`reads_covariance`](Self::reads_covariance)) and before an
    /// update. A smoother's backward pass then takes the same stretches. Default: nothing.
    fn covariance_continues(&mut self) {}

    /// Whether this recorder keeps the predictions (a smoother's replay needs every one
    /// as [`ErrorStateFilter::predict`] takes it); `false` lets the caller take
    /// shortcuts such as a covariance at a lower rate. Default: `true`.
    fn records(&self) -> bool {
        true
    }

    /// Whether the next [`before_predict`](Self::before_predict), with the filter at update
    /// count `epoch`, reads the filter's covariance (a recorder that stores one where a
    /// stretch of predictions opens). A caller that propagates the covariance at a lower
    /// rate than the state brings it to now first when this says so, and may skip it
    /// otherwise. Default: [`records`](Self::records) (every time).
    fn reads_covariance(&self, epoch: u64) -> bool {
        let _ = epoch;
        self.records()
    }
}

impl<X: Manifold, U> StepRecorder<X, U> for ()
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    #[inline]
    fn before_predict<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        _: &ErrorStateFilter<X, A, B>,
        _: &U,
        _: f64,
        _: bool,
    ) {
    }

    #[inline]
    fn records(&self) -> bool {
        false
    }
}

impl<X: Manifold, U, R: StepRecorder<X, U>> StepRecorder<X, U> for Option<R>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    #[inline]
    fn before_predict<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
        u: &U,
        dt: f64,
        mark: bool,
    ) {
        if let Some(r) = self {
            r.before_predict(filter, u, dt, mark);
        }
    }

    #[inline]
    fn before_update<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
    ) {
        if let Some(r) = self {
            r.before_update(filter);
        }
    }

    #[inline]
    fn mark_variances(&mut self) {
        if let Some(r) = self {
            r.mark_variances();
        }
    }

    #[inline]
    fn covariance_continues(&mut self) {
        if let Some(r) = self {
            r.covariance_continues();
        }
    }

    #[inline]
    fn records(&self) -> bool {
        self.as_ref().is_some_and(|r| r.records())
    }

    #[inline]
    fn reads_covariance(&self, epoch: u64) -> bool {
        self.as_ref().is_some_and(|r| r.reads_covariance(epoch))
    }
}
