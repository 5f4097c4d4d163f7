//! Observation files: the header, the epochs, the signals' columns.

use super::*;

/// What an observation file's header says.
#[derive(Clone, Debug, PartialEq)]
pub struct ObsHeader {
    /// RINEX version (2.10, 3.04, …).
    pub version: f64,
    /// `MARKER NAME`.
    pub marker: String,
    /// `APPROX POSITION XYZ` (ECEF, m), if given and not zero.
    pub approx_position: Option<Vector3<f64>>,
    /// `INTERVAL`, s.
    pub interval: Option<f64>,
    /// Observation types per system (RINEX 2's one list is given to every system).
    types: Vec<(System, Vec<String>)>,
    /// The time system of the epochs.
    time_system: System,
}

/// A streaming reader of a RINEX observation file: the header at open, then epochs.
pub struct ObsReader {
    input: Input,
    path: PathBuf,
    line_no: usize,
    line: String,
    /// The header.
    pub header: ObsHeader,
    /// Epochs with an event flag > 1 (header records, external events) that were read past.
    pub events: usize,
    /// Observations of a system this crate does not use (GLONASS, SBAS, NavIC), read past.
    pub unused: usize,
    /// For each system's type list: `(slot, rank, kind)` per column.
    columns: Vec<(System, Vec<Column>)>,
}

/// Where an observation type goes: `(slot, rank, kind)` (kind `C`, `L`, `D` or `S`), or
/// nowhere.
type Column = Option<(usize, u8, u8)>;

impl ObsReader {
    /// Opens a RINEX observation file (plain or `.gz`/`.zst`/`.xz`) and reads its header.
    pub fn open(path: &Path) -> Result<Self, RawError> {
        let mut input = open_input(path)?;
        let mut line_no = 0;
        let mut lines = HeaderLines::default();
        read_header(&mut input, path, &mut line_no, |l| lines.take(l))?;
        let h = lines.header(path, line_no)?;
        let columns = h
            .types
            .iter()
            .map(|(sys, list)| (*sys, list.iter().map(|t| column_of(*sys, t, h.version)).collect()))
            .collect();
        Ok(Self {
            input,
            path: path.to_path_buf(),
            line_no,
            line: String::new(),
            header: h,
            events: 0,
            unused: 0,
            columns,
        })
    }

    fn next_line(&mut self) -> Result<bool, RawError> {
        self.line.clear();
        let n = self
            .input
            .read_line(&mut self.line)
            .map_err(|e| err(&self.path, self.line_no, e.to_string()))?;
        if n == 0 {
            return Ok(false);
        }
        self.line_no += 1;
        let t = self.line.trim_end_matches(['\n', '\r']).len();
        self.line.truncate(t);
        Ok(true)
    }

    fn bad(&self, m: impl Into<String>) -> RawError {
        err(&self.path, self.line_no, m)
    }

    /// The 1-based line the last epoch read ended on (0 before any).
    pub fn line(&self) -> usize {
        self.line_no
    }

    /// A satellite's values of system `cols`'s types, from its line `body` (from column
    /// `first_col`) and, in RINEX 2, the lines that continue it (five values a line):
    /// (value, loss-of-lock indicator, signal strength) per type.
    #[allow(clippy::type_complexity)]
    fn values(
        &mut self,
        cols: usize,
        body: String,
        first_col: usize,
        v3: bool,
    ) -> Result<Vec<(Option<f64>, u8, Option<u32>)>, RawError> {
        let ntypes = self.columns[cols].1.len();
        let mut values = Vec::with_capacity(ntypes);
        let mut text = body;
        let mut col = first_col;
        for j in 0..ntypes {
            if !v3 && j > 0 && j % 5 == 0 {
                if !self.next_line()? {
                    return Err(self.bad("the file ends inside an observation record"));
                }
                text = self.line.clone();
                col = 0;
            }
            let v = field(&text, col, col + 14).map_err(|m| self.bad(m))?;
            let lli =
                text.as_bytes().get(col + 14).and_then(|c| (*c as char).to_digit(10)).unwrap_or(0)
                    as u8;
            let ssi = text.as_bytes().get(col + 15).and_then(|c| (*c as char).to_digit(10));
            values.push((v, lli, ssi));
            col += 16;
        }
        Ok(values)
    }

