//! The fixes' error model as a decision judged by the filter's likelihood: the probe of
//! the first fixes, the bank of hypotheses on their persisting part (each one whole run
//! scored by the fixes' innovations), and what the navigator learned.

use super::*;
use std::sync::Arc;

/// The correlation time (s) the bank of hypotheses on the fixes' errors starts from, then its
/// neighbours by [`BANK_TAU_STEP`] while the likelihood rises.
pub const BANK_TAU: f64 = 100.0;

/// The ratio between two correlation times the bank compares.
pub const BANK_TAU_STEP: f64 = 3.0;

/// The ratio between two persisting σ the bank compares at one correlation time.
pub const BANK_SIGMA_STEP: f64 = std::f64::consts::SQRT_2;

/// The bank's bounds on the persisting σ, as multiples of the total σ the probe learned,
/// and on the correlation time (s).
pub const BANK_SIGMA_RANGE: (f64, f64) = (1.0 / 16.0, 16.0);

/// See [`BANK_SIGMA_RANGE`].
pub const BANK_TAU_RANGE: (f64, f64) = (10.0, 3000.0);

/// Log-likelihoods within which the bank's hypotheses are not told apart by the data
/// (½ χ²₂ at 0.99: the likelihood-ratio region of the two parameters, σ and τ): of
/// those, the bank takes the most cautious.
pub const BANK_MARGIN: f64 = 4.61;

/// What the bank of hypotheses on the fixes' errors compared (`gnss.errors.model =
/// "auto"`; see the guide's everyday-GNSS section).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixErrorBank {
    /// Hypotheses run.
    pub runs: usize,
    /// The chosen persisting σ (N, E, D), m, and correlation time, s.
    pub chosen: (Vector3<f64>, f64),
    /// The chosen hypothesis's log-likelihood of the fixes over the best other's
    /// (negative: a likelier one within [`BANK_MARGIN`] was passed over for caution).
    pub margin: f64,
    /// The white model's log-likelihood over the best persisting hypothesis's (the white
    /// model is chosen when above [`BANK_MARGIN`]; NaN: its run failed).
    pub white: f64,
}

impl FixErrorBank {
    /// Whether the white model was chosen.
    pub fn white_chosen(&self) -> bool {
        self.white > BANK_MARGIN
    }
}

/// The probe as the prior of a hypothesis's white part: the white share of the total
/// variance the probe learned (the prior split's).
pub(super) fn white_prior(probe: FixErrorProbe) -> FixErrorProbe {
    let share = ins_gnss_core::navigator::FIX_ERROR_SHARE;
    FixErrorProbe { factor: probe.factor * (1.0 - share), ..probe }
}

/// The fixes' error model judged by the filter's own likelihood (`gnss.errors.model =
/// "auto"`, once the probe has learned the fixes' total noise scale): a bank of runs over
/// the whole data, the white model and persisting parts of stated σ and correlation time
/// as states (the white part's scale learned from the residuals), each scored by the
/// log-likelihood of the fixes' innovations after the first
/// [`SETTLED_AFTER`] ([`StreamStats::log_likelihood_settled`]).
/// The σ are multiples of the total σ the probe learned (the declared σ times the probe's
/// factor), stepped by [`BANK_SIGMA_STEP`] while the likelihood rises; the correlation times are
/// stepped by [`BANK_TAU_STEP`] from [`BANK_TAU`] (each time's first σ moved along the
/// ridge where `σ²/τ` is constant), shorter while the likelihood rises, longer while it
/// stays within [`BANK_MARGIN`] of the best. Of the hypotheses within that margin of the
/// best, the longest correlation time is chosen (the most cautious); the white model only
/// when it is likelier than every persisting part by more than the margin. Returns the
/// configuration chosen (`None`: no hypothesis ran to its end, the learned split stands)
/// and what the bank compared.
pub(super) fn judge_fix_errors(
    config: &Config,
    strategy: &AnyStrategy,
    inputs: &Inputs,
    probe: FixErrorProbe,
    start: &StartMemo,
) -> (Option<Config>, Option<FixErrorBank>) {
    judge_with(config, strategy, inputs, probe, Workers::IdleCores, (true, Some(start)))
}

/// How many passes a bank runs at once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Workers {
    /// As many as the machine's cores not taken by other passes of the process
    /// ([`idle_cores`]).
    IdleCores,
    /// This many (the law test's: one, or two whatever else runs).
    #[cfg_attr(not(feature = "unit-tests"), allow(dead_code))]
    Exactly(usize),
}

