//! The calibration states' CI subset (`examples/calibration_campaign.rs` runs the table):
//! the simulator's drive with RTK-grade fixes (white, 2/2/5 cm), the antenna 1.0 m from
//! the IMU, seeds 1–3, each run as a user makes it (no `[init]`, the default gate).
//!
//! The laws: the lever arm declared `[0, 0, 0]` is found within 5 cm on the horizontal
//! axes with its error within 3σ on every axis, and the vertical one — which a drive on
//! the level cannot tell — is reported not observable; an IMU 0.3 s and 5 s late is
//! found within 5 and 10 ms; an IMU on time gives an offset within 3σ of 0 and no line
//! of the start on it; a mounting of pitch 1°, yaw 2° declared zero is found within 0.2°
//! by the non-holonomic constraint, the roll said to be unseen. And the 26-state filter with every item off is the 15-state one.

use crate::everyday::*;
use estimator::ins_gnss::{GnssConfig, InitialState, InitialStd, Navigator};
use estimator_core::{FixedNoise, NoObserver};
use ins_gnss::run::{run_in_memory, Inputs, RunSummary};
use ins_gnss_core::calibration::{Calibration, InsModelCal, InsStateCal};
use ins_gnss_core::model::InsModel;
use ins_gnss_sim::{scenarios, simulate, GnssSim, Trajectory};
use manifolds::Manifold;
use nalgebra::Vector3;
use rayon::prelude::*;

fn runs(late: f64, extra: &str) -> Vec<RunSummary> {
    mounted_runs(late, Vector3::zeros(), extra)
}

fn mounted_runs(late: f64, mounting: Vector3<f64>, extra: &str) -> Vec<RunSummary> {
    (1..=3u64)
        .into_par_iter()
        .map(|seed| {
            let d = mounted_drive(seed, late, mounting);
            let g = gnss_rows(&d, Errors::White([0.02, 0.02, 0.05]), 1.0, seed);
            let cfg = config_of(&d, extra);
            let inputs =
                Inputs::Arrays { imu: d.imu.clone(), imu_width: 7, gnss: g, gnss_width: 7 };
            run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs).unwrap().0
        })
        .collect()
}

#[test]
fn an_unknown_lever_arm_is_found_where_the_drive_tells_it() {
    let extra = "[gnss]\nlever_arm = [0.0, 0.0, 0.0]\n[calibrate]\nlever_arm = true\n";
    for s in runs(0.0, extra) {
        let c = s.calibration.expect("a calibration line");
        let (l, sigma, _) = c.lever_arm.expect("the lever arm estimated");
        let err = l - Vector3::from(LEVER);
        eprintln!("lever arm error {err:?} m, σ {sigma:?}");
        assert!(err.x.abs() <= 0.05 && err.y.abs() <= 0.05, "{err:?}");
        for k in 0..3 {
            assert!(err[k].abs() <= 3.0 * sigma[k], "axis {k}: {err:?} against σ {sigma:?}");
        }
        let line = c.line();
        assert!(line.contains("not observable by these data on z"), "{line}");
    }
}

#[test]
fn a_late_imu_is_found_to_milliseconds() {
    let lever = format!("[gnss]\nlever_arm = [{}, {}, {}]\n", LEVER[0], LEVER[1], LEVER[2]);
    let extra = format!("{lever}[calibrate]\ntime_offset = true\n");
    for (late, bar) in [(0.3, 0.005), (5.0, 0.010), (0.0, f64::NAN)] {
        for s in runs(late, &extra) {
            let (offset, sigma, _, _) = s.calibration.and_then(|c| c.time_offset).unwrap();
            eprintln!("late {late} s: found {offset:.4} s, σ {sigma:.4} s");
            if late == 0.0 {
                assert!(offset.abs() <= 3.0 * sigma, "on time: {offset} s, σ {sigma} s");
                assert!(!s.start.iter().any(|l| l.contains("time offset")), "{:?}", s.start);
            } else {
                assert!((offset - late).abs() <= bar, "{late} s late: found {offset} s");
                assert!(s.start.iter().any(|l| l.contains("applied to the IMU's stamps")));
            }
        }
    }
}

#[test]
fn an_unknown_mounting_is_found_by_the_nhc() {
    let lever = format!("[gnss]\nlever_arm = [{}, {}, {}]\n", LEVER[0], LEVER[1], LEVER[2]);
    let extra = format!("{lever}[vehicle.nhc]\n[calibrate]\nmounting = true\n");
    let truth = Vector3::new(0.0, 1.0, 2.0);
    for s in mounted_runs(0.0, truth.map(f64::to_radians), &extra) {
        let c = s.calibration.expect("a calibration line");
        let (m, sigma, _) = c.mounting.expect("the mounting estimated");
        let err = m - truth;
        eprintln!("mounting error {err:?}°, σ {sigma:?}°");
        for k in 1..3 {
            assert!(err[k].abs() <= 0.2, "{err:?}");
            assert!(err[k].abs() <= 3.0 * sigma[k].max(0.01), "{err:?} against σ {sigma:?}");
        }
        assert!(c.line().contains("the roll, which the non-holonomic constraint cannot see"));
    }
}

