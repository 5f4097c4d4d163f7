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
use std::io::{BufRead, BufReader, BufWriter, Read, Write};
use std::path::Path;
use std::sync::{Arc, Mutex};

use manifolds::So3;
use nalgebra::Vector3;

use super::columns::{ColumnMap, Resolved};
use super::lines::{LineError, LineErrorKind, NumericLines};
use crate::gnss::GnssEpoch;
use crate::imu::ImuSample;
use crate::position::GeoPos;

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

/// A buffered input file, decompressed on the fly when its name ends in `.gz`, `.zst` or
/// `.xz`.
pub type Input = BufReader<Box<dyn Read + Send>>;

/// Open a file for buffered reading, with a located error; `.gz`, `.zst` (`.zstd`) and
/// `.xz` files are decompressed as they are read (users' logs are often compressed).
pub fn open(path: &Path) -> Result<Input, LineError> {
    let err =
        |e: String| LineError { path: path.to_path_buf(), line: 0, kind: LineErrorKind::Io(e) };
    let file = File::open(path).map_err(|e| err(e.to_string()))?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let raw = BufReader::with_capacity(1 << 16, file);
    let inner: Box<dyn Read + Send> = match ext.as_str() {
        "gz" | "gzip" => Box::new(flate2::bufread::MultiGzDecoder::new(raw)),
        "zst" | "zstd" => Box::new(
            zstd::stream::read::Decoder::with_buffer(raw)
                .map_err(|e| err(format!("not a zstd file: {e}")))?,
        ),
        "xz" => Box::new(xz_reader(raw)),
        _ => Box::new(raw),
    };
    Ok(BufReader::with_capacity(1 << 16, inner))
}

/// An xz stream decoded by liblzma on a thread of its own into a pipe, so that decoding
/// (xz's own `xz -dc` takes 2.3× the whole plain navego run here) overlaps parsing and
/// filtering. A decoding error is stored before the pipe closes, so the reader reports
/// it instead of a short file.
fn xz_reader(mut raw: BufReader<File>) -> XzInput {
    let (reader, mut writer) = match std::io::pipe() {
        Ok(p) => p,
        Err(e) => {
            return XzInput { pipe: None, failure: Arc::new(Mutex::new(Some(e.to_string()))) }
        }
    };
    let failure = Arc::new(Mutex::new(None));
    let slot = Arc::clone(&failure);
    std::thread::spawn(move || {
        let mut decoder = liblzma::bufread::XzDecoder::new_multi_decoder(&mut raw);
        if let Err(e) = std::io::copy(&mut decoder, &mut writer) {
            if let Ok(mut s) = slot.lock() {
                *s = Some(format!("xz decoding failed: {e}"));
            }
        }
        drop(writer);
    });
    XzInput { pipe: Some(reader), failure }
}

struct XzInput {
    pipe: Option<std::io::PipeReader>,
    failure: Arc<Mutex<Option<String>>>,
}

impl Read for XzInput {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = match &mut self.pipe {
            Some(p) => p.read(buf)?,
            None => 0,
        };
        if n == 0 {
            if let Some(e) = self.failure.lock().ok().and_then(|mut s| s.take()) {
                return Err(std::io::Error::other(e));
            }
        }
        Ok(n)
    }
}

/// The largest IMU gap [`BadLinePolicy::Skip`] bridges by default, in IMU intervals
/// ([`ImuReader::with_max_bridge`]).
pub const DEFAULT_MAX_BRIDGE: f64 = 20.0;

/// IMU file format.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ImuFormat {
    /// Increments, 7 or 8 columns (default).
    #[default]
    Increments,
    /// Rates with a header line.
    Rates,
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
                })
            }
            Ok(None) => return Ok(false),
            Err(e) if policy == BadLinePolicy::Skip && !matches!(e.kind, LineErrorKind::Io(_)) => {
                count(skipped, &e.kind)
            }
            Err(e) => return Err(e),
        }
    }
}

/// Streaming IMU reader.
pub struct ImuReader<R: BufRead> {
    lines: NumericLines<R>,
    format: ImuFormat,
    nominal_dt: f64,
    max_gap: f64,
    max_bridge: f64,
    policy: BadLinePolicy,
    prev_t: Option<f64>,
    prev_line: usize,
    /// Rates: the last records read (time, interval, ω, f, odometer), oldest first, up to
    /// four; the interval ending at the second-newest is emitted once the newest is read.
    rate_history: Vec<RateRecord>,
    /// Rates: the line of the last sample returned.
    emitted_line: usize,
    header_done: bool,
    /// What was skipped so far.
    pub skipped: SkipCounts,
    records: usize,
    columns: Mapping,
    /// Sensor-to-body rotation applied to every sample as it is read.
    mounting: Option<nalgebra::Matrix3<f64>>,
    /// Seconds added to every sample's time ([`ImuReader::with_time_offset`]).
    time_offset: f64,
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

impl ImuReader<Input> {
    /// Open an IMU file at `rate_hz` (the first sample's interval is `1/rate_hz`). A gap
    /// longer than `max_gap_factor / rate_hz` is an error, or under
    /// [`BadLinePolicy::Skip`] a counted bridge; see [`with_max_bridge`](Self::with_max_bridge).
    pub fn open(
        path: &Path,
        format: ImuFormat,
        rate_hz: f64,
        max_gap_factor: f64,
        policy: BadLinePolicy,
    ) -> Result<Self, LineError> {
        Ok(Self::new(open(path)?, path, format, rate_hz, max_gap_factor, policy))
    }

