//! Delayed measurements by replay: a measurement stamped in the past gives exactly the
//! filter that saw it on time (on and between prediction epochs), one older than the
//! history is refused with the filter unchanged, and on a moving target the replayed
//! filter beats the same measurement applied as if current.

#![allow(non_snake_case)]

use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, FilterError, FixedNoise, Replay};
use nalgebra::{Matrix2, Matrix2x4, Matrix4, Vector2, Vector4};

const DT: f64 = 0.01;

fn process() -> LinearProcess<4> {
    let mut F = Matrix4::identity();
    F[(0, 2)] = DT;
    F[(1, 3)] = DT;
    let mut Q = Matrix4::zeros();
    Q[(2, 2)] = 0.5 * DT;
    Q[(3, 3)] = 0.5 * DT;
    LinearProcess { F, Q }
}

fn gps() -> LinearMeasurement<2, 4> {
    LinearMeasurement::new(Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0))
}

/// The target: 10 m/s east, turning.
fn truth(t: f64) -> Vector2<f64> {
    Vector2::new(10.0 * t, 5.0 * (0.3 * t).sin())
}

fn filter() -> ErrorStateFilter<Vector4<f64>> {
    ErrorStateFilter::new(Vector4::new(0.0, 0.0, 10.0, 0.0), Matrix4::identity(), FixedNoise)
        .unwrap()
}

/// Fixes every second at `t = k + offset`, received `delay` later; the replayed filter
/// and an on-time filter that split its prediction at the fix's time, compared bit for
/// bit after every step. Returns the replayed filter's final state.
fn delayed_equals_on_time(offset: f64, delay: f64) -> Vector4<f64> {
    let R = Matrix2::identity() * 0.25;
    let mut late = Replay::new(filter(), process(), 1.0);
    let mut on_time = filter();
    let mut pending: Vec<(f64, Vector2<f64>)> = Vec::new();
    let mut next_fix = offset;
    for _ in 0..500 {
        let (t0, t1) = (on_time.time(), on_time.time() + DT);
        // (a fix within `STAMP_TOLERANCE` of an epoch belongs to it: 0.5 is the epoch the
        // clock calls 0.5000000000000002, not a split leaving a step of 2.7e-16 s)
        if next_fix > t0 + 1e-9 && next_fix < t1 - 1e-9 {
            // the on-time filter splits its step at the fix
            on_time.predict(&process(), &(), next_fix - t0).unwrap();
            on_time.update(&gps(), &truth(next_fix), &R).unwrap();
            on_time.predict(&process(), &(), DT - (next_fix - t0)).unwrap();
            pending.push((next_fix, truth(next_fix)));
            next_fix += 1.0;
        } else {
            on_time.predict(&process(), &(), DT).unwrap();
        }
        late.predict(&(), DT).unwrap();
        if (next_fix - on_time.time()).abs() < 1e-9 {
            on_time.update(&gps(), &truth(next_fix), &R).unwrap();
            pending.push((late.filter().time(), truth(next_fix)));
            next_fix += 1.0;
        }
        // deliver the fixes whose delay has passed
        while let Some(&(t, z)) = pending.first() {
            if t + delay > late.filter().time() + 1e-9 {
                break;
            }
            late.update_at(gps(), z, R, t).unwrap();
            pending.remove(0);
        }
        if pending.is_empty() {
            assert_eq!(late.filter().state(), on_time.state());
            assert_eq!(*late.filter().covariance(), *on_time.covariance());
            assert_eq!(late.filter().epoch(), on_time.epoch());
        }
    }
    assert!(late.replays() >= 4, "{} replays", late.replays());
    *late.filter().state()
}

#[test]
fn a_delayed_fix_gives_the_filter_that_saw_it_on_time() {
    // on prediction epochs, 100 ms late
    delayed_equals_on_time(0.5, 0.1);
    // between epochs (a split step), 105 ms late
    delayed_equals_on_time(0.505, 0.105);
}