    /// The next epoch, `None` at the end of the file.
    pub fn next_epoch(&mut self) -> Result<Option<ObsEpoch>, RawError> {
        loop {
            if !self.next_line()? {
                return Ok(None);
            }
            if self.line.trim().is_empty() {
                continue;
            }
            let start = self.line_no;
            let v3 = self.header.version >= 3.0;
            let l = self.line.clone();
            let (time, flag, count, mut ids) = if v3 {
                if !l.starts_with('>') {
                    return Err(self.bad("expected an epoch line starting with `>`"));
                }
                self.epoch_line(&l, 2, 4, true)?
            } else {
                self.epoch_line(&l, 1, 3, false)?
            };
            if flag > 1 {
                // header records or events follow: `count` lines
                for _ in 0..count {
                    if !self.next_line()? {
                        return Err(self.bad("the file ends inside an event record"));
                    }
                }
                self.events += 1;
                continue;
            }
            let time = if self.header.time_system == System::BeiDou {
                time.add(-BDT_MINUS_GPST)
            } else {
                time
            };
            let mut sats = Vec::with_capacity(count);
            if !v3 {
                // the satellite list continues on lines of 12
                while ids.len() < count {
                    if !self.next_line()? {
                        return Err(self.bad("the file ends inside the satellite list"));
                    }
                    let more = self.line.clone();
                    ids.extend(sat_list(&more, count - ids.len()).map_err(|m| self.bad(m))?);
                }
            }
            #[allow(clippy::needless_range_loop)] // `k` also counts RINEX 3's satellites
            for k in 0..count {
                if !self.next_line()? {
                    return Err(self.bad(format!("the file ends after {k} of {count} satellites")));
                }
                let (sat, body, first_col) = if v3 {
                    let id = self.line.get(..3).unwrap_or("");
                    let sat = Sat::parse(id)
                        .ok_or_else(|| self.bad(format!("`{id}` is not a satellite")))?;
                    (sat, self.line.clone(), 3)
                } else {
                    (ids[k], self.line.clone(), 0)
                };
                let Some(cols) = self.columns.iter().position(|(s, _)| *s == sat.sys) else {
                    self.unused += 1;
                    if !v3 {
                        self.skip_continuations(sat.sys)?;
                    }
                    continue;
                };
                let values = self.values(cols, body, first_col, v3)?;
                if !sat.sys.keplerian() {
                    self.unused += 1;
                    continue;
                }
                sats.push(assemble(sat, &self.columns[cols].1, &values));
            }
            return Ok(Some(ObsEpoch { time, flag, sats, line: start }));
        }
    }

    fn skip_continuations(&mut self, sys: System) -> Result<(), RawError> {
        let n = self.columns.iter().find(|(s, _)| *s == sys).map_or(0, |c| c.1.len());
        for _ in 1..n.div_ceil(5).max(1) {
            if !self.next_line()? {
                return Err(self.bad("the file ends inside an observation record"));
            }
        }
        Ok(())
    }

    /// Parses an epoch line: time, flag, satellite count, and (RINEX 2) the satellites on it.
    fn epoch_line(
        &self,
        l: &str,
        y0: usize,
        ylen: usize,
        v3: bool,
    ) -> Result<(GpsTime, u8, usize, Vec<Sat>), RawError> {
        let b = |m: String| self.bad(m);
        let f = |a, z| int_field(l, a, z).map_err(b);
        let (yo, mo, d, h, mi, s_from, s_to, flag_at, n_from, n_to) = if v3 {
            (y0, 7, 10, 13, 16, 18, 29, 31, 32, 35)
        } else {
            (y0, 3, 6, 9, 12, 15, 26, 28, 29, 32)
        };
        let y = f(yo, yo + ylen)?;
        let flag = f(flag_at, flag_at + 1)?.unwrap_or(0) as u8;
        let count = f(n_from, n_to)?
            .ok_or_else(|| self.bad("no satellite count on the epoch line"))?
            as usize;
        if flag > 1 {
            return Ok((GpsTime::new(0, 0.0), flag, count, Vec::new()));
        }
        let parts = (y, f(mo, mo + 3)?, f(d, d + 3)?, f(h, h + 3)?, f(mi, mi + 3)?);
        let sec = field(l, s_from, s_to).map_err(b)?;
        let (Some(y), Some(mo), Some(d), Some(h), Some(mi), Some(sec)) =
            (parts.0, parts.1, parts.2, parts.3, parts.4, sec)
        else {
            return Err(self.bad("the epoch line has no complete date and time"));
        };
        if !(1..=12).contains(&mo)
            || !(1..=31).contains(&d)
            || !(0..24).contains(&h)
            || !(0..60).contains(&mi)
            || !(0.0..61.0).contains(&sec)
        {
            return Err(self.bad("the epoch's date or time is out of range"));
        }
        let t = GpsTime::from_calendar(year4(y), mo, d, h, mi, sec);
        let ids = if v3 { Vec::new() } else { sat_list(l, count).map_err(b)? };
        Ok((t, flag, count, ids))
    }
}

