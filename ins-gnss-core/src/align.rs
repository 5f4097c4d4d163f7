//! Initialisation from the data: a static start found in the IMU and GNSS streams, the
//! noise and gyro biases measured on it, and an in-motion alignment that finds the
//! attitude (heading included), position and velocity at the start from the first
//! seconds of IMU and GNSS data, whatever the initial heading.
//!
//! # In-motion alignment (position-integration form)
//!
//! Over a short span `τ = t − t_a` the navigation frame hardly turns, so the IMU position
//! obeys `p(τ) = p₀ + v₀ τ + ½ g τ² e_D + C₀ α(τ)`, with `C₀ = R_nb(t_a)` and
//! `α(τ) = ∫₀^τ ∫₀^s ΔC(r) f_b(r) dr ds` computed from the IMU alone (`ΔC = R_b(t_a)b(r)`
//! integrated from the gyros). The GNSS antenna adds `C₀ ΔC(τ) l_b`. Every fix is then
//! three equations **linear** in `p₀`, `v₀` and the nine entries of `C₀`: a weighted least
//! squares gives them with their covariance, and the nearest rotation to the fitted `C₀`
//! is the attitude at `t_a` — roll and pitch from gravity (`½ g τ²` dominates), heading
//! from the velocity changes, from any heading, with no forward-motion assumption (the
//! optimisation-based alignment of Wu & Pan, IEEE TAES 49(2), 2013, in its
//! position form; Earth rotation over the span is neglected: < 0.5 m over 20 s at
//! 16 m/s). The unconstrained fit also tests the data: a left-handed sensor frame fits
//! best with a reflection (`det C₀ < 0`), a wrong accelerometer unit with a `C₀` whose
//! singular values are far from 1, a wrong gyro unit with residuals that another gyro
//! scale removes.

use manifolds::So3;
use nalgebra::{Matrix2, Matrix3, SMatrix, Vector3};

use crate::earth::{earth_rate_ned, geodetic_to_local_ned, local_ned_to_geodetic, normal_gravity};
use crate::gnss::GnssEpoch;
use crate::imu::ImuSample;
use crate::position::GeoPos;

/// What the start of a log shows while it stands still: the span, and the mean and
/// per-axis standard deviation of the rates and specific forces over it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StaticStart {
    /// Samples from the first one that belong to the static span.
    pub samples: usize,
    /// First and last time of the span, s (start of the first interval, end of the last).
    pub span: (f64, f64),
    /// Mean angular rate, rad/s.
    pub mean_w: Vector3<f64>,
    /// Mean specific force, m/s².
    pub mean_f: Vector3<f64>,
    /// Per-axis standard deviation of the rates, rad/s.
    pub std_w: Vector3<f64>,
    /// Per-axis standard deviation of the specific force, m/s².
    pub std_f: Vector3<f64>,
    /// Mean sample interval, s.
    pub dt: f64,
}

impl StaticStart {
    /// Length of the static span, s.
    pub fn duration(&self) -> f64 {
        self.span.1 - self.span.0
    }

    /// Angular random walk per axis, rad/√s: the rates' σ times √dt (white noise
    /// sampled at `1/dt`; vibration at rest counts, which is the point).
    pub fn arw(&self) -> Vector3<f64> {
        self.std_w * self.dt.sqrt()
    }

    /// Velocity random walk per axis, m/s/√s.
    pub fn vrw(&self) -> Vector3<f64> {
        self.std_f * self.dt.sqrt()
    }

    /// 1σ of the mean rate over the span, per axis, rad/s (white noise only).
    pub fn mean_w_std(&self) -> Vector3<f64> {
        self.std_w / (self.samples.max(1) as f64).sqrt()
    }
}

/// Window statistics for [`detect_static`].
#[derive(Clone, Copy, Debug)]
struct Window {
    end: usize,
    t1: f64,
    n: usize,
    sum_w: Vector3<f64>,
    sum_f: Vector3<f64>,
    sq_w: Vector3<f64>,
    sq_f: Vector3<f64>,
}

impl Window {
    fn mean_w(&self) -> Vector3<f64> {
        self.sum_w / self.n as f64
    }
    fn mean_f(&self) -> Vector3<f64> {
        self.sum_f / self.n as f64
    }
    fn std(sum: &Vector3<f64>, sq: &Vector3<f64>, n: usize) -> Vector3<f64> {
        let n = n as f64;
        (sq / n - (sum / n).component_mul(&(sum / n))).map(|v| v.max(0.0).sqrt())
    }
    fn std_w(&self) -> Vector3<f64> {
        Self::std(&self.sum_w, &self.sq_w, self.n)
    }
    fn std_f(&self) -> Vector3<f64> {
        Self::std(&self.sum_f, &self.sq_f, self.n)
    }
}

