//! The 15-state error model and the INS process model.
//!
//! Continuous error dynamics for `δx = [δθ, δv, δp, δb_g, δb_a]` (right attitude error,
//! NED-metre position error), derived for this project from `R = R̂ Exp(δθ)`,
//! `Ṙ = R[ω_ib×] − [ω_in×]R`, `v̇ = R f + g − (2ω_ie + ω_en) × v`:
//!
//! ```text
//! δθ̇ = −[ω̂×] δθ − R̂ᵀ (N_v δv + N_p δp) − δb_g − n_g
//! δv̇ = −R̂[f̂×] δθ + (−[(2ω_ie+ω_en)×] + [v×]N_v) δv + ([v×](2 D_ie + D_en) + G_p) δp − R̂ δb_a − R̂ n_a
//! δṗ = δv + F_pp δp
//! δḃ = −b/τ + w                                       (Gauss–Markov; 0 for a random walk)
//! ```
//!
//! where `N_v = ∂ω_en/∂v`, `D_ie = ∂ω_ie/∂δp`, `D_en = ∂ω_en/∂δp`, `N_p = D_ie + D_en`,
//! `G_p` the latitude and height derivatives of normal gravity, and `F_pp` the curvature terms of the
//! NED-metre position error (derived from `δN = (R_M+h)δφ`, `δE = (R_N+h)cos φ δλ`,
//! `δD = −δh`). The flat-earth model keeps only `−[ω̂×]`, `−R̂[f̂×]`, `I`, `−I`, `−R̂` and
//! the bias terms (paper `fused-iae-afkf` eq. 8–12).
//!
//! Discretisation: `Φ = I + F dt`; `Q_d = (Φ D + D Φᵀ) dt/2` (the trapezoid
//! `(Φ D Φᵀ + D) dt/2` to second order in dt) with
//! `D = G Q_c Gᵀ = blockdiag(diag(ARW²), R̂ diag(VRW²) R̂ᵀ, 0, diag(q_bg), diag(q_ba))`.

use estimator_core::fma_kernel;
use estimator_core::kernels::madd;
use estimator_core::{Cov, ProcessJacobians, ProcessModel};
use manifolds::{hat, So3};
use nalgebra::{Const, Matrix3, SMatrix, Vector3};

use crate::earth::{
    earth_rate_ned_sc, normal_gravity_gradient_sc, prime_vertical_radius_derivative_sc,
    radii_from_sin, transport_rate_with,
};
use crate::imu::{BiasModel, ImuNoise, ImuSample};
use crate::mechanization::{self, Increments, Mechanization, Nav};
use crate::state::InsState;

/// 15×15 matrices of the error state.
pub type M15 = SMatrix<f64, 15, 15>;

/// Block index of the attitude error (blocks of 3 rows: θ, v, p, b_g, b_a).
pub const B_TH: usize = 0;
/// Block index of the velocity error.
pub const B_V: usize = 1;
/// Block index of the position error.
pub const B_P: usize = 2;
/// Block index of the gyro-bias error.
pub const B_BG: usize = 3;
/// Block index of the accelerometer-bias error.
pub const B_BA: usize = 4;

/// The input of one prediction: the previous and the current raw IMU samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuInput {
    /// The sample before (for coning and sculling); `None` at start-up.
    pub prev: Option<ImuSample>,
    /// The sample that ends this interval.
    pub cur: ImuSample,
}

/// The INS process model: mechanization, error model and noise.
#[derive(Clone, Debug)]
pub struct InsModel {
    /// Which mechanization.
    pub mechanization: Mechanization,
    /// IMU noise specification.
    pub noise: ImuNoise,
}

impl InsModel {
    /// A WGS-84 NED model with the given noise.
    pub fn wgs84(noise: ImuNoise) -> Self {
        Self { mechanization: Mechanization::Wgs84, noise }
    }

    /// Bias-corrected increments for state `x`.
    pub fn corrected(x: &InsState, u: &ImuInput) -> Increments {
        let c = &u.cur;
        let (dtheta_prev, dvel_prev) = match &u.prev {
            Some(p) => (p.dtheta - x.bg * p.dt, p.dvel - x.ba * p.dt),
            None => (Vector3::zeros(), Vector3::zeros()),
        };
        Increments {
            dtheta_prev,
            dvel_prev,
            dtheta: c.dtheta - x.bg * c.dt,
            dvel: c.dvel - x.ba * c.dt,
            dt: c.dt,
        }
    }

