//! The unscented filter on a vector space with linear models is the Kalman filter (to
//! 1e-12, for two sigma-point sets), and its update goes through the same strategy hook,
//! verdicts and reports as the error-state update.

#![allow(non_snake_case)]

use crate::common;

use common::{close, gaussian, rng, spd, PlainKf};
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{
    Adaptation, ErrorStateFilter, FilterAlloc, FixedNoise, NoiseStrategy, SigmaPoints, Verdict,
};
use nalgebra::{DefaultAllocator, DimName, Matrix2, Matrix2x4, Matrix4, Vector2, Vector4};

fn problem() -> (Matrix4<f64>, Matrix4<f64>, Matrix2x4<f64>) {
    let dt = 0.1;
    let mut r = rng(3);
    let f = Matrix4::new(
        1.0, 0.0, dt, 0.0, //
        0.0, 1.0, 0.0, dt, //
        0.0, 0.0, 1.0, 0.0, //
        0.0, 0.0, 0.0, 1.0,
    );
    (f, spd::<4>(&mut r, 0.01) * 0.01, Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.3, 0.0))
}

#[test]
fn the_unscented_filter_is_the_kalman_filter_on_a_linear_problem() {
    let (f, q, h) = problem();
    for sp in [SigmaPoints::default(), SigmaPoints::merwe(0.5, 2.0, 0.0)] {
        let mut r = rng(7);
        let p0 = spd::<4>(&mut r, 0.5);
        let x0 = gaussian::<4, 1>(&mut r);
        let (process, sensor) = (LinearProcess { F: f, Q: q }, LinearMeasurement::new(h));
        let mut ukf = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
        let mut kf = PlainKf { x: x0, p: p0 };
        let mut truth = Vector4::new(0.0, 0.0, 1.0, -0.5);
        for k in 0..200 {
            truth = f * truth;
            ukf.predict_unscented(&process, &(), 0.1, &sp).unwrap();
            kf.predict(&f, &q);
            assert!(close(ukf.state(), &kf.x, 1e-12), "{sp:?}: predicted x at {k}");
            assert!(close(&ukf.covariance(), &kf.p, 1e-12), "{sp:?}: predicted P at {k}");
            let rk = spd::<2>(&mut r, 0.1) * (0.5 + (k % 7) as f64 * 0.1);
            let z = h * truth + gaussian::<2, 1>(&mut r) * 0.3;
            let report = ukf.update_unscented(&sensor, &z, &rk, &sp).unwrap();
            let nis = kf.update(&h, &z, &rk);
            assert!(close(ukf.state(), &kf.x, 1e-12), "{sp:?}: x at {k}");
            assert!(close(&ukf.covariance(), &kf.p, 1e-12), "{sp:?}: P at {k}");
            assert!((report.nis - nis).abs() <= 1e-12 * nis.max(1.0), "{sp:?}: NIS at {k}");
        }
        assert!((ukf.time() - 20.0).abs() < 1e-9 && ukf.epoch() == 200);
    }
}

/// Refuses a measurement whose NIS is above 9.
#[derive(Clone, Debug, Default)]
struct Gate {
    seen: usize,
}

impl NoiseStrategy for Gate {
    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        self.seen += 1;
        if a.nis > 9.0 {
            a.verdict = Verdict::Rejected;
        }
    }
}

#[test]
fn the_unscented_update_goes_through_the_strategy_hook() {
    let (f, q, h) = problem();
    let sp = SigmaPoints::default();
    let (process, sensor) = (LinearProcess { F: f, Q: q }, LinearMeasurement::new(h));
    let mut ukf =
        ErrorStateFilter::new(Vector4::zeros(), Matrix4::identity(), Gate::default()).unwrap();
    ukf.predict_unscented(&process, &(), 0.1, &sp).unwrap();
    let r = Matrix2::identity() * 0.01;
    let ok = ukf.update_unscented(&sensor, &Vector2::new(0.1, -0.1), &r, &sp).unwrap();
    assert_eq!(ok.verdict, Verdict::Accepted);
    let (x, p) = (*ukf.state(), ukf.covariance().into_owned());
    let refused = ukf.update_unscented(&sensor, &Vector2::new(50.0, 0.0), &r, &sp).unwrap();
    assert_eq!(refused.verdict, Verdict::Rejected);
    assert!(refused.nis > 9.0);
    assert_eq!(*ukf.state(), x);
    assert_eq!(ukf.covariance().into_owned(), p);
    assert_eq!((ukf.strategy().seen, ukf.epoch()), (2, 2));
}

