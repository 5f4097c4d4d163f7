//! The states a run can use (15, 21, tight coupling) and the navigator at the start.

use super::*;

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

    /// The position variances (N, E, D; m²) the reported σ does not go below (tight
    /// coupling's [`Navigator::satellite_floor`]); `None` for the others.
    fn position_floor(nav: &Navigator<RunStrategy, Self>) -> Option<[f64; 3]> {
        let _ = nav;
        None
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

/// The receiver clock a tight run starts with: the single point's clock (its σ a few
/// metres; the drift from the Dopplers that follow), or, none found before the start,
/// 1 ms.
fn clock_init(clock: Option<f64>) -> ClockInit {
    match clock {
        Some(b) => ClockInit { clock: (b, 0.0), std: (30.0, 100.0), isb_std: 30.0 },
        None => ClockInit { clock: (0.0, 0.0), std: (3.0e5, 100.0), isb_std: 30.0 },
    }
}

fn clock_noise(config: &Config) -> ClockNoise {
    ClockNoise { drift: config.gnss.tight.clock_drift_noise, ..Default::default() }
}

/// What the two tight states share: the raw epochs' updates, every satellite update a
/// fix for `nav.pos`, the satellites' error floor.
macro_rules! tight_run_state {
    () => {
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
                Some(cfg) => {
                    nav.process_raw_recorded(imu, raw, cfg, &mut NoObserver, out, recorder)
                }
                // (a tight run always has its models: no satellite without them)
                None => nav.process_recorded(imu, &[], &mut NoObserver, out, recorder),
            }
        }

        fn is_fix(stream: estimator_core::StreamId) -> bool {
            !VEHICLE_STREAMS.contains(&stream)
        }

        fn position_floor(nav: &Navigator<RunStrategy, Self>) -> Option<[f64; 3]> {
            nav.satellite_floor().map(|f| [f[(0, 0)], f[(1, 1)], f[(2, 2)]])
        }
    };
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
        let model = InsModelTc { base, clock: clock_noise(config) };
        let init = config.initial_state(start);
        Navigator::new_tight(&init, &clock_init(clock), model, strategy, config.gnss_config())
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        None
    }

    tight_run_state!();
}

/// Tight coupling with 21 states: the scale factors as well.
impl RunState for InsStateTc21 {
    const SIGMA_COLUMNS: usize = 21;

    fn navigator(
        config: &Config,
        strategy: RunStrategy,
        start: f64,
        clock: Option<f64>,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let base = InsModel { mechanization: config.mechanization(), noise: config.imu_noise() };
        let base = InsModel21 { base, scale: config.scale_factor_noise() };
        let model = InsModelTc21 { base, clock: clock_noise(config) };
        let init = config.initial_state(start);
        let (scale, gnss) = (config.scale_init(), config.gnss_config());
        Navigator::new_tight21(&init, &scale, &clock_init(clock), model, strategy, gnss)
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        Some((self.nav.sg, self.nav.sa))
    }

    tight_run_state!();
}

/// The navigator at the start time (the configured one, or the first IMU sample's
/// `first_t`), the run's summary with its span started there, and the end time.
pub(crate) fn start_navigator<S: RunState>(
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
    let nav = S::navigator(config, strategy, start, clock)?
        .with_vehicle_aiding(config.vehicle_aiding())
        .with_covariance_interval(config.filter.covariance_interval);
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