    /// The mechanization step from corrected increments.
    fn propagate_with(&self, x: &InsState, inc: &Increments) -> InsState {
        let nav = Nav { att: x.att, vel: x.vel, pos: x.pos };
        let next = mechanization::step(&self.mechanization, &nav, inc);
        // A Gauss–Markov bias estimate decays towards zero, b⁺ = b·exp(−dt/τ); the other
        // models hold it (see `BiasModel`).
        let decay = match self.noise.bias_model {
            BiasModel::GaussMarkov { tau } if tau > 0.0 => (-inc.dt / tau).exp(),
            _ => 1.0,
        };
        InsState { att: next.att, vel: next.vel, pos: next.pos, bg: x.bg * decay, ba: x.ba * decay }
    }

    /// `Φ` and `Q_d` of the step from corrected increments and `c = R̂`.
    fn jacobians_with(
        &self,
        x: &InsState,
        inc: &Increments,
        c: &Matrix3<f64>,
    ) -> ProcessJacobians<Const<15>> {
        let inc = *inc;
        let dt = inc.dt;
        let (w, f) = if dt > 0.0 {
            (inc.dtheta / dt, inc.dvel / dt)
        } else {
            (Vector3::zeros(), Vector3::zeros())
        };
        // Φ = I + F dt, in place
        let mut Phi = self.error_dynamics_with(x, &w, &f, c);
        Phi *= dt;
        for i in 0..15 {
            Phi[(i, i)] += 1.0;
        }
        // Q_d = (Φ D + D Φᵀ) dt/2: the trapezoid (Φ D Φᵀ + D) dt/2 to second order in dt
        // (they differ by (Φ−I) D (Φ−I)ᵀ dt/2 = O(dt³)). D = G Q_c Gᵀ is block diagonal,
        // so Φ D is Φ's columns scaled (θ, b_g, b_a) and one 3×3 product (v).
        let q = self.noise_psd();
        let d_vv = c * Matrix3::from_diagonal(&Vector3::new(q[3], q[4], q[5])) * c.transpose();
        let f: &[[f64; 15]; 15] = &Phi.data.0;
        let mut pd = [[0.0_f64; 15]; 15];
        for k in 0..3 {
            for r in 0..15 {
                pd[k][r] = f[k][r] * q[k];
                pd[9 + k][r] = f[9 + k][r] * q[6 + k];
                pd[12 + k][r] = f[12 + k][r] * q[9 + k];
                pd[3 + k][r] =
                    f[3][r] * d_vv[(0, k)] + f[4][r] * d_vv[(1, k)] + f[5][r] * d_vv[(2, k)];
            }
        }
        let mut Q = M15::zeros();
        let h = 0.5 * dt;
        for (col, qcol) in Q.data.0.iter_mut().enumerate() {
            for (row, v) in qcol.iter_mut().enumerate() {
                *v = (pd[col][row] + pd[row][col]) * h;
            }
        }
        ProcessJacobians { Phi, Q }
    }

    /// The continuous error-state matrix `F` at `x` with corrected rate `w` (rad/s) and
    /// specific force `f` (m/s²).
    pub fn error_dynamics(&self, x: &InsState, w: &Vector3<f64>, f: &Vector3<f64>) -> M15 {
        self.error_dynamics_with(x, w, f, &x.att.matrix())
    }

