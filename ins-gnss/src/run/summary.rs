//! What a run did: [`RunSummary`], the per-stream statistics and the consistency verdicts.

use super::*;
use ins_gnss_core::gnss::GNSS_POSITION;

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    /// Strategy name.
    pub strategy: String,
    /// IMU epochs processed.
    pub imu_epochs: usize,
    /// GNSS epochs used (accepted + inflated + rejected).
    pub gnss_epochs: usize,
    /// Accepted updates.
    pub accepted: usize,
    /// Inflated updates.
    pub inflated: usize,
    /// Updates with adapted noise smaller than the nominal.
    pub deflated: usize,
    /// Rejected updates.
    pub rejected: usize,
    /// IMU lines skipped / gaps bridged.
    pub imu_skipped: SkipCounts,
    /// GNSS lines skipped.
    pub gnss_skipped: SkipCounts,
    /// NMEA fixes whose σ came from their HDOP (no GST, no `gnss.position_std`).
    pub gnss_sigma_from_hdop: usize,
    /// First and last processed time, s.
    pub span: (f64, f64),
    /// Wall time, s.
    pub wall_time: f64,
    /// Output directory.
    pub out_dir: PathBuf,
    /// Sum of the NIS of the plainly accepted updates, and of their dimensions (the
    /// degrees of freedom): `nis_sum / nis_dof` is the mean NIS per degree of freedom,
    /// 1 for a filter whose uncertainty is consistent with its innovations.
    pub nis_sum: f64,
    /// See [`nis_sum`](Self::nis_sum).
    pub nis_dof: usize,
    /// Time of the first and last GNSS epoch read, s (NaN when none was).
    pub gnss_span: (f64, f64),
    /// Vehicle-aiding updates per stream (NHC, ZUPT, ZARU, odometer): used (accepted or inflated)
    /// and refused.
    pub aiding: [AidingCount; 4],
    /// Headings of two antennas ([`GNSS_HEADING`](ins_gnss_core::heading::GNSS_HEADING)):
    /// used and refused.
    pub headings: AidingCount,
    /// The heading file's headings that found no fix at their time.
    pub headings_unmatched: usize,
    /// Time the vehicle was judged standing (detector and filter speed), s (0 without
    /// ZUPT).
    pub stationary_time: f64,
    /// With the odometer: the time it read motion, and of it the time the filter moved
    /// the other way, s ([`ins_gnss_core::navigator::Navigator::odometer_reversed`]).
    pub odometer_reversed: (f64, f64),
    /// Rows of `nav_smoothed.txt` when the run smoothed (`filter.smooth`), and the wall
    /// time of the backward pass, s.
    pub smoothed: Option<(usize, f64)>,
    /// The IMU noise densities the filter used, SI ([`crate::config::noise_echo`]).
    pub noise: String,
    /// How the parts of the initial state (and the noise) not given were found from the
    /// data ([`crate::start`]), one line each.
    pub start: Vec<String>,
    /// Every stream's innovations, whatever their verdict, in the order first seen.
    pub streams: Vec<StreamStats>,
    /// The first GNSS epoch the filter used.
    pub first_fix: Option<GnssEpoch>,
    /// What each GNSS stream's inliers showed of its noise, at the end of the run
    /// ([`adaptive::GrossErrorGate::learned`]; empty with `filter.gate.learn = false`).
    pub learned: Vec<adaptive::LearnedNoise>,
    /// The fixes' errors as learned, when their persisting part was modelled
    /// (`gnss.errors`).
    pub fix_errors: Option<FixErrorsLearned>,
    /// The bank of hypotheses that judged the fixes' errors (`gnss.errors.model =
    /// "auto"`), when one did.
    pub fix_bank: Option<super::FixErrorBank>,
    /// The rig's calibration as the filter estimated it (`calibrate`).
    pub calibration: Option<CalibrationLearned>,
    /// RTK's fix metrics (`gnss.coupling = "rtk"`).
    pub rtk: Option<RtkSummary>,
}

