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
use crate::raw::ephemeris::C;
use crate::raw::spp::{geometry, range_rate, Prepared};
use crate::raw::{Sat, System};
use crate::scale::{InsModel21, InsState21, M21};
use crate::state::InsState;

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
        let p15: SMatrix<f64, 15, 15> = P.fixed_view::<15, 15>(0, 0).into_owned();
        let mut o15 = SMatrix::<f64, 15, 15>::zeros();
        let mut phi_t15 = SMatrix::<f64, 15, 15>::zeros();
        let nav = self.base.step_covariance_adjoint(&x.nav, u, dt, &p15, &mut o15, &mut phi_t15);
        out.fixed_view_mut::<15, 15>(0, 0).copy_from(&o15);
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
        let phi21: M21 = jac.Phi.fixed_view::<21, 21>(0, 0).into_owned();
        let j21 = ProcessJacobians { Phi: phi21, Q: jac.Q.fixed_view::<21, 21>(0, 0).into_owned() };
        let mut o21 = M21::zeros();
        self.base.propagate_covariance(&P.fixed_view::<21, 21>(0, 0).into_owned(), &j21, &mut o21);
        out.fixed_view_mut::<21, 21>(0, 0).copy_from(&o21);
        let phic: SMatrix<f64, 5, 5> = jac.Phi.fixed_view::<5, 5>(C0, C0).into_owned();
        let cross = phi21 * P.fixed_view::<21, 5>(0, C0) * phic.transpose();
        out.fixed_view_mut::<21, 5>(0, C0).copy_from(&cross);
        out.fixed_view_mut::<5, 21>(C0, 0).copy_from(&cross.transpose());
        let pc = phic * P.fixed_view::<5, 5>(C0, C0) * phic.transpose()
            + jac.Q.fixed_view::<5, 5>(C0, C0);
        out.fixed_view_mut::<5, 5>(C0, C0).copy_from(&pc);
    }
}

/// A satellite model of [`InsStateTc`] applied to [`InsStateTc21`]: the same prediction
/// from [`InsStateTc21::tc`], `H`'s columns of the clock and the inter-system biases moved
/// past the scale factors (whose columns are zero: a satellite sees them only through
/// the navigation states they drive).
#[derive(Debug)]
pub struct OnTc<'a, M>(pub &'a M);

impl<M> Clone for OnTc<'_, M> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<M> Copy for OnTc<'_, M> {}

impl<M> MeasurementModel for OnTc<'_, M>
where
    M: MeasurementModel<State = InsStateTc, Measurement = Vector1<f64>>,
{
    type State = InsStateTc21;
    type Measurement = Vector1<f64>;

    fn predict(&self, x: &InsStateTc21) -> Vector1<f64> {
        self.0.predict(&x.tc())
    }

    fn jacobian(&self, x: &InsStateTc21) -> JacobiansOf<Self> {
        MeasurementJacobians { H: widen(&self.0.jacobian(&x.tc()).H) }
    }

    fn linearize(&self, x: &InsStateTc21) -> (Vector1<f64>, JacobiansOf<Self>) {
        let (z, j) = self.0.linearize(&x.tc());
        (z, MeasurementJacobians { H: widen(&j.H) })
    }

    fn stream(&self) -> StreamId {
        self.0.stream()
    }
}

/// A row of the 20-state `H` in the 26-state layout.
fn widen(h: &SMatrix<f64, 1, 20>) -> SMatrix<f64, 1, 26> {
    const NAV15: usize = 15;
    let mut out = SMatrix::<f64, 1, 26>::zeros();
    out.fixed_view_mut::<1, NAV15>(0, 0).copy_from(&h.fixed_view::<1, NAV15>(0, 0));
    out.fixed_view_mut::<1, 5>(0, InsStateTc21::CLOCK.start())
        .copy_from(&h.fixed_view::<1, 5>(0, InsStateTc::CLOCK.start()));
    out
}

