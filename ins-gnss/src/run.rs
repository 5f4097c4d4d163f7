//! One run of the navigator over files, streaming: the IMU and GNSS files are read line
//! by line, results are written as they are produced, and memory does not grow with the
//! dataset.
//!
//! Outputs (in the output directory):
//! - `nav.txt`: the 11-column navigation result at every IMU epoch;
//! - `std.txt`: `t`, 1σ of position N E D (m), velocity N E D (m/s), roll pitch yaw
//!   (deg), gyro bias x y z (deg/h), accelerometer bias x y z (mGal), with 21 states the
//!   gyro and accelerometer scale factors (ppm), after every IMU sample with an update,
//!   at least once a second, and at the end;
//! - `imu_errors.txt`: `t`, gyro bias x y z (deg/h), accelerometer bias x y z (mGal), with
//!   21 states the scale factors (ppm), at the same epochs;
//! - `updates.csv`: one row per update: time, stream name (`gnss-position`,
//!   `gnss-position-velocity`, `nhc`, `zupt`, `zaru`, `odometer`), dimension, NIS,
//!   adapted NIS, decision, reason, DOM, λ_P, λ_R, and 1 where a strategy's subspace prior
//!   scaling fell back to full scaling.

use core::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use adaptive::{AnyStrategy, GrossErrorGate, PerStream};
use estimator_core::{NoObserver, NoiseStrategy, SmoothedRow, UpdateSummary, Verdict};
use nalgebra::Vector3;

use crate::aiding::{AidEpoch, AidReader};
use crate::config::Config;
use estimator_core::DimAlloc;
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::imu::ImuSample;
use ins_gnss_core::imu::{DEG_PER_H, MGAL};
use ins_gnss_core::io::fixed::{push_exact, push_exact_row, push_row};
use ins_gnss_core::io::formats::{create_partial, partial_path, publish, push_nav};
use ins_gnss_core::io::{GnssReader, ImuReader, LineError, NavRecord, SkipCounts};
use ins_gnss_core::model::{ImuInput, InsModel};
use ins_gnss_core::navigator::{ClockInit, NavError, NavState, Navigator, RawEpoch, TightConfig};
use ins_gnss_core::scale::{InsModel21, InsState21};
use ins_gnss_core::state::InsState;
use ins_gnss_core::tight::{ClockNoise, InsModelTc, InsStateTc};
use ins_gnss_core::vehicle::VEHICLE_STREAMS;
use nalgebra::DefaultAllocator;

/// Why a run stopped.
#[derive(Debug)]
pub enum RunError {
    /// A configuration problem.
    Config(crate::config::ConfigError),
    /// A malformed input line or unreadable file.
    Input(LineError),
    /// The filter failed (with time).
    Navigation(NavError),
    /// The filter failed on the record of `path` at `line`: a GNSS epoch whose update
    /// failed, or the IMU sample whose prediction did.
    Located {
        /// The input file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What failed.
        error: NavError,
    },
    /// Writing an output failed.
    Output {
        /// The file.
        path: PathBuf,
        /// The error.
        message: String,
    },
    /// A raw GNSS file (tight coupling) is malformed or cannot be used.
    Raw(ins_gnss_core::raw::RawError),
    /// The IMU file ends before the start time or has no sample after it.
    NoData(String),
    /// The data do not match the configuration (units, axes, rate), or the initial state
    /// cannot be found from them; the message names the key to change.
    Start(String),
    /// The run failed after it had started writing: its outputs stay as `*.partial` in
    /// `dir`, earlier results there are untouched.
    Incomplete {
        /// Why.
        error: Box<RunError>,
        /// The output directory.
        dir: PathBuf,
    },
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::Config(e) => write!(f, "{e}"),
            RunError::Input(e) => write!(f, "{e}"),
            RunError::Navigation(e) => write!(f, "navigation failed {e}"),
            RunError::Located { path, line, error } => {
                write!(f, "{}:{line}: navigation failed {error}", path.display())
            }
            RunError::Output { path, message } => {
                write!(f, "{}: cannot write: {message}", path.display())
            }
            RunError::Raw(e) => write!(f, "{e}"),
            RunError::NoData(m) => write!(f, "{m}"),
            RunError::Start(m) => write!(f, "{m}"),
            RunError::Incomplete { error, dir } => write!(
                f,
                "{error}\n(no earlier result in {} was touched; this run's partial output is \
                 there as *.partial)",
                dir.display()
            ),
        }
    }
}

impl std::error::Error for RunError {}

impl From<LineError> for RunError {
    fn from(e: LineError) -> Self {
        RunError::Input(e)
    }
}

impl From<NavError> for RunError {
    fn from(e: NavError) -> Self {
        RunError::Navigation(e)
    }
}

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    /// Strategy name.
    pub strategy: String,
    /// IMU epochs processed.
    pub imu_epochs: usize,
    /// GNSS epochs used (accepted + inflated + rejected).
    pub gnss_epochs: usize,
    /// Accepted updates.
    pub accepted: usize,
    /// Inflated updates.
    pub inflated: usize,
    /// Updates with adapted noise smaller than the nominal.
    pub deflated: usize,
    /// Rejected updates.
    pub rejected: usize,
    /// IMU lines skipped / gaps bridged.
    pub imu_skipped: SkipCounts,
    /// GNSS lines skipped.
    pub gnss_skipped: SkipCounts,
    /// First and last processed time, s.
    pub span: (f64, f64),
    /// Wall time, s.
    pub wall_time: f64,
    /// Output directory.
    pub out_dir: PathBuf,
    /// Sum of the NIS of the plainly accepted updates, and of their dimensions (the
    /// degrees of freedom): `nis_sum / nis_dof` is the mean NIS per degree of freedom,
    /// 1 for a filter whose uncertainty is consistent with its innovations.
    pub nis_sum: f64,
    /// See [`nis_sum`](Self::nis_sum).
    pub nis_dof: usize,
    /// Time of the first and last GNSS epoch read, s (NaN when none was).
    pub gnss_span: (f64, f64),
    /// Vehicle-aiding updates per stream (NHC, ZUPT, ZARU, odometer): used (accepted or inflated)
    /// and refused.
    pub aiding: [AidingCount; 4],
    /// Time the vehicle was judged standing (detector and filter speed), s (0 without
    /// ZUPT).
    pub stationary_time: f64,
    /// Rows of `nav_smoothed.txt` when the run smoothed (`filter.smooth`), and the wall
    /// time of the backward pass, s.
    pub smoothed: Option<(usize, f64)>,
    /// The IMU noise densities the filter used, SI ([`Config::noise_echo`]).
    pub noise: String,
    /// How the parts of the initial state (and the noise) not given were found from the
    /// data ([`crate::start`]), one line each.
    pub start: Vec<String>,
    /// Every stream's innovations, whatever their verdict, in the order first seen.
    pub streams: Vec<StreamStats>,
    /// The first GNSS epoch the filter used.
    pub first_fix: Option<GnssEpoch>,
}

/// A GNSS gap longer than this (s) is an outage for [`StreamStats::refused_after_outage`].
pub const OUTAGE: f64 = 5.0;

/// One measurement stream's innovations over the run, with the nominal `S` (before any
/// adaptation): how many were refused as gross errors (the data's quality), and the
/// statistics of the others, used accepted or inflated (the run's consistency).
#[derive(Clone, Debug)]
pub struct StreamStats {
    /// The stream.
    pub stream: estimator_core::StreamId,
    /// Whether it is a GNSS stream (not vehicle aiding).
    pub gnss: bool,
    /// Updates.
    pub epochs: usize,
    /// Refused updates (gross errors: the data's quality, not the run's consistency).
    pub refused: usize,
    /// Sum of the NIS (nominal `S`) and of the dimensions, over the updates used.
    pub nis_sum: f64,
    /// See [`nis_sum`](Self::nis_sum).
    pub dof: usize,
    /// Updates used whose NIS exceeds the median of its χ² distribution (half of them
    /// for a consistent filter).
    pub above_median: usize,
    /// The median over the updates used of NIS / (χ² median): the factor² by which `S` is
    /// too small (about 1 when consistent), from the sorted ratios at the end of the run.
    pub median_ratio: f64,
    /// Refusals from a gap of more than [`OUTAGE`] s in the stream until its next
    /// accepted update.
    pub refused_after_outage: usize,
    /// Updates used with `R` inflated (a strategy's or the gate's `R` factor above 1).
    pub r_inflated: usize,
    /// The largest `R` factor, and the time of the first and the last inflated update.
    pub r_factor_max: f64,
    /// See [`r_factor_max`](Self::r_factor_max).
    pub r_inflated_span: (f64, f64),
    /// Updates used with the prior inflated (a strategy's or the gate's factor on `P⁻`
    /// above 1: a re-admission, or the state doubted).
    pub prior_inflated: usize,
    ratios: Vec<f32>,
    last_t: f64,
    after_outage: bool,
    accepted_any: bool,
}

impl StreamStats {
    /// The mean NIS per degree of freedom and its two-sided 99 % band for a consistent
    /// filter (the summed NIS is χ² with the summed degrees of freedom).
    pub fn mean_nis(&self) -> (f64, (f64, f64)) {
        let k = self.dof.max(1) as f64;
        let q = |p| estimator_core::consistency::chi2_quantile(p, k) / k;
        (self.nis_sum / k, (q(0.005), q(0.995)))
    }

    /// The fraction of updates above their χ² median and its band at a two-sided
    /// probability of 1e-6 for a consistent filter (binomial with p = ½, normal
    /// approximation): outside it, the innovations are far from their distribution.
    pub fn above_median_band(&self) -> (f64, (f64, f64)) {
        let n = self.used().max(1) as f64;
        // the standard normal quantile of 1 − 0.5e-6
        let half = 4.8916 * 0.5 / n.sqrt();
        (self.above_median as f64 / n, (0.5 - half, 0.5 + half))
    }

    /// Updates used (accepted or inflated): the ones the consistency is judged on.
    pub fn used(&self) -> usize {
        self.epochs - self.refused
    }

    /// The share of the stream's epochs refused as gross errors.
    pub fn refused_share(&self) -> f64 {
        self.refused as f64 / self.epochs.max(1) as f64
    }

    /// Consistent by the mean NIS of the innovations used.
    pub fn consistent(&self) -> bool {
        let (m, (lo, hi)) = self.mean_nis();
        m >= lo && m <= hi
    }

