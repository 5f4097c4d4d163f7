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
use ins_gnss_io::{ColumnMap, LineError, NavReader, NavRecord};

use crate::columns::TruthColumns;
use manifolds::wrap_angle;

mod nees;
mod reference;

pub use nees::*;
pub use reference::*;

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
    /// Every compared epoch after the skip (only when asked for,
    /// [`evaluate_records_per_epoch`]): time,
    /// position error N, E, D (m), velocity error N, E, D (m/s), attitude error roll,
    /// pitch, yaw (deg), the result minus the truth.
    #[serde(skip)]
    pub epochs: Vec<[f64; 10]>,
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
                evaluate_at_reference(
                    || res.next_record(),
                    || refs.next_record(),
                    Evaluator::new(skip, windows),
                )
            } else {
                evaluate_at_result(
                    || res.next_record(),
                    || refs.next_record(),
                    Evaluator::new(skip, windows),
                )
            }
        };
        let ev = errors();
        let nees = nees.map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)));
        let mut ev = ev?;
        ev.nees = nees.transpose()?;
        Ok(ev)
    })
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
    keep: bool,
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
                epochs: Vec::new(),
            },
            skip,
            windows: windows.to_vec(),
            start: None,
            keep: false,
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
            if self.keep {
                self.ev.epochs.push([t, dp.x, dp.y, dp.z, dv.x, dv.y, dv.z, da.x, da.y, da.z]);
            }
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

/// [`evaluate`] on records in memory (both time-ordered): a reference without velocity
/// (read from a 4-column file) is compared at its own epochs, a full one at the result's.
pub fn evaluate_records(
    results: &[NavRecord],
    reference: &[NavRecord],
    skip: f64,
    windows: &[(f64, f64)],
) -> Evaluation {
    records(results, reference, Evaluator::new(skip, windows))
}

/// [`evaluate_records`] without windows, keeping every compared epoch's errors
/// ([`Evaluation::epochs`]).
pub fn evaluate_records_per_epoch(
    results: &[NavRecord],
    reference: &[NavRecord],
    skip: f64,
) -> Evaluation {
    let mut ev = Evaluator::new(skip, &[]);
    ev.keep = true;
    records(results, reference, ev)
}

fn records(results: &[NavRecord], reference: &[NavRecord], ev: Evaluator) -> Evaluation {
    let (mut res, mut refs) = (results.iter().copied(), reference.iter().copied());
    let positions_only = reference.first().is_some_and(|r| r.vel.x.is_nan());
    let out = if positions_only {
        evaluate_at_reference(|| Ok(res.next()), || Ok(refs.next()), ev)
    } else {
        evaluate_at_result(|| Ok(res.next()), || Ok(refs.next()), ev)
    };
    // In memory nothing can fail to read.
    out.unwrap_or_default()
}

/// Evaluates the result at the reference's epochs (the result interpolated).
fn evaluate_at_reference(
    result: impl FnMut() -> Result<Option<NavRecord>, LineError>,
    mut reference: impl FnMut() -> Result<Option<NavRecord>, LineError>,
    ev: Evaluator,
) -> Result<Evaluation, LineError> {
    let mut res = Bracket::new(result)?;
    let mut ev = ev.with_start(res.first_t().unwrap_or(0.0));
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
    mut ev: Evaluator,
) -> Result<Evaluation, LineError> {
    let mut tru = Bracket::new(truth)?;
    while let Some(r) = result()? {
        ev.start.get_or_insert(r.t);
        match tru.at(r.t)?.or_else(|| tru.exact(r.t)) {
            Some(truth_here) => ev.add(&r, &truth_here),
            None => ev.unmatched(),
        }
    }
    Ok(ev.finish())
}
