//! GNSS measurement models: antenna position (with lever arm), antenna velocity (with the
//! lever-arm velocity), or both at once.
//!
//! Antenna position `p_a = p ⊕ R_nb l_b`, residual `z ⊖ p̂_a` in NED metres:
//! `H = [−R̂[l×], 0, I, 0, 0]`.
//! Antenna velocity `v_a = v + R_nb (ω_ib × l_b) − ω_in^n × (R_nb l_b)`:
//! `H = [−R̂[(ω×l)×] + [ω_in×] R̂ [l×], I, 0, R̂[l×], 0]` (the dependence of `ω_in` on
//! velocity and position, below 1e-6 of the other terms, is left out).

use estimator_core::{FilterAlloc, MeasurementJacobians, MeasurementModel, StateDim, StreamId};
use manifolds::{hat, R3};
use nalgebra::{Const, Matrix3, OMatrix, SMatrix, SVector, Vector3};

use crate::earth::LocalEarth;

use crate::position::{metric_at, GeoPos};
use crate::state::InsState;

/// The stream of [`GnssPosition`] updates.
pub const GNSS_POSITION: StreamId = StreamId::named("gnss-position");
/// The stream of [`GnssVelocity`] updates.
pub const GNSS_VELOCITY: StreamId = StreamId::named("gnss-velocity");
/// The stream of [`GnssPosVel`] updates.
pub const GNSS_POSITION_VELOCITY: StreamId = StreamId::named("gnss-position-velocity");
/// Every GNSS stream, for configurations that name them.
pub const GNSS_STREAMS: [StreamId; 3] = [GNSS_POSITION, GNSS_VELOCITY, GNSS_POSITION_VELOCITY];

/// One GNSS epoch as read from a file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssEpoch {
    /// Time, s.
    pub t: f64,
    /// Antenna position.
    pub pos: GeoPos,
    /// 1σ of the position in N, E, D, m.
    pub pos_std: Vector3<f64>,
    /// NED velocity and its 1σ (m/s), when the file has them.
    pub vel: Option<(Vector3<f64>, Vector3<f64>)>,
    /// The full NED position covariance (m²) when the file gives its correlations
    /// (RTKLIB's `sdne`, `sdeu`, `sdun`); `None`: diagonal, from `pos_std`.
    pub pos_cov: Option<Matrix3<f64>>,
    /// The same for the velocity (m²/s²).
    pub vel_cov: Option<Matrix3<f64>>,
    /// A moving-base receiver's heading of its antennas' baseline at this epoch.
    pub heading: Option<crate::heading::AntennaHeading>,
}

impl GnssEpoch {
    /// A single point ([`gnss::Spp`]) as a fix at time `t` (on the caller's
    /// clock): the geodetic position with its NED covariance, and the Doppler velocity
    /// (NED) with its covariance when there is one — what loose coupling and `.pos`
    /// output take.
    pub fn from_single_point(spp: &::gnss::Spp, t: f64) -> GnssEpoch {
        let (lat, lon, h) = crate::earth::ecef_to_geodetic(&spp.pos);
        let c_ne = crate::earth::ecef_to_ned_rotation(lat, lon);
        let cov = c_ne * spp.cov * c_ne.transpose();
        let sd =
            |c: &Matrix3<f64>| Vector3::new(c[(0, 0)].sqrt(), c[(1, 1)].sqrt(), c[(2, 2)].sqrt());
        let vel = spp.velocity.map(|(v, vc)| (c_ne * v, c_ne * vc * c_ne.transpose()));
        GnssEpoch {
            t,
            pos: GeoPos { lat, lon, h },
            pos_std: sd(&cov),
            vel: vel.map(|(v, vc)| (v, sd(&vc))),
            pos_cov: Some(cov),
            vel_cov: vel.map(|(_, vc)| vc),
            heading: None,
        }
    }

    /// An epoch with uncorrelated errors (σ per axis).
    pub fn new(
        t: f64,
        pos: GeoPos,
        pos_std: Vector3<f64>,
        vel: Option<(Vector3<f64>, Vector3<f64>)>,
    ) -> Self {
        Self { t, pos, pos_std, vel, pos_cov: None, vel_cov: None, heading: None }
    }

    /// The position covariance (NED, m²): the file's, or the σ's diagonal.
    pub fn position_covariance(&self) -> Matrix3<f64> {
        self.pos_cov.unwrap_or_else(|| Matrix3::from_diagonal(&self.pos_std.map(|s| s * s)))
    }

    /// The velocity covariance (NED, m²/s²), when there is a velocity.
    pub fn velocity_covariance(&self) -> Option<Matrix3<f64>> {
        let (_, std) = self.vel?;
        Some(self.vel_cov.unwrap_or_else(|| Matrix3::from_diagonal(&std.map(|s| s * s))))
    }
}

