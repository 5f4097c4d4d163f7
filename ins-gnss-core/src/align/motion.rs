//! The in-motion alignment (position-integration form) and its robust fit.

use super::*;

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

/// One fix of the fit: `y = p₀ + v₀ τ + C₀ (a + J δb)`, with `J = ∂a/∂b_g`.
#[derive(Clone, Copy, Debug)]
struct Fix {
    tau: f64,
    y: Vector3<f64>,
    a: Vector3<f64>,
    jac: Matrix3<f64>,
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
/// (a long span averages the fixes' noise but lets an unknown bias drift). `None` when
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
) -> Option<MotionFit> {
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
        if let Some(mut fit) = robust_solve(fixes, reference, t_a, t, gyro_bias, bias_std) {
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
            if let Some(b) = &best {
                if b.att_std.z < heading_std || t - t_a > 2.0 * (b.t_b - t_a) + 10.0 {
                    return false;
                }
            }
        }
        true
    });
    best
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
            solve(&last.sums, &last.fixes, last.reference, t_a, last.t, gyro_bias, 0.0)
                .map(|(f, _)| f)
        })
        .flatten()
}

/// The data of an in-motion fit.
struct Input<'a> {
    imu: &'a [ImuSample],
    gnss: &'a [GnssEpoch],
    t_a: f64,
    gyro_bias: &'a Vector3<f64>,
    gyro_scale: f64,
    lever_arm: &'a Vector3<f64>,
    t_b: f64,
}

/// What [`accumulate`] had added when it stopped: the sums, the fixes, the reference
/// position and the last fix's time.
struct Accumulated {
    sums: Sums,
    fixes: Vec<Fix>,
    reference: GeoPos,
    t: f64,
}

/// Integrates the IMU from `t_a` and adds each fix in `(t_a, t_b]` to the sums, calling
/// `at_fix(sums, fixes, reference, t, travelled)` after each, which returns whether to go
/// on; returns what it had added (`None` without a fix).
fn accumulate(
    input: &Input,
    mut at_fix: impl FnMut(&Sums, &[Fix], GeoPos, f64, f64) -> bool,
) -> Option<Accumulated> {
    let Input { imu, gnss, t_a, gyro_bias, gyro_scale, lever_arm, t_b } = *input;
    let fixes: Vec<&GnssEpoch> = gnss.iter().filter(|e| e.t > t_a + 1e-9 && e.t <= t_b).collect();
    let reference = fixes.first()?.pos;
    let g = normal_gravity(reference.lat, reference.h);
    let mut sums = Sums::default();
    let mut records = Vec::with_capacity(fixes.len());
    let mut dc = So3::identity();
    let (mut u, mut alpha) = (Vector3::zeros(), Vector3::zeros());
    // ∂/∂b_g of the rotation (B = ∫ ΔC), the velocity and the position integrals: a
    // bias change δb turns ΔC(r) by −B(r) δb (left, in the frame at t_a)
    let (mut b_int, mut ju, mut ja) = (Matrix3::zeros(), Matrix3::zeros(), Matrix3::zeros());
    let mut t = t_a;
    let mut next = 0;
    let mut travelled: f64 = 0.0;
    let mut last_t = t_a;
    for s in imu.iter().filter(|s| s.t > t_a + 1e-9) {
        if next == fixes.len() {
            break;
        }
        let dt = s.t - t.max(s.t - s.dt);
        let dtheta = (s.dtheta * gyro_scale - gyro_bias * s.dt) * (dt / s.dt);
        let dvel = s.dvel * (dt / s.dt);
        let (dc0, u0, alpha0, t_prev) = (dc, u, alpha, t);
        let (ju0, ja0) = (ju, ja);
        let half = dc * So3::exp(&(dtheta * 0.5));
        let du = half.rotate(&dvel);
        let half_m = half.matrix();
        let b_mid = b_int + half_m * (0.5 * dt);
        u += du;
        ju += du.cross_matrix() * b_mid;
        alpha += (u0 + u) * (0.5 * dt);
        ja += (ju0 + ju) * (0.5 * dt);
        b_int += half_m * dt;
        dc = dc * So3::exp(&dtheta);
        t = s.t;
        while next < fixes.len() && fixes[next].t <= t + 1e-9 {
            let e = fixes[next];
            next += 1;
            let a = if t > t_prev { ((e.t - t_prev) / (t - t_prev)).clamp(0.0, 1.0) } else { 1.0 };
            let alpha_e = alpha0 + (alpha - alpha0) * a;
            let jac = ja0 + (ja - ja0) * a;
            let dc_e = if a < 0.5 { dc0 } else { dc };
            let col = alpha_e + dc_e.rotate(lever_arm);
            let tau = e.t - t_a;
            let dp = geodetic_to_local_ned(reference.tuple(), e.pos.tuple());
            travelled = travelled.max(dp.xy().norm());
            let y = dp - Vector3::new(0.0, 0.0, 0.5 * g * tau * tau);
            let var = e.pos_std.map(|v| v.max(MODEL_ERROR).powi(2)).sum() / 3.0;
            sums.add(tau, &y, &col, 1.0 / var);
            records.push(Fix { tau, y, a: col, jac, w: 1.0 / var, pos: e.pos, pos_std: e.pos_std });
            last_t = e.t;
            if !at_fix(&sums, &records, reference, e.t, travelled) {
                return Some(Accumulated { sums, fixes: records, reference, t: last_t });
            }
        }
    }
    Some(Accumulated { sums, fixes: records, reference, t: last_t })
}

