//! `ins-gnss rtk`: a rover's RTK positions against a base station, written as an RTKLIB
//! `.pos` (Q = 1 fixed, 2 float), and their comparison with another solution.

use crate::cli::CliError;
use crate::spp::{compare, read_pos, scatter};

use gnss::rtk::{Rtk, RtkEpoch, RtkMode, RtkOptions};
use gnss::{single_point, ObsEpoch};
use ins_gnss_core::earth::{ecef_to_geodetic, ecef_to_ned_rotation};
use ins_gnss_core::GeoPos;
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

mod report;
pub use report::write_report;

pub use crate::config::rtk_settings::{base_position, RtkSettings};
pub use gnss::rtk::{metrics_line, RtkMetrics, RtkRun, PAIRING};

/// The run against another solution of the same rover ([`compared`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// Epochs in common (within 1 ms).
    pub common: usize,
    /// 3D RMS difference over them, m.
    pub rms: f64,
    /// Mean offset, ours − theirs, N E D, m.
    pub offset: Vector3<f64>,
    /// Fixed epochs with an epoch of the other at their time.
    pub fixed_compared: usize,
    /// Of those, the ones more than [`WRONG_FIX`] from it (wrong fixes, if it is the
    /// truth).
    pub wrong_fixes: usize,
}

/// The run against `theirs` (time of week, ECEF; an RTKLIB `.pos` as [`read_pos`] reads
/// it).
pub fn compared(run: &RtkRun, theirs: &[(f64, Vector3<f64>)]) -> Comparison {
    let ours: Vec<(f64, Vector3<f64>)> =
        run.solutions.iter().map(|s| (s.time.tow, s.pos)).collect();
    let (common, rms, offset) = compare(&ours, theirs);
    let (fixed_compared, wrong_fixes) = far_fixes(run, theirs, WRONG_FIX);
    Comparison { common, rms, offset, fixed_compared, wrong_fixes }
}

/// Solves every rover epoch that has a base epoch at most [`RtkOptions::max_age`] older.
pub fn solve_files(
    rover: &Path,
    base: &Path,
    navs: &[PathBuf],
    base_pos: Option<Vector3<f64>>,
    opt: &RtkOptions,
) -> Result<RtkRun, CliError> {
    let mut r = crate::raw_input::RawInput::open(rover, navs)?;
    let mut b = crate::raw_input::RawInput::open_base(base, navs, r.near())?;
    let Some(base_pos) = base_pos.or_else(|| b.approx_position()) else {
        return Err(format!(
            "{}: no APPROX POSITION XYZ in the header (RTCM 3: no 1005 or 1006 message): give \
             the base position (--base-position X,Y,Z)",
            base.display()
        )
        .into());
    };
    let mut run = solve_epochs(&mut r, || Ok(b.next_epoch()?), base_pos, opt)?;
    run.notes.extend(b.unread().map(str::to_owned));
    Ok(run)
}

/// [`solve_files`] on an opened rover and the base's epochs (in time order) from
/// `next_base`: each rover epoch with the latest base epoch at or before it (within
/// [`PAIRING`]), if at most [`RtkOptions::max_age`] older.
pub fn solve_epochs(
    r: &mut crate::raw_input::RawInput,
    mut next_base: impl FnMut() -> Result<Option<ObsEpoch>, CliError>,
    base_pos: Vector3<f64>,
    opt: &RtkOptions,
) -> Result<RtkRun, CliError> {
    let mut rtk = Rtk::new(base_pos, opt.clone());
    let mut run = RtkRun { base: base_pos, ..Default::default() };
    let mut prior = None;
    let (mut current, mut coming) = (None::<ObsEpoch>, next_base()?);
    while let Some(e) = r.next_epoch()? {
        run.epochs += 1;
        while coming.as_ref().is_some_and(|x| x.time.diff(&e.time) <= PAIRING) {
            current = coming.take();
            coming = next_base()?;
        }
        let Some(be) = current.as_ref().filter(|x| e.time.diff(&x.time) <= opt.max_age + PAIRING)
        else {
            run.fail(gnss::rtk::NO_BASE_EPOCH);
            continue;
        };
        let nav = &r.nav;
        let spp =
            single_point(&e, &nav.ephemerides, nav.klobuchar.as_ref(), &opt.spp, prior.as_ref())
                .ok();
        prior = spp.as_ref().map(|s| s.pos).or(prior);
        match rtk.step(&e, be, &nav.ephemerides, spp.as_ref().map(|s| s.pos)) {
            // (the instant the position holds at, as RTKLIB writes it: the time stamp
            // corrected by the single point's receiver clock)
            Ok(s) => run
                .solutions
                .push(RtkEpoch { time: spp.as_ref().map_or(s.time, |p| p.solution_time()), ..s }),
            Err(f) => run.fail(f.reason()),
        }
    }
    Ok(run)
}