/// What the position and velocity predictions and Jacobians share at one state: the
/// attitude matrix, the lever arm in NED, the body rate and the navigation-frame rate.
struct Geometry {
    c: Matrix3<f64>,
    /// [`GeoPos::metric`] at the state's position.
    metric: Vector3<f64>,
    /// `(sin φ, cos φ)` of the state's latitude.
    sin_cos: (f64, f64),
    lever: Vector3<f64>,
    lever_n: Vector3<f64>,
    w: Vector3<f64>,
    w_in: Vector3<f64>,
}

impl Geometry {
    fn new(x: &InsState, lever: &Vector3<f64>, w_ib: &Vector3<f64>) -> Self {
        let c = x.att.matrix();
        let e = LocalEarth::at(&x.pos);
        let w_in = e.earth_rate() + e.transport_rate(&x.vel);
        let (metric, sin_cos) = (e.metric(), (e.sin, e.cos));
        Self { c, metric, sin_cos, lever: *lever, lever_n: c * lever, w: w_ib - x.bg, w_in }
    }

    /// Without a gyro rate (position only: `w` and `w_in` unused).
    fn position_only(x: &InsState, lever: &Vector3<f64>) -> Self {
        let c = x.att.matrix();
        let z = Vector3::zeros();
        let (s, co) = x.pos.lat.sin_cos();
        let metric = metric_at(s, co, x.pos.h);
        let (lever, lever_n) = (*lever, c * lever);
        Self { c, metric, sin_cos: (s, co), lever, lever_n, w: z, w_in: z }
    }

    fn antenna_position(&self, x: &InsState) -> GeoPos {
        x.pos.oplus_with_metric(&self.lever_n, &self.metric)
    }

    /// `z ⊖ p_a` for the predicted antenna position `p_a`, its metric from the state's
    /// `sin_cos` (the antenna is metres from the state's position).
    fn position_residual(&self, x: &InsState, z: &GeoPos, p_a: &GeoPos) -> Vector3<f64> {
        z.ominus_with_metric(p_a, &p_a.metric_near(&x.pos, self.sin_cos))
    }

    fn antenna_velocity(&self, x: &InsState) -> Vector3<f64> {
        x.vel + self.c * self.w.cross(&self.lever) - self.w_in.cross(&self.lever_n)
    }

    fn h_position(&self) -> SMatrix<f64, 3, 15> {
        let mut H = SMatrix::<f64, 3, 15>::zeros();
        H.fixed_view_mut::<3, 3>(0, InsState::ATT.start()).copy_from(&(-self.c * hat(&self.lever)));
        H.fixed_view_mut::<3, 3>(0, InsState::POS.start()).copy_from(&Matrix3::identity());
        H
    }

    /// `∂v_a/∂l = R_nb [ω×] − [ω_in×] R_nb`: the antenna velocity's Jacobian in the
    /// lever arm.
    fn lever_velocity(&self) -> Matrix3<f64> {
        self.c * hat(&self.w) - hat(&self.w_in) * self.c
    }

    fn h_velocity(&self) -> SMatrix<f64, 3, 15> {
        let c_l = self.c * hat(&self.lever);
        let mut H = SMatrix::<f64, 3, 15>::zeros();
        let h_th = -self.c * hat(&self.w.cross(&self.lever)) + hat(&self.w_in) * c_l;
        H.fixed_view_mut::<3, 3>(0, InsState::ATT.start()).copy_from(&h_th);
        H.fixed_view_mut::<3, 3>(0, InsState::VEL.start()).copy_from(&Matrix3::identity());
        H.fixed_view_mut::<3, 3>(0, InsState::BG.start()).copy_from(&c_l);
        H
    }
}

/// GNSS antenna position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssPosition {
    /// Antenna lever arm in the body frame (FRD), m.
    pub lever_arm: Vector3<f64>,
}

impl MeasurementModel for GnssPosition {
    type State = InsState;
    type Measurement = GeoPos;