/// The parameters of the fit's refinement ([`solve`]).
#[derive(Clone, Copy)]
struct Params {
    c: Matrix3<f64>,
    p0: Vector3<f64>,
    v0: Vector3<f64>,
    db: Vector3<f64>,
}

/// The normal matrix, the right-hand side and the cost (χ² plus the bias prior's) of
/// the fit at `x`; the bias block is held fixed (identity, no coupling) when it is not
/// estimated.
fn linearise(
    fixes: &[Fix],
    x: &Params,
    estimate_bias: bool,
    prior: f64,
) -> (SMatrix<f64, 12, 12>, SVector<f64, 12>, f64) {
    let mut normal = SMatrix::<f64, 12, 12>::zeros();
    let mut rhs = SVector::<f64, 12>::zeros();
    let mut cost = 0.0;
    let mut h = SMatrix::<f64, 3, 12>::zeros();
    for f in fixes {
        let body = f.a + f.jac * x.db;
        let r = f.y - (x.p0 + x.v0 * f.tau + x.c * body);
        cost += r.norm_squared() * f.w;
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&-(x.c * body).cross_matrix());
        h.fixed_view_mut::<3, 3>(0, 3).copy_from(&Matrix3::identity());
        h.fixed_view_mut::<3, 3>(0, 6).copy_from(&(Matrix3::identity() * f.tau));
        if estimate_bias {
            // (δb_z has no column: its prior holds it at 0, see `solve`)
            h.fixed_view_mut::<3, 2>(0, 9).copy_from(&(x.c * f.jac).fixed_columns::<2>(0));
        }
        normal += h.transpose() * h * f.w;
        rhs += h.transpose() * r * f.w;
    }
    if estimate_bias {
        cost += prior * x.db.norm_squared();
        for k in 9..12 {
            normal[(k, k)] += prior;
            rhs[k] -= x.db[k - 9] * prior;
        }
    } else {
        normal.fixed_view_mut::<3, 3>(9, 9).copy_from(&Matrix3::identity());
    }
    (normal, rhs, cost)
}