/// [`judge_fix_errors`] with `workers` passes at once, the IMU read once into memory
/// (`replay`, within [`IMU_RECORDING_BYTES`]) or by each pass, and the start kept by
/// `start` or decided by each pass (`None`).
fn judge_with(
    config: &Config,
    strategy: &AnyStrategy,
    inputs: &Inputs,
    probe: FixErrorProbe,
    workers: Workers,
    (replay, start): (bool, Option<&StartMemo>),
) -> (Option<Config>, Option<FixErrorBank>) {
    let judged = config.for_bank_pass();
    // the inputs read once for every pass: a ROS recording into rows (with the
    // configuration it completes), the IMU's samples into memory (when not too many)
    let recording;
    let (judged, inputs) = match (inputs, &config.data.ros) {
        (Inputs::Files, Some(_)) => match open_recording(&judged) {
            Ok(r) => {
                recording = r;
                (recording.0.clone(), &recording.1)
            }
            Err(_) => return (None, None),
        },
        _ => (judged, inputs),
    };
    let replay = replay.then(|| ImuRecording::read(&judged, inputs)).flatten().map(Arc::new);
    let mut bank = Hypotheses {
        judged,
        strategy,
        inputs,
        replay,
        start,
        probe,
        total: probe.declared * probe.factor.max(0.0).sqrt(),
        scored: Vec::new(),
        ran: Vec::new(),
        workers,
        beside: 0,
    };
    let white_config = bank.judged.with_white_fix_errors();
    // (the prior's share of the total variance is the first guess)
    let k0 = ins_gnss_core::navigator::FIX_ERROR_SHARE.sqrt();
    // each correlation time's best σ: (τ, k, log-likelihood), the first one's beside the
    // white model's run
    let (first, white_ll) = if bank.at_once() > 1 {
        let replay = bank.replay.clone();
        let shared = Shared { replay: replay.as_ref(), start };
        std::thread::scope(|s| {
            let white = s.spawn(|| likelihood(&white_config, strategy, inputs, shared, None));
            bank.beside += 1;
            let first = bank.profile(BANK_TAU, k0);
            bank.beside -= 1;
            (first, white.join().unwrap_or(f64::NEG_INFINITY))
        })
    } else {
        let white = bank.likelihood(&white_config, None);
        (bank.profile(BANK_TAU, k0), white)
    };
    let Some((tau, k, ll, top)) = bank.search(first) else {
        return (None, None);
    };
    let next = bank
        .scored
        .iter()
        .filter(|s| !same((s.0, s.1), k, tau))
        .map(|s| s.2)
        .fold(f64::NEG_INFINITY, f64::max);
    let white = if white_ll.is_finite() { white_ll - top } else { f64::NAN };
    let total = bank.total;
    let found = FixErrorBank {
        runs: bank.scored.len() + 1,
        chosen: (total * k, tau),
        margin: ll - next.max(white_ll),
        white,
    };
    if found.white_chosen() {
        return (Some(config.with_white_fix_errors()), Some(found));
    }
    (Some(config.with_persisting_fix_errors(total * k, tau)), Some(found))
}

/// The bank's hypotheses as they are scored: each one whole run of the configuration
/// `judged` (not smoothed) with a persisting part of σ `total · k` and correlation time τ.
struct Hypotheses<'a> {
    judged: Config,
    strategy: &'a AnyStrategy,
    inputs: &'a Inputs,
    /// The IMU's samples, read once (`None`: each pass reads them).
    replay: Option<Arc<ImuRecording>>,
    /// The start, decided once (`None`: each pass decides it).
    start: Option<&'a StartMemo>,
    probe: FixErrorProbe,
    /// The fixes' total σ the probe found (N, E, D), m.
    total: Vector3<f64>,
    /// Every hypothesis the search consulted: (k, τ, log-likelihood).
    scored: Vec<(f64, f64, f64)>,
    /// Every hypothesis run, consulted or run ahead of the search: (k, τ, log-likelihood).
    ran: Vec<(f64, f64, f64)>,
    /// Passes at once ([`Workers`]): the hypotheses the search is likely to ask for next
    /// run beside the one it asks for. The search, its choice and what it reports do not
    /// depend on it.
    workers: Workers,
    /// The bank's own passes running beside its search (the white model's, during the
    /// first profile).
    beside: usize,
}

/// Whether hypothesis `a` is (k, τ) (each within 1e-6 of the other).
fn same(a: (f64, f64), k: f64, tau: f64) -> bool {
    (a.0 / k - 1.0).abs() < 1e-6 && (a.1 / tau - 1.0).abs() < 1e-6
}