    /// Read the rows of an array instead of a file: `data` row-major, 7 or 8 numbers per
    /// row (`t`, then the file format's columns in its units: increments in rad and m/s,
    /// or rates in rad/s and m/s², then the optional odometer speed), with the file's
    /// checks, mounting and rate integration; `name` and the 1-based row stand for the
    /// file and line in errors.
    pub fn from_rows(
        data: std::sync::Arc<[f64]>,
        width: usize,
        name: &Path,
        format: ImuFormat,
        rate_hz: f64,
        max_gap_factor: f64,
        policy: BadLinePolicy,
    ) -> Self {
        let mut r = Self::new(empty_input(), name, format, rate_hz, max_gap_factor, policy);
        r.lines = r.lines.with_rows(data, width);
        r.header_done = true;
        r
    }
}

/// An input with nothing in it (readers of arrays).
fn empty_input() -> Input {
    BufReader::new(Box::new(std::io::empty()))
}

impl<R: BufRead> ImuReader<R> {
    /// Read from any `BufRead`.
    pub fn new(
        inner: R,
        path: &Path,
        format: ImuFormat,
        rate_hz: f64,
        max_gap_factor: f64,
        policy: BadLinePolicy,
    ) -> Self {
        let nominal_dt = 1.0 / rate_hz;
        Self {
            lines: NumericLines::new(inner, path),
            format,
            nominal_dt,
            max_gap: nominal_dt * max_gap_factor,
            max_bridge: nominal_dt * max_gap_factor.max(DEFAULT_MAX_BRIDGE),
            policy,
            prev_t: None,
            prev_line: 0,
            rate_history: Vec::with_capacity(4),
            emitted_line: 0,
            header_done: format == ImuFormat::Increments,
            skipped: SkipCounts::default(),
            records: 0,
            columns: Mapping::None,
            mounting: None,
            time_offset: 0.0,
        }
    }

    /// Rotate every sample from the sensor's axes into the body frame: `C_bs`, the
    /// sensor-to-body rotation (a proper rotation; the configuration refuses a
    /// left-handed one), applied to the rates and specific forces (or increments) as they
    /// are read, before rates are integrated.
    pub fn with_mounting(mut self, c_bs: nalgebra::Matrix3<f64>) -> Self {
        self.mounting = Some(c_bs);
        self
    }

    /// Read a log with a header through `map`: fields `t, ωx, ωy, ωz, fx, fy, fz` and
    /// optionally the odometer speed, in s, rad/s and m/s² for rates (rad and m/s for
    /// increments), FRD axes (see [`crate::io::columns`]).
    pub fn with_columns(mut self, map: ColumnMap) -> Self {
        self.columns = Mapping::Pending(map);
        self.header_done = true;
        self
    }

    /// The largest gap [`BadLinePolicy::Skip`] bridges in one step, in IMU intervals
    /// (default [`DEFAULT_MAX_BRIDGE`], and never less than the gap limit); a longer one is an error naming
    /// the lines on both sides (a one-hour hole is not one IMU step).
    pub fn with_max_bridge(mut self, intervals: f64) -> Self {
        self.max_bridge = self.nominal_dt * intervals.max(self.max_gap / self.nominal_dt);
        self
    }

    /// Add `offset` seconds to every sample's time as it is read (an IMU whose clock runs
    /// behind or ahead of the GNSS's; the file's own times are checked as they are).
    pub fn with_time_offset(mut self, offset: f64) -> Self {
        self.time_offset = offset;
        self
    }

    /// The next sample, `Ok(None)` at the end.
    pub fn next_sample(&mut self) -> Result<Option<ImuSample>, LineError> {
        let s = self.next_sample_as_stamped()?;
        if self.time_offset == 0.0 {
            return Ok(s);
        }
        Ok(s.map(|s| ImuSample { t: s.t + self.time_offset, ..s }))
    }

