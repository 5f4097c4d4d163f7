//! Evaluation of a navigation result against a truth (or reference) file: RMS, maximum
//! and mean of the NED position errors, horizontal, 3-D, velocity, roll, pitch, yaw, over
//! the whole run after a skip and per time window (e.g. GNSS outages), and for windows
//! the RMS over windows of each window's maximum horizontal error (the outage score of
//! the KF-GINS authors). The reference is an 11-column navigation file or a 4-column
//! `t lat lon h` position file (then only positions are evaluated). Streaming: the
//! reference is interpolated linearly between its two records around each result epoch,
//! never across a gap longer than 1 s.

use std::path::Path;

use nalgebra::Vector3;
use serde::Serialize;

use ins_gnss_core::earth::geodetic_to_local_ned;
use ins_gnss_core::io::{ColumnMap, LineError, NavReader, NavRecord};

use crate::columns::TruthColumns;
use manifolds::wrap_angle;

/// Running statistics of one error component.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Stat {
    /// Root mean square.
    pub rms: f64,
    /// Maximum absolute value.
    pub max: f64,
    /// Mean (signed).
    pub mean: f64,
    #[serde(skip)]
    sum: f64,
    #[serde(skip)]
    sum_sq: f64,
    #[serde(skip)]
    n: usize,
}

impl Stat {
    fn push(&mut self, v: f64) {
        if v.is_nan() {
            // A reference without this quantity (a position-only RTK file).
            return;
        }
        self.sum += v;
        self.sum_sq += v * v;
        self.n += 1;
        self.max = self.max.max(v.abs());
        self.rms = (self.sum_sq / self.n as f64).sqrt();
        self.mean = self.sum / self.n as f64;
    }

    /// Number of samples.
    pub fn count(&self) -> usize {
        self.n
    }
}

/// All statistics of one time span.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Stats {
    /// Span label.
    pub label: String,
    /// Epochs compared.
    pub epochs: usize,
    /// North, east, down position error, m.
    pub north: Stat,
    /// East.
    pub east: Stat,
    /// Down.
    pub down: Stat,
    /// Horizontal, m.
    pub horizontal: Stat,
    /// 3-D position, m.
    pub position_3d: Stat,
    /// Velocity N, E, D and 3-D, m/s.
    pub vel_north: Stat,
    /// Velocity E.
    pub vel_east: Stat,
    /// Velocity D.
    pub vel_down: Stat,
    /// Velocity 3-D.
    pub velocity_3d: Stat,
    /// Roll, deg.
    pub roll: Stat,
    /// Pitch, deg.
    pub pitch: Stat,
    /// Yaw, deg (wrapped to ±180°).
    pub yaw: Stat,
}

impl Stats {
    fn new(label: String) -> Self {
        Self { label, ..Default::default() }
    }

    fn push(&mut self, dp: &Vector3<f64>, dv: &Vector3<f64>, da: &Vector3<f64>) {
        self.epochs += 1;
        self.north.push(dp.x);
        self.east.push(dp.y);
        self.down.push(dp.z);
        self.horizontal.push((dp.x * dp.x + dp.y * dp.y).sqrt());
        self.position_3d.push(dp.norm());
        self.vel_north.push(dv.x);
        self.vel_east.push(dv.y);
        self.vel_down.push(dv.z);
        self.velocity_3d.push(dv.norm());
        self.roll.push(da.x);
        self.pitch.push(da.y);
        self.yaw.push(da.z);
    }
}

/// The evaluation result.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Evaluation {
    /// After the skip, whole run.
    pub overall: Stats,
    /// Per requested window.
    pub windows: Vec<Stats>,
    /// RMS over the windows of each window's maximum horizontal error, m (the score of
    /// outage tests: each window a simulated GNSS outage). NaN without windows.
    pub windows_rms_of_max_horizontal: f64,
    /// The same for the vertical error, m.
    pub windows_rms_of_max_vertical: f64,
    /// Result epochs without truth around them (outside the truth's span, or inside a
    /// gap of the reference longer than 1 s).
    pub unmatched: usize,
    /// The errors against the result's own σ (its `std.txt` beside it), after the skip;
    /// `None` without a σ file.
    pub nees: Option<NeesSummary>,
}

/// The fraction of epochs beyond the 99 % quantile above which a block's NEES is judged
/// inconsistent: five times its expected 1 %. Errors at successive epochs are strongly
/// correlated (a 100 Hz output drifts for seconds), so no band drawn from the count of
/// epochs applies; the factor leaves room for that correlation and still flags a σ that
/// is too small by 1.3× or more on a long run (at 1.3× a χ²(3) NEES exceeds the 99 %
/// quantile 6 % of the time).
pub const NEES_BEYOND_LIMIT: f64 = 0.05;

