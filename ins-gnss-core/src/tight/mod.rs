//! Tight coupling: the INS error state with the receiver clock, and per-satellite
//! pseudorange and range-rate (Doppler) updates with the lever arm.
//!
//! State `[δθ, δv, δp, δb_g, δb_a, δ(c·dt), δ(c·ḋt), δisb_E, δisb_C, δisb_J]` (20): the
//! 15-state INS, the receiver clock bias (m) and drift (m/s) of GPS time, and the
//! inter-system biases (m) of Galileo, BeiDou and QZSS against GPS (random walks; they
//! stay at their prior when only GPS is seen). The clock is a two-state random walk:
//! `Φ_c = [[1, Δt], [0, 1]]`, `Q_c = [[q_b Δt + q_d Δt³/3, q_d Δt²/2], [q_d Δt²/2, q_d Δt]]`.
//!
//! Measurements, per satellite (each its own stream, so the gate and the noise strategy
//! judge each satellite alone):
//! - pseudorange `P = |r_s − r_a| + ω_e (x_s y_a − y_s x_a)/c + c·dt + isb − c·dt_s + I + T`,
//!   `H = [u_nᵀ R̂[l×], 0, −u_nᵀ, 0, 0, 1, 0, e_k]`;
//! - range rate `−λ·D = u·(v_s − v_a) + (Sagnac rate) + c·ḋt − c·ḋt_s`,
//!   `H = [u_nᵀ R̂[(ω×l)×], −u_nᵀ, 0, −u_nᵀ R̂[l×], 0, 0, 1, 0]`,
//!
//! with `u_n` the unit vector antenna → satellite in NED, `r_a` the antenna (the IMU
//! position plus `R̂ l`). The Sagnac term's and the Earth rate's dependence on the state
//! (below 1e-6 of the other terms) is left out of `H`.

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use estimator_core::{
    JacobiansOf, MeasurementJacobians, MeasurementModel, ProcessJacobians, ProcessModel, StreamId,
};
use manifolds::{composite_state, hat, Manifold, R2, R3};
use nalgebra::{Const, Matrix3, SMatrix, SVector, Vector1, Vector3};

use crate::earth::{ecef_to_ned_rotation, geodetic_to_ecef, LocalEarth};
use crate::model::{ImuInput, InsModel};
use crate::scale::{InsModel21, InsState21, M21};
use crate::state::InsState;
use ::gnss::ephemeris::C;
use ::gnss::spp::{geometry, range_rate, Prepared};
use ::gnss::{Sat, System};

mod measurements;

pub use measurements::*;

composite_state! {
    /// The INS state with the receiver clock and the inter-system biases: the nominal
    /// state of the tightly coupled filter. Tangent dimension `Const<20>`; blocks `NAV`
    /// (15), `CLOCK` (bias m, drift m/s), `ISB` (Galileo, BeiDou, QZSS − GPS, m).
    pub struct InsStateTc {
        /// Attitude, velocity, position, biases.
        pub nav: InsState => NAV,
        /// Receiver clock bias `c·dt` (m) and drift `c·ḋt` (m/s).
        pub clock: R2 => CLOCK,
        /// Inter-system biases of Galileo, BeiDou, QZSS against GPS, m.
        pub isb: R3 => ISB,
    }
}

/// 20×20 matrices of the tightly coupled error state.
pub type M20 = SMatrix<f64, 20, 20>;

/// Index of the clock bias in the error state.
pub const CLOCK_BIAS: usize = InsStateTc::CLOCK.start();
/// Index of the clock drift.
pub const CLOCK_DRIFT: usize = InsStateTc::CLOCK.start() + 1;
/// Index of the first inter-system bias.
pub const ISB: usize = InsStateTc::ISB.start();

// The navigation blocks' offsets inside the tight error state.
const ATT: usize = InsStateTc::NAV.start() + InsState::ATT.start();
const VEL: usize = InsStateTc::NAV.start() + InsState::VEL.start();
const POS: usize = InsStateTc::NAV.start() + InsState::POS.start();
const BG: usize = InsStateTc::NAV.start() + InsState::BG.start();
const BA: usize = InsStateTc::NAV.start() + InsState::BA.start();

/// The inter-system bias index of a system (`None` for GPS, the reference).
pub fn isb_index(sys: System) -> Option<usize> {
    match sys {
        System::Galileo => Some(0),
        System::BeiDou => Some(1),
        System::Qzss => Some(2),
        _ => None,
    }
}

/// Receiver clock noise densities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClockNoise {
    /// White noise on the bias, m/√s.
    pub bias: f64,
    /// Random walk of the drift, m/s/√s.
    pub drift: f64,
    /// Random walk of the inter-system biases, m/√s.
    pub isb: f64,
}

impl Default for ClockNoise {
    /// A TCXO of a consumer receiver (h₀ ≈ 2e-19, h₋₂ ≈ 2e-20): 0.1 m/√s, 0.2 m/s/√s; the
    /// inter-system biases nearly constant, 1e-3 m/√s.
    fn default() -> Self {
        Self { bias: 0.1, drift: 0.2, isb: 1e-3 }
    }
}