    /// One line for the run summary.
    pub fn verdict(&self) -> String {
        let (m, (lo, hi)) = self.mean_nis();
        let (f, (flo, fhi)) = self.above_median_band();
        let head = format!(
            "consistency of {}: mean NIS per degree of freedom {m:.3} over the {} updates \
             used ({} of {} refused as gross errors, {:.1} %), 99 % band [{lo:.3}, {hi:.3}]; \
             {:.1} % above their χ² median (band [{:.1}, {:.1}] %)",
            self.stream,
            self.used(),
            self.refused,
            self.epochs,
            100.0 * self.refused_share(),
            100.0 * f,
            100.0 * flo,
            100.0 * fhi
        );
        if self.consistent() {
            format!("{head}: consistent")
        } else if m > hi {
            format!(
                "{head}: NOT consistent — the innovations are larger than the filter believes \
                 (the typical one {:.2}× its σ, the excess in the largest ones), so its \
                 reported σ (std.txt) is too small",
                self.median_ratio.max(0.0).sqrt()
            )
        } else if self.stream.to_string().starts_with("pr ") {
            // a satellite's pseudoranges (tight coupling): see `health::assess`
            format!(
                "{head}: NOT consistent — the innovations are smaller than the filter \
                 believes: the satellite's errors stay the same from epoch to epoch and the \
                 position and clock absorb them (the position σ is then too small, not too \
                 large), or the noise settings are pessimistic"
            )
        } else {
            format!(
                "{head}: NOT consistent — the innovations are smaller than the filter \
                 believes, so its reported σ is too large (noise settings pessimistic)"
            )
        }
    }

    fn new(stream: estimator_core::StreamId) -> Self {
        Self {
            stream,
            gnss: !VEHICLE_STREAMS.contains(&stream),
            epochs: 0,
            refused: 0,
            nis_sum: 0.0,
            dof: 0,
            above_median: 0,
            median_ratio: f64::NAN,
            refused_after_outage: 0,
            r_inflated: 0,
            r_factor_max: 1.0,
            r_inflated_span: (f64::NAN, f64::NAN),
            prior_inflated: 0,
            ratios: Vec::new(),
            last_t: f64::NAN,
            after_outage: false,
            accepted_any: false,
        }
    }

    fn add(&mut self, u: &UpdateSummary, median: f64) {
        // (an outage after accepted updates: refusals from the start are not its doing)
        if self.last_t.is_finite() && u.time - self.last_t > OUTAGE && self.accepted_any {
            self.after_outage = true;
        }
        self.last_t = u.time;
        self.epochs += 1;
        if u.verdict != Verdict::Rejected {
            self.nis_sum += u.nis;
            self.dof += u.dim;
            self.above_median += usize::from(u.nis > median);
            self.ratios.push((u.nis / median) as f32);
        }
        match u.verdict {
            Verdict::Rejected => {
                self.refused += 1;
                self.refused_after_outage += usize::from(self.after_outage);
            }
            Verdict::Accepted => {
                self.after_outage = false;
                self.accepted_any = true;
            }
            Verdict::Inflated | Verdict::Deflated => {}
        }
        if u.verdict != Verdict::Rejected {
            if u.factors.lambda_r > 1.0 {
                self.r_inflated += 1;
                self.r_factor_max = self.r_factor_max.max(u.factors.lambda_r);
                if self.r_inflated_span.0.is_nan() {
                    self.r_inflated_span.0 = u.time;
                }
                self.r_inflated_span.1 = u.time;
            }
            self.prior_inflated += usize::from(u.factors.lambda_p > 1.0);
        }
    }

    /// How the stream's noise was adapted (`None` when it was not): the updates with `R`
    /// inflated, the largest factor and when; the updates with the prior inflated.
    pub fn adaptation(&self) -> Option<String> {
        if self.r_inflated == 0 && self.prior_inflated == 0 {
            return None;
        }
        let mut parts = Vec::new();
        if self.r_inflated > 0 {
            parts.push(format!(
                "R inflated on {} of {} updates (up to {:.1}×, σ × {:.1}; between {:.1} and \
                 {:.1} s)",
                self.r_inflated,
                self.epochs,
                self.r_factor_max,
                self.r_factor_max.sqrt(),
                self.r_inflated_span.0,
                self.r_inflated_span.1
            ));
        }
        if self.prior_inflated > 0 {
            parts.push(format!(
                "the prior inflated on {} (re-admitted after refusals, or the state doubted)",
                self.prior_inflated
            ));
        }
        Some(format!("adaptation of {}: {}", self.stream, parts.join("; ")))
    }

    fn finish(&mut self) {
        let mut r = std::mem::take(&mut self.ratios);
        if !r.is_empty() {
            let k = r.len() / 2;
            let (_, m, _) = r.select_nth_unstable_by(k, f32::total_cmp);
            self.median_ratio = f64::from(*m);
        }
    }
}

/// The median of χ² with `k` degrees of freedom (cached for the small `k` of
/// measurements).
fn chi2_median(k: usize) -> f64 {
    static CACHE: std::sync::OnceLock<[f64; 13]> = std::sync::OnceLock::new();
    let c = CACHE.get_or_init(|| {
        core::array::from_fn(|k| estimator_core::consistency::chi2_quantile(0.5, k.max(1) as f64))
    });
    match c.get(k) {
        Some(m) => *m,
        None => estimator_core::consistency::chi2_quantile(0.5, k as f64),
    }
}

/// Updates of one vehicle-aiding stream.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AidingCount {
    /// Accepted or inflated.
    pub used: usize,
    /// Rejected (by the gate or the strategy).
    pub rejected: usize,
}

/// Whether a run's innovations were consistent with its reported uncertainty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Consistency {
    /// Mean NIS per degree of freedom of the plainly accepted updates.
    pub mean_nis: f64,
    /// The two-sided 99 % band of that mean for a consistent filter (χ² with the summed
    /// degrees of freedom).
    pub band: (f64, f64),
    /// Updates counted.
    pub updates: usize,
}

impl Consistency {
    /// Inside the band.
    pub fn consistent(&self) -> bool {
        self.mean_nis >= self.band.0 && self.mean_nis <= self.band.1
    }

    /// One line for the run summary: the verdict, and a warning when not consistent.
    pub fn verdict(&self) -> String {
        let head = format!(
            "consistency: mean NIS per degree of freedom {:.3} over {} accepted updates, 99 % band [{:.3}, {:.3}]",
            self.mean_nis, self.updates, self.band.0, self.band.1
        );
        if self.consistent() {
            format!("{head}: consistent")
        } else if self.mean_nis > self.band.1 {
            format!(
                "{head}: NOT consistent — the innovations are larger than the filter believes, \
                 so its reported σ (std.txt) is too small; check the GNSS and IMU noise settings"
            )
        } else {
            format!(
                "{head}: NOT consistent — the innovations are smaller than the filter believes, \
                 so its reported σ is too large (noise settings pessimistic)"
            )
        }
    }
}

impl RunSummary {
    /// The consistency of the plainly accepted updates' NIS (`None` without any).
    pub fn consistency(&self) -> Option<Consistency> {
        if self.nis_dof == 0 {
            return None;
        }
        let k = self.nis_dof as f64;
        let q = |p| estimator_core::consistency::chi2_quantile(p, k) / k;
        Some(Consistency {
            mean_nis: self.nis_sum / k,
            band: (q(0.005), q(0.995)),
            updates: self.accepted,
        })
    }

    /// Close the streams' statistics at the end of the run.
    fn finish_streams(&mut self) {
        for s in &mut self.streams {
            s.finish();
        }
    }

    /// Count the verdicts of one epoch's updates (GNSS and vehicle aiding apart; only
    /// GNSS updates enter the consistency check).
    fn tally(&mut self, updates: &[UpdateSummary]) {
        for u in updates {
            let i = match self.streams.iter().position(|s| s.stream == u.stream) {
                Some(i) => i,
                None => {
                    self.streams.push(StreamStats::new(u.stream));
                    self.streams.len() - 1
                }
            };
            self.streams[i].add(u, chi2_median(u.dim));
            if let Some(k) = VEHICLE_STREAMS.iter().position(|s| *s == u.stream) {
                match u.verdict {
                    Verdict::Rejected => self.aiding[k].rejected += 1,
                    _ => self.aiding[k].used += 1,
                }
                continue;
            }
            self.gnss_epochs += 1;
            match u.verdict {
                Verdict::Accepted => {
                    self.accepted += 1;
                    self.nis_sum += u.nis;
                    self.nis_dof += u.dim;
                }
                Verdict::Inflated => self.inflated += 1,
                Verdict::Deflated => self.deflated += 1,
                Verdict::Rejected => self.rejected += 1,
            }
        }
    }
}

/// Called every `every` IMU epochs with the current time, for progress bars.
pub type Progress<'a> = &'a mut dyn FnMut(f64);

/// Where a run's results go: files in a directory ([`Outputs`], the program) or memory
/// ([`Results`], the bindings). The filter thread hands over the σ, IMU-error and update
/// rows ([`Outputs`] formats and writes them on a thread of its own); the navigation rows
/// go to [`Sink::Nav`] on the writer thread.
trait Sink {
    /// What takes the navigation rows, on the writer thread.
    type Nav: NavSink;
    /// The smoother's storage.
    type Store: std::io::Read + std::io::Write + std::io::Seek + Send;
    /// The smoother, recording into this sink's storage.
    fn recorder<S: RunState>(&mut self) -> Result<Recorder<S, Self::Store>, RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>;
    /// The σ and IMU-error rows (and `nav.pos`) at `t`; `gnss_fix`: a GNSS update was used
    /// at `t`.
    fn epoch<S: RunState>(
        &mut self,
        t: f64,
        nav: &Navigator<RunStrategy, S>,
        gnss_fix: bool,
    ) -> Result<(), RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>;
    /// One update's row.
    fn update(&mut self, u: &UpdateSummary) -> Result<(), RunError>;
    /// The navigation rows' taker back from the writer thread, at the end of the pass.
    fn nav_done(&mut self, nav: Self::Nav);
    /// End of the forward pass.
    fn flush(&mut self) -> Result<(), RunError>;
    /// The backward pass; returns the number of smoothed rows.
    fn smoothed<S: RunState>(
        &mut self,
        recorder: Recorder<S, Self::Store>,
        nav: &Navigator<RunStrategy, S>,
    ) -> Result<usize, RunError>
    where
        estimator_core::Cov<S::Dim>: Send,
        DefaultAllocator: DimAlloc<S::Dim>;
}

/// Takes the navigation rows (time, state) on the writer thread.
trait NavSink: Send {
    /// A batch of rows, in time order.
    fn rows(&mut self, batch: &[(f64, InsState)]) -> Result<(), RunError>;
    /// After the last batch.
    fn finish(&mut self) -> Result<(), RunError>;
}

/// The output files of the forward pass other than `nav.txt` ([`NavFile`]): `std.txt`,
/// `imu_errors.txt`, `nav.pos` and `updates.csv`. The filter thread only copies each row's
/// numbers ([`Row`]); a thread of their own formats and writes them ([`EpochFiles`]). With
/// an update at every car-aiding epoch (10 Hz) that text was an eighth of the filter
/// thread's time.
struct Outputs {
    dir: PathBuf,
    /// Rows not sent yet.
    rows: Vec<Row>,
    /// To the files' thread (`None` once it has been told to finish).
    tx: Option<std::sync::mpsc::SyncSender<Vec<Row>>>,
    thread: Option<std::thread::JoinHandle<Result<(), RunError>>>,
}

/// Rows the filter thread hands to the files' thread at a time.
const ROWS_BATCH: usize = 256;

/// One row's numbers, formatted on the files' thread.
#[allow(clippy::large_enum_variant)] // (most rows are epochs: boxing them would allocate each)
enum Row {
    /// `std.txt`, `nav.pos` and `imu_errors.txt` at an epoch.
    Epoch(EpochRow),
    /// `updates.csv`.
    Update(UpdateSummary),
}

