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
//!   `gnss-position-velocity`, `nhc`, `zupt`, `zaru`, `odometer`; with tight coupling a
//!   satellite's `pr G05`, `rr G05`, and `tdcp`), dimension, NIS,
//!   adapted NIS, decision, reason, DOM, λ_P, λ_R, and 1 where a strategy's subspace prior
//!   scaling fell back to full scaling.

use core::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use adaptive::{AnyStrategy, GrossErrorGate, PerStream};
use estimator_core::{NoObserver, NoiseStrategy, SmoothedRow, UpdateSummary, Verdict};
use nalgebra::Vector3;

use crate::config::{Config, FixErrorPlan, StateKind, PROBE_FIXES};
use crate::start::{Look, Start, Starter};
use aid::{AidEpoch, AidReader};
use estimator_core::DimAlloc;
use ins_gnss_core::calibration::{InsModelCal, InsStateCal};
use ins_gnss_core::fix_error::{InsModel21Fe, InsModelFe, InsState21Fe, InsStateFe};
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::imu::ImuSample;
use ins_gnss_core::imu::{DEG_PER_H, MGAL};
use ins_gnss_core::model::{ImuInput, InsModel};
use ins_gnss_core::navigator::{ClockInit, NavError, NavState, Navigator, RawEpoch, TightConfig};
use ins_gnss_core::scale::{InsModel21, InsState21};
use ins_gnss_core::tight::{ClockNoise, InsModelTc, InsModelTc21, InsStateTc, InsStateTc21};
use ins_gnss_core::vehicle::VEHICLE_STREAMS;
use ins_gnss_core::InsState;
use ins_gnss_io::fixed::{push_exact, push_exact_row, push_row};
use ins_gnss_io::formats::{create_partial, partial_path, publish, push_nav};
use ins_gnss_io::{GnssReader, ImuReader, LineError, NavRecord, SkipCounts};
use nalgebra::DefaultAllocator;

mod again;
mod aid;
mod error;
mod fix_errors;
mod inputs;
mod memory;
mod outputs;
mod pass;
mod recording;
mod rows;
mod rtk_aid;
mod slices;
mod smoothed;

/// The unit tests of `run`'s private modules, for the package's integration-test binary
/// (`tests/unit.rs`; the feature `unit-tests`).
#[cfg(feature = "unit-tests")]
#[doc(hidden)]
pub mod unit_tests {
    pub use super::fix_errors::fix_errors_tests as fix_errors;
    pub use super::inputs::inputs_tests as inputs;
    pub use super::smoothed::smoothed_tests as smoothed;
}
mod state;
mod streams;
mod summary;

pub use again::TIME_OFFSET_REFINED;
use again::*;
pub use error::*;
pub use fix_errors::*;
pub use inputs::*;
pub use memory::*;
pub use outputs::*;
use pass::*;
pub(crate) use recording::open_recording;
pub use rows::*;
pub use slices::*;
use smoothed::*;
pub use state::*;
pub use streams::*;
pub use summary::*;

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