    fn predict(&self, x: &InsState) -> GeoPos {
        Geometry::position_only(x, &self.lever_arm).antenna_position(x)
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<3>, Const<15>> {
        MeasurementJacobians { H: Geometry::position_only(x, &self.lever_arm).h_position() }
    }

    fn linearize(&self, x: &InsState) -> (GeoPos, MeasurementJacobians<Const<3>, Const<15>>) {
        let g = Geometry::position_only(x, &self.lever_arm);
        (g.antenna_position(x), MeasurementJacobians { H: g.h_position() })
    }

    /// The residual's metric from the state's latitude functions (one `sin_cos` fewer).
    fn innovation(
        &self,
        x: &InsState,
        z: &GeoPos,
    ) -> (Vector3<f64>, MeasurementJacobians<Const<3>, Const<15>>) {
        let g = Geometry::position_only(x, &self.lever_arm);
        let r = g.position_residual(x, z, &g.antenna_position(x));
        (r, MeasurementJacobians { H: g.h_position() })
    }

    fn stream(&self) -> StreamId {
        GNSS_POSITION
    }
}

/// GNSS antenna velocity; needs the gyro rate of the epoch (rad/s, raw).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssVelocity {
    /// Antenna lever arm (FRD), m.
    pub lever_arm: Vector3<f64>,
    /// Measured angular rate `ω_ib^b` at the epoch, rad/s (bias removed inside).
    pub gyro_rate: Vector3<f64>,
}

impl MeasurementModel for GnssVelocity {
    type State = InsState;
    type Measurement = R3;

    fn predict(&self, x: &InsState) -> R3 {
        Geometry::new(x, &self.lever_arm, &self.gyro_rate).antenna_velocity(x)
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<3>, Const<15>> {
        MeasurementJacobians { H: Geometry::new(x, &self.lever_arm, &self.gyro_rate).h_velocity() }
    }

    fn linearize(&self, x: &InsState) -> (R3, MeasurementJacobians<Const<3>, Const<15>>) {
        let g = Geometry::new(x, &self.lever_arm, &self.gyro_rate);
        (g.antenna_velocity(x), MeasurementJacobians { H: g.h_velocity() })
    }

    fn stream(&self) -> StreamId {
        GNSS_VELOCITY
    }
}

/// GNSS position and velocity in one 6-D update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssPosVel {
    /// Antenna lever arm (FRD), m.
    pub lever_arm: Vector3<f64>,
    /// Measured angular rate at the epoch, rad/s.
    pub gyro_rate: Vector3<f64>,
}

impl MeasurementModel for GnssPosVel {
    type State = InsState;
    type Measurement = (GeoPos, R3);

    fn predict(&self, x: &InsState) -> (GeoPos, R3) {
        let g = Geometry::new(x, &self.lever_arm, &self.gyro_rate);
        (g.antenna_position(x), g.antenna_velocity(x))
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<6>, Const<15>> {
        MeasurementJacobians { H: pos_vel_h(&Geometry::new(x, &self.lever_arm, &self.gyro_rate)) }
    }

    fn linearize(&self, x: &InsState) -> ((GeoPos, R3), MeasurementJacobians<Const<6>, Const<15>>) {
        let g = Geometry::new(x, &self.lever_arm, &self.gyro_rate);
        ((g.antenna_position(x), g.antenna_velocity(x)), MeasurementJacobians { H: pos_vel_h(&g) })
    }

    /// The position residual's metric from the state's latitude functions (one `sin_cos`
    /// fewer).
    fn innovation(
        &self,
        x: &InsState,
        z: &(GeoPos, R3),
    ) -> (SVector<f64, 6>, MeasurementJacobians<Const<6>, Const<15>>) {
        let g = Geometry::new(x, &self.lever_arm, &self.gyro_rate);
        let r_pos = g.position_residual(x, &z.0, &g.antenna_position(x));
        let r_vel = z.1 - g.antenna_velocity(x);
        let r = SVector::<f64, 6>::new(r_pos.x, r_pos.y, r_pos.z, r_vel.x, r_vel.y, r_vel.z);
        (r, MeasurementJacobians { H: pos_vel_h(&g) })
    }

    fn stream(&self) -> StreamId {
        GNSS_POSITION_VELOCITY
    }
}

fn pos_vel_h(g: &Geometry) -> SMatrix<f64, 6, 15> {
    let mut H = SMatrix::<f64, 6, 15>::zeros();
    H.fixed_view_mut::<3, 15>(0, 0).copy_from(&g.h_position());
    H.fixed_view_mut::<3, 15>(3, 0).copy_from(&g.h_velocity());
    H
}

/// The Jacobian of a fix model's prediction (measurement `M`) in the 15 error states.
pub type FixJacobian<M> = OMatrix<f64, StateDim<M>, Const<15>>;

/// What a GNSS fix model offers the calibration states ([`crate::calibration`]): its lever
/// arm, the Jacobian of its prediction in the lever arm, and the rate of change of its
/// prediction (the antenna's velocity; with velocity rows, the acceleration), which a
/// time offset between the IMU's and the receiver's clocks multiplies.
pub trait GnssFixModel: MeasurementModel<State = InsState> + Copy
where
    nalgebra::DefaultAllocator: FilterAlloc<Const<15>, StateDim<Self::Measurement>>
        + FilterAlloc<Const<3>, StateDim<Self::Measurement>>,
{
    /// The same model with another lever arm.
    fn with_lever_arm(&self, lever: Vector3<f64>) -> Self;

    /// `∂/∂l (h + δ ḣ)`: the Jacobian in the body-frame lever arm of the prediction moved
    /// by a time offset `delta` along its rate (position rows `R_nb`; velocity rows, and
    /// `δ` times the position rows' rate, the lever arm's own velocity
    /// `R_nb [ω×] − [ω_in×] R_nb`, where the model has a gyro rate).
    fn lever_jacobian(
        &self,
        x: &InsState,
        delta: f64,
    ) -> OMatrix<f64, StateDim<Self::Measurement>, Const<3>>;

    /// `ḣ`, the prediction's rate of change at `x` (antenna velocity NED, m/s; with
    /// velocity rows, the acceleration `R_nb (f − b_a) + g − (2ω_ie + ω_en) × v`, m/s²,
    /// from the specific force `f` of the epoch), and its Jacobian in the 15 error states
    /// (the transport rate's own dependence on velocity and position, below 1e-6 of the
    /// others, left out).
    fn rate(
        &self,
        x: &InsState,
        force: &Vector3<f64>,
    ) -> (manifolds::Tangent<Self::Measurement>, FixJacobian<Self::Measurement>);
}

/// The navigation-frame acceleration `R_nb (f − b_a) + g − (2ω_ie + ω_en) × v` and its
/// Jacobian in the 15 error states (attitude, velocity — the Coriolis term with its rate
/// held — and accelerometer-bias columns).
fn acceleration(x: &InsState, force: &Vector3<f64>) -> (Vector3<f64>, SMatrix<f64, 3, 15>) {
    let c = x.att.matrix();
    let e = LocalEarth::at(&x.pos);
    let f = force - x.ba;
    let w = 2.0 * e.earth_rate() + e.transport_rate(&x.vel);
    let a = c * f + Vector3::new(0.0, 0.0, e.gravity()) - w.cross(&x.vel);
    let mut H = SMatrix::<f64, 3, 15>::zeros();
    H.fixed_view_mut::<3, 3>(0, InsState::ATT.start()).copy_from(&(-c * hat(&f)));
    H.fixed_view_mut::<3, 3>(0, InsState::VEL.start()).copy_from(&(-hat(&w)));
    H.fixed_view_mut::<3, 3>(0, InsState::BA.start()).copy_from(&(-c));
    (a, H)
}

impl GnssFixModel for GnssPosition {
    fn with_lever_arm(&self, lever: Vector3<f64>) -> Self {
        Self { lever_arm: lever }
    }

