//! RINEX 2.10/2.11 and 3.0x observation and navigation files (GPS, Galileo, BeiDou,
//! QZSS; GLONASS and SBAS records are read past and counted).
//!
//! Written here rather than taken from the `rinex` crate, by measurement: `rinex` 0.24
//! with its `obs` and `nav` features pulls 198 crates (a second nalgebra, an HTTP and
//! TLS stack through `anise`) and took 5 min 26 s to build in release on this project's
//! 2-core machine, for the two fixed-column formats this file reads in ~500 lines. Its
//! values on the shipped files agree with this reader's (checked by hand on the first
//! epochs and records); the tests check this reader against RTKLIB's own decoding.
//!
//! Errors carry the file and the 1-based line; a file is refused, never half read, when
//! a line cannot be what the format says.

use super::atmosphere::Klobuchar;
use super::ephemeris::{Ephemerides, Ephemeris};
use super::obs::{slot_of, ObsEpoch, SatObs, Signal};
use super::open_input;
use super::time::{GpsTime, Sat, System, BDT_MINUS_GPST, BDT_WEEK_OFFSET};
use super::RawError;
use crate::input::Input;
use nalgebra::Vector3;
use std::io::BufRead;
use std::path::{Path, PathBuf};

mod navigation;
mod observations;

pub use navigation::{read_nav, NavData};
pub use observations::{ObsHeader, ObsReader};

fn err(path: &Path, line: usize, message: impl Into<String>) -> RawError {
    RawError { path: path.to_path_buf(), line, message: message.into() }
}

/// A fixed-column number: blank is `None`; Fortran `D` exponents accepted.
fn field(line: &str, from: usize, to: usize) -> Result<Option<f64>, String> {
    let end = to.min(line.len());
    if from >= end {
        return Ok(None);
    }
    let s = line.get(from..end).ok_or_else(|| format!("columns {}–{to} are not text", from + 1))?;
    let t = s.trim();
    if t.is_empty() {
        return Ok(None);
    }
    let v: f64 =
        if t.contains(['D', 'd']) { t.replace(['D', 'd'], "E").parse() } else { t.parse() }
            .map_err(|_| format!("columns {}–{to} are not a number: `{t}`", from + 1))?;
    if v.is_finite() {
        Ok(Some(v))
    } else {
        Err(format!("columns {}–{to} are not finite", from + 1))
    }
}

fn int_field(line: &str, from: usize, to: usize) -> Result<Option<i64>, String> {
    let end = to.min(line.len());
    match line.get(from..end).map(str::trim) {
        None | Some("") => Ok(None),
        Some(t) => t
            .parse()
            .map(Some)
            .map_err(|_| format!("columns {}–{to}: `{t}` is not an integer", from + 1)),
    }
}

fn year4(y: i64) -> i64 {
    match y {
        0..=79 => 2000 + y,
        80..=99 => 1900 + y,
        _ => y,
    }
}

fn label(line: &str) -> &str {
    line.get(60..).unwrap_or("").trim_end()
}

/// Reads the lines up to `END OF HEADER`, calling `each` on each (its
/// error is located at the line).
fn read_header(
    input: &mut Input,
    path: &Path,
    line_no: &mut usize,
    mut each: impl FnMut(&str) -> Result<(), String>,
) -> Result<(), RawError> {
    let mut line = String::new();
    loop {
        line.clear();
        let n = input.read_line(&mut line).map_err(|e| err(path, *line_no, e.to_string()))?;
        if n == 0 {
            return Err(err(path, *line_no, "no `END OF HEADER`"));
        }
        *line_no += 1;
        let l = line.trim_end_matches(['\n', '\r']);
        if label(l) == "END OF HEADER" {
            return Ok(());
        }
        each(l).map_err(|m| err(path, *line_no, m))?;
    }
}

fn version_and_type(l: &str) -> Result<(f64, char, char), String> {
    let v = field(l, 0, 9)?.ok_or("no version in `RINEX VERSION / TYPE`")?;
    let kind = l.chars().nth(20).unwrap_or(' ');
    let sys = l.chars().nth(40).unwrap_or(' ');
    Ok((v, kind, sys))
}
