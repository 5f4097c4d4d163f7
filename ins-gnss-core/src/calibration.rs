//! The rig's calibration as states of the filter: the GNSS antenna's lever arm, the
//! offset between the IMU's and the receiver's clocks, and the IMU's mounting in the
//! vehicle, each switched on on its own.
//!
//! A lever arm measured with a tape, or not at all, and an IMU stamped a few hundred
//! milliseconds late are the two errors users of loosely coupled INS/GNSS most often
//! carry without knowing (KF-GINS #15, OB_GINS #17, rtklibexplorer's GNSS_IMU with its
//! hand-set `imu_t_off`). Both are constants of the rig, observable from the fixes when
//! the vehicle turns and accelerates (the lever arm and time synchronisation of loose
//! coupling: Groves, *Principles of GNSS, Inertial and Multisensor Integrated Navigation
//! Systems*, 2nd ed., ch. 14). The fix at receiver time `t` is the antenna at the IMU's
//! time `t + δ` (`δ` the IMU stamps' lateness), so with the body-frame lever arm `l`
//!
//! ```text
//! ẑ = h(x; l) ⊕ ḣ(x) δ,          residual  z ⊖ h(x; l) − ḣ δ
//! H = [ H_nav + δ ∂ḣ/∂x,  ∂h/∂l + δ ∂ḣ/∂l,  ḣ ]
//! ```
//!
//! `ḣ` the antenna's velocity on position rows and its acceleration on velocity rows
//! ([`GnssFixModel::rate`]), linear in `δ`: a large offset is found first by the start's
//! search (the gyro's turns against the GNSS course) and applied to the stamps, the state
//! refining what is left. All are random walks of small driving noise (a rig is
//! constant; the noise keeps the filter from freezing them).
//!
//! The mounting: the non-holonomic constraint and the odometer measure the velocity in
//! the vehicle frame, `C_vb (R_nbᵀ v + ω × l)`; with `C_vb = Exp(μ) C₀` (`C₀` the
//! configured mounting, `μ` three states) a mounting off by a degree leaves a lateral
//! velocity of 1.7 % of the speed that the constraint sees whenever the car moves. Pitch
//! and yaw are estimated; the roll only turns the lateral and vertical axes into each
//! other, which the constraint, zero on both, cannot see, and stays the configured one
//! (its state is never updated).
//!
//! The odometer: its reading is `(1 + s)` times the wheel point's forward speed; with the
//! odometer's states on, `s` and the wheel point's lever arm are estimated (a turn shows
//! the lever arm's lateral part, `ω_z l_y`; its forward part never shows in a forward
//! speed, and the summary says so).
//!
//! [`InsStateCal`] is the 15-state INS with the eleven states (26). An item switched off
//! keeps its columns of `H` zero: its states are never updated and stay the configured
//! values, exactly.

use estimator_core::{
    FilterAlloc, JacobiansOf, MeasurementJacobians, MeasurementModel, StateDim, StreamId,
};
use manifolds::{composite_state, Manifold, Rn, Tangent};
use nalgebra::{Const, DefaultAllocator, OMatrix, SVector, Vector3};

use crate::augment::augmented_process;
use crate::gnss::{FixJacobian, GnssFixModel};
use crate::model::InsModel;
use crate::state::InsState;
use crate::vehicle::VehicleModel;

composite_state! {
    /// The 15-state INS state and the rig's calibration: the nominal state of the
    /// 26-state loosely coupled filter. Blocks `NAV` (15) and `CAL` (11): the antenna
    /// lever arm (body FRD, m), the IMU stamps' lateness on the receiver's clock (s), the
    /// mounting's correction `μ` (rad, `C_vb = Exp(μ) C₀`), the odometer's scale error
    /// `s` (its reading `(1 + s)` times the wheel point's forward speed) and the wheel
    /// point's lever arm (body FRD, m).
    pub struct InsStateCal {
        /// Attitude, velocity, position, biases.
        pub nav: InsState => NAV,
        /// Lever arm x, y, z (m), time offset (s), mounting correction (rad), the
        /// odometer's scale error (fraction) and its lever arm x, y, z (m).
        pub cal: Rn<11> => CAL,
    }
}