/// The tightly coupled process model: the 15-state [`InsModel`] and the clock.
#[derive(Clone, Debug)]
pub struct InsModelTc {
    /// The INS.
    pub base: InsModel,
    /// The clock.
    pub clock: ClockNoise,
}

/// The receiver clock (bias, drift) after `dt`: the bias grows by the drift.
fn clock_after(clock: &R2, dt: f64) -> R2 {
    R2::new(clock[0] + clock[1] * dt, clock[1])
}

impl InsModelTc {
    fn next(&self, x: &InsStateTc, nav: InsState, dt: f64) -> InsStateTc {
        InsStateTc { nav, clock: clock_after(&x.clock, dt), isb: x.isb }
    }

    /// The clock and bias blocks of `Q_d` over `dt` (rows/columns 15..20).
    fn clock_q(&self, dt: f64) -> SMatrix<f64, 5, 5> {
        clock_q(&self.clock, dt)
    }
}

/// `Q_d` of the clock (bias, drift) and the inter-system biases over `dt`.
fn clock_q(clock: &ClockNoise, dt: f64) -> SMatrix<f64, 5, 5> {
    let (qb, qd) = (clock.bias.powi(2), clock.drift.powi(2));
    let mut q = SMatrix::<f64, 5, 5>::zeros();
    q[(0, 0)] = qb * dt + qd * dt.powi(3) / 3.0;
    q[(0, 1)] = qd * dt * dt / 2.0;
    q[(1, 0)] = q[(0, 1)];
    q[(1, 1)] = qd * dt;
    for k in 2..5 {
        q[(k, k)] = clock.isb.powi(2) * dt;
    }
    q
}

impl ProcessModel for InsModelTc {
    type State = InsStateTc;
    type Input = ImuInput;

    fn propagate(&self, x: &InsStateTc, u: &ImuInput, dt: f64) -> InsStateTc {
        self.next(x, self.base.propagate(&x.nav, u, dt), dt)
    }

    fn jacobians(&self, x: &InsStateTc, u: &ImuInput, dt: f64) -> ProcessJacobians<Const<20>> {
        self.step(x, u, dt).1
    }

    fn fold_input(&self, sum: &mut Option<ImuInput>, u: &ImuInput) -> bool {
        u.fold_into(sum);
        true
    }

    fn step(
        &self,
        x: &InsStateTc,
        u: &ImuInput,
        dt: f64,
    ) -> (InsStateTc, ProcessJacobians<Const<20>>) {
        let (nav, j15) = self.base.step(&x.nav, u, dt);
        let mut Phi = M20::identity();
        Phi.fixed_view_mut::<15, 15>(0, 0).copy_from(&j15.Phi);
        Phi[(CLOCK_BIAS, CLOCK_DRIFT)] = dt;
        let mut Q = M20::zeros();
        Q.fixed_view_mut::<15, 15>(0, 0).copy_from(&j15.Q);
        Q.fixed_view_mut::<5, 5>(15, 15).copy_from(&self.clock_q(dt));
        (self.next(x, nav, dt), ProcessJacobians { Phi, Q })
    }

    /// `Φ P Φᵀ + Q` by blocks: the INS block by the 15-state model's structured product,
    /// the clock blocks (a 2×2 shear) and the cross blocks `Φ₁₅ P₁₅,c Φ_cᵀ` directly.
    fn step_covariance(
        &self,
        x: &InsStateTc,
        u: &ImuInput,
        dt: f64,
        P: &M20,
        out: &mut M20,
    ) -> InsStateTc {
        let p15 = crate::augment::leading_block::<15, 20>(P);
        let mut o15 = SMatrix::<f64, 15, 15>::zeros();
        let mut phi_t15 = SMatrix::<f64, 15, 15>::zeros();
        let nav = self.base.step_covariance_adjoint(&x.nav, u, dt, &p15, &mut o15, &mut phi_t15);
        crate::augment::set_leading_block::<15, 20>(out, &o15);
        // Φ_c = [[1, dt], [0, 1]] ⊕ I₃ acting on the last five rows
        let shear = |m: &mut SMatrix<f64, 5, 5>| {
            // rows: r0 += dt r1; columns: c0 += dt c1
            for c in 0..5 {
                m[(0, c)] += dt * m[(1, c)];
            }
            for r in 0..5 {
                m[(r, 0)] += dt * m[(r, 1)];
            }
        };
        let mut pc: SMatrix<f64, 5, 5> = P.fixed_view::<5, 5>(15, 15).into_owned();
        shear(&mut pc);
        out.fixed_view_mut::<5, 5>(15, 15).copy_from(&(pc + self.clock_q(dt)));
        // cross: Φ₁₅ P₁₅,c Φ_cᵀ
        let mut cross = phi_t15.transpose() * P.fixed_view::<15, 5>(0, 15);
        for r in 0..15 {
            cross[(r, 0)] += dt * cross[(r, 1)];
        }
        out.fixed_view_mut::<15, 5>(0, 15).copy_from(&cross);
        out.fixed_view_mut::<5, 15>(15, 0).copy_from(&cross.transpose());
        self.next(x, nav, dt)
    }

