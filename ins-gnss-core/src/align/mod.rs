//! Initialisation from the data: a static start found in the IMU and GNSS streams, the
//! noise and gyro biases measured on it, and an in-motion alignment that finds the
//! attitude (heading included), position and velocity at the start from the first
//! seconds of IMU and GNSS data, whatever the initial heading.
//!
//! # In-motion alignment (position-integration form)
//!
//! Over a short span `τ = t − t_a` the navigation frame hardly turns, so the IMU position
//! obeys `p(τ) = p₀ + v₀ τ + ½ g τ² e_D + C₀ α(τ)`, with `C₀ = R_nb(t_a)` and
//! `α(τ) = ∫₀^τ ∫₀^s ΔC(r) f_b(r) dr ds` computed from the IMU alone (`ΔC = R_b(t_a)b(r)`
//! integrated from the gyros). The GNSS antenna adds `C₀ ΔC(τ) l_b`. Every fix is then
//! three equations linear in `p₀` and `v₀`, which are projected out; what is left is
//! Wahba's problem for `C₀`, solved by SVD so that the fit is always a rotation — roll
//! and pitch from gravity (`½ g τ²` dominates), heading from the velocity changes, from
//! any heading, with no forward-motion assumption (the optimisation-based alignment of
//! Wu & Pan, IEEE TAES 49(2), 2013, in its position form; Earth rotation over the span
//! is neglected: < 0.5 m over 20 s at 16 m/s). The fit also tests the data: a
//! left-handed sensor frame fits far better as a reflection, a wrong gyro unit leaves
//! residuals that another gyro scale removes.
//!
//! # Gyro scale from the course
//!
//! A straight start leaves the gyro scale unseen by the fit above. [`turn_ratio`]
//! compares, between consecutive moving fixes, the change of the GNSS course with the
//! gyro's rotation about the down axis: the slope of one on the other is 1 whatever the
//! mounting, and 57.3 or 1/57.3 when a unit is wrong.

use manifolds::So3;
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};

use crate::earth::{earth_rate_ned, geodetic_to_local_ned, local_ned_to_geodetic, normal_gravity};
use crate::gnss::GnssEpoch;
use crate::imu::ImuSample;
use crate::position::GeoPos;

mod checks;
mod heading_bank;
mod motion;
mod static_start;

pub use checks::{time_offset, turn_ratio, TimeOffset, TurnRatio};
pub use heading_bank::{
    heading_bank, BankHeading, BankStart, Wheels, BANK_ACCEL_NOISE, BANK_DRIFT_TIME, BANK_SIZE,
    ODOMETER_SCALE_STD, WHEEL_INTERVAL,
};
pub use motion::{align_in_motion, fit_span, MotionFit, GROSS, MISFIT};
pub use static_start::{
    detect_static, static_gyro_bias, still_span, StaticStart, MOVING_SIGMAS, MOVING_SPEED,
};
