//! The static-start test against a vehicle at constant velocity from the first sample:
//! the IMU cannot tell it from rest, the fixes can (issue 49's slow rover, 0.42 m/s with
//! σ 5 m fixes, was "levelled over the static start (75 s)" and started with velocity 0
//! σ 0.02 m/s while it moved at 0.42 m/s).

use ins_gnss_core::align::detect_static;
use ins_gnss_core::earth::local_ned_to_geodetic;
use ins_gnss_core::{GeoPos, GnssEpoch, ImuSample};
use nalgebra::Vector3;

/// Reproducible standard normal draws (xorshift and Box–Muller).
struct Normal(u64);

impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn next(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * core::f64::consts::PI * v).cos()
    }
}

/// `seconds` of a level IMU at 100 Hz that neither turns nor accelerates (white noise of a
/// consumer MEMS), and 1 Hz fixes of σ `std` m moving north-east at `speed` m/s.
fn log(seed: u64, seconds: f64, speed: f64, std: f64) -> (Vec<ImuSample>, Vec<GnssEpoch>) {
    let mut n = Normal(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    let dt = 0.01;
    let imu = (1..=(seconds / dt) as usize)
        .map(|k| {
            let w = Vector3::new(n.next(), n.next(), n.next()) * 2e-3;
            let f = Vector3::new(n.next() * 0.02, n.next() * 0.02, -9.79 + n.next() * 0.02);
            ImuSample::from_increments(k as f64 * dt, dt, w * dt, f * dt)
        })
        .collect();
    let origin = (28.5f64.to_radians(), -16.3f64.to_radians(), 2300.0);
    let gnss = (0..=seconds as usize)
        .map(|k| {
            let t = k as f64;
            let along = speed * t / core::f64::consts::SQRT_2;
            let ned = Vector3::new(along + std * n.next(), along + std * n.next(), std * n.next());
            let (lat, lon, h) = local_ned_to_geodetic(origin, &ned);
            GnssEpoch::new(t, GeoPos::new(lat, lon, h), Vector3::new(std, std, std), None)
        })
        .collect();
    (imu, gnss)
}

#[test]
fn a_constant_velocity_from_the_first_sample_is_no_static_start() {
    for seed in 0..20 {
        // 0.42 m/s: 31 m in 75 s, within 3σ of the first fix for each fix alone
        let (imu, gnss) = log(seed, 150.0, 0.42, 5.0);
        let s = detect_static(&imu, &gnss, 1.0);
        assert_eq!(s.samples, 0, "seed {seed}: static {:?} while moving at 0.42 m/s", s.span);
    }
}

#[test]
fn a_vehicle_at_rest_with_coarse_fixes_stays_static() {
    for seed in 0..20 {
        let (imu, gnss) = log(100 + seed, 150.0, 0.0, 5.0);
        let s = detect_static(&imu, &gnss, 1.0);
        // every full window of the log
        assert!(s.duration() >= 149.0, "seed {seed}: static only {:?}", s.span);
    }
}

#[test]
fn a_vehicle_at_rest_with_rtk_fixes_that_wander_stays_static() {
    // fixes of declared σ 2 cm that wander 2 mm/s (0.3 m over the log: within the 3σ +
    // 0.3 m of the first fix, yet 50σ of their line's slope, as real RTK fixes near a wall
    // drift): the drift floor keeps the start static
    for seed in 0..20 {
        let (imu, gnss) = log(200 + seed, 150.0, 0.002, 0.02);
        let s = detect_static(&imu, &gnss, 1.0);
        assert!(s.duration() >= 149.0, "seed {seed}: static only {:?}", s.span);
    }
}

/// `seconds` of the same level IMU at rest, and fixes at `rate` Hz whose errors wander as
/// a single-point receiver's (a first-order Gauss–Markov error of σ `wander` m and
/// correlation time `tau` s per axis, over white noise of σ `white` m), declaring σ
/// `declared` m.
fn wandering_log(
    seed: u64,
    seconds: f64,
    rate: f64,
    (wander, tau, white): (f64, f64, f64),
    declared: f64,
) -> (Vec<ImuSample>, Vec<GnssEpoch>) {
    let (imu, _) = log(seed, seconds, 0.0, 0.0);
    let mut n = Normal(seed.wrapping_mul(0xd1b5_4a32_d192_ed03) | 1);
    let origin = (28.5f64.to_radians(), -16.3f64.to_radians(), 2300.0);
    let dt = 1.0 / rate;
    let decay = (-dt / tau).exp();
    let mut b = Vector3::new(n.next(), n.next(), n.next()) * wander;
    let gnss = (0..=(seconds * rate) as usize)
        .map(|k| {
            let t = k as f64 * dt;
            b = b * decay
                + Vector3::new(n.next(), n.next(), n.next())
                    * wander
                    * (1.0 - decay * decay).sqrt();
            let ned = b + Vector3::new(n.next(), n.next(), n.next()) * white;
            let (lat, lon, h) = local_ned_to_geodetic(origin, &ned);
            GnssEpoch::new(t, GeoPos::new(lat, lon, h), Vector3::repeat(declared), None)
        })
        .collect();
    (imu, gnss)
}

/// The everyday-GNSS issue's single-point fixes (1.5 m wander, τ 100 s, 0.3 m white, at 4
/// Hz as drive-0708's) under an IMU at rest for 35 s. Declared with their true σ, the
/// start is static on at least 19 of 20 seeds (before, each fix was held to 3σ of the
/// first and the fitted line to a white-noise slope: drive-0708's 33 s stand was "static
/// for 0.0 s" on 1 of 20 seeds of the corpus with the true σ, and on 20 of 20 with σ
/// 0.15 m). Declared 10× too small, on at least 19 of 20 too (measured: 20; it was 11
/// while the fixes' drift was tested at the end of every window, each test a new chance
/// to take the wander for a creep; now once, over the span the IMU shows still).
#[test]
fn a_vehicle_at_rest_with_single_point_fixes_that_wander_stays_static() {
    for (declared, least) in [(1.55, 19), (0.155, 19)] {
        let found = (0..20)
            .filter(|&seed| {
                let (imu, gnss) = wandering_log(300 + seed, 35.0, 4.0, (1.5, 100.0, 0.3), declared);
                detect_static(&imu, &gnss, 1.0).duration() >= 34.0
            })
            .count();
        assert!(found >= least, "declared σ {declared} m: static on {found} of 20 seeds");
    }
}

/// White fixes of σ 1.4 m declared as 0.14 m under an IMU at rest: static throughout on
/// every seed (the fixes jump beyond their declared σ; the IMU shows no motion).
#[test]
fn a_vehicle_at_rest_with_fixes_ten_times_noisier_than_declared_stays_static() {
    for seed in 0..20 {
        let (imu, gnss) = wandering_log(400 + seed, 35.0, 1.0, (0.0, 100.0, 1.4), 0.14);
        let s = detect_static(&imu, &gnss, 1.0);
        assert!(s.duration() >= 34.0, "seed {seed}: static only {:?}", s.span);
    }
}
