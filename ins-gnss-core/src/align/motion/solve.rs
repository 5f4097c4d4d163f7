//! The least squares of the in-motion fit: the sums, the linearisation, the closed form and the Gauss–Newton solve.

use super::*;

/// The sums of the fit (weights `w = 1/σ²`): over fixes of `1, τ, τ²` and of the
/// gravity-corrected displacements `y` and the IMU's double integrals `a`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Sums {
    pub(super) n: usize,
    pub(super) g: Matrix2<f64>,
    pub(super) y: SMatrix<f64, 3, 2>,
    pub(super) a: SMatrix<f64, 3, 2>,
    pub(super) ya: Matrix3<f64>,
    pub(super) aa: Matrix3<f64>,
    pub(super) yy: f64,
}

impl Sums {
    pub(super) fn add(&mut self, tau: f64, y: &Vector3<f64>, a: &Vector3<f64>, w: f64) {
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

/// The priors of a fit's biases (1σ, per axis): the gyro's (rad/s; its horizontal axes
/// fitted, 0: not fitted) and the accelerometer's (m/s²; considered, never fitted; 0:
/// none).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Priors {
    pub(super) gyro_bias: f64,
    pub(super) accel_bias: f64,
}

/// The data of an in-motion fit.
pub(super) struct Input<'a> {
    pub(super) imu: &'a [ImuSample],
    pub(super) gnss: &'a [GnssEpoch],
    pub(super) t_a: f64,
    pub(super) gyro_bias: &'a Vector3<f64>,
    pub(super) gyro_scale: f64,
    pub(super) lever_arm: &'a Vector3<f64>,
    pub(super) t_b: f64,
}

/// What [`accumulate`] had added when it stopped: the sums, the fixes, the reference
/// position and the last fix's time.
pub(super) struct Accumulated {
    pub(super) sums: Sums,
    pub(super) fixes: Vec<Fix>,
    pub(super) reference: GeoPos,
    pub(super) t: f64,
}