    fn lever_jacobian(&self, x: &InsState, _delta: f64) -> SMatrix<f64, 3, 3> {
        x.att.matrix()
    }

    /// The INS velocity (the model has no gyro rate for the lever arm's own velocity,
    /// centimetres per second on a car).
    fn rate(&self, x: &InsState, _force: &Vector3<f64>) -> (Vector3<f64>, SMatrix<f64, 3, 15>) {
        let mut H = SMatrix::<f64, 3, 15>::zeros();
        H.fixed_view_mut::<3, 3>(0, InsState::VEL.start()).copy_from(&Matrix3::identity());
        (x.vel, H)
    }
}

impl GnssFixModel for GnssPosVel {
    fn with_lever_arm(&self, lever: Vector3<f64>) -> Self {
        Self { lever_arm: lever, ..*self }
    }

    fn lever_jacobian(&self, x: &InsState, delta: f64) -> SMatrix<f64, 6, 3> {
        let g = Geometry::new(x, &self.lever_arm, &self.gyro_rate);
        let own = g.lever_velocity();
        let mut H = SMatrix::<f64, 6, 3>::zeros();
        H.fixed_view_mut::<3, 3>(0, 0).copy_from(&(g.c + own * delta));
        H.fixed_view_mut::<3, 3>(3, 0).copy_from(&own);
        H
    }

    fn rate(&self, x: &InsState, force: &Vector3<f64>) -> (SVector<f64, 6>, SMatrix<f64, 6, 15>) {
        let g = Geometry::new(x, &self.lever_arm, &self.gyro_rate);
        let (a, h_a) = acceleration(x, force);
        let v = g.antenna_velocity(x);
        let mut H = SMatrix::<f64, 6, 15>::zeros();
        H.fixed_view_mut::<3, 15>(0, 0).copy_from(&g.h_velocity());
        H.fixed_view_mut::<3, 15>(3, 0).copy_from(&h_a);
        (SVector::<f64, 6>::new(v.x, v.y, v.z, a.x, a.y, a.z), H)
    }
}