    /// [`error_dynamics`](Self::error_dynamics) with the attitude matrix `c = R̂` given.
    fn error_dynamics_with(
        &self,
        x: &InsState,
        w: &Vector3<f64>,
        f: &Vector3<f64>,
        c: &Matrix3<f64>,
    ) -> M15 {
        let mut F = M15::zeros();
        let c = *c;
        let inv_tau = self.noise.inverse_tau();
        put(&mut F, B_TH, B_TH, &(-hat(w)));
        put(&mut F, B_TH, B_BG, &(-Matrix3::identity()));
        put(&mut F, B_V, B_TH, &(-c * hat(f)));
        put(&mut F, B_V, B_BA, &(-c));
        put(&mut F, B_P, B_V, &Matrix3::identity());
        put(&mut F, B_BG, B_BG, &(Matrix3::identity() * -inv_tau));
        put(&mut F, B_BA, B_BA, &(Matrix3::identity() * -inv_tau));
        if let Mechanization::Wgs84 = self.mechanization {
            // Every latitude function of this epoch from one `sin_cos`.
            let (lat, h, v) = (x.pos.lat, x.pos.h, x.vel);
            let (sl, cl) = lat.sin_cos();
            let (rm, rn) = radii_from_sin(sl);
            let (rmh, rnh) = (rm + h, rn + h);
            let t = sl / cl;
            let w_ie = earth_rate_ned_sc(sl, cl);
            let w_en = transport_rate_with(rmh, rnh, t, &v);
            // N_v = ∂ω_en/∂v
            let nv = Matrix3::new(0.0, 1.0 / rnh, 0.0, -1.0 / rmh, 0.0, 0.0, 0.0, -t / rnh, 0.0);
            // D_ie = ∂ω_ie/∂δp (through δφ = δN/(R_M+h))
            let om = crate::earth::OMEGA_IE;
            let d_ie = Matrix3::new(
                -om * sl / rmh,
                0.0,
                0.0, //
                0.0,
                0.0,
                0.0, //
                -om * cl / rmh,
                0.0,
                0.0,
            );
            // D_en = ∂ω_en/∂δp (δφ = δN/(R_M+h), δh = −δD)
            let d_en = Matrix3::new(
                0.0,
                0.0,
                v.y / (rnh * rnh), //
                0.0,
                0.0,
                -v.x / (rmh * rmh), //
                -v.y / (rnh * rmh * (cl * cl)),
                0.0,
                -v.y * t / (rnh * rnh),
            );
            let np = d_ie + d_en;
            put(&mut F, B_TH, B_V, &(-c.transpose() * nv));
            put(&mut F, B_TH, B_P, &(-c.transpose() * np));
            let vx = hat(&v);
            put(&mut F, B_V, B_V, &(-hat(&(w_ie * 2.0 + w_en)) + vx * nv));
            // δg_D = ∂g/∂φ · δN/(R_M+h) − ∂g/∂h · δD
            let (dg_dlat, dg_dh) = normal_gravity_gradient_sc(sl, cl, h);
            let mut gp = Matrix3::zeros();
            gp[(2, 0)] = dg_dlat / rmh;
            gp[(2, 2)] = -dg_dh;
            put(&mut F, B_V, B_P, &(vx * (d_ie * 2.0 + d_en) + gp));
            // The E row keeps dR_N/dφ (in the N row the dR_M/dφ terms cancel).
            let rn_prime = prime_vertical_radius_derivative_sc(sl, cl);
            let fpp = Matrix3::new(
                -v.z / rmh,
                0.0,
                v.x / rmh, //
                v.y * t / rmh - v.y * rn_prime / (rnh * rmh),
                -(v.z / rnh + v.x * t / rmh) + v.x * rn_prime / (rnh * rmh),
                v.y / rnh, //
                0.0,
                0.0,
                0.0,
            );
            put(&mut F, B_P, B_P, &fpp);
        }
        F
    }

