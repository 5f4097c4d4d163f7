//! The iterated update: one iteration is the plain update; on strongly nonlinear
//! measurements (range and bearing from a close beacon; two reference directions seen
//! from an attitude 40° off) it fits the measurement and reports an honest covariance
//! where the plain update does neither.

use estimator_core::linear::LinearMeasurement;
use estimator_core::{ErrorStateFilter, FixedNoise, MeasurementJacobians, MeasurementModel};
use manifolds::{Manifold, So3};
use nalgebra::{Const, Matrix1x2, Matrix2, Matrix3, Matrix6x3, Vector1, Vector2, Vector3, Vector6};
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// Range and bearing of a position from the origin.
struct RangeBearing;

impl MeasurementModel for RangeBearing {
    type State = Vector2<f64>;
    type Measurement = Vector2<f64>;

    fn predict(&self, x: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(x.norm(), x.y.atan2(x.x))
    }

    fn jacobian(&self, x: &Vector2<f64>) -> MeasurementJacobians<Const<2>, Const<2>> {
        let r2 = x.norm_squared();
        let r = r2.sqrt();
        MeasurementJacobians { H: Matrix2::new(x.x / r, x.y / r, -x.y / r2, x.x / r2) }
    }

    fn residual(&self, z: &Vector2<f64>, z_hat: &Vector2<f64>) -> Vector2<f64> {
        let d = z - z_hat;
        Vector2::new(d.x, manifolds::wrap_angle(d.y))
    }
}

fn gauss(rng: &mut StdRng) -> f64 {
    StandardNormal.sample(rng)
}

#[test]
fn one_iteration_is_the_plain_update() {
    let p0 = Matrix2::new(2.0, 0.3, 0.3, 1.0);
    let x0 = Vector2::new(3.0, 1.0);
    let r = Matrix2::new(0.01, 0.0, 0.0, 1e-4);
    let z = Vector2::new(3.5, 0.4);
    let mut plain = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    plain.update(&RangeBearing, &z, &r).unwrap();
    let mut iterated = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    let rep = iterated.update_iterated(&RangeBearing, &z, &r, 1, 0.0).unwrap();
    assert_eq!(rep.iterations, 1);
    assert!((plain.state() - iterated.state()).abs().max() < 1e-12);
    assert!(
        (plain.covariance().into_owned() - iterated.covariance().into_owned()).abs().max() < 1e-12
    );
    // and on a linear model the iteration stops after its second step, which is zero
    let lin = LinearMeasurement::<1, 2>::new(Matrix1x2::new(1.0, 2.0));
    let mut f = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    let mut g = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    f.update(&lin, &Vector1::new(1.0), &nalgebra::Matrix1::new(0.5)).unwrap();
    let rep = g.update_iterated(&lin, &Vector1::new(1.0), &nalgebra::Matrix1::new(0.5), 10, 1e-12);
    let rep = rep.unwrap();
    assert!(rep.converged && rep.iterations == 2, "{rep:?}");
    assert!((f.state() - g.state()).abs().max() < 1e-12);
}

#[test]
fn iterating_fits_a_nonlinear_measurement_and_keeps_its_covariance_honest() {
    // a prior 1 m around a point 2 m from the beacon, range σ 1 cm, bearing σ 0.2°
    let p0 = Matrix2::identity();
    let r = Matrix2::new(1e-4, 0.0, 0.0, (0.2f64.to_radians()).powi(2));
    let mut rng = StdRng::seed_from_u64(7);
    let runs = 400;
    let (mut nees_plain, mut nees_iter, mut fit_plain, mut fit_iter) = (0.0, 0.0, 0.0, 0.0);
    let mut iterations = 0;
    for _ in 0..runs {
        let truth = Vector2::new(2.0, 0.0);
        let x0 = truth + Vector2::new(gauss(&mut rng), gauss(&mut rng));
        let z = RangeBearing.predict(&truth)
            + Vector2::new(0.01 * gauss(&mut rng), 0.2f64.to_radians() * gauss(&mut rng));
        let mut plain = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
        plain.update(&RangeBearing, &z, &r).unwrap();
        let mut iter = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
        let rep = iter.update_iterated(&RangeBearing, &z, &r, 30, 1e-10).unwrap();
        assert!(rep.converged, "{rep:?}");
        iterations += rep.iterations;
        let nees = |f: &ErrorStateFilter<Vector2<f64>, FixedNoise>| {
            let e = f.state() - truth;
            (e.transpose() * f.covariance().try_inverse().unwrap() * e)[0]
        };
        nees_plain += nees(&plain) / runs as f64;
        nees_iter += nees(&iter) / runs as f64;
        let fit = |f: &ErrorStateFilter<Vector2<f64>, FixedNoise>| {
            let d = RangeBearing.residual(&z, &RangeBearing.predict(f.state()));
            (d.transpose() * r.try_inverse().unwrap() * d)[0]
        };
        fit_plain += fit(&plain) / runs as f64;
        fit_iter += fit(&iter) / runs as f64;
    }
    eprintln!(
        "mean NEES plain {nees_plain:.2}, iterated {nees_iter:.2} (2 expected); post-fit \
         residual plain {fit_plain:.2}, iterated {fit_iter:.3}; {:.1} iterations",
        iterations as f64 / runs as f64
    );
    // the iterated posterior is the MAP: the measurement fits, the NEES is in its band
    assert!(fit_iter < 0.01 * fit_plain, "post-fit {fit_iter} vs {fit_plain}");
    assert!(nees_iter < 3.0 && nees_plain > 3.0 * nees_iter, "NEES {nees_iter} vs {nees_plain}");
}

