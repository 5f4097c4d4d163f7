//! Ready-made scenarios used by the tests, the benches and the demo.

use nalgebra::Vector3;

use ins_gnss_core::imu::{BiasModel, ImuNoise, DEG_PER_H, DEG_PER_SQRT_H, MGAL, M_S_PER_SQRT_H};
use ins_gnss_core::GeoPos;

use super::sensors::ImuErrors;
use super::trajectory::{Segment, Start};
use super::GnssSim;

/// A 600 s car drive: start from rest, accelerate, straights, left and right turns, a
/// climb and descent, a stop, and a final leg; speeds up to ≈ 20 m/s.
pub fn drive_600s() -> (Start, Vec<Segment>) {
    let deg = core::f64::consts::PI / 180.0;
    let start = Start {
        t: 0.0,
        pos: GeoPos::from_degrees(30.5, 114.3, 25.0),
        speed: 0.0,
        yaw: 20.0 * deg,
        pitch: 0.0,
    };
    let segs = vec![
        Segment::stop(20.0),
        Segment::accelerate(10.0, 1.5), // 15 m/s
        Segment::straight(40.0),
        Segment::turn(15.0, 6.0 * deg), // 90° right
        Segment::straight(30.0),
        Segment::accelerate(5.0, 1.0),  // 20 m/s
        Segment::climb(5.0, 0.6 * deg), // pitch up to 3°
        Segment::straight(40.0),
        Segment::climb(5.0, -0.6 * deg), // level
        Segment::turn(30.0, -3.0 * deg), // 90° left
        Segment::straight(50.0),
        Segment::decelerate(10.0, 2.0), // stop
        Segment::stop(30.0),
        Segment::accelerate(8.0, 1.5), // 12 m/s
        Segment::turn(20.0, 4.5 * deg),
        Segment::straight(40.0),
        Segment::turn(20.0, -9.0 * deg), // 180° left
        Segment::straight(60.0),
        Segment::accelerate(4.0, 2.0), // 20 m/s
        Segment::straight(60.0),
        Segment::turn(12.0, 7.5 * deg),
        Segment::straight(51.0),
        Segment::decelerate(10.0, 2.0), // stop
        Segment::stop(25.0),
    ];
    (start, segs)
}

/// A consumer-grade MEMS IMU: ARW 0.3°/√h, VRW 0.1 m/s/√h, gyro bias instability 10°/h,
/// accelerometer 100 mGal, Gauss–Markov τ = 1 h; turn-on biases 50°/h and 500 mGal,
/// scale factors 0 (the 15-state filter does not model them).
pub fn mems_imu() -> ImuErrors {
    ImuErrors {
        noise: ImuNoise {
            arw: Vector3::repeat(0.3 * DEG_PER_SQRT_H),
            vrw: Vector3::repeat(0.1 * M_S_PER_SQRT_H),
            gyro_bias: Vector3::repeat(10.0 * DEG_PER_H),
            accel_bias: Vector3::repeat(100.0 * MGAL),
            bias_model: BiasModel::GaussMarkov { tau: 3600.0 },
        },
        gyro_turn_on: Vector3::new(50.0, -40.0, 30.0) * DEG_PER_H,
        accel_turn_on: Vector3::new(500.0, -400.0, 300.0) * MGAL,
        gyro_scale: Vector3::zeros(),
        accel_scale: Vector3::zeros(),
        vibration: (0.0, 0.0),
        odometer: None,
        mounting: Vector3::zeros(),
    }
}

/// A 1 Hz receiver with position (1σ 1, 1, 2 m in N, E, D) and velocity (1σ 0.05 m/s),
/// the antenna at `lever_arm` in the body frame, no outages.
pub fn gnss_1hz(lever_arm: Vector3<f64>) -> GnssSim {
    GnssSim {
        rate_hz: 1.0,
        pos_sigma: Vector3::new(1.0, 1.0, 2.0),
        vel_sigma: Some(Vector3::repeat(0.05)),
        lever_arm,
        windows: vec![],
    }
}