#[test]
fn a_fix_older_than_the_history_is_refused_and_changes_nothing() {
    let mut late = Replay::new(filter(), process(), 0.2);
    for _ in 0..100 {
        late.predict(&(), DT).unwrap();
    }
    let (x, p) = (*late.filter().state(), late.filter().covariance().into_owned());
    let err = late.update_at(gps(), Vector2::zeros(), Matrix2::identity(), 0.5).unwrap_err();
    assert!(matches!(err, FilterError::TooLate { .. }), "{err}");
    assert!(err.to_string().contains("older than the replay history"));
    assert_eq!(*late.filter().state(), x);
    assert_eq!(late.filter().covariance().into_owned(), p);
    assert!(late.oldest() >= 0.8 - 1e-9);
}

#[test]
fn replay_beats_a_late_fix_applied_as_current() {
    let R = Matrix2::identity() * 0.01;
    let (mut late, mut naive) = (Replay::new(filter(), process(), 1.0), filter());
    let (mut sq_late, mut sq_naive, mut n) = (0.0, 0.0, 0);
    for k in 1..=3000 {
        late.predict(&(), DT).unwrap();
        naive.predict(&process(), &(), DT).unwrap();
        // a fix taken 10 steps (100 ms) ago arrives every 100 steps
        if k % 100 == 0 {
            let t = late.filter().time() - 0.1;
            late.update_at(gps(), truth(t), R, t).unwrap();
            naive.update(&gps(), &truth(t), &R).unwrap();
        }
        if k > 500 {
            let t = late.filter().time();
            sq_late += (late.filter().state().xy() - truth(t)).norm_squared();
            sq_naive += (naive.state().xy() - truth(t)).norm_squared();
            n += 1;
        }
    }
    let (a, b) = ((sq_late / n as f64).sqrt(), (sq_naive / n as f64).sqrt());
    println!("position RMS: replayed {a:.3} m, applied as current {b:.3} m");
    assert!(a < 0.7 * b, "{a} {b}");
}

/// Sigma-point predictions (`predict_with`), iterated and unscented updates
/// (`update_with_at`) and a fix stamped with its natural time `k · 0.1` — not the filter's
/// clock, which sums its steps (20.000000000000014 after 200 steps of 0.1 s) — delivered
/// 0.35 s late: the replayed filter equals, bit for bit, the filter that applied the fix on
/// time after that epoch's other updates; then the filter comes back out of the replay.
#[test]
fn any_update_and_prediction_replay_bit_for_bit_with_natural_stamps() {
    use estimator_core::SigmaPoints;
    const STEP: f64 = 0.1;
    let R = Matrix2::identity() * 0.25;
    let sp = SigmaPoints::default();
    let mut late = Replay::new(filter(), process(), 1.0);
    let mut on_time = filter();
    let mut pending: Vec<(f64, usize)> = Vec::new();
    let mut replays_checked = 0;
    for k in 1..=300usize {
        late.predict_with(STEP, move |f, dt| f.predict_unscented(&process(), &(), dt, &sp))
            .unwrap();
        on_time.predict_unscented(&process(), &(), STEP, &sp).unwrap();
        let t = on_time.time();
        assert_eq!(late.filter().time(), t);
        if k % 5 == 0 {
            // two updates of other kinds at this epoch, on time in both filters
            let z = truth(t) + Vector2::new(0.3, -0.2);
            on_time.update_iterated(&gps(), &z, &R, 5, 1e-12).unwrap();
            late.update_with_at(t, move |f| {
                f.update_iterated(&gps(), &z, &R, 5, 1e-12).map(|_| ())
            })
            .unwrap();
            on_time.update_unscented(&gps(), &z, &(R * 4.0), &sp).unwrap();
            late.update_with_at(t, move |f| {
                f.update_unscented(&gps(), &z, &(R * 4.0), &sp).map(|_| ())
            })
            .unwrap();
        }
        if k % 20 == 0 {
            // the fix of epoch k, applied on time after the epoch's other updates, and
            // stamped k · 0.1 for the late filter
            on_time.update(&gps(), &truth(k as f64 * STEP), &R).unwrap();
            pending.push((k as f64 * STEP, k));
        }
        while let Some(&(stamp, _)) = pending.first() {
            if stamp + 0.35 > t + 1e-9 {
                break;
            }
            late.update_at(gps(), truth(stamp), R, stamp).unwrap();
            pending.remove(0);
            assert_eq!(late.filter().state(), on_time.state());
            assert_eq!(*late.filter().covariance(), *on_time.covariance());
            replays_checked += 1;
        }
    }
    // the last fix (epoch 300), delivered at once: at the filter's own epoch, by the
    // tolerance, without a replay
    let replays = late.replays();
    for (stamp, _) in pending.drain(..) {
        late.update_at(gps(), truth(stamp), R, stamp).unwrap();
    }
    assert_eq!(late.replays(), replays);
    assert!(replays_checked >= 14, "{replays_checked}");
    assert!(late.replays() >= 14);
    let (f, _model) = late.into_inner();
    assert_eq!(f.state(), on_time.state());
    // the filter's clock is not the natural stamp, which is why the tolerance matters
    assert_ne!(f.time(), 300.0 * STEP);
}