/// The normalised estimation error squared of one block (position, velocity or attitude)
/// against a truth: `Σ (e_i / σ_i)²` over its three components, with the result's
/// reported σ (the diagonal of its covariance: `std.txt` holds no correlations).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Nees {
    /// Epochs compared.
    pub epochs: usize,
    /// Degrees of freedom per epoch.
    pub dof: usize,
    /// Mean NEES per degree of freedom (1 for a consistent filter).
    pub mean_per_dof: f64,
    /// Fraction of epochs whose NEES exceeds `χ²_{0.99}(dof)` (0.01 for a consistent
    /// filter).
    pub beyond_99: f64,
    #[serde(skip)]
    sum: f64,
    #[serde(skip)]
    beyond: usize,
}

impl Nees {
    fn push(&mut self, e: &Vector3<f64>, sigma: &[f64], gate: f64) {
        if e.iter().chain(sigma).any(|v| !v.is_finite()) || sigma.iter().any(|s| *s <= 0.0) {
            return;
        }
        let q: f64 = (0..3).map(|i| (e[i] / sigma[i]).powi(2)).sum();
        self.epochs += 1;
        self.dof = 3;
        self.sum += q;
        self.beyond += usize::from(q > gate);
        self.mean_per_dof = self.sum / (3 * self.epochs) as f64;
        self.beyond_99 = self.beyond as f64 / self.epochs as f64;
    }

    /// Whether the block is consistent: at most [`NEES_BEYOND_LIMIT`] of the epochs
    /// beyond the 99 % quantile (`None` when nothing was compared).
    pub fn consistent(&self) -> Option<bool> {
        (self.epochs > 0).then_some(self.beyond_99 <= NEES_BEYOND_LIMIT)
    }
}

/// NEES of a result against a truth, per block.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct NeesSummary {
    /// Position (north, east, down; m).
    pub position: Nees,
    /// Velocity (m/s); empty against a position reference.
    pub velocity: Nees,
    /// Attitude (roll, pitch, yaw; deg); empty against a position reference.
    pub attitude: Nees,
}

impl NeesSummary {
    /// The compared blocks, named.
    pub fn blocks(&self) -> impl Iterator<Item = (&'static str, &Nees)> {
        [("position", &self.position), ("velocity", &self.velocity), ("attitude", &self.attitude)]
            .into_iter()
            .filter(|(_, n)| n.epochs > 0)
    }

    /// Consistent when every compared block is.
    pub fn consistent(&self) -> bool {
        self.blocks().all(|(_, n)| n.consistent() != Some(false))
    }

    /// One line for a summary: each block's mean NEES per degree of freedom and its
    /// fraction beyond the 99 % quantile, and the verdict.
    pub fn line(&self) -> String {
        let blocks: Vec<String> = self
            .blocks()
            .map(|(name, n)| {
                format!(
                    "{name} NEES/dof {:.2}, {:.1} % of {} epochs beyond χ²₀.₉₉({})",
                    n.mean_per_dof,
                    100.0 * n.beyond_99,
                    n.epochs,
                    n.dof
                )
            })
            .collect();
        format!(
            "{} (expected 1.00 and 1 %; judged on at most {:.0} % beyond): {}",
            blocks.join("; "),
            100.0 * NEES_BEYOND_LIMIT,
            if self.consistent() {
                "consistent"
            } else {
                "NOT consistent — the errors against the truth are larger than the reported σ"
            }
        )
    }
}

/// The reference reader of `truth`, through its column map when it has one.
fn reference_reader(truth: &Path, columns: Option<&TruthColumns>) -> Result<RefReader, LineError> {
    let map = match columns {
        Some(c) => Some(c.map().map_err(|m| LineError {
            path: truth.to_path_buf(),
            line: 0,
            kind: ins_gnss_core::io::LineErrorKind::WrongUnits(m),
        })?),
        None => None,
    };
    RefReader::open(truth, map.as_ref())
}

/// The σ file written beside a result (`nav.txt` → `std.txt`, `nav_smoothed.txt` →
/// `std_smoothed.txt`), when it exists.
pub fn sigma_file(result: &Path) -> Option<std::path::PathBuf> {
    let name = result.file_name()?.to_str()?;
    let std = name.strip_prefix("nav").map(|rest| format!("std{rest}"))?;
    let p = result.with_file_name(std);
    p.is_file().then_some(p)
}

