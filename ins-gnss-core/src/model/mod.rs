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
//! Discretisation: `Φ = I + F dt` and the trapezoid `Q_d = (Φ D Φᵀ + D) dt/2`
//! (ALGORITHMS.md §1) with
//! `D = G Q_c Gᵀ = blockdiag(diag(ARW²), R̂ diag(VRW²) R̂ᵀ, 0, diag(q_bg), diag(q_ba))`.
//! With the block-diagonal `E = D dt/2` the whole prediction is
//! `P⁻ = Φ (P + E) Φᵀ + E`: one structured product and two block-diagonal additions, so
//! [`InsModel`]'s fused `step_covariance` never forms `Q_d` (nor `Φ` as a dense matrix).

use estimator_core::{Cov, ProcessJacobians, ProcessModel};
use manifolds::{hat, So3};
use nalgebra::{Const, Matrix3, SMatrix, Vector3};

use crate::earth::LocalEarth;
use crate::imu::{BiasModel, ImuNoise, ImuSample};
use crate::mechanization::{self, Increments, Mechanization, Nav};
use crate::state::InsState;

/// `[recv.method::<0>(args), …, recv.method::<14>(args)]`: the 15 padded columns, each
/// built by a function whose column index is a constant, so that which blocks it holds is
/// settled at compile time (measured faster than a run-time index: `docs/history/benches.md`).
macro_rules! each_column {
    ($recv:ident . $method:ident $args:tt) => {
        each_column!(@ $recv $method $args; 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14)
    };
    (@ $recv:ident $method:ident $args:tt; $($j:literal)*) => {
        [$($recv.$method::<$j> $args),*]
    };
}

mod error_blocks;
mod kernel;
mod noise;

use error_blocks::ErrorBlocks;
pub use kernel::{
    adjoint_sandwich_into, phi_sandwich, phi_sandwich_into, phi_times, times_phi_into,
};
pub use kernel::{phi_sandwich_avx2, phi_sandwich_portable, phi_times_avx2, phi_times_portable};
use kernel::{sandwich_padded, Cols, Cols16};
use noise::HalfNoise;

/// 15×15 matrices of the error state.
pub type M15 = SMatrix<f64, 15, 15>;

/// Block index of the attitude error in the kernels' blocks of 3 rows ([`InsState`]'s
/// named blocks `ATT`, `VEL`, `POS`, `BG`, `BA`, whose rows they are).
pub const B_TH: usize = InsState::ATT.start() / 3;
/// Block index of the velocity error (`InsState::VEL`).
pub const B_V: usize = InsState::VEL.start() / 3;
/// Block index of the position error (`InsState::POS`).
pub const B_P: usize = InsState::POS.start() / 3;
/// Block index of the gyro-bias error (`InsState::BG`).
pub const B_BG: usize = InsState::BG.start() / 3;
/// Block index of the accelerometer-bias error (`InsState::BA`).
pub const B_BA: usize = InsState::BA.start() / 3;

/// The input of one prediction: the previous and the current raw IMU samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuInput {
    /// The sample before (for coning and sculling); `None` at start-up.
    pub prev: Option<ImuSample>,
    /// The sample that ends this interval.
    pub cur: ImuSample,
}

impl ImuInput {
    /// Fold this input into `sum`, the combined input of a stretch of samples taken as
    /// one covariance step (`None` at the stretch's first sample; the combination is
    /// [`ImuSample::add_to_stretch`], with no sample before): the INS models'
    /// [`ProcessModel::fold_input`].
    pub fn fold_into(&self, sum: &mut Option<ImuInput>) {
        let s = &self.cur;
        let open = || ImuInput { prev: None, cur: s.stretch_opening() };
        sum.get_or_insert_with(open).cur.add_to_stretch(s);
    }
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

    /// What the mechanization and the Jacobians of one epoch share: the corrected
    /// increments, `R̂` and the Earth functions at `x`.
    #[inline(always)]
    fn shared(x: &InsState, u: &ImuInput) -> (Increments, Matrix3<f64>, LocalEarth) {
        (Self::corrected(x, u), x.att.matrix(), LocalEarth::at(&x.pos))
    }

    /// The mechanization step from corrected increments, with `R̂` and the Earth functions
    /// at `x` given.
    fn propagate_with(
        &self,
        x: &InsState,
        inc: &Increments,
        c: &Matrix3<f64>,
        earth: &LocalEarth,
    ) -> InsState {
        let nav = Nav { att: x.att, vel: x.vel, pos: x.pos };
        let next = match &self.mechanization {
            Mechanization::Wgs84 => mechanization::wgs84_step_with(&nav, inc, c, earth),
            other => mechanization::step(other, &nav, inc),
        };
        // A Gauss–Markov bias estimate decays towards zero, b⁺ = b·exp(−dt/τ); the other
        // models hold it (see `BiasModel`).
        let decay = match self.noise.bias_model {
            BiasModel::GaussMarkov { tau } if tau > 0.0 => (-inc.dt / tau).exp(),
            _ => 1.0,
        };
        InsState { att: next.att, vel: next.vel, pos: next.pos, bg: x.bg * decay, ba: x.ba * decay }
    }