/// The stream of a satellite's pseudoranges (`"pr G05"`) or range rates (`"rr G05"`):
/// each satellite is a stream of its own. The names are made once per satellite.
pub fn satellite_stream(sat: Sat, rate: bool) -> StreamId {
    static NAMES: OnceLock<Mutex<HashMap<(Sat, bool), StreamId>>> = OnceLock::new();
    let map = NAMES.get_or_init(|| Mutex::new(HashMap::new()));
    let mut m = match map.lock() {
        Ok(m) => m,
        Err(poisoned) => poisoned.into_inner(),
    };
    *m.entry((sat, rate)).or_insert_with(|| {
        let name: &'static str =
            Box::leak(format!("{} {sat}", if rate { "rr" } else { "pr" }).into_boxed_str());
        StreamId::named(name)
    })
}

/// What the satellite models and the navigator's raw epochs need of the state: the
/// antenna (geodetic and ECEF) and the NED frame there.
pub(crate) struct Antenna {
    pub(crate) c_nb: Matrix3<f64>,
    pub(crate) c_ne: Matrix3<f64>,
    pub(crate) pos: crate::position::GeoPos,
    pub(crate) r: Vector3<f64>,
    pub(crate) lever_n: Vector3<f64>,
}

impl Antenna {
    /// The antenna of state `x` with lever arm `lever` (FRD).
    pub(crate) fn at(x: &InsState, lever: &Vector3<f64>) -> Self {
        let c_nb = x.att.matrix();
        let lever_n = c_nb * lever;
        let p = x.pos.oplus(&lever_n);
        Self {
            c_nb,
            c_ne: ecef_to_ned_rotation(p.lat, p.lon),
            pos: p,
            r: geodetic_to_ecef(p.lat, p.lon, p.h),
            lever_n,
        }
    }

    /// Range with the Sagnac term and the unit vector antenna → satellite (ECEF).
    fn range(&self, rs: &Vector3<f64>) -> (f64, Vector3<f64>) {
        geometry(rs, &self.r)
    }
}

/// A satellite's pseudorange: the prepared satellite, the corrections `I + T` (m) and the
/// lever arm.
#[derive(Clone, Copy, Debug)]
pub struct Pseudorange<'a> {
    /// The satellite at its transmission time, and the code.
    pub sat: &'a Prepared,
    /// Ionosphere plus troposphere delay, m.
    pub corrections: f64,
    /// Antenna lever arm (FRD), m.
    pub lever_arm: Vector3<f64>,
}

impl MeasurementModel for Pseudorange<'_> {
    type State = InsStateTc;
    type Measurement = Vector1<f64>;

    fn predict(&self, x: &InsStateTc) -> Vector1<f64> {
        self.linearize(x).0
    }

    fn jacobian(&self, x: &InsStateTc) -> JacobiansOf<Self> {
        self.linearize(x).1
    }

    fn linearize(&self, x: &InsStateTc) -> (Vector1<f64>, JacobiansOf<Self>) {
        let a = Antenna::at(&x.nav, &self.lever_arm);
        let (rho, u) = a.range(&self.sat.state.pos);
        let isb = isb_index(self.sat.sat.sys).map_or(0.0, |k| x.isb[k]);
        let z = rho + x.clock[0] + isb - C * self.sat.state.clock + self.corrections;
        let u_n = a.c_ne * u;
        let mut H = SMatrix::<f64, 1, 20>::zeros();
        let att = u_n.transpose() * a.c_nb * hat(&self.lever_arm);
        for k in 0..3 {
            H[(0, ATT + k)] = att[(0, k)];
            H[(0, POS + k)] = -u_n[k];
        }
        H[(0, CLOCK_BIAS)] = 1.0;
        if let Some(k) = isb_index(self.sat.sat.sys) {
            H[(0, ISB + k)] = 1.0;
        }
        (Vector1::new(z), MeasurementJacobians { H })
    }

    fn stream(&self) -> StreamId {
        satellite_stream(self.sat.sat, false)
    }
}

/// A satellite's range rate (from its Doppler): the prepared satellite, the lever arm and
/// the gyro rate (for the lever arm's velocity).
#[derive(Clone, Copy, Debug)]
pub struct RangeRate<'a> {
    /// The satellite at its transmission time.
    pub sat: &'a Prepared,
    /// Antenna lever arm (FRD), m.
    pub lever_arm: Vector3<f64>,
    /// Measured body rate `ω_ib^b` (before the bias correction), rad/s.
    pub gyro_rate: Vector3<f64>,
}

