//! The bank of heading hypotheses (`ins_gnss_core::align::heading_bank`) against the
//! simulator: after a static start, forwards and backwards (the IMU mounted facing the
//! rear), from any heading, its heading within 3σ of the truth on every seed; standing
//! still, it claims nothing (the mixture's σ stays the circle's).

use ins_gnss_core::align::{heading_bank, BankStart, Wheels, BANK_SIZE};
use ins_gnss_core::imu::{DEG_PER_H, DEG_PER_SQRT_H, M_S_PER_SQRT_H};
use ins_gnss_core::init::level;
use ins_gnss_core::GeoPos;
use ins_gnss_sim::scenarios::mems_imu;
use ins_gnss_sim::{simulate, GnssSim, ImuErrors, SimDataset};
use ins_gnss_sim::{Segment, Start, Trajectory};
use manifolds::So3;
use nalgebra::Vector3;

const DEG: f64 = core::f64::consts::PI / 180.0;

/// Stands `standing` s, then drives with two turns; headed `yaw0` (deg); the IMU mounted
/// at yaw `mounting` (deg); 1 Hz fixes of white σ `std` m from 0.3 m ahead, 1 m above.
fn drive(seed: u64, yaw0: f64, standing: f64, mounting: f64, std: f64) -> SimDataset {
    let start = Start {
        t: 0.0,
        pos: GeoPos::from_degrees(30.5, 114.3, 25.0),
        speed: 0.0,
        yaw: yaw0 * DEG,
        pitch: 0.0,
    };
    let segs = [
        Segment::stop(standing),
        Segment::accelerate(8.0, 1.5),
        Segment::straight(20.0),
        Segment::turn(15.0, 6.0 * DEG),
        Segment::straight(20.0),
        Segment::turn(15.0, -6.0 * DEG),
        Segment::straight(20.0),
    ];
    let traj = Trajectory::new(start, &segs).unwrap();
    let gnss = GnssSim {
        rate_hz: 1.0,
        pos_sigma: Vector3::repeat(std),
        vel_sigma: None,
        lever_arm: Vector3::new(0.3, 0.0, -1.0),
        windows: vec![],
    };
    let imu = ImuErrors { mounting: Vector3::new(0.0, 0.0, mounting * DEG), ..mems_imu() };
    simulate(&traj, 100.0, &imu, &gnss, seed)
}

/// A start from the first sample at `speed` m/s, headed by the seed (spread over the
/// circle).
fn moving(seed: u64, speed: f64) -> Start {
    let yaw0 = (seed as f64 * 101.0 + 7.0) % 360.0 - 180.0;
    Start {
        t: 0.0,
        pos: GeoPos::from_degrees(30.5, 114.3, 25.0),
        speed,
        yaw: yaw0 * DEG,
        pitch: 0.0,
    }
}

/// Roll and pitch levelled on the mean specific force of the first `secs` s.
fn level_on_first(d: &SimDataset, secs: f64) -> (f64, f64) {
    let first: Vec<_> = d.imu.iter().filter(|s| s.t <= secs).collect();
    level(&(first.iter().map(|s| s.specific_force()).sum::<Vector3<f64>>() / first.len() as f64))
}