/// What RTK did in a run: its fix metrics, the fixes the INS prediction contradicted, the
/// base station's position.
#[derive(Clone, Debug, PartialEq)]
pub struct RtkSummary {
    /// Fix rate, time to first fix, the fix's outages, the ratio test's values.
    pub metrics: gnss::rtk::RtkMetrics,
    /// Fixes of the INS-aided RTK filter that the RTK filter alone contradicted (χ²₃
    /// 99.9 %), not used (the INS's position widened, the alone filter's fix used).
    pub gated: usize,
    /// The base station's antenna (ECEF, m).
    pub base: Vector3<f64>,
    /// What the base's file held that is not read (an RTCM 3 file's other messages).
    pub notes: Vec<String>,
}

impl RtkSummary {
    /// The summary's line.
    pub fn line(&self) -> String {
        let m = &self.metrics;
        format!(
            "RTK: {} of {} rover epochs solved, {} fixed ({:.1} %), {} INS-aided fix{} the RTK \
             alone contradicted (not used){}; {}{}",
            m.solved,
            m.epochs,
            m.fixed,
            100.0 * m.fix_rate,
            self.gated,
            if self.gated == 1 { "" } else { "es" },
            if m.failures.is_empty() {
                String::new()
            } else {
                format!("; unsolved: {}", gnss::rtk::reasons_text(&m.failures))
            },
            gnss::rtk::metrics_line(m),
            self.notes.iter().map(|n| format!("; {n}")).collect::<String>()
        )
    }
}

/// The calibration states at the end of a run (`calibrate`): each estimate, its σ
/// and its prior σ (the data's share in it: the ratio of the two).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationLearned {
    /// The lever arm (body FRD, m), its σ and the prior σ per axis, when estimated.
    pub lever_arm: Option<AxesEstimate>,
    /// How late the IMU's stamps, as the file has them, are on the receiver's clock (s),
    /// its σ, the prior σ, and the offset applied to the stamps
    /// (`data.imu_time_offset`, the start's search included), when estimated.
    pub time_offset: Option<(f64, f64, f64, f64)>,
    /// The mounting (roll, pitch, yaw of the body in the vehicle frame, degrees, as
    /// `vehicle.nhc.mounting` takes it), the σ of its correction and the prior σ
    /// (degrees), when estimated.
    pub mounting: Option<(Vector3<f64>, Vector3<f64>, f64)>,
    /// The odometer's scale error (fraction: reading = `(1 + s)` × speed), its σ and the
    /// prior σ; its wheel point's lever arm (body FRD, m), σ and prior σ; when estimated.
    pub odometer: Option<(Estimate, AxesEstimate)>,
}

/// A calibration estimate, its σ and its prior σ.
pub type Estimate = (f64, f64, f64);

/// A calibration estimate per axis, its σ per axis and the prior σ.
pub type AxesEstimate = (Vector3<f64>, Vector3<f64>, f64);

/// The share of its prior σ above which a calibration state is reported as not
/// observable by the run's data: they did not reduce its σ to a fifth.
pub const UNOBSERVED: f64 = 0.2;

/// The names of the axes whose σ stays above [`UNOBSERVED`] of the prior `prior`.
fn unobserved<'a, 'b>(
    names: &[&'a str],
    sigma: impl Iterator<Item = &'b f64>,
    prior: f64,
) -> Vec<&'a str> {
    names.iter().zip(sigma).filter(|(_, s)| **s > UNOBSERVED * prior).map(|(a, _)| *a).collect()
}

/// A share of the prior σ left, in percent.
fn share(s: f64, p: f64) -> String {
    format!("{:.0} %", 100.0 * s / p)
}

/// A point's lever arm (m), its σ, the prior σ and how far the data reduced it.
fn lever_text((l, s, p): AxesEstimate) -> String {
    format!(
        "[{:.3}, {:.3}, {:.3}] m σ [{:.3}, {:.3}, {:.3}] (prior σ {p:.2} m, reduced to {}, {}, \
         {})",
        l.x,
        l.y,
        l.z,
        s.x,
        s.y,
        s.z,
        share(s.x, p),
        share(s.y, p),
        share(s.z, p)
    )
}

