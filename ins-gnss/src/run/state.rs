//! The states a run can use (15, 21, tight coupling) and the navigator at the start.

use super::*;
use ins_gnss_core::navigator::NavStart;

/// The states a run can use (`filter.states = 15 | 21`): how each starts and what it
/// writes beyond the 15-state columns.
pub trait RunState: NavState<Model: Sync> + estimator_core::Spill + Send + 'static
where
    DefaultAllocator: DimAlloc<Self::Dim>,
{
    /// The error states written to `std.txt` (the first ones).
    const SIGMA_COLUMNS: usize;

    /// The navigator from what the start found (`from`: the start time, the initial state
    /// and the IMU noise), with what the GNSS said at the start (`at`).
    fn navigator(
        config: &Config,
        from: &Start,
        strategy: RunStrategy,
        at: &GnssAtStart,
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
        from: &Start,
        strategy: RunStrategy,
        _at: &GnssAtStart,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let model = ins_model(config, from);
        Navigator::new(&from.initial_state(), model, strategy, config.gnss_config())
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        None
    }
}

impl RunState for InsState21 {
    const SIGMA_COLUMNS: usize = 21;

    fn navigator(
        config: &Config,
        from: &Start,
        strategy: RunStrategy,
        _at: &GnssAtStart,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let base = ins_model(config, from);
        let model = InsModel21 { base, scale: config.scale_factor_noise() };
        let init = from.initial_state();
        Navigator::new((&init, &config.scale_init()), model, strategy, config.gnss_config())
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        Some((self.sg, self.sa))
    }
}

/// The 15-state INS with the fixes' persisting error (`gnss.errors`).
impl RunState for InsStateFe {
    const SIGMA_COLUMNS: usize = 15;

    fn navigator(
        config: &Config,
        from: &Start,
        strategy: RunStrategy,
        at: &GnssAtStart,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let base = ins_model(config, from);
        let init = from.initial_state();
        let (fix, p_fix) = fix_error_start(config, at);
        let model = InsModelFe { base, fix };
        let (nav, p_nav) = (&init).state_and_covariance();
        let x = InsStateFe { nav, fix: Vector3::zeros() };
        let mut p = estimator_core::Cov::<nalgebra::Const<18>>::zeros();
        p.fixed_view_mut::<15, 15>(0, 0).copy_from(&p_nav);
        p.fixed_view_mut::<3, 3>(15, 15).copy_from(&p_fix);
        let strategy = strategy.without_learning_on(&ins_gnss_core::gnss::GNSS_STREAMS);
        Navigator::from_parts(x, p, init.time, model, strategy, config.gnss_config())
            .map(|n| n.with_fix_noise_prior(at.fix_factor.unwrap_or(1.0)))
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        None
    }
}

/// The 21-state INS with the fixes' persisting error (`gnss.errors`).
impl RunState for InsState21Fe {
    const SIGMA_COLUMNS: usize = 21;

    fn navigator(
        config: &Config,
        from: &Start,
        strategy: RunStrategy,
        at: &GnssAtStart,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let base = ins_model(config, from);
        let base = InsModel21 { base, scale: config.scale_factor_noise() };
        let init = from.initial_state();
        let (fix, p_fix) = fix_error_start(config, at);
        let model = InsModel21Fe { base, fix };
        let (nav, p_nav) = (&init, &config.scale_init()).state_and_covariance();
        let x = InsState21Fe { nav, fix: Vector3::zeros() };
        let mut p = estimator_core::Cov::<nalgebra::Const<24>>::zeros();
        p.fixed_view_mut::<21, 21>(0, 0).copy_from(&p_nav);
        p.fixed_view_mut::<3, 3>(21, 21).copy_from(&p_fix);
        let strategy = strategy.without_learning_on(&ins_gnss_core::gnss::GNSS_STREAMS);
        Navigator::from_parts(x, p, init.time, model, strategy, config.gnss_config())
            .map(|n| n.with_fix_noise_prior(at.fix_factor.unwrap_or(1.0)))
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        Some((self.nav.sg, self.nav.sa))
    }
}

