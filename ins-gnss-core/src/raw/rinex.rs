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
use crate::io::formats::Input;
use nalgebra::Vector3;
use std::io::BufRead;
use std::path::{Path, PathBuf};

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

impl ObsReader {
    /// Opens a RINEX observation file (plain or `.gz`/`.zst`/`.xz`) and reads its header.
    pub fn open(path: &Path) -> Result<Self, RawError> {
        let mut input = open_input(path)?;
        let mut line_no = 0;
        let mut h = ObsHeader {
            version: 0.0,
            marker: String::new(),
            approx_position: None,
            interval: None,
            types: Vec::new(),
            time_system: System::Gps,
        };
        let mut v2_types: Vec<String> = Vec::new();
        let mut v2_count = 0usize;
        let mut v3_pending: Option<(System, usize)> = None;
        let mut file_sys = ' ';
        read_header(&mut input, path, &mut line_no, |l| {
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
                    file_sys = sys;
                }
                "CRINEX VERS   / TYPE" => {
                    return Err(
                        "Hatanaka-compressed (CRINEX): decompress with `crx2rnx` first".into()
                    )
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
                        v2_count = c as usize;
                    }
                    v2_types
                        .extend(l.get(6..60).unwrap_or("").split_whitespace().map(String::from));
                    if v2_types.len() > v2_count {
                        return Err(format!(
                            "{} types listed, {v2_count} announced",
                            v2_types.len()
                        ));
                    }
                }
                "SYS / # / OBS TYPES" => {
                    let first = l.chars().next().unwrap_or(' ');
                    let (sys, count) = if first != ' ' {
                        let sys = System::from_letter(first)
                            .ok_or(format!("unknown system `{first}`"))?;
                        let count = int_field(l, 3, 6)?.ok_or("no count of types")? as usize;
                        h.types.push((sys, Vec::new()));
                        (sys, count)
                    } else {
                        v3_pending.ok_or("a continuation line with no system before it")?
                    };
                    v3_pending = Some((sys, count));
                    let list = &mut h.types.last_mut().ok_or("no system")?.1;
                    list.extend(l.get(7..60).unwrap_or("").split_whitespace().map(String::from));
                    if list.len() > count {
                        return Err(format!("{} types listed, {count} announced", list.len()));
                    }
                }
                "TIME OF FIRST OBS" => {
                    let ts = l.get(48..51).unwrap_or("").trim();
                    h.time_system = match ts {
                        "" | "GPS" | "GAL" | "QZS" => System::Gps,
                        "BDT" => System::BeiDou,
                        other => {
                            return Err(format!(
                                "time system `{other}` is not read (GPS, GAL, QZS, BDT)"
                            ))
                        }
                    };
                }
                _ => {}
            }
            Ok(())
        })?;
        if h.version == 0.0 {
            return Err(err(path, 1, "no `RINEX VERSION / TYPE` line"));
        }
        if h.version < 3.0 {
            if v2_types.len() != v2_count || v2_count == 0 {
                return Err(err(
                    path,
                    line_no,
                    format!("`# / TYPES OF OBSERV`: {} of {v2_count} types", v2_types.len()),
                ));
            }
            // RINEX 2: one list for every system in the file
            let systems: Vec<System> = match file_sys {
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
            h.types = systems.into_iter().map(|s| (s, v2_types.clone())).collect();
        } else if h.types.is_empty() {
            return Err(err(path, line_no, "no `SYS / # / OBS TYPES` lines"));
        }
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
                    let lli = text
                        .as_bytes()
                        .get(col + 14)
                        .and_then(|c| (*c as char).to_digit(10))
                        .unwrap_or(0) as u8;
                    let ssi = text.as_bytes().get(col + 15).and_then(|c| (*c as char).to_digit(10));
                    values.push((v, lli, ssi));
                    col += 16;
                }
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

