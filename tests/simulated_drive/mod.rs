//! The simulated drive the umbrella's INS tests share: the built-in 600 s drive's first
//! segments, a MEMS IMU, GNSS position and velocity at 10 Hz (σ 1 m and 0.05 m/s) from an
//! antenna 0.3 m forward and 1 m up, and a filter started at the truth with σ of 1°,
//! 0.1 m/s, 1 m and small biases.

use estimator::ins_gnss::{GnssConfig, InitialState, InitialStd};
use ins_gnss_sim::{scenarios, simulate, GnssSim, SimDataset, Trajectory};
use nalgebra::Vector3;

/// The GNSS of the drive.
pub fn gnss_10hz() -> GnssSim {
    GnssSim {
        rate_hz: 10.0,
        pos_sigma: Vector3::repeat(1.0),
        vel_sigma: Some(Vector3::repeat(0.05)),
        lever_arm: Vector3::new(0.3, 0.0, -1.0),
        windows: vec![],
    }
}

/// The first `segments` of the drive at `imu_hz`, noise drawn with `seed`. The
/// trajectories are kept (one per number of segments), so the exact IMU of each is
/// integrated once ([`Trajectory::exact_imu`]) and each seed draws only its errors.
pub fn drive(segments: usize, imu_hz: f64, seed: u64) -> SimDataset {
    static KEPT: std::sync::Mutex<Vec<(usize, Trajectory)>> = std::sync::Mutex::new(Vec::new());
    let traj = {
        let mut kept = KEPT.lock().unwrap();
        match kept.iter().find(|k| k.0 == segments) {
            Some(k) => k.1.clone(),
            None => {
                let (start, segs) = scenarios::drive_600s();
                let traj = Trajectory::new(start, &segs[..segments]).unwrap();
                kept.push((segments, traj.clone()));
                traj
            }
        }
    };
    simulate(&traj, imu_hz, &scenarios::mems_imu(), &gnss_10hz(), seed)
}

/// The filter's start at the truth's first record, and the GNSS settings with the
/// antenna's lever arm.
pub fn start_at_truth(data: &SimDataset) -> (InitialState, GnssConfig) {
    let t0 = &data.truth[0];
    let deg = core::f64::consts::PI / 180.0;
    let std = InitialStd {
        att: Vector3::repeat(deg),
        vel: Vector3::repeat(0.1),
        pos: Vector3::repeat(1.0),
        bg: Vector3::repeat(1e-4),
        ba: Vector3::repeat(1e-2),
    };
    let init = InitialState { time: t0.t, state: t0.state.clone(), std };
    (init, GnssConfig { lever_arm: gnss_10hz().lever_arm, ..GnssConfig::default() })
}
