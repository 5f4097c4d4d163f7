//! The fixed-interval smoother on a nonlinear manifold problem: the planar unicycle on
//! `(R², SO(2))` with range-bearing landmarks, the heading crossing ±π. Over Monte Carlo
//! runs drawn from the models' own noise, the smoothed NEES lies in its band and the
//! smoothed position and heading errors are below the filter's.

use estimator_core::consistency::normalized_squared;
use estimator_core::{
    ErrorStateFilter, FixedNoise, Manifold, MeasurementModel, ProcessModel, RtsSmoother,
};
use manifolds::{So2, R2};
use models::planar::{Pose2, RangeBearing, Unicycle};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

struct Outcome {
    smoothed_nees: Vec<f64>,
    filtered_nees: Vec<f64>,
    smoothed_sq: (f64, f64),
    filtered_sq: (f64, f64),
    crossings: usize,
}

fn run(seed: u64) -> Outcome {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut n = || rng.sample::<f64, _>(StandardNormal);
    let model = Unicycle { sigma_v: 0.1, sigma_w: 0.02 };
    let landmarks = [Vector2::new(-30.0, 0.05), Vector2::new(-25.0, -5.0), Vector2::new(5.0, 40.0)];
    let (u, dt) = ((5.0, 0.3), 0.1);
    let r = Matrix2::new(0.25, 0.0, 0.0, 4e-4); // 0.5 m, 0.02 rad
    let p0 = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.01));
    let x0: Pose2 = (R2::new(0.0, -20.0), So2::new(3.0));
    let l = p0.cholesky().unwrap().l();
    let mut truth = x0.oplus(&(l * Vector3::new(n(), n(), n())));
    let mut f = ErrorStateFilter::new(x0, p0, FixedNoise).unwrap();
    let mut s = RtsSmoother::new();
    let mut truths = vec![truth];
    let mut filtered = vec![(*f.state(), f.covariance().into_owned())];
    let mut crossings = 0;
    for k in 0..300 {
        let noisy = (u.0 + model.sigma_v * n(), u.1 + model.sigma_w * n());
        let before = truth.1.angle();
        truth = model.propagate(&truth, &noisy, dt);
        crossings += usize::from((truth.1.angle() - before).abs() > 3.0);
        s.predict(&mut f, &model, &u, dt).unwrap();
        if k % 2 == 0 {
            let sensor = RangeBearing { landmark: landmarks[(k / 2) % 3] };
            let z = sensor.predict(&truth).oplus(&Vector2::new(0.5 * n(), 0.02 * n()));
            f.update(&sensor, &z, &r).unwrap();
        }
        truths.push(truth);
        filtered.push((*f.state(), f.covariance().into_owned()));
    }
    let smoothed = s.smooth(&f).unwrap();
    assert_eq!(smoothed.len(), truths.len());
    let mut out = Outcome {
        smoothed_nees: Vec::new(),
        filtered_nees: Vec::new(),
        smoothed_sq: (0.0, 0.0),
        filtered_sq: (0.0, 0.0),
        crossings,
    };
    for ((t, sm), (xf, pf)) in truths.iter().zip(&smoothed).zip(&filtered) {
        let es = t.ominus(&sm.x);
        let ef = t.ominus(xf);
        out.smoothed_nees.push(normalized_squared(&es, &sm.p).unwrap());
        out.filtered_nees.push(normalized_squared(&ef, pf).unwrap());
        out.smoothed_sq.0 += es[0] * es[0] + es[1] * es[1];
        out.smoothed_sq.1 += es[2] * es[2];
        out.filtered_sq.0 += ef[0] * ef[0] + ef[1] * ef[1];
        out.filtered_sq.1 += ef[2] * ef[2];
    }
    out
}

#[test]
fn smoothed_nees_in_band_and_errors_below_the_filter() {
    let runs: Vec<Outcome> = (0..40).map(run).collect();
    let samples: usize = runs.iter().map(|r| r.smoothed_nees.len()).sum();
    let mean = |f: &dyn Fn(&Outcome) -> &Vec<f64>| {
        runs.iter().flat_map(|r| f(r).iter()).sum::<f64>() / samples as f64
    };
    let (nees_s, nees_f) = (mean(&|r| &r.smoothed_nees), mean(&|r| &r.filtered_nees));
    let rms =
        |f: &dyn Fn(&Outcome) -> f64| (runs.iter().map(f).sum::<f64>() / samples as f64).sqrt();
    let (pos_s, pos_f) = (rms(&|r| r.smoothed_sq.0), rms(&|r| r.filtered_sq.0));
    let (th_s, th_f) = (rms(&|r| r.smoothed_sq.1), rms(&|r| r.filtered_sq.1));
    let crossings: usize = runs.iter().map(|r| r.crossings).sum();
    eprintln!(
        "40 runs × 301 epochs, {crossings} crossings of ±π: mean NEES smoothed {nees_s:.3}, \
         filtered {nees_f:.3} (3 dof); RMS position smoothed {pos_s:.3} m vs filtered \
         {pos_f:.3} m, heading {th_s:.4} vs {th_f:.4} rad"
    );
    assert!(crossings >= 40, "the heading must cross ±π: {crossings}");
    // 12,040 samples, strongly correlated in time: a wide band around 3
    assert!((2.5..3.6).contains(&nees_s), "smoothed NEES {nees_s}");
    assert!(pos_s < 0.9 * pos_f && th_s < 0.9 * th_f, "smoothing must help");
}
