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

type Late = estimator::estimator_core::Replay<
    Pose2,
    GrossErrorGate<SageHusa>,
    estimator::estimator_core::StaticCov,
    Unicycle,
>;

const UNICYCLE: Unicycle = Unicycle { sigma_v: 0.1, sigma_w: 0.02 };

/// Step `k` of a smoothed `Replay`: a model prediction on even steps, an unscented one
/// (with its statistical transition) on odd ones; an on-time unscented range-bearing
/// update every fourth step; a fix measured every fifth step and delivered three steps
/// late, applied iterated at its stamp by replay. The measurements come from the
/// noise-free path `truth`, so they do not depend on the filter.
fn late_step(r: &mut Late, k: usize, truth: &[Pose2], pending: &mut Vec<(f64, usize)>) -> Vec<u64> {
    use estimator::estimator_core::SigmaPoints;
    let u = (5.0, 0.3 + 0.2 * (0.05 * k as f64).sin());
    let sp = SigmaPoints::default();
    if k.is_multiple_of(2) {
        r.predict(&u, 0.1).unwrap();
    } else {
        r.predict_with_transition(0.1, move |f, dt| {
            f.predict_unscented_transition(&UNICYCLE, &u, dt, &sp)
        })
        .unwrap();
    }
    let t = r.filter().time();
    let landmarks = [Vector2::new(-30.0, 0.05), Vector2::new(-25.0, -5.0), Vector2::new(5.0, 40.0)];
    let rb = Matrix2::new(0.25, 0.0, 0.0, 4e-4);
    let wobble =
        |j: usize| Vector2::new(0.4 * (1.3 * j as f64).sin(), 0.015 * (0.7 * j as f64).cos());
    if k % 4 == 1 {
        let sensor = RangeBearing { landmark: landmarks[k % 3] };
        let z = sensor.predict(&truth[k]).oplus(&wobble(k));
        r.update_with_at(t, move |f| f.update_unscented(&sensor, &z, &(rb * 2.0), &sp).map(|_| ()))
            .unwrap();
    }
    if k.is_multiple_of(5) {
        pending.push((t, k));
    }
    while let Some(&(stamp, j)) = pending.first() {
        if j + 3 > k {
            break;
        }
        let sensor = RangeBearing { landmark: landmarks[(j + 1) % 3] };
        let z = sensor.predict(&truth[j]).oplus(&wobble(j + 7));
        r.update_with_at(stamp, move |f| f.update_iterated(&sensor, &z, &rb, 5, 1e-12).map(|_| ()))
            .unwrap();
        pending.remove(0);
    }
    bits(r.filter(), 0.0)
}

fn late_start() -> Late {
    let c = start();
    Late::new(c.filter, UNICYCLE, 1.0).with_smoother()
}

fn noise_free_path(n: usize) -> Vec<Pose2> {
    use estimator::estimator_core::ProcessModel;
    let mut path = vec![(Vector2::new(0.5, -19.0), So2::new(3.05))];
    for k in 1..n {
        let u = (5.0, 0.3 + 0.2 * (0.05 * k as f64).sin());
        let next = UNICYCLE.propagate(&path[k - 1], &u, 0.1);
        path.push(next);
    }
    path
}

/// A `Replay` with its smoother — model and unscented predictions, on-time unscented
/// updates, fixes three steps late applied iterated by replay — written to JSON at step
/// 100 (`Replay::checkpoint`) and resumed with the model (`Replay::resume`): at every later
/// step the filter equals the run that never stopped, bit for bit, and so does the
/// smoothed trajectory at the end. The checkpoint closes the history: a fix stamped
/// before step 100 is refused by the resumed run (`TooLate`) and taken by the other.
#[test]
fn a_replay_resumes_bit_for_bit_from_a_checkpoint() {
    use estimator::estimator_core::{FilterError, Replay, ReplayCheckpoint};
    let truth = noise_free_path(201);
    let (mut straight, mut pending_a) = (late_start(), Vec::new());
    let through: Vec<_> =
        (1..=200).map(|k| late_step(&mut straight, k, &truth, &mut pending_a)).collect();
    assert!(straight.replays() >= 35, "{}", straight.replays());

    let (mut first, mut pending_b) = (late_start(), Vec::new());
    let mut resumed: Vec<_> =
        (1..=100).map(|k| late_step(&mut first, k, &truth, &mut pending_b)).collect();
    let text = serde_json::to_string(&first.checkpoint().unwrap()).unwrap();
    let before = first.filter().clone();
    // (the checkpoint leaves the Replay as it was)
    assert_eq!(bits(first.filter(), 0.0), bits(&before, 0.0));
    let t_checkpoint = first.filter().time();
    drop(first);
    let back: ReplayCheckpoint<Pose2, GrossErrorGate<SageHusa>, _> =
        serde_json::from_str(&text).unwrap();
    let mut second = Replay::resume(back, UNICYCLE);
    assert_eq!(second.oldest(), t_checkpoint);

    // a fix stamped before the checkpoint: refused after the resume, taken without it
    let sensor = RangeBearing { landmark: Vector2::new(5.0, 40.0) };
    let (z, r) = (sensor.predict(&truth[99]), Matrix2::new(0.25, 0.0, 0.0, 4e-4));
    let stamp = t_checkpoint - 0.1;
    let mut again: Late = Replay::resume(serde_json::from_str(&text).unwrap(), UNICYCLE);
    let refused = again.update_at(sensor, z, r, stamp);
    assert!(matches!(refused, Err(FilterError::TooLate { .. })), "{refused:?}");
    let (mut third, mut pending_c) = (late_start(), Vec::new());
    (1..=100).for_each(|k| drop(late_step(&mut third, k, &truth, &mut pending_c)));
    assert!(third.update_at(sensor, z, r, stamp).is_ok());

    resumed.extend((101..=200).map(|k| late_step(&mut second, k, &truth, &mut pending_b)));
    for (k, (a, b)) in through.iter().zip(&resumed).enumerate() {
        assert_eq!(a, b, "step {}", k + 1);
    }
    let smoothed = |r: &Late| -> Vec<u64> {
        let mut v = Vec::new();
        for s in r.smooth().unwrap() {
            v.extend([
                s.time.to_bits(),
                s.x.0.x.to_bits(),
                s.x.0.y.to_bits(),
                s.x.1.angle().to_bits(),
            ]);
            v.extend(s.p.iter().map(|p| p.to_bits()));
        }
        v
    };
    let (a, b) = (smoothed(&straight), smoothed(&second));
    assert_eq!((a.len(), b.len()), (201 * (4 + 9), 201 * (4 + 9)));
    if let Some(i) = a.iter().zip(&b).position(|(p, q)| p != q) {
        panic!("the smoothed trajectories differ first at epoch {}", i / 13);
    }
}
