//! The fixed-lag smoother is the fixed-interval smoother restricted to its window: at
//! every moment its estimates equal the last entries of `RtsSmoother::smooth` on the data
//! so far (to 1e-12), whatever the lag; with a lag that covers the run they are the whole
//! fixed-interval result; its memory stays at the lag.

#![allow(non_snake_case)]

use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, FixedLagSmoother, FixedNoise, Lag, RtsSmoother, Smoothed};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

fn same(a: &[Smoothed<Vector2<f64>>], b: &[Smoothed<Vector2<f64>>]) {
    assert_eq!(a.len(), b.len());
    for (a, b) in a.iter().zip(b) {
        assert_eq!(a.time, b.time);
        assert!((a.x - b.x).amax() <= 1e-12 * b.x.amax().max(1.0), "{} {}", a.x, b.x);
        assert!((a.p - b.p).amax() <= 1e-12 * b.p.amax(), "{} {}", a.p, b.p);
    }
}

/// Runs both smoothers on one forward pass; `check(k, fixed_lag, rts, filter)` after
/// every step.
fn run(
    lag: Lag,
    mut check: impl FnMut(
        usize,
        &FixedLagSmoother<Vector2<f64>>,
        &RtsSmoother<Vector2<f64>>,
        &ErrorStateFilter<Vector2<f64>>,
    ),
) {
    let dt = 0.5;
    let process = LinearProcess {
        F: Matrix2::new(1.0, dt, 0.0, 1.0),
        Q: Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.05,
    };
    let sensor = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0));
    let mut f = ErrorStateFilter::new(
        Vector2::new(0.5, -0.2),
        Matrix2::new(4.0, 0.5, 0.5, 1.0),
        FixedNoise,
    )
    .unwrap()
    .with_time(100.0);
    let (mut fl, mut rts) = (FixedLagSmoother::new(lag), RtsSmoother::new());
    for k in 0..120 {
        let mut g = f.clone();
        fl.predict(&mut f, &process, &(), dt).unwrap();
        rts.predict(&mut g, &process, &(), dt).unwrap();
        assert_eq!(f.state(), g.state());
        let t = f.time() - 100.0;
        if k % 4 != 3 && !(40..60).contains(&k) {
            let z = Vector1::new(0.3 * t + (0.7 * t).sin() * 2.0);
            f.update(&sensor, &z, &Matrix1::new(0.4)).unwrap();
        }
        check(k, &fl, &rts, &f);
    }
}

#[test]
fn a_lag_that_covers_the_run_gives_the_fixed_interval_smoother() {
    run(Lag::Steps(1000), |k, fl, rts, f| {
        if k == 119 {
            same(&fl.smooth(f).unwrap(), &rts.smooth(f).unwrap());
        }
    });
    run(Lag::Seconds(1e6), |k, fl, rts, f| {
        if k == 119 {
            same(&fl.smooth(f).unwrap(), &rts.smooth(f).unwrap());
        }
    });
}

#[test]
fn every_window_is_the_fixed_interval_smoother_on_the_data_so_far() {
    for lag in [Lag::Steps(1), Lag::Steps(10), Lag::Seconds(3.2)] {
        let mut largest = 0;
        run(lag, |k, fl, rts, f| {
            let mut full = rts.smooth(f).unwrap();
            let window = fl.smooth(f).unwrap();
            let tail = full.split_off(full.len() - window.len());
            same(&window, &tail);
            let lagged = fl.lagged(f).unwrap();
            assert_eq!(lagged.time, tail[0].time);
            if k >= 20 {
                let expected = match lag {
                    Lag::Steps(n) => n,
                    Lag::Seconds(s) => (s / 0.5) as usize,
                };
                assert_eq!(fl.len(), expected, "{lag:?} at {k}");
            }
            largest = largest.max(fl.len());
        });
        println!("{lag:?}: at most {largest} steps kept");
    }
}
