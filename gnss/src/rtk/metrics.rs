//! What users ask of an RTK run — how often and how soon it fixed, and how sure the
//! fixes were: [`RtkRun`] (its solutions) and [`RtkMetrics`].

use super::RtkEpoch;
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// How far (s) a base epoch may be after the rover's and still count as at or before it
/// (receivers' stamps differ by their clocks' milliseconds).
pub const PAIRING: f64 = 0.5;

/// What users ask of an RTK run: how often and how soon it fixed, and how sure the fixes
/// were ([`RtkRun::metrics`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RtkMetrics {
    /// Rover epochs read.
    pub epochs: usize,
    /// Epochs with a solution (fixed or float).
    pub solved: usize,
    /// Fixed epochs.
    pub fixed: usize,
    /// Fixed over solved epochs.
    pub fix_rate: f64,
    /// Seconds from the first solution to the first fixed one (`None`: never fixed).
    pub time_to_first_fix: Option<f64>,
    /// Each outage of the fix: seconds from the last fixed epoch before it to the first
    /// after it ([`RtkRun::refix_times`]).
    pub refix_times: Vec<f64>,
    /// The ratio test's minimum and median over the fixed epochs (NaN: none).
    pub ratio_fixed: (f64, f64),
    /// The same over the epochs searched and not fixed.
    pub ratio_other: (f64, f64),
    /// Epochs without a solution, by reason.
    pub failures: BTreeMap<String, usize>,
}

/// What an RTK run found.
#[derive(Clone, Debug, Default)]
pub struct RtkRun {
    /// Rover epochs read.
    pub epochs: usize,
    /// The solutions.
    pub solutions: Vec<RtkEpoch>,
    /// Epochs without a solution, by reason.
    pub failures: BTreeMap<String, usize>,
    /// The base position used (ECEF, m).
    pub base: Vector3<f64>,
    /// What the inputs held that the solution did not use (an RTCM 3 base's other
    /// messages), one note each.
    pub notes: Vec<String>,
}

/// The failure of a rover epoch without a base epoch recent enough.
pub const NO_BASE_EPOCH: &str = "no base epoch recent enough";

/// Counts by reason as text: each count before its reason, comma-separated ("3 too few
/// common satellites, 1 singular update").
pub fn reasons_text(counts: &BTreeMap<String, usize>) -> String {
    counts.iter().map(|(k, v)| format!("{v} {k}")).collect::<Vec<_>>().join(", ")
}

impl RtkRun {
    /// One more epoch without a solution, for `reason`.
    pub fn fail(&mut self, reason: &str) {
        *self.failures.entry(reason.into()).or_default() += 1;
    }

    /// Fixed solutions over all solutions.
    pub fn fix_rate(&self) -> f64 {
        self.solutions.iter().filter(|s| s.fixed).count() as f64
            / self.solutions.len().max(1) as f64
    }

    /// Seconds from the first solution to the first fixed one (`None`: never fixed).
    pub fn time_to_first_fix(&self) -> Option<f64> {
        let first = self.solutions.first()?;
        self.solutions.iter().find(|s| s.fixed).map(|s| s.time.diff(&first.time))
    }

    /// Each outage of the fix (a run of float epochs after a fixed one): seconds from the
    /// last fixed epoch before it to the first after it (an outage still open at the end
    /// is left out).
    pub fn refix_times(&self) -> Vec<f64> {
        let mut out = Vec::new();
        let mut last_fixed: Option<&RtkEpoch> = None;
        let mut lost = false;
        for s in &self.solutions {
            match (s.fixed, last_fixed) {
                (true, Some(l)) if lost => out.push(s.time.diff(&l.time)),
                (false, Some(_)) => lost = true,
                _ => {}
            }
            if s.fixed {
                last_fixed = Some(s);
                lost = false;
            }
        }
        out
    }

    /// The run's [`RtkMetrics`].
    pub fn metrics(&self) -> RtkMetrics {
        let (ratio_fixed, ratio_other) = self.ratios();
        RtkMetrics {
            epochs: self.epochs,
            solved: self.solutions.len(),
            fixed: self.solutions.iter().filter(|s| s.fixed).count(),
            fix_rate: self.fix_rate(),
            time_to_first_fix: self.time_to_first_fix(),
            refix_times: self.refix_times(),
            ratio_fixed,
            ratio_other,
            failures: self.failures.clone(),
        }
    }

    /// The ratio test's values over the epochs searched: (minimum, median) of the fixed
    /// ones and of the others (NaN where there are none).
    pub fn ratios(&self) -> ((f64, f64), (f64, f64)) {
        let stats = |fixed: bool| {
            let mut r: Vec<f64> = self
                .solutions
                .iter()
                .filter(|s| s.fixed == fixed && s.ratio.is_finite())
                .map(|s| s.ratio)
                .collect();
            r.sort_by(f64::total_cmp);
            match r.len() {
                0 => (f64::NAN, f64::NAN),
                n => (r[0], r[n / 2]),
            }
        };
        (stats(true), stats(false))
    }
}

/// The fix's metrics as a line: time to first fix, the outages of the fix and the time to
/// fix again, the ratio's minimum and median over the fixed epochs and the others.
pub fn metrics_line(m: &RtkMetrics) -> String {
    let ratios = |(min, median): (f64, f64)| {
        if min.is_nan() {
            "none".to_string()
        } else {
            format!("min {min:.1}, median {median:.1}")
        }
    };
    let refix = &m.refix_times;
    format!(
        "time to first fix {}; {} outage{} of the fix{}; ratio of the fixed epochs: {}; of the others: {}",
        m.time_to_first_fix.map_or("never".into(), |t| format!("{t:.0} s")),
        refix.len(),
        if refix.len() == 1 { "" } else { "s" },
        if refix.is_empty() {
            String::new()
        } else {
            format!(
                " (fixed again after {} s at most)",
                refix.iter().fold(0.0f64, |a, b| a.max(*b)).round()
            )
        },
        ratios(m.ratio_fixed),
        ratios(m.ratio_other)
    )
}
