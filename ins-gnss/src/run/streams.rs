//! Each stream's updates as the run saw them: counts, NIS and their χ² bands, the
//! innovations' likelihood and autocorrelation, and the consistency verdict drawn from
//! them.

use super::*;

/// A stream's updates after which [`StreamStats::log_likelihood_settled`] counts: the
/// fixes' white noise is learned with a memory of 30 fixes
/// ([`WHITE_WINDOW`](ins_gnss_core::fix_error::WHITE_WINDOW)), so its prior weighs 4 %
/// after 100.
pub const SETTLED_AFTER: usize = 100;

/// An update's log-likelihood with its quadratic term capped at the χ² 0.999 quantile
/// of its dimension ([`StreamStats::log_likelihood_settled`]).
pub fn robust_log_likelihood(u: &UpdateSummary) -> f64 {
    // (the quadratic term of the likelihood: the adapted NIS where the update adapted S)
    let q = if u.nis_adapted.is_finite() { u.nis_adapted } else { u.nis };
    let cap = match u.dim {
        1 => 10.828,
        2 => 13.816,
        3 => 16.266,
        6 => 22.458,
        m => estimator_core::consistency::chi2_quantile(0.999, m as f64),
    };
    if u.log_likelihood.is_finite() && q.is_finite() {
        u.log_likelihood + 0.5 * (q - q.min(cap))
    } else {
        0.0
    }
}

/// A GNSS gap longer than this (s) is an outage for [`StreamStats::refused_after_outage`].
pub const OUTAGE: f64 = 5.0;

/// One measurement stream's innovations over the run, with the nominal `S` (before any
/// adaptation): how many were refused as gross errors (the data's quality), and the
/// statistics of the others, used accepted or inflated (the run's consistency).
#[derive(Clone, Debug)]
pub struct StreamStats {
    /// The stream.
    pub stream: estimator_core::StreamId,
    /// Whether it is a GNSS stream (not vehicle aiding).
    pub gnss: bool,
    /// Updates.
    pub epochs: usize,
    /// Refused updates (gross errors: the data's quality, not the run's consistency).
    pub refused: usize,
    /// Sum of the NIS (nominal `S`) and of the dimensions, over the updates used.
    pub nis_sum: f64,
    /// See [`nis_sum`](Self::nis_sum).
    pub dof: usize,
    /// The filter's own log-likelihood of the stream's data after its first
    /// [`SETTLED_AFTER`] updates (the noise the run learns from them has settled: a
    /// hypothesis is not judged by how its learning began): the sum over every later
    /// update, refused ones included, of the innovation's Gaussian log-likelihood with the
    /// innovation covariance the update used, its quadratic term capped at χ² 0.999 of
    /// the dimension ([`robust_log_likelihood`]: one gross error weighs no more than a
    /// rare inlier, a model is not judged by how it fares on gross errors).
    pub log_likelihood_settled: f64,
    /// Updates used whose NIS exceeds the median of its χ² distribution (half of them
    /// for a consistent filter).
    pub above_median: usize,
    /// The median over the updates used of NIS / (χ² median): the factor² by which `S` is
    /// too small (about 1 when consistent), from the sorted ratios at the end of the run.
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
    pub(crate) ratios: Vec<f32>,
    pub(crate) last_t: f64,
    pub(crate) after_outage: bool,
    pub(crate) accepted_any: bool,
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
        let n = self.used().max(1) as f64;
        // the standard normal quantile of 1 − 0.5e-6
        let half = 4.8916 * 0.5 / n.sqrt();
        (self.above_median as f64 / n, (0.5 - half, 0.5 + half))
    }

    /// Updates used (accepted or inflated): the ones the consistency is judged on.
    pub fn used(&self) -> usize {
        self.epochs - self.refused
    }

    /// The share of the stream's epochs refused as gross errors.
    pub fn refused_share(&self) -> f64 {
        self.refused as f64 / self.epochs.max(1) as f64
    }

    /// Consistent by the mean NIS of the innovations used.
    pub fn consistent(&self) -> bool {
        let (m, (lo, hi)) = self.mean_nis();
        m >= lo && m <= hi
    }

    /// One line for the run summary.
    pub fn verdict(&self) -> String {
        self.verdict_of(false)
    }

    /// [`verdict`](Self::verdict) of a stream whose errors the filter follows (`follows`:
    /// RTK's fixes), whose innovations are then smaller than its errors.
    pub fn verdict_of(&self, follows: bool) -> String {
        let (m, (lo, hi)) = self.mean_nis();
        let (f, (flo, fhi)) = self.above_median_band();
        let head = format!(
            "consistency of {}: mean NIS per degree of freedom {m:.3} over the {} updates \
             used ({} of {} refused as gross errors, {:.1} %), 99 % band [{lo:.3}, {hi:.3}]; \
             {:.1} % above their χ² median (band [{:.1}, {:.1}] %)",
            self.stream,
            self.used(),
            self.refused,
            self.epochs,
            100.0 * self.refused_share(),
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
        } else if follows {
            format!(
                "{head}: smaller than the filter believes, as the innovations of errors that \
                 persist from epoch to epoch are (RTK's: the atmosphere's residuals and the \
                 multipath change over minutes, and the filter follows them); not a sign of a \
                 σ too large (judge it against a truth)"
            )
        } else if self.stream.to_string().starts_with("pr ") {
            // a satellite's pseudoranges (tight coupling): see `health::assess`
            format!(
                "{head}: NOT consistent — the innovations are smaller than the filter \
                 believes: the satellite's errors stay the same from epoch to epoch and the \
                 position and clock absorb them (the position σ is then too small, not too \
                 large), or the noise settings are pessimistic"
            )
        } else {
            format!(
                "{head}: NOT consistent — the innovations are smaller than the filter \
                 believes, so its reported σ is too large (noise settings pessimistic)"
            )
        }
    }

    pub(crate) fn new(stream: estimator_core::StreamId) -> Self {
        Self {
            stream,
            gnss: !VEHICLE_STREAMS.contains(&stream),
            epochs: 0,
            refused: 0,
            nis_sum: 0.0,
            dof: 0,
            log_likelihood_settled: 0.0,
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

    pub(crate) fn add(&mut self, u: &UpdateSummary, median: f64) {
        // (an outage after accepted updates: refusals from the start are not its doing)
        if self.last_t.is_finite() && u.time - self.last_t > OUTAGE && self.accepted_any {
            self.after_outage = true;
        }
        self.last_t = u.time;
        self.epochs += 1;
        if self.epochs > SETTLED_AFTER {
            self.log_likelihood_settled += robust_log_likelihood(u);
        }
        if u.verdict != Verdict::Rejected {
            // judged at the noise the gate learned from the data, where it stands for the
            // declared one (the declared σ's factor is the summary's `noise learned` line)
            let nis = if u.reason == adaptive::LEARNED_REASON { u.nis_adapted } else { u.nis };
            self.nis_sum += nis;
            self.dof += u.dim;
            self.above_median += usize::from(nis > median);
            self.ratios.push((nis / median) as f32);
        }
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

    pub(crate) fn finish(&mut self) {
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
pub(crate) fn chi2_median(k: usize) -> f64 {
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