/// Range and bearing to a landmark, written with `predict` only: no Jacobian.
struct RangeBearingNoJacobian;

impl estimator_core::MeasurementModel for RangeBearingNoJacobian {
    type State = Vector2<f64>;
    type Measurement = Vector2<f64>;

    fn predict(&self, x: &Vector2<f64>) -> Vector2<f64> {
        let d = Vector2::new(5.0, 10.0) - x;
        Vector2::new(d.norm(), d.y.atan2(d.x))
    }
}

/// A model with no Jacobian: the unscented update needs none, and the default `H` (central
/// differences through ⊕/⊖) is the analytic one to 1e-7, so the plain update runs too.
#[test]
fn a_model_without_jacobian_runs_unscented_and_plain() {
    use estimator_core::{ErrorStateFilter, FixedNoise, MeasurementModel, SigmaPoints};
    let x0 = Vector2::new(2.0, 6.0);
    let p0 = Matrix2::new(0.1, 0.02, 0.02, 0.2);
    let r = Matrix2::new(0.09, 0.0, 0.0, 0.01);
    let z = Vector2::new(4.9, 0.95);
    let mut ukf = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    ukf.update_unscented(&RangeBearingNoJacobian, &z, &r, &SigmaPoints::default()).unwrap();
    let mut ekf = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    ekf.update(&RangeBearingNoJacobian, &z, &r).unwrap();
    let d = Vector2::new(5.0, 10.0) - x0;
    let q = d.norm_squared();
    let analytic = Matrix2::new(-d.x / q.sqrt(), -d.y / q.sqrt(), d.y / q, -d.x / q);
    let h = RangeBearingNoJacobian.jacobian(&x0).H;
    assert!((h - analytic).abs().max() < 1e-7, "{h} vs {analytic}");
    // the two filters see the same measurement and land close (a mild nonlinearity)
    assert!((ukf.state() - ekf.state()).norm() < 0.05, "{} vs {}", ukf.state(), ekf.state());
}

/// The smoothers record unscented predictions (with the statistical transition): on the
/// linear problem the RTS smoother over unscented steps is the RTS smoother over plain
/// ones, and the fixed-lag smoother over unscented steps is the RTS smoother's window.
#[test]
fn the_smoothers_record_unscented_predictions() {
    use estimator_core::{FixedLagSmoother, Lag, RtsSmoother};
    let (f, q, h) = problem();
    let sp = SigmaPoints::merwe(0.5, 2.0, 0.0);
    let mut r = rng(9);
    let p0 = spd::<4>(&mut r, 0.5);
    let x0 = gaussian::<4, 1>(&mut r);
    let (process, sensor) = (LinearProcess { F: f, Q: q }, LinearMeasurement::new(h));
    let mut plain = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    let mut sigma = plain.clone();
    let mut lagged = plain.clone();
    let (mut rts_plain, mut rts_sigma) = (RtsSmoother::new(), RtsSmoother::new());
    let mut window = FixedLagSmoother::new(Lag::Steps(15));
    let mut truth = Vector4::new(0.0, 0.0, 1.0, -0.5);
    for k in 0..100 {
        truth = f * truth;
        rts_plain.predict(&mut plain, &process, &(), 0.1).unwrap();
        rts_sigma.predict_unscented(&mut sigma, &process, &(), 0.1, &sp).unwrap();
        window.predict_unscented(&mut lagged, &process, &(), 0.1, &sp).unwrap();
        let rk = spd::<2>(&mut r, 0.1) * (0.5 + (k % 7) as f64 * 0.1);
        let z = h * truth + gaussian::<2, 1>(&mut r) * 0.3;
        plain.update(&sensor, &z, &rk).unwrap();
        sigma.update_unscented(&sensor, &z, &rk, &sp).unwrap();
        lagged.update_unscented(&sensor, &z, &rk, &sp).unwrap();
    }
    let (a, b) = (rts_plain.smooth(&plain).unwrap(), rts_sigma.smooth(&sigma).unwrap());
    assert_eq!((a.len(), b.len()), (101, 101));
    for (k, (a, b)) in a.iter().zip(&b).enumerate() {
        assert!(close(&a.x, &b.x, 1e-10), "x at {k}");
        assert!(close(&a.p, &b.p, 1e-10), "P at {k}");
    }
    let w = window.smooth(&lagged).unwrap();
    assert_eq!(w.len(), 16);
    for (k, (a, b)) in b[85..].iter().zip(&w).enumerate() {
        assert!(close(&a.x, &b.x, 1e-10), "window x at {k}");
        assert!(close(&a.p, &b.p, 1e-10), "window P at {k}");
    }
}
