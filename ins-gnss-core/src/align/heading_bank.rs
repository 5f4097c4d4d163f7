//! A bank of heading hypotheses judged by their fixes' likelihood: a Gaussian-sum filter
//! for the heading at the start, as PX4's EKF2 estimates yaw without a magnetometer (its
//! EKF-GSF: a bank of small yaw filters driven by the tilt-corrected velocity increments,
//! weighted by their innovations' likelihood).
//!
//! The tilt is shared: the attitude with heading 0 is propagated once from `R₀` (levelled,
//! with the heading left at 0) along the gyros less their bias. Hypothesis `k` turns that
//! attitude's horizontal velocity increments by its own heading `ψ_k`, which is thus the
//! heading offset of the whole track: constant but for the vertical gyro bias's drift,
//! and the heading at the bank's start. Each hypothesis is a seven-state extended Kalman
//! filter (north and east position and velocity, `ψ_k`, and the shared attitude's error
//! about the body's x and y axes, which tilts gravity into the horizontal velocity
//! increments and turns with the body; a horizontal accelerometer bias looks the same)
//! updated by the fixes' horizontal position (lever arm included) and, when the fixes
//! carry one and [`BankStart::use_velocity`] allows, their horizontal velocity (a
//! receiver's Doppler velocity: a walker's heading to about ±10° per fix, where fixes good
//! to metres tell little for minutes); its weight is multiplied by its innovations'
//! Gaussian likelihood at every fix. The tilt as states, not as acceleration noise: with a
//! white 0.5 m/s² standing in for it (PX4's kind of figure), a rover at 0.42 m/s with 5 m
//! fixes kept its heading at ±60° after 120 s; what is left as noise is the
//! accelerometer's (its bias and random walk). Started with `N` headings spread over the
//! circle, the bank needs no motion assumption: standing, the likelihoods are equal and
//! the mixture's spread stays the circle's; moving (forwards, backwards, turning), the
//! hypotheses whose velocity increments point the wrong way lose.

use super::*;
use nalgebra::{Const, DimMin, Matrix1, Vector1};

/// Hypotheses in the bank: 16, 22.5° apart (each starts with half of that as its σ, well
/// inside the extended filter's linear range).
pub const BANK_SIZE: usize = 16;

/// The horizontal acceleration noise each hypothesis allows beside the accelerometer's
/// random walk, m/s² (white over a second): the Coriolis and transport terms, the lever
/// arm's dynamics and the fixes' latency, which the bank does not model (2Ω v is 0.003
/// m/s² at 20 m/s). With 0.5 m/s² (PX4's kind of figure, which stands for the tilt's
/// error there) a rover at 0.42 m/s with 5 m fixes kept its heading at ±90° after 300 s.
pub const BANK_ACCEL_NOISE: f64 = 0.02;

/// The time (s) over which the gyro bias's drift of the shared tilt is spread as a random
/// walk: `σ_b² · h · BANK_DRIFT_TIME` per step, so that the tilt's σ grows by about
/// `σ_b · t` over the first minute, as a constant bias's drift does.
pub const BANK_DRIFT_TIME: f64 = 60.0;

/// Where the bank starts and what it knows of the IMU.
#[derive(Clone, Copy, Debug)]
pub struct BankStart {
    /// The attitude `R_nb` at the start with its heading at 0 (roll and pitch only).
    pub tilt: So3,
    /// The gyro bias (rad/s) taken off the rates (a static start's mean rate).
    pub gyro_bias: Vector3<f64>,
    /// NED velocity at the start, m/s.
    pub vel: Vector3<f64>,
    /// 1σ of its horizontal components, m/s.
    pub vel_std: f64,
    /// The antenna's lever arm in the body frame, m.
    pub lever: Vector3<f64>,
    /// The gyro's angle random walk, rad/√s: the heading's drift from sample to sample.
    pub arw: f64,
    /// 1σ of the shared tilt's error (roll and pitch) at the start, rad.
    pub tilt_std: f64,
    /// The gyro bias's 1σ (rad/s): the tilt's drift.
    pub gyro_bias_std: f64,
    /// Velocity random walk, m/s/√s.
    pub vrw: f64,
    /// Whether the fixes' velocities (a receiver's Doppler velocity) update the members
    /// beside their positions.
    pub use_velocity: bool,
    /// What the configuration says of the vehicle's wheels (a non-holonomic constraint, an
    /// odometer): the members' velocity in the vehicle frame judged by them too.
    pub wheels: Option<Wheels>,
}

