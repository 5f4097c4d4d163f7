//! Navigation and truth records (11 columns): reader and writers.

use super::*;

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
    crate::fixed::push_row(out, &core::array::from_fn::<_, 11, _>(|i| (v[i], DECIMALS[i])));
}