/// A navigation file's contents.
#[derive(Clone, Debug, Default)]
pub struct NavData {
    /// The Keplerian ephemerides.
    pub ephemerides: Ephemerides,
    /// The GPS ionosphere coefficients, when the header has them.
    pub klobuchar: Option<Klobuchar>,
    /// Records of systems not used (GLONASS, SBAS, NavIC), read past.
    pub unused: usize,
}

/// Reads a RINEX 2 (GPS `N`) or 3 (any `N`) navigation file.
pub fn read_nav(path: &Path) -> Result<NavData, RawError> {
    let mut input = open_input(path)?;
    let mut line_no = 0;
    let mut version = 0.0;
    let mut file_sys = 'G';
    let (mut alpha, mut beta) = (None, None);
    read_header(&mut input, path, &mut line_no, |l| {
        let d4 = |from: usize| -> Result<[f64; 4], String> {
            let mut c = [0.0; 4];
            for (k, v) in c.iter_mut().enumerate() {
                *v = field(l, from + 12 * k, from + 12 * (k + 1))?.unwrap_or(0.0);
            }
            Ok(c)
        };
        match label(l) {
            "RINEX VERSION / TYPE" => {
                let (v, kind, sys) = version_and_type(l)?;
                if !(2.0..4.0).contains(&v) {
                    return Err(format!("RINEX version {v}: 2.xx and 3.xx are read"));
                }
                if kind != 'N' {
                    return Err(format!("file type `{kind}`: only GPS (RINEX 2) and mixed/any (RINEX 3) navigation files (`N`) hold Keplerian ephemerides"));
                }
                version = v;
                file_sys = if sys == ' ' { 'G' } else { sys };
            }
            "ION ALPHA" => alpha = Some(d4(2)?),
            "ION BETA" => beta = Some(d4(2)?),
            "IONOSPHERIC CORR" => match l.get(..4) {
                Some("GPSA") => alpha = Some(d4(5)?),
                Some("GPSB") => beta = Some(d4(5)?),
                _ => {}
            },
            _ => {}
        }
        Ok(())
    })?;
    if version == 0.0 {
        return Err(err(path, 1, "no `RINEX VERSION / TYPE` line"));
    }
    let v3 = version >= 3.0;
    let mut records = Vec::new();
    let mut unused = 0;
    let mut line = String::new();
    let mut lines: Vec<String> = Vec::with_capacity(8);
    loop {
        line.clear();
        let n = input.read_line(&mut line).map_err(|e| err(path, line_no, e.to_string()))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let l = line.trim_end_matches(['\n', '\r']).to_string();
        if l.trim().is_empty() {
            continue;
        }
        let start = line_no;
        let sys = if v3 {
            let c = l.chars().next().unwrap_or(' ');
            System::from_letter(c)
                .ok_or_else(|| err(path, start, format!("`{c}` is not a satellite system")))?
        } else {
            System::from_letter(file_sys).unwrap_or(System::Gps)
        };
        // GLONASS and SBAS records have 4 lines, the Keplerian ones 8
        let total = if matches!(sys, System::Glonass | System::Sbas) { 4 } else { 8 };
        lines.clear();
        lines.push(l);
        while lines.len() < total {
            line.clear();
            let n = input.read_line(&mut line).map_err(|e| err(path, line_no, e.to_string()))?;
            if n == 0 {
                // the last record's final line may hold only its first fields; a record cut short is refused
                return Err(err(
                    path,
                    line_no,
                    format!("the file ends inside the record that starts on line {start}"),
                ));
            }
            line_no += 1;
            lines.push(line.trim_end_matches(['\n', '\r']).to_string());
        }
        if !sys.keplerian() {
            unused += 1;
            continue;
        }
        let e = kepler_record(&lines, sys, v3).map_err(|(k, m)| err(path, start + k, m))?;
        records.push(e);
    }
    let klobuchar = match (alpha, beta) {
        (Some(alpha), Some(beta)) => Some(Klobuchar { alpha, beta }).filter(Klobuchar::is_set),
        _ => None,
    };
    Ok(NavData { ephemerides: Ephemerides::new(records), klobuchar, unused })
}