/// The 15-state INS with the rig's calibration (`calibrate`): the lever arm starts
/// at `gnss.lever_arm`, the time offset at 0 on the (shifted) stamps, the mounting's
/// correction at 0 about `vehicle.nhc.mounting`, each with its prior σ; an item off is
/// never updated.
impl RunState for InsStateCal {
    const SIGMA_COLUMNS: usize = 15;

    fn navigator(
        config: &Config,
        from: &Start,
        strategy: RunStrategy,
        _at: &GnssAtStart,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let base = ins_model(config, from);
        let c = &config.calibrate;
        let model = InsModelCal { base, calibration: c.calibration() };
        let init = from.initial_state();
        let l = config.gnss.lever_arm;
        let odometer =
            config.vehicle.odometer.as_ref().map_or(Vector3::zeros(), |o| o.lever_arm.into());
        let x = InsStateCal::new(init.state.clone(), Vector3::from(l))
            .with_odometer_lever_arm(odometer);
        let mut p = estimator_core::Cov::<nalgebra::Const<26>>::zeros();
        p.fixed_view_mut::<15, 15>(0, 0).copy_from(&init.std.covariance());
        // the start's position is a fix's less the declared lever arm, `p = z − R l`: a
        // lever arm known to σ_l leaves the position known only to it too, and the two
        // correlated (`P_pp += σ_l² I`, `P_pl = −σ_l² R`). Left out, the prior says the
        // IMU sits at the antenna to the fix's σ, that is `l ≈ 0`, and the filter stays
        // between that and the data (the simulated drive's 1 m lever arm settled at half
        // its value, σ 2 cm).
        let var = c.lever_arm_std.powi(2);
        if c.lever_arm {
            let r = init.state.att.matrix();
            for i in 0..3 {
                p[(6 + i, 6 + i)] += var;
                for j in 0..3 {
                    p[(6 + i, 15 + j)] = -var * r[(i, j)];
                    p[(15 + j, 6 + i)] = -var * r[(i, j)];
                }
            }
        }
        for k in 0..3 {
            p[(15 + k, 15 + k)] = var;
        }
        p[(18, 18)] = c.time_offset_std.powi(2);
        for k in 19..22 {
            p[(k, k)] = c.mounting_std.to_radians().powi(2);
        }
        p[(22, 22)] = (c.odometer_scale_std / 100.0).powi(2);
        for k in 23..26 {
            p[(k, k)] = c.odometer_lever_arm_std.powi(2);
        }
        Navigator::from_parts(x, p, init.time, model, strategy, config.gnss_config())
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        None
    }
}

/// What the GNSS said at the start: the receiver clock `c·dt` (m) of the first raw
/// epoch's single point (tight coupling), and the σ (N, E, D; m) the fixes declare
/// (`gnss.position_std`, or the first fixes' own; loose coupling).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GnssAtStart {
    /// The first raw epoch's receiver clock, m.
    pub clock: Option<f64>,
    /// The σ the fixes declare, m.
    pub fix_std: Option<Vector3<f64>>,
    /// The variance factor a white model's innovations showed on the declared σ (a
    /// restarted run: the prior of both parts of the fixes' error split).
    pub fix_factor: Option<f64>,
}

impl GnssAtStart {
    /// From the configuration and the first fixes (their median σ per axis).
    pub fn of_fixes<'a>(config: &Config, fixes: impl Iterator<Item = &'a GnssEpoch>) -> Self {
        let fix_std = config.gnss.position_std.map(Vector3::from).or_else(|| {
            let mut s: Vec<Vector3<f64>> = fixes.take(20).map(|g| g.pos_std).collect();
            (!s.is_empty()).then(|| {
                Vector3::from_fn(|i, _| {
                    s.sort_by(|a, b| a[i].total_cmp(&b[i]));
                    s[s.len() / 2][i]
                })
            })
        });
        Self { clock: None, fix_std, fix_factor: None }
    }

    /// How the run models the fixes' errors (`gnss.errors`; tight coupling and RTK:
    /// white — RTK's fixes are what its double differences add to the INS prediction).
    pub fn plan(&self, config: &Config) -> crate::config::FixErrorPlan {
        // (the calibration states run on the white model: `validate` refuses
        // `persisting` with them)
        if config.gnss.coupling.is_raw() || config.calibrate.any() {
            return crate::config::FixErrorPlan::White;
        }
        config.gnss.errors.plan(self.fix_std.map(|s| s[0].max(s[1])))
    }
}