/// One attempt of [`run_with`]: `persisting` is the probe whose total noise scale is the
/// prior of a run with the fixes' persisting error as states (`None`: the plan the
/// configuration and the first fixes make). `shared`: what it takes from the run's other
/// attempts.
fn attempt<O: Sink>(
    config: &Config,
    strategy: AnyStrategy,
    inputs: &Inputs,
    progress: Option<Progress<'_>>,
    create: &mut impl FnMut() -> Result<(O, O::Nav), RunError>,
    persisting: Option<FixErrorProbe>,
    shared: Shared<'_>,
) -> Result<(RunSummary, O), (RunError, bool)> {
    // a recording is read once, into rows, and completes the configuration
    let recording;
    let (config, inputs) = match (inputs, &config.data.ros) {
        (Inputs::Files, Some(_)) => {
            recording = open_recording(config).map_err(|e| (e, false))?;
            (&recording.0, &recording.1)
        }
        _ => (config, inputs),
    };
    let look = Look::of(config);
    let (mut feed, mut gnss, checks) =
        open_feed(config, inputs, shared.replay, look).map_err(|e| (e, false))?;
    let decide = |starter: &Starter<'_>| match shared.start {
        Some(memo) => memo.decide(config, starter),
        None => starter.decide(),
    };
    let ready = read_prefix(config, &mut feed, &mut gnss, look)
        .and_then(|prefix| Ok((decide(&prefix.starter).map_err(RunError::Start)?, prefix)))
        .and_then(|(start, prefix)| {
            if let Some(offset) = start.time_offset.filter(|o| *o != config.data.imu_time_offset) {
                return Err(RunError::TimeOffsetApplied(offset, start.report));
            }
            Ok((start, prefix, create()?))
        });
    let (start, prefix, (mut out, nav)) = match ready {
        Ok(ready) => ready,
        Err(e) => {
            let _ = feed.finish();
            return Err((e, false));
        }
    };
    let names = (inputs.imu_name(config), inputs.gnss_name(config));
    let notes = match inputs {
        Inputs::Recording { notes, .. } => notes.clone(),
        _ => Vec::new(),
    };
    let plan = match persisting {
        Some(_) => FixErrorPlan::Persisting,
        None => GnssAtStart::of_fixes(config, prefix.fixes().iter()).plan(config),
    };
    let probe = plan.probes().then_some(plan);
    let persisting_probe = persisting;
    let persisting = plan == FixErrorPlan::Persisting;
    let inputs = Opened {
        feed,
        gnss,
        prefix,
        checks,
        out: &mut out,
        nav,
        probe,
        found: persisting_probe,
        start: &start,
    };
    let result = run_kind(config.state_kind(persisting), config, strategy, names, progress, inputs);
    match result {
        Ok(mut summary) => {
            // the recording's notes, the start's report, then what the checks run beside
            // add to it (they repeat the static start's lines)
            let mut beside = std::mem::take(&mut summary.start);
            beside.retain(|l| !start.report.contains(l));
            summary.start = notes.into_iter().chain(start.report).chain(beside).collect();
            Ok((summary, out))
        }
        Err(e) => Err((e, true)),
    }
}

/// The IMU feed (replayed from memory, or read on a thread of its own), the GNSS reader,
/// and the checks beside the filter when the start only checks (`look`): with the whole
/// initial state and noise given, the data's first seconds are only checked (the start
/// changes nothing but the noise floor, which needs only the static start), on a copy of
/// them the feed tees, and a refusal stops the run; otherwise the filter waits for the
/// start ([`Look::of`]).
fn open_feed(
    config: &Config,
    inputs: &Inputs,
    replay: Option<&std::sync::Arc<ImuRecording>>,
    look: Look,
) -> Result<(ImuFeed, AidReader, Option<Checks>), RunError> {
    let (imu, gnss) = match replay {
        Some(r) => (Err(r.clone()), open_aid(config, inputs)?),
        None => open_inputs(config, inputs).map(|(i, g)| (Ok(i), g))?,
    };
    let feed_of = |tee| match imu {
        Ok(imu) => ImuFeed::spawn(imu, tee),
        Err(r) => ImuFeed::replay(r, tee),
    };
    if config.align.checks && look != Look::Span {
        let (tee, prefix) = std::sync::mpsc::channel();
        let checks = Checks::spawn(config, inputs, prefix)?;
        Ok((feed_of(Some(tee)), gnss, Some(checks)))
    } else {
        Ok((feed_of(None), gnss, None))
    }
}

/// [`run_into`] with the state type of `kind`.
fn run_kind<O: Sink>(
    kind: StateKind,
    config: &Config,
    strategy: AnyStrategy,
    names: (PathBuf, PathBuf),
    progress: Option<Progress<'_>>,
    inputs: Opened<'_, O>,
) -> Result<RunSummary, RunError> {
    let (c, s, n, p, i) = (config, strategy, names, progress, inputs);
    match kind {
        StateKind::Calibration => run_into::<InsStateCal, O>(c, s, n, p, i),
        StateKind::Tight21 => run_into::<InsStateTc21, O>(c, s, n, p, i),
        StateKind::Tight15 => run_into::<InsStateTc, O>(c, s, n, p, i),
        StateKind::Persisting21 => run_into::<InsState21Fe, O>(c, s, n, p, i),
        StateKind::Persisting15 => run_into::<InsStateFe, O>(c, s, n, p, i),
        StateKind::Ins21 => run_into::<InsState21, O>(c, s, n, p, i),
        StateKind::Ins15 => run_into::<InsState, O>(c, s, n, p, i),
    }
}