/// `predict_to` lands on the stamp exactly, where a sum of steps drifts, and refuses a
/// time in the past.
#[test]
fn predict_to_lands_on_the_stamp() {
    use estimator_core::linear::LinearProcess;
    use estimator_core::{ErrorStateFilter, FixedNoise};
    use nalgebra::{Matrix2, Vector2};
    let process =
        LinearProcess { F: Matrix2::new(1.0, 0.1, 0.0, 1.0), Q: Matrix2::identity() * 1e-3 };
    let mut summed =
        ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), FixedNoise).unwrap();
    let mut stamped = summed.clone();
    for k in 1..=200 {
        summed.predict(&process, &(), 0.1).unwrap();
        stamped.predict_to(&process, &(), k as f64 * 0.1).unwrap();
    }
    assert_ne!(summed.time(), 20.0);
    assert_eq!(stamped.time(), 20.0);
    assert!((summed.state() - stamped.state()).abs().max() < 1e-12);
    assert!(stamped.predict_to(&process, &(), 19.9).is_err());
    assert_eq!(stamped.time(), 20.0);
}

/// A smoothed `Replay` (`with_smoother`): fixes twice a second (on a prediction epoch and
/// between two) received 0.25 s late give
/// the fixed-interval smoothed trajectory of the on-time filter recorded by an
/// `RtsSmoother` — the same epochs, states and covariances, bit for bit — whether the
/// predictions are the model's (`predict`) or the caller's with their transition
/// (`predict_with_transition`); a caller's prediction without its transition is refused
/// with nothing changed.
#[test]
fn a_smoothed_replay_gives_the_on_time_smoothed_trajectory() {
    use estimator_core::{FixedLagSmoother, Lag, RtsSmoother};
    let R = Matrix2::identity() * 0.25;
    let (delay, offset) = (0.25, 0.5);
    // fixes at 0.5, 1.005, 1.5, 2.005, …: on an epoch, then inside a step
    let mut on_time = filter();
    let mut rts = RtsSmoother::new();
    // (the same on-time filter again, recorded by a fixed-lag smoother of 0.3 s)
    let (mut on_lag, mut lag) = (filter(), FixedLagSmoother::new(Lag::Seconds(0.3)));
    let mut by_model = Replay::new(filter(), process(), 1.0).with_smoother();
    let mut by_lag = Replay::new(filter(), process(), 1.0).with_fixed_lag(Lag::Seconds(0.3));
    let mut lagged_checked = 0;
    let mut by_step = Replay::new(filter(), process(), 1.0).with_smoother();
    let step = |f: &mut ErrorStateFilter<Vector4<f64>>, dt: f64| {
        f.predict(&process(), &(), dt)?;
        Ok(process().F)
    };
    let mut pending: Vec<(f64, Vector2<f64>)> = Vec::new();
    let mut next_fix = offset;
    for _ in 0..500 {
        let t0 = on_time.time();
        if next_fix > t0 + 1e-9 && next_fix < t0 + DT - 1e-9 {
            rts.predict(&mut on_time, &process(), &(), next_fix - t0).unwrap();
            lag.predict(&mut on_lag, &process(), &(), next_fix - t0).unwrap();
            on_time.update(&gps(), &truth(next_fix), &R).unwrap();
            on_lag.update(&gps(), &truth(next_fix), &R).unwrap();
            rts.predict(&mut on_time, &process(), &(), DT - (next_fix - t0)).unwrap();
            lag.predict(&mut on_lag, &process(), &(), DT - (next_fix - t0)).unwrap();
            pending.push((next_fix, truth(next_fix)));
            next_fix += if next_fix.fract() < 0.1 { 0.505 } else { 0.495 };
        } else {
            rts.predict(&mut on_time, &process(), &(), DT).unwrap();
            lag.predict(&mut on_lag, &process(), &(), DT).unwrap();
        }
        by_model.predict(&(), DT).unwrap();
        by_lag.predict(&(), DT).unwrap();
        by_step.predict_with_transition(DT, step).unwrap();
        if (next_fix - on_time.time()).abs() < 1e-9 {
            on_time.update(&gps(), &truth(next_fix), &R).unwrap();
            on_lag.update(&gps(), &truth(next_fix), &R).unwrap();
            pending.push((by_model.filter().time(), truth(next_fix)));
            next_fix += if next_fix.fract() < 0.1 { 0.505 } else { 0.495 };
        }
        while let Some(&(t, z)) = pending.first() {
            if t + delay > by_model.filter().time() + 1e-9 {
                break;
            }
            by_model.update_at(gps(), z, R, t).unwrap();
            by_step.update_at(gps(), z, R, t).unwrap();
            by_lag.update_at(gps(), z, R, t).unwrap();
            pending.remove(0);
        }
        // with no fix on its way, the fixed-lag window, late fixes and all, is the
        // on-time one's
        if pending.is_empty() {
            let (got, want) = (by_lag.lagged().unwrap(), lag.lagged(&on_lag).unwrap());
            assert_eq!((got.time, got.x, got.p), (want.time, want.x, want.p));
            lagged_checked += 1;
        }
    }
    // the fixes still on their way arrive
    for (t, z) in pending {
        by_model.update_at(gps(), z, R, t).unwrap();
        by_step.update_at(gps(), z, R, t).unwrap();
        by_lag.update_at(gps(), z, R, t).unwrap();
    }
    let (got, want) = (by_lag.smooth().unwrap(), lag.smooth(&on_lag).unwrap());
    assert_eq!(got.len(), want.len());
    assert!((30..=33).contains(&got.len()), "{}", got.len());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!((g.time, g.x, g.p), (w.time, w.x, w.p));
    }
    assert!(lagged_checked > 100, "{lagged_checked}");
    assert!(by_model.replays() > 0 && by_model.smoother().unwrap().steps().len() > 300);
    let want = rts.smooth(&on_time).unwrap();
    for replay in [&by_model, &by_step] {
        let got = replay.smooth().unwrap();
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            assert!((g.time - w.time).abs() < 1e-9, "{} vs {}", g.time, w.time);
            assert_eq!((g.x, g.p), (w.x, w.p), "at {}", w.time);
        }
    }
    let before = by_model.filter().clone();
    let refused = by_model.predict_with(DT, |f, dt| f.predict(&process(), &(), dt));
    assert!(matches!(refused, Err(FilterError::Unsupported { .. })), "{refused:?}");
    assert_eq!(by_model.filter().state(), before.state());
}
