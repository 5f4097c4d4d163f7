//! A run that starts again: on stamps shifted by the time offset its start found, with the
//! fixes' error model the bank chose, or with the offset the filter refined; each attempt
//! is [`attempt`].

use super::*;

/// [`run`]'s work on any inputs into any sink, created by `create` once the start is
/// known (a refused start creates nothing). An error says whether the sink was created.
///
/// A run whose fixes' errors are probed ([`FixErrorPlan::Probe`]) has their model judged
/// by a bank of runs ([`judge_fix_errors`]) and starts again, from the beginning, with
/// the one chosen (the sink created anew).
pub(super) fn run_with<O: Sink>(
    config: &Config,
    strategy: AnyStrategy,
    inputs: &Inputs,
    mut progress: Option<Progress<'_>>,
    mut create: impl FnMut() -> Result<(O, O::Nav), RunError>,
) -> Result<(RunSummary, O), (RunError, bool)> {
    let again = progress.as_mut().map(|p| &mut **p as Progress<'_>);
    // the start decided once for the attempts it serves (the bank's, the run after it)
    let memo = StartMemo::default();
    let shared = Shared { replay: None, start: Some(&memo) };
    let first = attempt(config, strategy.clone(), inputs, again, &mut create, None, shared);
    // the start's lines of the attempts that started again
    let mut lines = Vec::new();
    // a time offset the start found and calibration applies: again, on shifted stamps
    let mut shifted = None;
    let first = match first {
        Err((RunError::TimeOffsetApplied(offset, found), _)) => {
            let c = config.with_imu_time_offset(offset);
            lines.extend(found);
            let again = progress.as_mut().map(|p| &mut **p as Progress<'_>);
            let run =
                settled(attempt(&c, strategy.clone(), inputs, again, &mut create, None, shared));
            shifted = Some(c);
            run
        }
        other => other,
    };
    let config = shifted.as_ref().unwrap_or(config);
    let result = match first {
        Err((RunError::FixErrorsProbed(probe), _)) => {
            let (chosen, bank) = judge_fix_errors(config, &strategy, inputs, probe, &memo);
            let again = progress.as_mut().map(|p| &mut **p as Progress<'_>);
            // (the white model chosen: a white run, which does not probe again)
            let white = bank.is_some_and(|b| b.white_chosen());
            let (c, prior) = match &chosen {
                Some(c) if white => (c, None),
                Some(c) => (c, Some(white_prior(probe))),
                None => (config, Some(probe)),
            };
            let (mut summary, out) =
                attempt(c, strategy.clone(), inputs, again, &mut create, prior, shared)?;
            if let Some(f) = summary.fix_errors.as_mut() {
                f.probe = Some(probe);
            }
            summary.fix_bank = bank;
            Ok((summary, out))
        }
        other => other,
    };
    // The time offset the filter estimated: its outputs are on the IMU's stamps as
    // shifted, off the receiver's clock by what the state found. Beyond its 3σ and
    // `TIME_OFFSET_REFINED`, the run is made again with it applied to the stamps, so that
    // `nav.txt` and the rest are on the receiver's clock.
    let result = match result {
        Ok((summary, out)) => match summary.calibration.and_then(|c| c.time_offset) {
            Some((late, sigma, _, applied))
                if (late + applied).abs() > (3.0 * sigma).max(TIME_OFFSET_REFINED) =>
            {
                let c = config.with_imu_time_offset(-late);
                lines.push(format!(
                    "IMU–GNSS time offset: the filter found the IMU's stamps {:.4} s (σ {:.4} s) \
                     off the receiver's clock after the {applied:.3} s applied: run again with \
                     `data.imu_time_offset = {:.4}`, its outputs on the receiver's clock",
                    late + applied,
                    sigma,
                    -late
                ));
                settled(attempt(&c, strategy, inputs, progress, &mut create, None, shared))
            }
            _ => Ok((summary, out)),
        },
        other => other,
    };
    result.map(|(mut summary, out)| {
        summary.start.splice(0..0, lines);
        (summary, out)
    })
}

/// An attempt on stamps already shifted: a start that would shift them again (its search
/// and the filter disagree, or the turns fit two offsets) is refused, not run a third way.
fn settled<T>(r: Result<T, (RunError, bool)>) -> Result<T, (RunError, bool)> {
    match r {
        Err((RunError::TimeOffsetApplied(offset, _), created)) => Err((
            RunError::Start(format!(
                "`calibrate.time_offset`: on the IMU's stamps shifted by the offset found, the \
                 start's search finds another ({offset:.3} s for `data.imu_time_offset`): the \
                 gyro's turns fit the GNSS course at two offsets; set `data.imu_time_offset` \
                 to the right one"
            )),
            created,
        )),
        other => other,
    }
}

/// The time offset (s) the calibration state must find beyond its 3σ for a run to be
/// made again with it applied to the IMU's stamps (a millisecond moves a car's position
/// by 2 cm at 20 m/s).
pub const TIME_OFFSET_REFINED: f64 = 0.001;