/// The static span at the start of `imu`: consecutive windows of `window` seconds that
/// look like the first one (rates and specific force with the same mean and spread, to
/// within what the first window's noise explains plus 0.1 deg/s and 0.05 m/s²) while the
/// specific force stays near gravity (|f| within 0.5 m/s² of normal gravity at the first
/// fix, or of 9.8 without one) and the GNSS fixes of the span show no motion (speed below
/// 0.3 m/s, positions within 3σ + 0.3 m of the first). A vibrating vehicle (engine
/// running) is static too: the test is relative to the first window. Returns a span of
/// zero samples when the first window already moves.
pub fn detect_static(imu: &[ImuSample], gnss: &[GnssEpoch], window: f64) -> StaticStart {
    let none = |t: f64| StaticStart {
        samples: 0,
        span: (t, t),
        mean_w: Vector3::zeros(),
        mean_f: Vector3::zeros(),
        std_w: Vector3::zeros(),
        std_f: Vector3::zeros(),
        dt: 0.0,
    };
    let Some(first) = imu.first() else { return none(f64::NAN) };
    let t0 = first.t - first.dt;
    let g = gnss.iter().find(|e| e.t >= t0).map_or(9.8, |e| normal_gravity(e.pos.lat, e.pos.h));
    // windows
    let mut windows: Vec<Window> = Vec::new();
    let mut cur = Window {
        end: 0,
        t1: t0 + window,
        n: 0,
        sum_w: Vector3::zeros(),
        sum_f: Vector3::zeros(),
        sq_w: Vector3::zeros(),
        sq_f: Vector3::zeros(),
    };
    for (k, s) in imu.iter().enumerate() {
        if s.t > cur.t1 + 1e-9 && cur.n > 0 {
            windows.push(cur);
            cur = Window {
                end: k,
                t1: cur.t1 + window * ((s.t - cur.t1) / window).ceil().max(1.0),
                n: 0,
                sum_w: Vector3::zeros(),
                sum_f: Vector3::zeros(),
                sq_w: Vector3::zeros(),
                sq_f: Vector3::zeros(),
            };
        }
        let (w, f) = (s.rate(), s.specific_force());
        cur.sum_w += w;
        cur.sum_f += f;
        cur.sq_w += w.component_mul(&w);
        cur.sq_f += f.component_mul(&f);
        cur.n += 1;
        cur.end = k + 1;
    }
    // a last window counts only when full (a partial one has a noisier mean)
    if cur.n > 0 && imu.last().is_some_and(|s| s.t >= cur.t1 - 1e-6) {
        windows.push(cur);
    }
    let Some(w0) = windows.first().copied() else { return none(t0) };
    let moving_gnss = |ta: f64, tb: f64| {
        let mut first_fix: Option<&GnssEpoch> = None;
        gnss.iter().filter(|e| e.t > t0 - 1e-9 && e.t <= tb + 1e-9).any(|e| {
            let f = *first_fix.get_or_insert(e);
            if e.t < ta - 1e-9 {
                return false;
            }
            let fast = e.vel.is_some_and(|(v, _)| v.xy().norm() > 0.3);
            let d = geodetic_to_local_ned(f.pos.tuple(), e.pos.tuple());
            let tol = 3.0 * (f.pos_std.xy().norm() + e.pos_std.xy().norm()) + 0.3;
            fast || d.xy().norm() > tol
        })
    };
    let (m0w, m0f, s0w, s0f) = (w0.mean_w(), w0.mean_f(), w0.std_w(), w0.std_f());
    let deg = core::f64::consts::PI / 180.0;
    let still = |w: &Window, ta: f64| {
        let n = (w.n as f64).sqrt();
        let mf = w.mean_f();
        (mf.norm() - g).abs() < 0.5
            && (w.mean_w() - m0w).norm() <= 3.0 * s0w.norm() / n + 0.1 * deg
            && (mf - m0f).norm() <= 3.0 * s0f.norm() / n + 0.05
            && w.std_w().norm() <= 2.0 * s0w.norm() + 0.2 * deg
            && w.std_f().norm() <= 2.0 * s0f.norm() + 0.1
            && !moving_gnss(ta, w.t1)
    };
    let mut n_windows = 0;
    let mut ta = t0;
    for w in &windows {
        if !still(w, ta) {
            break;
        }
        n_windows += 1;
        ta = w.t1;
    }
    if n_windows == 0 {
        return none(t0);
    }
    let used = &windows[..n_windows];
    let samples = used.last().map_or(0, |w| w.end);
    let sum = |f: fn(&Window) -> Vector3<f64>| used.iter().map(f).sum::<Vector3<f64>>();
    let (sum_w, sum_f, sq_w, sq_f) =
        (sum(|w| w.sum_w), sum(|w| w.sum_f), sum(|w| w.sq_w), sum(|w| w.sq_f));
    let span = (t0, imu[samples - 1].t);
    StaticStart {
        samples,
        span,
        mean_w: sum_w / samples as f64,
        mean_f: sum_f / samples as f64,
        std_w: Window::std(&sum_w, &sq_w, samples),
        std_f: Window::std(&sum_f, &sq_f, samples),
        dt: (span.1 - span.0) / samples as f64,
    }
}

