//! The start behind one interface: a [`Starter`] is fed the data's first IMU samples and
//! GNSS fixes as they are read until it holds all it looks at, then decides the
//! [`Start`]. What it looks at (nothing, the static start, or the span of the in-motion
//! fit) and where that span ends are its own rules; the run only feeds it.

use super::*;

/// How much of the data's start the start looks at before the filter starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Look {
    /// The first sample: the initial state and noise are given, nothing is found from
    /// the data (the checks, when on, run beside the filter).
    First,
    /// Until the static start ends: the noise floor (`prepare_floor`).
    StaticStart,
    /// All `prepare` looks at (`span_end`).
    Span,
}

impl Look {
    /// What a run of `config` must look at before its filter starts: the span when a part
    /// of the initial state or noise is found from the data (or the time offset
    /// calibrated: the start's search runs before the filter, which starts on the stamps
    /// it corrects), the static start for the noise floor, else the first sample.
    pub fn of(config: &Config) -> Self {
        if config.start_fills() || config.calibrate.time_offset {
            Look::Span
        } else if config.start_floors() {
            Look::StaticStart
        } else {
            Look::First
        }
    }
}

/// The run's start time: the configured one, or the first IMU sample's `first_t`.
pub fn start_time(config: &Config, first_t: f64) -> f64 {
    config.data.start_time.unwrap_or(first_t)
}

/// The start, fed the data's first samples and fixes until it holds all it looks at
/// ([`Starter::has_all`]), then [`Starter::decide`]d. It keeps the samples from the first
/// one (up to the first past the furthest `prepare` may look: `align.max_time` after
/// the start time and a static start of up to [`STATIC_ALLOWANCE`]) and the fixes.
pub struct Starter<'c> {
    config: &'c Config,
    look: Look,
    /// The start time, s.
    t0: f64,
    /// The furthest it may look, s.
    cap: f64,
    /// Where [`prepare`] stops looking, once known ([`span_end`]).
    end: Option<f64>,
    /// The sample count at which `span_end` (which reads every sample so far) is next
    /// asked: at doubling counts, its work over a long static start stays linear.
    next: usize,
    imu: Vec<ImuSample>,
    fixes: Vec<GnssEpoch>,
}

impl<'c> Starter<'c> {
    /// A start looking at `look` of the data whose first IMU sample is at `first_t`.
    pub fn new(config: &'c Config, look: Look, first_t: f64) -> Self {
        let t0 = start_time(config, first_t);
        let cap = t0 + config.align.max_time + STATIC_ALLOWANCE;
        Self { config, look, t0, cap, end: None, next: 0, imu: Vec::new(), fixes: Vec::new() }
    }

    /// The start time, s.
    pub fn time(&self) -> f64 {
        self.t0
    }

    /// What it looks at.
    pub fn look(&self) -> Look {
        self.look
    }

    /// The time of the last sample it took, s.
    pub fn last_sample(&self) -> Option<f64> {
        self.imu.last().map(|s| s.t)
    }

    /// The fixes it was given.
    pub fn fixes(&self) -> &[GnssEpoch] {
        &self.fixes
    }

    /// Keep the samples of one batch, up to the first past the furthest it may look (only
    /// the first sample when it looks at nothing else); whether it wants no more samples
    /// for having passed that.
    pub fn take_samples(&mut self, batch: impl IntoIterator<Item = ImuSample>) -> bool {
        if self.look == Look::First {
            if self.imu.is_empty() {
                self.imu.extend(batch.into_iter().next());
            }
            return true;
        }
        for s in batch {
            self.imu.push(s);
            if s.t > self.cap {
                return true;
            }
        }
        false
    }

    /// Keep the fixes read with the samples.
    pub fn take_fixes(&mut self, fixes: impl IntoIterator<Item = GnssEpoch>) {
        self.fixes.extend(fixes);
    }

    /// Whether the samples and fixes taken (the fixes up to the first epoch past the last
    /// sample) hold all it looks at: for the span, up to `span_end` (known once the
    /// static start has ended) as `reaches` says; for the static start, once it has
    /// ended inside the samples; always for the first sample; and always once the samples
    /// pass the furthest it may look.
    pub fn has_all(&mut self) -> bool {
        let Some(last) = self.imu.last() else { return false };
        if self.look == Look::First || last.t > self.cap {
            return true;
        }
        let (config, imu, fixes) = (self.config, &self.imu[..], &self.fixes[..]);
        match self.look {
            Look::Span => {
                if self.end.is_none() && imu.len() >= self.next {
                    self.next = 2 * imu.len();
                    self.end = span_end(config, imu, fixes, self.t0);
                }
                self.end.is_some_and(|end| reaches(imu, self.t0, end))
            }
            _ => {
                let still = still_imu_span(config, imu, fixes, self.t0);
                still.samples == 0 || still.span.1 < last.t - config.align.static_window
            }
        }
    }

    /// The start from what it was fed: the initial state and noise of the configuration,
    /// completed and checked as `look` says. The error names the key to change.
    pub fn decide(&self) -> Result<Start, String> {
        let (config, imu, gnss, t0) = (self.config, &self.imu[..], &self.fixes[..], self.t0);
        Ok(match self.look {
            Look::Span => prepare(config, imu, gnss, t0)?,
            Look::StaticStart => prepare_floor(config, imu, gnss, t0),
            Look::First => Start::given(config, t0),
        })
    }
}

/// The start of a run over samples and fixes in memory (`imu` and `gnss` whole), looking
/// at the whole span `prepare` may look at: the samples up to the furthest it may look
/// and the fixes up to then, fed at once.
pub fn start_on(config: &Config, imu: &[ImuSample], gnss: &[GnssEpoch]) -> Result<Start, String> {
    let first_t = imu.first().map_or(0.0, |s| s.t);
    let mut starter = Starter::new(config, Look::Span, first_t);
    let cap = starter.cap;
    let n_imu = imu.partition_point(|s| s.t <= cap + 1e-9);
    let n_gnss = gnss.partition_point(|e| e.t <= cap + 1e-9);
    starter.imu.extend_from_slice(&imu[..n_imu]);
    starter.take_fixes(gnss[..n_gnss].iter().cloned());
    starter.decide()
}
