//! A 9-state attitude and heading reference system (paper `cs-maekf-ahrs`).
//!
//! State: attitude `R_nb` (So3, right error `δθ`), gyro drift `b_g`, and a third block
//! whose meaning depends on the variant:
//!
//! | variant | third block | its model | accelerometer measurement |
//! |---|---|---|---|
//! | [`AccelModel::CurrentStatistical`] (CS-MAEKF) | body-frame maneuvering acceleration `a` | CS model, `Q` adapted from `ā` by the membership law | `f = a − R_nbᵀ g` |
//! | [`AccelModel::RandomWalk`] ("modified 9-state EKF", Guo et al.) | `a` | random walk with a fixed intensity | `f = a − R_nbᵀ g` |
//! | [`AccelModel::None`] ("conventional 9-state EKF") | accelerometer bias `b_a` | random walk, small | `f = b_a − R_nbᵀ g` |
//!
//! The paper says only that the conventional filter "does not consider the maneuvering
//! acceleration"; **our reading** is the common 9-state gravity/magnetometer AHRS whose
//! third block is the accelerometer bias, so maneuvering acceleration enters as
//! unmodelled measurement error. The magnetometer measures `m = R_nbᵀ m_n`.
//!
//! Error dynamics (right perturbation), with `ω = ω_m − b_g` held over `T`:
//! `Φ_θθ = Exp(ωT)ᵀ`, `Φ_θb = −Jr(ωT) T`, `Φ_aa = e^{−αT} I` (CS) or `I`.

#[cfg(feature = "std")]
pub mod experiment;
mod model;
pub mod onboard;
#[cfg(feature = "std")]
pub mod sim;

pub use model::{AccelModel, AhrsInput, AhrsMeasurement, AhrsModel, AhrsState, AhrsTuning};
pub use onboard::{Ahrs, Recording};
