//! The fixes' error model as a decision judged by the filter's likelihood: the probe of
//! the first fixes, the bank of hypotheses on their persisting part (each one whole run
//! scored by the fixes' innovations), and what the navigator learned.

use super::*;

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

/// A configuration whose fixes' persisting error is a hypothesis: its σ and correlation
/// time stated, the white part's scale learned, nothing written, nothing smoothed.
fn hypothesis(config: &Config, sigma: Vector3<f64>, tau: f64) -> Config {
    let mut c = config.clone();
    c.gnss.errors.model = crate::config::ErrorModel::Persisting;
    c.gnss.errors.sigma = Some(sigma.into());
    c.gnss.errors.tau = tau;
    c.gnss.errors.learn = true;
    c
}

/// The fixes' error model judged by the filter's own likelihood (`gnss.errors.model =
/// "auto"`, once the probe has learned the fixes' total noise scale): a bank of runs over
/// the whole data, the white model and persisting parts of stated σ and correlation time
/// as states (the white part's scale learned from the residuals), each scored by the
/// log-likelihood of the fixes' innovations after the first
/// [`SETTLED_AFTER`] ([`StreamStats::log_likelihood_settled`]).
/// The σ are multiples of the total σ the probe learned (the declared σ times the probe's
/// factor), stepped by [`BANK_SIGMA_STEP`] while the likelihood rises, then refined at the
/// vertex of the parabola through the best and its neighbours; the correlation times are
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
) -> (Option<Config>, Option<FixErrorBank>) {
    let mut judged = config.clone();
    judged.filter.smooth = false;
    let mut bank = Hypotheses {
        judged,
        strategy,
        inputs,
        probe,
        total: probe.declared * probe.factor.max(0.0).sqrt(),
        scored: Vec::new(),
    };
    let mut white_config = bank.judged.clone();
    white_config.gnss.errors.model = crate::config::ErrorModel::White;
    let white_ll = bank.likelihood(&white_config, None);
    // (the prior's share of the total variance is the first guess)
    let k0 = ins_gnss_core::navigator::FIX_ERROR_SHARE.sqrt();
    // each correlation time's best σ: (τ, k, log-likelihood)
    let mut profiles = vec![(BANK_TAU, bank.profile(BANK_TAU, k0))];
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
            let go_on = if step > 1.0 { p.1 .1 >= so_far - BANK_MARGIN } else { p.1 .1 > so_far };
            if !go_on {
                break;
            }
            from = p;
        }
    }
    // the data cannot tell apart the hypotheses within the margin of the best: of those,
    // the longest correlation time (its σ the largest: the most cautious)
    let top = best_ll(&profiles);
    let Some(&(tau, (k, ll))) =
        profiles.iter().filter(|p| p.1 .1 >= top - BANK_MARGIN).max_by(|a, b| a.0.total_cmp(&b.0))
    else {
        return (None, None);
    };
    if !ll.is_finite() {
        return (None, None);
    }
    let next = bank
        .scored
        .iter()
        .filter(|s| !((s.0 / k - 1.0).abs() < 1e-6 && (s.1 / tau - 1.0).abs() < 1e-6))
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
        let mut c = config.clone();
        c.gnss.errors.model = crate::config::ErrorModel::White;
        return (Some(c), Some(found));
    }
    (Some(hypothesis(config, total * k, tau)), Some(found))
}

/// The bank's hypotheses as they are scored: each one whole run of the configuration
/// `judged` (not smoothed) with a persisting part of σ `total · k` and correlation time τ.
struct Hypotheses<'a> {
    judged: Config,
    strategy: &'a AnyStrategy,
    inputs: &'a Inputs,
    probe: FixErrorProbe,
    /// The fixes' total σ the probe found (N, E, D), m.
    total: Vector3<f64>,
    /// Every hypothesis run: (k, τ, log-likelihood).
    scored: Vec<(f64, f64, f64)>,
}

impl Hypotheses<'_> {
    /// The fixes' log-likelihood of one run (−∞: it failed).
    fn likelihood(&self, c: &Config, prior: Option<FixErrorProbe>) -> f64 {
        let mut create = || Ok((Discard, DiscardRows));
        match attempt(c, self.strategy.clone(), self.inputs, None, &mut create, prior) {
            Ok((summary, _)) => {
                summary.streams.iter().filter(|s| s.gnss).map(|s| s.log_likelihood_settled).sum()
            }
            Err(_) => f64::NEG_INFINITY,
        }
    }

    /// The hypothesis (k, τ)'s log-likelihood, run once.
    fn score(&mut self, k: f64, tau: f64) -> f64 {
        if let Some(&(_, _, ll)) = self
            .scored
            .iter()
            .find(|s| (s.0 / k - 1.0).abs() < 1e-6 && (s.1 / tau - 1.0).abs() < 1e-6)
        {
            return ll;
        }
        let c = hypothesis(&self.judged, self.total * k, tau);
        let ll = self.likelihood(&c, Some(white_prior(self.probe)));
        self.scored.push((k, tau, ll));
        ll
    }

    /// The best σ at one correlation time, from `k0`, by steps while the likelihood
    /// rises, then the vertex of the parabola through the best and its two neighbours in
    /// ln σ (a step of √2 is coarse against the likelihood's curvature): (k, its
    /// log-likelihood).
    fn profile(&mut self, tau: f64, k0: f64) -> (f64, f64) {
        let (lo, hi) = BANK_SIGMA_RANGE;
        let k0 = k0.clamp(lo, hi);
        let mut best = (k0, self.score(k0, tau));
        for step in [BANK_SIGMA_STEP, 1.0 / BANK_SIGMA_STEP] {
            loop {
                let k = best.0 * step;
                if !(lo..=hi).contains(&k) {
                    break;
                }
                let ll = self.score(k, tau);
                if ll > best.1 {
                    best = (k, ll);
                } else {
                    break;
                }
            }
        }
        let s = BANK_SIGMA_STEP;
        let (k, y1) = best;
        if (lo..=hi).contains(&(k / s)) && (lo..=hi).contains(&(k * s)) {
            let (y0, y2) = (self.score(k / s, tau), self.score(k * s, tau));
            let curve = y0 - 2.0 * y1 + y2;
            if curve < 0.0 {
                let d = (0.5 * (y0 - y2) / curve).clamp(-0.5, 0.5);
                if d.abs() > 0.05 {
                    let kv = k * s.powf(d);
                    let yv = self.score(kv, tau);
                    if yv > best.1 {
                        best = (kv, yv);
                    }
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
