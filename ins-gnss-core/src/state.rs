//! The 15-state INS state and its error definition.
//!
//! Error state, rotation first: `δx = [δθ, δv, δp, δb_g, δb_a]`.
//! - `δθ`: right (body-frame) attitude error, `R_nb,true = R̂_nb · Exp(δθ)`;
//! - `δv`: NED velocity error, `v_true = v̂ + δv` (m/s);
//! - `δp`: NED position error in metres (see [`GeoPos`]);
//! - `δb_g`, `δb_a`: additive gyro (rad/s) and accelerometer (m/s²) bias errors.

use manifolds::{composite_state, So3, R3};

use crate::position::GeoPos;

composite_state! {
    /// Attitude, velocity, position and IMU biases: the nominal state of the 15-state
    /// INS/GNSS filter. Its tangent dimension is `Const<15>`; blocks are named
    /// `InsState::ATT`, `VEL`, `POS`, `BG`, `BA`.
    pub struct InsState {
        /// Attitude `R_nb` (body FRD → navigation NED).
        pub att: So3 => ATT,
        /// Velocity in NED, m/s.
        pub vel: R3 => VEL,
        /// Geodetic position.
        pub pos: GeoPos => POS,
        /// Gyro bias, rad/s (subtracted from the measured rate).
        pub bg: R3 => BG,
        /// Accelerometer bias, m/s² (subtracted from the measured specific force).
        pub ba: R3 => BA,
    }
}

impl InsState {
    /// Roll, pitch, yaw in radians (ZYX, yaw in (−π, π]).
    pub fn euler(&self) -> (f64, f64, f64) {
        self.att.euler()
    }
}