/// A fixed epoch further than this (m, 3D) from a reference that is the truth is a wrong
/// fix: a wrong integer moves the position by decimetres (an L1 cycle is 19 cm).
pub const WRONG_FIX: f64 = 0.10;

/// Of the run's fixed epochs, those with a reference epoch at their time (within 1 ms),
/// and how many of them are more than `limit` (m, 3D) from it.
pub fn far_fixes(run: &RtkRun, reference: &[(f64, Vector3<f64>)], limit: f64) -> (usize, usize) {
    let (mut matched, mut far) = (0, 0);
    for s in run.solutions.iter().filter(|s| s.fixed) {
        if let Some((_, p)) = reference.iter().find(|(t, _)| (t - s.time.tow).abs() <= 1e-3) {
            matched += 1;
            far += usize::from((s.pos - p).norm() > limit);
        }
    }
    (matched, far)
}

/// Writes the solutions as an RTKLIB `.pos` (Q = 1 fixed, 2 float), atomically.
pub fn write_pos(path: &Path, run: &RtkRun, opt: &RtkOptions) -> Result<(), CliError> {
    let epochs = run.solutions.iter().map(|s| {
        let (lat, lon, h) = ecef_to_geodetic(&s.pos);
        let c = ecef_to_ned_rotation(lat, lon);
        let q = if s.fixed { 1 } else { 2 };
        (
            s.time.week as f64,
            s.time.tow,
            GeoPos { lat, lon, h },
            c * s.cov * c.transpose(),
            q,
            s.sats,
        )
    });
    crate::spp::write_solutions(path, &describe(run, opt), epochs)
}

/// The fix's metrics of a run as a line ([`metrics_line`]).
fn fix_metrics_line(run: &RtkRun) -> String {
    metrics_line(&run.metrics())
}

/// `ins-gnss rtk`: solve, print, write, compare, and with `report` an HTML report of it
/// ([`write_report`]).
#[allow(clippy::too_many_arguments)]
pub fn run(
    rover: &Path,
    base: &Path,
    navs: &[PathBuf],
    base_pos: Option<Vector3<f64>>,
    out: Option<&Path>,
    opt: &RtkOptions,
    against: Option<&Path>,
    report: Option<&Path>,
) -> Result<(), CliError> {
    let run = solve_files(rover, base, navs, base_pos, opt)?;
    // each line printed as it comes (a failed write comes after the summary), and kept
    // for the report
    let mut lines = Vec::new();
    let mut say = |line: String| {
        out!("{line}");
        lines.push(line);
    };
    say(format!(
        "{}: {} of {} epochs solved, {} fixed ({:.1} %){}",
        rover.display(),
        run.solutions.len(),
        run.epochs,
        run.solutions.iter().filter(|s| s.fixed).count(),
        100.0 * run.fix_rate(),
        if run.failures.is_empty() {
            String::new()
        } else {
            format!("; unsolved: {}", gnss::rtk::reasons_text(&run.failures))
        }
    ));
    if let Some((mean, hs, vs)) = fixed_scatter(&run) {
        let (lat, lon, h) = ecef_to_geodetic(&mean);
        say(format!(
            "fixed: mean {:.9}° {:.9}° {:.4} m, baseline {:.3} m; scatter about it: horizontal {:.4} m, vertical {:.4} m (RMS)",
            lat.to_degrees(),
            lon.to_degrees(),
            h,
            (mean - run.base).norm(),
            hs,
            vs
        ));
    }
    say(fix_metrics_line(&run));
    for n in &run.notes {
        say(n.clone());
    }
    if let Some(out) = out {
        write_pos(out, &run, opt)?;
        say(format!("wrote {}", out.display()));
    }
    if let Some(a) = against {
        let theirs = read_pos(a)?;
        let c = compared(&run, &theirs);
        say(format!(
            "against {} ({} epochs): {} common, 3D RMS difference {:.4} m, mean offset N {:.4} E {:.4} D {:.4} m; {} of the {} fixed epochs in common more than {:.0} cm from it (wrong fixes, if it is the truth)",
            a.display(),
            theirs.len(),
            c.common,
            c.rms,
            c.offset.x,
            c.offset.y,
            c.offset.z,
            c.wrong_fixes,
            c.fixed_compared,
            100.0 * WRONG_FIX
        ));
    }
    if let Some(path) = report {
        write_report(path, &format!("ins-gnss rtk: {}", rover.display()), &lines, &run, opt)?;
        out!("wrote {}", path.display());
    }
    Ok(())
}

