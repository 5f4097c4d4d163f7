//! Mechanization alone on exact IMU data: the simulator and the mechanization must agree
//! to far better than any sensor can.

#![allow(non_snake_case)]

use ins_gnss_core::earth::geodetic_to_local_ned;
use ins_gnss_core::imu::ImuSample;
use ins_gnss_core::mechanization::{step, Increments, Mechanization, Nav};
use ins_gnss_sim::{scenarios, simulate, GnssSim, ImuErrors, Trajectory};
use manifolds::Manifold;
use nalgebra::Vector3;

/// Run the mechanization from the true start over every sample; return the largest
/// horizontal and vertical position errors and the largest attitude error (rad).
fn drift(mech: Mechanization, rate: f64) -> (f64, f64, f64, f64) {
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs).unwrap();
    let data = simulate(&traj, rate, &ImuErrors::none(), &GnssSim::none(), 0);
    let t0 = &data.truth[0].state;
    let mut nav = Nav { att: t0.att, vel: t0.vel, pos: t0.pos };
    let mut prev: Option<ImuSample> = None;
    let (mut h_max, mut v_max, mut a_max) = (0.0_f64, 0.0_f64, 0.0_f64);
    for (s, truth) in data.imu.iter().zip(&data.truth[1..]) {
        let inc = Increments {
            dtheta_prev: prev.map_or(Vector3::zeros(), |p| p.dtheta),
            dvel_prev: prev.map_or(Vector3::zeros(), |p| p.dvel),
            dtheta: s.dtheta,
            dvel: s.dvel,
            dt: s.dt,
        };
        nav = step(&mech, &nav, &inc);
        prev = Some(*s);
        let e = geodetic_to_local_ned(truth.state.pos.tuple(), nav.pos.tuple());
        h_max = h_max.max((e.x * e.x + e.y * e.y).sqrt());
        v_max = v_max.max(e.z.abs());
        a_max = a_max.max(nav.att.ominus(&truth.state.att).norm());
    }
    (h_max, v_max, a_max, data.imu.last().unwrap().t)
}

#[test]
fn wgs84_mechanization_drifts_less_than_10_cm_in_600_s() {
    let (h, v, a, t_end) = drift(Mechanization::Wgs84, 200.0);
    eprintln!(
        "WGS-84, 200 Hz, {t_end} s: horizontal {h:.4} m, vertical {v:.4} m, attitude {a:.2e} rad"
    );
    assert!(t_end >= 600.0);
    assert!(h < 0.1, "horizontal drift {h} m");
    assert!(a < 1e-5, "attitude drift {a} rad");
}

#[test]
fn flat_earth_mechanization_is_not_the_wgs84_one() {
    // Sensitivity check: the same exact data through the flat-earth model (which ignores
    // Earth rate and transport rate that the simulated gyro contains) drifts by metres.
    let (start, _) = scenarios::drive_600s();
    let (h, _, _, _) = drift(Mechanization::FlatEarth { reference: start.pos }, 200.0);
    eprintln!("flat earth on WGS-84 data: horizontal {h:.1} m");
    assert!(h > 10.0);
}