/// A wheeled vehicle's constraints as the bank takes them: the velocity in the vehicle
/// frame at the constraint point is forward (no lateral component) and, with an odometer,
/// the wheels' speed. A member whose heading puts the track's velocity sideways or
/// backward in its body loses, so a vehicle moving straight at constant speed — which
/// shows its heading to the specific force only through its turns — shows it through its
/// course.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wheels {
    /// `C_vb`, body → vehicle frame (the mounting).
    pub c_vb: Matrix3<f64>,
    /// The lateral velocity's 1σ (m/s) when a non-holonomic constraint is declared, and its
    /// point from the IMU (body frame, m).
    pub nhc: Option<(f64, Vector3<f64>)>,
    /// The odometer's speed 1σ (m/s) and its wheel point from the IMU (body frame, m), when
    /// the samples carry an odometer. Its scale is not calibrated at the start: the bank
    /// takes [`ODOMETER_SCALE_STD`] of the speed beside the 1σ, so that it tells forward
    /// from backward and sideways, not a few degrees.
    pub odometer: Option<(f64, Vector3<f64>)>,
    /// Time between the bank's wheel updates, s (at least [`WHEEL_INTERVAL`]).
    pub interval: f64,
    /// The constraint is applied only above this speed (the members' own), m/s.
    pub min_speed: f64,
}

/// The odometer's scale uncertainty the bank allows (a fraction of the speed): before the
/// run calibrates it, a wheel's radius and slip are known to tens of percent.
pub const ODOMETER_SCALE_STD: f64 = 0.3;

/// The shortest time (s) between the bank's wheel updates: the constraints' errors (a
/// mounting angle, a skid-steer's slip in a turn) persist for seconds, and updates
/// closer than that would count one error many times.
pub const WHEEL_INTERVAL: f64 = 1.0;

/// What the bank concluded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BankHeading {
    /// The heading at the bank's start (the mixture's circular mean), rad.
    pub heading: f64,
    /// The mixture's 1σ: its members' own spread and their spread about the mean, rad
    /// (about 104° while nothing is known, a uniform circle's).
    pub std: f64,
    /// The largest weight.
    pub weight: f64,
    /// Fixes used.
    pub fixes: usize,
    /// The last fix used, s.
    pub t_end: f64,
}

#[derive(Clone, Copy, Debug)]
struct Member {
    /// North, east position (m, from the first fix), velocity (m/s), heading (rad), the
    /// shared attitude's error about the body's x and y axes (rad).
    x: SVector<f64, 7>,
    p: SMatrix<f64, 7, 7>,
    log_w: f64,
}

/// Run the bank over `imu` and `gnss` (the samples and fixes after the start, in time
/// order) from `start`, until the mixture's σ falls below `target` (rad) or the data end.
/// `None` without a fix.
pub fn heading_bank(
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    start: &BankStart,
    target: f64,
) -> Option<BankHeading> {
    let first = gnss.first()?;
    let origin = first.pos.tuple();
    let mut members = members_at(first, start);
    let t_first = imu.first().map_or(first.t, |s| s.t - s.dt);
    let mut att = start.tilt;
    let mut t = t_first;
    let mut g = gnss.partition_point(|e| e.t < t_first - 1e-9);
    let mut fixes = 0usize;
    let mut result = summarise(&members, 0, first.t);
    let mut last_wheels = f64::NEG_INFINITY;
    let shown = shown_floor(gnss, start);
    for s in imu {
        // fixes inside this sample's interval: predict to each, update
        while g < gnss.len() && gnss[g].t <= s.t + 1e-9 {
            let e = &gnss[g];
            advance(&mut members, &mut att, &mut t, s, e.t, start);
            let d = geodetic_to_local_ned(origin, e.pos.tuple());
            let lever = att.rotate(&start.lever).xy();
            // the velocity, with the antenna's velocity about the body's centre (the rate
            // of the last sample, heading-0 frame)
            let vel = e.vel.filter(|_| start.use_velocity).map(|(v, std)| {
                let omega = (s.dtheta / s.dt.max(1e-9)) - start.gyro_bias;
                (v.xy(), att.rotate(&omega.cross(&start.lever)).xy(), std.xy())
            });
            for m in members.iter_mut() {
                let std = e.pos_std.xy().map(|s| s.max(shown));
                update(m, POSITION, &d.xy(), &lever, &std, POSITION_FLOOR);
                if let Some((v, lever_rate, std)) = &vel {
                    update(m, VELOCITY, v, lever_rate, std, BANK_VELOCITY_FLOOR);
                }
            }
            fixes += 1;
            result = summarise(&members, fixes, e.t);
            g += 1;
            if fixes >= 3 && result.std < target {
                return Some(result);
            }
        }
        advance(&mut members, &mut att, &mut t, s, s.t, start);
        if let Some(w) = &start.wheels
            && fixes > 0
            && s.t - last_wheels >= w.interval.max(WHEEL_INTERVAL) - 1e-9
        {
            last_wheels = s.t;
            let omega = (s.dtheta / s.dt.max(1e-9)) - start.gyro_bias;
            for m in members.iter_mut() {
                wheel_update(m, &att, w, &omega, s.odometer);
            }
        }
    }
    Some(result)
}