impl Iterator for ObsReader {
    type Item = Result<ObsEpoch, RawError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.next_epoch().transpose()
    }
}

/// RINEX 2 satellite list from column 33, up to 12 a line.
fn sat_list(l: &str, left: usize) -> Result<Vec<Sat>, String> {
    (0..left.min(12))
        .map(|k| {
            let id = l.get(32 + 3 * k..35 + 3 * k).unwrap_or("");
            Sat::parse(id).ok_or_else(|| {
                format!("`{id}` is not a satellite (columns {}–{})", 33 + 3 * k, 35 + 3 * k)
            })
        })
        .collect()
}

/// A type's column: `(slot, rank, kind)` where kind is `C`, `L`, `D` or `S`.
fn column_of(sys: System, t: &str, version: f64) -> Column {
    let b = t.as_bytes();
    if b.len() < 2 {
        return None;
    }
    let kind = match b[0] {
        b'P' => b'C',
        k @ (b'C' | b'L' | b'D' | b'S') => k,
        _ => return None,
    };
    let band = b[1];
    let attr = if version >= 3.0 && b.len() >= 3 {
        b[2]
    } else {
        // RINEX 2: C1 is C/A, P1/P2 are P(Y), C2 is L2C; L, D, S follow their band's code
        match (b[0], band) {
            (b'P', _) => b'W',
            (b'C', _) => b'C',
            _ => b'*',
        }
    };
    let (slot, rank) = if attr == b'*' {
        let (slot, _) =
            slot_of(sys, band, if band == b'2' && sys == System::Gps { b'W' } else { b'C' })
                .or_else(|| slot_of(sys, band, b'I'))
                .or_else(|| slot_of(sys, band, b'Q'))?;
        (slot, 0)
    } else {
        slot_of(sys, band, attr)?
    };
    Some((slot, rank, kind))
}

/// Puts a satellite's values into its two slots, each kind from the best-ranked code present.
fn assemble(
    sat: Sat,
    cols: &[Option<(usize, u8, u8)>],
    values: &[(Option<f64>, u8, Option<u32>)],
) -> SatObs {
    let mut signals = [Signal::default(); 2];
    let mut best = [[u8::MAX; 4]; 2];
    for (c, (v, lli, ssi)) in cols.iter().zip(values) {
        let Some((slot, rank, kind)) = *c else { continue };
        let Some(v) = *v else { continue };
        let k = match kind {
            b'C' => 0,
            b'L' => 1,
            b'D' => 2,
            _ => 3,
        };
        if rank >= best[slot][k] {
            continue;
        }
        best[slot][k] = rank;
        let s = &mut signals[slot];
        match k {
            0 => s.code = Some(v),
            1 => {
                s.phase = Some(v);
                s.lli = *lli;
                if s.cn0.is_none() {
                    // RINEX 2's signal strength digit 1–9 ≈ C/N0 of 6·digit dB-Hz (RTKLIB's reading)
                    s.cn0 = ssi.filter(|d| *d > 0).map(|d| 6.0 * d as f64);
                }
            }
            2 => s.doppler = Some(v),
            _ => s.cn0 = Some(v),
        }
    }
    SatObs { sat, signals }
}

/// An observation file's header as its lines are read: the header, and RINEX 2's type
/// list (one for every system) or the RINEX 3 system whose list continues.
struct HeaderLines {
    h: ObsHeader,
    v2_types: Vec<String>,
    v2_count: usize,
    v3_pending: Option<(System, usize)>,
    file_sys: char,
}

impl Default for HeaderLines {
    fn default() -> Self {
        Self {
            h: ObsHeader {
                version: 0.0,
                marker: String::new(),
                approx_position: None,
                interval: None,
                types: Vec::new(),
                time_system: System::Gps,
            },
            v2_types: Vec::new(),
            v2_count: 0,
            v3_pending: None,
            file_sys: ' ',
        }
    }
}