    /// The next sample with the file's time.
    fn next_sample_as_stamped(&mut self) -> Result<Option<ImuSample>, LineError> {
        if !self.header_done {
            // Rates: the first data line is a header naming the seven columns (a line of
            // numbers, `1e-3` included, is data, not a header).
            match self.lines.next_text()? {
                Some(h)
                    if {
                        let fields: Vec<&str> = h
                            .split(|c: char| c == ',' || c.is_whitespace())
                            .filter(|s| !s.is_empty())
                            .collect();
                        fields.len() == 7 && fields.iter().any(|s| s.parse::<f64>().is_err())
                    } => {}
                Some(_) => return Err(self.lines.error(LineErrorKind::WrongUnits(
                    "a rate-type IMU file needs a header line `t,gx,gy,gz,ax,ay,az` (rad/s, m/s²)"
                        .into(),
                ))),
                None => return Err(self.lines.error(LineErrorKind::Empty)),
            }
            self.header_done = true;
        }
        self.columns.start(&mut self.lines)?;
        loop {
            if !next_record(&mut self.lines, self.policy, &mut self.skipped, self.records)? {
                // rates: the last interval, without a sample after it
                if let Some(s) = integrate_rates(&self.rate_history, 0) {
                    self.emitted_line = self.rate_history[self.rate_history.len() - 1].line;
                    self.rate_history.clear();
                    return Ok(Some(s));
                }
                return Ok(None);
            }
            let rec = self.columns.record(self.lines.values());
            let allowed: &[usize] = match self.format {
                ImuFormat::Increments => &[7, 8],
                ImuFormat::Rates => &[7, 8],
            };
            let checked = if !allowed.contains(&rec.len()) {
                Err(LineErrorKind::ColumnCount { expected: allowed.to_vec(), found: rec.len() })
            } else {
                check_time(self.prev_t, rec[0]).map(|_| {
                    (
                        rec[0],
                        Vector3::new(rec[1], rec[2], rec[3]),
                        Vector3::new(rec[4], rec[5], rec[6]),
                    )
                })
            };
            let (t, a, b) = match checked {
                Ok((t, a, b)) => match &self.mounting {
                    Some(c) => (t, c * a, c * b),
                    None => (t, a, b),
                },
                Err(kind) => {
                    if self.policy == BadLinePolicy::Skip {
                        count(&mut self.skipped, &kind);
                        continue;
                    }
                    return Err(self.lines.error(kind));
                }
            };
            let dt = match self.prev_t {
                Some(p) => t - p,
                None => self.nominal_dt,
            };
            if self.records < 20 && (dt > 100.0 * self.nominal_dt || dt < 0.01 * self.nominal_dt) {
                // the first intervals 100× off the rate: the times are not in seconds
                // (ms, µs) or the rate is wrong, not a gap
                return Err(self.lines.error(LineErrorKind::WrongUnits(format!(
                    "samples {dt} s apart where the IMU rate ({:.6} Hz) says {:.6} s: the \
                     times are not in seconds (a factor of {:.3e}), or the rate is wrong; \
                     set `time_unit` (ms, us, ns) in the column map or `data.imu_rate`",
                    1.0 / self.nominal_dt,
                    self.nominal_dt,
                    dt / self.nominal_dt
                ))));
            }
            if dt > self.max_gap {
                let bridged = self.policy == BadLinePolicy::Skip && dt <= self.max_bridge;
                let allowed =
                    if self.policy == BadLinePolicy::Skip { self.max_bridge } else { self.max_gap };
                let kind = LineErrorKind::Gap { gap: dt, allowed, previous_line: self.prev_line };
                if !bridged {
                    return Err(self.lines.error(kind));
                }
                count(&mut self.skipped, &kind);
            }
            let sample = match self.format {
                ImuFormat::Rates if self.records == 0 && b.norm() < 0.5 => {
                    // Gravity alone is 9.8 m/s²: a first specific force below 1 m/s² is an
                    // increment over one interval, not a rate.
                    return Err(self.lines.error(LineErrorKind::WrongUnits(format!(
                        "|f| = {:.4} m/s² is far below gravity: these look like increments, \
                         not rates; set the IMU format to increments",
                        b.norm()
                    ))));
                }
                ImuFormat::Rates if self.records == 0 && b.norm() > 5.0 * 9.80665 => {
                    // the first sample, at rest or nearly: gravity read in a unit
                    // 10×, 1000× … too large
                    let ratio = b.norm() / 9.80665;
                    return Err(self.lines.error(LineErrorKind::WrongUnits(format!(
                        "|f| = {:.3} m/s² is {ratio:.0}× gravity: `accel_unit` is about \
                         {:.0}× too large for this log (mg read as g: 1000×; m/s² read as g: \
                         9.8×)",
                        b.norm(),
                        if ratio > 300.0 { (ratio / 1000.0).round() * 1000.0 } else { ratio }
                    ))));
                }
                ImuFormat::Rates if b.norm() > 1000.0 || a.norm() > 50.0 => {
                    let kind = LineErrorKind::WrongUnits(format!(
                        "|ω| = {:.3} rad/s, |f| = {:.3} m/s²: beyond any IMU (50 rad/s, 100 g); \
                         a spike, or not rad/s and m/s²",
                        a.norm(),
                        b.norm()
                    ));
                    if self.policy == BadLinePolicy::Skip && self.records > 0 {
                        count(&mut self.skipped, &kind);
                        continue;
                    }
                    return Err(self.lines.error(kind));
                }
                ImuFormat::Increments => {
                    // Increments that are really rates: a stationary accelerometer gives
                    // |Δv| ≈ 9.8 m/s in one interval, i.e. > 100 g.
                    if b.norm() / dt > 1000.0 || a.norm() / dt > 50.0 {
                        return Err(self.lines.error(LineErrorKind::WrongUnits(format!(
                            "|Δθ| = {:.3} rad and |Δv| = {:.3} m/s in {dt:.4} s look like rates, not increments; \
                             set the IMU format to rates",
                            a.norm(),
                            b.norm()
                        ))));
                    }
                    let odometer = (rec.len() == 8).then(|| rec[7]);
                    if odometer.is_some_and(|v| !(v.is_finite() && v.abs() < 1000.0)) {
                        return Err(self.lines.error(LineErrorKind::WrongUnits(format!(
                            "odometer speed {} m/s (8th column): not finite or beyond 1000 m/s",
                            rec[7]
                        ))));
                    }
                    ImuSample { t, dt, dtheta: a, dvel: b, odometer }
                }
                ImuFormat::Rates => {
                    let odometer = (rec.len() == 8).then(|| rec[7]);
                    if self.rate_history.len() == 4 {
                        self.rate_history.remove(0);
                    }
                    let line = self.lines.line();
                    self.rate_history.push(RateRecord { t, dt, w: a, f: b, odometer, line });
                    self.prev_t = Some(t);
                    self.prev_line = self.lines.line();
                    self.records += 1;
                    // the interval ending at the previous record, now that the next is known
                    match integrate_rates(&self.rate_history, 1) {
                        Some(s) => {
                            self.emitted_line = self.rate_history[self.rate_history.len() - 2].line;
                            return Ok(Some(s));
                        }
                        None => continue,
                    }
                }
            };
            self.prev_t = Some(t);
            self.prev_line = self.lines.line();
            self.records += 1;
            return Ok(Some(sample));
        }
    }

