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

use estimator_core::fma_kernel;
use estimator_core::kernels::madd;
use estimator_core::{Cov, ProcessJacobians, ProcessModel};
use manifolds::{hat, So3};
use nalgebra::{Const, Matrix3, SMatrix, Vector3};

use crate::earth::LocalEarth;
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
        // The squares directly rather than through `noise_psd`'s 12-vector: that measured
        // 0.04 µs slower per INS epoch (`epoch_loop`, 0.56 against 0.52 µs).
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

/// The non-zero 3×3 blocks of the continuous error dynamics `F` at one epoch, besides the
/// constant `F_θ,bg = −I` and `F_p,v = I` (the flat-earth model leaves the WGS-84 terms
/// zero).
#[derive(Clone, Copy, Debug)]
struct ErrorBlocks {
    th_th: Matrix3<f64>,
    th_v: Matrix3<f64>,
    th_p: Matrix3<f64>,
    v_th: Matrix3<f64>,
    v_v: Matrix3<f64>,
    v_p: Matrix3<f64>,
    v_ba: Matrix3<f64>,
    p_p: Matrix3<f64>,
    /// `−1/τ` on both bias diagonals (0 for a random walk).
    bias: f64,
}

/// `[recv.method::<0>(args), …, recv.method::<14>(args)]`: the 15 padded columns, each
/// built by a function whose column index is a constant, so that which blocks it holds is
/// settled at compile time (with the index at run time the INS epoch took 0.66 instead
/// of 0.53 µs).
macro_rules! each_column {
    ($recv:ident . $method:ident $args:tt) => {
        each_column!(@ $recv $method $args; 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14)
    };
    (@ $recv:ident $method:ident $args:tt; $($j:literal)*) => {
        [$($recv.$method::<$j> $args),*]
    };
}

impl ErrorBlocks {
    /// Column `J` of `F s`, padded to 16 rows, plus `diag` on the diagonal (the first
    /// value on 0..9, the second on the biases). Built whole, zeros included, so that it
    /// is written as four vectors.
    #[inline(always)]
    fn column<const J: usize>(&self, s: f64, diag: [f64; 2]) -> [f64; 16] {
        let j = J;
        let mut col = [0.0; 16];
        let i = j % 3;
        let mut put = |row_block: usize, b: &Matrix3<f64>| {
            for r in 0..3 {
                col[3 * row_block + r] = b[(r, i)] * s;
            }
        };
        match j / 3 {
            B_TH => {
                put(B_TH, &self.th_th);
                put(B_V, &self.v_th);
            }
            B_V => {
                put(B_TH, &self.th_v);
                put(B_V, &self.v_v);
            }
            B_P => {
                put(B_TH, &self.th_p);
                put(B_V, &self.v_p);
                put(B_P, &self.p_p);
            }
            B_BG => {}
            _ => put(B_V, &self.v_ba),
        }
        match j / 3 {
            B_V => col[6 + i] = s, // F_p,v = I
            B_BG => col[i] = -s,   // F_θ,bg = −I
            _ => {}
        }
        col[j] += if j < 9 { diag[0] } else { diag[1] };
        col
    }

    /// The 15 columns of `F s` plus `diag` (see [`column`](Self::column)).
    #[inline(always)]
    fn columns(&self, s: f64, diag: [f64; 2]) -> Cols16 {
        each_column!(self.column(s, diag))
    }

    /// `Φ = I + F dt` (with `1 + bias·dt` on the bias diagonal) as padded columns.
    #[inline(always)]
    fn phi(&self, dt: f64) -> Cols16 {
        self.columns(dt, [1.0, 1.0 + self.bias * dt])
    }

    /// `F` as a dense matrix.
    fn dense(&self) -> M15 {
        let cols = self.columns(1.0, [0.0, self.bias]);
        M15::from_fn(|r, c| cols[c][r])
    }
}

/// The half-interval noise `E = D dt/2` of the trapezoid, block diagonal: θ, b_g and b_a
/// diagonal, v a full (exactly symmetric) 3×3 block.
#[derive(Clone, Copy, Debug, Default)]
struct HalfNoise {
    th: [f64; 3],
    v: Matrix3<f64>,
    bg: [f64; 3],
    ba: [f64; 3],
}

impl HalfNoise {
    /// `E[row, c]`, or `None` where `E` is zero by its structure (so that, with constant
    /// indices, the zeros cost nothing). Exactly symmetric: the v block is.
    #[inline(always)]
    fn entry(&self, row: usize, c: usize) -> Option<f64> {
        match (row / 3, c / 3) {
            (B_TH, B_TH) if row == c => Some(self.th[c]),
            (B_V, B_V) => Some(self.v[(row - 3, c - 3)]),
            (B_BG, B_BG) if row == c => Some(self.bg[c - 9]),
            (B_BA, B_BA) if row == c => Some(self.ba[c - 12]),
            _ => None,
        }
    }