/// What [`EpochFiles::write_epoch`] writes at an epoch.
struct EpochRow {
    t: f64,
    /// A GNSS update was used at `t`.
    gnss_fix: bool,
    /// The error states' 1σ, `sigma[..n]`.
    sigma: [f64; 21],
    n: usize,
    x: InsState,
    pos_cov: nalgebra::Matrix3<f64>,
    vel_cov: nalgebra::Matrix3<f64>,
    scale: Option<(Vector3<f64>, Vector3<f64>)>,
}

/// The files of [`Outputs`], on their own thread.
struct EpochFiles {
    dir: PathBuf,
    std: std::io::BufWriter<std::fs::File>,
    imu_err: std::io::BufWriter<std::fs::File>,
    updates: std::io::BufWriter<std::fs::File>,
    pos: std::io::BufWriter<std::fs::File>,
    /// Time of the last `nav.pos` epoch (the end of a run can repeat it).
    pos_last_t: Option<f64>,
    /// A row's text before it is written (reused).
    line: Vec<u8>,
}

/// A write to the output `name` in `dir` (its `.partial` file) failed.
fn partial_error(dir: &Path, name: &str, e: std::io::Error) -> RunError {
    RunError::Output { path: partial_path(&dir.join(name)), message: e.to_string() }
}

/// `nav.txt`, written on the writer thread.
struct NavFile {
    w: std::io::BufWriter<std::fs::File>,
    path: PathBuf,
    /// A batch's text (reused).
    text: Vec<u8>,
}

impl NavSink for NavFile {
    fn rows(&mut self, batch: &[(f64, InsState)]) -> Result<(), RunError> {
        // the batch's text in one buffer, one write
        self.text.clear();
        for (t, x) in batch {
            push_nav(&mut self.text, &nav_record(*t, x));
        }
        let written = self.w.write_all(&self.text);
        written.map_err(|e| self.err(e))
    }

    fn finish(&mut self) -> Result<(), RunError> {
        self.w.flush().map_err(|e| self.err(e))
    }
}

impl NavFile {
    fn err(&self, e: std::io::Error) -> RunError {
        RunError::Output { path: self.path.clone(), message: e.to_string() }
    }
}

impl Outputs {
    /// Create the output directory and files and start the files' thread; returns the
    /// outputs and `nav.txt`.
    fn create(dir: &Path) -> Result<(Self, NavFile), RunError> {
        let out =
            |path: PathBuf, e: std::io::Error| RunError::Output { path, message: e.to_string() };
        std::fs::create_dir_all(dir).map_err(|e| out(dir.to_path_buf(), e))?;
        // Every output is written as `NAME.partial` and renamed into place when the run
        // completes ([`Outputs::publish`]): a failed run never touches earlier results.
        let open = |name: &str| {
            let p = dir.join(name);
            create_partial(&p).map_err(|e| out(partial_path(&p), e))
        };
        let nav = NavFile {
            w: open("nav.txt")?,
            path: partial_path(&dir.join("nav.txt")),
            text: Vec::new(),
        };
        let mut files = EpochFiles {
            dir: dir.to_path_buf(),
            std: open("std.txt")?,
            imu_err: open("imu_errors.txt")?,
            updates: open("updates.csv")?,
            pos: open("nav.pos")?,
            pos_last_t: None,
            line: Vec::with_capacity(256),
        };
        ins_gnss_core::io::rtklib::write_header(
            &mut files.pos,
            concat!("ins-gnss ", env!("CARGO_PKG_VERSION")),
            true,
        )
        .map_err(|e| out(dir.join("nav.pos"), e))?;
        writeln!(
            files.updates,
            "time,stream,dim,nis,nis_adapted,decision,reason,dom,lambda_p,lambda_r,scaling_fallback"
        )
        .map_err(|e| out(dir.join("updates.csv"), e))?;
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<Row>>(4);
        let thread = std::thread::spawn(move || -> Result<(), RunError> {
            for batch in rx {
                for row in &batch {
                    files.write(row)?;
                }
            }
            files.flush()
        });
        let outputs = Outputs {
            dir: dir.to_path_buf(),
            rows: Vec::with_capacity(ROWS_BATCH),
            tx: Some(tx),
            thread: Some(thread),
        };
        Ok((outputs, nav))
    }

    /// Queue a row; a full batch goes to the files' thread. A failed write there stops
    /// the thread, and its error comes back here.
    fn push(&mut self, row: Row) -> Result<(), RunError> {
        self.rows.push(row);
        if self.rows.len() < ROWS_BATCH {
            return Ok(());
        }
        let batch = std::mem::replace(&mut self.rows, Vec::with_capacity(ROWS_BATCH));
        if self.tx.as_ref().is_some_and(|tx| tx.send(batch).is_ok()) {
            return Ok(());
        }
        // the thread stopped on a failed write (its error), or was told to finish before
        // this row (never silently dropped)
        self.finish()?;
        Err(RunError::Output {
            path: self.dir.clone(),
            message: "a row came after the output files were closed".into(),
        })
    }

    /// Send the rows left, let the files' thread finish and flush, and return its error,
    /// if any.
    fn finish(&mut self) -> Result<(), RunError> {
        if let Some(tx) = self.tx.take() {
            // (a thread that stopped early has its error: a failed send is that case)
            let _ = tx.send(std::mem::take(&mut self.rows));
        }
        match self.thread.take() {
            Some(thread) => thread.join().map_err(|_| RunError::Output {
                path: self.dir.clone(),
                message: "the output files' thread panicked".into(),
            })?,
            None => Ok(()),
        }
    }

    /// The names of the outputs.
    const NAMES: [&'static str; 5] =
        ["nav.txt", "std.txt", "imu_errors.txt", "updates.csv", "nav.pos"];

    /// The outputs of the smoother.
    const SMOOTHED: [&'static str; 3] =
        ["nav_smoothed.txt", "std_smoothed.txt", "nav_smoothed.pos"];

    /// Rename every finished `NAME.partial` over `NAME`. A run that did not smooth removes
    /// the smoothed files of an earlier run, which would not match its `nav.txt`.
    fn publish(dir: &Path, smoothed: bool) -> Result<(), RunError> {
        let names = Self::NAMES.iter().chain(Self::SMOOTHED.iter().filter(|_| smoothed));
        for name in names {
            let p = dir.join(name);
            publish(&p).map_err(|e| RunError::Output { path: p, message: e.to_string() })?;
        }
        if !smoothed {
            for name in Self::SMOOTHED {
                let p = dir.join(name);
                if p.exists() {
                    std::fs::remove_file(&p)
                        .map_err(|e| RunError::Output { path: p, message: e.to_string() })?;
                }
            }
        }
        Ok(())
    }
}

impl Drop for Outputs {
    /// A run that failed: what was queued is still written (the `.partial` files keep the
    /// rows up to the failure), and the thread is waited for.
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

impl EpochFiles {
    fn write(&mut self, row: &Row) -> Result<(), RunError> {
        match row {
            Row::Epoch(e) => self.write_epoch(e),
            Row::Update(u) => self.write_update(u),
        }
    }

    fn err(&self, name: &str, e: std::io::Error) -> RunError {
        partial_error(&self.dir, name, e)
    }

    /// `std.txt`, `imu_errors.txt` and `nav.pos` at `t`.
    fn write_epoch(&mut self, e: &EpochRow) -> Result<(), RunError> {
        let (row, n) = sigma_row(e.t, &e.sigma[..e.n]);
        self.line.clear();
        push_row(&mut self.line, &row[..n]);
        self.std.write_all(&self.line).map_err(|err| self.err("std.txt", err))?;
        // nav.pos: the position and velocity with their NED covariance blocks (error
        // states 6–8 and 3–5); Q 1 after a GNSS update, 5 (no GNSS) otherwise
        if self.pos_last_t == Some(e.t) {
            return Ok(());
        }
        self.pos_last_t = Some(e.t);
        let q = if e.gnss_fix { 1 } else { 5 };
        // (these files were written by `format!`; `push_epoch` and `push_exact_row` write
        // the same bytes, faster)
        self.line.clear();
        let vel = Some((&e.x.vel, &e.vel_cov));
        ins_gnss_core::io::rtklib::push_epoch(
            &mut self.line,
            0.0,
            e.t,
            &e.x.pos,
            &e.pos_cov,
            vel,
            q,
        );
        self.pos.write_all(&self.line).map_err(|err| self.err("nav.pos", err))?;
        let (row, n) = imu_error_row(e.t, &e.x, e.scale);
        self.line.clear();
        push_exact_row(&mut self.line, &row[..n]);
        self.imu_err.write_all(&self.line).map_err(|err| self.err("imu_errors.txt", err))
    }

    fn write_update(&mut self, u: &UpdateSummary) -> Result<(), RunError> {
        let l = &mut self.line;
        l.clear();
        push_exact(l, u.time, 0, 6);
        let _ = write!(l, ",{},{},", u.stream.name(), u.dim);
        push_exact(l, u.nis, 0, 6);
        l.push(b',');
        push_exact(l, u.nis_adapted, 0, 6);
        let _ = write!(l, ",{},\"{}\",", u.verdict.as_str(), u.reason);
        for v in [u.factors.dom, u.factors.lambda_p, u.factors.lambda_r] {
            push_exact(l, v, 0, 6);
            l.push(b',');
        }
        let _ = writeln!(l, "{}", u8::from(u.prior_scaling_fallback));
        self.updates.write_all(&self.line).map_err(|e| self.err("updates.csv", e))
    }

    fn flush(&mut self) -> Result<(), RunError> {
        for (w, name) in [
            (&mut self.pos, "nav.pos"),
            (&mut self.std, "std.txt"),
            (&mut self.imu_err, "imu_errors.txt"),
            (&mut self.updates, "updates.csv"),
        ] {
            w.flush().map_err(|e| partial_error(&self.dir, name, e))?;
        }
        Ok(())
    }
}

impl Sink for Outputs {
    type Nav = NavFile;
    type Store = std::fs::File;

    fn recorder<S: RunState>(&mut self) -> Result<Recorder<S, Self::Store>, RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        let path = self.dir.join(SMOOTHER_STATES);
        Recorder::<S, _>::on_file(&path, SMOOTHER_SEGMENT)
            .map_err(|e| RunError::Output { path, message: e.to_string() })
    }

    fn epoch<S: RunState>(
        &mut self,
        t: f64,
        nav: &Navigator<RunStrategy, S>,
        gnss_fix: bool,
    ) -> Result<(), RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        let s = nav.sigma();
        let mut sigma = [0.0; 21];
        let n = S::SIGMA_COLUMNS;
        sigma[..n].copy_from_slice(&s.as_slice()[..n]);
        let p = nav.covariance();
        let block = |i: usize| nalgebra::Matrix3::from_fn(|r, c| p[(i + r, i + c)]);
        self.push(Row::Epoch(EpochRow {
            t,
            gnss_fix,
            sigma,
            n,
            x: nav.nav_state().clone(),
            pos_cov: block(6),
            vel_cov: block(3),
            scale: nav.state().scale_factors(),
        }))
    }

    fn update(&mut self, u: &UpdateSummary) -> Result<(), RunError> {
        self.push(Row::Update(*u))
    }

    fn nav_done(&mut self, _nav: NavFile) {}

    fn flush(&mut self) -> Result<(), RunError> {
        self.finish()
    }

    fn smoothed<S: RunState>(
        &mut self,
        recorder: Recorder<S, Self::Store>,
        nav: &Navigator<RunStrategy, S>,
    ) -> Result<usize, RunError>
    where
        estimator_core::Cov<S::Dim>: Send,
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        write_smoothed(recorder, nav, &self.dir)
    }
}