/// The gyro bias of a static start once the attitude is known: the mean rate less the
/// Earth rate seen in the body frame, rad/s.
pub fn static_gyro_bias(s: &StaticStart, att: &So3, lat: f64) -> Vector3<f64> {
    s.mean_w - att.inverse().rotate(&earth_rate_ned(lat))
}

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
    /// The factor on the IMU's specific force that fits best (1 for consistent units).
    pub scale: f64,
    /// How much better a mirror image of the IMU's motion fits than the best rotation:
    /// the drop of χ² in units of the fit's χ² per degree of freedom (positive: a
    /// left-handed sensor frame; 0 when the motion cannot tell, e.g. a straight line).
    pub mirror: f64,
    /// RMS of the fixes' residuals in units of their σ (about 1 when the model fits).
    pub residual: f64,
}

/// The sums of the fit (weights `w = 1/σ²`): over fixes of `1, τ, τ²` and of the
/// gravity-corrected displacements `y` and the IMU's double integrals `a`.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    n: usize,
    g: Matrix2<f64>,
    y: SMatrix<f64, 3, 2>,
    a: SMatrix<f64, 3, 2>,
    ya: Matrix3<f64>,
    aa: Matrix3<f64>,
    yy: f64,
}

impl Sums {
    fn add(&mut self, tau: f64, y: &Vector3<f64>, a: &Vector3<f64>, w: f64) {
        self.n += 1;
        let basis = nalgebra::Vector2::new(1.0, tau);
        self.g += basis * basis.transpose() * w;
        self.y += y * basis.transpose() * w;
        self.a += a * basis.transpose() * w;
        self.ya += y * a.transpose() * w;
        self.aa += a * a.transpose() * w;
        self.yy += y.norm_squared() * w;
    }
}

/// 1σ floor of a fix in the fit, m: what the model neglects (the Earth's rotation,
/// vibration, the gyro errors over the span), which an RTK fix's centimetre σ would hide.
const MODEL_ERROR: f64 = 0.2;

/// Horizontal distance from the first fix before the fit may stop, m: a heading fitted
/// on the first metres of motion rests on too few of them to be trusted whatever its
/// formal σ.
const MIN_TRAVEL: f64 = 30.0;

/// In-motion alignment from the IMU samples after `t_a` and the GNSS fixes between `t_a`
/// and `t_a + max_time` (see the module text). `gyro_bias` (rad/s) is removed from the
/// rates and the gyro increments are multiplied by `gyro_scale` (1 normally; the unit
/// check tries others); `lever_arm` is the antenna's (body frame, m). The fit stops at the
/// first fix after which the heading's σ is below `heading_std` (rad) with at least 30 m
/// travelled, or at `max_time`. The heading's σ counts the fit's own and the drift of a
/// gyro bias of 1σ `bias_std` (rad/s) over the span; the fit with the smallest is kept
/// (a long span averages the fixes' noise but lets an unknown bias drift). `None` when
/// fewer than 8 fixes fall in the span or the motion cannot tell the attitude.
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
) -> Option<MotionFit> {
    let min_fixes = 8;
    let fixes: Vec<&GnssEpoch> =
        gnss.iter().filter(|e| e.t > t_a + 1e-9 && e.t <= t_a + max_time).collect();
    let reference = fixes.first()?.pos;
    let g = normal_gravity(reference.lat, reference.h);
    let mut sums = Sums::default();
    let mut dc = So3::identity();
    let (mut u, mut alpha) = (Vector3::zeros(), Vector3::zeros());
    let mut t = t_a;
    let mut next = 0;
    let mut best: Option<MotionFit> = None;
    let mut solve_at = 0;
    let mut travelled: f64 = 0.0;
    for s in imu.iter().filter(|s| s.t > t_a + 1e-9) {
        if next == fixes.len() {
            break;
        }
        let dt = s.t - t.max(s.t - s.dt);
        let dtheta = (s.dtheta * gyro_scale - gyro_bias * s.dt) * (dt / s.dt);
        let dvel = s.dvel * (dt / s.dt);
        let (dc0, u0, alpha0, t_prev) = (dc, u, alpha, t);
        let half = dc * So3::exp(&(dtheta * 0.5));
        u += half.rotate(&dvel);
        alpha += (u0 + u) * (0.5 * dt);
        dc = dc * So3::exp(&dtheta);
        t = s.t;
        while next < fixes.len() && fixes[next].t <= t + 1e-9 {
            let e = fixes[next];
            next += 1;
            let a = if t > t_prev { ((e.t - t_prev) / (t - t_prev)).clamp(0.0, 1.0) } else { 1.0 };
            let alpha_e = alpha0 + (alpha - alpha0) * a;
            let dc_e = if a < 0.5 { dc0 } else { dc };
            let col = alpha_e + dc_e.rotate(lever_arm);
            let tau = e.t - t_a;
            let dp = geodetic_to_local_ned(reference.tuple(), e.pos.tuple());
            travelled = travelled.max(dp.xy().norm());
            let y = dp - Vector3::new(0.0, 0.0, 0.5 * g * tau * tau);
            let var = e.pos_std.map(|v| v.max(MODEL_ERROR).powi(2)).sum() / 3.0;
            sums.add(tau, &y, &col, 1.0 / var);
            if sums.n >= min_fixes && sums.n >= solve_at {
                solve_at = sums.n + 2;
                if let Some(mut fit) = solve(&sums, reference, t_a, e.t) {
                    let drift = bias_std * (fit.t_b - fit.t_a) * 0.5;
                    // (the tilt is seen against gravity at every fix; the heading only
                    // through the velocity changes, so the drift counts on it)
                    fit.att_std.z = fit.att_std.z.hypot(drift);
                    let moved = travelled >= MIN_TRAVEL;
                    if moved && best.as_ref().is_none_or(|b| fit.att_std.z <= b.att_std.z) {
                        best = Some(fit);
                    }
                    // good enough, or long past the best span (the drift only grows)
                    if let Some(b) = &best {
                        if b.att_std.z < heading_std || e.t - t_a > 2.0 * (b.t_b - t_a) + 10.0 {
                            return best;
                        }
                    }
                }
            }
        }
    }
    best
}

