#![allow(non_snake_case)]
//! The unscented filter against FilterPy's `UnscentedKalmanFilter` on the planar
//! range-bearing robot (`models::planar`): the reference in `tests/reference/` was written
//! by `ukf_range_bearing.py` with FilterPy from PyPI (Merwe points α = 0.5, β = 2, κ = 0).
//! With the same mean rule as this filter (the fixed-point iteration on the circle) the
//! states and covariances agree to 1e-9 after every prediction and update; with the
//! extrinsic atan2 mean of FilterPy recipes (`x_mean_fn`, `z_mean_fn`) they differ by what
//! the two means differ, and agree to 1e-9 again when the models give that mean through
//! their `sigma_mean` hooks.

use estimator::estimator_core::{
    ErrorStateFilter, FixedNoise, Manifold, MeasurementModel, ProcessJacobians, ProcessModel,
    SigmaPoints,
};
use estimator::manifolds::{So2, R1};
use estimator::models::planar::{Pose2, RangeBearing, Unicycle};
use nalgebra::{Matrix2, Matrix3, Vector2};
use serde_json::Value;

fn nums(v: &Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(|x| x.as_f64().expect("number")).collect()
}

/// `atan2(Σ wᵢ sin θᵢ, Σ wᵢ cos θᵢ)`: the FilterPy recipes' mean of angles.
fn atan2_mean(angles: impl Iterator<Item = f64>, w: &[f64]) -> So2 {
    let (s, c) =
        angles.zip(w).fold((0.0, 0.0), |(s, c), (a, w)| (s + w * a.sin(), c + w * a.cos()));
    So2::new(s.atan2(c))
}

/// The models with the reference's `atan2_mean` as their sigma-point means (`x_mean_fn`,
/// `z_mean_fn`): positions and ranges by their weighted sums, angles by [`atan2_mean`].
struct Atan2Mean<M>(M);

impl ProcessModel for Atan2Mean<Unicycle> {
    type State = Pose2;
    type Input = (f64, f64);
    fn propagate(&self, x: &Pose2, u: &(f64, f64), dt: f64) -> Pose2 {
        self.0.propagate(x, u, dt)
    }
    fn jacobians(&self, x: &Pose2, u: &(f64, f64), dt: f64) -> ProcessJacobians<nalgebra::U3> {
        self.0.jacobians(x, u, dt)
    }
    fn sigma_mean(&self, points: &[Pose2], w: &[f64]) -> Option<Pose2> {
        let p = points.iter().zip(w).map(|(x, w)| x.0 * *w).sum::<Vector2<f64>>();
        Some((p, atan2_mean(points.iter().map(|x| x.1.angle()), w)))
    }
}

impl MeasurementModel for Atan2Mean<RangeBearing> {
    type State = Pose2;
    type Measurement = (R1, So2);
    fn predict(&self, x: &Pose2) -> (R1, So2) {
        self.0.predict(x)
    }
    fn sigma_mean(&self, points: &[(R1, So2)], w: &[f64]) -> Option<(R1, So2)> {
        let r = points.iter().zip(w).map(|(z, w)| z.0[0] * w).sum::<f64>();
        Some((R1::new(r), atan2_mean(points.iter().map(|z| z.1.angle()), w)))
    }
}

/// Largest state (heading wrapped) and covariance differences over a run, against the
/// reference run `name`; `hooks`: the models give the atan2 mean.
fn replay(doc: &Value, name: &str) -> (f64, f64) {
    replay_with(doc, name, false)
}

fn replay_with(doc: &Value, name: &str, hooks: bool) -> (f64, f64) {
    let dt = doc["dt"].as_f64().unwrap();
    let x0 = nums(&doc["x0"]);
    let P0 = Matrix3::from_row_slice(&nums(&doc["P0"]));
    let R = Matrix2::from_row_slice(&nums(&doc["R"]));
    let model = Unicycle {
        sigma_v: doc["sigma_v"].as_f64().unwrap(),
        sigma_w: doc["sigma_w"].as_f64().unwrap(),
    };
    let sp = SigmaPoints::merwe(
        doc["alpha"].as_f64().unwrap(),
        doc["beta"].as_f64().unwrap(),
        doc["kappa"].as_f64().unwrap(),
    );
    let x: Pose2 = (Vector2::new(x0[0], x0[1]), So2::new(x0[2]));
    let mut f = ErrorStateFilter::new(x, P0, FixedNoise).unwrap();
    let (mut dx, mut dp) = (0.0f64, 0.0f64);
    let mut compare = |f: &ErrorStateFilter<Pose2>, r: &Value| {
        let (x, p) = (nums(&r["x"]), Matrix3::from_row_slice(&nums(&r["P"])));
        let reference: Pose2 = (Vector2::new(x[0], x[1]), So2::new(x[2]));
        dx = dx.max(f.state().ominus(&reference).amax());
        dp = dp.max((f.covariance().into_owned() - p).amax());
    };
    let run = doc["runs"][name].as_array().unwrap();
    for (step, r) in doc["steps"].as_array().unwrap().iter().zip(run) {
        let u = nums(&step["u"]);
        if hooks {
            f.predict_unscented(&Atan2Mean(model), &(u[0], u[1]), dt, &sp).unwrap();
        } else {
            f.predict_unscented(&model, &(u[0], u[1]), dt, &sp).unwrap();
        }
        compare(&f, &r["predicted"]);
        let lm = nums(&step["landmark"]);
        let z = nums(&step["z"]);
        let sensor = RangeBearing { landmark: Vector2::new(lm[0], lm[1]) };
        let z = (R1::new(z[0]), So2::new(z[1]));
        if hooks {
            f.update_unscented(&Atan2Mean(sensor), &z, &R, &sp).unwrap();
        } else {
            f.update_unscented(&sensor, &z, &R, &sp).unwrap();
        }
        compare(&f, &r["updated"]);
    }
    (dx, dp)
}

#[test]
fn the_unscented_filter_equals_filterpy_on_the_range_bearing_robot() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/reference/ukf_range_bearing.json");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let (dx, dp) = replay(&doc, "iterated");
    println!(
        "FilterPy {}, iterated circular mean: state {dx:.2e}, covariance {dp:.2e}",
        doc["filterpy"]
    );
    assert!(dx < 1e-9 && dp < 1e-9, "state {dx:e}, covariance {dp:e}");
    let (ax, ap) = replay(&doc, "atan2");
    println!("atan2 circular mean: state {ax:.2e}, covariance {ap:.2e}");
    // the two means differ at third order in the points' spread: visibly, but little
    assert!(ax > 1e-9 && ax < 1e-3, "state {ax:e}");
    let (hx, hp) = replay_with(&doc, "atan2", true);
    println!("atan2 mean through the sigma_mean hooks: state {hx:.2e}, covariance {hp:.2e}");
    assert!(hx < 1e-9 && hp < 1e-9, "state {hx:e}, covariance {hp:e}");
}