/// A run's results in memory ([`run_in_memory`]): the rows of the output files, as
/// numbers in the files' units, without `nav.pos`.
#[derive(Clone, Debug, Default)]
pub struct Results {
    /// `nav.txt` without the week: `t`, latitude and longitude (deg), height (m), velocity
    /// N E D (m/s), roll, pitch, yaw (deg), at every IMU epoch.
    pub nav: Vec<[f64; 10]>,
    /// `std.txt`, row-major, [`std_width`](Self::std_width) numbers per row.
    pub std: Vec<f64>,
    /// Numbers per row of [`std`](Self::std) and [`smoothed_std`](Self::smoothed_std):
    /// 16 with 15 states, 22 with 21.
    pub std_width: usize,
    /// `imu_errors.txt`, row-major, [`imu_errors_width`](Self::imu_errors_width) per row.
    pub imu_errors: Vec<f64>,
    /// Numbers per row of [`imu_errors`](Self::imu_errors): 7, or 13 with 21 states.
    pub imu_errors_width: usize,
    /// Every update (`updates.csv`).
    pub updates: Vec<UpdateSummary>,
    /// `nav_smoothed.txt` in the layout of [`nav`](Self::nav), when the run smoothed.
    pub smoothed_nav: Vec<[f64; 10]>,
    /// `std_smoothed.txt` in the layout of [`std`](Self::std), when the run smoothed.
    pub smoothed_std: Vec<f64>,
}

/// The navigation rows in memory, on the writer thread.
#[derive(Default)]
struct NavRows(Vec<[f64; 10]>);

impl NavSink for NavRows {
    fn rows(&mut self, batch: &[(f64, InsState)]) -> Result<(), RunError> {
        self.0.extend(batch.iter().map(|(t, x)| nav_values(*t, x)));
        Ok(())
    }

    fn finish(&mut self) -> Result<(), RunError> {
        Ok(())
    }
}

/// `nav.txt`'s numbers without the week.
fn nav_values(t: f64, x: &InsState) -> [f64; 10] {
    let v = nav_record(t, x).values();
    core::array::from_fn(|i| v[i + 1])
}

impl Sink for Results {
    type Nav = NavRows;
    type Store = std::io::Cursor<Vec<u8>>;

    fn recorder<S: RunState>(&mut self) -> Result<Recorder<S, Self::Store>, RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        Ok(Recorder::<S, _>::new(Default::default(), SMOOTHER_SEGMENT))
    }

    fn epoch<S: RunState>(
        &mut self,
        t: f64,
        nav: &Navigator<RunStrategy, S>,
        _gnss_fix: bool,
    ) -> Result<(), RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        let (row, n) = sigma_row(t, &nav.sigma().as_slice()[..S::SIGMA_COLUMNS]);
        self.std.extend(row[..n].iter().map(|r| r.0));
        self.std_width = n;
        // (like `imu_errors.txt`: not twice at the same time, which the run's end can
        // repeat)
        let w = self.imu_errors_width;
        if w > 0 && self.imu_errors.len() >= w && self.imu_errors[self.imu_errors.len() - w] == t {
            return Ok(());
        }
        let (row, n) = imu_error_row(t, nav.nav_state(), nav.state().scale_factors());
        self.imu_errors.extend(row[..n].iter().map(|r| r.0));
        self.imu_errors_width = n;
        Ok(())
    }

    fn update(&mut self, u: &UpdateSummary) -> Result<(), RunError> {
        self.updates.push(*u);
        Ok(())
    }

    fn nav_done(&mut self, nav: NavRows) {
        self.nav = nav.0;
    }

    fn flush(&mut self) -> Result<(), RunError> {
        Ok(())
    }

    fn smoothed<S: RunState>(
        &mut self,
        recorder: Recorder<S, Self::Store>,
        nav: &Navigator<RunStrategy, S>,
    ) -> Result<usize, RunError>
    where
        estimator_core::Cov<S::Dim>: Send,
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        let n = S::SIGMA_COLUMNS;
        // segments arrive last to first, each in time order
        let mut segments: Vec<(Vec<[f64; 10]>, Vec<f64>)> = Vec::new();
        recorder
            .smooth_threaded(nav.filter(), nav.model(), |rows: &[SmoothedRow<S>]| {
                let mut navs = Vec::with_capacity(rows.len());
                let mut stds = Vec::with_capacity(rows.len() * (n + 1));
                for r in rows {
                    let (t, x, sigma) = smoothed_row(r);
                    navs.push(nav_values(t, &x));
                    if let Some(sigma) = sigma {
                        let (row, len) = sigma_row(t, &sigma[..n]);
                        stds.extend(row[..len].iter().map(|v| v.0));
                    }
                }
                segments.push((navs, stds));
                Ok(())
            })
            .map_err(|e| RunError::Output {
                path: PathBuf::from("(the smoother's memory)"),
                message: e.to_string(),
            })?;
        for (navs, stds) in segments.into_iter().rev() {
            self.smoothed_nav.extend(navs);
            self.smoothed_std.extend(stds);
        }
        Ok(self.smoothed_nav.len())
    }
}

/// A smoothed row: time, navigation state, and the σ of the error states (as many as the
/// state has).
fn smoothed_row<S: RunState>(r: &SmoothedRow<S>) -> (f64, InsState, Option<[f64; 21]>)
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let sigma = r.var.as_ref().map(|var| {
        let mut sigma = [0.0; 21];
        for (s, v) in sigma.iter_mut().zip(var.iter()) {
            *s = v.max(0.0).sqrt();
        }
        sigma
    });
    (r.time, r.x.nav().clone(), sigma)
}

/// The navigation record of a state.
pub fn nav_record(t: f64, x: &ins_gnss_core::state::InsState) -> NavRecord {
    let (r, p, y) = x.euler();
    NavRecord { week: 0.0, t, pos: x.pos, vel: x.vel, att: Vector3::new(r, p, y) }
}

/// One row of `std.txt` (its values and decimals) and its length: `t`, then the 1σ of
/// the error states `s` in the file's units (position, velocity, attitude in degrees,
/// biases in deg/h and mGal, scale factors in ppm).
fn sigma_row(t: f64, s: &[f64]) -> ([(f64, usize); 22], usize) {
    let d = 180.0 / core::f64::consts::PI;
    let mut row: [(f64, usize); 22] = [(0.0, 0); 22];
    row[0] = (t, 6);
    let order = [6, 7, 8, 3, 4, 5, 0, 1, 2, 9, 10, 11, 12, 13, 14];
    for (k, &i) in order.iter().enumerate() {
        row[1 + k] = match i {
            0..=2 => (s[i] * d, 8),
            9..=11 => (s[i] / DEG_PER_H, 6),
            12..=14 => (s[i] / MGAL, 6),
            _ => (s[i], 6),
        };
    }
    // 21 states: the scale factors' σ, ppm (KF-GINS's columns)
    let n = s.len().min(21);
    for i in 15..n {
        row[1 + i] = (s[i] * 1e6, 3);
    }
    (row, 1 + n)
}

/// One row of `imu_errors.txt` (its values and decimals) and its length: `t`, gyro bias
/// (deg/h), accelerometer bias (mGal), and with 21 states the scale factors (ppm).
fn imu_error_row(
    t: f64,
    x: &InsState,
    scale: Option<(Vector3<f64>, Vector3<f64>)>,
) -> ([(f64, usize); 13], usize) {
    let mut row = [(0.0, 3); 13];
    row[0] = (t, 6);
    for i in 0..3 {
        row[1 + i] = (x.bg[i] / DEG_PER_H, 6);
        row[4 + i] = (x.ba[i] / MGAL, 6);
    }
    let Some((sg, sa)) = scale else { return (row, 7) };
    for (i, v) in sg.iter().chain(sa.iter()).enumerate() {
        row[7 + i] = (v * 1e6, 3);
    }
    (row, 13)
}

type FileReader = ins_gnss_core::io::formats::Input;

/// The configured IMU and GNSS readers (format, rate, gap limit, skip policy) on the
/// files or arrays of `inputs`.
fn open_inputs(
    config: &Config,
    inputs: &Inputs,
) -> Result<(ImuReader<FileReader>, AidReader), RunError> {
    let (format, rate, gap, policy) =
        (config.imu_format(), config.data.imu_rate, config.data.max_gap, config.bad_lines());
    let mut imu = match inputs {
        Inputs::Files => {
            config.require_inputs().map_err(RunError::Config)?;
            ImuReader::open(&config.data.imu, format, rate, gap, policy)?
        }
        Inputs::Arrays { imu, imu_width, .. } => {
            let name = Path::new(IMU_ARRAY);
            ImuReader::from_rows(imu.clone(), *imu_width, name, format, rate, gap, policy)
        }
    }
    .with_max_bridge(config.data.max_bridge)
    .with_time_offset(config.data.imu_time_offset);
    if let Some(c) = &config.data.imu_columns {
        array_refuses(inputs, "data.imu_columns")?;
        let rates = config.imu_format() == ins_gnss_core::io::ImuFormat::Rates;
        imu = imu.with_columns(c.map(rates).map_err(|e| bad_map("data.imu_columns", e))?);
    }
    if let Some(m) = &config.imu.mounting {
        imu = imu.with_mounting(m.matrix().map_err(|e| bad_map("imu.mounting", e))?);
    }
    Ok((imu, open_aid(config, inputs)?))
}

/// The configured GNSS input: fixes, or raw observations (tight coupling, files only).
fn open_aid(config: &Config, inputs: &Inputs) -> Result<AidReader, RunError> {
    if config.gnss.coupling == crate::config::Coupling::Tight {
        if let Inputs::Arrays { .. } = inputs {
            return Err(bad_map(
                "gnss.coupling",
                "tight coupling reads raw observations from `data.gnss` and `data.nav` files; \
                 arrays hold fixes (loose coupling)"
                    .into(),
            ));
        }
    }
    AidReader::open(config, || open_gnss(config, inputs))
}

/// A column map with arrays: it names a file's columns and units, which an array does
/// not have (its columns are in the file format's order and units), so it is refused
/// rather than ignored.
fn array_refuses(inputs: &Inputs, key: &str) -> Result<(), RunError> {
    match inputs {
        Inputs::Files => Ok(()),
        Inputs::Arrays { .. } => Err(bad_map(
            key,
            "a column map applies to a file's header; arrays are read in the file format's \
             column order and units (convert the columns before the call, and remove the map)"
                .into(),
        )),
    }
}