/// What [`run_into`] runs on: the inputs opened and the outputs created, and whether
/// the fixes' errors are probed.
struct Opened<'o, O: Sink> {
    feed: ImuFeed,
    gnss: AidReader,
    prefix: Prefix<'o>,
    checks: Option<Checks>,
    out: &'o mut O,
    nav: O::Nav,
    probe: Option<FixErrorPlan>,
    /// The probe whose noise scale is the prior (a run with the persisting part).
    found: Option<FixErrorProbe>,
    /// What the start found: the initial state, the IMU noise, the static start's end
    /// (ZARU over it).
    start: &'o Start,
}

/// `probe`: the plan whose fixes' errors are probed ([`FixErrorPlan::probes`]): once the
/// first [`PROBE_FIXES`] fixes have been learned from, the run stops with
/// [`RunError::FixErrorsProbed`] for the bank to judge their model if the plan
/// [`judges`](FixErrorPlan::judges) them, and goes on otherwise.
fn run_into<S: RunState, O: Sink>(
    config: &Config,
    strategy: AnyStrategy,
    names: (PathBuf, PathBuf),
    mut progress: Option<Progress<'_>>,
    opened: Opened<'_, O>,
) -> Result<RunSummary, RunError>
where
    DefaultAllocator: DimAlloc<S::Dim>,
    estimator_core::Cov<S::Dim>: Send,
{
    let wall = Instant::now();
    let Opened { feed, mut gnss, prefix, mut checks, out, nav: nav_sink, probe, found, start } =
        opened;
    // Start: the configured time, or the first IMU sample (the prefix holds one at
    // least); samples up to it are skipped.
    let Prefix { batches: first_batches, gnss: first_epochs, .. } = prefix;
    let at = gnss_at_start(config, start.time, &first_epochs, found);
    let started = start_navigator::<S>(config, start, strategy, &at)?;
    let tight = gnss.tight().cloned();
    let rtk = gnss.rtk().map(|s| rtk_aid::RtkAid::new(s, Vector3::from(config.gnss.lever_arm)));
    let mut pass = Pass::<S, O>::new(config, started, out, probe, at, tight, rtk)?;
    let locate = Locate { imu: names.0, gnss: names.1 };

    // what the checks beside the filter report (an offset named, not refused)
    let mut beside = Vec::new();
    std::thread::scope(|scope| -> Result<(), RunError> {
        // States, not records: the writer thread does the Euler conversion.
        let (rows, nav_rx) =
            std::sync::mpsc::sync_channel::<Vec<(f64, ins_gnss_core::InsState)>>(4);
        let writer = scope.spawn(move || write_rows(nav_sink, nav_rx));
        let result = GnssQueue::new(first_epochs, &mut gnss).and_then(|mut queue| {
            let messages = first_batches.into_iter().map(Ok).chain(feed.batches.iter());
            let r = (|| {
                for message in messages {
                    // a refusal by the checks stops the run
                    if checks.as_ref().is_some_and(Checks::done) {
                        beside.extend(checks.take().map_or(Ok(Vec::new()), Checks::join)?);
                    }
                    for (sample, imu_line) in message? {
                        match pass.step(&sample, imu_line, &mut queue, &rows, &locate)? {
                            Flow::Stop => return Ok(()),
                            Flow::Skipped => {}
                            Flow::Filtered => {
                                if pass.summary.imu_epochs.is_multiple_of(2000)
                                    && let Some(p) = progress.as_mut()
                                {
                                    p(sample.t);
                                }
                            }
                        }
                    }
                }
                Ok(())
            })();
            pass.summary.gnss_span = queue.span;
            if r.is_ok() {
                pass.flush_rows(&rows);
            }
            r
        });
        drop(rows);
        let written =
            writer.join().map_err(|_| RunError::NoData("the writer thread panicked".into()))?;
        pass.summary.imu_skipped = feed.finish()?;
        // the checks' verdict first: a refused input explains a failed run
        beside.extend(checks.take().map_or(Ok(Vec::new()), Checks::join)?);
        if let Err(RunError::FixErrorsProbed(_)) = result {
            // the run starts again after the bank: an output this stretch could not write
            // (a full disk) is reported now, not after the bank's passes
            let _ = written?;
            pass.out.flush()?;
            return result;
        }
        result?;
        pass.out.nav_done(written?);
        Ok(())
    })?;
    pass.summary.start = beside;
    let mut summary = pass.finish(config, &gnss, &locate)?;
    summary.wall_time = wall.elapsed().as_secs_f64();
    Ok(summary)
}

