//! Navigator behaviour: GNSS epochs between IMU samples are applied at their exact time;
//! static coarse alignment; the χ²-gated IAKF recovers from a 30° heading error.

#![allow(non_snake_case)]

use crate::common;

use adaptive::{FixedNoise, Iakf};
use estimator_core::UpdateLog;
use ins_gnss_core::init::{coarse_align, heading_from_velocity};
use ins_gnss_core::{GeoPos, GnssConfig, InitialState, InitialStd, InsModel, Navigator};
use ins_gnss_sim::{
    scenarios, simulate_from, ExactImu, GnssSim, ImuErrors, Segment, Start, Trajectory,
};
use nalgebra::Vector3;

/// Max NIS over a run on error-free IMU data with noise-free GNSS (σ reported 1 cm) whose
/// epochs fall between IMU samples; `snap` moves each epoch's *time* to the nearest IMU
/// epoch while keeping its position, as a filter without interval splitting would.
fn max_nis(snap: bool) -> f64 {
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs[..6]).unwrap(); // 120 s, up to 20 m/s
    let exact = ExactImu::new(&traj, 100.0);
    let gnss = GnssSim {
        rate_hz: 0.7,
        pos_sigma: Vector3::repeat(0.01),
        vel_sigma: None,
        lever_arm: Vector3::zeros(),
        windows: vec![],
    };
    let mut data = simulate_from(&exact, &traj, &ImuErrors::none(), &gnss, 0);
    // Noise-free positions (σ stays 1 cm in the file).
    for g in &mut data.gnss {
        g.pos = traj.at(g.t).pos;
        if snap {
            g.t = (g.t * 100.0).round() / 100.0;
        }
    }
    let off_grid =
        data.gnss.iter().filter(|g| ((g.t * 100.0) - (g.t * 100.0).round()).abs() > 0.1).count();
    assert!(snap || off_grid > 50, "the epochs must fall between IMU samples");
    let t0 = &data.truth[0];
    let std = InitialStd {
        att: Vector3::repeat(1e-4),
        vel: Vector3::repeat(1e-3),
        pos: Vector3::repeat(1e-3),
        bg: Vector3::repeat(1e-7),
        ba: Vector3::repeat(1e-5),
    };
    let init = InitialState { time: t0.t, state: t0.state.clone(), std };
    let mut nav = Navigator::new(
        &init,
        InsModel::wgs84(scenarios::mems_imu().noise),
        FixedNoise,
        GnssConfig::default(),
    )
    .unwrap();
    let mut log = UpdateLog::default();
    for (s, gnss) in data.replay() {
        nav.process(s, gnss, &mut log).unwrap();
    }
    assert!(log.entries.len() > 70);
    log.entries.iter().filter(|e| e.time > 35.0).map(|e| e.nis).fold(0.0, f64::max)
}

#[test]
fn gnss_between_imu_samples_is_applied_at_its_exact_time() {
    let exact = max_nis(false);
    let snapped = max_nis(true);
    eprintln!("max NIS with splitting {exact:.3}, with snapping {snapped:.1}");
    assert!(exact < 1.0, "max NIS {exact}");
    assert!(snapped > 10.0 * exact.max(0.1), "the control should show the snapping error");
}

#[test]
fn static_coarse_alignment_recovers_roll_pitch_and_gyro_bias() {
    let deg = core::f64::consts::PI / 180.0;
    let start = Start {
        t: 0.0,
        pos: GeoPos::from_degrees(40.0, -105.0, 1600.0),
        speed: 0.0,
        yaw: 60.0 * deg,
        pitch: 2.0 * deg,
    };
    let traj = Trajectory::new(start, &[Segment::stop(60.0)]).unwrap();
    let mut errors = scenarios::mems_imu();
    errors.accel_turn_on = Vector3::zeros(); // roll/pitch absorb accelerometer biases
    let data = ins_gnss_sim::simulate(&traj, 100.0, &errors, &GnssSim::none(), 3);
    let n = data.imu.len() as f64;
    let f = data.imu.iter().map(|s| s.specific_force()).sum::<Vector3<f64>>() / n;
    let w = data.imu.iter().map(|s| s.rate()).sum::<Vector3<f64>>() / n;
    let a = coarse_align(&f, &w, start.pos.lat, 60.0 * deg);
    let truth = &data.truth.last().unwrap().state;
    let (r, p, _) = truth.euler();
    assert!(
        (a.roll - r).abs() < 0.05 * deg && (a.pitch - p).abs() < 0.05 * deg,
        "roll {} pitch {}",
        a.roll / deg,
        a.pitch / deg
    );
    // Gyro bias within 3× the white-noise floor of a 60 s mean (ARW 0.3°/√h ≈ 5e-6 rad/s).
    let floor = errors.noise.arw.x / 60f64.sqrt();
    assert!(
        (a.gyro_bias - truth.bg).abs().max() < 3.0 * floor + 2e-6,
        "bias {:?} vs {:?}",
        a.gyro_bias,
        truth.bg
    );
    assert_eq!(heading_from_velocity(&Vector3::new(0.1, 0.1, 0.0), 1.0), None);
    assert!(
        (heading_from_velocity(&Vector3::new(0.0, 5.0, 0.0), 1.0).unwrap() - 90.0 * deg).abs()
            < 1e-12
    );
}