/// A column map or mounting the reader cannot take (they were checked when the
/// configuration was loaded).
fn bad_map(key: &str, message: String) -> RunError {
    RunError::Config(crate::config::ConfigError { path: PathBuf::from(key), message })
}

/// The configured GNSS file, or array, open.
fn open_gnss(config: &Config, inputs: &Inputs) -> Result<GnssReader<FileReader>, RunError> {
    let policy = config.bad_lines();
    let gnss = match inputs {
        Inputs::Files => {
            GnssReader::open(&config.data.gnss, policy)?.with_format(config.data.gnss_format.into())
        }
        Inputs::Arrays { gnss, gnss_width, .. } => {
            GnssReader::from_rows(gnss.clone(), *gnss_width, Path::new(GNSS_ARRAY), policy)
        }
    };
    let mut gnss = gnss
        .with_quality(config.gnss.quality.factors().map_err(|e| bad_map("gnss.quality", e))?)
        .with_default_sigma(config.gnss.position_std.map(|s| s.into()));
    if let Some(c) = &config.data.gnss_columns {
        array_refuses(inputs, "data.gnss_columns")?;
        gnss = gnss.with_columns(c.map().map_err(|e| bad_map("data.gnss_columns", e))?);
    }
    Ok(gnss)
}

/// The states a run can use (`filter.states = 15 | 21`): how each starts and what it
/// writes beyond the 15-state columns.
pub trait RunState: NavState<Model: Sync> + estimator_core::Spill + Send + 'static
where
    DefaultAllocator: DimAlloc<Self::Dim>,
{
    /// The error states written to `std.txt` (the first ones).
    const SIGMA_COLUMNS: usize;

    /// The navigator at `start`; `clock`: the receiver clock `c·dt` (m) of the first
    /// raw epoch's single point (tight coupling).
    fn navigator(
        config: &Config,
        strategy: RunStrategy,
        start: f64,
        clock: Option<f64>,
    ) -> Result<Navigator<RunStrategy, Self>, NavError>;

    /// The scale factors (gyro, accelerometer), when the state has them.
    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)>;

    /// One IMU sample with the GNSS of its interval: the fixes (loose coupling) or the raw
    /// epochs with their models (tight).
    #[allow(clippy::too_many_arguments)]
    fn process<R: estimator_core::StepRecorder<Self, ImuInput>>(
        nav: &mut Navigator<RunStrategy, Self>,
        imu: &ImuSample,
        fixes: &[GnssEpoch],
        raw: &[RawEpoch],
        tight: Option<&TightConfig>,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        let _ = (raw, tight);
        nav.process_recorded(imu, fixes, &mut NoObserver, out, recorder)
    }

    /// Whether an update of `stream` is a GNSS fix's (`nav.pos` marks the epoch).
    fn is_fix(stream: estimator_core::StreamId) -> bool {
        ins_gnss_core::gnss::GNSS_STREAMS.contains(&stream)
    }
}

impl RunState for InsState {
    const SIGMA_COLUMNS: usize = 15;

    fn navigator(
        config: &Config,
        strategy: RunStrategy,
        start: f64,
        _clock: Option<f64>,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let model = InsModel { mechanization: config.mechanization(), noise: config.imu_noise() };
        Navigator::new(&config.initial_state(start), model, strategy, config.gnss_config())
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        None
    }
}

impl RunState for InsState21 {
    const SIGMA_COLUMNS: usize = 21;

    fn navigator(
        config: &Config,
        strategy: RunStrategy,
        start: f64,
        _clock: Option<f64>,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let base = InsModel { mechanization: config.mechanization(), noise: config.imu_noise() };
        let model = InsModel21 { base, scale: config.scale_factor_noise() };
        let init = config.initial_state(start);
        Navigator::new21(&init, &config.scale_init(), model, strategy, config.gnss_config())
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        Some((self.sg, self.sa))
    }
}

/// Tight coupling: the 15 states, the receiver clock and the inter-system biases.
impl RunState for InsStateTc {
    const SIGMA_COLUMNS: usize = 15;

    fn navigator(
        config: &Config,
        strategy: RunStrategy,
        start: f64,
        clock: Option<f64>,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let base = InsModel { mechanization: config.mechanization(), noise: config.imu_noise() };
        let noise = ClockNoise { drift: config.gnss.tight.clock_drift_noise, ..Default::default() };
        let model = InsModelTc { base, clock: noise };
        // the single point's clock (its σ a few metres; the drift from the Dopplers that
        // follow), or, none found before the start, 1 ms
        let clock = match clock {
            Some(b) => ClockInit { clock: (b, 0.0), std: (30.0, 100.0), isb_std: 30.0 },
            None => ClockInit { clock: (0.0, 0.0), std: (3.0e5, 100.0), isb_std: 30.0 },
        };
        let init = config.initial_state(start);
        Navigator::new_tight(&init, &clock, model, strategy, config.gnss_config())
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        None
    }

    fn process<R: estimator_core::StepRecorder<Self, ImuInput>>(
        nav: &mut Navigator<RunStrategy, Self>,
        imu: &ImuSample,
        _fixes: &[GnssEpoch],
        raw: &[RawEpoch],
        tight: Option<&TightConfig>,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        match tight {
            Some(cfg) => nav.process_raw_recorded(imu, raw, cfg, &mut NoObserver, out, recorder),
            // (a tight run always has its models: no satellite without them)
            None => nav.process_recorded(imu, &[], &mut NoObserver, out, recorder),
        }
    }

    fn is_fix(stream: estimator_core::StreamId) -> bool {
        !VEHICLE_STREAMS.contains(&stream)
    }
}

/// The navigator at the start time (the configured one, or the first IMU sample's
/// `first_t`), the run's summary with its span started there, and the end time.
fn start_navigator<S: RunState>(
    config: &Config,
    strategy: AnyStrategy,
    first_t: f64,
    clock: Option<f64>,
) -> Result<(Navigator<RunStrategy, S>, RunSummary, f64), RunError>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let start = config.data.start_time.unwrap_or(first_t);
    let end = config.data.end_time.unwrap_or(f64::INFINITY);
    // the name of the strategy the user chose (the vehicle streams' fixed noise aside)
    let name = if config.filter.streams.is_empty() { strategy.name() } else { "per-stream" };
    let strategy = config.strategy(strategy).map_err(RunError::Config)?;
    let nav =
        S::navigator(config, strategy, start, clock)?.with_vehicle_aiding(config.vehicle_aiding());
    let summary = RunSummary {
        strategy: name.to_string(),
        span: (start, start),
        noise: config.noise_echo(),
        ..Default::default()
    };
    Ok((nav, summary, end))
}

/// The strategy of a run: the configured strategies per stream behind the gross-error
/// gate ([`Config::strategy`]).
pub type RunStrategy = GrossErrorGate<PerStream<AnyStrategy>>;

/// The smoother's scratch file in the output directory (removed when the run ends).
const SMOOTHER_STATES: &str = "smoother-segments.tmp";

/// Predictions per smoother segment at most (the backward pass holds one segment: three
/// `N × N` matrices per prediction, 0.7 MB with 15 states).
const SMOOTHER_SEGMENT: usize = 128;

/// The recorder of a run that smooths: the segment smoother on a scratch file.
type Recorder<S, T = std::fs::File> = estimator_core::SegmentSmoother<S, ImuInput, T>;

/// The backward pass: `nav_smoothed.txt`, `std_smoothed.txt` and `nav_smoothed.pos` (as
/// `.partial`, in the formats of `nav.txt`, `std.txt` and `nav.pos`: the first at every
/// IMU epoch, the others at the epochs of `std.txt`). The smoother hands the segments
/// last to first: each batch's text is appended to its file with its bytes reversed, so
/// each file ends up as its final text backwards, which is then turned around in place
/// ([`reverse_file`]): no scratch file, the disk never holds more than the outputs.
/// Returns the number of rows.
fn write_smoothed<S: RunState>(
    recorder: Recorder<S>,
    nav: &Navigator<RunStrategy, S>,
    dir: &Path,
) -> Result<usize, RunError>
where
    estimator_core::Cov<S::Dim>: Send,
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let names = Outputs::SMOOTHED.map(|name| partial_path(&dir.join(name)));
    let result = write_smoothed_into(recorder, nav, &names);
    if result.is_err() {
        // half-written, backwards: of no use to anyone
        for path in &names {
            let _ = std::fs::remove_file(path);
        }
    }
    result
}

fn write_smoothed_into<S: RunState>(
    recorder: Recorder<S>,
    nav: &Navigator<RunStrategy, S>,
    names: &[PathBuf; 3],
) -> Result<usize, RunError>
where
    estimator_core::Cov<S::Dim>: Send,
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |e: std::io::Error| RunError::Output { path: path.clone(), message: e.to_string() }
    };
    let open = |path: &PathBuf| {
        std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)
            .map_err(io(path))
    };
    let files = [open(&names[0])?, open(&names[1])?, open(&names[2])?];
    // The rows are formatted and written by a second thread while the backward pass runs.
    // (time, state, σ of the error states, as many as the state has, where asked)
    type Row = (f64, InsState, Option<[f64; 21]>);
    let n = S::SIGMA_COLUMNS;
    let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<Row>>(8);
    let writer = std::thread::spawn(move || -> Result<_, (usize, std::io::Error)> {
        let mut out = files.map(|f| std::io::BufWriter::with_capacity(1 << 16, f));
        let mut count = 0usize;
        let mut text: [Vec<u8>; 3] = Default::default();
        let var = |s: &[f64]| -> nalgebra::Matrix3<f64> {
            let z = 0.0;
            nalgebra::Matrix3::new(s[0] * s[0], z, z, z, s[1] * s[1], z, z, z, s[2] * s[2])
        };
        for rows in rx {
            let [nav_text, std_text, pos_text] = &mut text;
            nav_text.clear();
            std_text.clear();
            pos_text.clear();
            for (t, x, sigma) in &rows {
                push_nav(nav_text, &nav_record(*t, x));
                let Some(sigma) = sigma else { continue };
                let (row, len) = sigma_row(*t, &sigma[..n]);
                push_row(std_text, &row[..len]);
                // the smoother keeps the variances only: the .pos covariances are written as 0
                let vel_var = var(&sigma[3..6]);
                let vel = Some((&x.vel, &vel_var));
                let pos_var = var(&sigma[6..9]);
                ins_gnss_core::io::rtklib::push_epoch(pos_text, 0.0, *t, &x.pos, &pos_var, vel, 1);
            }
            for (i, (w, t)) in out.iter_mut().zip(text.iter_mut()).enumerate() {
                t.reverse();
                w.write_all(t).map_err(|e| (i, e))?;
            }
            count += rows.len();
        }
        // the .pos header goes first: last, backwards
        let mut header = Vec::new();
        let program = concat!("ins-gnss ", env!("CARGO_PKG_VERSION"), ", smoothed");
        ins_gnss_core::io::rtklib::write_header(&mut header, program, true).map_err(|e| (2, e))?;
        header.reverse();
        out[2].write_all(&header).map_err(|e| (2, e))?;
        let mut files = Vec::new();
        for (i, w) in out.into_iter().enumerate() {
            files.push(w.into_inner().map_err(|e| (i, e.into_error()))?);
        }
        Ok((files, count))
    });
    // segments arrive last to first: their rows are gathered backwards, and a batch of
    // them is turned around and sent as one chunk, in time order
    const BATCH_ROWS: usize = 4096;
    let mut pending: Vec<Row> = Vec::with_capacity(BATCH_ROWS + SMOOTHER_SEGMENT);
    let send = |pending: &mut Vec<Row>| {
        pending.reverse();
        let rows = core::mem::replace(pending, Vec::with_capacity(BATCH_ROWS + SMOOTHER_SEGMENT));
        tx.send(rows).map_err(|_| std::io::Error::other("the row writer stopped"))
    };
    let smoothed =
        recorder.smooth_threaded(nav.filter(), nav.model(), |rows: &[SmoothedRow<S>]| {
            pending.extend(rows.iter().rev().map(smoothed_row));
            if pending.len() >= BATCH_ROWS {
                send(&mut pending)?;
            }
            Ok(())
        });
    let smoothed = smoothed.and_then(|()| send(&mut pending).map_err(Into::into));
    drop(tx);
    let written = writer
        .join()
        .map_err(|_| RunError::NoData("the smoother's writer thread panicked".into()))?;
    let dir = names[0].parent().unwrap_or(Path::new("."));
    // a failed write stops the writer and then the backward pass ("the row writer
    // stopped"): the write's error is the cause, and is reported first
    let (files, count) = written.map_err(|(i, e)| io(&names[i])(e))?;
    smoothed.map_err(|e| RunError::Output {
        path: dir.join(SMOOTHER_STATES),
        message: e.to_string(),
    })?;
    // the three files turned around side by side (a day at 100 Hz is 2.5 GB of text)
    let flipped: Vec<std::io::Result<()>> = std::thread::scope(|scope| {
        let handles: Vec<_> =
            files.into_iter().map(|mut f| scope.spawn(move || reverse_file(&mut f))).collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    });
    for (i, result) in flipped.into_iter().enumerate() {
        result.map_err(io(&names[i]))?;
    }
    Ok(count)
}

