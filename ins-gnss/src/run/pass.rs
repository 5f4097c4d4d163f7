//! One pass of the filter over the opened inputs ([`run_into`](super::run_into)'s
//! steps): the GNSS epochs queued in time order, each IMU sample filtered with the epochs
//! of its interval, the rows written as they come, and the summary finished at the end.

use super::*;

/// The GNSS epochs in time order: first those read with the start's prefix, then the
/// reader's; the times of the first and last read.
pub(super) struct GnssQueue<'g> {
    first: std::collections::VecDeque<(AidEpoch, usize)>,
    reader: &'g mut AidReader,
    next: Option<(AidEpoch, usize)>,
    /// The first and last epoch's times read (NaN before the first).
    pub(super) span: (f64, f64),
    /// The epochs of the current sample's interval: fixes, raw epochs, and (time, line)
    /// of each, 0 for an epoch not from a text file.
    fixes: Vec<GnssEpoch>,
    raws: Vec<RawEpoch>,
    lines: Vec<(f64, usize)>,
    /// RTK: the interval's rover epochs (their single point, and the base epoch paired
    /// with them if any), for the RTK filter before the INS takes its fixes.
    rtks: Vec<(Option<GnssEpoch>, Option<Box<super::aid::RtkPair>>)>,
    rtk: bool,
}

impl<'g> GnssQueue<'g> {
    pub(super) fn new(
        first: std::collections::VecDeque<(AidEpoch, usize)>,
        reader: &'g mut AidReader,
    ) -> Result<Self, RunError> {
        let rtk = reader.rtk().is_some();
        let mut q = Self {
            first,
            rtk,
            rtks: Vec::new(),
            reader,
            next: None,
            span: (f64::NAN, f64::NAN),
            fixes: Vec::with_capacity(4),
            raws: Vec::new(),
            lines: Vec::with_capacity(4),
        };
        q.next = q.read()?;
        Ok(q)
    }

    fn read(&mut self) -> Result<Option<(AidEpoch, usize)>, RunError> {
        let g = match self.first.pop_front() {
            Some(g) => Some(g),
            None => self.reader.next_epoch()?.map(|g| (g, self.reader.line())),
        };
        if let Some((g, _)) = &g {
            if self.span.0.is_nan() {
                self.span.0 = g.t;
            }
            self.span.1 = g.t;
        }
        Ok(g)
    }

    /// Take the epochs up to `t` (those after `start` into the interval's lists, the
    /// first fix into `first_fix`).
    fn take_until(
        &mut self,
        t: f64,
        start: f64,
        first_fix: &mut Option<GnssEpoch>,
    ) -> Result<(), RunError> {
        self.fixes.clear();
        self.raws.clear();
        self.lines.clear();
        self.rtks.clear();
        while self.next.as_ref().is_some_and(|(g, _)| g.t <= t + 1e-9) {
            let Some((g, line)) = self.next.take() else { break };
            if g.t > start + 1e-9 {
                if let Some(fix) = g.fix {
                    first_fix.get_or_insert(fix);
                }
                if self.rtk {
                    // (RTK: the single point was the start's first fix; the RTK filter
                    // decides what the INS takes)
                    self.rtks.push((g.fix, g.rtk));
                } else if let Some(fix) = g.fix {
                    // (raw epochs: their single points served the start and this first
                    // fix; the filter takes the satellites)
                    self.reader.skip_single_points();
                    self.fixes.push(fix);
                }
                self.raws.extend(g.raw.map(|r| r.0));
                self.lines.push((g.t, line));
            }
            self.next = self.read()?;
        }
        Ok(())
    }
}

/// Which record a failure belongs to: the GNSS epoch whose update failed (by its line in
/// the GNSS file), or the IMU sample whose prediction did.
pub(super) struct Locate {
    pub(super) imu: PathBuf,
    pub(super) gnss: PathBuf,
}

impl Locate {
    fn error(&self, e: NavError, imu_line: usize, lines: &[(f64, usize)]) -> RunError {
        match &e {
            NavError::Measurement { t, .. } => {
                match lines.iter().find(|(tg, line)| (tg - t).abs() < 1e-6 && *line > 0) {
                    Some((_, line)) => {
                        RunError::Located { path: self.gnss.clone(), line: *line, error: e }
                    }
                    None => RunError::Navigation(e),
                }
            }
            _ => RunError::Located { path: self.imu.clone(), line: imu_line, error: e },
        }
    }
}

/// What a sample's step says of the pass: filtered, skipped (at or before the start
/// time), or stop (the end time passed, or the writer gone).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Flow {
    Filtered,
    Skipped,
    Stop,
}