    /// Line number of the last sample.
    pub fn line(&self) -> usize {
        match self.format {
            // (a rate sample is emitted when the line after it has been read)
            ImuFormat::Rates => self.emitted_line,
            ImuFormat::Increments => self.lines.line(),
        }
    }
}

/// One record of a rate-type IMU log.
#[derive(Clone, Copy, Debug)]
struct RateRecord {
    t: f64,
    dt: f64,
    w: Vector3<f64>,
    f: Vector3<f64>,
    odometer: Option<f64>,
    /// Its line in the file.
    line: usize,
}

/// The increments of the interval ending at `h[h.len() − 1 − ahead]` from instantaneous
/// rate samples (`ahead` = how many samples after it are known, 0 or 1; `None` when that
/// record does not exist).
///
/// With two samples on each side of a uniformly sampled interval, the integral of the
/// cubic through the four, `dt (−ω₋₁ + 13 ω₀ + 13 ω₁ − ω₂)/24` (exact for cubic rates;
/// on a 2 Hz coning sampled at 100 Hz the trapezoid's gain error is 1.3e-3, this one's
/// 3.8e-6: `tests/rate_path.rs`); at the log's second and last samples the quadratic
/// through three; across an irregular interval the trapezoid `dt (ω₀ + ω₁)/2`; for the
/// first record the rectangle over its nominal interval.
fn integrate_rates(h: &[RateRecord], ahead: usize) -> Option<ImuSample> {
    let j = h.len().checked_sub(1 + ahead)?;
    let cur = &h[j];
    // the mean rates over the interval from the samples around it, where there are enough
    let mean = j.checked_sub(1).and_then(|i| {
        let prev = &h[i];
        let uniform = |a: f64| (a - cur.dt).abs() <= 0.01 * cur.dt;
        match (j.checked_sub(2).map(|i| &h[i]), h.get(j + 1)) {
            (Some(p2), Some(next)) if uniform(prev.dt) && uniform(next.dt) => Some((
                (-p2.w + (prev.w + cur.w) * 13.0 - next.w) / 24.0,
                (-p2.f + (prev.f + cur.f) * 13.0 - next.f) / 24.0,
            )),
            // the log's first interval: the quadratic through it and the next sample
            (None, Some(next)) if uniform(next.dt) => Some((
                (prev.w * 5.0 + cur.w * 8.0 - next.w) / 12.0,
                (prev.f * 5.0 + cur.f * 8.0 - next.f) / 12.0,
            )),
            // its last: the quadratic through the two samples before
            (Some(p2), None) if uniform(prev.dt) => Some((
                (-p2.w + prev.w * 8.0 + cur.w * 5.0) / 12.0,
                (-p2.f + prev.f * 8.0 + cur.f * 5.0) / 12.0,
            )),
            _ => None,
        }
    });
    let mut s = match mean {
        Some((w, f)) => ImuSample::from_increments(cur.t, cur.dt, w * cur.dt, f * cur.dt),
        // the trapezoid, or the rectangle for the first record
        None => {
            let previous = j.checked_sub(1).map(|i| (h[i].w, h[i].f));
            ImuSample::from_rates(cur.t, cur.dt, cur.w, cur.f, previous)
        }
    };
    s.odometer = cur.odometer;
    Some(s)
}

/// The layout of a GNSS file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GnssFormat {
    /// An RTKLIB solution when the header says so, else the 7/13-column format (default).
    #[default]
    Auto,
    /// The 7- or 13-column KF-GINS format (or a column-mapped log).
    Columns,
    /// An RTKLIB solution file (`.pos`); see [`crate::io::rtklib`].
    Rtklib,
    /// NMEA 0183 sentences (GGA, GST, RMC/ZDA); see [`crate::io::nmea`].
    Nmea,
}

