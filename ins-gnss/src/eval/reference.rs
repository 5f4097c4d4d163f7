//! The truth or reference file: read, interpolated between its records, and the errors against it.

use super::*;

/// The reference reader of `truth`, through its column map when it has one.
pub(super) fn reference_reader(
    truth: &Path,
    columns: Option<&TruthColumns>,
) -> Result<RefReader, LineError> {
    let map = match columns {
        Some(c) => Some(c.map().map_err(|m| LineError {
            path: truth.to_path_buf(),
            line: 0,
            kind: ins_gnss_io::LineErrorKind::WrongUnits(m),
        })?),
        None => None,
    };
    RefReader::open(truth, map.as_ref())
}

/// Largest gap of the reference that is interpolated across, s.
pub const MAX_REFERENCE_GAP: f64 = 1.0;

/// Reads a reference: the 11-column navigation format, or `t lat lon h` (4 columns, e.g.
/// RTK-fixed positions), whose velocity and attitude are NaN (not evaluated).
pub struct RefReader {
    lines: ins_gnss_io::NumericLines<ins_gnss_io::formats::Input>,
    prev_t: Option<f64>,
    /// A log with a header: its map, resolved, and the mapped record.
    map: Option<(ins_gnss_io::columns::Resolved, Vec<f64>)>,
}

impl RefReader {
    /// Open a reference file; with `columns`, a log with a header read through its map
    /// (11 fields, NaN where the log has no velocity or attitude: see
    /// [`TruthColumns`]).
    pub fn open(path: &Path, columns: Option<&ColumnMap>) -> Result<Self, LineError> {
        let mut lines = ins_gnss_io::NumericLines::new(ins_gnss_io::formats::open(path)?, path);
        let map = match columns {
            Some(c) => {
                let header = lines.next_text()?.map(str::to_string);
                let header =
                    header.ok_or_else(|| lines.error(ins_gnss_io::LineErrorKind::Empty))?;
                let resolved = c
                    .resolve(&header)
                    .map_err(|m| lines.error(ins_gnss_io::LineErrorKind::WrongUnits(m)))?;
                lines.select(&resolved.columns);
                Some((resolved, Vec::with_capacity(11)))
            }
            None => None,
        };
        Ok(Self { lines, prev_t: None, map })
    }

    /// The next record, `Ok(None)` at the end.
    pub fn next_record(&mut self) -> Result<Option<NavRecord>, LineError> {
        let Some(r) = self.lines.next_record()? else { return Ok(None) };
        let r = match &mut self.map {
            Some((resolved, out)) => {
                resolved.apply(r, out);
                &out[..]
            }
            None => r,
        };
        let d = core::f64::consts::PI / 180.0;
        let rec = match r.len() {
            11 => NavRecord {
                week: r[0],
                t: r[1],
                pos: ins_gnss_core::GeoPos::from_degrees(r[2], r[3], r[4]),
                vel: Vector3::new(r[5], r[6], r[7]),
                att: Vector3::new(r[8] * d, r[9] * d, r[10] * d),
            },
            4 => NavRecord {
                week: 0.0,
                t: r[0],
                pos: ins_gnss_core::GeoPos::from_degrees(r[1], r[2], r[3]),
                vel: Vector3::repeat(f64::NAN),
                att: Vector3::repeat(f64::NAN),
            },
            found => {
                return Err(self.lines.error(ins_gnss_io::LineErrorKind::ColumnCount {
                    expected: vec![11, 4],
                    found,
                }));
            }
        };
        if let Some(p) = self.prev_t
            && rec.t <= p
        {
            return Err(self
                .lines
                .error(ins_gnss_io::LineErrorKind::TimeBackwards { t: rec.t, previous: p }));
        }
        self.prev_t = Some(rec.t);
        Ok(Some(rec))
    }
}

/// The record between `a` and `b` at `t` (positions and velocity linear, angles wrapped).
pub fn interpolate(a: &NavRecord, b: &NavRecord, t: f64) -> NavRecord {
    let u = if b.t > a.t { ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0) } else { 0.0 };
    let lerp = |x: f64, y: f64| x + (y - x) * u;
    let att = Vector3::new(
        a.att.x + wrap_angle(b.att.x - a.att.x) * u,
        a.att.y + wrap_angle(b.att.y - a.att.y) * u,
        a.att.z + wrap_angle(b.att.z - a.att.z) * u,
    );
    NavRecord {
        week: a.week,
        t,
        pos: ins_gnss_core::GeoPos {
            lat: lerp(a.pos.lat, b.pos.lat),
            lon: lerp(a.pos.lon, b.pos.lon),
            h: lerp(a.pos.h, b.pos.h),
        },
        vel: a.vel + (b.vel - a.vel) * u,
        att,
    }
}

/// Errors `(NED position m, velocity m/s, attitude deg)` of `r` against truth `t`.
pub fn errors(r: &NavRecord, t: &NavRecord) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let dp = geodetic_to_local_ned(t.pos.tuple(), r.pos.tuple());
    let d = 180.0 / core::f64::consts::PI;
    let da = Vector3::new(
        wrap_angle(r.att.x - t.att.x) * d,
        wrap_angle(r.att.y - t.att.y) * d,
        wrap_angle(r.att.z - t.att.z) * d,
    );
    (dp, r.vel - t.vel, da)
}

pub(super) fn reference_columns(path: &Path) -> Result<usize, LineError> {
    let mut lines = ins_gnss_io::NumericLines::new(ins_gnss_io::formats::open(path)?, path);
    Ok(lines.next_record()?.map(|r| r.len()).unwrap_or(0))
}

/// A pair of consecutive records of one time-ordered stream around a query time.
pub(super) struct Bracket<F> {
    next: F,
    a: Option<NavRecord>,
    b: Option<NavRecord>,
}

impl<F: FnMut() -> Result<Option<NavRecord>, LineError>> Bracket<F> {
    pub(super) fn new(mut next: F) -> Result<Self, LineError> {
        let a = next()?;
        let b = next()?;
        Ok(Self { next, a, b })
    }

    /// Time of the stream's first record.
    pub(super) fn first_t(&self) -> Option<f64> {
        self.a.as_ref().map(|r| r.t)
    }

    /// The stream interpolated at `t` (non-decreasing across calls), or `None` when `t`
    /// is outside the stream or inside a gap longer than [`MAX_REFERENCE_GAP`].
    pub(super) fn at(&mut self, t: f64) -> Result<Option<NavRecord>, LineError> {
        while let (Some(_), Some(b)) = (&self.a, &self.b) {
            if b.t >= t {
                break;
            }
            self.a = self.b.take();
            self.b = (self.next)()?;
        }
        Ok(match (&self.a, &self.b) {
            (Some(a), Some(b))
                if a.t <= t + 1e-9 && b.t >= t - 1e-9 && b.t - a.t <= MAX_REFERENCE_GAP =>
            {
                Some(interpolate(a, b, t))
            }
            _ => None,
        })
    }

    /// The current lower record when it falls on `t` (the stream's last record, which
    /// [`Bracket::at`] cannot bracket).
    pub(super) fn exact(&self, t: f64) -> Option<NavRecord> {
        self.a.filter(|a| (a.t - t).abs() < 1e-6)
    }
}

/// Read a whole reference file (11-column navigation or 4-column positions) into memory,
/// for repeated in-memory evaluations ([`evaluate_records`]).
pub fn read_reference(path: &Path) -> Result<Vec<NavRecord>, LineError> {
    let mut r = RefReader::open(path, None)?;
    let mut out = Vec::new();
    while let Some(rec) = r.next_record()? {
        out.push(rec);
    }
    Ok(out)
}