impl InsStateCal {
    /// The antenna lever arm (body FRD), m.
    pub fn lever_arm(&self) -> Vector3<f64> {
        Vector3::new(self.cal[0], self.cal[1], self.cal[2])
    }

    /// How late the IMU's stamps are on the receiver's clock, s.
    pub fn time_offset(&self) -> f64 {
        self.cal[3]
    }

    /// The mounting's correction `μ`, rad (`C_vb = Exp(μ) C₀`).
    pub fn mounting(&self) -> Vector3<f64> {
        Vector3::new(self.cal[4], self.cal[5], self.cal[6])
    }

    /// The odometer's scale error `s` (reading = `(1 + s)` × forward speed).
    pub fn odometer_scale(&self) -> f64 {
        self.cal[7]
    }

    /// The odometer's wheel point from the IMU (body FRD), m.
    pub fn odometer_lever_arm(&self) -> Vector3<f64> {
        Vector3::new(self.cal[8], self.cal[9], self.cal[10])
    }

    /// A state at `nav` with the lever arm `lever`, no offset, no mounting correction, no
    /// odometer scale error and the odometer at the IMU.
    pub fn new(nav: InsState, lever: Vector3<f64>) -> Self {
        let mut cal = Rn::<11>::zeros();
        cal[0] = lever.x;
        cal[1] = lever.y;
        cal[2] = lever.z;
        Self { nav, cal }
    }

    /// The same state with the odometer's wheel point at `lever` (body FRD, m).
    pub fn with_odometer_lever_arm(mut self, lever: Vector3<f64>) -> Self {
        self.cal[8] = lever.x;
        self.cal[9] = lever.y;
        self.cal[10] = lever.z;
        self
    }
}

/// The calibration block's size.
pub const CAL_STATES: usize = 11;

/// Which calibration items are estimated, and their driving noise. The default estimates
/// every item, the lever arms walking 1e-4 m/√s, the time offset 1e-5 s/√s, the mounting
/// 1e-5 rad/√s, the odometer's scale 1e-6 /√s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    /// Estimate the lever arm.
    pub lever_arm: bool,
    /// Estimate the time offset.
    pub time_offset: bool,
    /// Random-walk density of the lever arm, m/√s.
    pub lever_arm_walk: f64,
    /// Random-walk density of the time offset, s/√s.
    pub time_offset_walk: f64,
    /// Estimate the mounting.
    pub mounting: bool,
    /// Random-walk density of the mounting, rad/√s.
    pub mounting_walk: f64,
    /// Estimate the odometer's scale error and lever arm.
    pub odometer: bool,
    /// Random-walk density of the odometer's scale error, 1/√s (its lever arm walks as
    /// the antenna's).
    pub odometer_walk: f64,
}

impl Default for Calibration {
    fn default() -> Self {
        Self {
            lever_arm: true,
            time_offset: true,
            lever_arm_walk: 1e-4,
            time_offset_walk: 1e-5,
            mounting: true,
            mounting_walk: 1e-5,
            odometer: true,
            odometer_walk: 1e-6,
        }
    }
}

impl Calibration {
    /// The variance the random walks add over `h` seconds (zero for an item off).
    pub fn added_variance(&self, h: f64) -> SVector<f64, 11> {
        let l = if self.lever_arm { self.lever_arm_walk.powi(2) * h } else { 0.0 };
        let o = if self.time_offset { self.time_offset_walk.powi(2) * h } else { 0.0 };
        let m = if self.mounting { self.mounting_walk.powi(2) * h } else { 0.0 };
        let (s, w) = if self.odometer {
            (self.odometer_walk.powi(2) * h, self.lever_arm_walk.powi(2) * h)
        } else {
            (0.0, 0.0)
        };
        SVector::<f64, 11>::from([l, l, l, o, m, m, m, s, w, w, w])
    }
}

/// The process model of an INS with the calibration states.
#[derive(Clone, Debug)]
pub struct CalibrationProcess<M> {
    /// The INS model.
    pub base: M,
    /// What is estimated, and how it wanders.
    pub calibration: Calibration,
}

/// The 26-state model.
pub type InsModelCal = CalibrationProcess<InsModel>;