    /// `P + E` as padded columns.
    fn added_to(&self, P: &M15) -> Cols16 {
        each_column!(self.added_column(&P.data.0))
    }

    /// Column `J` of `P + E` from column `J` of `P`, built whole so that it is written as
    /// four vectors (adding `E` in memory afterwards made the kernel's whole-column reads
    /// wait for single-value writes).
    #[inline(always)]
    fn added_column<const J: usize>(&self, p: &Cols) -> [f64; 16] {
        let mut col = [0.0; 16];
        col[..15].copy_from_slice(&p[J]);
        for (row, x) in col.iter_mut().enumerate().take(15) {
            if let Some(e) = self.entry(row, J) {
                *x += e;
            }
        }
        col
    }

    fn dense(&self) -> M15 {
        M15::from_fn(|r, c| self.entry(r, c).unwrap_or(0.0))
    }
}

type Cols = [[f64; 15]; 15];

/// Columns padded to 16 rows: four 4-wide vectors each.
type Cols16 = [[f64; 16]; 15];

/// `acc[r] += a·x[r]` for `r` in `max(lo, LO)..hi`; fused in the AVX2+FMA path (without
/// the instruction `mul_add` is a slow library call). Every caller passes literal bounds
/// that are multiples of 4, so after inlining the loop is whole vectors.
#[inline(always)]
fn axpy<const FMA: bool, const LO: usize>(
    acc: &mut [f64; 16],
    x: &[f64; 16],
    a: f64,
    lo: usize,
    hi: usize,
) {
    for r in lo.max(LO)..hi {
        acc[r] = madd::<FMA>(x[r], a, acc[r]);
    }
}

/// `Σ_k Φ[:, k] m[k]` from row `LO` (a multiple of 4) down, over the non-zero rows of
/// each column of `Φ` only: the θ columns have rows θ and v (0..6), the v and p columns
/// rows θ v p (0..9), the b_g columns one θ row and their diagonal, the b_a columns the v
/// rows and their diagonal. The sum stays in registers (plain loops, no closures: a
/// closure does not inherit the caller's `target_feature`, and `mul_add` outside it is a
/// library call).
#[inline(always)]
fn phi_combination<const FMA: bool, const LO: usize>(phi: &Cols16, m: &[f64; 16]) -> [f64; 16] {
    let mut acc = [0.0_f64; 16];
    for k in 0..3 {
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 0, 8);
    }
    for k in 3..9 {
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 0, 12);
    }
    for k in 9..12 {
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 0, 4);
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 8, 12);
    }
    for k in 12..15 {
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 0, 8);
        axpy::<FMA, LO>(&mut acc, &phi[k], m[k], 12, 16);
    }
    acc
}

/// `Σ_k M[:, k] Φ[j, k]`, column `j` of `M Φᵀ`, over the non-zero entries of row `j` of
/// `Φ` only (θ rows: θ v p and one b_g; v rows: θ v p b_a; p rows: v p; bias rows: the
/// diagonal).
#[inline(always)]
fn times_row<const FMA: bool>(m: &Cols16, phi: &Cols16, j: usize) -> [f64; 16] {
    let mut acc = [0.0_f64; 16];
    let (first, second) = match j / 3 {
        0 => ((0, 9), (j + 9, j + 10)),
        1 => ((0, 9), (12, 15)),
        2 => ((3, 9), (0, 0)),
        _ => ((j, j + 1), (0, 0)),
    };
    for (lo, hi) in [first, second] {
        for k in lo..hi {
            axpy::<FMA, 0>(&mut acc, &m[k], phi[k][j], 0, 16);
        }
    }
    acc
}

/// Fill the 15 columns of `buf` with `column(j)` without zeroing them first, and return
/// them. (Zeroing the arrays and returning them by value cost 6 % of an INS epoch.)
macro_rules! fill_columns {
    ($buf:expr, |$j:ident| $column:expr) => {{
        let cols = $buf.as_mut_ptr().cast::<[f64; 16]>();
        for $j in 0..15 {
            let column: [f64; 16] = $column;
            // SAFETY: `$j < 15`, a column of the array.
            unsafe { cols.add($j).write(column) };
        }
        // SAFETY: all 15 columns were written.
        unsafe { $buf.assume_init_ref() }
    }};
}