/// The bank's passes running in this process (every bank's: a program that runs several
/// at once, as a test binary or a campaign does, or a bank's white pass beside its first
/// profile).
static PASSES_RUNNING: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// One running pass in [`PASSES_RUNNING`] while it lives.
struct Running;

impl Running {
    fn new() -> Self {
        PASSES_RUNNING.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        Running
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        PASSES_RUNNING.fetch_sub(1, std::sync::atomic::Ordering::SeqCst);
    }
}

/// The machine's cores not taken by a bank's pass of this process (at least 1): a
/// bank runs the hypotheses its search is likely to ask for next only on cores that
/// would otherwise wait, never in place of another's pass.
fn idle_cores() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    cores.saturating_sub(PASSES_RUNNING.load(std::sync::atomic::Ordering::SeqCst)).max(1)
}

/// The fixes' log-likelihood of one pass of `c` (−∞: it failed).
fn likelihood(
    c: &Config,
    strategy: &AnyStrategy,
    inputs: &Inputs,
    shared: Shared<'_>,
    prior: Option<FixErrorProbe>,
) -> f64 {
    let mut create = || Ok((Discard, DiscardRows));
    let _running = Running::new();
    match attempt(c, strategy.clone(), inputs, None, &mut create, prior, shared) {
        Ok((summary, _)) => {
            summary.streams.iter().filter(|s| s.gnss).map(|s| s.log_likelihood_settled).sum()
        }
        Err(_) => f64::NEG_INFINITY,
    }
}

impl Hypotheses<'_> {
    /// Passes to run at once now (at least 1).
    fn at_once(&self) -> usize {
        match self.workers {
            // (the bank's own passes beside the search are among those counted)
            Workers::IdleCores => idle_cores(),
            Workers::Exactly(n) => n.saturating_sub(self.beside).max(1),
        }
    }

    /// The fixes' log-likelihood of one pass (−∞: it failed).
    fn likelihood(&self, c: &Config, prior: Option<FixErrorProbe>) -> f64 {
        let shared = Shared { replay: self.replay.as_ref(), start: self.start };
        likelihood(c, self.strategy, self.inputs, shared, prior)
    }

    /// The hypothesis (k, τ)'s log-likelihood, run once (with `next`, the hypotheses
    /// the search is likely to ask for after it, run beside it when there are idle cores).
    fn score_ahead(&mut self, k: f64, tau: f64, next: &[f64]) -> f64 {
        if let Some(&(_, _, ll)) = self.scored.iter().find(|s| same((s.0, s.1), k, tau)) {
            return ll;
        }
        let ran = |h: &Self, k: f64| h.ran.iter().find(|s| same((s.0, s.1), k, tau)).map(|s| s.2);
        if ran(self, k).is_none() {
            let (lo, hi) = BANK_SIGMA_RANGE;
            let todo: Vec<f64> = std::iter::once(k)
                .chain(next.iter().copied().filter(|n| (lo..=hi).contains(n)))
                .filter(|&n| ran(self, n).is_none())
                .take(self.at_once())
                .collect();
            let prior = Some(white_prior(self.probe));
            let configs: Vec<Config> = todo
                .iter()
                .map(|&k| self.judged.with_persisting_fix_errors(self.total * k, tau))
                .collect();
            let lls: Vec<f64> = if configs.len() == 1 {
                vec![self.likelihood(&configs[0], prior)]
            } else {
                let this = &*self;
                std::thread::scope(|s| {
                    let runs: Vec<_> = configs
                        .iter()
                        .map(|c| s.spawn(move || this.likelihood(c, prior)))
                        .collect();
                    // (a pass that panicked scores as failed)
                    runs.into_iter().map(|r| r.join().unwrap_or(f64::NEG_INFINITY)).collect()
                })
            };
            self.ran.extend(todo.iter().zip(lls).map(|(&k, ll)| (k, tau, ll)));
        }
        let ll = ran(self, k).unwrap_or(f64::NEG_INFINITY);
        self.scored.push((k, tau, ll));
        ll
    }

    /// The best σ at one correlation time, from `k0`, by steps while the likelihood
    /// rises: (k, its log-likelihood). (Not refined between the steps: the likelihood of
    /// neighbouring hypotheses differs by the run's own discrete decisions — which fixes
    /// the gate inflates, and what follows — by 4–20 log-units on navego, where the
    /// vertex of a parabola through three steps beat their best in none of six profiles
    /// (and by ~1,500 on drive-0708 when a ZUPT held the creeping car); leaving it out
    /// changed no rate of the everyday corpus beyond its seeds' scatter, for a fifth
    /// fewer runs.)
    fn profile(&mut self, tau: f64, k0: f64) -> (f64, f64) {
        let (lo, hi) = BANK_SIGMA_RANGE;
        let k0 = k0.clamp(lo, hi);
        let s = BANK_SIGMA_STEP;
        let mut best = (k0, self.score_ahead(k0, tau, &[k0 * s, k0 / s]));
        for step in [s, 1.0 / s] {
            loop {
                let k = best.0 * step;
                if !(lo..=hi).contains(&k) {
                    break;
                }
                // (the next step beside it: a walk goes on more often than not)
                let ll = self.score_ahead(k, tau, &[k * step, k / step / step]);
                if ll > best.1 {
                    best = (k, ll);
                } else {
                    break;
                }
            }
        }
        best
    }
}