/// Two reference directions (gravity, a magnetic field) seen in the body frame of an
/// attitude: `z = [Rᵀ g; Rᵀ m]`, H by central differences through ⊕ (exact to ~1e-9).
struct TwoVectors;

const G: Vector3<f64> = Vector3::new(0.0, 0.0, 1.0);
const M: Vector3<f64> = Vector3::new(0.6, 0.0, 0.8);

impl MeasurementModel for TwoVectors {
    type State = So3;
    type Measurement = Vector6<f64>;

    fn predict(&self, x: &So3) -> Vector6<f64> {
        let rt = x.matrix().transpose();
        let (a, b) = (rt * G, rt * M);
        Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
    }

    fn jacobian(&self, x: &So3) -> MeasurementJacobians<Const<6>, Const<3>> {
        let mut h = Matrix6x3::zeros();
        let e = 1e-6;
        for k in 0..3 {
            let mut d = Vector3::zeros();
            d[k] = e;
            let col = (self.predict(&x.oplus(&d)) - self.predict(&x.oplus(&-d))) / (2.0 * e);
            h.set_column(k, &col);
        }
        MeasurementJacobians { H: h }
    }
}

#[test]
fn one_iteration_is_the_plain_update_on_so3_too() {
    let truth = So3::exp(&Vector3::new(0.1, -0.2, 0.3));
    let x0 = truth.oplus(&Vector3::new(0.2, -0.1, 0.3));
    let p0 = Matrix3::new(0.04, 0.01, 0.0, 0.01, 0.09, 0.02, 0.0, 0.02, 0.25);
    let z = TwoVectors.predict(&truth);
    let r = nalgebra::Matrix6::identity() * 1e-3;
    let mut plain = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    plain.update(&TwoVectors, &z, &r).unwrap();
    let mut once = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    once.update_iterated(&TwoVectors, &z, &r, 1, 0.0).unwrap();
    assert!(plain.state().ominus(once.state()).amax() < 1e-12);
    let dp = (plain.covariance().into_owned() - once.covariance().into_owned()).amax();
    assert!(dp < 1e-12, "{dp:e}");
}

#[test]
fn on_so3_the_iteration_converges_where_one_step_does_not() {
    let truth = So3::exp(&Vector3::new(0.1, -0.2, 0.3));
    // the prior 40° off about an axis both directions see
    let x0 = truth.oplus(&(Vector3::new(1.0, 1.0, 0.0).normalize() * 40f64.to_radians()));
    let p0 = Matrix3::identity() * 0.7f64.powi(2);
    let z = TwoVectors.predict(&truth);
    let r = nalgebra::Matrix6::identity() * 1e-6;
    let mut plain = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    plain.update(&TwoVectors, &z, &r).unwrap();
    let mut iter = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    let rep = iter.update_iterated(&TwoVectors, &z, &r, 30, 1e-12).unwrap();
    let err = |f: &ErrorStateFilter<So3, FixedNoise>| f.state().ominus(&truth).norm().to_degrees();
    eprintln!(
        "attitude error after one step {:.3}°, iterated {:.2e}° in {} iterations",
        err(&plain),
        err(&iter),
        rep.iterations
    );
    assert!(rep.converged && rep.iterations < 15, "{rep:?}");
    // (the MAP point, not the truth: the prior 40° away still pulls by ~R/P × 40°)
    assert!(err(&iter) < 1e-3 && err(&plain) > 1.0, "{} vs {}", err(&iter), err(&plain));
    // whitened by R (σ 1e-3): the measurement fits to a few thousandths of its σ
    assert!(rep.post_fit < 1e-4, "{rep:?}");
}