/// Reverse the bytes of `file` in place: blocks from both ends swapped and reversed,
/// moving inwards (one read and one write of every byte, 3 MB of memory).
fn reverse_file(file: &mut std::fs::File) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    const BLOCK: u64 = 1 << 20;
    let (mut lo, mut hi) = (0u64, file.seek(SeekFrom::End(0))?);
    // (`a` holds the middle too, up to two blocks)
    let (mut a, mut b) = (vec![0u8; 2 * BLOCK as usize], vec![0u8; BLOCK as usize]);
    let at = |file: &mut std::fs::File, pos: u64, buf: &mut [u8], write: bool| {
        file.seek(SeekFrom::Start(pos))?;
        if write {
            file.write_all(buf)
        } else {
            file.read_exact(buf)
        }
    };
    while hi - lo >= 2 * BLOCK {
        let a = &mut a[..BLOCK as usize];
        at(file, lo, a, false)?;
        at(file, hi - BLOCK, &mut b, false)?;
        a.reverse();
        b.reverse();
        at(file, lo, &mut b, true)?;
        at(file, hi - BLOCK, a, true)?;
        lo += BLOCK;
        hi -= BLOCK;
    }
    let mid = &mut a[..(hi - lo) as usize];
    at(file, lo, mid, false)?;
    mid.reverse();
    at(file, lo, mid, true)?;
    file.flush()
}

/// Longest time between two rows of `std.txt` and `imu_errors.txt`, s (they are written
/// after every update, and at this interval without one).
const STD_EVERY: f64 = 1.0;

/// Samples or records per message between the pipeline's threads.
const BATCH: usize = 1024;

/// Run `config` with `strategy`, writing into `out_dir`. `progress` (if any) is called
/// with the current time every 2,000 IMU epochs.
///
/// The run is a pipeline over bounded channels: a reader thread parses the IMU file, this
/// thread runs the filter, a writer thread formats and writes `nav.txt`, and another the
/// σ, IMU-error, `nav.pos` and update rows. Memory is bounded by the channels (a few
/// batches of 1,024 samples and 256 rows), whatever the length of the dataset.
pub fn run(
    config: &Config,
    strategy: AnyStrategy,
    out_dir: &Path,
    progress: Option<Progress<'_>>,
) -> Result<RunSummary, RunError> {
    let result = run_with(config, strategy, &Inputs::Files, progress, || Outputs::create(out_dir));
    // once the outputs were created, the smoother's scratch file goes whatever happened
    if !matches!(result, Err((_, false))) {
        let _ = std::fs::remove_file(out_dir.join(SMOOTHER_STATES));
    }
    match result {
        Err((error, false)) => Err(error),
        Ok((mut summary, _)) => {
            Outputs::publish(out_dir, summary.smoothed.is_some())?;
            summary.out_dir = out_dir.to_path_buf();
            Ok(summary)
        }
        // refused by the checks, as before a start: nothing of this run is kept
        Err((error @ RunError::Start(_), true)) => {
            for name in Outputs::NAMES.iter().chain(&Outputs::SMOOTHED) {
                let _ = std::fs::remove_file(partial_path(&out_dir.join(name)));
            }
            Err(error)
        }
        Err((error, true)) => {
            Err(RunError::Incomplete { error: Box::new(error), dir: out_dir.to_path_buf() })
        }
    }
}

/// [`run`] without output files: the same run (the same start, checks, filter and
/// smoother, the same numbers) on the configured files or on arrays, its results kept in
/// memory. With `filter.smooth` the smoother's records are kept in memory too (they grow
/// with the run, as its scratch file does), so that nothing at all is written.
pub fn run_in_memory(
    config: &Config,
    strategy: AnyStrategy,
    inputs: &Inputs,
) -> Result<(RunSummary, Results), RunError> {
    run_with(config, strategy, inputs, None, || Ok((Results::default(), NavRows::default())))
        .map_err(|(error, _)| error)
}

/// [`run`]'s work on any inputs into any sink, created by `create` once the start is
/// known (a refused start creates nothing). An error says whether the sink was created.
fn run_with<O: Sink>(
    config: &Config,
    strategy: AnyStrategy,
    inputs: &Inputs,
    progress: Option<Progress<'_>>,
    create: impl FnOnce() -> Result<(O, O::Nav), RunError>,
) -> Result<(RunSummary, O), (RunError, bool)> {
    let (imu, mut gnss) = open_inputs(config, inputs).map_err(|e| (e, false))?;
    // With the whole initial state and noise given, the data's first seconds are only
    // checked (`start::prepare` changes nothing but the noise floor, which needs only the
    // static start): the checks run beside the filter on a copy of them, and a refusal
    // stops the run. Otherwise the filter waits for `prepare`.
    let look = if crate::start::fills(config) {
        Look::Span
    } else if crate::start::floors(config) {
        Look::StaticStart
    } else {
        Look::First
    };
    let beside = config.align.checks && look != Look::Span;
    let (mut feed, checks) = if beside {
        let (tee, prefix) = std::sync::mpsc::channel();
        let checks = Checks::spawn(config, inputs, prefix).map_err(|e| (e, false))?;
        (ImuFeed::spawn(imu, Some((tee, config.clone()))), Some(checks))
    } else {
        (ImuFeed::spawn(imu, None), None)
    };
    let ready = read_prefix(config, &mut feed, &mut gnss, look)
        .and_then(|prefix| Ok((prepare_start(config, &prefix, look)?, prefix)))
        .and_then(|(start, prefix)| Ok((start, prefix, create()?)));
    let (start, prefix, (mut out, nav)) = match ready {
        Ok(ready) => ready,
        Err(e) => {
            let _ = feed.finish();
            return Err((e, false));
        }
    };
    let config = &start.config;
    let names = (inputs.imu_name(config), inputs.gnss_name(config));
    let inputs = ((feed, gnss, prefix, checks), (&mut out, nav));
    let tight = config.gnss.coupling == crate::config::Coupling::Tight;
    let result = match config.filter.states {
        _ if tight => {
            run_into::<InsStateTc, O>(config, strategy, names, progress, inputs.0, inputs.1)
        }
        21 => run_into::<InsState21, O>(config, strategy, names, progress, inputs.0, inputs.1),
        _ => run_into::<InsState, O>(config, strategy, names, progress, inputs.0, inputs.1),
    };
    match result {
        Ok(mut summary) => {
            summary.start = start.report;
            Ok((summary, out))
        }
        Err(e) => Err((e, true)),
    }
}

/// Where a run's inputs come from.
#[derive(Clone, Debug, Default)]
pub enum Inputs {
    /// The configuration's `data.imu` and `data.gnss` files.
    #[default]
    Files,
    /// Arrays in memory, row-major, in the files' column order and units
    /// ([`ImuReader::from_rows`], [`GnssReader::from_rows`]); errors name them
    /// [`IMU_ARRAY`] and [`GNSS_ARRAY`], with the 1-based row as the line. The
    /// configuration's IMU format (increments or rates), rate, mounting and GNSS settings
    /// apply; its column maps, which name a file's header, are refused.
    Arrays {
        /// The IMU rows.
        imu: std::sync::Arc<[f64]>,
        /// Numbers per IMU row: 7, or 8 with the odometer speed.
        imu_width: usize,
        /// The GNSS rows.
        gnss: std::sync::Arc<[f64]>,
        /// Numbers per GNSS row: 7 (position), or 13 (with velocity).
        gnss_width: usize,
    },
}

/// The name of an IMU array in errors (the line is the 1-based row).
pub const IMU_ARRAY: &str = "imu array row";
/// The name of a GNSS array in errors (the line is the 1-based row).
pub const GNSS_ARRAY: &str = "gnss array row";

impl Inputs {
    fn imu_name(&self, config: &Config) -> PathBuf {
        match self {
            Inputs::Files => config.data.imu.clone(),
            Inputs::Arrays { .. } => PathBuf::from(IMU_ARRAY),
        }
    }

    fn gnss_name(&self, config: &Config) -> PathBuf {
        match self {
            Inputs::Files => config.data.gnss.clone(),
            Inputs::Arrays { .. } => PathBuf::from(GNSS_ARRAY),
        }
    }
}

/// Batches of parsed IMU samples (with their lines) from the reader thread.
type ImuBatch = Result<Vec<(ImuSample, usize)>, LineError>;

/// The IMU file parsed on a thread of its own, [`BATCH`] samples per message over a
/// bounded channel; a parse error ends the stream after the samples before it.
struct ImuFeed {
    batches: std::sync::mpsc::Receiver<ImuBatch>,
    reader: std::thread::JoinHandle<SkipCounts>,
}