/// Streaming GNSS reader: the 7 or 13 columns of the KF-GINS format (detected from the
/// first data line), a column-mapped log, or an RTKLIB solution file (detected from its
/// header).
pub struct GnssReader<R: BufRead> {
    lines: NumericLines<R>,
    policy: BadLinePolicy,
    columns: Option<usize>,
    prev_t: Option<f64>,
    /// What was skipped so far.
    pub skipped: SkipCounts,
    records: usize,
    mapping: Mapping,
    format: GnssFormat,
    started: bool,
    rtklib: Option<super::rtklib::PosHeader>,
    quality: super::rtklib::QualityFactors,
    /// RTKLIB epochs dropped, by solution quality `Q` (0: no solution).
    pub dropped: [usize; 7],
    nmea: Option<super::nmea::NmeaState>,
    /// σ (N, E, D) for NMEA fixes without a GST sentence.
    default_sigma: Option<Vector3<f64>>,
}

impl GnssReader<Input> {
    /// Open a GNSS file.
    pub fn open(path: &Path, policy: BadLinePolicy) -> Result<Self, LineError> {
        Ok(Self::new(open(path)?, path, policy))
    }

    /// Read the rows of an array instead of a file: `data` row-major, 7 or 13 numbers per
    /// row in the 7/13-column format's order and units (`t`, latitude and longitude in
    /// degrees, height, σ N E D in m, then velocity N E D and its σ in m/s), with the
    /// file's checks; `name` and the 1-based row stand for the file and line in errors.
    pub fn from_rows(
        data: std::sync::Arc<[f64]>,
        width: usize,
        name: &Path,
        policy: BadLinePolicy,
    ) -> Self {
        let mut r = Self::new(empty_input(), name, policy).with_format(GnssFormat::Columns);
        r.lines = r.lines.with_rows(data, width);
        r
    }
}

impl<R: BufRead> GnssReader<R> {
    /// Read from any `BufRead`.
    pub fn new(inner: R, path: &Path, policy: BadLinePolicy) -> Self {
        Self {
            lines: NumericLines::new(inner, path),
            policy,
            columns: None,
            prev_t: None,
            skipped: SkipCounts::default(),
            records: 0,
            mapping: Mapping::None,
            format: GnssFormat::Auto,
            started: false,
            rtklib: None,
            quality: Default::default(),
            dropped: [0; 7],
            nmea: None,
            default_sigma: None,
        }
    }

    /// σ (N, E, D, m) for NMEA fixes that have no GST sentence.
    pub fn with_default_sigma(mut self, sigma: Option<Vector3<f64>>) -> Self {
        self.default_sigma = sigma;
        self
    }

    /// NMEA epochs dropped, by GGA fix quality (0–9), when the file is NMEA.
    pub fn nmea_dropped(&self) -> Option<[usize; 10]> {
        self.nmea.as_ref().map(|n| n.dropped)
    }

    /// Read the file as `format` (default: detected).
    pub fn with_format(mut self, format: GnssFormat) -> Self {
        self.format = format;
        self
    }

