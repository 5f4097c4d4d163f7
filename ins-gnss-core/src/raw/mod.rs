//! Raw GNSS: observations and broadcast ephemerides from RINEX, the satellite and
//! atmosphere models, and the single-point solution.
//!
//! | module | what |
//! |---|---|
//! | [`time`] | [`GpsTime`] (week, seconds of week), [`Sat`], [`System`] |
//! | [`obs`] | [`ObsEpoch`]: per satellite, two frequencies' code, phase, Doppler, C/N0 |
//! | [`rinex`] | RINEX 2/3 observation ([`ObsReader`]) and navigation ([`read_nav`]) files |
//! | [`ephemeris`] | broadcast orbits: satellite position, velocity, clock |
//! | [`atmosphere`] | Klobuchar ionosphere, Saastamoinen troposphere (1/sin or Niell mapping) |
//! | [`lnav`], [`inav`], [`bds`] | GPS LNAV subframes, Galileo I/NAV words and BeiDou D1 subframes to ephemerides and back |
//! | [`ubx`] | u-blox RXM-RAWX observations and RXM-SFRBX navigation data |
//! | [`spp`] | single point: weighted least squares, χ² check, RAIM exclusion, Doppler velocity |

pub mod atmosphere;
pub mod bds;
pub mod ephemeris;
mod fields;
pub mod inav;
pub mod lambda;
pub mod lnav;
pub mod obs;
pub mod rinex;
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
pub(crate) fn open_input(path: &std::path::Path) -> Result<crate::io::formats::Input, RawError> {
    crate::io::formats::open(path).map_err(|e| RawError {
        path: path.to_path_buf(),
        line: 0,
        message: match e.kind {
            crate::io::lines::LineErrorKind::Io(m) => format!("cannot read: {m}"),
            other => format!("{other:?}"),
        },
    })
}
