//! GNSS without an INS: RINEX and u-blox observations, the broadcast navigation messages
//! and their ephemerides, time scales, the satellite and atmosphere models, the single
//! point and RTK (double differences, integer ambiguities). The INS crate
//! (`ins-gnss-core`) builds its tight coupling and its fixes on this one; the program
//! (`ins-gnss`) runs its `spp` and `rtk` commands from it.
//!
//! | module | what |
//! |---|---|
//! | [`time`] | [`GpsTime`] (week, seconds of week), [`Sat`], [`System`] |
//! | [`calendar`] | civil dates, leap seconds, time systems: epochs on the GPST seconds-of-week scale |
//! | [`geodesy`] | the WGS-84 ellipsoid, geodetic ↔ ECEF ↔ local NED |
//! | [`obs`] | [`ObsEpoch`]: per satellite, two frequencies' code, phase, Doppler, C/N0 |
//! | [`rinex`] | RINEX 2/3 observation ([`ObsReader`]) and navigation ([`read_nav`]) files |
//! | [`ephemeris`] | broadcast orbits: satellite position, velocity, clock |
//! | [`atmosphere`] | Klobuchar ionosphere, Saastamoinen troposphere (1/sin or Niell mapping) |
//! | [`lnav`], [`inav`], [`bds`] | GPS LNAV subframes, Galileo I/NAV words and BeiDou D1 subframes to ephemerides and back |
//! | [`ubx`] | u-blox RXM-RAWX observations, RXM-SFRBX navigation data, NAV-RELPOSNED headings |
//! | [`heading`] | [`heading::AntennaHeading`]: a heading between two antennas |
//! | [`spp`] | single point: weighted least squares, χ² check, RAIM exclusion, Doppler velocity |
//! | [`rtk`], [`lambda`] | RTK: double differences against a base, float and integer ambiguities (LAMBDA) |
//! | [`input`] | opening files, decompressed on the fly (`.gz`, `.zst`, `.xz`) |
#![deny(missing_docs)]
#![allow(non_snake_case)]

pub mod atmosphere;
pub mod bds;
pub mod calendar;
pub mod ephemeris;
mod fields;
pub mod geodesy;
pub mod heading;
pub mod inav;
pub mod input;
pub mod lambda;
pub mod lnav;
pub mod obs;
pub mod rinex;
pub mod rtcm;
pub mod rtk;
pub mod spp;
pub mod time;
pub mod ubx;

pub use ephemeris::{Ephemerides, Ephemeris, SatState};
pub use obs::{ObsEpoch, SatObs, Signal};
pub use rinex::{read_nav, NavData, ObsReader};
pub use spp::{single_point, Spp, SppFailure, SppOptions};
pub use time::{GpsTime, Sat, System};

use std::path::PathBuf;

/// A located error in a raw GNSS file: the file, the 1-based line (0: the file as a
/// whole), what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct RawError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

impl core::fmt::Display for RawError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.path.display(), self.message)
        } else {
            write!(f, "{}:{}: {}", self.path.display(), self.line, self.message)
        }
    }
}

impl std::error::Error for RawError {}

/// Opens a raw GNSS file (plain, `.gz`, `.zst`, `.xz`) with the readers' error: the file
/// named once, what went wrong.
pub(crate) fn open_input(path: &std::path::Path) -> Result<input::Input, RawError> {
    input::open(path).map_err(|m| RawError {
        path: path.to_path_buf(),
        line: 0,
        message: format!("cannot read: {m}"),
    })
}
