//! The in-motion alignment (position-integration form) and its robust fit.

use super::*;

mod robust;
mod solve;

pub use robust::*;
use solve::*;

/// The result of [`align_in_motion`]: the state at `t_a` and what the fit says of the
/// data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionFit {
    /// Start of the fit, s.
    pub t_a: f64,
    /// Last fix used, s.
    pub t_b: f64,
    /// Fixes used.
    pub fixes: usize,
    /// `R_nb` at `t_a`.
    pub att: So3,
    /// IMU position at `t_a`.
    pub pos: GeoPos,
    /// NED velocity at `t_a`, m/s.
    pub vel: Vector3<f64>,
    /// 1σ of the attitude about N, E, D (the last is the heading), rad.
    pub att_std: Vector3<f64>,
    /// 1σ of the position (N, E, D), m.
    pub pos_std: Vector3<f64>,
    /// 1σ of the velocity, m/s.
    pub vel_std: Vector3<f64>,
    /// The gyro bias with its x and y axes fitted with the attitude (rad/s, body frame;
    /// the argument `gyro_bias` plus the fitted change; z as given): a horizontal bias
    /// tilts the integrated specific force against gravity, so it shows within seconds
    /// of motion.
    pub gyro_bias: Vector3<f64>,
    /// 1σ of [`gyro_bias`](Self::gyro_bias), rad/s (z: the prior's; 0 when not fitted).
    pub gyro_bias_std: Vector3<f64>,
    /// How much better a mirror image of the IMU's motion fits than the best rotation:
    /// the drop of χ² in units of the fit's χ² per degree of freedom (positive: a
    /// left-handed sensor frame; 0 when the motion cannot tell, e.g. a straight line).
    pub mirror: f64,
    /// RMS of the fixes' residuals in units of their σ (about 1 when the model fits),
    /// over the fixes used.
    pub residual: f64,
    /// How many times fewer independent fixes the fit had than it counts, from its
    /// residuals' lag-one autocorrelation `ρ`: `(1 + ρ)/(1 − ρ)` (1 for white residuals).
    /// [`align_in_motion`] scales the σ of the fit it returns by its square root (not
    /// those of the fits it compares on its way: the span is chosen as before).
    pub persistence: f64,
    /// Fixes of the span left out as gross errors (see [`align_in_motion`]); `fixes`
    /// counts the others.
    pub rejected: usize,
    /// The distance along the fitted trajectory from the first fix used to the last, m
    /// (the fixes' noise does not add to it, as it would to the distance between the
    /// fixes themselves).
    pub path: f64,
    /// The first fix the fit used: its time after `t_a` (s), its position and 1σ (N, E,
    /// D, m) as read. The position at `t_a` is better taken from it (see
    /// [`MotionFit::position_from_first_fix`]) than from the fit's `p₀`, whose vertical
    /// takes up an accelerometer bias over the span (`½ b τ²`: 41 m after 64 s at 0.02
    /// m/s², seen on drive-0708).
    pub first_fix: (f64, GeoPos, Vector3<f64>),
}

impl MotionFit {
    /// The IMU's position at `t_a` from the first fix the fit used: the fix less the
    /// lever arm `lever_arm` (body frame, m) turned by the fitted attitude, moved back by
    /// the fitted velocity over the fix's time after `t_a`; and its 1σ (N, E, D, m): the
    /// fix's, the velocity's over that time, and half an acceleration of 1 m/s² over it
    /// (the fit's attitude error on the lever arm is below a centimetre for lever arms of
    /// a metre).
    pub fn position_from_first_fix(&self, lever_arm: &Vector3<f64>) -> (GeoPos, Vector3<f64>) {
        let (tau, pos, std) = self.first_fix;
        let offset = self.att.rotate(lever_arm) + self.vel * tau;
        let (lat, lon, h) = local_ned_to_geodetic(pos.tuple(), &-offset);
        let sigma = std.zip_map(&self.vel_std, |p, v| p.hypot(v * tau).hypot(0.5 * tau * tau));
        (GeoPos::new(lat, lon, h), sigma)
    }
}

/// One fix of the fit: `y = p₀ + v₀ τ + C₀ (a + J δb)`, with `J = ∂a/∂b_g`.
#[derive(Clone, Copy, Debug)]
struct Fix {
    tau: f64,
    y: Vector3<f64>,
    a: Vector3<f64>,
    jac: Matrix3<f64>,
    /// `∫∫ ΔC`: how an accelerometer bias `b_a` (body frame) moves `a` (by `−β b_a`).
    beta: Matrix3<f64>,
    w: f64,
    /// The fix as read: position and its 1σ (N, E, D), m.
    pos: GeoPos,
    pos_std: Vector3<f64>,
}

/// 1σ floor of a fix in the fit, m: what the model neglects (the Earth's rotation,
/// vibration, the gyro errors over the span), which an RTK fix's centimetre σ would hide.
const MODEL_ERROR: f64 = 0.2;

/// Metres of motion before the fit may stop — along the fitted path, or away from the
/// first fix: a heading fitted on the first metres of motion rests on too few of them to
/// be trusted whatever its formal σ. (Until session 14 only the distance from the first
/// fix counted, and a walk that turns inside a yard never started.)
const MIN_TRAVEL: f64 = 30.0;

