//! After a run: is its result quietly wrong? A run whose GNSS stream was mostly refused,
//! or whose innovations are far from their distribution, has an answer nobody should use
//! without knowing; [`assess`] says so, with the likeliest cause it can tell.
//!
//! "Far" is defined by the χ² distribution: for a consistent filter each update's NIS
//! exceeds the median of its χ² distribution with probability ½, whatever its dimension,
//! so the number of updates above it is binomial(n, ½); a fraction outside the two-sided
//! 1e-6 band of that binomial is far ([`StreamStats::above_median_band`]).
//!
//! A stream far from its distribution makes the run untrustworthy only when its typical
//! innovation is also more than 1.5× its σ, or less than 1/1.5 of it.
//!
//! The data's quality and the run's consistency are kept apart: the fixes the gate
//! refused as gross errors are counted (their share is reported, and more than half
//! refused is a problem: nothing then tells which half is right), but only the updates
//! used are judged for consistency. A log with a tenth of its fixes 1 km off whose
//! result is as good as the clean one is not flagged; when such a run is flagged for
//! another reason, the gross errors are named among the causes.

use crate::config::Config;
use crate::run::{RunSummary, StreamStats, OUTAGE};
use nalgebra::Vector3;

/// Streams below this many updates used are not judged (the band needs a sample).
const MIN_EPOCHS: usize = 30;

/// How far from 1 the typical innovation (in units of its σ: the square root of the median
/// NIS over the χ² median) must be, either way, before a stream far from its distribution
/// makes the run untrustworthy.
const MATERIAL_FACTOR: f64 = 1.5;

/// The share of a stream's epochs refused as gross errors beyond which they are named
/// among the causes of a flagged run.
const GROSS_SHARE: f64 = 0.2;

/// A lever arm longer than this (m) is named among the causes of a flagged run: a value
/// meant in cm or mm given in m, or the axes of another frame.
const LONG_LEVER_ARM: f64 = 10.0;

/// A run whose result is quietly wrong: what is wrong and the likeliest causes.
#[derive(Clone, Debug, PartialEq)]
pub struct Unhealthy {
    /// What is wrong, one line each.
    pub problems: Vec<String>,
    /// The likeliest causes found, one line each (may be empty).
    pub diagnosis: Vec<String>,
    /// Where the outputs went when an earlier, trusted result was in the output
    /// directory (it is kept; these go beside it), else `None` (written in place).
    pub beside: Option<(std::path::PathBuf, std::path::PathBuf)>,
}

impl core::fmt::Display for Unhealthy {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match &self.beside {
            Some((written, kept)) => writeln!(
                f,
                "the run's result cannot be trusted (its outputs are written to {}; the \
                 earlier result in {} is kept):",
                written.display(),
                kept.display()
            )?,
            None => writeln!(f, "the run's result cannot be trusted (its outputs are written):")?,
        }
        for p in &self.problems {
            writeln!(f, "  - {p}")?;
        }
        if self.diagnosis.is_empty() {
            writeln!(f, "likeliest cause: none the program can tell")?;
        } else {
            writeln!(f, "likeliest cause:")?;
            for d in &self.diagnosis {
                writeln!(f, "  - {d}")?;
            }
        }
        write!(f, "(--accept-inconsistent keeps the result with exit status 0)")
    }
}

impl std::error::Error for Unhealthy {}

/// What is wrong with one GNSS stream, if anything. `persisting`: the stream's errors
/// persist from epoch to epoch (a tight run's pseudoranges with `gnss.tight.error_floor`),
/// so its innovations are not a sample of independent draws and are judged with the other
/// satellites' ([`pseudorange_problem`]) instead of alone.
/// `persisting`: the stream's errors persist from epoch to epoch (its innovations say
/// nothing either way); `follows`: the filter follows them (RTK's fixes: the ionosphere's
/// and troposphere's residuals and the multipath change over minutes, so their
/// innovations are smaller than their errors), and only innovations too large count.
fn stream_problems(s: &StreamStats, persisting: bool, follows: bool) -> Vec<String> {
    let mut out = Vec::new();
    if s.refused * 2 > s.epochs {
        out.push(format!(
            "{}: {} of {} epochs refused (more than half)",
            s.stream, s.refused, s.epochs
        ));
    }
    if s.used() >= MIN_EPOCHS {
        let (f, (lo, hi)) = s.above_median_band();
        // far from the distribution, and by a factor that matters: a log of thousands of
        // fixes tells a typical innovation 0.87× its σ from 1× beyond any doubt
        // (drive-0708 `aided.toml`, 4.65 m, whose refused tail had hidden it), which is
        // no reason to distrust its result
        let factor = s.median_ratio.max(0.0).sqrt();
        let material = !(1.0 / MATERIAL_FACTOR..=MATERIAL_FACTOR).contains(&factor) && !persisting;
        // (a stream the filter follows: its innovations too large on the whole — a tail of
        // them, where the median says nothing — counts as well)
        let (mean, (_, mean_hi)) = s.mean_nis();
        let too_large = follows && mean > mean_hi;
        if (((f < lo && !follows) || f > hi) && material) || too_large {
            out.push(format!(
                "{}: {:.1} % of the innovations used lie above their χ² median, where a \
                 consistent filter has 50 % (outside [{:.1}, {:.1}] %, probability 1e-6), the \
                 typical one {factor:.2}× its σ",
                s.stream,
                100.0 * f,
                100.0 * lo,
                100.0 * hi
            ));
        }
    }
    out
}