/// The bank's members at its first fix: headings spread over the circle, each with half
/// the spacing as its σ, the position of the body's centre from the antenna's.
fn members_at(first: &GnssEpoch, start: &BankStart) -> Vec<Member> {
    let spacing = 2.0 * core::f64::consts::PI / BANK_SIZE as f64;
    (0..BANK_SIZE)
        .map(|k| {
            let psi = crate::heading::wrap(k as f64 * spacing);
            let lever = yaw_turn(psi, &start.tilt.rotate(&start.lever).xy());
            let mut x = SVector::<f64, 7>::zeros();
            x[0] = -lever.x;
            x[1] = -lever.y;
            x[2] = start.vel.x;
            x[3] = start.vel.y;
            x[4] = psi;
            let s = first.pos_std;
            let p = SMatrix::<f64, 7, 7>::from_diagonal(&SVector::<f64, 7>::from([
                s.x * s.x,
                s.y * s.y,
                start.vel_std.powi(2),
                start.vel_std.powi(2),
                (0.5 * spacing).powi(2),
                start.tilt_std.powi(2),
                start.tilt_std.powi(2),
            ]));
            Member { x, p, log_w: 0.0 }
        })
        .collect()
}

/// With the wheels, the heading comes from the direction of the members' velocity, which
/// fixes declared more precise than they are would make confident and wrong: their σ (per
/// axis) is then at least the noise they show (a declared σ is a prior). 0 without wheels.
fn shown_floor(gnss: &[GnssEpoch], start: &BankStart) -> f64 {
    if start.wheels.is_none() {
        return 0.0;
    }
    let refs = super::checks::fixes_a_second_apart(gnss, f64::NEG_INFINITY, f64::INFINITY);
    let s = super::checks::shown_noise(&refs) / core::f64::consts::SQRT_2;
    if s.is_finite() {
        s
    } else {
        0.0
    }
}

/// A member's update by the vehicle's wheels: the lateral velocity at the constraint
/// point is zero (with a non-holonomic constraint), the forward one the odometer's
/// `speed` (when there is one). The vertical velocity is taken as zero (a ground
/// vehicle); the tilt's error is left out of the Jacobian (its effect is second order).
fn wheel_update(m: &mut Member, att: &So3, w: &Wheels, omega: &Vector3<f64>, speed: Option<f64>) {
    let v = Vector2::new(m.x[2], m.x[3]);
    if v.norm() < w.min_speed {
        return;
    }
    // the vehicle-frame velocity: `C_vb R₀ᵀ Rz(ψ)ᵀ v` plus the point's turn about the IMU
    let a = w.c_vb * att.matrix().transpose();
    // (rows: forward with the odometer, lateral with the constraint)
    let rows = [
        speed.zip(w.odometer).map(|(z, (std, arm))| {
            (0, z, std.hypot(ODOMETER_SCALE_STD * z), w.c_vb * omega.cross(&arm))
        }),
        w.nhc.map(|(std, arm)| (1, 0.0, std, w.c_vb * omega.cross(&arm))),
    ];
    for (i, z, std, turn) in rows.into_iter().flatten() {
        let v = Vector2::new(m.x[2], m.x[3]);
        let (sn, cs) = m.x[4].sin_cos();
        let u = Vector2::new(cs * v.x + sn * v.y, -sn * v.x + cs * v.y);
        let pred = a[(i, 0)] * u.x + a[(i, 1)] * u.y + turn[i];
        let mut hm = SMatrix::<f64, 1, 7>::zeros();
        hm[(0, 2)] = a[(i, 0)] * cs - a[(i, 1)] * sn;
        hm[(0, 3)] = a[(i, 0)] * sn + a[(i, 1)] * cs;
        hm[(0, 4)] = a[(i, 0)] * u.y - a[(i, 1)] * u.x;
        correct(m, &Vector1::new(z - pred), &hm, &Matrix1::new(std * std));
    }
}