/// `out ← Φ M Φᵀ` for `M` (symmetric) in padded columns: `Aᵀ = M Φᵀ` over the non-zeros
/// of `Φ`'s rows (90 of 225), then `R = Φ Aᵀ` over the non-zero rows of `Φ`'s columns,
/// lower triangle only, mirrored, so the result is exactly symmetric. About 670
/// four-wide multiply-adds.
#[inline(always)]
fn sandwich_body<const FMA: bool, A: Addend>(phi: &Cols16, m: &Cols16, add: &A, out: &mut Cols) {
    let mut buf = core::mem::MaybeUninit::<Cols16>::uninit();
    let at = fill_columns!(buf, |j| times_row::<FMA>(m, phi, j));
    let mut buf = core::mem::MaybeUninit::<Cols16>::uninit();
    let r = fill_columns!(buf, |j| match j {
        0..=3 => phi_combination::<FMA, 0>(phi, &at[j]),
        4..=7 => phi_combination::<FMA, 4>(phi, &at[j]),
        8..=11 => phi_combination::<FMA, 8>(phi, &at[j]),
        _ => phi_combination::<FMA, 12>(phi, &at[j]),
    });
    mirror_blocks(r, add, out);
}

/// A symmetric matrix added to the sandwich as its blocks are written.
trait Addend {
    /// Rows `r0..r0 + 4` of column `c` (row 15, past the end, as zero).
    fn segment(&self, r0: usize, c: usize) -> [f64; 4];
}

impl Addend for HalfNoise {
    #[inline(always)]
    fn segment(&self, r0: usize, c: usize) -> [f64; 4] {
        // (a plain loop: a closure does not inherit the kernel's `target_feature`)
        let mut seg = [0.0; 4];
        for (i, x) in seg.iter_mut().enumerate() {
            *x = self.entry(r0 + i, c).unwrap_or(0.0);
        }
        seg
    }
}

impl Addend for M15 {
    #[inline(always)]
    fn segment(&self, r0: usize, c: usize) -> [f64; 4] {
        let mut seg = [0.0; 4];
        let col = &self.data.0[c];
        let n = (15 - r0).min(4);
        seg[..n].copy_from_slice(&col[r0..r0 + n]);
        seg
    }
}

/// `out = L + Lᵀ − diag(L) + A` from the lower triangle `L` of `r` (valid from row
/// `4⌊c/4⌋` of column `c` down) and a symmetric addend `A`, written in 4×4 blocks of
/// whole vectors: blocks below the diagonal copied, blocks above it transposed from
/// their mirror images, diagonal blocks blended from both, the addend added on the way.
/// (Mirroring value by value, 240 single stores, then adding `E` in memory took 0.017 µs
/// more per INS epoch: `epoch_loop`, best of 11.)
#[inline(always)]
fn mirror_blocks<A: Addend>(r: &Cols16, add: &A, out: &mut Cols) {
    let flat = out.as_flattened_mut();
    // Column block by column block, the bottom block first: its four-row stores reach one
    // row into the next column, whose top block is written afterwards.
    macro_rules! blocks {
        ($($cb:literal: $($rb:literal)*;)*) => {
            $($(mirror_block::<$cb, $rb, A>(r, add, flat);)*)*
        };
    }
    blocks! { 0: 3 2 1 0; 1: 3 2 1 0; 2: 3 2 1 0; 3: 3 2 1 0; }
}

/// Block `(RB, CB)` of [`mirror_blocks`] (rows `4 RB..`, columns `4 CB..`).
#[inline(always)]
fn mirror_block<const CB: usize, const RB: usize, A: Addend>(
    r: &Cols16,
    add: &A,
    flat: &mut [f64],
) {
    let (c0, r0) = (4 * CB, 4 * RB);
    let w = if CB == 3 { 3 } else { 4 };
    let mut blk = [[0.0f64; 4]; 4];
    if RB > CB {
        for (j, b) in blk.iter_mut().enumerate().take(w) {
            b.copy_from_slice(&r[c0 + j][r0..r0 + 4]);
        }
    } else {
        let mut a = [[0.0f64; 4]; 4];
        let (src, rows) = if RB < CB { (r0, 4) } else { (c0, w) };
        for (i, x) in a.iter_mut().enumerate().take(rows) {
            x.copy_from_slice(&r[src + i][c0..c0 + 4]);
        }
        for (j, b) in blk.iter_mut().enumerate() {
            for (i, x) in b.iter_mut().enumerate() {
                // above the diagonal (the whole block, or the diagonal block's upper
                // part): the mirror image
                *x = if RB < CB || i < j { a[i][j] } else { a[j][i] };
            }
        }
    }
    for (j, b) in blk.iter().enumerate().take(w) {
        let e = add.segment(r0, c0 + j);
        let mut v = [0.0; 4];
        for i in 0..4 {
            v[i] = b[i] + e[i];
        }
        let at = (c0 + j) * 15 + r0;
        if at + 4 <= 225 {
            flat[at..at + 4].copy_from_slice(&v);
        } else {
            flat[at..225].copy_from_slice(&v[..225 - at]);
        }
    }
}