/// The mean of the fixed positions (ECEF) and the horizontal and vertical RMS scatter
/// about it (`None`: nothing fixed).
pub(crate) fn fixed_scatter(run: &RtkRun) -> Option<(Vector3<f64>, f64, f64)> {
    let fixed: Vec<Vector3<f64>> =
        run.solutions.iter().filter(|s| s.fixed).map(|s| s.pos).collect();
    (!fixed.is_empty()).then(|| {
        let (hs, vs, mean) = scatter(&fixed);
        (mean, hs, vs)
    })
}

/// The solver's settings in words (the `.pos` header's and the report's).
pub(crate) fn describe(run: &RtkRun, opt: &RtkOptions) -> String {
    let (lat, lon, h) = ecef_to_geodetic(&run.base);
    format!(
        "{} RTK, {} frequenc{}, elevation mask {:.0}°, ratio {:.1}, base {:.9}° {:.9}° {:.4} m",
        match opt.mode {
            RtkMode::Static => "static",
            RtkMode::Kinematic => "kinematic",
        },
        opt.frequencies,
        if opt.frequencies == 1 { "y" } else { "ies" },
        opt.elevation_mask.to_degrees(),
        opt.ratio,
        lat.to_degrees(),
        lon.to_degrees(),
        h
    )
}

#[cfg(feature = "unit-tests")]
#[doc(hidden)]
pub mod tests {
    use super::*;
    use gnss::GpsTime;
    use nalgebra::Matrix3;

    /// The fix's timings and ratios from a run's epochs: fixed at 20 s, lost from 40 to
    /// 60 s (fixed again at 70 s: 40 s after the last fix at 30 s), lost again at the end.
    pub fn fix_timings_and_ratios() {
        let fixed = [false, false, true, true, false, false, false, true, false];
        let solutions = fixed
            .iter()
            .enumerate()
            .map(|(k, &f)| RtkEpoch {
                time: GpsTime::new(1316, 1000.0 + 10.0 * k as f64),
                pos: Vector3::zeros(),
                cov: Matrix3::identity(),
                fixed: f,
                fixed_ambiguities: if f { 4 } else { 0 },
                ratio: if f { 10.0 + k as f64 } else { 1.0 + 0.1 * k as f64 },
                sats: 5,
            })
            .collect();
        let run = RtkRun { epochs: 9, solutions, ..Default::default() };
        assert_eq!(run.time_to_first_fix(), Some(20.0));
        assert_eq!(run.refix_times(), vec![40.0]);
        let ((fmin, fmed), (omin, omed)) = run.ratios();
        assert_eq!((fmin, fmed), (12.0, 13.0));
        assert!((omin - 1.0).abs() < 1e-12 && (omed - 1.5).abs() < 1e-12, "{omin} {omed}");
        assert!((run.fix_rate() - 3.0 / 9.0).abs() < 1e-12);
        // against a reference: epochs 2 and 3 fixed and matched, epoch 3's 12 cm off;
        // epoch 7 fixed, no reference at its time
        let reference: Vec<(f64, Vector3<f64>)> = vec![
            (1020.0, Vector3::zeros()),
            (1030.0, Vector3::new(0.0, 0.12, 0.0)),
            (1040.0, Vector3::zeros()),
        ];
        assert_eq!(far_fixes(&run, &reference, WRONG_FIX), (2, 1));
        let never = RtkRun { solutions: run.solutions[..2].to_vec(), ..Default::default() };
        assert_eq!(never.time_to_first_fix(), None);
        assert!(never.refix_times().is_empty());
    }
}