/// One Keplerian record from its 8 lines; an error names the line (0-based in the record).
fn kepler_record(lines: &[String], sys: System, v3: bool) -> Result<Ephemeris, (usize, String)> {
    let first = &lines[0];
    let (sat, t, head) = if v3 {
        let id = first.get(..3).unwrap_or("");
        let sat = Sat::parse(id).ok_or((0, format!("`{id}` is not a satellite")))?;
        let g = |a, z| {
            int_field(first, a, z).map_err(|m| (0, m))?.ok_or((0, "incomplete epoch".to_string()))
        };
        let t = GpsTime::from_calendar(
            g(4, 8)?,
            g(9, 11)?,
            g(12, 14)?,
            g(15, 17)?,
            g(18, 20)?,
            g(21, 23)? as f64,
        );
        (sat, t, 23)
    } else {
        let prn = int_field(first, 0, 2).map_err(|m| (0, m))?.ok_or((0, "no PRN".to_string()))?;
        let sat = Sat { sys, prn: u8::try_from(prn).map_err(|_| (0, format!("PRN {prn}")))? };
        let g = |a, z| {
            int_field(first, a, z).map_err(|m| (0, m))?.ok_or((0, "incomplete epoch".to_string()))
        };
        let sec = field(first, 17, 22).map_err(|m| (0, m))?.ok_or((0, "no seconds".to_string()))?;
        let t = GpsTime::from_calendar(
            year4(g(2, 5)?),
            g(5, 8)?,
            g(8, 11)?,
            g(11, 14)?,
            g(14, 17)?,
            sec,
        );
        (sat, t, 22)
    };
    let mut v = [0.0f64; 31];
    for (k, slot) in v.iter_mut().take(3).enumerate() {
        *slot =
            field(first, head + 19 * k, head + 19 * (k + 1)).map_err(|m| (0, m))?.unwrap_or(0.0);
    }
    let indent = if v3 { 4 } else { 3 };
    for (r, l) in lines.iter().enumerate().skip(1) {
        for k in 0..4 {
            let idx = 3 + 4 * (r - 1) + k;
            if idx < v.len() {
                v[idx] = field(l, indent + 19 * k, indent + 19 * (k + 1))
                    .map_err(|m| (r, m))?
                    .unwrap_or(0.0);
            }
        }
    }
    // v: af0 af1 af2 | IODE Crs Δn M0 | Cuc e Cus √A | toe Cic Ω0 Cis | i0 Crc ω Ω̇ |
    //    IDOT codes week flag | accuracy health TGD IODC(TGD2) | ttm fit
    let week = v[21] as i32;
    let toe_sow = v[11];
    let (toc, toe) = match sys {
        System::BeiDou => {
            (t.add(-BDT_MINUS_GPST), GpsTime::new(week + BDT_WEEK_OFFSET, toe_sow - BDT_MINUS_GPST))
        }
        _ => (t, GpsTime::new(week, toe_sow)),
    };
    if v[10] <= 1000.0 || !(0.0..1.0).contains(&v[8]) {
        return Err((2, format!("{sat}: √A = {} m^½, e = {}: not an orbit", v[10], v[8])));
    }
    let tgd = match sys {
        System::Galileo | System::BeiDou => [v[25], v[26]],
        _ => [v[25], 0.0],
    };
    Ok(Ephemeris {
        sat,
        toc,
        toe,
        toe_sow,
        af: [v[0], v[1], v[2]],
        iode: v[3] as i32,
        iodc: if matches!(sys, System::Gps | System::Qzss) { v[26] as i32 } else { v[3] as i32 },
        sqrt_a: v[10],
        e: v[8],
        i0: v[15],
        omega0: v[13],
        omega: v[17],
        m0: v[6],
        delta_n: v[5],
        omega_dot: v[18],
        idot: v[19],
        harmonics: [v[7], v[9], v[16], v[4], v[12], v[14]],
        tgd,
        // GPS/QZSS health is a bit field; Galileo's and BeiDou's likewise: 0 is healthy
        health: v[24] as u32,
        accuracy: v[23],
    })
}