fma_kernel! {
    /// `out ← Φ M Φᵀ + E` for `Φ` and `M` in padded columns.
    fn sandwich_padded(phi: &Cols16, m: &Cols16, e: &HalfNoise, out: &mut M15) =
        sandwich_padded_kernel / sandwich_padded_avx2 / sandwich_padded_portable
}

#[inline(always)]
fn sandwich_padded_kernel<const FMA: bool>(phi: &Cols16, m: &Cols16, e: &HalfNoise, out: &mut M15) {
    sandwich_body::<FMA, _>(phi, m, e, &mut out.data.0);
}

/// A matrix as padded columns.
fn padded(m: &M15) -> Cols16 {
    let mut p: Cols16 = [[0.0; 16]; 15];
    for (dst, src) in p.iter_mut().zip(&m.data.0) {
        dst[..15].copy_from_slice(src);
    }
    p
}

fma_kernel! {
    /// `Φ M` for the INS `Φ` (its zero blocks skipped), on nalgebra's column arrays.
    pub fn phi_times(phi: &M15, m: &M15) -> M15 =
        phi_times_kernel / phi_times_avx2 / phi_times_portable
}

#[inline(always)]
fn phi_times_kernel<const FMA: bool>(phi: &M15, m: &M15) -> M15 {
    let (phi, m) = (padded(phi), padded(m));
    let mut buf = core::mem::MaybeUninit::<Cols16>::uninit();
    let a = fill_columns!(buf, |c| phi_combination::<FMA, 0>(&phi, &m[c]));
    M15::from_fn(|r, c| a[c][r])
}

/// `Φ M Φᵀ` for the INS `Φ` and a symmetric `M`: both products run over the non-zeros of
/// `Φ` only (about 2,700 multiply-adds, many of them on padding, instead of 6,750), with
/// compile-time lengths so the loops vectorise.
pub fn phi_sandwich(phi: &M15, m: &M15) -> M15 {
    let mut out = M15::zeros();
    phi_sandwich_into(phi, m, &M15::zeros(), &mut out);
    out
}

fma_kernel! {
    /// `out ← Φ M Φᵀ + Q`, the product's lower triangle mirrored (exactly symmetric when
    /// `Q` is).
    pub fn phi_sandwich_into(phi: &M15, m: &M15, q: &M15, out: &mut M15) =
        phi_sandwich_kernel / phi_sandwich_avx2 / phi_sandwich_portable
}

#[inline(always)]
fn phi_sandwich_kernel<const FMA: bool>(phi: &M15, m: &M15, q: &M15, out: &mut M15) {
    sandwich_body::<FMA, _>(&padded(phi), &padded(m), q, &mut out.data.0);
}

impl ProcessModel for InsModel {
    type State = InsState;
    type Input = ImuInput;

    /// The kernel mirrors one triangle, so its result is exactly symmetric.
    const SYMMETRIC_PROPAGATION: bool = true;

    fn propagate(&self, x: &InsState, u: &ImuInput, _dt: f64) -> InsState {
        let (inc, c, earth) = Self::shared(x, u);
        self.propagate_with(x, &inc, &c, &earth)
    }

    /// `Φ = I + F dt` and `Q_d = (Φ D Φᵀ + D) dt/2`, expanded to dense matrices.
    fn jacobians(&self, x: &InsState, u: &ImuInput, _dt: f64) -> ProcessJacobians<Const<15>> {
        let (inc, c, earth) = Self::shared(x, u);
        self.jacobians_with(x, &inc, &c, &earth)
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

    /// The whole epoch without forming `Φ` or `Q_d` as dense matrices: the non-zero
    /// blocks of `F` go straight into `Φ`'s padded columns, and the trapezoid's noise is
    /// folded in as `out ← Φ (P + E) Φᵀ + E` with the block-diagonal `E = D dt/2`.
    fn step_covariance(
        &self,
        x: &InsState,
        u: &ImuInput,
        _dt: f64,
        P: &Cov<Const<15>>,
        out: &mut Cov<Const<15>>,
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
        next
    }
}
