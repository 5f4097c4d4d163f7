//! The exact IMU a trajectory keeps ([`Trajectory::exact_imu`]): the same numbers as
//! integrating it again, integrated once per trajectory and rate, shared by its clones,
//! and a simulation from it the same as one that integrates afresh.

use ins_gnss_sim::{scenarios, simulate, simulate_from, ExactImu, Segment, Trajectory};

fn short_drive() -> Trajectory {
    let (start, segs) = scenarios::drive_600s();
    let segs: Vec<Segment> = segs.into_iter().take(3).collect();
    Trajectory::new(start, &segs).unwrap()
}

#[test]
fn a_kept_exact_imu_is_the_one_integrated_again() {
    let traj = short_drive();
    let fresh = ExactImu::new(&traj, 100.0);
    let kept = traj.exact_imu(100.0);
    assert_eq!(kept.samples, fresh.samples);
    assert_eq!(kept.kinematics.len(), fresh.kinematics.len());
    for (a, b) in kept.kinematics.iter().zip(&fresh.kinematics) {
        assert_eq!(
            (a.t, a.vel, a.pos.lat, a.pos.lon, a.pos.h),
            (b.t, b.vel, b.pos.lat, b.pos.lon, b.pos.h)
        );
        assert_eq!((a.w_ib_b, a.f_b), (b.w_ib_b, b.f_b));
        assert_eq!(a.att.matrix(), b.att.matrix());
    }
    // integrated once: the second call and a clone's give the same allocation
    assert!(std::sync::Arc::ptr_eq(&kept, &traj.exact_imu(100.0)));
    assert!(std::sync::Arc::ptr_eq(&kept, &traj.clone().exact_imu(100.0)));
    // another rate is integrated for itself, and then kept instead
    let other = traj.exact_imu(50.0);
    assert_eq!(other.samples.len() * 2, kept.samples.len());
    assert_eq!(other.samples, ExactImu::new(&traj, 50.0).samples);
    assert!(std::sync::Arc::ptr_eq(&other, &traj.exact_imu(50.0)));
    // a new trajectory of the same segments integrates its own
    assert!(!std::sync::Arc::ptr_eq(&kept, &short_drive().exact_imu(100.0)));
}

#[test]
fn a_simulation_from_the_kept_exact_imu_is_a_fresh_one() {
    let traj = short_drive();
    let gnss = scenarios::gnss_1hz(nalgebra::Vector3::new(0.3, 0.0, -1.0));
    for seed in [3, 4] {
        let kept = simulate(&traj, 100.0, &scenarios::mems_imu(), &gnss, seed);
        let fresh =
            simulate_from(&ExactImu::new(&traj, 100.0), &traj, &scenarios::mems_imu(), &gnss, seed);
        assert_eq!(kept.imu, fresh.imu);
        assert_eq!(kept.gnss, fresh.gnss);
        assert_eq!(kept.truth, fresh.truth);
    }
}