/// The closed form of the fit of [`Sums`] (no bias, no refinement): `p₀`, `v₀` projected
/// out, the rotation by Wahba's problem; and how much better a mirror image fits (the
/// `mirror` of [`MotionFit`]).
fn closed_form(s: &Sums) -> Option<(Params, f64)> {
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
    // the smallest singular value pairs with the last column of U and V (nalgebra's SVD
    // does not sort): the proper rotation flips the pair with the smallest one
    let k_min = sv.imin();
    let mut flip = Vector3::repeat(1.0);
    flip[k_min] = d;
    let c = u * Matrix3::from_diagonal(&flip) * vt;
    let s_min = sv[k_min];
    let fit_trace = (c.transpose() * b).trace();
    let chi2 = (yy - 2.0 * fit_trace + aa.trace()).max(0.0);
    let dof = (3 * s.n).saturating_sub(9).max(1) as f64;
    let inflate = (chi2 / dof).max(1.0);
    // a mirror image gains 4 s_min on χ² when det B < 0
    let mirror = if d < 0.0 { 4.0 * s_min / inflate } else { -4.0 * s_min / inflate };
    let pv = (s.y - c * s.a) * ginv;
    let x = Params {
        c,
        p0: pv.column(0).into_owned(),
        v0: pv.column(1).into_owned(),
        db: Vector3::zeros(),
    };
    Some((x, mirror))
}