impl ImuFeed {
    /// Start reading `imu`. With a `tee`, the samples up to the first after
    /// `align.max_time` from the start go to it too (for [`Checks`]).
    fn spawn(mut imu: ImuReader<FileReader>, tee: Option<(Tee, Config)>) -> Self {
        let (tx, batches) = std::sync::mpsc::sync_channel::<ImuBatch>(4);
        let reader = std::thread::spawn(move || {
            let mut batch = Vec::with_capacity(BATCH);
            // the checks' samples go in one message when their span ends (or the data
            // does): one wake-up of the checks' thread instead of one per sample
            let mut tee = tee.map(|(to, config)| (to, config, Vec::new()));
            let mut t_end = f64::NAN;
            loop {
                match imu.next_sample() {
                    Ok(Some(s)) => {
                        if let Some((_, config, span)) = &mut tee {
                            if t_end.is_nan() {
                                t_end = start_span(config, s.t).1;
                            }
                            span.push(s);
                            if s.t > t_end {
                                if let Some((to, _, span)) = tee.take() {
                                    let _ = to.send(span);
                                }
                            }
                        }
                        batch.push((s, imu.line()));
                        if batch.len() == BATCH
                            && tx
                                .send(Ok(std::mem::replace(&mut batch, Vec::with_capacity(BATCH))))
                                .is_err()
                        {
                            break;
                        }
                    }
                    Ok(None) => {
                        let _ = tx.send(Ok(batch));
                        break;
                    }
                    Err(e) => {
                        let _ = tx.send(Ok(std::mem::take(&mut batch)));
                        let _ = tx.send(Err(e));
                        break;
                    }
                }
            }
            if let Some((to, _, span)) = tee {
                let _ = to.send(span);
            }
            imu.skipped
        });
        Self { batches, reader }
    }

    /// Stop reading (if not at the end yet) and return the reader's skipped lines.
    /// (A tee still open closes with the reader: the data ended before `align.max_time`.)
    fn finish(self) -> Result<SkipCounts, RunError> {
        drop(self.batches);
        self.reader.join().map_err(|_| RunError::NoData("the reader thread panicked".into()))
    }
}

/// The IMU samples [`Checks`] look at, in one message (none if the reader stopped early).
type Tee = std::sync::mpsc::Sender<Vec<ImuSample>>;

/// [`crate::start::prepare`] run beside the filter when it only checks (the initial state
/// and noise are given): on the IMU samples the reader tees to it and the GNSS epochs of
/// the same span, read from a reader of its own.
struct Checks(std::thread::JoinHandle<Result<(), RunError>>);

impl Checks {
    fn spawn(
        config: &Config,
        inputs: &Inputs,
        imu: std::sync::mpsc::Receiver<Vec<ImuSample>>,
    ) -> Result<Self, RunError> {
        let mut gnss = open_aid(config, inputs)?;
        let config = config.clone();
        Ok(Self(std::thread::spawn(move || {
            let samples = imu.recv().unwrap_or_default();
            let Some(first) = samples.first() else {
                return Ok(());
            };
            let (t0, t_end) = start_span(&config, first.t);
            let mut epochs = Vec::new();
            while let Some(a) = gnss.next_epoch()? {
                epochs.extend(a.fix);
                if a.t > t_end {
                    break;
                }
            }
            crate::start::prepare(&config, &samples, &epochs, t0)
                .map(|_| ())
                .map_err(RunError::Start)
        })))
    }

    /// Whether the checks have finished (they can be joined without waiting).
    fn done(&self) -> bool {
        self.0.is_finished()
    }

    fn join(self) -> Result<(), RunError> {
        self.0.join().map_err(|_| RunError::NoData("the checks' thread panicked".into()))?
    }
}

/// The first seconds of the inputs, read before the filter starts ([`crate::start`]):
/// IMU samples and GNSS epochs (with their lines) up to `align.max_time` after the start.
pub struct Prefix {
    /// IMU batches as the reader sent them (the filter takes them first); they hold the
    /// samples [`crate::start::prepare`] looks at and may run on past them.
    batches: Vec<Vec<(ImuSample, usize)>>,
    /// How many of the batches' samples `prepare` looks at.
    looked_at: usize,
    /// GNSS epochs and their lines.
    gnss: std::collections::VecDeque<(AidEpoch, usize)>,
}

/// How much of the data's start [`run`] reads before the filter starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Look {
    /// The first sample (nothing to find from the data).
    First,
    /// Until the static start ends ([`crate::start::prepare_floor`]).
    StaticStart,
    /// `align.max_time` ([`crate::start::prepare`]).
    Span,
}

/// Read the [`Prefix`] (`look`): from the start time up to the first IMU sample past
/// its end, and the GNSS epochs up to the first past that sample.
fn read_prefix(
    config: &Config,
    imu: &mut ImuFeed,
    gnss: &mut AidReader,
    look: Look,
) -> Result<Prefix, RunError> {
    let mut p = Prefix { batches: Vec::new(), looked_at: 0, gnss: Default::default() };
    let mut span = None;
    let mut read_gnss = |p: &mut Prefix, t: f64| -> Result<(), RunError> {
        while p.gnss.back().is_none_or(|(g, _)| g.t <= t) {
            match gnss.next_epoch()? {
                Some(g) => p.gnss.push_back((g, gnss.line())),
                None => break,
            }
        }
        Ok(())
    };
    'batches: for batch in imu.batches.iter() {
        let batch = batch?;
        if batch.is_empty() {
            // (the reader's last message before an error, or at the end of the data)
            continue;
        }
        let (t0, t_end) = *span.get_or_insert_with(|| {
            let first = batch.first().map_or(f64::NAN, |(s, _)| s.t);
            let (t0, t_end) = start_span(config, first);
            (t0, if look == Look::First { f64::NEG_INFINITY } else { t_end })
        });
        for (s, _) in &batch {
            p.looked_at += 1;
            if s.t > t_end {
                p.batches.push(batch);
                break 'batches;
            }
        }
        p.batches.push(batch);
        if look == Look::StaticStart {
            // stop once the static start has ended inside what was read
            let last = p.batches.iter().flatten().last().map_or(f64::NAN, |(s, _)| s.t);
            read_gnss(&mut p, last)?;
            let (imu, gnss) = p.samples();
            let (still, _) = crate::start::static_start(config, &imu, &gnss, t0);
            if still.samples == 0 || still.span.1 < last - config.align.static_window {
                break;
            }
        }
    }
    let Some((_, t_end)) = span else {
        return Err(RunError::NoData("the IMU file has no samples".into()));
    };
    let t_gnss = match look {
        Look::StaticStart => p.batches.iter().flatten().last().map_or(t_end, |(s, _)| s.t),
        _ => t_end,
    };
    read_gnss(&mut p, t_gnss)?;
    Ok(p)
}

impl Prefix {
    /// The IMU samples looked at, and the GNSS epochs.
    fn samples(&self) -> (Vec<ImuSample>, Vec<GnssEpoch>) {
        let imu = self.batches.iter().flatten().take(self.looked_at).map(|(s, _)| *s).collect();
        (imu, self.gnss.iter().filter_map(|(g, _)| g.fix).collect())
    }
}

/// The run's start time (the configured one, or the first IMU sample's `first_t`) and the
/// end of the data [`crate::start::prepare`] looks at (`align.max_time` later, and a
/// static start's [`crate::start::STATIC_ALLOWANCE`]: the alignment's span counts from
/// the motion's start).
fn start_span(config: &Config, first_t: f64) -> (f64, f64) {
    let t0 = config.data.start_time.unwrap_or(first_t);
    (t0, t0 + config.align.max_time + crate::start::STATIC_ALLOWANCE)
}

/// [`crate::start::prepare`] (or its part `look` calls for) on a prefix.
fn prepare_start(
    config: &Config,
    prefix: &Prefix,
    look: Look,
) -> Result<crate::start::Start, RunError> {
    let (imu, gnss) = prefix.samples();
    let (t0, _) = start_span(config, imu.first().map_or(0.0, |s| s.t));
    match look {
        Look::Span => crate::start::prepare(config, &imu, &gnss, t0).map_err(RunError::Start),
        Look::StaticStart => Ok(crate::start::prepare_floor(config, &imu, &gnss, t0)),
        Look::First => Ok(crate::start::Start { config: config.clone(), report: Vec::new() }),
    }
}