/// The NEES of `result` (with its σ file `sigma`, line for line) against `truth`, at the
/// result's epochs (the truth interpolated, never across a gap longer than
/// [`MAX_REFERENCE_GAP`]), after `skip` seconds.
pub fn nees_with(
    result: &Path,
    sigma: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
    skip: f64,
) -> Result<NeesSummary, LineError> {
    let mut res = NavReader::open(result)?;
    let mut refs = reference_reader(truth, columns)?;
    let mut tru = Bracket::new(|| refs.next_record())?;
    let mut std =
        ins_gnss_core::io::NumericLines::new(ins_gnss_core::io::formats::open(sigma)?, sigma);
    let gate = estimator_core::consistency::chi2_quantile(0.99, 3.0);
    let mut out = NeesSummary::default();
    let mut start = None;
    let mut r = res.next_record()?;
    loop {
        let mut row = [0.0; 10];
        match std.next_record()? {
            None => break,
            Some(v) if v.len() >= 10 => row.copy_from_slice(&v[..10]),
            Some(v) => {
                let column = v.len();
                return Err(std.error(ins_gnss_core::io::LineErrorKind::NotNumeric {
                    column,
                    text: "a σ file has at least 10 columns (t, position, velocity, attitude)"
                        .into(),
                }));
            }
        }
        // the σ file is written at the GNSS epochs, the result at every IMU epoch
        while r.is_some_and(|r| r.t < row[0] - 1e-6) {
            r = res.next_record()?;
        }
        let Some(here) = r.filter(|r| (r.t - row[0]).abs() <= 1e-6) else { continue };
        let t0 = *start.get_or_insert(here.t);
        if here.t - t0 < skip {
            continue;
        }
        let Some(t) = tru.at(here.t)?.or_else(|| tru.exact(here.t)) else { continue };
        let (dp, dv, da) = errors(&here, &t);
        out.position.push(&dp, &row[1..4], gate);
        out.velocity.push(&dv, &row[4..7], gate);
        out.attitude.push(&da, &row[7..10], gate);
    }
    Ok(out)
}

impl Stats {
    /// The figures of a results table, in its order: N, E, D, horizontal RMS, horizontal
    /// max, 3-D RMS (m), velocity 3-D RMS (m/s), roll, pitch, yaw RMS and yaw max (deg).
    pub fn table_row(&self) -> [f64; 11] {
        [
            self.north.rms,
            self.east.rms,
            self.down.rms,
            self.horizontal.rms,
            self.horizontal.max,
            self.position_3d.rms,
            self.velocity_3d.rms,
            self.roll.rms,
            self.pitch.rms,
            self.yaw.rms,
            self.yaw.max,
        ]
    }
}

/// Largest gap of the reference that is interpolated across, s.
pub const MAX_REFERENCE_GAP: f64 = 1.0;

/// Reads a reference: the 11-column navigation format, or `t lat lon h` (4 columns, e.g.
/// RTK-fixed positions), whose velocity and attitude are NaN (not evaluated).
pub struct RefReader {
    lines: ins_gnss_core::io::NumericLines<ins_gnss_core::io::formats::Input>,
    prev_t: Option<f64>,
    /// A log with a header: its map, resolved, and the mapped record.
    map: Option<(ins_gnss_core::io::columns::Resolved, Vec<f64>)>,
}