/// The fit of [`Sums`]: `p₀`, `v₀` projected out (they enter linearly), the rotation by
/// Wahba's problem (SVD of the cross-covariance); then Gauss–Newton on the fixes for the
/// rotation, `p₀`, `v₀` and the horizontal axes of a gyro-bias change `δb` (prior 1σ
/// `bias_std`; not fitted when that is 0), which gives the covariance of all four.
///
/// Why x and y only, measured (heading error of the fit; the 10-seed drive of
/// `ins-gnss-sim/tests/in_motion_alignment.rs`, navego, drive-0708): no bias fitted
/// 3.0° max / 2.3° RMS, −0.13°, +0.6°; x, y, z fitted 0.83° / 0.53°, −4.7° (4.5σ), +24°
/// (these two solving at every second fix); x, y fitted 0.82° / 0.50°, −1.6°, +3.2°. A
/// horizontal bias tilts the integrated specific force against gravity (`g b τ³/6`: 63 m
/// after 54 s at 50°/h), so the fixes see it within seconds; the z bias shows only
/// through the turns, and on real data it takes up what the model leaves out (the
/// Earth's rate, Coriolis). The damping (Levenberg–Marquardt) is needed: undamped, the
/// x, y, z fit on drive-0708 diverged to +71°.
fn solve(
    s: &Sums,
    fixes: &[Fix],
    reference: GeoPos,
    t_a: f64,
    t_b: f64,
    gyro_bias: &Vector3<f64>,
    bias_std: f64,
) -> Option<(MotionFit, Params)> {
    let (x0, mirror) = closed_form(s)?;

    // Levenberg–Marquardt: x = [θ (nav-frame rotation), p₀, v₀, δb]
    let estimate_bias = bias_std > 0.0;
    let prior = if estimate_bias { 1.0 / (bias_std * bias_std) } else { 0.0 };
    let mut x = x0;
    let (mut normal, mut rhs, mut cost) = linearise(fixes, &x, estimate_bias, prior);
    let mut lambda = 1e-3;
    for _ in 0..20 {
        let mut damped = normal;
        for k in 0..12 {
            damped[(k, k)] *= 1.0 + lambda;
        }
        let step = damped.cholesky()?.solve(&rhs);
        let trial = Params {
            c: So3::exp(&step.fixed_rows::<3>(0).into_owned()).matrix() * x.c,
            p0: x.p0 + step.fixed_rows::<3>(3),
            v0: x.v0 + step.fixed_rows::<3>(6),
            db: x.db + step.fixed_rows::<3>(9),
        };
        let (n, r, trial_cost) = linearise(fixes, &trial, estimate_bias, prior);
        if trial_cost < cost {
            let small = cost - trial_cost < 1e-9 * cost;
            (x, normal, rhs, cost) = (trial, n, r, trial_cost);
            lambda = (lambda * 0.1).max(1e-9);
            if small {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e9 {
                break;
            }
        }
    }
    let params = x;
    let Params { c, p0, v0, db } = x;
    let chi2 = cost - prior * db.norm_squared();
    let dof = (3 * fixes.len()).saturating_sub(if estimate_bias { 12 } else { 9 }).max(1);
    let inflate = (chi2 / dof as f64).max(1.0);
    let cov = normal.cholesky()?.inverse() * inflate;
    let std = |k: usize| Vector3::new(cov[(k, k)], cov[(k + 1, k + 1)], cov[(k + 2, k + 2)]);
    let sqrt = |v: Vector3<f64>| v.map(|x| x.max(0.0).sqrt());
    let (lat, lon, h) = local_ned_to_geodetic(reference.tuple(), &p0);
    Some(
        MotionFit {
            t_a,
            t_b,
            fixes: s.n,
            att: So3::from_matrix(&c),
            pos: GeoPos::new(lat, lon, h),
            vel: v0,
            att_std: sqrt(std(0)),
            pos_std: sqrt(std(3)),
            vel_std: sqrt(std(6)),
            gyro_bias: gyro_bias + db,
            gyro_bias_std: if estimate_bias { sqrt(std(9)) } else { Vector3::zeros() },
            mirror,
            residual: (chi2 / (3 * fixes.len()) as f64).sqrt(),
            rejected: 0,
            first_fix: fixes.first().map(|f| (f.tau, f.pos, f.pos_std))?,
            path: fixes
                .windows(2)
                .map(|w| {
                    let da = (w[1].a - w[0].a) + (w[1].jac - w[0].jac) * db;
                    (v0 * (w[1].tau - w[0].tau) + c * da).norm()
                })
                .sum(),
        }
        .with_params(params),
    )
}

impl MotionFit {
    fn with_params(self, p: Params) -> (Self, Params) {
        (self, p)
    }
}

/// A fix's residual beyond this many times the fixes' robust scale (and at least this
/// many σ) is a gross error to the in-motion fit: the norm of a 3-D residual in units of
/// its σ exceeds 8 with probability 1e-13, so no fit the model explains is touched for it.
pub const GROSS: f64 = 8.0;

/// The RMS residual (in units of the fixes' σ) beyond which the least-squares in-motion
/// fit is not kept as it is but found again by consensus: navego fits at 1.4σ, and with
/// gross errors among its fixes at tens; drive-0708's centimetre RTK fixes, which the
/// model misfits beyond 4σ, go to the consensus too (54 of 287 fixes left out there).
pub const MISFIT: f64 = 4.0;

/// Samples of six fixes tried by the consensus fit: a sample of fixes half of which are
/// gross errors is clean with probability 1/64, so 500 samples all miss with probability
/// 4e-4 (a sample is a 3×3 SVD and one pass over the fixes).
const CONSENSUS_SAMPLES: usize = 500;

/// The norm of each fix's residual at `x`, in units of its σ.
fn residuals(fixes: &[Fix], x: &Params) -> Vec<f64> {
    fixes
        .iter()
        .map(|f| {
            let r = f.y - (x.p0 + x.v0 * f.tau + x.c * (f.a + f.jac * x.db));
            r.norm() * f.w.sqrt()
        })
        .collect()
}

/// The robust scale of normalised 3-D residuals: their median over the median of χ(3)
/// (1.538), at least 1.
fn robust_scale(r: &[f64]) -> f64 {
    let mut v: Vec<f64> = r.to_vec();
    if v.is_empty() {
        return 1.0;
    }
    let k = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    (*m / 1.538).max(1.0)
}

/// The sums of the fixes in `keep`.
fn sums_of<'a>(fixes: impl IntoIterator<Item = &'a Fix>) -> Sums {
    let mut s = Sums::default();
    for f in fixes {
        s.add(f.tau, &f.y, &f.a, f.w);
    }
    s
}