/// A tight run's pseudoranges judged together, when their errors persist from epoch to
/// epoch: each satellite's typical innovation is then one draw of its persisting error
/// (less what position and clock absorb), repeated at every epoch, so one satellite 2.8σ
/// off says little, and a median against the χ² median misreads a constant innovation
/// (one of exactly 1σ reads 1.48×). The typical satellite's innovation — the root of the
/// satellites' mean NIS per degree of freedom — above [`MATERIAL_FACTOR`] says the σ of
/// the pseudoranges is too small.
fn pseudorange_problem(gnss: &[&StreamStats]) -> Option<String> {
    let ratios: Vec<f64> = gnss
        .iter()
        .filter(|s| is_pseudorange(s) && s.used() >= MIN_EPOCHS)
        .map(|s| s.mean_nis().0)
        .collect();
    if ratios.is_empty() {
        return None;
    }
    let typical = (ratios.iter().sum::<f64>() / ratios.len() as f64).sqrt();
    (typical > MATERIAL_FACTOR).then(|| {
        format!(
            "pseudoranges: the typical satellite's innovation is {typical:.2}× its σ (the root \
             of the mean NIS over {} satellites): the code σ (`gnss.tight` models: orbit URA, ionosphere, \
             troposphere) is too small for this receiver, or the lever arm or the time tags \
             are wrong",
            ratios.len()
        )
    })
}

/// A satellite's pseudorange stream (tight coupling: `pr G05`).
fn is_pseudorange(s: &StreamStats) -> bool {
    s.stream.to_string().starts_with("pr ")
}

/// A distance in m or km.
fn distance(d: f64) -> String {
    if d >= 1000.0 {
        format!("{:.1} km", d / 1000.0)
    } else {
        format!("{d:.1} m")
    }
}

/// The configured initial position against the first fix the filter used: (horizontal,
/// vertical) distance in m and their 1σ.
fn initial_offset(summary: &RunSummary, config: &Config) -> Option<((f64, f64), (f64, f64))> {
    let p = config.init.position?;
    let fix = summary.first_fix?;
    let m = fix.pos.metric();
    let dn = (fix.pos.lat - p[0].to_radians()) * m.x;
    let de = (fix.pos.lon - p[1].to_radians()) * m.y;
    let dh = fix.pos.h - p[2];
    let s = Vector3::from(config.init.position_std.unwrap_or([0.0; 3]));
    let sigma_h =
        (s.x.powi(2) + s.y.powi(2) + fix.pos_std.x.powi(2) + fix.pos_std.y.powi(2)).sqrt();
    let sigma_v = (s.z.powi(2) + fix.pos_std.z.powi(2)).sqrt();
    Some(((dn.hypot(de), dh.abs()), (sigma_h, sigma_v)))
}

/// The odometer reads motion one way while the filter moves the other for most of the
/// time it reads motion (at least [`REVERSED_TIME`] s): the filter's heading is about 180°
/// off. Its GNSS innovations can stay small (the fixes hold the position; nothing but the
/// odometer, which then never calibrates, tells forward from backward), so only this
/// catches it. The problem and its cause.
fn odometer_reversed(summary: &RunSummary) -> Option<(String, String)> {
    let (moving, reversed) = summary.odometer_reversed;
    (reversed >= REVERSED_TIME && reversed > 0.5 * moving).then(|| {
        (
            format!(
                "odometer: for {reversed:.0} s of the {moving:.0} s it reads motion, the filter \
                 moves the other way (its forward speed beyond 0.5 m/s with the other sign): \
                 its heading is about 180° off, so its attitude and the odometer's use are wrong \
                 however well it follows the fixes"
            ),
            "the initial heading is reversed (the in-motion alignment's, when `init.attitude` is \
             not given: slow motion with a noisy IMU leaves it poorly determined), or \
             `imu.mounting` makes the body's x axis point backward: give `init.attitude` (the \
             heading of the vehicle's forward axis), or check the mounting"
                .into(),
        )
    })
}

/// Seconds the filter must move against the odometer before a run is flagged.
const REVERSED_TIME: f64 = 10.0;

