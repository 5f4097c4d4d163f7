//! The INS/GNSS library: the 15-state error-state filter on a WGS-84 navigation state,
//! driven by IMU samples and GNSS epochs. The GNSS without an INS (RINEX, u-blox,
//! ephemerides, time scales, the single point, RTK) is the `gnss` crate, which tight
//! coupling builds on (this crate's own [`gnss`] module is the fixes' measurement models
//! of loose coupling); the file formats (KF-GINS text, column maps, RTKLIB, NMEA, ROS) are
//! `ins-gnss-io`'s. No command-line, plotting, configuration-file or file-format
//! dependencies: the `ins-gnss` program and the `ins-gnss-sim` simulator are crates of
//! their own built on this one.
//!
//! | module or item | what |
//! |---|---|
//! | [`wgs84`] | the ellipsoid: constants, radii of curvature, trigonometry near a cached latitude |
//! | [`earth`] | WGS-84 gravity, Earth and transport rates, geodetic ↔ ECEF ↔ NED, [`earth::LocalEarth`] |
//! | [`GeoPos`] | the geodetic position as a manifold with NED-metre tangent |
//! | [`InsState`] | attitude, velocity, position, biases; 15-dimensional error state |
//! | [`imu`] | [`ImuSample`] (increments), [`ImuNoise`] and [`BiasModel`] |
//! | [`mechanization`] | WGS-84 NED (coning, sculling) and flat-earth mechanizations |
//! | [`model`] | [`InsModel`]: mechanization, `F`, `G Q_c Gᵀ`, `Φ`, `Q_d`, block-sparse `Φ P Φᵀ` |
//! | [`gnss`] | [`GnssPosition`], [`GnssVelocity`], [`GnssPosVel`] with lever arm; [`GnssEpoch`] |
//! | [`heading`] | heading (and pitch) from two antennas: [`heading::BaselineHeading`], [`heading::AntennaHeading`] |
//! | [`navigator`] | [`Navigator`]: the filter driven by IMU samples, GNSS epochs applied at their exact time |
//! | [`calibration`] | the rig's calibration as states: the antenna lever arm, the IMU–GNSS time offset, the mounting in the vehicle, the odometer's scale and wheel point, [`calibration::InsStateCal`] (26) |
//! | [`fix_error`] | the GNSS fixes' persisting (Gauss–Markov) error as states: [`fix_error::InsStateFe`] (18), [`fix_error::InsState21Fe`] (24) |
//! | [`scale`] | the 21-state INS: [`scale::InsState21`] (15 + gyro and accelerometer scale factors), [`scale::InsModel21`] |
//! | [`tight`] | tight coupling: [`tight::InsStateTc`] (15 + clock + inter-system biases) and [`tight::InsStateTc21`] (21 + clock + biases), per-satellite pseudorange and range-rate models |
//! | [`vehicle`] | land-vehicle aiding: [`vehicle::Nhc`], [`vehicle::Zupt`], [`vehicle::Zaru`], the stationary detector |
//! | [`align`] | initialisation from the data: the static start (levelling, gyro biases, noise), the in-motion alignment |
//! | [`init`] | static coarse alignment, heading from the GNSS track |
//!
//! Error state `[δθ, δv, δp, δb_g, δb_a]`: right (body-frame) attitude error, NED velocity
//! error, NED-metre position error, additive biases.
#![deny(missing_docs)]
#![allow(non_snake_case)]

pub mod align;
pub mod allan;
mod augment;
pub mod calibration;
pub mod earth;
pub mod fix_error;
pub mod gnss;
pub mod heading;
pub mod imu;
pub mod init;
pub mod mechanization;
pub mod model;
pub mod navigator;
mod position;
pub mod scale;
mod spill;
mod state;
pub mod tight;
pub mod vehicle;
pub mod wgs84;

pub use position::GeoPos;
pub use state::InsState;

// The main items of the modules above, at the root for short paths; their documentation
// is the module's (`no_inline`: one page per item).
#[doc(no_inline)]
pub use gnss::{GnssEpoch, GnssPosVel, GnssPosition, GnssVelocity};
#[doc(no_inline)]
pub use imu::{BiasModel, ImuNoise, ImuSample};
#[doc(no_inline)]
pub use mechanization::Mechanization;
#[doc(no_inline)]
pub use model::{ImuInput, InsModel};
#[doc(no_inline)]
pub use navigator::{GnssConfig, InitialState, InitialStd, NavError, Navigator};
#[doc(no_inline)]
pub use vehicle::VehicleAiding;