    /// The blocks of `F` for the step from corrected increments (rate and specific force
    /// are the increments over the interval).
    fn transition_blocks(
        &self,
        x: &InsState,
        inc: &Increments,
        c: &Matrix3<f64>,
        earth: &LocalEarth,
    ) -> ErrorBlocks {
        let dt = inc.dt;
        let (w, f) = if dt > 0.0 {
            (inc.dtheta / dt, inc.dvel / dt)
        } else {
            (Vector3::zeros(), Vector3::zeros())
        };
        self.error_blocks(x, &w, &f, c, earth)
    }

    /// `Φ` and `Q_d = Φ E Φᵀ + E` as dense matrices.
    fn jacobians_with(
        &self,
        x: &InsState,
        inc: &Increments,
        c: &Matrix3<f64>,
        earth: &LocalEarth,
    ) -> ProcessJacobians<Const<15>> {
        let b = self.transition_blocks(x, inc, c, earth);
        let phi = b.phi(inc.dt);
        let e = self.half_noise(c, inc.dt);
        let mut Q = M15::zeros();
        sandwich_padded(&phi, &e.added_to(&M15::zeros()), &e, &mut Q);
        ProcessJacobians { Phi: M15::from_fn(|r, c| phi[c][r]), Q }
    }

    /// `E = D dt/2`, the half-interval noise of the trapezoid, with
    /// `D = G Q_c Gᵀ = blockdiag(diag(ARW²), R̂ diag(VRW²) R̂ᵀ, 0, diag(q_bg), diag(q_ba))`.
    fn half_noise(&self, c: &Matrix3<f64>, dt: f64) -> HalfNoise {
        // The squares directly rather than through `noise_psd`'s 12-vector (measured
        // slower: `docs/history/benches.md`).
        let n = &self.noise;
        let h = 0.5 * dt;
        let (qbg, qba) = n.bias_psd();
        let qv = n.vrw.component_mul(&n.vrw) * h;
        // R̂ diag(qv) R̂ᵀ, its lower triangle computed and mirrored so it is exactly symmetric
        let mut v = Matrix3::zeros();
        for i in 0..3 {
            for j in 0..=i {
                let e = c[(i, 0)] * c[(j, 0)] * qv.x
                    + c[(i, 1)] * c[(j, 1)] * qv.y
                    + c[(i, 2)] * c[(j, 2)] * qv.z;
                v[(i, j)] = e;
                v[(j, i)] = e;
            }
        }
        HalfNoise {
            th: (n.arw.component_mul(&n.arw) * h).into(),
            v,
            bg: (qbg * h).into(),
            ba: (qba * h).into(),
        }
    }

    /// The continuous error-state matrix `F` at `x` with corrected rate `w` (rad/s) and
    /// specific force `f` (m/s²).
    pub fn error_dynamics(&self, x: &InsState, w: &Vector3<f64>, f: &Vector3<f64>) -> M15 {
        self.error_blocks(x, w, f, &x.att.matrix(), &LocalEarth::at(&x.pos)).dense()
    }