/// The fit of [`Sums`]: `p₀`, `v₀` projected out (they enter linearly), the rotation by
/// Wahba's problem (SVD of the cross-covariance), then `p₀`, `v₀` given it.
fn solve(s: &Sums, reference: GeoPos, t_a: f64, t_b: f64) -> Option<MotionFit> {
    let ginv = s.g.try_inverse()?;
    // Σ w ỹ ãᵀ, Σ w ã ãᵀ, Σ w |ỹ|², with ỹ, ã the residuals of y, a after the affine
    // part in τ
    let b = s.ya - s.y * ginv * s.a.transpose();
    let aa = s.aa - s.a * ginv * s.a.transpose();
    let yy = s.yy - (s.y * ginv * s.y.transpose()).trace();
    let svd = b.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let sv = svd.singular_values;
    let d = (u * vt).determinant().signum();
    let c = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * vt;
    // the smallest singular value pairs with the last column of U and V (nalgebra's SVD
    // does not sort): the proper rotation flips the pair with the smallest one
    let k_min = sv.imin();
    let c = if k_min == 2 {
        c
    } else {
        let mut flip = Vector3::repeat(1.0);
        flip[k_min] = d;
        u * Matrix3::from_diagonal(&flip) * vt
    };
    let s_min = sv[k_min];
    let fit_trace = (c.transpose() * b).trace();
    let chi2 = (yy - 2.0 * fit_trace + aa.trace()).max(0.0);
    let dof = (3 * s.n).saturating_sub(9).max(1) as f64;
    let inflate = (chi2 / dof).max(1.0);
    // a mirror image gains 4 s_min on χ² when det B < 0
    let mirror = if d < 0.0 { 4.0 * s_min / inflate } else { -4.0 * s_min / inflate };
    let scale = fit_trace / aa.trace().max(1e-300);
    // information of small nav-frame rotations: Σ w [Cã]×ᵀ[Cã]× = tr(M) I − M
    let m = c * aa * c.transpose();
    let info = Matrix3::identity() * m.trace() - m;
    let cov = info.try_inverse()? * inflate;
    let att_std = cov.diagonal().map(|v| v.max(0.0).sqrt());
    // p₀, v₀ per axis given C
    let rhs = s.y - c * s.a;
    let pv = rhs * ginv;
    let (p0, v0) = (pv.column(0).into_owned(), pv.column(1).into_owned());
    let var_p = ginv[(0, 0)] * inflate * 3.0;
    let var_v = ginv[(1, 1)] * inflate * 3.0;
    let (lat, lon, h) = local_ned_to_geodetic(reference.tuple(), &p0);
    Some(MotionFit {
        t_a,
        t_b,
        fixes: s.n,
        att: So3::from_matrix(&c),
        pos: GeoPos::new(lat, lon, h),
        vel: v0,
        att_std,
        pos_std: Vector3::repeat(var_p.sqrt()),
        vel_std: Vector3::repeat(var_v.sqrt()),
        scale,
        mirror,
        residual: (chi2 / (3 * s.n) as f64).sqrt(),
    })
}