/// The lever arm's part of the calibration line.
fn lever_part((l, s, p): AxesEstimate) -> String {
    let blind = unobserved(&["x", "y", "z"], s.iter(), p);
    let mut part = format!("lever arm {}", lever_text((l, s, p)));
    if !blind.is_empty() {
        part += &format!(
            "; not observable by these data on {} (σ not reduced to a fifth of the \
             prior: a drive level and straight does not tell it; measure it, or \
             calibrate on a drive that turns, climbs and changes speed)",
            blind.join(", ")
        );
    } else {
        part += &format!(" (`gnss.lever_arm = [{:.3}, {:.3}, {:.3}]`)", l.x, l.y, l.z);
    }
    part
}

/// The time offset's part of the calibration line.
fn time_offset_part((d, s, p, applied): (f64, f64, f64, f64)) -> String {
    let mut part = format!(
        "time offset: the IMU's stamps {:.4} s {} σ {:.4} s (prior σ {p:.3} s about the \
         stamps shifted by {applied:.3} s, reduced to {})",
        d.abs(),
        if d >= 0.0 { "late" } else { "early" },
        s,
        share(s, p)
    );
    if s > UNOBSERVED * p {
        part += "; not observable by these data (σ not reduced to a fifth of the prior: \
                 a drive that turns and changes speed tells it)";
    } else {
        part += &format!(" (`data.imu_time_offset = {:.4}`)", -d);
    }
    part
}

/// The mounting's part of the calibration line.
fn mounting_part((m, s, p): AxesEstimate) -> String {
    let blind = unobserved(&["pitch", "yaw"], s.iter().skip(1), p);
    let mut part = format!(
        "mounting pitch {:.2}° σ {:.2}°, yaw {:.2}° σ {:.2}° (prior σ {p:.1}°, reduced to \
         {}, {}; the roll, which the non-holonomic constraint cannot see, kept at \
         {:.2}°)",
        m.y,
        s.y,
        m.z,
        s.z,
        share(s.y, p),
        share(s.z, p),
        m.x
    );
    if !blind.is_empty() {
        part += &format!(
            "; not observable by these data on {} (σ not reduced to a fifth of the \
             prior: a drive at speed tells it)",
            blind.join(", ")
        );
    }
    part += &format!(" (`vehicle.nhc.mounting = [{:.2}, {:.2}, {:.2}]`)", m.x, m.y, m.z);
    part
}

/// The odometer's part of the calibration line.
fn odometer_part(((k, ks, kp), (l, s, p)): ((f64, f64, f64), AxesEstimate)) -> String {
    let mut part = format!(
        "odometer scale error {:+.3} % σ {:.3} % (prior σ {:.1} %, reduced to {}), its \
         wheel point {}",
        100.0 * k,
        100.0 * ks,
        100.0 * kp,
        share(ks, kp),
        lever_text((l, s, p))
    );
    let axes = unobserved(&["x", "y", "z"], s.iter(), p);
    if !axes.is_empty() {
        part += &format!(
            "; the wheel point not observable by these data on {} (a forward speed \
             never shows the forward lever arm; the lateral one shows in turns, the \
             vertical one in pitching)",
            axes.join(", ")
        );
    }
    if ks > UNOBSERVED * kp {
        part += "; the scale not observable by these data (σ not reduced to a fifth of \
                 the prior: a drive at speed with GNSS tells it)";
    }
    part
}

impl CalibrationLearned {
    /// The summary's line: each estimate with its σ, how far the data reduced the prior,
    /// and what the data could not tell.
    pub fn line(&self) -> String {
        let parts: Vec<String> = [
            self.lever_arm.map(lever_part),
            self.time_offset.map(time_offset_part),
            self.mounting.map(mounting_part),
            self.odometer.map(odometer_part),
        ]
        .into_iter()
        .flatten()
        .collect();
        format!("calibration: {}", parts.join("; "))
    }
}

