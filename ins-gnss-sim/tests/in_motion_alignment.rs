//! The in-motion alignment with no static start and the heading unknown: a car already
//! driving at 10 m/s, ten seeds, each with its own initial heading; the heading fitted
//! from the first 60 s of motion must be within 2° of the truth on every seed.

use ins_gnss_core::align::align_in_motion;
use ins_gnss_core::imu::DEG_PER_H;
use ins_gnss_core::GeoPos;
use ins_gnss_sim::scenarios::{gnss_1hz, mems_imu};
use ins_gnss_sim::simulate;
use ins_gnss_sim::{Segment, Start, Trajectory};
use nalgebra::Vector3;

fn wrap(a: f64) -> f64 {
    (a + 180.0).rem_euclid(360.0) - 180.0
}

#[test]
fn heading_from_motion_within_two_degrees_in_sixty_seconds_on_ten_seeds() {
    let deg = core::f64::consts::PI / 180.0;
    let lever = Vector3::new(0.5, 0.0, -1.0);
    let mut errors = Vec::new();
    let mut spans = Vec::new();
    for seed in 0..10u64 {
        let yaw0 = (seed as f64 * 37.0 + 11.0) % 360.0 - 180.0;
        let start = Start {
            t: 0.0,
            pos: GeoPos::from_degrees(45.0, 7.6, 240.0),
            speed: 10.0,
            yaw: yaw0 * deg,
            pitch: 0.0,
        };
        let segments = [
            Segment::straight(15.0),
            Segment::turn(20.0, 4.5 * deg),
            Segment::accelerate(5.0, 1.0),
            Segment::turn(10.0, -6.0 * deg),
            Segment::straight(15.0),
        ];
        let traj = Trajectory::new(start, &segments).unwrap();
        let data = simulate(&traj, 100.0, &mems_imu(), &gnss_1hz(lever), 100 + seed);
        // no static start, so no gyro bias known: the default prior of a MEMS gyro
        let fit = align_in_motion(
            &data.imu,
            &data.gnss,
            0.0,
            &Vector3::zeros(),
            1.0,
            &lever,
            60.0,
            1.0 * deg,
            100.0 * DEG_PER_H,
            0.0,
        )
        .expect("a fit within 60 s");
        let truth = data.truth[0].state.euler().2.to_degrees();
        let fitted = fit.att.euler().2.to_degrees();
        errors.push(wrap(fitted - truth));
        spans.push(fit.t_b - fit.t_a);
        assert!(fit.t_b - fit.t_a <= 60.0 + 1e-9);
        // the reported σ is honest: the error is within 3σ
        let err = wrap(fitted - truth).abs();
        assert!(
            err <= 3.0 * fit.att_std.z.to_degrees() + 0.05,
            "seed {seed}: {err}° vs σ {}°",
            fit.att_std.z.to_degrees()
        );
    }
    let max = errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    println!(
        "heading errors (deg): {errors:.3?}; max {max:.3}, RMS {rms:.3}; spans (s): {spans:.0?}"
    );
    assert!(max < 2.0, "heading errors {errors:.3?}");
}