    /// σ factors and dropped qualities for RTKLIB solutions.
    pub fn with_quality(mut self, quality: super::rtklib::QualityFactors) -> Self {
        self.quality = quality;
        self
    }

    /// The RTKLIB header, when the file is an RTKLIB solution (once the first epoch is
    /// read).
    pub fn rtklib_header(&self) -> Option<&super::rtklib::PosHeader> {
        self.rtklib.as_ref()
    }

    /// Read a log with a header through `map`: the 7 fields `t, lat, lon, h, σN, σE, σD`
    /// (s, degrees, m) or the 13 with `vN, vE, vD, σvN, σvE, σvD` (m/s) (see
    /// [`crate::io::columns`]).
    pub fn with_columns(mut self, map: ColumnMap) -> Self {
        self.mapping = Mapping::Pending(map);
        self
    }

    /// Line number of the last epoch.
    pub fn line(&self) -> usize {
        self.lines.line()
    }

    /// 7 (position) or 13 (position + velocity), once the first line is read.
    pub fn columns(&self) -> Option<usize> {
        self.columns
    }

    /// The next epoch, `Ok(None)` at the end.
    pub fn next_epoch(&mut self) -> Result<Option<GnssEpoch>, LineError> {
        if !self.started {
            self.started = true;
            if matches!(self.mapping, Mapping::None) && self.format != GnssFormat::Columns {
                let comments = self.lines.leading_comments()?;
                self.rtklib =
                    comments.iter().rev().find_map(|l| super::rtklib::PosHeader::parse(l));
                let first = self.lines.peek_byte()?;
                if self.format == GnssFormat::Nmea
                    || (self.format == GnssFormat::Auto && first == Some(b'$'))
                {
                    self.nmea = Some(Default::default());
                }
                if self.rtklib.is_none() && self.format == GnssFormat::Rtklib {
                    return Err(self.lines.error(LineErrorKind::WrongUnits(
                        "no RTKLIB solution header (a `%` line naming the time system and \
                         `latitude(deg)` or `x-ecef(m)` before the first epoch)"
                            .into(),
                    )));
                }
            }
        }
        if self.rtklib.is_some() {
            return self.next_rtklib();
        }
        if self.nmea.is_some() {
            return self.next_nmea();
        }
        self.mapping.start(&mut self.lines)?;
        loop {
            if !next_record(&mut self.lines, self.policy, &mut self.skipped, self.records)? {
                return Ok(None);
            }
            let rec = self.mapping.record(self.lines.values());
            let n = rec.len();
            let expected: Vec<usize> = match self.columns {
                Some(c) => vec![c],
                None => vec![7, 13],
            };
            let result = if !expected.contains(&n) {
                Err(LineErrorKind::ColumnCount { expected, found: n })
            } else if rec[1].abs() > 90.0 || rec[2].abs() > 360.0 {
                let hint = if rec[1].abs() > 90.0 && rec[2].abs() <= 90.0 {
                    ": latitude and longitude swapped? (the latitude field holds the value of a \
                     longitude; check which column is `latitude` and which `longitude`)"
                } else {
                    " (degrees expected; `angle_unit` in the column map)"
                };
                Err(LineErrorKind::WrongUnits(format!(
                    "latitude {} / longitude {} out of range{hint}",
                    rec[1], rec[2]
                )))
            } else if rec[4..7].iter().any(|s| *s <= 0.0)
                || (n == 13 && rec[10..13].iter().any(|s| *s <= 0.0))
            {
                Err(LineErrorKind::WrongUnits("standard deviations must be positive".into()))
            } else if rec[4..7].iter().any(|s| *s > 1e5)
                || (n == 13 && rec[10..13].iter().any(|s| *s > 1e3))
            {
                Err(LineErrorKind::WrongUnits(
                    "a standard deviation beyond 100 km (position) or 1 km/s (velocity)".into(),
                ))
            } else if !(-1_000.0..=100_000.0).contains(&rec[3]) {
                Err(LineErrorKind::WrongUnits(format!("height {} m outside −1 km…+100 km", rec[3])))
            } else {
                check_time(self.prev_t, rec[0]).map(|_| {
                    GnssEpoch::new(
                        rec[0],
                        GeoPos::from_degrees(rec[1], rec[2], rec[3]),
                        Vector3::new(rec[4], rec[5], rec[6]),
                        (n == 13).then(|| {
                            (
                                Vector3::new(rec[7], rec[8], rec[9]),
                                Vector3::new(rec[10], rec[11], rec[12]),
                            )
                        }),
                    )
                })
            };
            match result {
                Ok(e) => {
                    self.columns.get_or_insert(n);
                    self.prev_t = Some(e.t);
                    self.records += 1;
                    return Ok(Some(e));
                }
                Err(kind) => {
                    let fatal = matches!(kind, LineErrorKind::WrongUnits(_)) && self.records == 0;
                    self.skip_or_fail(kind, fatal)?;
                }
            }
        }
    }
}

