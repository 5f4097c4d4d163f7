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
        if next_fix > t0 && next_fix < t1 {
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
