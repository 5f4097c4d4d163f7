//! The 15-state INS/GNSS filter and its program.
//!
//! | item | what |
//! |---|---|
//! | [`earth`] | WGS-84: gravity, radii, Earth and transport rates, geodetic ↔ ECEF ↔ NED |
//! | [`GeoPos`] | geodetic position as a manifold with NED-metre tangent |
//! | [`InsState`] | attitude, velocity, position, biases; 15-dimensional error state |
//! | [`mechanization`] | WGS-84 NED (coning, sculling) and flat-earth mechanizations |
//! | [`InsModel`] | the process model: mechanization, `F`, `G Q_c Gᵀ`, `Φ`, `Q_d`, block-sparse `Φ P Φᵀ` |
//! | [`GnssPosition`], [`GnssVelocity`], [`GnssPosVel`] | GNSS measurement models with lever arm |
//! | [`Navigator`] | the filter driven by IMU samples, GNSS epochs applied at their exact time |
//! | [`init`] | initial state, static coarse alignment, heading from the GNSS track |
//! | [`sim`] | trajectory, IMU and GNSS simulator |
//!
//! Error state `[δθ, δv, δp, δb_g, δb_a]`: right (body-frame) attitude error, NED velocity
//! error, NED-metre position error, additive biases.
#![deny(missing_docs)]
#![allow(non_snake_case)]

pub mod cli;
pub mod config;
pub mod earth;
pub mod eval;
pub mod gnss;
pub mod imu;
pub mod init;
pub mod io;
pub mod mechanization;
pub mod model;
pub mod navigator;
pub mod plot;
pub mod position;
pub mod run;
pub mod scenario;
pub mod sim;
pub mod state;

pub use gnss::{GnssEpoch, GnssPosVel, GnssPosition, GnssVelocity};
pub use imu::{BiasModel, ImuNoise, ImuSample};
pub use mechanization::Mechanization;
pub use model::{ImuInput, InsModel};
pub use navigator::{GnssConfig, InitialState, InitialStd, NavError, Navigator};
pub use position::GeoPos;
pub use state::InsState;