impl<R: BufRead> GnssReader<R> {
    /// A malformed line: counted and skipped under [`BadLinePolicy::Skip`] unless
    /// `fatal`, else the error at the current line.
    fn skip_or_fail(&mut self, kind: LineErrorKind, fatal: bool) -> Result<(), LineError> {
        if self.policy == BadLinePolicy::Skip && !fatal {
            count(&mut self.skipped, &kind);
            return Ok(());
        }
        Err(self.lines.error(kind))
    }

    fn next_nmea(&mut self) -> Result<Option<GnssEpoch>, LineError> {
        loop {
            let (quality, sigma) = (self.quality, self.default_sigma);
            let Some(state) = self.nmea.as_mut() else { return Ok(None) };
            let step = match self.lines.next_text()? {
                Some(text) => state.push(text, &quality, sigma),
                None => match state.finish(&quality, sigma) {
                    Ok(None) if self.records == 0 => {
                        return Err(LineError {
                            path: self.lines.path().to_path_buf(),
                            line: 0,
                            kind: LineErrorKind::Empty,
                        })
                    }
                    other => {
                        let e = other.map_err(|k| self.lines.error(k))?;
                        if let Some(e) = &e {
                            self.prev_t = Some(e.t);
                            self.records += 1;
                        }
                        return Ok(e);
                    }
                },
            };
            let result = step.and_then(|e| match e {
                Some(e) => check_time(self.prev_t, e.t).map(|_| Some(e)),
                None => Ok(None),
            });
            match result {
                Ok(Some(e)) => {
                    self.columns.get_or_insert(7);
                    self.prev_t = Some(e.t);
                    self.records += 1;
                    return Ok(Some(e));
                }
                Ok(None) => {}
                Err(kind) => {
                    let fatal = matches!(kind, LineErrorKind::WrongUnits(ref m)
                        if m.contains("before any date") || m.contains("without its σ"));
                    self.skip_or_fail(kind, fatal)?;
                }
            }
        }
    }

    fn next_rtklib(&mut self) -> Result<Option<GnssEpoch>, LineError> {
        // (a few indices, copied so that the reader can count and fail below)
        let Some(header) = self.rtklib.clone() else { return Ok(None) };
        loop {
            let Some(text) = self.lines.next_text()? else {
                if self.records == 0 {
                    return Err(LineError {
                        path: self.lines.path().to_path_buf(),
                        line: 0,
                        kind: LineErrorKind::Empty,
                    });
                }
                return Ok(None);
            };
            let result =
                super::rtklib::parse_line(&header, text, &self.quality).and_then(|e| match e {
                    Some(e) => check_time(self.prev_t, e.t).map(|_| Some(e)),
                    None => Ok(None),
                });
            match result {
                Ok(Some(e)) => {
                    self.columns.get_or_insert(if e.vel.is_some() { 13 } else { 7 });
                    self.prev_t = Some(e.t);
                    self.records += 1;
                    return Ok(Some(e));
                }
                Ok(None) => {
                    // the quality of a dropped epoch: the field after the position
                    let q = header
                        .quality_field()
                        .and_then(|i| text.split_whitespace().nth(2 + i))
                        .and_then(|q| q.parse::<usize>().ok())
                        .unwrap_or(0)
                        .min(6);
                    self.dropped[q] += 1;
                }
                Err(kind) => {
                    let fatal = matches!(kind, LineErrorKind::WrongUnits(_)) && self.records == 0;
                    self.skip_or_fail(kind, fatal)?;
                }
            }
        }
    }
}

/// One navigation record (result or truth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavRecord {
    /// GPS week (0 when unknown).
    pub week: f64,
    /// Time, s.
    pub t: f64,
    /// Position.
    pub pos: GeoPos,
    /// NED velocity, m/s.
    pub vel: Vector3<f64>,
    /// Roll, pitch, yaw, rad.
    pub att: Vector3<f64>,
}

impl NavRecord {
    /// The 11 numbers of the navigation format: week, `t`, latitude and longitude (deg),
    /// height (m), velocity N E D (m/s), roll, pitch, yaw (deg).
    pub fn values(&self) -> [f64; 11] {
        let d = 180.0 / core::f64::consts::PI;
        let (p, v, a) = (&self.pos, &self.vel, &self.att);
        [self.week, self.t, p.lat * d, p.lon * d, p.h, v.x, v.y, v.z, a.x * d, a.y * d, a.z * d]
    }

    /// The attitude as a rotation.
    pub fn rotation(&self) -> So3 {
        So3::from_euler(self.att.x, self.att.y, self.att.z)
    }
}

