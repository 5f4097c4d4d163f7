//! The plain-text formats of the open INS/GNSS tools (KF-GINS, OB_GINS, i2Nav datasets),
//! read and written so people can switch without converting:
//!
//! | file | columns |
//! |---|---|
//! | IMU increments | `t dθx dθy dθz [rad] dvx dvy dvz [m/s]` (FRD, over the previous interval), optional 8th column (odometer speed, m/s) |
//! | IMU rates (CSV with a header) | `t gx gy gz [rad/s] ax ay az [m/s²]` |
//! | GNSS | `t lat lon [deg] h [m] σN σE σD [m]` (7) or `… vN vE vD σvN σvE σvD` (13) |
//! | navigation / truth | `week t lat lon h vN vE vD roll pitch yaw [deg]` (11) |
//!
//! # Bad-line policy
//!
//! With [`BadLinePolicy::Error`] (the default) the first malformed line stops the read with
//! a [`LineError`] naming file and line. With [`BadLinePolicy::Skip`] a malformed line
//! (wrong column count, non-numeric, NaN/inf, time backwards, duplicate time) is skipped
//! and counted in [`SkipCounts`]; an IMU gap longer than allowed is *bridged* (the sample
//! is used with the real interval) and counted. File-level problems (missing, empty,
//! values in the wrong units) are always errors.
//!
//! # Compressed files and byte-order marks
//!
//! Every reader opens `.gz`, `.zst` and `.xz` files transparently ([`open`]), and a UTF-8
//! byte-order mark at the start of a file is ignored.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::Path;

use manifolds::So3;
use nalgebra::Vector3;

use super::columns::{ColumnMap, Resolved};
use super::lines::{LineError, LineErrorKind, NumericLines};
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::imu::ImuSample;
use ins_gnss_core::GeoPos;

/// What to do with a malformed line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BadLinePolicy {
    /// Stop with an error naming file and line (default).
    #[default]
    Error,
    /// Skip the line and count it.
    Skip,
}

/// Lines skipped (or gaps bridged) under [`BadLinePolicy::Skip`], by cause.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SkipCounts {
    /// Wrong column count, non-numeric or non-finite values.
    pub malformed: usize,
    /// Time earlier than the previous line.
    pub backwards: usize,
    /// Time equal to the previous line.
    pub duplicate: usize,
    /// IMU gaps longer than allowed that were bridged.
    pub gaps: usize,
}

impl SkipCounts {
    /// Total.
    pub fn total(&self) -> usize {
        self.malformed + self.backwards + self.duplicate + self.gaps
    }
}

/// Checks one record's time against the previous one.
fn check_time(prev: Option<f64>, t: f64) -> Result<(), LineErrorKind> {
    match prev {
        Some(p) if t < p => Err(LineErrorKind::TimeBackwards { t, previous: p }),
        Some(p) if t == p => Err(LineErrorKind::DuplicateTime { t }),
        _ => Ok(()),
    }
}

fn count(counts: &mut SkipCounts, kind: &LineErrorKind) {
    match kind {
        LineErrorKind::TimeBackwards { .. } => counts.backwards += 1,
        LineErrorKind::DuplicateTime { .. } => counts.duplicate += 1,
        LineErrorKind::Gap { .. } => counts.gaps += 1,
        _ => counts.malformed += 1,
    }
}

/// Move `lines` to its next record under `policy`: a malformed line is an error, or a
/// counted skip; `false` at the end of the file, `Empty` when it had no record at all.
/// The record is then `lines.values()`.
fn next_record<R: BufRead>(
    lines: &mut NumericLines<R>,
    policy: BadLinePolicy,
    skipped: &mut SkipCounts,
    records_so_far: usize,
) -> Result<bool, LineError> {
    loop {
        match lines.next_record() {
            Ok(Some(_)) => return Ok(true),
            Ok(None) if records_so_far == 0 => {
                return Err(LineError {
                    path: lines.path().to_path_buf(),
                    line: 0,
                    kind: LineErrorKind::Empty,
                });
            }
            Ok(None) => return Ok(false),
            Err(e) if policy == BadLinePolicy::Skip && !matches!(e.kind, LineErrorKind::Io(_)) => {
                count(skipped, &e.kind)
            }
            Err(e) => return Err(e),
        }
    }
}

/// An input with nothing in it (readers of arrays).
fn empty_input() -> Input {
    BufReader::new(Box::new(std::io::empty()))
}

/// A reader's column map, before and after its header is read, and the mapped values.
#[derive(Default)]
enum Mapping {
    #[default]
    None,
    Pending(ColumnMap),
    Resolved(Resolved, Vec<f64>),
}

impl Mapping {
    /// Read the header and select the map's columns (once).
    fn start<R: BufRead>(&mut self, lines: &mut NumericLines<R>) -> Result<(), LineError> {
        if let Mapping::Pending(map) = self {
            let header = if map.headerless {
                String::new()
            } else {
                match lines.next_text()? {
                    Some(h) => h.to_string(),
                    None => return Err(lines.error(LineErrorKind::Empty)),
                }
            };
            let resolved =
                map.resolve(&header).map_err(|m| lines.error(LineErrorKind::WrongUnits(m)))?;
            lines.select(&resolved.columns);
            *self = Mapping::Resolved(resolved, Vec::new());
        }
        Ok(())
    }

    /// The record: the mapped fields, or the line's values as they are.
    fn record<'a>(&'a mut self, values: &'a [f64]) -> &'a [f64] {
        match self {
            Mapping::Resolved(r, out) => {
                r.apply(values, out);
                out
            }
            _ => values,
        }
    }
}

mod files;
mod gnss;
mod heading;
mod imu;
mod nav;

pub use files::{create, create_partial, open, partial_path, publish, write_published, Input};
pub use gnss::{write_gnss, GnssFormat, GnssReader};
pub use heading::{attach_headings, read_headings, write_headings, Headings};
pub use imu::{write_imu, ImuFormat, ImuReader, DEFAULT_MAX_BRIDGE};
pub use nav::{push_nav, write_nav, NavReader, NavRecord};