/// The bank from the end of the first `standing` s (levelled on them, their mean rate
/// taken off), as the program's start runs it; its heading error (deg) and σ (deg).
fn bank_after_standing(d: &SimDataset, standing: f64) -> (f64, f64) {
    let still: Vec<_> = d.imu.iter().filter(|s| s.t <= standing).collect();
    let n = still.len() as f64;
    let mean_f = still.iter().map(|s| s.specific_force()).sum::<Vector3<f64>>() / n;
    let mean_w = still.iter().map(|s| s.rate()).sum::<Vector3<f64>>() / n;
    let (roll, pitch) = level(&mean_f);
    let imu: Vec<_> = d.imu.iter().copied().filter(|s| s.t > standing).collect();
    let first = d.gnss.partition_point(|e| e.t <= standing) - 1;
    let start = BankStart {
        tilt: So3::from_euler(roll, pitch, 0.0),
        gyro_bias: mean_w,
        vel: Vector3::zeros(),
        vel_std: 0.05,
        lever: Vector3::new(0.3, 0.0, -1.0),
        arw: 0.3 * DEG_PER_SQRT_H,
        tilt_std: 0.5 * DEG,
        gyro_bias_std: 15.0 * DEG_PER_H,
        vrw: 0.1 * M_S_PER_SQRT_H,
        use_velocity: true,
        wheels: None,
    };
    let b = heading_bank(&imu, &d.gnss[first..], &start, 0.0).expect("fixes");
    let truth = d.truth.iter().find(|r| r.t >= standing).unwrap().state.att.euler().2;
    let e = ins_gnss_core::heading::wrap(b.heading - truth);
    (e / DEG, b.std / DEG)
}

#[test]
fn after_a_static_start_the_heading_is_found_within_three_sigma_from_any_heading() {
    let mut worst: f64 = 0.0;
    for seed in 0..12u64 {
        let yaw0 = (seed as f64 * 67.0 + 13.0) % 360.0 - 180.0;
        for (mounting, std) in [(0.0, 0.02), (180.0, 0.02), (0.0, 1.0)] {
            let d = drive(seed, yaw0, 10.0, mounting, std);
            let (e, s) = bank_after_standing(&d, 10.0);
            assert!(
                s < 10.0,
                "seed {seed}, yaw {yaw0}°, mounting {mounting}°, fixes σ {std} m: σ {s:.1}°"
            );
            assert!(
                e.abs() <= 3.0 * s,
                "seed {seed}, yaw {yaw0}°, mounting {mounting}°, fixes σ {std} m: error {e:.2}° at σ {s:.2}°"
            );
            worst = worst.max(e.abs() / s);
        }
    }
    // (the bank's σ is not a bound far beyond its errors: the worst error reaches a
    // third of 3σ at least)
    assert!(worst > 0.3, "worst error / σ {worst:.2}");
}

#[test]
fn standing_still_the_bank_claims_no_heading() {
    let d = drive(3, 40.0, 60.0, 0.0, 0.02);
    let imu: Vec<_> = d.imu.iter().copied().filter(|s| s.t <= 55.0).collect();
    let gnss: Vec<_> = d.gnss.iter().copied().filter(|e| e.t <= 55.0).collect();
    let (roll, pitch) = level(&imu[0].specific_force());
    let start = BankStart {
        tilt: So3::from_euler(roll, pitch, 0.0),
        gyro_bias: Vector3::zeros(),
        vel: Vector3::zeros(),
        vel_std: 0.05,
        lever: Vector3::new(0.3, 0.0, -1.0),
        arw: 0.3 * DEG_PER_SQRT_H,
        tilt_std: 0.5 * DEG,
        gyro_bias_std: 50.0 * DEG_PER_H,
        vrw: 0.1 * M_S_PER_SQRT_H,
        use_velocity: true,
        wheels: None,
    };
    let b = heading_bank(&imu, &gnss, &start, 0.0).unwrap();
    // a uniform circle's σ is 180°/√3 ≈ 104°; no hypothesis may stand out
    assert!(b.std > 90.0 * DEG, "σ {:.1}°", b.std / DEG);
    assert!(b.weight < 2.0 / BANK_SIZE as f64, "largest weight {:.3}", b.weight);
    assert_eq!(b.fixes, gnss.len());
}

/// The bank's start while moving, as the program's start makes it for a consumer MEMS
/// (`moving_bank`): levelled (`roll`, `pitch`) to 3°, the velocity `vel` known to 1 m/s,
/// no gyro bias known (100°/h), the antenna at `lever`; the fixes' velocities used.
fn moving_start(roll: f64, pitch: f64, vel: Vector3<f64>, lever: Vector3<f64>) -> BankStart {
    BankStart {
        tilt: So3::from_euler(roll, pitch, 0.0),
        gyro_bias: Vector3::zeros(),
        vel,
        vel_std: 1.0,
        lever,
        arw: 0.3 * DEG_PER_SQRT_H,
        tilt_std: 3.0 * DEG,
        gyro_bias_std: 100.0 * DEG_PER_H,
        vrw: 0.1 * M_S_PER_SQRT_H,
        use_velocity: true,
        wheels: None,
    }
}