/// Every member and the shared attitude `att` from `t` to `to` (inside sample `s`'s
/// interval, its increments taken in proportion); nothing when `to` is not later.
fn advance(
    members: &mut [Member],
    att: &mut So3,
    t: &mut f64,
    s: &ImuSample,
    to: f64,
    start: &BankStart,
) {
    let h = to - *t;
    if h > 0.0 {
        let part = h / s.dt;
        predict(members, att, &(s.dvel * part), h, start);
        *att = att.between_exp(&Vector3::zeros(), &((s.dtheta * part) - start.gyro_bias * h));
        *t = to;
    }
}

/// `v` (north, east) turned by the heading `psi`.
fn yaw_turn(psi: f64, v: &Vector2<f64>) -> Vector2<f64> {
    let (s, c) = psi.sin_cos();
    Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

/// ∂(yaw_turn(ψ, v))/∂ψ.
fn yaw_turn_d(psi: f64, v: &Vector2<f64>) -> Vector2<f64> {
    let (s, c) = psi.sin_cos();
    Vector2::new(-s * v.x - c * v.y, c * v.x - s * v.y)
}

/// Every member over `h` seconds with the body's velocity increment `dv` (heading-0
/// attitude `att` at the interval's start).
fn predict(members: &mut [Member], att: &So3, dv: &Vector3<f64>, h: f64, start: &BankStart) {
    let r0 = att.matrix();
    let dv0 = (r0 * dv).xy();
    // the attitude error ε (body x, y) moves the increment by `−R₀ [Δv_b]× ε`: gravity's
    // (−g h on the body's z) tilted into the horizontal, turning with the body
    let m_eps = (-(r0 * dv.cross_matrix())).fixed_view::<2, 2>(0, 0).into_owned();
    // the acceleration's noise (m²/s² per step), the heading's (the ARW; a constant
    // vertical bias's drift is the caller's to add), the tilt's (ARW and the bias's drift)
    let q_v = (BANK_ACCEL_NOISE * BANK_ACCEL_NOISE + start.vrw * start.vrw) * h;
    let q_psi = start.arw * start.arw * h;
    let q_tilt = start.arw * start.arw * h + start.gyro_bias_std.powi(2) * h * BANK_DRIFT_TIME;
    for m in members.iter_mut() {
        let psi = m.x[4];
        let eps = Vector2::new(m.x[5], m.x[6]);
        let inc = dv0 + m_eps * eps;
        let dvn = yaw_turn(psi, &inc);
        let d = yaw_turn_d(psi, &inc);
        // ∂Δv/∂ε: the rotation by ψ of `m_eps`
        let (sn, cs) = psi.sin_cos();
        let rz = Matrix2::new(cs, -sn, sn, cs);
        let de = rz * m_eps;
        m.x[0] += m.x[2] * h + 0.5 * dvn.x * h;
        m.x[1] += m.x[3] * h + 0.5 * dvn.y * h;
        m.x[2] += dvn.x;
        m.x[3] += dvn.y;
        let mut f = SMatrix::<f64, 7, 7>::identity();
        f[(0, 2)] = h;
        f[(1, 3)] = h;
        f[(0, 4)] = 0.5 * d.x * h;
        f[(1, 4)] = 0.5 * d.y * h;
        f[(2, 4)] = d.x;
        f[(3, 4)] = d.y;
        for i in 0..2 {
            for j in 0..2 {
                f[(i, 5 + j)] = 0.5 * de[(i, j)] * h;
                f[(2 + i, 5 + j)] = de[(i, j)];
            }
        }
        let mut p = f * m.p * f.transpose();
        // (velocity noise as a random walk over the step, with the position it moves)
        let qv = q_v / h.max(1e-9);
        p[(0, 0)] += qv * h * h * h / 3.0;
        p[(1, 1)] += qv * h * h * h / 3.0;
        p[(0, 2)] += qv * h * h / 2.0;
        p[(2, 0)] += qv * h * h / 2.0;
        p[(1, 3)] += qv * h * h / 2.0;
        p[(3, 1)] += qv * h * h / 2.0;
        p[(2, 2)] += q_v;
        p[(3, 3)] += q_v;
        p[(4, 4)] += q_psi;
        p[(5, 5)] += q_tilt;
        p[(6, 6)] += q_tilt;
        m.p = p;
    }
}

/// Where a member's north and east position and velocity start in its state.
const POSITION: usize = 0;
/// See [`POSITION`].
const VELOCITY: usize = 2;

/// The smallest position σ (m) a fix is taken with.
const POSITION_FLOOR: f64 = 1e-3;

/// One member's update by a measurement `z` (north, east; σ `std`, at least `floor`) of
/// its position ([`POSITION`], m from the first fix) or velocity ([`VELOCITY`], m/s) at
/// the antenna, which is `arm` from the body's centre in the heading-0 frame (the lever
/// arm, or its velocity about the centre).
fn update(
    m: &mut Member,
    at: usize,
    z: &Vector2<f64>,
    arm: &Vector2<f64>,
    std: &Vector2<f64>,
    floor: f64,
) {
    let psi = m.x[4];
    let pred = m.x.fixed_rows::<2>(at) + yaw_turn(psi, arm);
    let mut hm = SMatrix::<f64, 2, 7>::zeros();
    hm[(0, at)] = 1.0;
    hm[(1, at + 1)] = 1.0;
    let dl = yaw_turn_d(psi, arm);
    hm[(0, 4)] = dl.x;
    hm[(1, 4)] = dl.y;
    let r = Matrix2::from_diagonal(&std.map(|s| s.max(floor).powi(2)));
    correct(m, &(z - pred), &hm, &r);
}

/// A member's Kalman correction by the innovation `nu` of an `R`-row measurement (`hm`,
/// noise `r`), its weight multiplied by the innovation's likelihood.
fn correct<const R: usize>(
    m: &mut Member,
    nu: &SVector<f64, R>,
    hm: &SMatrix<f64, R, 7>,
    r: &SMatrix<f64, R, R>,
) where
    Const<R>: DimMin<Const<R>, Output = Const<R>>,
{
    let s = hm * m.p * hm.transpose() + r;
    let Some(si) = s.try_inverse() else { return };
    let k = m.p * hm.transpose() * si;
    m.x += k * nu;
    m.x[4] = crate::heading::wrap(m.x[4]);
    // Joseph form: P stays symmetric positive definite
    let ikh = SMatrix::<f64, 7, 7>::identity() - k * hm;
    m.p = ikh * m.p * ikh.transpose() + k * r * k.transpose();
    let quad = (nu.transpose() * si * nu)[(0, 0)];
    m.log_w += -0.5 * (quad + s.determinant().max(1e-300).ln());
}

/// The smallest velocity σ (m/s) a fix's velocity is taken with: what the bank does not
/// model between the receiver's velocity and its own (the fixes' latency, the lever arm's
/// dynamics within a sample).
pub const BANK_VELOCITY_FLOOR: f64 = 0.05;

/// The mixture: weights normalised (in place), circular mean and spread.
fn summarise(members: &[Member], fixes: usize, t_end: f64) -> BankHeading {
    let top = members.iter().map(|m| m.log_w).fold(f64::NEG_INFINITY, f64::max);
    let w: Vec<f64> = members.iter().map(|m| (m.log_w - top).exp()).collect();
    let total: f64 = w.iter().sum();
    let (mut s, mut c) = (0.0, 0.0);
    for (m, w) in members.iter().zip(&w) {
        s += w / total * m.x[4].sin();
        c += w / total * m.x[4].cos();
    }
    let mean = s.atan2(c);
    let var: f64 = members
        .iter()
        .zip(&w)
        .map(|(m, w)| w / total * (m.p[(4, 4)] + crate::heading::wrap(m.x[4] - mean).powi(2)))
        .sum();
    let weight = w.iter().copied().fold(0.0, f64::max) / total;
    BankHeading { heading: mean, std: var.sqrt(), weight, fixes, t_end }
}
