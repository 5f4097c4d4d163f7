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
use nalgebra::{DimName, Vector3};

use crate::config::Config;
use estimator_core::DimAlloc;
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::imu::ImuSample;
use ins_gnss_core::imu::{DEG_PER_H, MGAL};
use ins_gnss_core::io::fixed::push_row;
use ins_gnss_core::io::formats::{create_partial, partial_path, publish, write_nav};
use ins_gnss_core::io::{GnssReader, ImuReader, LineError, NavRecord, SkipCounts};
use ins_gnss_core::model::{ImuInput, InsModel};
use ins_gnss_core::navigator::{NavError, NavState, Navigator};
use ins_gnss_core::scale::{InsModel21, InsState21};
use ins_gnss_core::state::InsState;
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

/// One measurement stream's innovations over the run: all of them (accepted, inflated and
/// refused), with the nominal `S` (before any adaptation).
#[derive(Clone, Debug)]
pub struct StreamStats {
    /// The stream.
    pub stream: estimator_core::StreamId,
    /// Whether it is a GNSS stream (not vehicle aiding).
    pub gnss: bool,
    /// Updates.
    pub epochs: usize,
    /// Refused updates.
    pub refused: usize,
    /// Sum of the NIS (nominal `S`) and of the dimensions.
    pub nis_sum: f64,
    /// See [`nis_sum`](Self::nis_sum).
    pub dof: usize,
    /// Updates whose NIS exceeds the median of its χ² distribution (half of them for a
    /// consistent filter, whatever a few gross errors do).
    pub above_median: usize,
    /// The median over the updates of NIS / (χ² median): the factor² by which `S` is too
    /// small (about 1 when consistent), from the sorted ratios at the end of the run.
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
        let n = self.epochs.max(1) as f64;
        // the standard normal quantile of 1 − 0.5e-6
        let half = 4.8916 * 0.5 / n.sqrt();
        (self.above_median as f64 / n, (0.5 - half, 0.5 + half))
    }

    /// Consistent by the mean NIS of all innovations.
    pub fn consistent(&self) -> bool {
        let (m, (lo, hi)) = self.mean_nis();
        m >= lo && m <= hi
    }

    /// One line for the run summary.
    pub fn verdict(&self) -> String {
        let (m, (lo, hi)) = self.mean_nis();
        let (f, (flo, fhi)) = self.above_median_band();
        let head = format!(
            "consistency of {}: mean NIS per degree of freedom {m:.3} over all {} updates \
             ({} refused), 99 % band [{lo:.3}, {hi:.3}]; {:.1} % above their χ² median \
             (band [{:.1}, {:.1}] %)",
            self.stream,
            self.epochs,
            self.refused,
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
        self.nis_sum += u.nis;
        self.dof += u.dim;
        self.above_median += usize::from(u.nis > median);
        self.ratios.push((u.nis / median) as f32);
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

/// The outputs written by the filter thread (`nav.txt` goes to the writer thread).
struct Outputs {
    dir: PathBuf,
    std: std::io::BufWriter<std::fs::File>,
    imu_err: std::io::BufWriter<std::fs::File>,
    updates: std::io::BufWriter<std::fs::File>,
    pos: std::io::BufWriter<std::fs::File>,
    /// Time of the last `nav.pos` epoch (the end of a run can repeat it).
    pos_last_t: Option<f64>,
}

impl Outputs {
    /// Create the output directory and files; returns the outputs and `nav.txt`.
    fn create(dir: &Path) -> Result<(Self, std::io::BufWriter<std::fs::File>), RunError> {
        let out =
            |path: PathBuf, e: std::io::Error| RunError::Output { path, message: e.to_string() };
        std::fs::create_dir_all(dir).map_err(|e| out(dir.to_path_buf(), e))?;
        // Every output is written as `NAME.partial` and renamed into place when the run
        // completes ([`Outputs::publish`]): a failed run never touches earlier results.
        let open = |name: &str| {
            let p = dir.join(name);
            create_partial(&p).map_err(|e| out(partial_path(&p), e))
        };
        let nav = open("nav.txt")?;
        let mut o = Outputs {
            dir: dir.to_path_buf(),
            std: open("std.txt")?,
            imu_err: open("imu_errors.txt")?,
            updates: open("updates.csv")?,
            pos: open("nav.pos")?,
            pos_last_t: None,
        };
        ins_gnss_core::io::rtklib::write_header(
            &mut o.pos,
            concat!("ins-gnss ", env!("CARGO_PKG_VERSION")),
            true,
        )
        .map_err(|e| out(dir.join("nav.pos"), e))?;
        writeln!(
            o.updates,
            "time,stream,dim,nis,nis_adapted,decision,reason,dom,lambda_p,lambda_r,scaling_fallback"
        )
        .map_err(|e| out(dir.join("updates.csv"), e))?;
        Ok((o, nav))
    }

    fn err(&self, name: &str, e: std::io::Error) -> RunError {
        RunError::Output { path: partial_path(&self.dir.join(name)), message: e.to_string() }
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

/// The navigation record of a state.
pub fn nav_record(t: f64, x: &ins_gnss_core::state::InsState) -> NavRecord {
    let (r, p, y) = x.euler();
    NavRecord { week: 0.0, t, pos: x.pos, vel: x.vel, att: Vector3::new(r, p, y) }
}

fn write_std<A: NoiseStrategy, S: RunState>(
    o: &mut Outputs,
    t: f64,
    nav: &Navigator<A, S>,
    gnss_fix: bool,
) -> std::io::Result<()>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let x = nav.nav_state();
    write_sigma_row(&mut o.std, t, nav.sigma().as_slice())?;
    // nav.pos: the position and velocity with their NED covariance blocks (error states
    // 6–8 and 3–5); Q 1 after a GNSS update, 5 (no GNSS) otherwise
    if o.pos_last_t == Some(t) {
        return Ok(());
    }
    o.pos_last_t = Some(t);
    let p = nav.covariance();
    let block = |i: usize| nalgebra::Matrix3::from_fn(|r, c| p[(i + r, i + c)]);
    let (pos_cov, vel_cov) = (block(6), block(3));
    let q = if gnss_fix { 1 } else { 5 };
    ins_gnss_core::io::rtklib::write_epoch(
        &mut o.pos,
        0.0,
        t,
        &x.pos,
        &pos_cov,
        Some((&x.vel, &vel_cov)),
        q,
    )?;
    write!(
        o.imu_err,
        "{t:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6}",
        x.bg.x / DEG_PER_H,
        x.bg.y / DEG_PER_H,
        x.bg.z / DEG_PER_H,
        x.ba.x / MGAL,
        x.ba.y / MGAL,
        x.ba.z / MGAL
    )?;
    if let Some((sg, sa)) = nav.state().scale_factors() {
        for v in sg.iter().chain(sa.iter()) {
            write!(o.imu_err, " {:.3}", v * 1e6)?;
        }
    }
    writeln!(o.imu_err)
}

/// One row of `std.txt`: `t`, then the 1σ of the error states `s` in the file's units
/// (position, velocity, attitude in degrees, biases in deg/h and mGal, scale factors in
/// ppm).
fn write_sigma_row(w: &mut impl Write, t: f64, s: &[f64]) -> std::io::Result<()> {
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
    let mut line = Vec::with_capacity(200);
    push_row(&mut line, &row[..1 + n]);
    w.write_all(&line)
}

fn write_update(o: &mut Outputs, u: &UpdateSummary) -> std::io::Result<()> {
    writeln!(
        o.updates,
        "{:.6},{},{},{:.6},{:.6},{},\"{}\",{:.6},{:.6},{:.6},{}",
        u.time,
        u.stream.name(),
        u.dim,
        u.nis,
        u.nis_adapted,
        u.verdict.as_str(),
        u.reason,
        u.factors.dom,
        u.factors.lambda_p,
        u.factors.lambda_r,
        u8::from(u.prior_scaling_fallback)
    )
}

type FileReader = ins_gnss_core::io::formats::Input;

/// The configured IMU and GNSS readers (format, rate, gap limit, skip policy).
fn open_inputs(
    config: &Config,
) -> Result<(ImuReader<FileReader>, GnssReader<FileReader>), RunError> {
    config.require_inputs().map_err(RunError::Config)?;
    let mut imu = ImuReader::open(
        &config.data.imu,
        config.imu_format(),
        config.data.imu_rate,
        config.data.max_gap,
        config.bad_lines(),
    )?
    .with_max_bridge(config.data.max_bridge);
    if let Some(c) = &config.data.imu_columns {
        let rates = config.imu_format() == ins_gnss_core::io::ImuFormat::Rates;
        imu = imu.with_columns(c.map(rates).map_err(|e| bad_map("data.imu_columns", e))?);
    }
    if let Some(m) = &config.imu.mounting {
        imu = imu.with_mounting(m.matrix().map_err(|e| bad_map("imu.mounting", e))?);
    }
    Ok((imu, open_gnss(config)?))
}

/// A column map or mounting the reader cannot take (they were checked when the
/// configuration was loaded).
fn bad_map(key: &str, message: String) -> RunError {
    RunError::Config(crate::config::ConfigError { path: PathBuf::from(key), message })
}

/// The configured GNSS file, open.
fn open_gnss(config: &Config) -> Result<GnssReader<FileReader>, RunError> {
    let mut gnss = GnssReader::open(&config.data.gnss, config.bad_lines())?
        .with_format(config.data.gnss_format.into())
        .with_quality(config.gnss.quality.factors().map_err(|e| bad_map("gnss.quality", e))?)
        .with_default_sigma(config.gnss.position_std.map(|s| s.into()));
    if let Some(c) = &config.data.gnss_columns {
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
    /// The navigator at `start`.
    fn navigator(
        config: &Config,
        strategy: RunStrategy,
        start: f64,
    ) -> Result<Navigator<RunStrategy, Self>, NavError>;

    /// The scale factors (gyro, accelerometer), when the state has them.
    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)>;
}

impl RunState for InsState {
    fn navigator(
        config: &Config,
        strategy: RunStrategy,
        start: f64,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let model = InsModel { mechanization: config.mechanization(), noise: config.imu_noise() };
        Navigator::new(&config.initial_state(start), model, strategy, config.gnss_config())
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        None
    }
}

impl RunState for InsState21 {
    fn navigator(
        config: &Config,
        strategy: RunStrategy,
        start: f64,
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

/// The navigator at the start time (the configured one, or the first IMU sample's
/// `first_t`), the run's summary with its span started there, and the end time.
fn start_navigator<S: RunState>(
    config: &Config,
    strategy: AnyStrategy,
    first_t: f64,
) -> Result<(Navigator<RunStrategy, S>, RunSummary, f64), RunError>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let start = config.data.start_time.unwrap_or(first_t);
    let end = config.data.end_time.unwrap_or(f64::INFINITY);
    // the name of the strategy the user chose (the vehicle streams' fixed noise aside)
    let name = if config.filter.streams.is_empty() { strategy.name() } else { "per-stream" };
    let strategy = config.strategy(strategy).map_err(RunError::Config)?;
    let nav = S::navigator(config, strategy, start)?.with_vehicle_aiding(config.vehicle_aiding());
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

/// The smoother's scratch files in the output directory (removed when the run ends).
const SMOOTHER_STATES: &str = "smoother-segments.tmp";
const SMOOTHER_ROWS: &str = "smoother-rows.tmp";

/// Predictions per smoother segment at most (the backward pass holds one segment: three
/// `N × N` matrices per prediction, 0.7 MB with 15 states).
const SMOOTHER_SEGMENT: usize = 128;

/// The recorder of a run that smooths: the segment smoother on a scratch file.
type Recorder<S> = estimator_core::SegmentSmoother<S, ImuInput>;

/// Rows per second of `nav_smoothed.pos` at most (its text at every IMU epoch cost 15 %
/// of a smoothed navego run).
const POS_SMOOTHED_RATE: f64 = 10.0;

/// The backward pass: `nav_smoothed.txt` and `std_smoothed.txt` (as `.partial`, in the
/// formats of `nav.txt` and `std.txt`, at every IMU epoch). The smoother hands the
/// segments last to first; their text goes to a scratch file, which is then copied out
/// segment by segment in time order. Returns the number of rows.
fn write_smoothed<S: RunState>(
    recorder: Recorder<S>,
    nav: &Navigator<RunStrategy, S>,
    dir: &Path,
) -> Result<usize, RunError>
where
    estimator_core::Cov<S::Dim>: Send,
    DefaultAllocator: DimAlloc<S::Dim>,
{
    use std::io::{Read, Seek, SeekFrom};
    let scratch = dir.join(SMOOTHER_ROWS);
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |e: std::io::Error| RunError::Output { path: path.clone(), message: e.to_string() }
    };
    let file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(true)
        .open(&scratch)
        .map_err(io(&scratch))?;
    // The rows are formatted and written by a second thread while the backward pass runs.
    // (time, state, σ of the error states, as many as the state has)
    type Row = (f64, InsState, [f64; 21]);
    let n = S::Dim::DIM.min(21);
    let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<Row>>(8);
    let writer = std::thread::spawn(move || -> std::io::Result<_> {
        let mut rows_file = std::io::BufWriter::with_capacity(1 << 16, file);
        // (offset, bytes of nav rows, of std rows, of .pos rows) of each segment's text
        let mut chunks: Vec<(u64, usize, usize, usize)> = Vec::new();
        let (mut at, mut count) = (0u64, 0usize);
        let (mut nav_text, mut std_text, mut pos_text) = (Vec::new(), Vec::new(), Vec::new());
        let var = |s: &[f64]| -> nalgebra::Matrix3<f64> {
            let z = 0.0;
            nalgebra::Matrix3::new(s[0] * s[0], z, z, z, s[1] * s[1], z, z, z, s[2] * s[2])
        };
        for rows in rx {
            nav_text.clear();
            std_text.clear();
            pos_text.clear();
            let mut bin = f64::NAN;
            for (t, x, sigma) in &rows {
                write_nav(&mut nav_text, &nav_record(*t, x))?;
                write_sigma_row(&mut std_text, *t, &sigma[..n])?;
                // nav_smoothed.pos at most at 10 Hz (the first row of each 0.1 s); the
                // smoother keeps the variances only: the covariances are written as 0
                let here = (t * POS_SMOOTHED_RATE + 1e-6).floor();
                if here == bin {
                    continue;
                }
                bin = here;
                let vel_var = var(&sigma[3..6]);
                ins_gnss_core::io::rtklib::write_epoch(
                    &mut pos_text,
                    0.0,
                    *t,
                    &x.pos,
                    &var(&sigma[6..9]),
                    Some((&x.vel, &vel_var)),
                    1,
                )?;
            }
            rows_file.write_all(&nav_text)?;
            rows_file.write_all(&std_text)?;
            rows_file.write_all(&pos_text)?;
            chunks.push((at, nav_text.len(), std_text.len(), pos_text.len()));
            at += (nav_text.len() + std_text.len() + pos_text.len()) as u64;
            count += rows.len();
        }
        Ok((rows_file.into_inner().map_err(|e| e.into_error())?, chunks, count))
    });
    // segments arrive last to first: a batch of them is sent in time order, as one chunk
    let mut pending: Vec<Vec<Row>> = Vec::new();
    let mut pending_rows = 0;
    let send = |pending: &mut Vec<Vec<Row>>| {
        let rows: Vec<Row> = pending.drain(..).rev().flatten().collect();
        tx.send(rows).map_err(|_| std::io::Error::other("the row writer stopped"))
    };
    let smoothed =
        recorder.smooth_threaded(nav.filter(), nav.model(), |rows: &[SmoothedRow<S>]| {
            pending.push(
                rows.iter()
                    .map(|r| {
                        let mut sigma = [0.0; 21];
                        for (s, v) in sigma.iter_mut().zip(r.var.iter()) {
                            *s = v.max(0.0).sqrt();
                        }
                        (r.time, r.x.nav().clone(), sigma)
                    })
                    .collect(),
            );
            pending_rows += rows.len();
            if pending_rows >= 4096 {
                pending_rows = 0;
                send(&mut pending)?;
            }
            Ok(())
        });
    let smoothed = smoothed.and_then(|()| send(&mut pending).map_err(Into::into));
    drop(tx);
    let written = writer
        .join()
        .map_err(|_| RunError::NoData("the smoother's writer thread panicked".into()))?;
    smoothed.map_err(|e| RunError::Output {
        path: dir.join(SMOOTHER_STATES),
        message: e.to_string(),
    })?;
    let (mut file, chunks, count) = written.map_err(io(&scratch))?;
    let nav_path = dir.join("nav_smoothed.txt");
    let std_path = dir.join("std_smoothed.txt");
    let pos_path = dir.join("nav_smoothed.pos");
    let mut nav_out = create_partial(&nav_path).map_err(io(&partial_path(&nav_path)))?;
    let mut std_out = create_partial(&std_path).map_err(io(&partial_path(&std_path)))?;
    let mut pos_out = create_partial(&pos_path).map_err(io(&partial_path(&pos_path)))?;
    ins_gnss_core::io::rtklib::write_header(
        &mut pos_out,
        concat!("ins-gnss ", env!("CARGO_PKG_VERSION"), ", smoothed"),
        true,
    )
    .map_err(io(&partial_path(&pos_path)))?;
    let mut buf = Vec::new();
    for &(offset, n, s, p) in chunks.iter().rev() {
        buf.resize(n + s + p, 0);
        file.seek(SeekFrom::Start(offset)).map_err(io(&scratch))?;
        file.read_exact(&mut buf).map_err(io(&scratch))?;
        nav_out.write_all(&buf[..n]).map_err(io(&partial_path(&nav_path)))?;
        std_out.write_all(&buf[n..n + s]).map_err(io(&partial_path(&std_path)))?;
        pos_out.write_all(&buf[n + s..]).map_err(io(&partial_path(&pos_path)))?;
    }
    nav_out.flush().map_err(io(&partial_path(&nav_path)))?;
    std_out.flush().map_err(io(&partial_path(&std_path)))?;
    pos_out.flush().map_err(io(&partial_path(&pos_path)))?;
    Ok(count)
}

/// Longest time between two rows of `std.txt` and `imu_errors.txt`, s (they are written
/// after every update, and at this interval without one).
const STD_EVERY: f64 = 1.0;

/// Samples or records per message between the pipeline's threads.
const BATCH: usize = 1024;

/// Run `config` with `strategy`, writing into `out_dir`. `progress` (if any) is called
/// with the current time every 2,000 IMU epochs.
///
/// The run is a three-stage pipeline over bounded channels: a reader thread parses the
/// IMU file, this thread runs the filter, a writer thread formats and writes `nav.txt`.
/// Memory is bounded by the channels (a few batches of 1,024 samples), whatever the
/// length of the dataset.
pub fn run(
    config: &Config,
    strategy: AnyStrategy,
    out_dir: &Path,
    progress: Option<Progress<'_>>,
) -> Result<RunSummary, RunError> {
    let (imu, mut gnss) = open_inputs(config)?;
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
        let checks = Checks::spawn(config, prefix)?;
        (ImuFeed::spawn(imu, Some((tee, config.clone()))), Some(checks))
    } else {
        (ImuFeed::spawn(imu, None), None)
    };
    let prefix = match read_prefix(config, &mut feed, &mut gnss, look)
        .and_then(|prefix| Ok((prepare_start(config, &prefix, look)?, prefix)))
        .and_then(|(start, prefix)| Ok((start, prefix, Outputs::create(out_dir)?)))
    {
        Ok(ready) => ready,
        Err(e) => {
            let _ = feed.finish();
            return Err(e);
        }
    };
    let (start, prefix, (out, nav_file)) = prefix;
    let config = &start.config;
    let inputs = ((feed, gnss, prefix, checks), (out, nav_file));
    let result = match config.filter.states {
        21 => run_into::<InsState21>(config, strategy, out_dir, progress, inputs.0, inputs.1),
        _ => run_into::<InsState>(config, strategy, out_dir, progress, inputs.0, inputs.1),
    };
    let result = result.map(|mut s| {
        s.start = start.report;
        s
    });
    // the smoother's scratch files go whatever happened
    for name in [SMOOTHER_STATES, SMOOTHER_ROWS] {
        let _ = std::fs::remove_file(out_dir.join(name));
    }
    match result {
        Ok(summary) => {
            Outputs::publish(out_dir, summary.smoothed.is_some())?;
            Ok(summary)
        }
        // refused by the checks, as before a start: nothing of this run is kept
        Err(error @ RunError::Start(_)) => {
            for name in Outputs::NAMES.iter().chain(&Outputs::SMOOTHED) {
                let _ = std::fs::remove_file(partial_path(&out_dir.join(name)));
            }
            Err(error)
        }
        Err(error) => {
            Err(RunError::Incomplete { error: Box::new(error), dir: out_dir.to_path_buf() })
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
            let (mut tee, config) = tee.unzip();
            let mut t_end = f64::NAN;
            loop {
                match imu.next_sample() {
                    Ok(Some(s)) => {
                        if let (Some(to), Some(config)) = (&tee, &config) {
                            if t_end.is_nan() {
                                t_end = start_span(config, s.t).1;
                            }
                            let _ = to.send(s);
                            if s.t > t_end {
                                tee = None;
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

/// The IMU samples [`Checks`] look at, one by one (the channel closes after the last).
type Tee = std::sync::mpsc::Sender<ImuSample>;

/// [`crate::start::prepare`] run beside the filter when it only checks (the initial state
/// and noise are given): on the IMU samples the reader tees to it and the GNSS epochs of
/// the same span, read from a reader of its own.
struct Checks(std::thread::JoinHandle<Result<(), RunError>>);

impl Checks {
    fn spawn(config: &Config, imu: std::sync::mpsc::Receiver<ImuSample>) -> Result<Self, RunError> {
        let mut gnss = open_gnss(config)?;
        let config = config.clone();
        Ok(Self(std::thread::spawn(move || {
            let samples: Vec<ImuSample> = imu.iter().collect();
            let Some(first) = samples.first() else {
                return Ok(());
            };
            let (t0, t_end) = start_span(&config, first.t);
            let mut epochs = Vec::new();
            while let Some(g) = gnss.next_epoch()? {
                epochs.push(g);
                if g.t > t_end {
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
    gnss: std::collections::VecDeque<(GnssEpoch, usize)>,
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
    gnss: &mut GnssReader<FileReader>,
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
        (imu, self.gnss.iter().map(|(g, _)| *g).collect())
    }
}

/// The run's start time (the configured one, or the first IMU sample's `first_t`) and the
/// end of the data [`crate::start::prepare`] looks at (`align.max_time` later).
fn start_span(config: &Config, first_t: f64) -> (f64, f64) {
    let t0 = config.data.start_time.unwrap_or(first_t);
    (t0, t0 + config.align.max_time)
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

/// [`run`] with its inputs open and its partial outputs created.
fn run_into<S: RunState>(
    config: &Config,
    strategy: AnyStrategy,
    out_dir: &Path,
    mut progress: Option<Progress<'_>>,
    (feed, mut gnss, prefix, mut checks): (ImuFeed, GnssReader<FileReader>, Prefix, Option<Checks>),
    (mut out, nav_file): (Outputs, std::io::BufWriter<std::fs::File>),
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
    let (mut nav, mut summary, end) = start_navigator::<S>(config, strategy, first_t)?;
    let start = summary.span.0;
    summary.out_dir = out_dir.to_path_buf();
    let mut recorder: Option<Recorder<S>> = if config.filter.smooth {
        let path = out_dir.join(SMOOTHER_STATES);
        Some(
            Recorder::<S>::on_file(&path, SMOOTHER_SEGMENT)
                .map_err(|e| RunError::Output { path, message: e.to_string() })?,
        )
    } else {
        None
    };
    let (imu_path, gnss_path) = (config.data.imu.clone(), config.data.gnss.clone());
    // Which record a failure belongs to: the GNSS epoch whose update failed, or the IMU
    // sample whose prediction did.
    // `epochs` and `lines`: the batch's GNSS epochs and their lines, in step
    let locate = |e: NavError, imu_line: usize, epochs: &[GnssEpoch], lines: &[usize]| match &e {
        NavError::Measurement { t, .. } => {
            match epochs.iter().zip(lines).find(|(g, _)| (g.t - t).abs() < 1e-6) {
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
        let nav_path = partial_path(&out_dir.join("nav.txt"));
        let writer = scope.spawn(move || -> Result<(), RunError> {
            let mut w = nav_file;
            for batch in nav_rx {
                for (t, x) in &batch {
                    write_nav(&mut w, &nav_record(*t, x)).map_err(|e| RunError::Output {
                        path: nav_path.clone(),
                        message: e.to_string(),
                    })?;
                }
            }
            w.flush()
                .map_err(|e| RunError::Output { path: nav_path.clone(), message: e.to_string() })
        });

        let result = (|| -> Result<(), RunError> {
            let mut read_gnss = |gnss: &mut GnssReader<FileReader>, span: &mut (f64, f64)| {
                let g = match first_epochs.pop_front() {
                    Some(g) => Some(g),
                    None => gnss.next_epoch()?.map(|g| (g, gnss.line())),
                };
                if let Some((g, _)) = &g {
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
            let mut batch_lines: Vec<usize> = Vec::with_capacity(4);
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
                    batch_lines.clear();
                    while let Some((g, line)) = next_gnss {
                        if g.t > sample.t + 1e-9 {
                            break;
                        }
                        if g.t > start + 1e-9 {
                            summary.first_fix.get_or_insert(g);
                            batch.push(g);
                            batch_lines.push(line);
                        }
                        next_gnss = read_gnss(&mut gnss, &mut summary.gnss_span)?;
                    }
                    updates.clear();
                    nav.process_recorded(
                        &sample,
                        &batch,
                        &mut NoObserver,
                        &mut updates,
                        &mut recorder,
                    )
                    .map_err(|e| locate(e, imu_line, &batch, &batch_lines))?;
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
                        write_update(&mut out, u).map_err(|e| out.err("updates.csv", e))?;
                    }
                    // after every update, and once a second without (an outage's σ)
                    if !updates.is_empty() || sample.t >= last_std + STD_EVERY - 1e-9 {
                        let fix = updates.iter().any(|u| {
                            ins_gnss_core::gnss::GNSS_STREAMS.contains(&u.stream)
                                && u.verdict != estimator_core::Verdict::Rejected
                        });
                        write_std(&mut out, sample.t, &nav, fix)
                            .map_err(|e| out.err("std.txt", e))?;
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
        written
    })?;

    if summary.imu_epochs == 0 {
        return Err(RunError::NoData(format!(
            "no IMU sample after the start time {start} s in {}",
            config.data.imu.display()
        )));
    }
    summary.finish_streams();
    check_gnss_overlap(&summary, &config.data.gnss)?;
    write_std(&mut out, summary.span.1, &nav, false).map_err(|e| out.err("std.txt", e))?;
    for (w, name) in [
        (&mut out.pos, "nav.pos"),
        (&mut out.std, "std.txt"),
        (&mut out.imu_err, "imu_errors.txt"),
        (&mut out.updates, "updates.csv"),
    ] {
        w.flush().map_err(|e| RunError::Output {
            path: partial_path(&out_dir.join(name)),
            message: e.to_string(),
        })?;
    }
    summary.gnss_skipped = gnss.skipped;
    summary.stationary_time = nav.stationary_time();
    if let Some(recorder) = recorder {
        let backward = Instant::now();
        let rows = write_smoothed(recorder, &nav, out_dir)?;
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
    let (mut imu, mut gnss) = open_inputs(config)?;
    let (mut samples, mut epochs) = (Vec::new(), Vec::new());
    while let Some(s) = imu.next_sample()? {
        samples.push(s);
    }
    while let Some(g) = gnss.next_epoch()? {
        epochs.push(g);
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
    let (mut nav, mut summary, end) = start_navigator::<S>(config, strategy, first.t)?;
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