#[test]
fn iakf_recovers_from_a_30_degree_heading_error() {
    let setup = common::drive_setup(100.0, None);
    let deg = core::f64::consts::PI / 180.0;
    for (name, runs) in
        [("iakf", common::run_many(&setup, 0..2, Iakf::default(), Some(30.0 * deg)))]
    {
        for r in &runs {
            let readmitted =
                r.log.entries.iter().filter(|e| e.reason.contains("re-admitted")).count();
            let last = r.records.last().unwrap();
            let yaw_err = last.error[2].abs() / deg;
            eprintln!("{name}: final yaw error {yaw_err:.3}°, re-admissions {readmitted}");
            assert!(
                readmitted > 0,
                "the 30° start never needed the guard: the test would prove nothing"
            );
            assert!(yaw_err < 1.0, "{name} did not converge: yaw error {yaw_err}°");
            // Once converged the gate stops firing: few inflations in the last 200 s.
            let late = r
                .log
                .entries
                .iter()
                .filter(|e| e.time > 400.0 && e.verdict != estimator_core::Verdict::Accepted)
                .count();
            assert!(late < 20, "{late} inflations after convergence");
        }
    }
}

/// The covariance at a lower rate (`with_covariance_interval`): the state's path is the
/// exact mode's bit for bit until the first update; the settled covariance stays close to
/// the exact one and symmetric positive definite; a recorded run (a smoother's) keeps the
/// state too, and its covariance, brought to now where the recorder stores one (here every
/// 64 samples), as close to the exact one; an interval of 0 is the exact mode.
#[test]
fn covariance_at_a_lower_rate_keeps_the_state_and_follows_the_exact_covariance() {
    use estimator_core::{NoObserver, SegmentSmoother};
    use ins_gnss_core::model::ImuInput;
    use manifolds::Manifold;
    let setup = common::drive_setup(100.0, None);
    let errors = common::imu_errors();
    let data = simulate_from(&setup.exact, &setup.traj, &errors, &setup.gnss, 3);
    let init = common::initial_state(&data, 10_003, None);
    let model = InsModel::wgs84(errors.noise);
    let cfg = GnssConfig { lever_arm: setup.gnss.lever_arm, ..GnssConfig::default() };
    let start = |interval: f64| {
        Navigator::new(&init, model.clone(), FixedNoise, cfg)
            .unwrap()
            .with_covariance_interval(interval)
    };
    let (mut exact, mut coarse, mut zero) = (start(0.0), start(0.05), start(0.0));
    assert_eq!(coarse.covariance_interval(), 0.05);
    let mut recorded = start(0.05);
    let mut smoother = SegmentSmoother::<_, ImuInput, _>::new(std::io::Cursor::new(Vec::new()), 64);
    let mut out = Vec::new();
    // 1. No GNSS for 30 s (3,000 samples): the same states bit for bit.
    let samples: Vec<_> = data.replay().map(|(s, _)| *s).take(3000).collect();
    for s in &samples {
        exact.process_into(s, &[], &mut NoObserver, &mut out).unwrap();
        coarse.process_into(s, &[], &mut NoObserver, &mut out).unwrap();
        zero.process_into(s, &[], &mut NoObserver, &mut out).unwrap();
        recorded.process_recorded(s, &[], &mut NoObserver, &mut out, &mut smoother).unwrap();
    }
    assert_eq!(coarse.nav_state(), exact.nav_state(), "the state's path must not change");
    assert_eq!(zero.covariance(), exact.covariance(), "interval 0 is the exact mode");
    assert_eq!(recorded.nav_state(), exact.nav_state(), "the recorded state's path too");
    assert_eq!(smoother.segments(), 3000 / 64, "a covariance stored every 64 samples");
    coarse.settle_covariance().unwrap();
    recorded.settle_covariance().unwrap();
    let p = exact.covariance();
    let (mut worst, mut worst_recorded): (f64, f64) = (0.0, 0.0);
    let q = coarse.covariance();
    let r = recorded.covariance();
    for i in 0..15 {
        worst = worst.max((q[(i, i)] / p[(i, i)] - 1.0).abs());
        worst_recorded = worst_recorded.max((r[(i, i)] / p[(i, i)] - 1.0).abs());
    }
    assert_ne!(*r, *p, "a recorded run's covariance is not the exact one's");
    assert!(worst_recorded < 0.02, "recorded: variances {worst_recorded:.3} off");
    eprintln!(
        "30 s without GNSS, covariance every 50 ms: largest relative variance change {worst:.2e}"
    );
    assert!(worst < 0.02, "variances {worst:.3} off the exact mode's");
    assert!((q - q.transpose()).amax() == 0.0, "not symmetric");
    assert!(q.cholesky().is_some(), "not positive definite");
    // 2. The whole drive with GNSS (updates settle the covariance first): final position
    //    within a centimetre of the exact mode's and the same updates accepted.
    let (mut exact, mut coarse) = (start(0.0), start(0.05));
    let (mut updates_e, mut updates_c) = (Vec::new(), Vec::new());
    for (s, gnss) in data.replay() {
        exact.process_into(s, gnss, &mut NoObserver, &mut updates_e).unwrap();
        coarse.process_into(s, gnss, &mut NoObserver, &mut updates_c).unwrap();
    }
    let e = exact.nav_state().ominus(coarse.nav_state());
    let d = e.fixed_rows::<3>(6).norm();
    eprintln!("600 s with GNSS: final positions {d:.2e} m apart");
    assert!(d < 0.01, "final positions {d} m apart");
    let verdicts =
        |u: &[estimator_core::UpdateSummary]| u.iter().map(|u| u.verdict).collect::<Vec<_>>();
    assert_eq!(verdicts(&updates_e), verdicts(&updates_c));
}