/// The fixes' errors at the end of a run that modelled their persisting part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixErrorsLearned {
    /// The persisting part's σ (N, E, D), m, and its correlation time, s.
    pub persisting: (nalgebra::Vector3<f64>, f64),
    /// The white part's variance factor on its declared share.
    pub white: f64,
    /// The factor learned on the declared ratio of the persisting variance to the white.
    pub split: f64,
    /// The whitened innovations' lag-one autocorrelation.
    pub lag_one: f64,
    /// Fixes learned from.
    pub fixes: u64,
    /// The probe that found the errors persisting (`gnss.errors.model = "auto"`), when
    /// one did.
    pub probe: Option<super::FixErrorProbe>,
}

/// A declared σ the data contradict by more than this factor, either way, is named with
/// its key in the summary.
pub const CONTRADICTED: f64 = 3.0;

/// The configuration key that declares a stream's noise.
pub fn noise_key(stream: &str) -> &'static str {
    if stream.starts_with("rr ") {
        "gnss.tight.doppler_std"
    } else if stream.starts_with("pr ") {
        "the pseudoranges' elevation model"
    } else if stream == "tdcp" {
        "gnss.tight.phase_std"
    } else if stream == "gnss-heading" {
        "gnss.heading.std (with replace_std) or the heading file's σ"
    } else if stream == "gnss-velocity" {
        "gnss.velocity_std or the file's velocity σ columns"
    } else if stream == "gnss-position-velocity" {
        "gnss.position_std, gnss.velocity_std or the file's σ columns"
    } else {
        "gnss.position_std or the file's σ columns"
    }
}

impl RunSummary {
    /// The summary's line on the noise learned: each stream's σ factor (what its
    /// inliers' residuals show over the declared σ) and the factor applied; satellites'
    /// streams of one kind as their median and range. Streams the data contradict by more
    /// than [`CONTRADICTED`]× are named with their key. `None` without learning.
    pub fn learned_line(&self) -> Option<String> {
        let seen: Vec<&adaptive::LearnedNoise> =
            self.learned.iter().filter(|l| l.updates >= 20).collect();
        if seen.is_empty() {
            return None;
        }
        let mut parts = Vec::new();
        let mut contradicted = Vec::new();
        for (kind, label) in [("pr ", "pseudoranges"), ("rr ", "Dopplers")] {
            let mut f: Vec<f64> = seen
                .iter()
                .filter(|l| l.stream.starts_with(kind))
                .map(|l| l.factor.sqrt())
                .collect();
            if f.is_empty() {
                continue;
            }
            f.sort_by(f64::total_cmp);
            let med = f[f.len() / 2];
            parts.push(format!(
                "{label} σ × {med:.2} (median of {} satellites, {:.2}–{:.2})",
                f.len(),
                f[0],
                f[f.len() - 1]
            ));
            if !(1.0 / CONTRADICTED..=CONTRADICTED).contains(&med) {
                contradicted.push(format!("{} ({med:.2}×)", noise_key(kind)));
            }
        }
        for l in
            seen.iter().filter(|l| !l.stream.starts_with("pr ") && !l.stream.starts_with("rr "))
        {
            let f = l.factor.sqrt();
            parts.push(format!(
                "{} σ × {f:.2} (applied × {:.2}, {} updates, lag-one autocorrelation {:.2})",
                l.stream,
                l.applied.sqrt(),
                l.updates,
                l.lag_one
            ));
            if !(1.0 / CONTRADICTED..=CONTRADICTED).contains(&f) {
                contradicted.push(format!("`{}` ({f:.2}×)", noise_key(l.stream)));
            }
        }
        let mut line = format!("noise learned: {}", parts.join("; "));
        if !contradicted.is_empty() {
            line += &format!(
                "; the data contradict the declared σ by more than {CONTRADICTED}×: {}",
                contradicted.join(", ")
            );
        }
        Some(line)
    }
}