/// [`run`] with its inputs open and its outputs created.
fn run_into<S: RunState, O: Sink>(
    config: &Config,
    strategy: AnyStrategy,
    names: (PathBuf, PathBuf),
    mut progress: Option<Progress<'_>>,
    (feed, mut gnss, prefix, mut checks): (ImuFeed, AidReader, Prefix, Option<Checks>),
    (out, nav_sink): (&mut O, O::Nav),
) -> Result<RunSummary, RunError>
where
    DefaultAllocator: DimAlloc<S::Dim>,
    estimator_core::Cov<S::Dim>: Send,
{
    let wall = Instant::now();

    // Start: the configured time, or the first IMU sample; samples up to it are skipped.
    let Prefix { batches: first_batches, gnss: mut first_epochs, .. } = prefix;
    let first_t = first_batches
        .iter()
        .flatten()
        .next()
        .ok_or_else(|| RunError::NoData("the IMU file has no samples".into()))?
        .0
        .t;
    // the receiver clock of the first raw epoch after the start with a single point
    let t0 = config.data.start_time.unwrap_or(first_t);
    let clock = first_epochs
        .iter()
        .filter(|(a, _)| a.t > t0 + 1e-9)
        .find_map(|(a, _)| a.raw.as_ref().and_then(|r| r.1));
    let (mut nav, mut summary, end) = start_navigator::<S>(config, strategy, first_t, clock)?;
    let start = summary.span.0;
    let mut recorder = if config.filter.smooth { Some(out.recorder::<S>()?) } else { None };
    let (imu_path, gnss_path) = names;
    // Which record a failure belongs to: the GNSS epoch whose update failed, or the IMU
    // sample whose prediction did.
    // `lines`: the batch's GNSS epochs' times and lines (0: not a text file)
    let locate = |e: NavError, imu_line: usize, lines: &[(f64, usize)]| match &e {
        NavError::Measurement { t, .. } => {
            match lines.iter().find(|(tg, line)| (tg - t).abs() < 1e-6 && *line > 0) {
                Some((_, line)) => {
                    RunError::Located { path: gnss_path.clone(), line: *line, error: e }
                }
                None => RunError::Navigation(e),
            }
        }
        _ => RunError::Located { path: imu_path.clone(), line: imu_line, error: e },
    };

    std::thread::scope(|scope| -> Result<(), RunError> {
        // States, not records: the writer thread does the Euler conversion.
        let (nav_tx, nav_rx) =
            std::sync::mpsc::sync_channel::<Vec<(f64, ins_gnss_core::state::InsState)>>(4);
        let writer = scope.spawn(move || -> Result<O::Nav, RunError> {
            let mut w = nav_sink;
            for batch in nav_rx {
                w.rows(&batch)?;
            }
            w.finish()?;
            Ok(w)
        });

        let result = (|| -> Result<(), RunError> {
            let tight = gnss.tight().cloned();
            let mut read_gnss = |gnss: &mut AidReader, span: &mut (f64, f64)| {
                let g = match first_epochs.pop_front() {
                    Some(g) => Some(g),
                    None => gnss.next_epoch()?.map(|g| (g, gnss.line())),
                };
                if let Some((g, _)) = &g {
                    let g: &AidEpoch = g;
                    if span.0.is_nan() {
                        span.0 = g.t;
                    }
                    span.1 = g.t;
                }
                Ok::<_, RunError>(g)
            };
            summary.gnss_span = (f64::NAN, f64::NAN);
            let mut next_gnss = read_gnss(&mut gnss, &mut summary.gnss_span)?;
            let mut batch: Vec<GnssEpoch> = Vec::with_capacity(4);
            let mut raws: Vec<RawEpoch> = Vec::new();
            let mut batch_lines: Vec<(f64, usize)> = Vec::with_capacity(4);
            let mut updates: Vec<UpdateSummary> = Vec::with_capacity(4);
            let mut records = Vec::with_capacity(BATCH);
            let mut last_std = f64::NEG_INFINITY;
            let messages = first_batches.into_iter().map(Ok).chain(feed.batches.iter());
            'outer: for message in messages {
                // a refusal by the checks stops the run
                if checks.as_ref().is_some_and(Checks::done) {
                    checks.take().map_or(Ok(()), Checks::join)?;
                }
                for (sample, imu_line) in message? {
                    if sample.t <= start + 1e-9 {
                        continue;
                    }
                    if sample.t > end + 1e-9 {
                        break 'outer;
                    }
                    batch.clear();
                    raws.clear();
                    batch_lines.clear();
                    while next_gnss.as_ref().is_some_and(|(g, _)| g.t <= sample.t + 1e-9) {
                        let Some((g, line)) = next_gnss.take() else { break };
                        if g.t > start + 1e-9 {
                            if let Some(fix) = g.fix {
                                summary.first_fix.get_or_insert(fix);
                                batch.push(fix);
                            }
                            raws.extend(g.raw.map(|r| r.0));
                            batch_lines.push((g.t, line));
                        }
                        next_gnss = read_gnss(&mut gnss, &mut summary.gnss_span)?;
                    }
                    updates.clear();
                    S::process(
                        &mut nav,
                        &sample,
                        &batch,
                        &raws,
                        tight.as_ref(),
                        &mut updates,
                        &mut recorder,
                    )
                    .map_err(|e| locate(e, imu_line, &batch_lines))?;
                    summary.imu_epochs += 1;
                    records.push((sample.t, nav.nav_state().clone()));
                    if records.len() == BATCH
                        && nav_tx
                            .send(std::mem::replace(&mut records, Vec::with_capacity(BATCH)))
                            .is_err()
                    {
                        break 'outer;
                    }
                    summary.tally(&updates);
                    for u in &updates {
                        out.update(u)?;
                    }
                    // after every update, and once a second without (an outage's σ)
                    if !updates.is_empty() || sample.t >= last_std + STD_EVERY - 1e-9 {
                        let fix = updates.iter().any(|u| {
                            S::is_fix(u.stream) && u.verdict != estimator_core::Verdict::Rejected
                        });
                        out.epoch(sample.t, &nav, fix)?;
                        // the smoothed σ at the same epochs
                        estimator_core::StepRecorder::<S, ImuInput>::mark_variances(&mut recorder);
                        last_std = sample.t;
                    }
                    summary.span.1 = sample.t;
                    if summary.imu_epochs.is_multiple_of(2000) {
                        if let Some(p) = progress.as_mut() {
                            p(sample.t);
                        }
                    }
                }
            }
            let _ = nav_tx.send(records);
            Ok(())
        })();
        drop(nav_tx);
        let written =
            writer.join().map_err(|_| RunError::NoData("the writer thread panicked".into()))?;
        summary.imu_skipped = feed.finish()?;
        // the checks' verdict first: a refused input explains a failed run
        checks.take().map_or(Ok(()), Checks::join)?;
        result?;
        out.nav_done(written?);
        Ok(())
    })?;

    if summary.imu_epochs == 0 {
        return Err(RunError::NoData(format!(
            "no IMU sample after the start time {start} s in {}",
            imu_path.display()
        )));
    }
    summary.finish_streams();
    check_gnss_overlap(&summary, &gnss_path)?;
    out.epoch(summary.span.1, &nav, false)?;
    estimator_core::StepRecorder::<S, ImuInput>::mark_variances(&mut recorder);
    out.flush()?;
    summary.gnss_skipped = gnss.skipped();
    summary.stationary_time = nav.stationary_time();
    if let Some(recorder) = recorder {
        let backward = Instant::now();
        let rows = out.smoothed(recorder, &nav)?;
        summary.smoothed = Some((rows, backward.elapsed().as_secs_f64()));
    }
    summary.wall_time = wall.elapsed().as_secs_f64();
    Ok(summary)
}

/// A run that used no GNSS epoch although the file has some: the file does not overlap
/// the IMU span (a pure-INS result nobody asked for), refused.
fn check_gnss_overlap(summary: &RunSummary, gnss: &Path) -> Result<(), RunError> {
    let (g0, g1) = summary.gnss_span;
    if summary.gnss_epochs == 0 && !g0.is_nan() {
        let (i0, i1) = summary.span;
        let gap = if g0 > i1 { g0 - i1 } else { i0 - g1.max(g0) };
        let offset = g0 - i0;
        let hint = time_scale_hint(offset, i0, g0);
        // refused like an input that cannot give a result: nothing of it is kept
        return Err(RunError::Start(format!(
            "{}: no GNSS epoch falls inside the IMU span {i0:.3}–{i1:.3} s (the file's epochs \
             read span {g0:.3}–{g1:.3} s, {gap:.3} s {} it); both files are read as seconds on \
             one scale (the KF-GINS formats: GPS seconds of week; RTKLIB solutions are \
             converted to it){hint}; check the files' times and `data.start_time`",
            gnss.display(),
            if g0 > i1 { "after" } else { "before" },
        )));
    }
    Ok(())
}

/// What an offset `gnss − imu` (s) between two files' first times suggests about their
/// time scales.
fn time_scale_hint(offset: f64, imu0: f64, gnss0: f64) -> String {
    let week = 604_800.0;
    let near = |x: f64, v: f64| (x - v).abs() < 0.5;
    if near(offset.abs(), 18.0) {
        format!(
            "; the offset is {offset:+.1} s, GPS − UTC since 2017: one file is in UTC, the other \
             in GPST"
        )
    } else if offset.abs() > 0.5 * week && (offset / week - (offset / week).round()).abs() < 1e-3 {
        format!("; the offset is {:.0} whole GPS weeks", offset / week)
    } else if (gnss0 > 1e8) != (imu0 > 1e8) {
        "; one file's times look like Unix or absolute seconds, the other's like seconds of \
         week or of the day"
            .into()
    } else {
        String::new()
    }
}

/// Read the configured IMU and GNSS files whole, with the same checks and skip policy as
/// [`run`], for repeated in-memory runs ([`run_slices`]): Monte Carlo over injected
/// errors, strategy sweeps. Memory grows with the dataset (≈ 64 bytes per IMU sample).
pub fn load_inputs(config: &Config) -> Result<(Vec<ImuSample>, Vec<GnssEpoch>), RunError> {
    if config.gnss.coupling == crate::config::Coupling::Tight {
        return Err(bad_map(
            "gnss.coupling",
            "in-memory slices hold fixes (loose coupling); a tight run goes through `run`".into(),
        ));
    }
    let (mut imu, mut gnss) = open_inputs(config, &Inputs::Files)?;
    let (mut samples, mut epochs) = (Vec::new(), Vec::new());
    while let Some(s) = imu.next_sample()? {
        samples.push(s);
    }
    while let Some(g) = gnss.next_epoch()? {
        epochs.extend(g.fix);
    }
    Ok((samples, epochs))
}

/// [`run`] on data in memory, without output files: the same start and end times, the
/// same GNSS batching. `each(k, t, state)` is called after IMU sample `imu[k]` (at time
/// `t`) has been processed. The summary counts epochs and verdicts; its skip counts and
/// output directory are empty.
pub fn run_slices(
    config: &Config,
    strategy: AnyStrategy,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    each: impl FnMut(usize, f64, &InsState),
) -> Result<RunSummary, RunError> {
    match config.filter.states {
        21 => run_slices_on::<InsState21>(config, strategy, imu, gnss, each),
        _ => run_slices_on::<InsState>(config, strategy, imu, gnss, each),
    }
}

fn run_slices_on<S: RunState>(
    config: &Config,
    strategy: AnyStrategy,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    mut each: impl FnMut(usize, f64, &InsState),
) -> Result<RunSummary, RunError>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let wall = Instant::now();
    let first = imu.first().ok_or_else(|| RunError::NoData("no IMU samples".into()))?;
    let (t0, t_end) = start_span(config, first.t);
    let n_imu = imu.partition_point(|s| s.t <= t_end + 1e-9);
    let n_gnss = gnss.partition_point(|e| e.t <= t_end + 1e-9);
    let start = crate::start::prepare(config, &imu[..n_imu], &gnss[..n_gnss], t0)
        .map_err(RunError::Start)?;
    let config = &start.config;
    let (mut nav, mut summary, end) = start_navigator::<S>(config, strategy, first.t, None)?;
    summary.start = start.report;
    let start = summary.span.0;
    let mut updates: Vec<UpdateSummary> = Vec::with_capacity(4);
    // GNSS epochs at or before the start are not used.
    let mut g = gnss.partition_point(|e| e.t <= start + 1e-9);
    for (k, sample) in imu.iter().enumerate() {
        if sample.t <= start + 1e-9 {
            continue;
        }
        if sample.t > end + 1e-9 {
            break;
        }
        let first = g;
        while g < gnss.len() && gnss[g].t <= sample.t + 1e-9 {
            g += 1;
        }
        if summary.first_fix.is_none() && g > first {
            summary.first_fix = Some(gnss[first]);
        }
        updates.clear();
        nav.process_into(sample, &gnss[first..g], &mut NoObserver, &mut updates)?;
        summary.imu_epochs += 1;
        summary.tally(&updates);
        summary.span.1 = sample.t;
        each(k, sample.t, nav.nav_state());
    }
    if summary.imu_epochs == 0 {
        return Err(RunError::NoData(format!("no IMU sample after the start time {start} s")));
    }
    summary.gnss_span = match (gnss.first(), gnss.last()) {
        (Some(a), Some(b)) => (a.t, b.t),
        _ => (f64::NAN, f64::NAN),
    };
    summary.finish_streams();
    check_gnss_overlap(&summary, Path::new("(GNSS data)"))?;
    summary.stationary_time = nav.stationary_time();
    summary.wall_time = wall.elapsed().as_secs_f64();
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `reverse_file` turns files of every length around, blocks and middle included.
    #[test]
    fn files_are_reversed_in_place() {
        let dir = std::env::temp_dir().join(format!("ins-gnss-reverse-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("f");
        let block = 1usize << 20;
        for len in [0, 1, 2, 1000, 2 * block - 1, 2 * block, 2 * block + 1, 5 * block + 3] {
            let bytes: Vec<u8> = (0..len).map(|i| (i * 7 + i / 251) as u8).collect();
            std::fs::write(&path, &bytes).unwrap();
            let mut file = std::fs::OpenOptions::new().read(true).write(true).open(&path).unwrap();
            reverse_file(&mut file).unwrap();
            drop(file);
            let back = std::fs::read(&path).unwrap();
            let expected: Vec<u8> = bytes.iter().rev().copied().collect();
            assert!(back == expected, "length {len}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