/// The causes each GNSS stream's statistics point to: refusals after gaps, gross errors,
/// innovations far from their σ either way (with `floor`, a tight run's pseudoranges are
/// judged together instead; with `tight`, pseudoranges far below their σ are the
/// satellites' persisting errors).
fn stream_causes(gnss: &[&StreamStats], floor: bool, tight: bool) -> Vec<String> {
    let mut diagnosis = Vec::new();
    // tight coupling: pseudoranges whose innovations are far below their σ
    let mut absorbed = Vec::new();
    for s in gnss {
        if s.refused > 0 && s.refused_after_outage * 2 > s.refused {
            diagnosis.push(format!(
                "{}: {} of the {} refusals follow a GNSS gap of more than {OUTAGE} s until the \
                 next accepted fix: the filter's σ grew too little over the gap (the IMU noise \
                 or bias settings are too small for this sensor)",
                s.stream, s.refused_after_outage, s.refused
            ));
        }
        if s.refused_share() > GROSS_SHARE {
            diagnosis.push(format!(
                "{}: {} of {} epochs ({:.1} %) were refused as gross errors: the stream itself \
                 holds gross errors (multipath, jamming, a receiver's bad fixes), or the \
                 filter was wrong when they came",
                s.stream,
                s.refused,
                s.epochs,
                100.0 * s.refused_share()
            ));
        }
        let factor = s.median_ratio.max(0.0).sqrt();
        if floor && is_pseudorange(s) {
            // judged with the other satellites (`pseudorange_problem`)
        } else if factor > 2.0 && s.used() >= MIN_EPOCHS {
            diagnosis.push(format!(
                "{}: the typical innovation is {factor:.1}× its σ (the median NIS against its \
                 χ² median): the receiver's σ (`gnss.position_std`) or the IMU noise \
                 (`[imu_noise]`) is too small by about that factor",
                s.stream
            ));
        } else if factor < 0.5 && s.used() >= MIN_EPOCHS && tight && is_pseudorange(s) {
            absorbed.push(format!("{} {factor:.2}×", s.stream));
        } else if factor < 0.5 && s.used() >= MIN_EPOCHS {
            diagnosis.push(format!(
                "{}: the typical innovation is {factor:.2}× its σ: the noise settings are \
                 pessimistic by about that factor",
                s.stream
            ));
        }
    }
    if !absorbed.is_empty() {
        // isolated on simulated raw observations (scenarios/tight.toml): with each
        // satellite's orbit, code-bias and atmosphere errors constant over the run, the
        // pseudoranges' NIS/dof is 0.08–0.6 and the position NEES/dof 19; the same errors
        // drawn afresh at every epoch (`raw.white_errors`) give 0.93–1.12 and 0.92
        diagnosis.push(format!(
            "pseudoranges whose typical innovation is far below its σ ({}): with tight \
             coupling the likeliest cause is satellite errors that stay the same from epoch \
             to epoch (orbit and clock, ionosphere and troposphere residuals, code biases): \
             the position and clock absorb them, so the innovations are small while the \
             position's error is not; the reported position σ is then too small, not too \
             large. `gnss.tight.error_floor = true` (the default) keeps the reported σ at \
             least what these errors leave a single point; dual-frequency iono-free codes \
             (`gnss.tight.ionosphere = \"iono-free\"`) or precise orbits shrink them; a \
             smaller pseudorange σ would make it worse",
            absorbed.join(", ")
        ));
    }
    diagnosis
}

/// Judge a finished run: `Err` when a GNSS stream refused more than half of its epochs or
/// its innovations are far from their distribution, or the filter moves against the odometer. `config` is the run's configuration
/// as the user gave it (the initial position, if given, is checked against the first
/// fix).
pub fn assess(summary: &RunSummary, config: &Config) -> Result<(), Unhealthy> {
    let gnss: Vec<&StreamStats> = summary.streams.iter().filter(|s| s.gnss).collect();
    let tight = config.gnss.coupling == crate::config::Coupling::Tight;
    let floor = tight && config.gnss.tight.error_floor;
    let mut problems: Vec<String> = gnss
        .iter()
        .flat_map(|s| stream_problems(s, floor && is_pseudorange(s), summary.follows(s)))
        .collect();
    if floor {
        problems.extend(pseudorange_problem(&gnss));
    }
    let reversed = odometer_reversed(summary);
    problems.extend(reversed.iter().map(|(p, _)| p.clone()));
    if problems.is_empty() {
        return Ok(());
    }
    let mut diagnosis: Vec<String> = reversed.into_iter().map(|(_, d)| d).collect();
    // the initial position, farther from the first fix than its σ and the fix's allow
    if let Some(((h, v), (sh, sv))) = initial_offset(summary, config)
        && (h > 5.0 * sh.max(0.5) || v > 5.0 * sv.max(0.5))
    {
        diagnosis.push(format!(
            "the initial position `init.position` is {} horizontally and {} vertically \
                 from the first GNSS fix (at {:.3} s; 1σ together {:.2} m and {:.2} m): a typo \
                 in it, or in the file's position",
            distance(h),
            distance(v),
            summary.first_fix.map_or(f64::NAN, |f| f.t),
            sh,
            sv
        ));
    }
    diagnosis.extend(stream_causes(&gnss, floor, tight));
    let lever = Vector3::from(config.gnss.lever_arm).norm();
    if lever > LONG_LEVER_ARM {
        diagnosis.push(format!(
            "`gnss.lever_arm` = {:?} is {lever:.1} m long: a value in cm or mm given in m, \
             or the antenna's offset in another frame than the IMU's (forward, right, down)",
            config.gnss.lever_arm
        ));
    }
    Err(Unhealthy { problems, diagnosis, beside: None })
}
