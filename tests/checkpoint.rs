//! Checkpoints (feature `serde`): a filter with its strategy's windows and its smoothers,
//! written out mid-run and read back, resumes bit for bit — the same state, covariance,
//! epoch counter, reports and smoothed trajectory as the run that never stopped.

use estimator::adaptive::{GrossErrorGate, SageHusa};
use estimator::estimator_core::{
    ErrorStateFilter, FixedLagSmoother, Lag, Manifold, MeasurementModel, RtsSmoother, Verdict,
};
use estimator::manifolds::{So2, So3, R1};
use estimator::models::ahrs::AhrsState;
use estimator::models::planar::{Pose2, RangeBearing, Unicycle};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

type Filter = ErrorStateFilter<Pose2, GrossErrorGate<SageHusa>>;

/// Everything a resumed run needs.
#[derive(Serialize, Deserialize)]
struct Checkpoint {
    filter: Filter,
    rts: RtsSmoother<Pose2>,
    lag: FixedLagSmoother<Pose2>,
    step: usize,
}

/// One step's outputs, as bits.
fn bits(f: &Filter, nis: f64) -> Vec<u64> {
    let x = f.state();
    let mut v = vec![x.0.x.to_bits(), x.0.y.to_bits(), x.1.angle().to_bits(), nis.to_bits()];
    v.extend(f.covariance().iter().map(|p| p.to_bits()));
    v.push(f.epoch());
    v
}

/// A robot with range-bearing fixes, one in ten a gross error, the noise 3× what `R`
/// says for a while (so that Sage–Husa's estimate and the gate's windows matter).
fn step(c: &mut Checkpoint, model: &Unicycle) -> Vec<u64> {
    let k = c.step;
    let u = (5.0, 0.3 + 0.2 * (0.05 * k as f64).sin());
    // (one filter, two recorders: the fixed-lag one records on a twin)
    let mut twin = c.filter.clone();
    c.lag.predict(&mut twin, model, &u, 0.1).unwrap();
    c.rts.predict(&mut c.filter, model, &u, 0.1).unwrap();
    let landmarks = [Vector2::new(-30.0, 0.05), Vector2::new(-25.0, -5.0), Vector2::new(5.0, 40.0)];
    let sensor = RangeBearing { landmark: landmarks[k % 3] };
    let wobble = if (100..160).contains(&k) { 3.0 } else { 1.0 };
    let mut z = sensor.predict(c.filter.state());
    z = z.oplus(&Vector2::new(
        0.4 * wobble * (1.3 * k as f64).sin(),
        0.015 * (0.7 * k as f64).cos(),
    ));
    if k % 10 == 7 {
        z = (R1::new(z.0.x + 40.0), z.1);
    }
    let r = Matrix2::new(0.25, 0.0, 0.0, 4e-4);
    let report = c.filter.update(&sensor, &z, &r).unwrap();
    c.step += 1;
    let mut out = bits(&c.filter, report.nis);
    out.push(u64::from(report.verdict == Verdict::Rejected));
    out
}

fn start() -> Checkpoint {
    let x0: Pose2 = (Vector2::new(0.0, -20.0), So2::new(3.0));
    let p0 = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.01));
    let strategy = GrossErrorGate::new(SageHusa::new(0.97), 1e-6, 5);
    Checkpoint {
        filter: ErrorStateFilter::new(x0, p0, strategy).unwrap(),
        rts: RtsSmoother::new(),
        lag: FixedLagSmoother::new(Lag::Steps(25)),
        step: 0,
    }
}

fn smoothed_bits(c: &Checkpoint) -> Vec<u64> {
    let mut v = Vec::new();
    for s in c.rts.smooth(&c.filter).unwrap().iter().chain(&c.lag.smooth(&c.filter).unwrap()) {
        v.extend([s.time.to_bits(), s.x.0.x.to_bits(), s.x.0.y.to_bits(), s.x.1.angle().to_bits()]);
        v.extend(s.p.iter().map(|p| p.to_bits()));
    }
    v
}

#[test]
fn a_run_stopped_and_resumed_equals_one_that_never_stopped() {
    let model = Unicycle { sigma_v: 0.1, sigma_w: 0.02 };
    let mut straight = start();
    let through: Vec<_> = (0..300).map(|_| step(&mut straight, &model)).collect();

    let mut first = start();
    let mut resumed: Vec<_> = (0..150).map(|_| step(&mut first, &model)).collect();
    let text = serde_json::to_string(&first).unwrap();
    drop(first);
    let mut second: Checkpoint = serde_json::from_str(&text).unwrap();
    assert_eq!(second.filter.epoch(), 150);
    resumed.extend((150..300).map(|_| step(&mut second, &model)));

    for (k, (a, b)) in through.iter().zip(&resumed).enumerate() {
        assert_eq!(a, b, "step {k}");
    }
    assert_eq!(smoothed_bits(&straight), smoothed_bits(&second));
    let refused = through.iter().filter(|b| b.last() == Some(&1)).count();
    assert!(refused >= 10, "{refused} refusals: the gate must be exercised");
    println!("checkpoint: {} bytes of JSON at step 150", text.len());
}

#[test]
fn a_composite_state_round_trips_exactly() {
    let x = AhrsState {
        att: So3::from_euler(0.1, -0.25, 2.9),
        bg: Vector3::new(1e-5, -3.3e-4, 0.1 / 3.0),
        acc: Vector3::new(0.0, -9.81, std::f64::consts::PI),
    };
    let back: AhrsState = serde_json::from_str(&serde_json::to_string(&x).unwrap()).unwrap();
    assert_eq!(back, x);
}