impl RefReader {
    /// Open a reference file; with `columns`, a log with a header read through its map
    /// (11 fields, NaN where the log has no velocity or attitude: see
    /// [`TruthColumns`]).
    pub fn open(path: &Path, columns: Option<&ColumnMap>) -> Result<Self, LineError> {
        let mut lines =
            ins_gnss_core::io::NumericLines::new(ins_gnss_core::io::formats::open(path)?, path);
        let map = match columns {
            Some(c) => {
                let header = lines.next_text()?.map(str::to_string);
                let header =
                    header.ok_or_else(|| lines.error(ins_gnss_core::io::LineErrorKind::Empty))?;
                let resolved = c
                    .resolve(&header)
                    .map_err(|m| lines.error(ins_gnss_core::io::LineErrorKind::WrongUnits(m)))?;
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
                pos: ins_gnss_core::position::GeoPos::from_degrees(r[2], r[3], r[4]),
                vel: Vector3::new(r[5], r[6], r[7]),
                att: Vector3::new(r[8] * d, r[9] * d, r[10] * d),
            },
            4 => NavRecord {
                week: 0.0,
                t: r[0],
                pos: ins_gnss_core::position::GeoPos::from_degrees(r[1], r[2], r[3]),
                vel: Vector3::repeat(f64::NAN),
                att: Vector3::repeat(f64::NAN),
            },
            found => {
                return Err(self.lines.error(ins_gnss_core::io::LineErrorKind::ColumnCount {
                    expected: vec![11, 4],
                    found,
                }))
            }
        };
        if let Some(p) = self.prev_t {
            if rec.t <= p {
                return Err(self.lines.error(ins_gnss_core::io::LineErrorKind::TimeBackwards {
                    t: rec.t,
                    previous: p,
                }));
            }
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
        pos: ins_gnss_core::position::GeoPos {
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

/// Evaluate `result` against `truth`, skipping the first `skip` seconds of the result,
/// with extra statistics inside each `(t0, t1)` window (absolute times).
///
/// An 11-column truth is compared at the result's epochs (truth interpolated); a 4-column
/// position reference, usually sparser than the result (RTK at a few Hz), is compared at
/// its own epochs (result interpolated), so no reference position is invented between
/// fixes.
pub fn evaluate(
    result: &Path,
    truth: &Path,
    skip: f64,
    windows: &[(f64, f64)],
) -> Result<Evaluation, LineError> {
    evaluate_with(result, truth, None, skip, windows)
}

/// [`evaluate`] against a truth log with a header, read through its column map (a map
/// without velocity is a position reference, compared at its own epochs).
pub fn evaluate_with(
    result: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
    skip: f64,
    windows: &[(f64, f64)],
) -> Result<Evaluation, LineError> {
    // The NEES pass (the σ file beside the result) reads the files a second time: on a
    // thread of its own, beside the error statistics (a day at 100 Hz is 2 GB of text per
    // pass).
    let sigma = sigma_file(result);
    std::thread::scope(|scope| {
        let nees = sigma
            .as_ref()
            .map(|sigma| scope.spawn(move || nees_with(result, sigma, truth, columns, skip)));
        let errors = || -> Result<Evaluation, LineError> {
            let mut res = NavReader::open(result)?;
            let mut refs = reference_reader(truth, columns)?;
            let positions_only = match columns {
                Some(c) => c.positions_only(),
                None => reference_columns(truth)? == 4,
            };
            if positions_only {
                evaluate_at_reference(|| res.next_record(), || refs.next_record(), skip, windows)
            } else {
                evaluate_at_result(|| res.next_record(), || refs.next_record(), skip, windows)
            }
        };
        let ev = errors();
        let nees = nees.map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)));
        let mut ev = ev?;
        ev.nees = nees.transpose()?;
        Ok(ev)
    })
}

fn reference_columns(path: &Path) -> Result<usize, LineError> {
    let mut lines =
        ins_gnss_core::io::NumericLines::new(ins_gnss_core::io::formats::open(path)?, path);
    Ok(lines.next_record()?.map(|r| r.len()).unwrap_or(0))
}

/// A pair of consecutive records of one time-ordered stream around a query time.
struct Bracket<F> {
    next: F,
    a: Option<NavRecord>,
    b: Option<NavRecord>,
}

impl<F: FnMut() -> Result<Option<NavRecord>, LineError>> Bracket<F> {
    fn new(mut next: F) -> Result<Self, LineError> {
        let a = next()?;
        let b = next()?;
        Ok(Self { next, a, b })
    }

    /// Time of the stream's first record.
    fn first_t(&self) -> Option<f64> {
        self.a.as_ref().map(|r| r.t)
    }

    /// The stream interpolated at `t` (non-decreasing across calls), or `None` when `t`
    /// is outside the stream or inside a gap longer than [`MAX_REFERENCE_GAP`].
    fn at(&mut self, t: f64) -> Result<Option<NavRecord>, LineError> {
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
    fn exact(&self, t: f64) -> Option<NavRecord> {
        self.a.filter(|a| (a.t - t).abs() < 1e-6)
    }
}

/// Incremental evaluation, for results produced in memory (Monte Carlo runs, tests):
/// add `(result, reference)` pairs in time order, then [`Evaluator::finish`]. The file
/// evaluation ([`evaluate`]) is built on it.
#[derive(Clone, Debug)]
pub struct Evaluator {
    ev: Evaluation,
    skip: f64,
    windows: Vec<(f64, f64)>,
    start: Option<f64>,
}

impl Evaluator {
    /// Statistics after the first `skip` seconds (counted from the first pair added, or
    /// from [`Evaluator::with_start`]) and inside each `(t0, t1)` window (absolute
    /// times).
    pub fn new(skip: f64, windows: &[(f64, f64)]) -> Self {
        Self {
            ev: Evaluation {
                overall: Stats::new(format!("after {skip} s")),
                windows: windows.iter().map(|(a, b)| Stats::new(format!("{a}–{b}"))).collect(),
                windows_rms_of_max_horizontal: f64::NAN,
                windows_rms_of_max_vertical: f64::NAN,
                unmatched: 0,
                nees: None,
            },
            skip,
            windows: windows.to_vec(),
            start: None,
        }
    }