/// The fixes' errors as the navigator learned them (a state with their persisting part).
pub(crate) fn fix_errors_learned<S: NavState>(
    nav: &Navigator<RunStrategy, S>,
) -> Option<FixErrorsLearned>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let (model, split) = (nav.fix_error_model()?, nav.fix_split()?);
    Some(FixErrorsLearned {
        persisting: (model.sigma, model.tau),
        white: split.white(),
        split: split.factor(),
        lag_one: split.lag_one(),
        fixes: split.fixes(),
        probe: None,
    })
}

/// What the probe of the fixes' errors found ([`FixErrorPlan::Probe`]): the first fixes'
/// noise scale on their declared σ, and the lag-one autocorrelation of their whitened
/// innovations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixErrorProbe {
    /// The lag-one autocorrelation.
    pub lag_one: f64,
    /// Fixes.
    pub fixes: u64,
    /// The variance factor the white model's innovations showed on the declared σ (the
    /// restart's prior for both parts of the split).
    pub factor: f64,
    /// The σ the first fixes declare (N, E, D), m.
    pub declared: Vector3<f64>,
}

/// The probe's finding once the GNSS fix stream has been learned from over
/// [`PROBE_FIXES`] fixes (`None` before).
pub(super) fn probe_fix_errors(strategy: &RunStrategy, at: &GnssAtStart) -> Option<FixErrorProbe> {
    let declared = at.fix_std.unwrap_or_else(|| Vector3::repeat(1.0));
    strategy
        .learned()
        .filter(|l| {
            ins_gnss_core::gnss::GNSS_STREAMS.iter().any(|s| s.name() == l.stream)
                && l.updates >= PROBE_FIXES
        })
        .map(|l| FixErrorProbe { lag_one: l.lag_one, fixes: l.updates, factor: l.factor, declared })
        .next()
}

impl Hypotheses<'_> {
    /// From the first correlation time's best (`first`: σ factor and log-likelihood), the
    /// correlation times stepped by [`BANK_TAU_STEP`]: longer while their best is within
    /// [`BANK_MARGIN`] of the best so far, shorter while they are better. Of those within
    /// the margin of the best (the data cannot tell them apart), the longest correlation
    /// time (its σ the largest: the most cautious): (τ, k, its log-likelihood, the best
    /// log-likelihood); `None` when no hypothesis ran to its end.
    fn search(&mut self, first: (f64, f64)) -> Option<(f64, f64, f64, f64)> {
        let bank = self;
        let mut profiles = vec![(BANK_TAU, first)];
        let best_ll =
            |p: &[(f64, (f64, f64))]| p.iter().map(|x| x.1 .1).fold(f64::NEG_INFINITY, f64::max);
        // longer correlation times while their best is within the margin of the best so far;
        // shorter ones while they are better
        for step in [BANK_TAU_STEP, 1.0 / BANK_TAU_STEP] {
            let mut from = profiles[0];
            loop {
                let tau = from.0 * step;
                if !(BANK_TAU_RANGE.0..=BANK_TAU_RANGE.1).contains(&tau) {
                    break;
                }
                // along the ridge σ²/τ constant
                let p = (tau, bank.profile(tau, from.1 .0 * step.sqrt()));
                let so_far = best_ll(&profiles);
                profiles.push(p);
                let go_on =
                    if step > 1.0 { p.1 .1 >= so_far - BANK_MARGIN } else { p.1 .1 > so_far };
                if !go_on {
                    break;
                }
                from = p;
            }
        }
        // the data cannot tell apart the hypotheses within the margin of the best: of those,
        // the longest correlation time (its σ the largest: the most cautious)
        let top = best_ll(&profiles);
        let &(tau, (k, ll)) = profiles
            .iter()
            .filter(|p| p.1 .1 >= top - BANK_MARGIN)
            .max_by(|a, b| a.0.total_cmp(&b.0))?;
        if !ll.is_finite() {
            return None;
        }
        Some((tau, k, ll, top))
    }
}