    /// The non-zero blocks of `F`, with `c = R̂` and the Earth functions at `x`.
    fn error_blocks(
        &self,
        x: &InsState,
        w: &Vector3<f64>,
        f: &Vector3<f64>,
        c: &Matrix3<f64>,
        earth: &LocalEarth,
    ) -> ErrorBlocks {
        let c = *c;
        let mut b = ErrorBlocks {
            th_th: -hat(w),
            th_v: Matrix3::zeros(),
            th_p: Matrix3::zeros(),
            v_th: -c * hat(f),
            v_v: Matrix3::zeros(),
            v_p: Matrix3::zeros(),
            v_ba: -c,
            p_p: Matrix3::zeros(),
            bias: -self.noise.inverse_tau(),
        };
        if let Mechanization::Wgs84 = self.mechanization {
            let v = x.vel;
            let e = earth;
            let (sl, cl, t) = (e.sin, e.cos, e.tan);
            let (irm, irn) = (e.inv_rmh, e.inv_rnh);
            let w_ie = e.earth_rate();
            let w_en = e.transport_rate(&v);
            // N_v = ∂ω_en/∂v
            let nv = Matrix3::new(0.0, irn, 0.0, -irm, 0.0, 0.0, 0.0, -t * irn, 0.0);
            // D_ie = ∂ω_ie/∂δp (through δφ = δN/(R_M+h))
            let om = crate::earth::OMEGA_IE;
            let d_ie =
                Matrix3::new(-om * sl * irm, 0.0, 0.0, 0.0, 0.0, 0.0, -om * cl * irm, 0.0, 0.0);
            // D_en = ∂ω_en/∂δp (δφ = δN/(R_M+h), δh = −δD)
            let d_en = Matrix3::new(
                0.0,
                0.0,
                v.y * irn * irn, //
                0.0,
                0.0,
                -v.x * irm * irm, //
                -v.y * irn * irm * e.sec * e.sec,
                0.0,
                -v.y * t * irn * irn,
            );
            let np = d_ie + d_en;
            b.th_v = -c.transpose() * nv;
            b.th_p = -c.transpose() * np;
            let vx = hat(&v);
            b.v_v = -hat(&(w_ie * 2.0 + w_en)) + vx * nv;
            // δg_D = ∂g/∂φ · δN/(R_M+h) − ∂g/∂h · δD
            let (dg_dlat, dg_dh) = e.gravity_gradient();
            let mut gp = Matrix3::zeros();
            gp[(2, 0)] = dg_dlat * irm;
            gp[(2, 2)] = -dg_dh;
            b.v_p = vx * (d_ie * 2.0 + d_en) + gp;
            // The E row keeps dR_N/dφ (in the N row the dR_M/dφ terms cancel).
            let rn_prime = e.rn_prime();
            b.p_p = Matrix3::new(
                -v.z * irm,
                0.0,
                v.x * irm, //
                v.y * t * irm - v.y * rn_prime * irn * irm,
                -(v.z * irn + v.x * t * irm) + v.x * rn_prime * irn * irm,
                v.y * irn, //
                0.0,
                0.0,
                0.0,
            );
        }
        b
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
        // E = D dt/2 with dt = 2
        self.half_noise(&att.matrix(), 2.0).dense()
    }
}

impl InsModel {
    /// The whole epoch without forming `Φ` or `Q_d` as dense matrices: the non-zero
    /// blocks of `F` go straight into `Φ`'s padded columns, and the trapezoid's noise is
    /// folded in as `out ← Φ (P + E) Φᵀ + E` with the block-diagonal `E = D dt/2`; `Φᵀ`
    /// copied into `phi_t` when asked (a smoother's replay).
    #[allow(non_snake_case)]
    #[inline(always)]
    fn fused_step(
        &self,
        x: &InsState,
        u: &ImuInput,
        P: &Cov<Const<15>>,
        out: &mut Cov<Const<15>>,
        phi_t: Option<&mut Cov<Const<15>>>,
    ) -> InsState {
        let (inc, c, earth) = Self::shared(x, u);
        let b = self.transition_blocks(x, &inc, &c, &earth);
        let phi = b.phi(inc.dt);
        let e = self.half_noise(&c, inc.dt);
        let m = e.added_to(P);
        // The mechanization between writing Φ and P + E and reading them lets the stores
        // drain before the kernel loads whole columns.
        let next = self.propagate_with(x, &inc, &c, &earth);
        sandwich_padded(&phi, &m, &e, out);
        if let Some(phi_t) = phi_t {
            copy_transposed(&phi, phi_t);
        }
        next
    }
}

/// `Φᵀ` from the padded columns of `Φ`: `Φᵀ[(r, c)] = Φ[(c, r)] = phi[r][c]` (column `c` of
/// `Φᵀ` is row `c` of `Φ`). In 4 × 4 blocks read four values at a time, as the columns
/// were just written (reading them value by value waited on those wide stores).
#[inline(always)]
fn copy_transposed(phi: &Cols16, phi_t: &mut Cov<Const<15>>) {
    let dst = &mut phi_t.data.0;
    for r0 in (0..15).step_by(4) {
        let rows = (15 - r0).min(4);
        for c0 in (0..16).step_by(4) {
            let mut a = [[0.0f64; 4]; 4];
            for (i, ai) in a.iter_mut().enumerate().take(rows) {
                ai.copy_from_slice(&phi[r0 + i][c0..c0 + 4]);
            }
            for j in 0..(15 - c0).min(4) {
                let col = &mut dst[c0 + j];
                for (i, ai) in a.iter().enumerate().take(rows) {
                    col[r0 + i] = ai[j];
                }
            }
        }
    }
}

impl ProcessModel for InsModel {
    type State = InsState;
    type Input = ImuInput;

    /// The kernel mirrors one triangle, so its result is exactly symmetric.
    const SYMMETRIC_PROPAGATION: bool = true;

    /// `step_covariance` folds the trapezoid noise in without forming `Q_d`; the noise is
    /// a function of [`ImuNoise`] (non-negative densities, checked where a configuration
    /// is read) and the harness checks the dense `Q_d`.
    const FUSED_STEP_COVARIANCE: bool = true;