augmented_process!(
    InsModelCal,
    InsStateCal,
    cal,
    15,
    11,
    26,
    decay: |_: &InsModelCal, _| SVector::<f64, 11>::repeat(1.0),
    added: |m: &InsModelCal, h| m.calibration.added_variance(h)
);

/// A GNSS fix model of the 15-state INS applied to [`InsStateCal`]: the lever arm the
/// state's, the prediction moved by the time offset along its rate of change (module
/// documentation). `force` is the epoch's specific force (body, m/s²), for the
/// acceleration on velocity rows; `calibration` says which columns are live.
#[derive(Debug)]
pub struct OnCalibration<'a, M> {
    model: &'a M,
    force: Vector3<f64>,
    calibration: Calibration,
}

impl<'a, M> OnCalibration<'a, M> {
    /// `model` on [`InsStateCal`].
    pub fn new(model: &'a M, force: Vector3<f64>, calibration: Calibration) -> Self {
        Self { model, force, calibration }
    }
}

impl<M> Clone for OnCalibration<'_, M> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<M> Copy for OnCalibration<'_, M> {}

impl<M> OnCalibration<'_, M>
where
    M: GnssFixModel,
    DefaultAllocator: FilterAlloc<Const<15>, StateDim<M::Measurement>>
        + FilterAlloc<Const<3>, StateDim<M::Measurement>>,
{
    /// The model at the state's lever arm and its rate of change `ḣ` with the rate's
    /// Jacobian (the prediction is moved by `ḣ δ`).
    fn parts(&self, x: &InsStateCal) -> (M, Tangent<M::Measurement>, FixJacobian<M::Measurement>) {
        let m = self.model.with_lever_arm(x.lever_arm());
        let (rate, h_rate) = m.rate(&x.nav, &self.force);
        (m, rate, h_rate)
    }

    /// `H` from the base model's `H_nav` at the state's lever arm: `[H_nav + δ ∂ḣ/∂x,
    /// ∂/∂l (h + δ ḣ), ḣ, 0]`, the columns of an item off zero.
    fn h(
        &self,
        x: &InsStateCal,
        m: &M,
        h_nav: FixJacobian<M::Measurement>,
        rate: &Tangent<M::Measurement>,
        h_rate: FixJacobian<M::Measurement>,
    ) -> OMatrix<f64, StateDim<M::Measurement>, Const<26>>
    where
        DefaultAllocator: FilterAlloc<Const<26>, StateDim<M::Measurement>>,
    {
        let delta = x.time_offset();
        let mut H = OMatrix::<f64, StateDim<M::Measurement>, Const<26>>::zeros();
        H.fixed_columns_mut::<15>(0).copy_from(&(h_nav + h_rate * delta));
        if self.calibration.lever_arm {
            H.fixed_columns_mut::<3>(15).copy_from(&m.lever_jacobian(&x.nav, delta));
        }
        if self.calibration.time_offset {
            H.column_mut(18).copy_from(rate);
        }
        H
    }
}

impl<M> MeasurementModel for OnCalibration<'_, M>
where
    M: GnssFixModel,
    DefaultAllocator: FilterAlloc<Const<15>, StateDim<M::Measurement>>
        + FilterAlloc<Const<3>, StateDim<M::Measurement>>
        + FilterAlloc<Const<26>, StateDim<M::Measurement>>,
{
    type State = InsStateCal;
    type Measurement = M::Measurement;

    fn predict(&self, x: &InsStateCal) -> M::Measurement {
        let (m, rate, _) = self.parts(x);
        m.predict(&x.nav).oplus(&(rate * x.time_offset()))
    }

    fn jacobian(&self, x: &InsStateCal) -> JacobiansOf<Self> {
        let (m, rate, h_rate) = self.parts(x);
        MeasurementJacobians { H: self.h(x, &m, m.jacobian(&x.nav).H, &rate, h_rate) }
    }

    fn innovation(
        &self,
        x: &InsStateCal,
        z: &M::Measurement,
    ) -> (Tangent<M::Measurement>, JacobiansOf<Self>) {
        let (m, rate, h_rate) = self.parts(x);
        let (r, j) = m.innovation(&x.nav, z);
        let shift = &rate * x.time_offset();
        (r - shift, MeasurementJacobians { H: self.h(x, &m, j.H, &rate, h_rate) })
    }

    fn stream(&self) -> StreamId {
        self.model.stream()
    }
}