/// The writer thread's work: the rows `rows` brings, written as they come.
fn write_rows<N: NavSink>(
    mut w: N,
    rows: std::sync::mpsc::Receiver<Vec<(f64, InsState)>>,
) -> Result<N, RunError> {
    for batch in rows {
        w.rows(&batch)?;
    }
    w.finish()?;
    Ok(w)
}

/// What the GNSS said at the start (`t0`): the fixes read with the prefix, the receiver
/// clock of the first raw epoch after the start with a single point, and the probe's
/// noise factor (a run with the fixes' persisting part).
fn gnss_at_start(
    config: &Config,
    t0: f64,
    first: &std::collections::VecDeque<(AidEpoch, usize)>,
    found: Option<FixErrorProbe>,
) -> GnssAtStart {
    let clock = first
        .iter()
        .filter(|(a, _)| a.t > t0 + 1e-9)
        .find_map(|(a, _)| a.raw.as_ref().and_then(|r| r.1));
    GnssAtStart {
        clock,
        fix_factor: found.map(|f| f.factor),
        ..GnssAtStart::of_fixes(config, first.iter().filter_map(|(a, _)| a.fix.as_ref()))
    }
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

/// The calibration states as the navigator estimated them (a state that carries them).
pub(crate) fn calibration_learned<S: NavState>(
    config: &Config,
    nav: &Navigator<RunStrategy, S>,
) -> Option<CalibrationLearned>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let x = nav.state().calibration_states()?;
    let k = InsStateCal::CAL.start();
    let (lever, offset) = (x.lever_arm(), x.time_offset());
    let c = &config.calibrate;
    let sigma = |i: usize| nav.covariance()[(k + i, k + i)].max(0.0).sqrt();
    let applied = config.data.imu_time_offset;
    // the mounting as the configuration writes it: `C_vb = Exp(μ) C₀`, its roll, pitch, yaw
    let mounting = c.mounting.then(|| {
        let c0 = config.vehicle.nhc.as_ref().map_or([0.0; 3], |n| n.mounting);
        let c0 = ins_gnss_core::vehicle::mounting_matrix(&Vector3::from(c0).map(f64::to_radians));
        let rot = manifolds::So3::exp(&x.mounting()).matrix() * c0;
        let (r, p, y) = manifolds::So3::from_matrix(&rot).euler();
        let deg = |v: f64| v.to_degrees();
        let s = Vector3::new(deg(sigma(4)), deg(sigma(5)), deg(sigma(6)));
        (Vector3::new(deg(r), deg(p), deg(y)), s, c.mounting_std)
    });
    Some(CalibrationLearned {
        lever_arm: c
            .lever_arm
            .then(|| (lever, Vector3::new(sigma(0), sigma(1), sigma(2)), c.lever_arm_std)),
        // (the stamps as read are the file's shifted by `applied`: late by `offset` on
        // them, late by `offset − applied` as the file has them)
        time_offset: c
            .time_offset
            .then(|| (offset - applied, sigma(3), c.time_offset_std, applied)),
        mounting,
        odometer: c.odometer.then(|| {
            let s = Vector3::new(sigma(8), sigma(9), sigma(10));
            let scale = (x.odometer_scale(), sigma(7), c.odometer_scale_std / 100.0);
            (scale, (x.odometer_lever_arm(), s, c.odometer_lever_arm_std))
        }),
    })
}