/// A strategy that quadruples `R` and counts the gains it is shown.
#[derive(Clone, Default)]
struct Quadruple {
    gains: usize,
}

impl estimator_core::NoiseStrategy for Quadruple {
    fn adapt<N: nalgebra::DimName, M: nalgebra::DimName>(
        &mut self,
        a: &mut estimator_core::Adaptation<'_, N, M>,
    ) where
        nalgebra::DefaultAllocator: estimator_core::FilterAlloc<N, M>,
    {
        a.R *= 4.0;
        a.verdict = estimator_core::Verdict::Inflated;
    }

    fn after_update<N: nalgebra::DimName, M: nalgebra::DimName>(
        &mut self,
        _p: &mut estimator_core::PostUpdate<'_, N, M>,
    ) where
        nalgebra::DefaultAllocator: estimator_core::FilterAlloc<N, M>,
    {
        self.gains += 1;
    }
}

/// The iterated update goes through the strategy and the observer as the plain one does:
/// a gate refuses an outlier (nothing changes, no iteration), an adapted `R*` is the `R`
/// the iterations use, the strategy sees the gain, and the observer every report.
#[test]
fn the_iterated_update_is_gated_adapted_and_observed() {
    use estimator_core::{NisGate, UpdateLog, Verdict};
    let p0 = Matrix2::new(2.0, 0.3, 0.3, 1.0);
    let x0 = Vector2::new(3.0, 1.0);
    let r = Matrix2::new(0.01, 0.0, 0.0, 1e-4);
    let (good, outlier) = (Vector2::new(3.5, 0.4), Vector2::new(30.0, -2.0));
    let mut log = UpdateLog::default();
    let mut gated = ErrorStateFilter::new(x0, p0, NisGate { threshold: 9.21 }).unwrap();
    let (rep, update) =
        gated.update_iterated_observed(&RangeBearing, &outlier, &r, 30, 1e-10, &mut log).unwrap();
    assert_eq!((rep.verdict, rep.iterations), (Verdict::Rejected, 0));
    assert!(update.nis > 9.21, "{}", update.nis);
    assert_eq!(gated.state(), &x0);
    assert_eq!(gated.covariance().into_owned(), p0);
    // a good measurement is taken as the ungated filter takes it
    let (rep, _) =
        gated.update_iterated_observed(&RangeBearing, &good, &r, 30, 1e-10, &mut log).unwrap();
    assert_eq!(rep.verdict, Verdict::Accepted);
    let mut plain = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    let plain_rep = plain.update_iterated(&RangeBearing, &good, &r, 30, 1e-10).unwrap();
    assert_eq!(rep.iterations, plain_rep.iterations);
    assert!((gated.state() - plain.state()).abs().max() < 1e-12);
    let verdicts: Vec<Verdict> = log.entries.iter().map(|e| e.verdict).collect();
    assert_eq!(verdicts, [Verdict::Rejected, Verdict::Accepted]);
    // an adapted R*: the iterations use it, the report has the adapted NIS, the strategy
    // sees the gain
    let mut adapted = ErrorStateFilter::new(x0, p0, Quadruple::default()).unwrap();
    let (rep, update) =
        adapted.update_iterated_observed(&RangeBearing, &good, &r, 30, 1e-10, &mut log).unwrap();
    let mut by_hand = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    by_hand.update_iterated(&RangeBearing, &good, &(r * 4.0), 30, 1e-10).unwrap();
    assert_eq!(rep.verdict, Verdict::Inflated);
    assert!((adapted.state() - by_hand.state()).abs().max() < 1e-12);
    assert!(
        (adapted.covariance().into_owned() - by_hand.covariance().into_owned()).abs().max() < 1e-12
    );
    assert!(update.nis_adapted < update.nis, "{} vs {}", update.nis_adapted, update.nis);
    assert_eq!(adapted.strategy().gains, 1);
    // the plain call's report is as full as the observed one's (dimension-free)
    let mut again = ErrorStateFilter::new(x0, p0, Quadruple::default()).unwrap();
    let short = again.update_iterated(&RangeBearing, &good, &r, 30, 1e-10).unwrap();
    let full = update.summary();
    assert_eq!(short.update.nis_adapted, full.nis_adapted);
    assert_eq!((short.update.verdict, short.update.reason), (full.verdict, full.reason));
    assert_eq!(short.update.factors.lambda_r, full.factors.lambda_r);
    assert_eq!(short.update.dim, 2);
    assert_eq!(log.entries.len(), 3);
}