/// The in-motion fit with gross errors left out. The least-squares fit ([`solve`]) is
/// kept when its RMS residual is at most [`MISFIT`] and it leaves no fix beyond
/// [`GROSS`] × the robust scale of its residuals (navego: the same fit as before).
/// Otherwise a consensus: samples of six fixes, one from each sixth of the span, each solved in closed form (Wahba's problem), are scored
/// by the 35 % quantile of all fixes' residuals (a least-quantile criterion, which holds
/// with up to 65 % of the fixes wrong where a least-median one breaks at 50 %); the fixes
/// within [`GROSS`] × the best sample's robust scale are fitted again, and those within it
/// of that fit make the result. Sampling is seeded by the number of fixes, so a run is
/// repeatable.
///
/// Why a consensus and not an M-estimator, measured (`benches/campaign.py`, navego, 1 km
/// errors at random bearings, 10 seeds per cell): a Tukey-biweight IRLS started from the
/// least-squares fit did as well up to 20 % of the fixes, but with half of them wrong from
/// the first fix and no `[init]` it kept every fix in 3 of 10 seeds ("finds the heading
/// only to ±22–30°", refused), where the consensus started all 10; least squares, which
/// half of the fixes 1 km off pull far away, is a start the weights do not recover from.
fn robust_solve(
    fixes: &[Fix],
    reference: GeoPos,
    t_a: f64,
    t_b: f64,
    gyro_bias: &Vector3<f64>,
    bias_std: f64,
) -> Option<MotionFit> {
    let all = sums_of(fixes);
    let ls = solve(&all, fixes, reference, t_a, t_b, gyro_bias, bias_std);
    if let Some((fit, x)) = &ls {
        // (a fit that half of the fixes pulled away leaves every residual large, the good
        // fixes' too, so their median is no scale: such a fit shows in its RMS)
        let r = residuals(fixes, x);
        let scale = robust_scale(&r);
        if fit.residual <= MISFIT && r.iter().all(|&v| v <= GROSS * scale) {
            return Some(*fit);
        }
    }
    let n = fixes.len();
    if n < 12 {
        return ls.map(|(f, _)| f);
    }
    // consensus over stratified samples of six
    let mut rng = (n as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move |k: usize| {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng % k as u64) as usize
    };
    let h = ((n as f64 * 0.35).ceil() as usize).clamp(7, n) - 1;
    let mut best: Option<(f64, Params)> = None;
    let mut r = vec![0.0; n];
    for _ in 0..CONSENSUS_SAMPLES {
        let mut s = Sums::default();
        for b in 0..6 {
            let (lo, hi) = (b * n / 6, (b + 1) * n / 6);
            let f = &fixes[lo + next(hi - lo)];
            s.add(f.tau, &f.y, &f.a, f.w);
        }
        let Some((x, _)) = closed_form(&s) else { continue };
        for (ri, f) in r.iter_mut().zip(fixes) {
            let d = f.y - (x.p0 + x.v0 * f.tau + x.c * f.a);
            *ri = d.norm() * f.w.sqrt();
        }
        let (_, q, _) = r.select_nth_unstable_by(h, f64::total_cmp);
        let q = *q;
        if best.as_ref().is_none_or(|(b, _)| q < *b) {
            best = Some((q, x));
        }
    }
    let (_, x) = best?;
    // the fixes the best sample explains, fitted again; then those the refit explains
    let keep = |x: &Params| -> Vec<Fix> {
        let r = residuals(fixes, x);
        let mut inl: Vec<f64> = r.clone();
        inl.sort_by(f64::total_cmp);
        let scale = robust_scale(&inl[..=h]);
        fixes.iter().zip(&r).filter(|(_, &v)| v <= GROSS * scale).map(|(f, _)| *f).collect()
    };
    let first = keep(&x);
    if first.len() < 8 {
        return ls.map(|(f, _)| f);
    }
    let (_, x1) = solve(&sums_of(&first), &first, reference, t_a, t_b, gyro_bias, bias_std)?;
    let used = keep(&x1);
    if used.len() < 8 {
        return ls.map(|(f, _)| f);
    }
    let (mut fit, _) = solve(&sums_of(&used), &used, reference, t_a, t_b, gyro_bias, bias_std)?;
    fit.rejected = n - used.len();
    Some(fit)
}