/// A vehicle-frame velocity model (the NHC, the odometer) applied to [`InsStateCal`]: its
/// `C_vb` corrected by the state's mounting, `Exp(μ) C₀`, and the mounting's columns of
/// `H` live when `calibration.mounting` is on; the odometer's reading scaled by the state's
/// `(1 + s)` at the state's wheel point, their columns live, when `calibration.odometer`
/// is on.
#[derive(Debug)]
pub struct OnMounting<'a, M> {
    model: &'a M,
    calibration: Calibration,
}

impl<'a, M> OnMounting<'a, M> {
    /// `model` (its `C_vb` the configured `C₀`) on [`InsStateCal`].
    pub fn new(model: &'a M, calibration: Calibration) -> Self {
        Self { model, calibration }
    }
}

impl<M> Clone for OnMounting<'_, M> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<M> Copy for OnMounting<'_, M> {}

impl<M> OnMounting<'_, M>
where
    M: VehicleModel,
    DefaultAllocator: FilterAlloc<Const<15>, StateDim<M::Measurement>>
        + FilterAlloc<Const<3>, StateDim<M::Measurement>>,
{
    /// Whether the odometer's states apply (a wheel model, the item on).
    fn wheel(&self) -> bool {
        self.model.wheel() && self.calibration.odometer
    }

    /// The configured model at the state's wheel point (when its states apply).
    fn placed(&self, x: &InsStateCal) -> M {
        if self.wheel() {
            self.model.with_lever_arm(x.odometer_lever_arm())
        } else {
            *self.model
        }
    }

    /// The model at the state's mounting and wheel point, and the reading's scale.
    fn corrected(&self, x: &InsStateCal) -> (M, f64) {
        let placed = self.placed(x);
        let c = manifolds::So3::exp(&x.mounting()).matrix() * placed.c_vb();
        let k = if self.wheel() { 1.0 + x.odometer_scale() } else { 1.0 };
        (placed.with_c_vb(c), k)
    }
}

impl<M> MeasurementModel for OnMounting<'_, M>
where
    M: VehicleModel,
    DefaultAllocator: FilterAlloc<Const<15>, StateDim<M::Measurement>>
        + FilterAlloc<Const<3>, StateDim<M::Measurement>>
        + FilterAlloc<Const<26>, StateDim<M::Measurement>>,
{
    type State = InsStateCal;
    type Measurement = M::Measurement;

    fn predict(&self, x: &InsStateCal) -> M::Measurement {
        let (m, k) = self.corrected(x);
        let z = m.predict(&x.nav);
        if !self.wheel() {
            return z;
        }
        let origin = M::Measurement::origin();
        origin.oplus(&(z.ominus(&origin) * k))
    }

    fn jacobian(&self, x: &InsStateCal) -> JacobiansOf<Self> {
        let (m, k) = self.corrected(x);
        let h_nav = m.jacobian(&x.nav).H;
        let mut H = OMatrix::<f64, StateDim<M::Measurement>, Const<26>>::zeros();
        H.fixed_columns_mut::<15>(0).copy_from(&(h_nav * k));
        if self.calibration.mounting {
            // pitch and yaw: the roll only turns the constraint's two axes into each
            // other, and a roll state only absorbs what else the constraint gets wrong
            // (drive-0708 with the NHC: the roll went to 5.5° σ 0.9° and the outage
            // score from 2.90 to 3.20 m); it stays the configured one
            let h_mu = self.placed(x).mounting_jacobian(&x.nav, &x.mounting()) * k;
            H.fixed_columns_mut::<2>(20).copy_from(&h_mu.fixed_columns::<2>(1));
        }
        if self.wheel() {
            let origin = M::Measurement::origin();
            H.column_mut(22).copy_from(&m.predict(&x.nav).ominus(&origin));
            H.fixed_columns_mut::<3>(23).copy_from(&(m.lever_jacobian(&x.nav) * k));
        }
        MeasurementJacobians { H }
    }

    fn stream(&self) -> StreamId {
        self.model.stream()
    }
}