    fn propagate(&self, x: &InsState, u: &ImuInput, _dt: f64) -> InsState {
        let (inc, c, earth) = Self::shared(x, u);
        self.propagate_with(x, &inc, &c, &earth)
    }

    /// `Φ = I + F dt` and `Q_d = (Φ D Φᵀ + D) dt/2`, expanded to dense matrices.
    fn jacobians(&self, x: &InsState, u: &ImuInput, _dt: f64) -> ProcessJacobians<Const<15>> {
        let (inc, c, earth) = Self::shared(x, u);
        self.jacobians_with(x, &inc, &c, &earth)
    }

    /// `Φ` without `Q_d`.
    fn transition(&self, x: &InsState, u: &ImuInput, _dt: f64) -> M15 {
        let (inc, c, earth) = Self::shared(x, u);
        let phi = self.transition_blocks(x, &inc, &c, &earth).phi(inc.dt);
        M15::from_fn(|r, c| phi[c][r])
    }

    /// Mechanization and Jacobians sharing the corrected increments, `R̂` and the Earth
    /// functions.
    fn step(
        &self,
        x: &InsState,
        u: &ImuInput,
        _dt: f64,
    ) -> (InsState, ProcessJacobians<Const<15>>) {
        let (inc, c, earth) = Self::shared(x, u);
        (self.propagate_with(x, &inc, &c, &earth), self.jacobians_with(x, &inc, &c, &earth))
    }

    /// `out ← Φ P Φᵀ + Q` with the block structure of `Φ` (13 of 25 blocks non-zero, four
    /// of them scalar).
    fn propagate_covariance(
        &self,
        P: &Cov<Const<15>>,
        jac: &ProcessJacobians<Const<15>>,
        out: &mut Cov<Const<15>>,
    ) {
        phi_sandwich_into(&jac.Phi, P, &jac.Q, out);
    }

    /// The whole epoch without forming `Φ` or `Q_d` as dense matrices
    /// (`fused_step`).
    fn step_covariance(
        &self,
        x: &InsState,
        u: &ImuInput,
        _dt: f64,
        P: &Cov<Const<15>>,
        out: &mut Cov<Const<15>>,
    ) -> InsState {
        self.fused_step(x, u, P, out, None)
    }

    /// The fused step, `Φᵀ` copied out of the columns it already formed.
    fn step_covariance_adjoint(
        &self,
        x: &InsState,
        u: &ImuInput,
        _dt: f64,
        P: &Cov<Const<15>>,
        out: &mut Cov<Const<15>>,
        phi_t: &mut Cov<Const<15>>,
    ) -> InsState {
        self.fused_step(x, u, P, out, Some(phi_t))
    }

    /// `Φᵀ` from the error blocks (no `Q_d`, no mechanization).
    fn transition_transposed(
        &self,
        x: &InsState,
        u: &ImuInput,
        _dt: f64,
        phi_t: &mut Cov<Const<15>>,
    ) {
        let (inc, c, earth) = Self::shared(x, u);
        self.transition_blocks(x, &inc, &c, &earth).phi_transposed_into(inc.dt, phi_t);
    }

    /// `Q_d v = Φ (E (Φᵀ v)) + E v`: one product with `Φ` and two with the
    /// block-diagonal `E` (`Q_d` is never formed).
    fn noise_times(
        &self,
        x: &InsState,
        u: &ImuInput,
        _dt: f64,
        phi_t: &Cov<Const<15>>,
        v: &nalgebra::SVector<f64, 15>,
        phi_t_v: &nalgebra::SVector<f64, 15>,
        out: &mut nalgebra::SVector<f64, 15>,
    ) {
        let e = self.half_noise(&x.att.matrix(), u.cur.dt);
        let ew = nalgebra::SVector::<f64, 15>::from(e.times(phi_t_v.as_slice()));
        phi_t.tr_mul_to(&ew, out);
        let ev = e.times(v.as_slice());
        for (o, a) in out.iter_mut().zip(ev) {
            *o += a;
        }
    }

    /// `Φᵀ Λ Φ` over the non-zero blocks of `Φ` (the prediction's kernel, transposed).
    fn adjoint_sandwich(
        &self,
        phi_t: &Cov<Const<15>>,
        lambda: &Cov<Const<15>>,
        out: &mut Cov<Const<15>>,
    ) {
        adjoint_sandwich_into(phi_t, lambda, out);
    }

    fn fold_input(&self, sum: &mut Option<ImuInput>, u: &ImuInput) -> bool {
        u.fold_into(sum);
        true
    }

    /// `M Φ` over the non-zeros of `Φ`'s columns.
    fn times_transition(
        &self,
        m: &Cov<Const<15>>,
        phi_t: &Cov<Const<15>>,
        out: &mut Cov<Const<15>>,
    ) {
        times_phi_into(m, phi_t, out);
    }
}