/// Integrates the IMU from `t_a` and adds each fix in `(t_a, t_b]` to the sums, calling
/// `at_fix(sums, fixes, reference, t, travelled)` after each, which returns whether to go
/// on; returns what it had added (`None` without a fix).
pub(super) fn accumulate(
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
    let mut beta = Matrix3::zeros();
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
        let (ju0, ja0, beta0, b_int0) = (ju, ja, beta, b_int);
        let half = dc * So3::exp(&(dtheta * 0.5));
        let du = half.rotate(&dvel);
        let half_m = half.matrix();
        let b_mid = b_int + half_m * (0.5 * dt);
        u += du;
        ju += du.cross_matrix() * b_mid;
        alpha += (u0 + u) * (0.5 * dt);
        ja += (ju0 + ju) * (0.5 * dt);
        b_int += half_m * dt;
        beta += (b_int0 + b_int) * (0.5 * dt);
        dc = dc * So3::exp(&dtheta);
        t = s.t;
        while next < fixes.len() && fixes[next].t <= t + 1e-9 {
            let e = fixes[next];
            next += 1;
            let a = if t > t_prev { ((e.t - t_prev) / (t - t_prev)).clamp(0.0, 1.0) } else { 1.0 };
            let alpha_e = alpha0 + (alpha - alpha0) * a;
            let jac = ja0 + (ja - ja0) * a;
            let beta_e = beta0 + (beta - beta0) * a;
            let dc_e = if a < 0.5 { dc0 } else { dc };
            let col = alpha_e + dc_e.rotate(lever_arm);
            let tau = e.t - t_a;
            let dp = geodetic_to_local_ned(reference.tuple(), e.pos.tuple());
            travelled = travelled.max(dp.xy().norm());
            let y = dp - Vector3::new(0.0, 0.0, 0.5 * g * tau * tau);
            let var = e.pos_std.map(|v| v.max(MODEL_ERROR).powi(2)).sum() / 3.0;
            sums.add(tau, &y, &col, 1.0 / var);
            records.push(Fix {
                tau,
                y,
                a: col,
                jac,
                beta: beta_e,
                w: 1.0 / var,
                pos: e.pos,
                pos_std: e.pos_std,
            });
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
pub(super) struct Params {
    pub(super) c: Matrix3<f64>,
    pub(super) p0: Vector3<f64>,
    pub(super) v0: Vector3<f64>,
    pub(super) db: Vector3<f64>,
}

/// Normal equations: the normal matrix, the right-hand side, the cost.
type Normal = (SMatrix<f64, 12, 12>, SVector<f64, 12>, f64);

/// The normal matrix, the right-hand side and the cost (χ² plus the bias prior's) of
/// the fit at `x`; the bias block is held fixed (identity, no coupling) when it is not
/// estimated.
///
/// A fix's Jacobian is `H = [A | I | τ I | B | 0]` (attitude, `p₀`, `v₀`, the two fitted
/// bias axes, the held one), so `Hᵀ H` and `Hᵀ r` are written out by blocks: the zeros
/// and ones left out, the upper triangle mirrored, each remaining sum in the order of the
/// dense product. The result is bit for bit the dense `Hᵀ H w` of nalgebra
/// (`tests::blocks_match_the_dense_products_bit_for_bit`), with about a quarter of its
/// floating-point operations (some 250 per fix against 1,000: 54 entries of the 144 are
/// not structurally 0 or 1); the search of the in-motion alignment solves many times
/// per run.
pub(super) fn linearise(fixes: &[Fix], x: &Params, estimate_bias: bool, prior: f64) -> Normal {
    let mut normal = SMatrix::<f64, 12, 12>::zeros();
    let mut rhs = SVector::<f64, 12>::zeros();
    let mut cost = 0.0;
    // (δb_z has no column: its prior holds it at 0, see `solve`)
    let bias_columns = if estimate_bias { 2 } else { 0 };
    // (the sums of three products, left to right, as the dense product adds them)
    let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    for f in fixes {
        let (body, r) = residual(f, x);
        let (tau, w) = (f.tau, f.w);
        cost += r.norm_squared() * w;
        let a = -(x.c * body).cross_matrix();
        let b = match estimate_bias {
            true => (x.c * f.jac).fixed_columns::<2>(0).into_owned(),
            false => SMatrix::<f64, 3, 2>::zeros(),
        };
        let ac = |i: usize| [a[(0, i)], a[(1, i)], a[(2, i)]];
        let bc = |n: usize| [b[(0, n)], b[(1, n)], b[(2, n)]];
        let mut add = |i: usize, j: usize, v: f64| {
            let v = v * w;
            normal[(i, j)] += v;
            if i != j {
                normal[(j, i)] += v;
            }
        };
        for i in 0..3 {
            for j in i..3 {
                add(i, j, dot(ac(i), ac(j)));
            }
            for m in 0..3 {
                add(i, 3 + m, a[(m, i)]);
                add(i, 6 + m, a[(m, i)] * tau);
            }
            for n in 0..bias_columns {
                add(i, 9 + n, dot(ac(i), bc(n)));
            }
            rhs[i] += dot(ac(i), r.into()) * w;
        }
        for m in 0..3 {
            add(3 + m, 3 + m, 1.0);
            add(3 + m, 6 + m, tau);
            add(6 + m, 6 + m, tau * tau);
            for n in 0..bias_columns {
                add(3 + m, 9 + n, b[(m, n)]);
                add(6 + m, 9 + n, tau * b[(m, n)]);
            }
            rhs[3 + m] += r[m] * w;
            rhs[6 + m] += tau * r[m] * w;
        }
        for m in 0..bias_columns {
            for n in m..bias_columns {
                add(9 + m, 9 + n, dot(bc(m), bc(n)));
            }
            rhs[9 + m] += dot(bc(m), r.into()) * w;
        }
    }
    with_bias_prior((normal, rhs, cost), x, estimate_bias, prior)
}

/// A fix's IMU displacement with the bias change applied (`a + J δb`) and the fit's
/// residual at `x`.
fn residual(f: &Fix, x: &Params) -> (Vector3<f64>, Vector3<f64>) {
    let body = f.a + f.jac * x.db;
    (body, f.y - (x.p0 + x.v0 * f.tau + x.c * body))
}

/// The bias prior added to [`linearise`]'s sums (its cost, `prior` on the diagonal), or
/// the bias block held at the identity when the bias is not estimated.
fn with_bias_prior(
    (mut normal, mut rhs, mut cost): Normal,
    x: &Params,
    estimate_bias: bool,
    prior: f64,
) -> Normal {
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

/// How many times fewer independent fixes the fit had than it counts: `(1 + ρ)/(1 − ρ)`
/// with `ρ` the lag-one autocorrelation of its residuals (consecutive fixes, the three
/// axes pooled; clamped to [0, 0.9]). A single point's errors wander over minutes: a fit
/// that takes them for white puts its velocity and heading's σ several times too small
/// (a walk from the first sample on such fixes: 2 of 10 headings within 3σ).
fn persistence(fixes: &[Fix], x: &Params) -> f64 {
    let r: Vec<Vector3<f64>> = fixes.iter().map(|f| residual(f, x).1 * f.w.sqrt()).collect();
    let sq: f64 = r.iter().map(|v| v.norm_squared()).sum();
    let lag: f64 = r.windows(2).map(|w| w[0].dot(&w[1])).sum();
    let rho = if sq > 0.0 { (lag / sq).clamp(0.0, 0.9) } else { 0.0 };
    (1.0 + rho) / (1.0 - rho)
}

/// The covariance an accelerometer bias of 1σ `std` (m/s², per axis, body frame; not
/// fitted) adds to the fit at `x` (normal matrix inverse `n_inv`): the fixes move by
/// `−C β b_a`, the estimate by `S b_a` with `S = N⁻¹ Σ Hᵀ w (−C β)`, so its covariance
/// grows by `S S' std²` (a consider parameter).
fn considered(
    fixes: &[Fix],
    x: &Params,
    estimate_bias: bool,
    n_inv: &SMatrix<f64, 12, 12>,
    std: f64,
) -> SMatrix<f64, 12, 12> {
    if std <= 0.0 {
        return SMatrix::zeros();
    }
    let mut m = SMatrix::<f64, 12, 3>::zeros();
    for f in fixes {
        m -= fix_jacobian(f, x, estimate_bias).transpose() * (x.c * f.beta) * f.w;
    }
    let s = n_inv * m;
    s * s.transpose() * (std * std)
}

/// A fix's whole Jacobian `H = [A | I | τ I | B | 0]` at `x` (what [`linearise`] writes
/// out by blocks).
fn fix_jacobian(f: &Fix, x: &Params, estimate_bias: bool) -> SMatrix<f64, 3, 12> {
    let (body, _) = residual(f, x);
    let mut h = SMatrix::<f64, 3, 12>::zeros();
    h.fixed_view_mut::<3, 3>(0, 0).copy_from(&-(x.c * body).cross_matrix());
    h.fixed_view_mut::<3, 3>(0, 3).copy_from(&Matrix3::identity());
    h.fixed_view_mut::<3, 3>(0, 6).copy_from(&(Matrix3::identity() * f.tau));
    if estimate_bias {
        h.fixed_view_mut::<3, 2>(0, 9).copy_from(&(x.c * f.jac).fixed_columns::<2>(0));
    }
    h
}

/// The closed form of the fit of [`Sums`] (no bias, no refinement): `p₀`, `v₀` projected
/// out, the rotation by Wahba's problem; and how much better a mirror image fits (the
/// `mirror` of [`MotionFit`]).
pub(super) fn closed_form(s: &Sums) -> Option<(Params, f64)> {
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
pub(super) fn solve(
    s: &Sums,
    fixes: &[Fix],
    reference: GeoPos,
    t_a: f64,
    t_b: f64,
    gyro_bias: &Vector3<f64>,
    priors: Priors,
) -> Option<(MotionFit, Params)> {
    let bias_std = priors.gyro_bias;
    let (x0, mirror) = closed_form(s)?;

    // Levenberg–Marquardt: x = [θ (nav-frame rotation), p₀, v₀, δb]
    let estimate_bias = bias_std > 0.0;
    let prior = if estimate_bias { 1.0 / (bias_std * bias_std) } else { 0.0 };
    let (x, normal, cost) = levenberg_marquardt(fixes, x0, estimate_bias, prior)?;
    let params = x;
    let Params { c, p0, v0, db } = x;
    let chi2 = cost - prior * db.norm_squared();
    let dof = (3 * fixes.len()).saturating_sub(if estimate_bias { 12 } else { 9 }).max(1);
    let inflate = (chi2 / dof as f64).max(1.0);
    let n_inv = normal.cholesky()?.inverse();
    let cov = n_inv * inflate + considered(fixes, &x, estimate_bias, &n_inv, priors.accel_bias);
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
            persistence: persistence(fixes, &x),
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

/// The damped Gauss–Newton iterations from `x` (at most 20; until the cost falls by less
/// than 1e-9 of itself, or the damping passes 1e9): the parameters, their normal matrix
/// and the cost there.
fn levenberg_marquardt(
    fixes: &[Fix],
    mut x: Params,
    estimate_bias: bool,
    prior: f64,
) -> Option<(Params, SMatrix<f64, 12, 12>, f64)> {
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
    Some((x, normal, cost))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::{Rng, SeedableRng};

    /// [`linearise`] as the dense products of each fix's whole `H` (its form before the
    /// blocks were written out).
    fn linearise_dense(fixes: &[Fix], x: &Params, estimate_bias: bool, prior: f64) -> Normal {
        let (mut normal, mut rhs, mut cost): Normal = (SMatrix::zeros(), SVector::zeros(), 0.0);
        for f in fixes {
            let (_, r) = residual(f, x);
            cost += r.norm_squared() * f.w;
            let h = fix_jacobian(f, x, estimate_bias);
            normal += h.transpose() * h * f.w;
            rhs += h.transpose() * r * f.w;
        }
        with_bias_prior((normal, rhs, cost), x, estimate_bias, prior)
    }

    /// Values of every scale and sign, zeros among them, from a seeded generator.
    struct Values(StdRng);
    impl Values {
        fn next(&mut self) -> f64 {
            let u: u64 = self.0.random();
            match u % 11 {
                0 => 0.0,
                1 => -0.0,
                k => {
                    let unit = (u >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                    unit * 10f64.powi(k as i32 - 6)
                }
            }
        }
        fn vector(&mut self) -> Vector3<f64> {
            Vector3::new(self.next(), self.next(), self.next())
        }
        fn matrix(&mut self) -> Matrix3<f64> {
            Matrix3::from_fn(|_, _| self.next())
        }
    }

    #[test]
    fn blocks_match_the_dense_products_bit_for_bit() {
        let mut v = Values(StdRng::seed_from_u64(53));
        let bits = |m: &[f64]| m.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for case in 0..400 {
            let fixes: Vec<Fix> = (0..1 + case % 40)
                .map(|k| Fix {
                    tau: k as f64 * 0.2 + v.next().abs(),
                    y: v.vector(),
                    a: v.vector(),
                    jac: v.matrix(),
                    beta: v.matrix(),
                    w: 1.0 / (0.04 + v.next().abs()),
                    pos: GeoPos { lat: 0.7, lon: 0.1, h: 100.0 },
                    pos_std: Vector3::repeat(0.2),
                })
                .collect();
            let x = Params {
                c: So3::exp(&v.vector()).matrix(),
                p0: v.vector(),
                v0: v.vector(),
                db: v.vector(),
            };
            for estimate_bias in [false, true] {
                let prior = 1.0 + v.next().abs();
                let (n, r, c) = linearise(&fixes, &x, estimate_bias, prior);
                let (nd, rd, cd) = linearise_dense(&fixes, &x, estimate_bias, prior);
                assert_eq!(
                    bits(n.as_slice()),
                    bits(nd.as_slice()),
                    "case {case}, bias {estimate_bias}"
                );
                assert_eq!(
                    bits(r.as_slice()),
                    bits(rd.as_slice()),
                    "case {case}, bias {estimate_bias}"
                );
                assert_eq!(c.to_bits(), cd.to_bits());
            }
        }
    }
}