    const FUSED_STEP_COVARIANCE: bool = true;
}

composite_state! {
    /// The 21-state INS (with the IMU scale factors) and the receiver clock and
    /// inter-system biases: the tightly coupled filter with `filter.states = 21`. Tangent
    /// dimension `Const<26>`; blocks `NAV` (21), `CLOCK`, `ISB`. The satellite models,
    /// written for [`InsStateTc`], apply through [`OnTc`].
    pub struct InsStateTc21 {
        /// Attitude, velocity, position, biases, scale factors.
        pub nav: InsState21 => NAV,
        /// Receiver clock bias `c·dt` (m) and drift `c·ḋt` (m/s).
        pub clock: R2 => CLOCK,
        /// Inter-system biases of Galileo, BeiDou, QZSS against GPS, m.
        pub isb: R3 => ISB,
    }
}

/// 26×26 matrices of the 21-state tightly coupled error state.
pub type M26 = SMatrix<f64, 26, 26>;

impl InsStateTc21 {
    /// The 20-state view the satellite models read: the 15 navigation states, the clock
    /// and the inter-system biases (the scale factors left out).
    pub fn tc(&self) -> InsStateTc {
        InsStateTc { nav: self.nav.nav.clone(), clock: self.clock, isb: self.isb }
    }
}

/// The 21-state tightly coupled process model: [`InsModel21`] and the clock.
#[derive(Clone, Debug)]
pub struct InsModelTc21 {
    /// The 21-state INS.
    pub base: InsModel21,
    /// The clock.
    pub clock: ClockNoise,
}

impl ProcessModel for InsModelTc21 {
    type State = InsStateTc21;
    type Input = ImuInput;

    fn propagate(&self, x: &InsStateTc21, u: &ImuInput, dt: f64) -> InsStateTc21 {
        InsStateTc21 {
            nav: self.base.propagate(&x.nav, u, dt),
            clock: clock_after(&x.clock, dt),
            isb: x.isb,
        }
    }

    fn jacobians(&self, x: &InsStateTc21, u: &ImuInput, dt: f64) -> ProcessJacobians<Const<26>> {
        self.step(x, u, dt).1
    }

    fn fold_input(&self, sum: &mut Option<ImuInput>, u: &ImuInput) -> bool {
        u.fold_into(sum);
        true
    }

    /// The 21-state model's `Φ` and `Q_d` in the first 21 rows and columns, the clock's
    /// (`[[1, Δt], [0, 1]]` and [`InsModelTc`]'s `Q_c`) in the last five.
    fn step(
        &self,
        x: &InsStateTc21,
        u: &ImuInput,
        dt: f64,
    ) -> (InsStateTc21, ProcessJacobians<Const<26>>) {
        let (nav, j21) = self.base.step(&x.nav, u, dt);
        const C0: usize = InsStateTc21::CLOCK.start();
        let mut Phi = M26::identity();
        Phi.fixed_view_mut::<21, 21>(0, 0).copy_from(&j21.Phi);
        Phi[(C0, C0 + 1)] = dt;
        let mut Q = M26::zeros();
        Q.fixed_view_mut::<21, 21>(0, 0).copy_from(&j21.Q);
        Q.fixed_view_mut::<5, 5>(C0, C0).copy_from(&clock_q(&self.clock, dt));
        let next = InsStateTc21 { nav, clock: clock_after(&x.clock, dt), isb: x.isb };
        (next, ProcessJacobians { Phi, Q })
    }

    /// `Φ P Φᵀ + Q` by blocks (`Φ` and `Q` are block-diagonal: the INS's 21 and the
    /// clock's 5): the INS block by the 21-state model's product, the clock's and the
    /// cross blocks directly; about 60 % of the dense product's multiply-adds.
    fn propagate_covariance(&self, P: &M26, jac: &ProcessJacobians<Const<26>>, out: &mut M26) {
        const C0: usize = InsStateTc21::CLOCK.start();
        let phi21: M21 = crate::augment::leading_block::<21, 26>(&jac.Phi);
        let j21 =
            ProcessJacobians { Phi: phi21, Q: crate::augment::leading_block::<21, 26>(&jac.Q) };
        let mut o21 = M21::zeros();
        self.base.propagate_covariance(&crate::augment::leading_block::<21, 26>(P), &j21, &mut o21);
        crate::augment::set_leading_block::<21, 26>(out, &o21);
        let phic: SMatrix<f64, 5, 5> = jac.Phi.fixed_view::<5, 5>(C0, C0).into_owned();
        let cross = phi21 * P.fixed_view::<21, 5>(0, C0) * phic.transpose();
        out.fixed_view_mut::<21, 5>(0, C0).copy_from(&cross);
        out.fixed_view_mut::<5, 21>(C0, 0).copy_from(&cross.transpose());
        let pc = phic * P.fixed_view::<5, 5>(C0, C0) * phic.transpose()
            + jac.Q.fixed_view::<5, 5>(C0, C0);
        out.fixed_view_mut::<5, 5>(C0, C0).copy_from(&pc);
    }
}
