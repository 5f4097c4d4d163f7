//! The heading from a bank of hypotheses ([`heading_bank`]): after a static start, or
//! while moving when the in-motion fit cannot tell the heading.

use super::*;

/// The bank over the motion after a static start: levelled on it, its mean rate taken
/// off the gyros, standing at its end.
pub(super) fn static_bank(
    config: &Config,
    still: &StaticStart,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    bias_std: f64,
) -> Option<BankHeading> {
    let (roll, pitch) = level(&still.mean_f);
    let t_s = still.span.1;
    let imu = &imu[imu.partition_point(|s| s.t <= t_s + 1e-9)..];
    let end = t_s + config.align.max_time;
    let imu = &imu[..imu.partition_point(|s| s.t <= end + 1e-9)];
    // (the last fix of the static start: the bank's first position)
    let from = gnss.partition_point(|e| e.t <= t_s + 1e-9).saturating_sub(1);
    let gnss = &gnss[from..gnss.partition_point(|e| e.t <= end + 1e-9)];
    let start = BankStart {
        tilt: manifolds::So3::from_euler(roll, pitch, 0.0),
        gyro_bias: still.mean_w,
        vel: Vector3::zeros(),
        vel_std: 0.05,
        lever: Vector3::from(config.gnss.lever_arm),
        tilt_std: 0.5f64.to_radians(),
        gyro_bias_std: bias_std,
        ..imu_part(config)
    };
    let mut b = heading_bank(imu, gnss, &start, config.align.heading_std.to_radians())?;
    // a vertical gyro bias left after the static mean turns the track over the bank's
    // span: half of it on the heading the bank found for its start
    b.std = b.std.hypot(0.5 * bias_std * (b.t_end - t_s).max(0.0));
    Some(b)
}

/// The bank's start with what the configuration says of the IMU (the gyro's ARW, the
/// accelerometer's VRW); the rest to be set.
fn imu_part(config: &Config) -> BankStart {
    let n = &config.imu_noise;
    let largest = |v: [f64; 3]| v.iter().fold(0.0f64, |a, b| a.max(*b));
    BankStart {
        tilt: manifolds::So3::identity(),
        gyro_bias: Vector3::zeros(),
        vel: Vector3::zeros(),
        vel_std: 0.0,
        lever: Vector3::zeros(),
        arw: n.arw[2] * DEG_PER_SQRT_H,
        tilt_std: 0.0,
        gyro_bias_std: 0.0,
        vrw: largest(n.vrw) * M_S_PER_SQRT_H,
        use_velocity: config.gnss.use_velocity,
        wheels: wheels(config),
    }
}

/// The vehicle's wheels as the configuration declares them (`[vehicle.nhc]`,
/// `[vehicle.odometer]`), for the bank; `None` without either.
fn wheels(config: &Config) -> Option<Wheels> {
    let v = &config.vehicle;
    if v.nhc.is_none() && v.odometer.is_none() {
        return None;
    }
    let mounting = v.nhc.as_ref().map_or([0.0; 3], |n| n.mounting);
    Some(Wheels {
        c_vb: ins_gnss_core::vehicle::mounting_matrix(
            &Vector3::from(mounting).map(f64::to_radians),
        ),
        nhc: v.nhc.as_ref().map(|n| (n.std[0], Vector3::from(n.lever_arm))),
        odometer: v.odometer.as_ref().map(|o| (o.std, Vector3::from(o.lever_arm))),
        interval: v.nhc.as_ref().map_or(0.0, |n| n.interval),
        min_speed: v.nhc.as_ref().map_or(0.0, |n| n.min_speed),
    })
}

/// Seconds of fixes whose straight line gives a moving start's velocity.
const VELOCITY_SPAN: f64 = 5.0;

/// The 1σ (rad) of roll and pitch levelled while moving: a vehicle's acceleration over
/// the levelling second tilts the specific force by `a/g` (0.5 m/s²: 3°).
pub(super) const MOVING_TILT_STD: f64 = 3.0 * core::f64::consts::PI / 180.0;

/// A moving start found by the bank: its tilt, velocity and heading at `t0`.
#[derive(Clone, Copy, Debug)]
pub(super) struct MovingStart {
    pub(super) bank: BankHeading,
    pub(super) roll: f64,
    pub(super) pitch: f64,
    /// NED velocity at `t0` and its 1σ, m/s.
    pub(super) vel: Vector3<f64>,
    pub(super) vel_std: Vector3<f64>,
}

/// The bank from `t0` while moving: levelled on the first [`ACCEL_SPAN`] s of specific
/// force, the velocity of a straight line through the first [`VELOCITY_SPAN`] s of
/// fixes (at least three), no gyro bias known (`bias_std`, rad/s, drifts the heading).
pub(super) fn moving_bank(
    config: &Config,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
    bias_std: f64,
) -> Option<MovingStart> {
    let end = t0 + config.align.max_time;
    let imu = &imu[..imu.partition_point(|s| s.t <= end + 1e-9)];
    let gnss = &gnss[..gnss.partition_point(|e| e.t <= end + 1e-9)];
    let first = imu.first()?;
    let level_end = first.t - first.dt + ACCEL_SPAN;
    let span = &imu[..imu.partition_point(|s| s.t <= level_end + 1e-9).max(1)];
    let mean_f = span.iter().map(|s| s.specific_force()).sum::<Vector3<f64>>() / span.len() as f64;
    let (roll, pitch) = level(&mean_f);
    let (vel, vel_std) = line_velocity(gnss, t0)?;
    let start = BankStart {
        tilt: manifolds::So3::from_euler(roll, pitch, 0.0),
        gyro_bias: Vector3::zeros(),
        vel,
        vel_std: vel_std.x.max(vel_std.y),
        lever: Vector3::from(config.gnss.lever_arm),
        tilt_std: MOVING_TILT_STD,
        gyro_bias_std: bias_std,
        ..imu_part(config)
    };
    let mut bank = heading_bank(imu, gnss, &start, config.align.heading_std.to_radians())?;
    bank.std = bank.std.hypot(0.5 * bias_std * (bank.t_end - t0).max(0.0));
    Some(MovingStart { bank, roll, pitch, vel, vel_std })
}

/// The velocity at `t0` of a straight line through the fixes of the first
/// [`VELOCITY_SPAN`] s after it (at least three), and its 1σ: the fixes' σ over the
/// line's span, and 1 m/s for what the vehicle's acceleration over it changes.
fn line_velocity(gnss: &[GnssEpoch], t0: f64) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let after = &gnss[gnss.partition_point(|e| e.t <= t0 + 1e-9)..];
    let first = after.first()?;
    let n = after.partition_point(|e| e.t <= first.t + VELOCITY_SPAN + 1e-9).max(3);
    let fixes = after.get(..n)?;
    let k = fixes.len() as f64;
    let t_mean = fixes.iter().map(|e| e.t).sum::<f64>() / k;
    let stt: f64 = fixes.iter().map(|e| (e.t - t_mean).powi(2)).sum();
    if stt <= 0.0 {
        return None;
    }
    let origin = first.pos.tuple();
    let mut slope = Vector3::zeros();
    let mut var = Vector3::zeros();
    for e in fixes {
        slope += geodetic_to_local_ned(origin, e.pos.tuple()) * ((e.t - t_mean) / stt);
        var += e.pos_std.map(|s| s * s) / k;
    }
    let std = (var / stt).map(|v| v.sqrt().hypot(1.0));
    Some((slope, std))
}