#[cfg(feature = "unit-tests")]
#[doc(hidden)]
pub mod fix_errors_tests {
    use super::*;
    use ins_gnss_sim::{scenarios, simulate, GnssSim, Trajectory};

    /// Independent paths agree: the bank's choice and what it reports are the same with
    /// one pass at a time or two, with the IMU replayed from memory or read again by each
    /// pass, and with the start decided by each pass or kept from the first attempt (a
    /// simulated 600 s drive, fixes with 1/1/2 m white errors declared as such; the probe
    /// from the program's first attempt).
    pub fn the_bank_is_the_same_one_pass_at_a_time_or_two_replayed_or_read_start_kept() {
        let (start, segs) = scenarios::drive_600s();
        let traj = Trajectory::new(start, &segs).unwrap();
        let sigma = Vector3::new(1.0, 1.0, 2.0);
        let gnss = GnssSim {
            rate_hz: 1.0,
            pos_sigma: sigma,
            vel_sigma: None,
            lever_arm: Vector3::zeros(),
            windows: vec![],
        };
        let d = simulate(&traj, 50.0, &scenarios::mems_imu(), &gnss, 11);
        let imu: Vec<f64> = d
            .imu
            .iter()
            .flat_map(|s| {
                [s.t, s.dtheta[0], s.dtheta[1], s.dtheta[2], s.dvel[0], s.dvel[1], s.dvel[2]]
            })
            .collect();
        let fixes: Vec<f64> = d
            .gnss
            .iter()
            .flat_map(|g| {
                [
                    g.t,
                    g.pos.lat.to_degrees(),
                    g.pos.lon.to_degrees(),
                    g.pos.h,
                    sigma[0],
                    sigma[1],
                    sigma[2],
                ]
            })
            .collect();
        let inputs =
            Inputs::Arrays { imu: imu.into(), imu_width: 7, gnss: fixes.into(), gnss_width: 7 };
        let text = "[data]\nimu = \"imu\"\ngnss = \"gnss\"\nimu_rate = 50.0\n\
             [imu_noise]\narw = [0.3, 0.3, 0.3]\nvrw = [0.1, 0.1, 0.1]\n\
             gyro_bias_std = [10.0, 10.0, 10.0]\naccel_bias_std = [100.0, 100.0, 100.0]\n\
             corr_time = 1.0\n";
        let config =
            Config::parse(text, crate::config::ConfigKind::Toml, std::path::Path::new("."))
                .unwrap();
        let strategy: AnyStrategy = "fixed".parse().unwrap();
        let mut create = || Ok((Discard, DiscardRows));
        let memo = StartMemo::default();
        let shared = Shared { replay: None, start: Some(&memo) };
        let probe =
            match attempt(&config, strategy.clone(), &inputs, None, &mut create, None, shared) {
                Err((RunError::FixErrorsProbed(p), _)) => p,
                other => panic!("the fixes were not probed: {:?}", other.map(|r| r.0.lines())),
            };
        // (the configuration has no `[init]`: each pass's start is the in-motion alignment)
        assert_eq!(crate::start::Look::of(&config), crate::start::Look::Span);
        let one = judge_with(&config, &strategy, &inputs, probe, Workers::Exactly(1), (true, None));
        let (chosen, bank) = (one.0.as_ref().expect("a choice"), one.1.expect("a bank"));
        assert!(bank.runs >= 5, "{bank:?}");
        assert_eq!(
            judge_with(&config, &strategy, &inputs, probe, Workers::Exactly(2), (true, None)),
            one
        );
        assert_eq!(
            judge_with(&config, &strategy, &inputs, probe, Workers::Exactly(1), (false, None)),
            one
        );
        // the start kept from the first attempt
        assert_eq!(memo.hits(), 0);
        assert_eq!(
            judge_with(
                &config,
                &strategy,
                &inputs,
                probe,
                Workers::Exactly(2),
                (true, Some(&memo))
            ),
            one
        );
        assert!(
            memo.hits() >= bank.runs,
            "every pass given the start kept: {} of {}",
            memo.hits(),
            bank.runs
        );
        assert_eq!(chosen.gnss.errors.model, crate::config::ErrorModel::White, "{bank:?}");
    }
}
