//! Strategies per measurement stream, and the "unchanged on error" contract for every
//! strategy: a failed update leaves the strategy as it was.

use adaptive::{AnyStrategy, FusedDualWindow, PerStream, Route, STRATEGY_NAMES};
use estimator_core::linear::LinearMeasurement;
use estimator_core::{
    ErrorStateFilter, FilterError, FixedNoise, Manifold, NoiseStrategy, StreamId, Tangent,
    UpdateLog, Verdict,
};
use nalgebra::{Const, Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

fn gps() -> LinearMeasurement<1, 2> {
    LinearMeasurement::new(Matrix1x2::new(1.0, 0.0)).on_stream("gps")
}
fn compass() -> LinearMeasurement<1, 2> {
    LinearMeasurement::new(Matrix1x2::new(0.0, 1.0)).on_stream("compass")
}

/// Routes the same innovations to each stream's strategy: the compass keeps the plain
/// filter (its updates are plain accepts, no factors), GPS gets the fused rule.
fn check_routing<A: NoiseStrategy>(strategy: A) {
    let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), strategy).unwrap();
    let mut log = UpdateLog::default();
    for k in 0..30 {
        let z = Vector1::new(if k % 7 == 3 { 40.0 } else { 0.1 * (k % 3) as f64 });
        f.update_observed(&gps(), &z, &Matrix1::new(1.0), &mut log).unwrap();
        f.update_observed(&compass(), &z, &Matrix1::new(1.0), &mut log).unwrap();
    }
    let on = |name: &'static str| log.entries.iter().filter(move |e| e.stream.name() == name);
    assert!(on("compass").all(|e| e.verdict == Verdict::Accepted && e.factors.dom.is_nan()));
    assert!(on("gps").all(|e| e.verdict != Verdict::Accepted), "fused decides every GPS update");
    assert!(on("gps").any(|e| e.verdict == Verdict::Rejected), "gross errors refused on GPS");
    assert_eq!(on("gps").count(), 30);
}

#[test]
fn route_by_type_gives_each_stream_its_strategy() {
    check_routing(Route::new(gps().stream, FusedDualWindow::default(), FixedNoise));
}

#[test]
fn per_stream_by_name_gives_each_stream_its_strategy() {
    let s = PerStream::new("fixed".parse::<AnyStrategy>().unwrap())
        .with(StreamId::named("gps"), "fused".parse().unwrap());
    assert_eq!(s.name(), "per-stream");
    check_routing(s);
}

/// A vector state whose ⊕ fails (NaN) for corrections above 1e6: an update that every
/// strategy accepts, then fails after the strategy has adapted.
#[derive(Clone, Debug)]
struct Fragile(Vector2<f64>);

impl Manifold for Fragile {
    type Dim = Const<2>;
    fn origin() -> Self {
        Fragile(Vector2::zeros())
    }
    fn oplus(&self, d: &Tangent<Self>) -> Self {
        if d.norm() > 1e6 {
            Fragile(Vector2::repeat(f64::NAN))
        } else {
            Fragile(self.0 + d)
        }
    }
    fn ominus(&self, o: &Self) -> Tangent<Self> {
        self.0 - o.0
    }
    fn is_finite(&self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }
}

struct Position;
impl estimator_core::MeasurementModel for Position {
    type State = Fragile;
    type Measurement = Vector1<f64>;
    fn predict(&self, x: &Fragile) -> Vector1<f64> {
        Vector1::new(x.0[0])
    }
    fn jacobian(&self, _: &Fragile) -> estimator_core::MeasurementJacobians<Const<1>, Const<2>> {
        estimator_core::MeasurementJacobians { H: Matrix1x2::new(1.0, 0.0) }
    }
}

#[test]
fn every_strategy_is_unchanged_after_a_failed_update() {
    for name in STRATEGY_NAMES {
        let s: AnyStrategy = name.parse().unwrap();
        let mut f = ErrorStateFilter::new(Fragile::origin(), Matrix2::identity(), s).unwrap();
        for k in 0..12 {
            f.update(&Position, &Vector1::new(0.3 * ((k % 5) as f64 - 2.0)), &Matrix1::new(1.0))
                .unwrap();
        }
        let before = format!("{:?}", f.strategy());
        let (x, p) = (f.state().0, f.covariance().into_owned());
        // a huge prior makes the gain ≈ 1 and the NIS tiny: every strategy uses the update,
        // and the correction of 1e8 breaks ⊕
        f.set_covariance(Matrix2::identity() * 1e20).unwrap();
        let e = f.update(&Position, &Vector1::new(1e8), &Matrix1::new(1.0)).unwrap_err();
        assert!(matches!(e, FilterError::NonFinite { .. }), "{name}: {e}");
        assert_eq!(
            format!("{:?}", f.strategy()),
            before,
            "{name}: strategy changed by a failed update"
        );
        assert_eq!(f.state().0, x, "{name}");
        f.set_covariance(p).unwrap();
        // and it goes on working
        f.update(&Position, &Vector1::new(0.1), &Matrix1::new(1.0)).unwrap();
    }
}