impl HeaderLines {
    /// One header line.
    fn take(&mut self, l: &str) -> Result<(), String> {
        let h = &mut self.h;
        match label(l) {
            "RINEX VERSION / TYPE" => {
                let (v, kind, sys) = version_and_type(l)?;
                if kind != 'O' {
                    return Err(format!("file type `{kind}`, not an observation file (`O`)"));
                }
                if !(2.0..4.0).contains(&v) {
                    return Err(format!("RINEX version {v}: 2.xx and 3.xx are read"));
                }
                h.version = v;
                self.file_sys = sys;
            }
            "CRINEX VERS   / TYPE" => {
                return Err("Hatanaka-compressed (CRINEX): decompress with `crx2rnx` first".into());
            }
            "MARKER NAME" => h.marker = l.get(..60).unwrap_or(l).trim().to_string(),
            "APPROX POSITION XYZ" => {
                let p = [field(l, 0, 14)?, field(l, 14, 28)?, field(l, 28, 42)?];
                if let [Some(x), Some(y), Some(z)] = p {
                    let r = Vector3::new(x, y, z);
                    h.approx_position = (r.norm() > 1e6).then_some(r);
                }
            }
            "INTERVAL" => h.interval = field(l, 0, 10)?,
            "# / TYPES OF OBSERV" => {
                if let Some(c) = int_field(l, 0, 6)? {
                    self.v2_count = c as usize;
                }
                let listed = l.get(6..60).unwrap_or("").split_whitespace().map(String::from);
                self.v2_types.extend(listed);
                if self.v2_types.len() > self.v2_count {
                    return Err(format!(
                        "{} types listed, {} announced",
                        self.v2_types.len(),
                        self.v2_count
                    ));
                }
            }
            "SYS / # / OBS TYPES" => self.v3_types(l)?,
            "TIME OF FIRST OBS" => {
                let ts = l.get(48..51).unwrap_or("").trim();
                h.time_system = match ts {
                    "" | "GPS" | "GAL" | "QZS" => System::Gps,
                    "BDT" => System::BeiDou,
                    other => {
                        return Err(format!(
                            "time system `{other}` is not read (GPS, GAL, QZS, BDT)"
                        ));
                    }
                };
            }
            _ => {}
        }
        Ok(())
    }

    /// A `SYS / # / OBS TYPES` line: a system's list, or its continuation.
    fn v3_types(&mut self, l: &str) -> Result<(), String> {
        let first = l.chars().next().unwrap_or(' ');
        let (sys, count) = if first != ' ' {
            let sys = System::from_letter(first).ok_or(format!("unknown system `{first}`"))?;
            let count = int_field(l, 3, 6)?.ok_or("no count of types")? as usize;
            self.h.types.push((sys, Vec::new()));
            (sys, count)
        } else {
            self.v3_pending.ok_or("a continuation line with no system before it")?
        };
        self.v3_pending = Some((sys, count));
        let list = &mut self.h.types.last_mut().ok_or("no system")?.1;
        list.extend(l.get(7..60).unwrap_or("").split_whitespace().map(String::from));
        if list.len() > count {
            return Err(format!("{} types listed, {count} announced", list.len()));
        }
        Ok(())
    }

    /// The header once its lines are read (`line_no`: the last), each system with its
    /// type list.
    fn header(self, path: &Path, line_no: usize) -> Result<ObsHeader, RawError> {
        let mut h = self.h;
        if h.version == 0.0 {
            return Err(err(path, 1, "no `RINEX VERSION / TYPE` line"));
        }
        if h.version < 3.0 {
            let (types, count) = (self.v2_types, self.v2_count);
            if types.len() != count || count == 0 {
                return Err(err(
                    path,
                    line_no,
                    format!("`# / TYPES OF OBSERV`: {} of {count} types", types.len()),
                ));
            }
            // RINEX 2: one list for every system in the file
            let systems: Vec<System> = match self.file_sys {
                'M' => vec![
                    System::Gps,
                    System::Glonass,
                    System::Galileo,
                    System::Sbas,
                    System::BeiDou,
                    System::Qzss,
                ],
                c => vec![System::from_letter(c).unwrap_or(System::Gps)],
            };
            h.types = systems.into_iter().map(|s| (s, types.clone())).collect();
        } else if h.types.is_empty() {
            return Err(err(path, line_no, "no `SYS / # / OBS TYPES` lines"));
        }
        Ok(h)
    }
}