    /// Noise input matrix `G` (15×12) for `w = [n_g, n_a, w_bg, w_ba]`:
    /// `δθ̇ ∋ −n_g`, `δv̇ ∋ −R̂ n_a`, `δḃ_g ∋ w_bg`, `δḃ_a ∋ w_ba`.
    pub fn noise_input(att: &So3) -> SMatrix<f64, 15, 12> {
        let mut G = SMatrix::<f64, 15, 12>::zeros();
        G.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-Matrix3::identity()));
        G.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-att.matrix()));
        G.fixed_view_mut::<3, 3>(9, 6).copy_from(&Matrix3::identity());
        G.fixed_view_mut::<3, 3>(12, 9).copy_from(&Matrix3::identity());
        G
    }

    /// Power spectral densities `Q_c = diag(ARW², VRW², q_bg, q_ba)` (12 values).
    pub fn noise_psd(&self) -> nalgebra::SVector<f64, 12> {
        let n = &self.noise;
        let (qbg, qba) = n.bias_psd();
        let mut q = nalgebra::SVector::<f64, 12>::zeros();
        for i in 0..3 {
            q[i] = n.arw[i] * n.arw[i];
            q[3 + i] = n.vrw[i] * n.vrw[i];
            q[6 + i] = qbg[i];
            q[9 + i] = qba[i];
        }
        q
    }

    /// `D = G Q_c Gᵀ` at attitude `att` (block diagonal: θ, v, b_g, b_a).
    pub fn noise_density(&self, att: &So3) -> M15 {
        let q = self.noise_psd();
        let mut D = M15::zeros();
        let g =
            |i: usize| Matrix3::from_diagonal(&Vector3::new(q[3 * i], q[3 * i + 1], q[3 * i + 2]));
        put(&mut D, B_TH, B_TH, &g(0));
        let c = att.matrix();
        // −R̂ diag(VRW²) (−R̂)ᵀ
        put(&mut D, B_V, B_V, &(c * g(1) * c.transpose()));
        put(&mut D, B_BG, B_BG, &g(2));
        put(&mut D, B_BA, B_BA, &g(3));
        D
    }
}

type Cols = [[f64; 15]; 15];

/// Columns padded to 16 rows: four 4-wide vectors each.
type Cols16 = [[f64; 16]; 15];

/// `acc += a·x` over 16 entries; fused in the AVX2+FMA path (without the instruction
/// `mul_add` is a slow library call).
#[inline(always)]
fn axpy16<const FMA: bool>(acc: &mut [f64; 16], x: &[f64; 16], a: f64) {
    for r in 0..16 {
        acc[r] = madd::<FMA>(x[r], a, acc[r]);
    }
}

/// `acc[lo..hi] += a·x[lo..hi]`, fused in the AVX2+FMA path.
#[inline(always)]
fn axpy_range<const FMA: bool>(acc: &mut [f64; 16], x: &[f64; 15], a: f64, lo: usize, hi: usize) {
    for r in lo..hi {
        acc[r] = madd::<FMA>(x[r], a, acc[r]);
    }
}

/// `Φ M` for the INS `Φ` into padded columns, over the non-zero rows of each column of
/// `Φ` only: θ, v and p columns have rows θ v p (0..9), the b_g columns rows θ and their
/// own diagonal, the b_a columns rows v and their diagonal. Each output column is
/// accumulated in a local array that stays in registers (writing partial ranges of a
/// column in memory instead made every step wait on a failed store-to-load forward).
#[inline(always)]
fn times_padded<const FMA: bool>(phi: &Cols, m: &Cols) -> Cols16 {
    // Plain loops, no closures: a closure is a separate function that does not inherit
    // the caller's `target_feature`, and `mul_add` outside it is a library call.
    let mut a: Cols16 = [[0.0; 16]; 15];
    for (acol, mcol) in a.iter_mut().zip(m) {
        let mut acc = [0.0_f64; 16];
        for k in 0..9 {
            // Rows 9..12 of these columns are zero: a 12-row update is three vectors.
            axpy_range::<FMA>(&mut acc, &phi[k], mcol[k], 0, 12);
        }
        for k in 9..12 {
            axpy_range::<FMA>(&mut acc, &phi[k], mcol[k], 0, 3);
            axpy_range::<FMA>(&mut acc, &phi[k], mcol[k], k, k + 1);
        }
        for k in 12..15 {
            axpy_range::<FMA>(&mut acc, &phi[k], mcol[k], 3, 6);
            axpy_range::<FMA>(&mut acc, &phi[k], mcol[k], k, k + 1);
        }
        *acol = acc;
    }
    a
}

fma_kernel! {
    /// `Φ M` for the INS `Φ` (its zero blocks skipped), on nalgebra's column arrays.
    pub fn phi_times(phi: &M15, m: &M15) -> M15 =
        phi_times_kernel / phi_times_avx2 / phi_times_portable
}

#[inline(always)]
fn phi_times_kernel<const FMA: bool>(phi: &M15, m: &M15) -> M15 {
    let a = times_padded::<FMA>(&phi.data.0, &m.data.0);
    let mut out = M15::zeros();
    for (dst, src) in out.data.0.iter_mut().zip(&a) {
        dst.copy_from_slice(&src[..15]);
    }
    out
}