impl MeasurementModel for RangeRate<'_> {
    type State = InsStateTc;
    type Measurement = Vector1<f64>;

    fn predict(&self, x: &InsStateTc) -> Vector1<f64> {
        self.linearize(x).0
    }

    fn jacobian(&self, x: &InsStateTc) -> JacobiansOf<Self> {
        self.linearize(x).1
    }

    fn linearize(&self, x: &InsStateTc) -> (Vector1<f64>, JacobiansOf<Self>) {
        let n = &x.nav;
        let a = Antenna::at(n, &self.lever_arm);
        let (_, u) = a.range(&self.sat.state.pos);
        let e = LocalEarth::at(&n.pos);
        let w_in = e.earth_rate() + e.transport_rate(&n.vel);
        let w = self.gyro_rate - n.bg;
        let wl = w.cross(&self.lever_arm);
        let v_a_n = n.vel + a.c_nb * wl - w_in.cross(&a.lever_n);
        let vr = a.c_ne.transpose() * v_a_n;
        let rate = range_rate(&self.sat.state.pos, &self.sat.state.vel, &a.r, &vr, &u);
        let z = rate + x.clock[1] - C * self.sat.state.drift;
        let u_n = a.c_ne * u;
        let mut H = SMatrix::<f64, 1, 20>::zeros();
        let att = u_n.transpose() * a.c_nb * hat(&wl);
        let bg = -(u_n.transpose() * a.c_nb * hat(&self.lever_arm));
        for k in 0..3 {
            H[(0, ATT + k)] = att[(0, k)];
            H[(0, VEL + k)] = -u_n[k];
            H[(0, BG + k)] = bg[(0, k)];
        }
        H[(0, CLOCK_DRIFT)] = 1.0;
        (Vector1::new(z), MeasurementJacobians { H })
    }

    fn stream(&self) -> StreamId {
        satellite_stream(self.sat.sat, true)
    }
}

/// The error-state vector type of [`InsStateTc`].
pub type V20 = SVector<f64, 20>;

/// One row of an epoch's time-differenced carrier phases, whitened: the phases' changes
/// since the last epoch, differenced against the highest satellite's (the receiver clock
/// cancels), decorrelated by the Cholesky factor of their covariance, so each row is an
/// independent scalar of unit variance. Its error is, to first order, that of the
/// antenna's displacement over the interval, `Δt δv + ½ Δt² C_nb ([f^b×] δθ + δb_a)` (the anchor of
/// the last epoch being the filter's own position then): `predict(x) = c + hᵀ (v − v₀) +
/// h_attᵀ (att ⊖ att₀)` around the state the rows were formed at.
#[derive(Clone, Debug)]
pub struct CarrierRow {
    /// The row's sensitivity to the velocity (NED).
    pub h: Vector3<f64>,
    /// Its sensitivity to the attitude error (body frame).
    pub h_att: Vector3<f64>,
    /// Its sensitivity to the accelerometer bias error.
    pub h_ba: Vector3<f64>,
    /// The row's prediction at the state it was formed at.
    pub c: f64,
    /// The velocity the rows were formed at.
    pub v0: Vector3<f64>,
    /// The attitude the rows were formed at.
    pub att0: manifolds::So3,
    /// The accelerometer bias the rows were formed at.
    pub ba0: Vector3<f64>,
}

/// The stream of the time-differenced carrier phases.
pub fn carrier_stream() -> StreamId {
    StreamId::named("tdcp")
}

impl MeasurementModel for CarrierRow {
    type State = InsStateTc;
    type Measurement = Vector1<f64>;

    fn predict(&self, x: &InsStateTc) -> Vector1<f64> {
        let d_att = x.nav.att.ominus(&self.att0);
        Vector1::new(
            self.c
                + self.h.dot(&(x.nav.vel - self.v0))
                + self.h_att.dot(&d_att)
                + self.h_ba.dot(&(x.nav.ba - self.ba0)),
        )
    }

    fn jacobian(&self, _x: &InsStateTc) -> JacobiansOf<Self> {
        let mut H = SMatrix::<f64, 1, 20>::zeros();
        for k in 0..3 {
            H[(0, ATT + k)] = self.h_att[k];
            H[(0, VEL + k)] = self.h[k];
            H[(0, BA + k)] = self.h_ba[k];
        }
        MeasurementJacobians { H }
    }

    fn stream(&self) -> StreamId {
        carrier_stream()
    }
}
