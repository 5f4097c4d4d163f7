//! Initialisation: static coarse alignment and heading from the GNSS track.
//!
//! At rest the accelerometers measure `f_b = R_nbᵀ [0, 0, −g]`, so
//! `pitch = atan2(f_x, √(f_y² + f_z²))` and `roll = atan2(−f_y, −f_z)` (Groves 2013,
//! §5.6.2). The gyros measure the Earth rate plus their bias; with the heading known the
//! Earth rate `R_nbᵀ ω_ie^n` is removed and the rest is the bias. Heading comes from a
//! given value or from the GNSS track once the vehicle moves.

use manifolds::So3;
use nalgebra::Vector3;

use crate::earth::earth_rate_ned;

/// Result of a static coarse alignment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    /// Roll, rad.
    pub roll: f64,
    /// Pitch, rad.
    pub pitch: f64,
    /// Yaw, rad (as given).
    pub yaw: f64,
    /// Gyro bias estimate, rad/s.
    pub gyro_bias: Vector3<f64>,
}

/// Roll and pitch from the mean specific force at rest (m/s², FRD).
pub fn level(mean_f_b: &Vector3<f64>) -> (f64, f64) {
    let roll = (-mean_f_b.y).atan2(-mean_f_b.z);
    let pitch = mean_f_b.x.atan2((mean_f_b.y.powi(2) + mean_f_b.z.powi(2)).sqrt());
    (roll, pitch)
}

/// Static coarse alignment from mean specific force and mean angular rate (rad/s) at
/// latitude `lat` with heading `yaw` (rad).
pub fn coarse_align(
    mean_f_b: &Vector3<f64>,
    mean_w_b: &Vector3<f64>,
    lat: f64,
    yaw: f64,
) -> Alignment {
    let (roll, pitch) = level(mean_f_b);
    let r_nb = So3::from_euler(roll, pitch, yaw);
    let earth_in_body = r_nb.inverse().rotate(&earth_rate_ned(lat));
    Alignment { roll, pitch, yaw, gyro_bias: mean_w_b - earth_in_body }
}

/// Heading (rad) of a NED velocity, when the horizontal speed exceeds `min_speed` (m/s).
pub fn heading_from_velocity(v_n: &Vector3<f64>, min_speed: f64) -> Option<f64> {
    let s = (v_n.x * v_n.x + v_n.y * v_n.y).sqrt();
    (s >= min_speed).then(|| v_n.y.atan2(v_n.x))
}