/// `Φ M Φᵀ` for the INS `Φ` and a symmetric `M`, on the raw column arrays: both products
/// are sums of column updates over the non-zero ranges of `Φ` only (≈3,100
/// multiply-adds instead of 6,750), with compile-time lengths so the loops vectorise.
pub fn phi_sandwich(phi: &M15, m: &M15) -> M15 {
    let mut out = M15::zeros();
    phi_sandwich_into(phi, m, &M15::zeros(), &mut out);
    out
}

fma_kernel! {
    /// `out ← Φ M Φᵀ + Q` (symmetrised), without temporaries of the result.
    pub fn phi_sandwich_into(phi: &M15, m: &M15, q: &M15, out: &mut M15) =
        phi_sandwich_kernel / phi_sandwich_avx2 / phi_sandwich_portable
}

#[inline(always)]
fn phi_sandwich_kernel<const FMA: bool>(phi: &M15, m: &M15, q: &M15, out: &mut M15) {
    let f: &Cols = &phi.data.0;
    let a = times_padded::<FMA>(f, &m.data.0);
    // R = A Φᵀ: column j of R is Σ_k A[:, k] Φ[j, k] over the non-zero k of row j of Φ
    // (θ rows: θ v p b_g; v rows: θ v p b_a; p rows: v p; bias rows: the diagonal).
    let mut r: Cols16 = [[0.0; 16]; 15];
    for (j, rcol) in r.iter_mut().enumerate() {
        let mut acc = [0.0_f64; 16];
        let (lo1, hi1, lo2, hi2) = match j / 3 {
            0 => (0, 12, 0, 0),
            1 => (0, 9, 12, 15),
            2 => (3, 9, 0, 0),
            _ => (j, j + 1, 0, 0),
        };
        for k in lo1..hi1 {
            axpy16::<FMA>(&mut acc, &a[k], f[k][j]);
        }
        for k in lo2..hi2 {
            axpy16::<FMA>(&mut acc, &a[k], f[k][j]);
        }
        *rcol = acc;
    }
    // out = (R + Rᵀ)/2 + Q
    let (o, qc): (&mut Cols, &Cols) = (&mut out.data.0, &q.data.0);
    for c in 0..15 {
        for row in 0..15 {
            o[c][row] = 0.5 * (r[c][row] + r[row][c]) + qc[c][row];
        }
    }
}

/// Write a 3×3 block at block position (r, c).
pub fn put(m: &mut M15, r: usize, c: usize, b: &Matrix3<f64>) {
    m.fixed_view_mut::<3, 3>(3 * r, 3 * c).copy_from(b);
}

impl ProcessModel for InsModel {
    type State = InsState;
    type Input = ImuInput;

    /// The kernel writes `(R + Rᵀ)/2 + Q` with `Q` built symmetric.
    const SYMMETRIC_PROPAGATION: bool = true;

    fn propagate(&self, x: &InsState, u: &ImuInput, _dt: f64) -> InsState {
        self.propagate_with(x, &Self::corrected(x, u))
    }

    fn jacobians(&self, x: &InsState, u: &ImuInput, _dt: f64) -> ProcessJacobians<Const<15>> {
        self.jacobians_with(x, &Self::corrected(x, u), &x.att.matrix())
    }

    /// Mechanization and Jacobians sharing the corrected increments and `R̂`.
    fn step(
        &self,
        x: &InsState,
        u: &ImuInput,
        _dt: f64,
    ) -> (InsState, ProcessJacobians<Const<15>>) {
        let inc = Self::corrected(x, u);
        (self.propagate_with(x, &inc), self.jacobians_with(x, &inc, &x.att.matrix()))
    }

    /// `out ← Φ P Φᵀ + Q_d` with the block structure of `Φ` (13 of 25 blocks non-zero,
    /// four of them scalar), written straight into `out`.
    fn propagate_covariance(
        &self,
        P: &Cov<Const<15>>,
        jac: &ProcessJacobians<Const<15>>,
        out: &mut Cov<Const<15>>,
    ) {
        phi_sandwich_into(&jac.Phi, P, &jac.Q, out);
    }
}