/// The fixes' persisting error at the start: its model (from the split of the declared
/// σ) and its covariance (the model's steady state).
fn fix_error_start(
    config: &Config,
    at: &GnssAtStart,
) -> (ins_gnss_core::fix_error::FixErrorModel, nalgebra::Matrix3<f64>) {
    let split = config.gnss.errors.split();
    let declared =
        at.fix_std.unwrap_or_else(|| Vector3::repeat(1.0)) * at.fix_factor.unwrap_or(1.0).sqrt();
    let sigma = split.sigma.unwrap_or(declared * split.share.sqrt());
    let fix = ins_gnss_core::fix_error::FixErrorModel { sigma, tau: split.tau };
    (fix, ins_gnss_core::fix_error::initial_fix_covariance(&fix))
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
        from: &Start,
        strategy: RunStrategy,
        at: &GnssAtStart,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let clock = at.clock;
        let base = ins_model(config, from);
        let model = InsModelTc { base, clock: clock_noise(config) };
        let init = from.initial_state();
        Navigator::new((&init, &clock_init(clock)), model, strategy, config.gnss_config())
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
        from: &Start,
        strategy: RunStrategy,
        at: &GnssAtStart,
    ) -> Result<Navigator<RunStrategy, Self>, NavError> {
        let clock = at.clock;
        let base = ins_model(config, from);
        let base = InsModel21 { base, scale: config.scale_factor_noise() };
        let model = InsModelTc21 { base, clock: clock_noise(config) };
        let init = from.initial_state();
        let (scale, gnss) = (config.scale_init(), config.gnss_config());
        Navigator::new((&init, &scale, &clock_init(clock)), model, strategy, gnss)
    }

    fn scale_factors(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        Some((self.nav.sg, self.nav.sa))
    }

    tight_run_state!();
}

/// The INS model of a run: the configured mechanization (a flat Earth's reference at the
/// initial position) and the IMU noise the start settled on.
fn ins_model(config: &Config, from: &Start) -> InsModel {
    InsModel { mechanization: config.mechanization(from.init.position()), noise: from.noise }
}

/// The navigator at the start time from what the start found (`from`), the run's summary
/// with its span started there, and the end time.
pub(crate) fn start_navigator<S: RunState>(
    config: &Config,
    from: &Start,
    strategy: AnyStrategy,
    at: &GnssAtStart,
) -> Result<(Navigator<RunStrategy, S>, RunSummary, f64), RunError>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let start = from.time;
    let end = config.data.end_time.unwrap_or(f64::INFINITY);
    // the name of the strategy the user chose (the vehicle streams' fixed noise aside)
    let name = if config.filter.streams.is_empty() { strategy.name() } else { "per-stream" };
    let strategy = config.strategy(strategy).map_err(RunError::Config)?;
    // a static start the start found and started from: ZARU over it, unless the
    // configuration asks for ZUPT and ZARU over the whole run
    let mut aiding = config.vehicle_aiding();
    if let (None, Some(until)) = (aiding.zupt, from.still_until) {
        aiding.zupt = Some(ins_gnss_core::vehicle::ZuptConfig {
            until,
            zaru_only: true,
            ..Default::default()
        });
    }
    let nav = S::navigator(config, from, strategy, at)?
        .with_vehicle_aiding(aiding)
        .with_covariance_interval(config.filter.covariance_interval);
    let summary = RunSummary {
        strategy: name.to_string(),
        span: (start, start),
        noise: crate::config::noise_echo(&from.noise),
        ..Default::default()
    };
    Ok((nav, summary, end))
}

/// The strategy of a run: the configured strategies per stream behind the gross-error
/// gate ([`Config::strategy`]).
pub type RunStrategy = GrossErrorGate<PerStream<AnyStrategy>>;