#[test]
fn moving_from_the_first_sample_the_heading_is_found_within_three_sigma() {
    // a car at 10 m/s from the first sample, forwards and backwards (IMU facing the
    // rear), levelled on its first 5 s, its velocity from a line through its first fixes,
    // no gyro bias known: the bank as the program's start runs it when the in-motion fit
    // cannot tell the heading
    for seed in 0..8u64 {
        for mounting in [0.0, 180.0] {
            let start = moving(seed, 10.0);
            let segs = [
                Segment::straight(10.0),
                Segment::turn(15.0, 6.0 * DEG),
                Segment::accelerate(5.0, 1.0),
                Segment::turn(15.0, -6.0 * DEG),
                Segment::straight(15.0),
            ];
            let traj = Trajectory::new(start, &segs).unwrap();
            let gnss = GnssSim {
                rate_hz: 1.0,
                pos_sigma: Vector3::repeat(0.5),
                vel_sigma: None,
                lever_arm: Vector3::new(0.3, 0.0, -1.0),
                windows: vec![],
            };
            let imu = ImuErrors { mounting: Vector3::new(0.0, 0.0, mounting * DEG), ..mems_imu() };
            let d = simulate(&traj, 100.0, &imu, &gnss, seed);
            let (roll, pitch) = level_on_first(&d, 5.0);
            // (the true velocity at the first fix, as a line through the first fixes gives
            // it to about its 1 m/s σ)
            let v = d.truth[0].state.vel;
            let start = moving_start(
                roll,
                pitch,
                v + Vector3::new(0.3, -0.3, 0.0),
                Vector3::new(0.3, 0.0, -1.0),
            );
            let b = heading_bank(&d.imu, &d.gnss, &start, 0.0).unwrap();
            let truth = d.truth[0].state.att.euler().2;
            let e = ins_gnss_core::heading::wrap(b.heading - truth) / DEG;
            let s = b.std / DEG;
            assert!(s < 10.0, "seed {seed}, mounting {mounting}°: σ {s:.1}°");
            assert!(
                e.abs() <= 3.0 * s,
                "seed {seed}, mounting {mounting}°: error {e:.2}° at σ {s:.2}°"
            );
        }
    }
}

#[test]
fn a_walker_with_a_receivers_doppler_velocity_is_headed_within_three_sigma() {
    // a person walking at 1.4 m/s from the first sample with two square turns, the
    // fixes of a receiver that sees four satellites: positions to 9 m, the Doppler's
    // velocity to 0.2 m/s. The positions alone cannot tell the heading within the
    // walk's 100 s (the program refused such walks); the velocities do.
    for seed in 0..8u64 {
        let start = moving(seed, 1.4);
        let segs = [
            Segment::straight(30.0),
            Segment::turn(2.0, 45.0 * DEG),
            Segment::straight(30.0),
            Segment::turn(2.0, -45.0 * DEG),
            Segment::straight(36.0),
        ];
        let traj = Trajectory::new(start, &segs).unwrap();
        let gnss = GnssSim {
            rate_hz: 1.0,
            pos_sigma: Vector3::new(9.0, 9.0, 13.0),
            vel_sigma: Some(Vector3::repeat(0.2)),
            lever_arm: Vector3::new(0.0, 0.0, -0.2),
            windows: vec![],
        };
        let d = simulate(&traj, 100.0, &mems_imu(), &gnss, seed);
        let (roll, pitch) = level_on_first(&d, 1.0);
        let bank = |use_velocity: bool| {
            // (the first fix's velocity, as the program's line through the first fixes
            // gives it to its 1 m/s σ)
            let vel = d.gnss[0].vel.unwrap().0;
            let start = BankStart {
                use_velocity,
                ..moving_start(roll, pitch, vel, Vector3::new(0.0, 0.0, -0.2))
            };
            heading_bank(&d.imu, &d.gnss, &start, 0.0).unwrap()
        };
        let truth = d.truth[0].state.att.euler().2;
        let (with, without) = (bank(true), bank(false));
        let e = ins_gnss_core::heading::wrap(with.heading - truth) / DEG;
        let s = with.std / DEG;
        eprintln!(
            "seed {seed}: error {e:.2}°, σ {s:.2}° with the velocities, {:.1}° without",
            without.std / DEG
        );
        assert!(s < 8.0, "seed {seed}: σ {s:.1}° with the velocities");
        assert!(e.abs() <= 3.0 * s, "seed {seed}: error {e:.2}° at σ {s:.2}°");
        assert!(
            without.std / DEG > 3.0 * s,
            "seed {seed}: σ {:.1}° from the positions alone against {s:.1}°",
            without.std / DEG
        );
    }
}

