//! "Add a strategy" (docs/guide/library.md): a user's own noise strategy, its state kept per stream,
//! combined with a built-in one on another stream, run and checked through the public API.

use estimator::adaptive::{FusedDualWindow, Route};
use estimator::estimator_core::linear::LinearMeasurement;
use estimator::estimator_core::{
    Adaptation, ErrorStateFilter, FilterAlloc, NoiseStrategy, StreamId, StreamMap, UpdateLog,
    Verdict,
};
use nalgebra::{DefaultAllocator, DimName, Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

/// Huber-like down-weighting: above the gate, `R* = (NIS / gate) R`, so the update's
/// weight falls as the innovation grows instead of being cut off.
#[derive(Clone, Debug, Default)]
struct Huber {
    gate: f64,
    /// Down-weighted updates per stream.
    downweighted: StreamMap<u32>,
}

impl NoiseStrategy for Huber {
    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        if a.nis > self.gate {
            let k = a.nis / self.gate;
            a.R = a.R_nominal * k; // R* = (NIS/gate) R
            a.factors.lambda_r = k;
            a.verdict = Verdict::Inflated;
            a.reason = "huber: NIS above the gate";
            *self.downweighted.get_or_insert_with(a.stream, || 0) += 1;
        }
    }
}

#[test]
fn a_users_strategy_runs_per_stream_and_reports_its_decisions() {
    let compass = LinearMeasurement::<1, 2>::new(Matrix1x2::new(0.0, 1.0)).on_stream("compass");
    let gps = LinearMeasurement::<1, 2>::new(Matrix1x2::new(1.0, 0.0)).on_stream("gps");
    // Huber on the compass, the fused dual-window rule on GPS.
    let strategy = Route::new(
        compass.stream,
        Huber { gate: 9.0, ..Default::default() },
        FusedDualWindow::default(),
    );
    assert_eq!(Huber::default().name(), "Huber", "the default name is the type's");
    let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), strategy).unwrap();
    let mut log = UpdateLog::default();
    for k in 0..40 {
        let outlier = if k % 10 == 5 { 30.0 } else { 0.0 };
        let z = Vector1::new(0.05 * (k % 4) as f64 + outlier);
        f.update_observed(&compass, &z, &Matrix1::new(0.01), &mut log).unwrap();
        f.update_observed(&gps, &z, &Matrix1::new(0.01), &mut log).unwrap();
    }
    let huber = &f.strategy().on;
    assert_eq!(huber.downweighted.get(compass.stream), Some(&4), "the four compass outliers");
    assert_eq!(huber.downweighted.get(StreamId::named("gps")), None, "GPS is not Huber's");
    let compass_rows: Vec<_> =
        log.entries.iter().filter(|e| e.stream.name() == "compass").collect();
    assert_eq!(compass_rows.iter().filter(|e| e.verdict == Verdict::Inflated).count(), 4);
    assert!(compass_rows.iter().all(|e| e.verdict != Verdict::Rejected));
    // the compass state stays near the inliers: outliers were down-weighted
    assert!(f.state()[1].abs() < 1.0, "{}", f.state()[1]);
}
