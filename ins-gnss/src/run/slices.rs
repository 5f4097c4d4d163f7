//! Runs over data in memory ([`load_inputs`], [`run_slices`]): Monte Carlo and strategy sweeps.

use super::*;

/// Read the configured IMU and GNSS files whole, with the same checks and skip policy as
/// [`run`], for repeated in-memory runs ([`run_slices`]): Monte Carlo over injected
/// errors, strategy sweeps. Memory grows with the dataset (≈ 64 bytes per IMU sample).
pub fn load_inputs(config: &Config) -> Result<(Vec<ImuSample>, Vec<GnssEpoch>), RunError> {
    if config.gnss.coupling.is_raw() {
        return Err(bad_map(
            "gnss.coupling",
            "in-memory slices hold fixes (loose coupling); a tight or RTK run goes through `run`"
                .into(),
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
    // (slices run once: a probed plan stays white here; `run` probes)
    let plan = GnssAtStart::of_fixes(config, gnss.iter()).plan(config);
    let persisting = plan == crate::config::FixErrorPlan::Persisting;
    // (in-memory slices hold fixes: a tight configuration runs loosely coupled here)
    match config.state_kind(persisting) {
        StateKind::Calibration => run_slices_on::<InsStateCal>(config, strategy, imu, gnss, each),
        StateKind::Persisting21 => run_slices_on::<InsState21Fe>(config, strategy, imu, gnss, each),
        StateKind::Persisting15 => run_slices_on::<InsStateFe>(config, strategy, imu, gnss, each),
        StateKind::Ins21 | StateKind::Tight21 => {
            run_slices_on::<InsState21>(config, strategy, imu, gnss, each)
        }
        StateKind::Ins15 | StateKind::Tight15 => {
            run_slices_on::<InsState>(config, strategy, imu, gnss, each)
        }
    }
}

pub(crate) fn run_slices_on<S: RunState>(
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
    if imu.is_empty() {
        return Err(RunError::NoData("no IMU samples".into()));
    }
    let start = crate::start::start_on(config, imu, gnss).map_err(RunError::Start)?;
    let at = GnssAtStart::of_fixes(config, gnss.iter());
    let (mut nav, mut summary, end) = start_navigator::<S>(config, &start, strategy, &at)?;
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
    summary.odometer_reversed = nav.odometer_reversed();
    summary.learned = nav.filter().strategy().learned().collect();
    summary.fix_errors = fix_errors_learned(&nav);
    summary.wall_time = wall.elapsed().as_secs_f64();
    Ok(summary)
}