/// The filter over the samples: the navigator and the run's summary, the smoother's
/// records, the outputs, and the rows on their way to the writer.
pub(super) struct Pass<'o, S: RunState, O: Sink>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    pub(super) nav: Navigator<RunStrategy, S>,
    pub(super) summary: RunSummary,
    pub(super) recorder: Option<Recorder<S, O::Store>>,
    /// (tight coupling, smoothing) the reported position σ floors over time
    pub(super) floors: Floors,
    pub(super) out: &'o mut O,
    /// The start and end times, s.
    pub(super) span: (f64, f64),
    /// The plan whose fixes' errors are probed: the pass stops once the probe has learned
    /// what the plan judges ([`FixErrorPlan::judges`]; `None`: not probed, or the probe
    /// learned and the pass goes on).
    pub(super) probe: Option<crate::config::FixErrorPlan>,
    pub(super) at: GnssAtStart,
    pub(super) tight: Option<TightConfig>,
    /// RTK's filter (`gnss.coupling = "rtk"`).
    pub(super) rtk: Option<super::rtk_aid::RtkAid>,
    last_std: f64,
    records: Vec<(f64, InsState)>,
    updates: Vec<UpdateSummary>,
}

impl<'o, S: RunState, O: Sink> Pass<'o, S, O>
where
    DefaultAllocator: DimAlloc<S::Dim>,
    estimator_core::Cov<S::Dim>: Send,
{
    /// The pass from the navigator at the start (`nav`, `summary` from
    /// [`start_navigator`], `end` the end time), the smoother's records when the
    /// configuration smooths.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        config: &Config,
        started: (Navigator<RunStrategy, S>, RunSummary, f64),
        out: &'o mut O,
        probe: Option<crate::config::FixErrorPlan>,
        at: GnssAtStart,
        tight: Option<TightConfig>,
        rtk: Option<super::rtk_aid::RtkAid>,
    ) -> Result<Self, RunError> {
        let (nav, summary, end) = started;
        // (the exact mode keeps the step-by-step adjoint: its outputs stay those of
        // earlier builds byte for byte; the two agree to rounding,
        // `docs/history/benches.md`)
        let adjoint = if config.filter.covariance_interval > 0.0 {
            estimator_core::AdjointForm::Accumulated
        } else {
            estimator_core::AdjointForm::PerStep
        };
        let recorder = if config.filter.smooth {
            Some(
                out.recorder::<S>()?
                    .with_adjoint_form(adjoint)
                    .with_replayed_priors(config.filter.smooth_low_scratch),
            )
        } else {
            None
        };
        Ok(Self {
            span: (summary.span.0, end),
            nav,
            summary,
            recorder,
            floors: Floors::default(),
            out,
            probe,
            at,
            tight,
            rtk,
            last_std: f64::NEG_INFINITY,
            records: Vec::with_capacity(BATCH),
            updates: Vec::with_capacity(4),
        })
    }

    /// One IMU sample (line `imu_line`) with the GNSS epochs of its interval: filtered,
    /// its row sent to the writer (`rows`), its updates and σ written.
    pub(super) fn step(
        &mut self,
        sample: &ImuSample,
        imu_line: usize,
        gnss: &mut GnssQueue<'_>,
        rows: &std::sync::mpsc::SyncSender<Vec<(f64, InsState)>>,
        locate: &Locate,
    ) -> Result<Flow, RunError> {
        let (start, end) = self.span;
        if sample.t <= start + 1e-9 {
            return Ok(Flow::Skipped);
        }
        if sample.t > end + 1e-9 {
            return Ok(Flow::Stop);
        }
        gnss.take_until(sample.t, start, &mut self.summary.first_fix)?;
        let rtk_quality = self.rtk_epochs(gnss, sample.t)?;
        self.updates.clear();
        S::process(
            &mut self.nav,
            sample,
            &gnss.fixes,
            &gnss.raws,
            self.tight.as_ref(),
            &mut self.updates,
            &mut self.recorder,
        )
        .map_err(|e| locate.error(e, imu_line, &gnss.lines))?;
        self.summary.imu_epochs += 1;
        if let (Some(_), Some(f)) = (&self.recorder, S::position_floor(&self.nav)) {
            self.floors.push(sample.t, f);
        }
        self.records.push((sample.t, self.nav.nav_state().clone()));
        if self.records.len() == BATCH
            && rows.send(std::mem::replace(&mut self.records, Vec::with_capacity(BATCH))).is_err()
        {
            return Ok(Flow::Stop);
        }
        self.summary.tally(&self.updates);
        for u in &self.updates {
            self.out.update(u)?;
        }
        if let (Some(plan), false) = (self.probe, self.updates.is_empty())
            && let Some(found) = probe_fix_errors(self.nav.filter().strategy(), &self.at)
        {
            if plan.judges(found.factor, found.lag_one) {
                return Err(RunError::FixErrorsProbed(found));
            }
            self.probe = None;
        }
        // after every update and RTK epoch, and once a second without (an outage's σ)
        if !self.updates.is_empty()
            || rtk_quality.is_some()
            || sample.t >= self.last_std + STD_EVERY - 1e-9
        {
            let q = self.nav_pos_quality(rtk_quality);
            self.out.epoch(sample.t, &self.nav, q)?;
            // the smoothed σ at the same epochs
            estimator_core::StepRecorder::<S, ImuInput>::mark_variances(&mut self.recorder);
            self.last_std = sample.t;
        }
        self.summary.span.1 = sample.t;
        Ok(Flow::Filtered)
    }

    /// `nav.pos`'s Q after this sample's updates, RTKLIB's: RTK's at its epochs
    /// (`rtk_quality`), 1 fixed and 2 float — 1 only where the INS took the fix as it is,
    /// not refused or its noise inflated by the gate; else 1 after a GNSS fix, 5 without.
    fn nav_pos_quality(&self, rtk_quality: Option<u8>) -> u8 {
        let fix = |ok: &dyn Fn(estimator_core::Verdict) -> bool| {
            self.updates.iter().any(|u| S::is_fix(u.stream) && ok(u.verdict))
        };
        use estimator_core::Verdict::{Accepted, Deflated, Rejected};
        match rtk_quality {
            Some(1) if !fix(&|v| matches!(v, Accepted | Deflated)) => 2,
            Some(q) => q,
            None if fix(&|v| v != Rejected) => 1,
            None => 5,
        }
    }

    /// RTK: the interval's rover epochs through the RTK filter around the INS's
    /// prediction, their fixes into `gnss.fixes` (in time order) for the INS; the
    /// interval's RTKLIB quality (1 when an epoch fixed, else 2; `None`: no RTK epoch).
    /// A fixed epoch's covariance is the smoothed position σ's floor from `t` on.
    fn rtk_epochs(&mut self, gnss: &mut GnssQueue<'_>, t: f64) -> Result<Option<u8>, RunError> {
        let Some(aid) = self.rtk.as_mut() else { return Ok(None) };
        let mut quality = None;
        let t_x = self.nav.time();
        for (spp, pair) in gnss.rtks.drain(..) {
            let Some(pair) = pair else {
                aid.unpaired();
                quality = quality.or(Some(2));
                continue;
            };
            let p9 = self.nav.covariance().fixed_view::<9, 9>(0, 0).into_owned();
            let step = aid.step(&pair, spp.as_ref(), self.nav.nav_state(), t_x, &p9);
            if let Some((p, v)) = &step.widen {
                self.nav.widen(p, v)?;
            }
            quality = Some(quality.map_or(step.quality, |q: u8| q.min(step.quality)));
            gnss.fixes.extend(step.fix);
            if let (Some(_), Some(f)) = (&self.recorder, step.floor) {
                self.floors.push(t, f);
            }
        }
        Ok(quality)
    }

    /// The rows not yet sent.
    pub(super) fn flush_rows(&mut self, rows: &std::sync::mpsc::SyncSender<Vec<(f64, InsState)>>) {
        let _ = rows.send(std::mem::take(&mut self.records));
    }

    /// The pass's end: the last σ written, the summary completed from the navigator and
    /// the GNSS reader, and the smoother's backward pass when it smooths.
    pub(super) fn finish(
        mut self,
        config: &Config,
        gnss: &AidReader,
        locate: &Locate,
    ) -> Result<RunSummary, RunError> {
        let summary = &mut self.summary;
        if summary.imu_epochs == 0 {
            return Err(RunError::NoData(format!(
                "no IMU sample after the start time {} s in {}",
                self.span.0,
                locate.imu.display()
            )));
        }
        summary.finish_streams();
        if let Some(aid) = &self.rtk {
            aid.check_base_overlap(config)?;
        }
        check_gnss_overlap(summary, &locate.gnss)?;
        self.out.epoch(summary.span.1, &self.nav, 5)?;
        estimator_core::StepRecorder::<S, ImuInput>::mark_variances(&mut self.recorder);
        self.out.flush()?;
        summary.gnss_skipped = gnss.skipped();
        summary.headings_unmatched = gnss.headings_unmatched();
        summary.gnss_sigma_from_hdop = gnss.sigma_from_hdop();
        summary.stationary_time = self.nav.stationary_time();
        summary.odometer_reversed = self.nav.odometer_reversed();
        summary.learned = self.nav.filter().strategy().learned().collect();
        summary.fix_errors = fix_errors_learned(&self.nav);
        summary.calibration = calibration_learned(config, &self.nav);
        summary.rtk = self.rtk.as_ref().map(|a| RtkSummary {
            metrics: a.run.metrics(),
            gated: a.gated,
            base: a.run.base,
            notes: a.run.notes.clone(),
        });
        if let Some(recorder) = self.recorder {
            let backward = Instant::now();
            // (a covariance at a lower rate than the state: the backward pass starts from
            // now's)
            self.nav.settle_covariance()?;
            let rows = self.out.smoothed(recorder, &self.nav, &self.floors)?;
            self.summary.smoothed = Some((rows, backward.elapsed().as_secs_f64()));
        }
        Ok(self.summary)
    }
}