/// The calibration states switched off change nothing: their columns of `H` are zero,
/// their block never correlates, and the navigation states follow the 15-state filter's
/// to rounding.
#[test]
fn the_calibration_states_off_are_the_15_state_filter() {
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs[..6]).unwrap();
    let gnss = GnssSim {
        rate_hz: 5.0,
        pos_sigma: Vector3::repeat(0.5),
        vel_sigma: Some(Vector3::repeat(0.05)),
        lever_arm: Vector3::new(0.3, 0.0, -1.0),
        windows: vec![],
    };
    let data = simulate(&traj, 100.0, &scenarios::mems_imu(), &gnss, 7);
    let t0 = &data.truth[0];
    let std = InitialStd {
        att: Vector3::repeat(0.01),
        vel: Vector3::repeat(0.1),
        pos: Vector3::repeat(1.0),
        bg: Vector3::repeat(1e-4),
        ba: Vector3::repeat(1e-2),
    };
    let init = InitialState { time: t0.t, state: t0.state.clone(), std };
    let config = GnssConfig { lever_arm: gnss.lever_arm, ..GnssConfig::default() };
    let base = InsModel::wgs84(scenarios::mems_imu().noise);
    let mut plain = Navigator::new(&init, base.clone(), FixedNoise, config).unwrap();
    let off = Calibration {
        lever_arm: false,
        time_offset: false,
        mounting: false,
        odometer: false,
        ..Calibration::default()
    };
    let model = InsModelCal { base, calibration: off };
    let l = gnss.lever_arm;
    let x = InsStateCal::new(init.state.clone(), l);
    let mut p = estimator_core::Cov::<nalgebra::Const<26>>::identity();
    p.fixed_view_mut::<15, 15>(0, 0).copy_from(&std.covariance());
    let mut cal = Navigator::from_parts(x, p, init.time, model, FixedNoise, config).unwrap();
    let mut worst: f64 = 0.0;
    for (s, g) in data.replay() {
        plain.process(s, g, &mut NoObserver).unwrap();
        cal.process(s, g, &mut NoObserver).unwrap();
        let (a, b) = (plain.state(), &cal.state().nav);
        let dp = a.pos.ominus(&b.pos).norm();
        worst = worst.max(dp).max((a.vel - b.vel).norm()).max(a.att.ominus(&b.att).norm());
    }
    assert!(worst < 1e-9, "the 26-state run left the 15-state one by {worst}");
    assert_eq!(cal.state().cal, InsStateCal::new(init.state.clone(), l).cal);
    let p = cal.covariance();
    assert_eq!(p.fixed_view::<15, 11>(0, 15).abs().max(), 0.0);
    assert_eq!(p.fixed_view::<11, 11>(15, 15), nalgebra::SMatrix::<f64, 11, 11>::identity());
}

/// The odometer's scale (1.5 % fast) and its wheel point (declared 0.4 m left of where it
/// is) as states: the scale found within 0.1 %, the lateral lever arm within 5 cm, the
/// forward one reported not observable, every axis within 3σ; the outages' score at most
/// 0.8 of the cascade's (the scale calibrated outside the filter) with the same wrong
/// wheel point (measured: 0.226 against 0.703 m, 0.481 against 0.704 m). Against the
/// cascade given the right wheel point the states' score is 8 % and 23 % higher on these
/// seeds (0.210 and 0.390 m); with the wheel point's states held (prior 1 mm) it is 0.237
/// and 0.446 m: the scale's state, not the lever arm's, costs it; why is not established.
#[test]
fn the_odometers_scale_and_wheel_point_are_found() {
    let outs: Vec<_> = (1..=2u64)
        .into_par_iter()
        .map(|seed| {
            let d = odometer_drive(seed, 0.015);
            let g = gnss_rows(&d, Errors::White([0.02, 0.02, 0.05]), 1.0, seed);
            let go = |extra: &str| {
                let cfg = config_of(&d, extra);
                let inputs = Inputs::Arrays {
                    imu: d.imu.clone(),
                    imu_width: 8,
                    gnss: g.clone(),
                    gnss_width: 7,
                };
                run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs).unwrap()
            };
            let wrong = "[vehicle.odometer]\nlever_arm = [0.0, -0.4, 0.0]\n";
            let (states, rs) = go(&format!("{wrong}[calibrate]\nodometer = true\n"));
            let (_, rc) = go(wrong);
            (states, score(&d, &rs, 0.0).0, score(&d, &rc, 0.0).0)
        })
        .collect();
    for (s, score_s, score_c) in outs {
        let c = s.calibration.expect("a calibration line");
        let ((k, ks, _), (l, ls, _)) = c.odometer.expect("the odometer estimated");
        eprintln!(
            "scale {:.4} % σ {:.4} %, wheel point {l:?} σ {ls:?}; outages {score_s:.3} m \
             against the cascade's {score_c:.3} m with the same wheel point\n{}",
            100.0 * k,
            100.0 * ks,
            c.line()
        );
        assert!((k - 0.015).abs() <= 0.001, "scale {k}");
        assert!(l.y.abs() <= 0.05, "lateral wheel point {l:?}");
        for i in 0..3 {
            assert!(l[i].abs() <= 3.0 * ls[i], "axis {i}: {l:?} against σ {ls:?}");
        }
        assert!(c.line().contains("not observable by these data on x"), "{}", c.line());
        assert!(score_s <= 0.8 * score_c, "{score_s} m against {score_c} m");
    }
}
