//! GNSS measurement models: antenna position (with lever arm), antenna velocity (with the
//! lever-arm velocity), or both at once.
//!
//! Antenna position `p_a = p ⊕ R_nb l_b`, residual `z ⊖ p̂_a` in NED metres:
//! `H = [−R̂[l×], 0, I, 0, 0]`.
//! Antenna velocity `v_a = v + R_nb (ω_ib × l_b) − ω_in^n × (R_nb l_b)`:
//! `H = [−R̂[(ω×l)×] + [ω_in×] R̂ [l×], I, 0, R̂[l×], 0]` (the dependence of `ω_in` on
//! velocity and position, below 1e-6 of the other terms, is left out).

use estimator_core::{MeasurementJacobians, MeasurementModel, StreamId};
use manifolds::{hat, Manifold, R3};
use nalgebra::{Const, Matrix3, SMatrix, Vector3};

use crate::earth::{earth_rate_ned, transport_rate};

use crate::position::GeoPos;
use crate::state::InsState;

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
}

fn h_position(x: &InsState, lever: &Vector3<f64>) -> SMatrix<f64, 3, 15> {
    let mut H = SMatrix::<f64, 3, 15>::zeros();
    H.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-x.att.matrix() * hat(lever)));
    H.fixed_view_mut::<3, 3>(0, 6).copy_from(&Matrix3::identity());
    H
}

fn antenna_position(x: &InsState, lever: &Vector3<f64>) -> GeoPos {
    x.pos.oplus(&x.att.rotate(lever))
}

fn antenna_velocity(x: &InsState, lever: &Vector3<f64>, w_ib: &Vector3<f64>) -> Vector3<f64> {
    let w = w_ib - x.bg;
    let w_in = earth_rate_ned(x.pos.lat) + transport_rate(x.pos.lat, x.pos.h, &x.vel);
    x.vel + x.att.rotate(&w.cross(lever)) - w_in.cross(&x.att.rotate(lever))
}

fn h_velocity(x: &InsState, lever: &Vector3<f64>, w_ib: &Vector3<f64>) -> SMatrix<f64, 3, 15> {
    let c = x.att.matrix();
    let w = w_ib - x.bg;
    let w_in = earth_rate_ned(x.pos.lat) + transport_rate(x.pos.lat, x.pos.h, &x.vel);
    let mut H = SMatrix::<f64, 3, 15>::zeros();
    let h_th = -c * hat(&w.cross(lever)) + hat(&w_in) * c * hat(lever);
    H.fixed_view_mut::<3, 3>(0, 0).copy_from(&h_th);
    H.fixed_view_mut::<3, 3>(0, 3).copy_from(&Matrix3::identity());
    H.fixed_view_mut::<3, 3>(0, 9).copy_from(&(c * hat(lever)));
    H
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
        antenna_position(x, &self.lever_arm)
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<3>, Const<15>> {
        MeasurementJacobians { H: h_position(x, &self.lever_arm) }
    }

    fn stream(&self) -> StreamId {
        StreamId::named("gnss-position")
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
        antenna_velocity(x, &self.lever_arm, &self.gyro_rate)
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<3>, Const<15>> {
        MeasurementJacobians { H: h_velocity(x, &self.lever_arm, &self.gyro_rate) }
    }

    fn stream(&self) -> StreamId {
        StreamId::named("gnss-velocity")
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
        (
            antenna_position(x, &self.lever_arm),
            antenna_velocity(x, &self.lever_arm, &self.gyro_rate),
        )
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<6>, Const<15>> {
        let mut H = SMatrix::<f64, 6, 15>::zeros();
        H.fixed_view_mut::<3, 15>(0, 0).copy_from(&h_position(x, &self.lever_arm));
        H.fixed_view_mut::<3, 15>(3, 0).copy_from(&h_velocity(x, &self.lever_arm, &self.gyro_rate));
        MeasurementJacobians { H }
    }

    fn stream(&self) -> StreamId {
        StreamId::named("gnss-position-velocity")
    }
}
