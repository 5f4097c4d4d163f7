//! The GNSS reader (7/13 columns, RTKLIB, NMEA, column maps) and writer.

use super::*;

/// The layout of a GNSS file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GnssFormat {
    /// An RTKLIB solution when the header says so, else the 7/13-column format (default).
    #[default]
    Auto,
    /// The 7- or 13-column KF-GINS format (or a column-mapped log).
    Columns,
    /// An RTKLIB solution file (`.pos`); see [`crate::rtklib`].
    Rtklib,
    /// NMEA 0183 sentences (GGA, GST, RMC/ZDA); see [`crate::nmea`].
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
    rtklib: Option<crate::rtklib::PosHeader>,
    quality: crate::rtklib::QualityFactors,
    /// RTKLIB epochs dropped, by solution quality `Q` (0: no solution).
    pub dropped: [usize; 7],
    nmea: Option<crate::nmea::NmeaState>,
    /// σ (N, E, D) for NMEA fixes without a GST sentence.
    default_sigma: Option<Vector3<f64>>,
    /// A heading file's headings ([`with_headings`](Self::with_headings)).
    headings: ins_gnss_core::heading::HeadingQueue,
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
            headings: Default::default(),
        }
    }

    /// σ (N, E, D, m) for NMEA fixes that have no GST sentence.
    pub fn with_default_sigma(mut self, sigma: Option<Vector3<f64>>) -> Self {
        self.default_sigma = sigma;
        self
    }

    /// NMEA fixes whose σ came from their HDOP (no GST sentence, no default σ).
    pub fn nmea_sigma_from_hdop(&self) -> usize {
        self.nmea.as_ref().map_or(0, |n| n.sigma_from_hdop)
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
    pub fn with_quality(mut self, quality: crate::rtklib::QualityFactors) -> Self {
        self.quality = quality;
        self
    }

    /// The RTKLIB header, when the file is an RTKLIB solution (once the first epoch is
    /// read).
    pub fn rtklib_header(&self) -> Option<&crate::rtklib::PosHeader> {
        self.rtklib.as_ref()
    }

    /// Read a log with a header through `map`: the 7 fields `t, lat, lon, h, σN, σE, σD`
    /// (s, degrees, m) or the 13 with `vN, vE, vD, σvN, σvE, σvD` (m/s) (see
    /// [`crate::columns`]).
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
        let mut e = self.next_fix()?;
        if let Some(f) = e.as_mut()
            && let Some(m) = self.headings.take(f.t)
        {
            f.heading = Some(m);
        }
        Ok(e)
    }

    /// Attach `headings` (time order; a heading file's, [`read_headings`](super::read_headings))
    /// to the fixes at their time (within 1 ms), replacing headings the GNSS file carries
    /// at those epochs.
    pub fn with_headings(mut self, headings: Vec<ins_gnss_core::heading::AntennaHeading>) -> Self {
        self.headings = ins_gnss_core::heading::HeadingQueue::new(headings);
        self
    }

    /// Headings of [`with_headings`](Self::with_headings) that found no fix at their
    /// time, or were not reached.
    pub fn headings_unmatched(&self) -> usize {
        self.headings.unmatched()
    }

    fn next_fix(&mut self) -> Result<Option<GnssEpoch>, LineError> {
        if !self.started {
            self.started = true;
            if matches!(self.mapping, Mapping::None) && self.format != GnssFormat::Columns {
                let comments = self.lines.leading_comments()?;
                self.rtklib =
                    comments.iter().rev().find_map(|l| crate::rtklib::PosHeader::parse(l));
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
            let result = fix_of(rec, self.columns, self.prev_t);
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

/// A text record's fix (time, latitude, longitude and height in degrees and metres, their
/// σ, with 13 columns the velocity and its σ), checked: the column count (`columns` once
/// known, else 7 or 13), the angles' range, the σ, the height, the time after `prev_t`.
fn fix_of(
    rec: &[f64],
    columns: Option<usize>,
    prev_t: Option<f64>,
) -> Result<GnssEpoch, LineErrorKind> {
    let n = rec.len();
    let expected: Vec<usize> = match columns {
        Some(c) => vec![c],
        None => vec![7, 13],
    };
    if !expected.contains(&n) {
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
        check_time(prev_t, rec[0]).map(|_| {
            GnssEpoch::new(
                rec[0],
                GeoPos::from_degrees(rec[1], rec[2], rec[3]),
                Vector3::new(rec[4], rec[5], rec[6]),
                (n == 13).then(|| {
                    (Vector3::new(rec[7], rec[8], rec[9]), Vector3::new(rec[10], rec[11], rec[12]))
                }),
            )
        })
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
                        });
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
                crate::rtklib::parse_line(&header, text, &self.quality).and_then(|e| match e {
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