/// In-motion alignment from the IMU samples after `t_a` and the GNSS fixes between `t_a`
/// and `t_a + max_time` (see the module text). `gyro_bias` (rad/s) is removed from the
/// rates and the gyro increments are multiplied by `gyro_scale` (1 normally; the unit
/// check tries others); `lever_arm` is the antenna's (body frame, m). The fit stops at the
/// first fix after which the heading's σ is below `heading_std` (rad) with at least 30 m
/// travelled, or at `max_time`. The heading's σ counts the fit's own and the drift of a
/// gyro bias of 1σ `bias_std` (rad/s) over the span; the fit with the smallest is kept
/// (a long span averages the fixes' noise but lets an unknown bias drift). An
/// accelerometer bias of 1σ `accel_bias_std` (m/s², per axis; 0: none) is not fitted but
/// considered: the σ of every part of the fit counts what such a bias moves it by (its
/// double integral over a minute is tens of metres, which `p₀`, `v₀` and the rotation take
/// up: a fit over 72 s of a car whose accelerometers were 0.015 m/s² off put its start
/// velocity 0.75 m/s off at a σ of 0.16). `None` when
/// fewer than 8 fixes fall in the span or the motion cannot tell the attitude.
///
/// Gross errors among the fixes do not move the fit: when the least-squares fit misfits
/// (RMS beyond [`MISFIT`], or a fix beyond [`GROSS`] times the fixes' robust scale), the
/// fit is found again by consensus over samples of six fixes spread over the span, and
/// the fixes it does not explain are left out ([`MotionFit::rejected`]).
#[allow(clippy::too_many_arguments)]
pub fn align_in_motion(
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t_a: f64,
    gyro_bias: &Vector3<f64>,
    gyro_scale: f64,
    lever_arm: &Vector3<f64>,
    max_time: f64,
    heading_std: f64,
    bias_std: f64,
    accel_bias_std: f64,
) -> Option<MotionFit> {
    let priors = Priors { gyro_bias: bias_std, accel_bias: accel_bias_std };
    let min_fixes = 8;
    let mut best: Option<MotionFit> = None;
    let mut solve_at = 0;
    let input = Input { imu, gnss, t_a, gyro_bias, gyro_scale, lever_arm, t_b: t_a + max_time };
    // (what was added is in `best` already)
    let _ = accumulate(&input, |sums, fixes, reference, t, travelled| {
        if sums.n < min_fixes || sums.n < solve_at {
            return true;
        }
        // (at every eighth more fixes: a solve costs O(n), so the search O(n log n))
        solve_at = sums.n + (sums.n / 8).max(2);
        if let Some(mut fit) = robust_solve(fixes, reference, t_a, t, gyro_bias, priors) {
            // the z bias is not fitted (see `solve`): its drift counts on the heading,
            // which is seen only through the velocity changes (the tilt against gravity
            // at every fix)
            let drift = bias_std * (fit.t_b - fit.t_a) * 0.5;
            fit.att_std.z = fit.att_std.z.hypot(drift);
            // metres of motion: along the fitted path (a walk in a yard turns within
            // a few metres of its start), or away from the first fix
            let moved = travelled >= MIN_TRAVEL || fit.path >= MIN_TRAVEL;
            if moved && best.as_ref().is_none_or(|b| fit.att_std.z <= b.att_std.z) {
                best = Some(fit);
            }
            // good enough, or long past the best span (the drift only grows)
            if let Some(b) = &best
                && (b.att_std.z < heading_std || t - t_a > 2.0 * (b.t_b - t_a) + 10.0)
            {
                return false;
            }
        }
        true
    });
    // the fixes' persistence, on the fit returned: a single point's errors wander over
    // minutes, and a fit that took them for white had its velocity and heading's σ
    // several times too small (a walk from the first sample on such fixes: 2 of 10
    // headings within 3σ; with it, 10 of 10)
    best.map(|mut b| {
        let k = b.persistence.sqrt();
        b.att_std *= k;
        b.pos_std *= k;
        b.vel_std *= k;
        b
    })
}

/// The position-integration fit over every fix in `(t_a, t_b]` at once (the arguments
/// as for [`align_in_motion`], no early stop and no drift bound): what the whole span
/// says of the axes, where [`align_in_motion`] may have stopped before the first turn.
pub fn fit_span(
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t_a: f64,
    gyro_bias: &Vector3<f64>,
    lever_arm: &Vector3<f64>,
    t_b: f64,
) -> Option<MotionFit> {
    let input = Input { imu, gnss, t_a, gyro_bias, gyro_scale: 1.0, lever_arm, t_b };
    let last = accumulate(&input, |_, _, _, _, _| true)?;
    // (the bias as given: a fit over a long span would take a wrong axis's error for
    // one)
    // (least squares, gross errors and all: the mirror test it serves is decisive only
    // on a fit that explains its fixes, and gross errors inflate its χ² so that it says
    // nothing; a consensus fit of a mirror image explains a part of the fixes as well)
    (last.sums.n >= 8)
        .then(|| {
            let none = Priors::default();
            solve(&last.sums, &last.fixes, last.reference, t_a, last.t, gyro_bias, none)
                .map(|(f, _)| f)
        })
        .flatten()
}

impl MotionFit {
    fn with_params(self, p: Params) -> (Self, Params) {
        (self, p)
    }
}