impl RunSummary {
    /// The summary's line on the fixes' errors, when their persisting part was modelled or
    /// a bank judged them: the model chosen and how, its σ and correlation time, the white
    /// part's σ factor and the innovations' whiteness.
    pub fn fix_errors_line(&self) -> Option<String> {
        if let Some(b) = self.fix_bank.filter(|b| b.white_chosen()) {
            let (sigma, tau) = b.chosen;
            return Some(format!(
                "fix errors: white, chosen by the fixes' likelihood among {} hypotheses \
                 (log-likelihood {:.1} above the likeliest persisting part's, σ [{:.2}, {:.2}, \
                 {:.2}] m, τ {:.0} s)",
                b.runs, b.white, sigma[0], sigma[1], sigma[2], tau
            ));
        }
        let f = self.fix_errors?;
        let (sigma, tau) = f.persisting;
        let (chosen, white) = match self.fix_bank {
            Some(b) => (
                format!(
                    ", chosen by the fixes' likelihood among {} hypotheses (log-likelihood \
                     {:.1} above the next likeliest; the white model's {:.1})",
                    b.runs, b.margin, b.white
                ),
                format!("white σ × {:.2} of the declared", f.white.sqrt()),
            ),
            None => (
                String::new(),
                format!(
                    "white σ × {:.2} of its declared share, the declared ratio of the two × {:.2}",
                    f.white.sqrt(),
                    f.split
                ),
            ),
        };
        Some(format!(
            "fix errors: persisting σ [{:.2}, {:.2}, {:.2}] m (N, E, D; Gauss–Markov, τ {:.0} s, \
             states of the filter){chosen}, {white}; {} fixes, whiteness of the innovations \
             {:.2}",
            sigma[0], sigma[1], sigma[2], tau, f.fixes, f.lag_one
        ))
    }
}

impl RunSummary {
    /// The consistency of the plainly accepted updates' NIS (`None` without any).
    pub fn consistency(&self) -> Option<Consistency> {
        if self.nis_dof == 0 {
            return None;
        }
        let k = self.nis_dof as f64;
        let q = |p| estimator_core::consistency::chi2_quantile(p, k) / k;
        Some(Consistency {
            mean_nis: self.nis_sum / k,
            band: (q(0.005), q(0.995)),
            updates: self.accepted,
        })
    }

    /// Close the streams' statistics at the end of the run.
    pub(crate) fn finish_streams(&mut self) {
        for s in &mut self.streams {
            s.finish();
        }
    }

    /// Count the verdicts of one epoch's updates (GNSS and vehicle aiding apart; only
    /// GNSS updates enter the consistency check).
    pub(crate) fn tally(&mut self, updates: &[UpdateSummary]) {
        for u in updates {
            let i = match self.streams.iter().position(|s| s.stream == u.stream) {
                Some(i) => i,
                None => {
                    self.streams.push(StreamStats::new(u.stream));
                    self.streams.len() - 1
                }
            };
            self.streams[i].add(u, chi2_median(u.dim));
            if u.stream == ins_gnss_core::heading::GNSS_HEADING {
                match u.verdict {
                    Verdict::Rejected => self.headings.rejected += 1,
                    _ => self.headings.used += 1,
                }
                continue;
            }
            if let Some(k) = VEHICLE_STREAMS.iter().position(|s| *s == u.stream) {
                match u.verdict {
                    Verdict::Rejected => self.aiding[k].rejected += 1,
                    _ => self.aiding[k].used += 1,
                }
                continue;
            }
            self.gnss_epochs += 1;
            match u.verdict {
                Verdict::Accepted => {
                    self.accepted += 1;
                    self.nis_sum += u.nis;
                    self.nis_dof += u.dim;
                }
                Verdict::Inflated => self.inflated += 1,
                Verdict::Deflated => self.deflated += 1,
                Verdict::Rejected => self.rejected += 1,
            }
        }
    }
}

