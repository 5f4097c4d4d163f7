//! The IMU reader (increments, rates, column maps) and writer.

use super::*;

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
    /// increments), FRD axes (see [`crate::columns`]).
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
            self.read_rates_header()?;
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
            // (seven columns, or eight with the odometer speed, in either format)
            let allowed: &[usize] = &[7, 8];
            let checked = if !allowed.contains(&rec.len()) {
                Err(LineErrorKind::ColumnCount { expected: allowed.to_vec(), found: rec.len() })
            } else {
                check_time(self.prev_t, rec[0]).map(|_| {
                    let (a, b) = (
                        Vector3::new(rec[1], rec[2], rec[3]),
                        Vector3::new(rec[4], rec[5], rec[6]),
                    );
                    match &self.mounting {
                        Some(c) => (rec[0], c * a, c * b),
                        None => (rec[0], a, b),
                    }
                })
            };
            // (the eighth column, the odometer's speed, when there is one)
            let odometer = (rec.len() == 8).then(|| rec[7]);
            let (t, a, b) = match checked {
                Ok(tab) => tab,
                Err(kind) => {
                    if self.policy == BadLinePolicy::Skip {
                        count(&mut self.skipped, &kind);
                        continue;
                    }
                    return Err(self.lines.error(kind));
                }
            };
            let dt = self.prev_t.map_or(self.nominal_dt, |p| t - p);
            self.check_interval(dt)?;
            let sample = match self.format {
                ImuFormat::Increments => self.increments_sample(t, dt, a, b, odometer)?,
                ImuFormat::Rates => {
                    if let Err((kind, skip)) = self.rates_units(&a, &b) {
                        if skip {
                            count(&mut self.skipped, &kind);
                            continue;
                        }
                        return Err(self.lines.error(kind));
                    }
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

    /// A rate-type file's first line: a header naming the seven columns (a line of
    /// numbers, `1e-3` included, is data, not a header); read once.
    fn read_rates_header(&mut self) -> Result<(), LineError> {
        match self.lines.next_text()? {
            Some(h)
                if {
                    let fields: Vec<&str> = h
                        .split(|c: char| c == ',' || c.is_whitespace())
                        .filter(|s| !s.is_empty())
                        .collect();
                    fields.len() == 7 && fields.iter().any(|s| s.parse::<f64>().is_err())
                } =>
            {
                self.header_done = true;
                Ok(())
            }
            Some(_) => Err(self.lines.error(LineErrorKind::WrongUnits(
                "a rate-type IMU file needs a header line `t,gx,gy,gz,ax,ay,az` (rad/s, m/s²)"
                    .into(),
            ))),
            None => Err(self.lines.error(LineErrorKind::Empty)),
        }
    }

    /// The interval `dt` (s) up to the record just read: the first intervals 100× off the
    /// rate are a time unit (ms, µs) or a rate that is wrong, not a gap; a later interval
    /// beyond `max_gap` is a gap, bridged (and counted) up to `max_bridge` when bad lines
    /// are skipped.
    fn check_interval(&mut self, dt: f64) -> Result<(), LineError> {
        if self.records < 20 && (dt > 100.0 * self.nominal_dt || dt < 0.01 * self.nominal_dt) {
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
        Ok(())
    }

    /// A rate-type record's units (`w` rad/s, `f` m/s²): the first one's specific force far
    /// below gravity (increments, not rates) or far above it (an accelerometer unit), and
    /// any beyond an IMU's range (a spike: skippable after the first record when bad
    /// lines are skipped, the `bool`).
    fn rates_units(&self, w: &Vector3<f64>, f: &Vector3<f64>) -> Result<(), (LineErrorKind, bool)> {
        if self.records == 0 && f.norm() < 0.5 {
            // Gravity alone is 9.8 m/s²: a first specific force below 1 m/s² is an
            // increment over one interval, not a rate.
            return Err((
                LineErrorKind::WrongUnits(format!(
                    "|f| = {:.4} m/s² is far below gravity: these look like increments, \
                     not rates; set the IMU format to increments",
                    f.norm()
                )),
                false,
            ));
        }
        if self.records == 0 && f.norm() > 5.0 * 9.80665 {
            // the first sample, at rest or nearly: gravity read in a unit 10×, 1000× … too
            // large
            let ratio = f.norm() / 9.80665;
            return Err((
                LineErrorKind::WrongUnits(format!(
                    "|f| = {:.3} m/s² is {ratio:.0}× gravity: `accel_unit` is about \
                     {:.0}× too large for this log (mg read as g: 1000×; m/s² read as g: \
                     9.8×)",
                    f.norm(),
                    if ratio > 300.0 { (ratio / 1000.0).round() * 1000.0 } else { ratio }
                )),
                false,
            ));
        }
        if f.norm() > 1000.0 || w.norm() > 50.0 {
            let kind = LineErrorKind::WrongUnits(format!(
                "|ω| = {:.3} rad/s, |f| = {:.3} m/s²: beyond any IMU (50 rad/s, 100 g); \
                 a spike, or not rad/s and m/s²",
                w.norm(),
                f.norm()
            ));
            return Err((kind, self.policy == BadLinePolicy::Skip && self.records > 0));
        }
        Ok(())
    }

    /// An increment-type record as a sample: increments that are really rates refused (a
    /// stationary accelerometer gives |Δv| ≈ 9.8 m/s in one interval, i.e. > 100 g), and
    /// the odometer's speed (`odometer`, an eighth column) when finite and below 1000 m/s.
    fn increments_sample(
        &self,
        t: f64,
        dt: f64,
        dtheta: Vector3<f64>,
        dvel: Vector3<f64>,
        odometer: Option<f64>,
    ) -> Result<ImuSample, LineError> {
        if dvel.norm() / dt > 1000.0 || dtheta.norm() / dt > 50.0 {
            return Err(self.lines.error(LineErrorKind::WrongUnits(format!(
                "|Δθ| = {:.3} rad and |Δv| = {:.3} m/s in {dt:.4} s look like rates, not increments; \
                 set the IMU format to rates",
                dtheta.norm(),
                dvel.norm()
            ))));
        }
        if let Some(v) = odometer.filter(|v| !(v.is_finite() && v.abs() < 1000.0)) {
            return Err(self.lines.error(LineErrorKind::WrongUnits(format!(
                "odometer speed {v} m/s (8th column): not finite or beyond 1000 m/s"
            ))));
        }
        Ok(ImuSample { t, dt, dtheta, dvel, odometer })
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