    /// Count the skip from `t0` instead of the first pair's time.
    pub fn with_start(mut self, t0: f64) -> Self {
        self.start = Some(t0);
        self
    }

    /// Adds the errors of `result` against `reference` at the reference's time: to the
    /// whole run when it is at least `skip` after the start, and to every window that
    /// contains it.
    pub fn add(&mut self, result: &NavRecord, reference: &NavRecord) {
        let t = reference.t;
        let start = *self.start.get_or_insert(t);
        let (dp, dv, da) = errors(result, reference);
        if t - start >= self.skip {
            self.ev.overall.push(&dp, &dv, &da);
        }
        for (w, (a, b)) in self.ev.windows.iter_mut().zip(&self.windows) {
            if t >= *a && t <= *b {
                w.push(&dp, &dv, &da);
            }
        }
    }

    /// Counts a result epoch without a reference around it.
    pub fn unmatched(&mut self) {
        self.ev.unmatched += 1;
    }

    /// The statistics, with the per-window score.
    pub fn finish(mut self) -> Evaluation {
        let used: Vec<&Stats> = self.ev.windows.iter().filter(|w| w.epochs > 0).collect();
        if !used.is_empty() {
            let n = used.len() as f64;
            self.ev.windows_rms_of_max_horizontal =
                (used.iter().map(|w| w.horizontal.max.powi(2)).sum::<f64>() / n).sqrt();
            self.ev.windows_rms_of_max_vertical =
                (used.iter().map(|w| w.down.max.powi(2)).sum::<f64>() / n).sqrt();
        }
        self.ev
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

/// [`evaluate`] on records in memory (both time-ordered): a reference without velocity
/// (read from a 4-column file) is compared at its own epochs, a full one at the result's.
pub fn evaluate_records(
    results: &[NavRecord],
    reference: &[NavRecord],
    skip: f64,
    windows: &[(f64, f64)],
) -> Evaluation {
    let (mut res, mut refs) = (results.iter().copied(), reference.iter().copied());
    let positions_only = reference.first().is_some_and(|r| r.vel.x.is_nan());
    let out = if positions_only {
        evaluate_at_reference(|| Ok(res.next()), || Ok(refs.next()), skip, windows)
    } else {
        evaluate_at_result(|| Ok(res.next()), || Ok(refs.next()), skip, windows)
    };
    // In memory nothing can fail to read.
    out.unwrap_or_default()
}

/// Evaluates the result at the reference's epochs (the result interpolated).
fn evaluate_at_reference(
    result: impl FnMut() -> Result<Option<NavRecord>, LineError>,
    mut reference: impl FnMut() -> Result<Option<NavRecord>, LineError>,
    skip: f64,
    windows: &[(f64, f64)],
) -> Result<Evaluation, LineError> {
    let mut res = Bracket::new(result)?;
    let mut ev = Evaluator::new(skip, windows).with_start(res.first_t().unwrap_or(0.0));
    while let Some(f) = reference()? {
        match res.at(f.t)? {
            Some(here) => ev.add(&here, &f),
            None => ev.unmatched(),
        }
    }
    Ok(ev.finish())
}

/// Evaluates the result at its own epochs (the truth interpolated).
fn evaluate_at_result(
    mut result: impl FnMut() -> Result<Option<NavRecord>, LineError>,
    truth: impl FnMut() -> Result<Option<NavRecord>, LineError>,
    skip: f64,
    windows: &[(f64, f64)],
) -> Result<Evaluation, LineError> {
    let mut tru = Bracket::new(truth)?;
    let mut ev = Evaluator::new(skip, windows);
    while let Some(r) = result()? {
        ev.start.get_or_insert(r.t);
        match tru.at(r.t)?.or_else(|| tru.exact(r.t)) {
            Some(truth_here) => ev.add(&r, &truth_here),
            None => ev.unmatched(),
        }
    }
    Ok(ev.finish())
}