/// Streaming reader of 11-column navigation files.
pub struct NavReader<R: BufRead> {
    lines: NumericLines<R>,
    prev_t: Option<f64>,
}

impl NavReader<Input> {
    /// Open a navigation or truth file.
    pub fn open(path: &Path) -> Result<Self, LineError> {
        Ok(Self { lines: NumericLines::new(open(path)?, path), prev_t: None })
    }
}

impl<R: BufRead> NavReader<R> {
    /// Read from any `BufRead`.
    pub fn new(inner: R, path: &Path) -> Self {
        Self { lines: NumericLines::new(inner, path), prev_t: None }
    }

    /// The next record, `Ok(None)` at the end.
    pub fn next_record(&mut self) -> Result<Option<NavRecord>, LineError> {
        let Some(r) = self.lines.next_record()? else { return Ok(None) };
        if r.len() != 11 {
            let found = r.len();
            return Err(self.lines.error(LineErrorKind::ColumnCount { expected: vec![11], found }));
        }
        let d = core::f64::consts::PI / 180.0;
        let rec = NavRecord {
            week: r[0],
            t: r[1],
            pos: GeoPos::from_degrees(r[2], r[3], r[4]),
            vel: Vector3::new(r[5], r[6], r[7]),
            att: Vector3::new(r[8] * d, r[9] * d, r[10] * d),
        };
        if let Err(kind) = check_time(self.prev_t, rec.t) {
            return Err(self.lines.error(kind));
        }
        self.prev_t = Some(rec.t);
        Ok(Some(rec))
    }
}

/// Writes the 11-column navigation format (lat/lon to 1e-10°, h to 0.1 mm, velocity to
/// 0.01 mm/s, attitude to 1e-8°).
pub fn write_nav<W: Write>(w: &mut W, r: &NavRecord) -> std::io::Result<()> {
    let mut line = Vec::with_capacity(160);
    push_nav(&mut line, r);
    w.write_all(&line)
}

/// [`write_nav`] appended to `out` (no allocation when `out` has room: the writers of a
/// run keep one buffer).
pub fn push_nav(out: &mut Vec<u8>, r: &NavRecord) {
    const DECIMALS: [usize; 11] = [0, 6, 10, 10, 4, 5, 5, 5, 8, 8, 8];
    let v = r.values();
    super::fixed::push_row(out, &core::array::from_fn::<_, 11, _>(|i| (v[i], DECIMALS[i])));
}

/// Writes one GNSS epoch in the 7- or 13-column format.
pub fn write_gnss<W: Write>(w: &mut W, e: &GnssEpoch) -> std::io::Result<()> {
    let d = 180.0 / core::f64::consts::PI;
    write!(
        w,
        "{:.3} {:.10} {:.10} {:.4} {:.4} {:.4} {:.4}",
        e.t,
        e.pos.lat * d,
        e.pos.lon * d,
        e.pos.h,
        e.pos_std.x,
        e.pos_std.y,
        e.pos_std.z
    )?;
    if let Some((v, s)) = e.vel {
        write!(w, " {:.5} {:.5} {:.5} {:.5} {:.5} {:.5}", v.x, v.y, v.z, s.x, s.y, s.z)?;
    }
    writeln!(w)
}

/// Writes one IMU sample in the 7-column increment format.
pub fn write_imu<W: Write>(w: &mut W, s: &ImuSample) -> std::io::Result<()> {
    write!(
        w,
        "{:.6} {:.12e} {:.12e} {:.12e} {:.12e} {:.12e} {:.12e}",
        s.t, s.dtheta.x, s.dtheta.y, s.dtheta.z, s.dvel.x, s.dvel.y, s.dvel.z
    )?;
    match s.odometer {
        Some(v) => writeln!(w, " {v:.6}"),
        None => writeln!(w),
    }
}

/// `path` with `.partial` appended: where an output is written until it is complete and
/// renamed into place ([`create_partial`], [`publish`]).
pub fn partial_path(path: &Path) -> std::path::PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".partial");
    std::path::PathBuf::from(s)
}

/// Create `path.partial` for writing: the output `path` itself is untouched until
/// [`publish`] renames the finished file over it, so a failed or interrupted run never
/// destroys an earlier result.
pub fn create_partial(path: &Path) -> std::io::Result<BufWriter<File>> {
    create(&partial_path(path))
}

/// Rename the finished `path.partial` over `path` (atomic on one file system).
pub fn publish(path: &Path) -> std::io::Result<()> {
    std::fs::rename(partial_path(path), path)
}

/// Create a file for buffered writing (truncating it).
pub fn create(path: &Path) -> std::io::Result<BufWriter<File>> {
    Ok(BufWriter::with_capacity(1 << 16, File::create(path)?))
}