#[test]
fn a_rover_driving_straight_shows_its_heading_through_its_wheels() {
    // a rover at 1 m/s in a straight line from the first sample for 120 s, fixes of 1 m
    // σ: nothing turns and nothing accelerates, so the specific force cannot tell the
    // heading (the Husky bag's case); its wheels can: no lateral velocity (a
    // non-holonomic constraint) and the odometer's forward speed (5 % scale error)
    let wheels = |nhc: bool, odometer: bool| Wheels {
        c_vb: nalgebra::Matrix3::identity(),
        nhc: nhc.then(|| (0.1, Vector3::zeros())),
        odometer: odometer.then(|| (0.1, Vector3::zeros())),
        interval: 0.1,
        min_speed: 0.0,
    };
    for seed in 0..8u64 {
        let start = moving(seed, 1.0);
        let traj = Trajectory::new(start, &[Segment::straight(120.0)]).unwrap();
        let gnss = GnssSim {
            rate_hz: 1.0,
            pos_sigma: Vector3::repeat(1.0),
            vel_sigma: None,
            lever_arm: Vector3::new(0.3, 0.0, -1.0),
            windows: vec![],
        };
        let imu = ImuErrors { odometer: Some((0.05, 0.05)), ..mems_imu() };
        let d = simulate(&traj, 100.0, &imu, &gnss, seed);
        let (roll, pitch) = level_on_first(&d, 5.0);
        let v = d.truth[0].state.vel + Vector3::new(0.3, -0.3, 0.0);
        let truth = d.truth[0].state.att.euler().2;
        let bank = |w: Option<Wheels>| {
            let start = BankStart { wheels: w, ..moving_start(roll, pitch, v, gnss.lever_arm) };
            let b = heading_bank(&d.imu, &d.gnss, &start, 0.0).unwrap();
            (ins_gnss_core::heading::wrap(b.heading - truth) / DEG, b.std / DEG)
        };
        let (_, s) = bank(None);
        assert!(s > 20.0, "seed {seed}, no wheels: σ {s:.1}°");
        // the constraint alone cannot tell forward from backward: both stay
        let (_, s) = bank(Some(wheels(true, false)));
        assert!(s > 45.0, "seed {seed}, nhc alone: σ {s:.1}°");
        for (nhc, odometer, at_most) in [(false, true, 30.0), (true, true, 5.0)] {
            let (e, s) = bank(Some(wheels(nhc, odometer)));
            let what = format!("seed {seed}, nhc {nhc}, odometer {odometer}");
            eprintln!("{what}: error {e:.2}° at σ {s:.2}°");
            assert!(s < at_most, "{what}: σ {s:.1}°");
            assert!(e.abs() <= 3.0 * s, "{what}: error {e:.2}° at σ {s:.2}°");
        }
    }
}