impl RunSummary {
    /// Whether the filter follows `st`'s errors: RTK's fixes (the atmosphere's residuals
    /// and the multipath persist for minutes), whose small innovations are then no sign
    /// of a σ too large (the summary's verdicts, the report, [`crate::health::assess`]).
    pub fn follows(&self, st: &StreamStats) -> bool {
        self.rtk.is_some() && st.stream == GNSS_POSITION
    }

    /// The summary's line on two antennas' headings (`None`: none in the data).
    fn headings_line(&self) -> Option<String> {
        let s = self;
        if s.headings.used + s.headings.rejected + s.headings_unmatched == 0 {
            return None;
        }
        let mut line = format!(
            "two antennas: {} headings used, {} refused",
            s.headings.used, s.headings.rejected
        );
        if s.headings_unmatched > 0 {
            line += &format!(
                "; {} of `data.heading` found no fix at their time (within 1 ms) and were \
                 not used",
                s.headings_unmatched
            );
        }
        Some(line)
    }

    /// The lines of the summary (printed by the program, in the report, and in the Python
    /// package's summary).
    pub fn lines(&self) -> Vec<String> {
        let s = self;
        let mut lines = vec![format!(
            "{}: {} IMU epochs ({:.1}–{:.1} s), {} GNSS epochs: {} accepted, {} inflated, {}{} rejected; \
         skipped IMU lines {} (gaps bridged {}), GNSS lines {}; {:.2} s wall, {:.0} epochs/s{}",
            s.strategy,
            s.imu_epochs,
            s.span.0,
            s.span.1,
            s.gnss_epochs,
            s.accepted,
            s.inflated,
            if s.deflated > 0 { format!("{} deflated, ", s.deflated) } else { String::new() },
            s.rejected,
            s.imu_skipped.total() - s.imu_skipped.gaps,
            s.imu_skipped.gaps,
            s.gnss_skipped.total(),
            s.wall_time,
            s.imu_epochs as f64 / s.wall_time.max(1e-9),
            // (a run in memory has no output directory)
            if s.out_dir.as_os_str().is_empty() {
                String::new()
            } else {
                format!("; output {}", s.out_dir.display())
            }
        )];
        if s.gnss_sigma_from_hdop > 0 {
            lines.push(format!(
                "GNSS σ: {} fixes state none (no GST sentence): σ from their HDOP × the fix \
                 type's range error (single point 3 m, DGPS or SBAS 1 m, RTK float 0.3 m, \
                 fixed 0.02 m), a prior the run learns the scale of (`gnss.position_std` \
                 states one)",
                s.gnss_sigma_from_hdop
            ));
        }
        lines.extend(s.start.iter().cloned());
        if !s.noise.is_empty() {
            lines.push(s.noise.clone());
        }
        lines.extend(s.learned_line());
        lines.extend(s.fix_errors_line());
        lines.extend(
            s.calibration.map(|c| c.line()).into_iter().chain(s.rtk.as_ref().map(RtkSummary::line)),
        );
        if s.aiding.iter().any(|a| a.used + a.rejected > 0) || s.stationary_time > 0.0 {
            let [n, z, r, o] = s.aiding;
            lines.push(format!(
            "vehicle aiding: NHC {} used, {} refused; ZUPT {} used, {} refused; ZARU {} used, {} refused; odometer {} used, {} refused; stationary {:.1} s",
            n.used, n.rejected, z.used, z.rejected, r.used, r.rejected, o.used, o.rejected, s.stationary_time
        ));
        }
        lines.extend(s.headings_line());
        for st in &s.streams {
            lines.push(st.verdict_of(s.follows(st)));
            lines.extend(st.adaptation());
        }
        if let Some((rows, secs)) = s.smoothed {
            let mut line = format!("smoothed: {rows} epochs in {secs:.2} s (backward pass)");
            if !s.out_dir.as_os_str().is_empty() {
                line += &format!(
                    " -> {}, {}",
                    s.out_dir.join("nav_smoothed.txt").display(),
                    s.out_dir.join("std_smoothed.txt").display()
                );
            }
            lines.push(line);
        }
        lines
    }
}
