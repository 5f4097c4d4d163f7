//! `ins-gnss rtk`: a rover's RTK positions against a base station, written as an RTKLIB
//! `.pos` (Q = 1 fixed, 2 float), and their comparison with another solution.

use crate::cli::CliError;
use crate::spp::{compare, read_pos, scatter};

use gnss::rtk::{Rtk, RtkEpoch, RtkFailure, RtkMode, RtkOptions};
use gnss::{single_point, ObsEpoch};
use ins_gnss_core::earth::{ecef_to_geodetic, ecef_to_ned_rotation};
use ins_gnss_core::GeoPos;
use ins_gnss_io::formats::{create_partial, publish};
use ins_gnss_io::rtklib::{push_epoch_ns, write_header_mode};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// How far (s) a base epoch may be after the rover's and still count as at or before it
/// (receivers' stamps differ by their clocks' milliseconds).
pub const PAIRING: f64 = 0.5;

/// The base's ECEF position from `--base-position X,Y,Z` (m): three finite numbers whose
/// distance from the Earth's centre is a place on Earth (6,300–6,450 km), or an error
/// naming the option.
pub fn base_position(v: &[f64]) -> Result<Vector3<f64>, CliError> {
    let r = match v {
        [x, y, z] => Vector3::new(*x, *y, *z),
        _ => {
            return Err(format!(
                "--base-position: 3 numbers (ECEF X,Y,Z in m) expected, {} given",
                v.len()
            )
            .into());
        }
    };
    if !(r.iter().all(|c| c.is_finite()) && (6.3e6..=6.45e6).contains(&r.norm())) {
        return Err(format!(
            "--base-position: {:.3},{:.3},{:.3} is {:.0} km from the Earth's centre: not an \
             ECEF position on Earth (m)",
            r.x,
            r.y,
            r.z,
            r.norm() / 1e3
        )
        .into());
    }
    Ok(r)
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
}

impl RtkRun {
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

/// Solves every rover epoch that has a base epoch at most [`RtkOptions::max_age`] older.
pub fn solve_files(
    rover: &Path,
    base: &Path,
    navs: &[PathBuf],
    base_pos: Option<Vector3<f64>>,
    opt: &RtkOptions,
) -> Result<RtkRun, CliError> {
    let mut r = crate::raw_input::RawInput::open(rover, navs)?;
    let mut b = crate::raw_input::RawInput::open(base, navs)?;
    let Some(base_pos) = base_pos.or_else(|| b.approx_position()) else {
        return Err(format!(
            "{}: no APPROX POSITION XYZ in the header: give the base position (--base-position X,Y,Z)",
            base.display()
        )
        .into());
    };
    solve_epochs(&mut r, || Ok(b.next_epoch()?), base_pos, opt)
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
            *run.failures.entry("no base epoch recent enough".into()).or_default() += 1;
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
            Err(f) => {
                let key = match f {
                    RtkFailure::TooFewSatellites(_) => "too few common satellites",
                    RtkFailure::NoSinglePoint => "no single point yet",
                    RtkFailure::Singular => "singular update",
                };
                *run.failures.entry(key.into()).or_default() += 1;
            }
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
    let mut w = create_partial(path)?;
    let (lat, lon, h) = ecef_to_geodetic(&run.base);
    let mode = format!(
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
    );
    write_header_mode(&mut w, &format!("ins-gnss {}", env!("CARGO_PKG_VERSION")), &mode, false)?;
    let mut line = Vec::with_capacity(200);
    for s in &run.solutions {
        let (lat, lon, h) = ecef_to_geodetic(&s.pos);
        let c = ecef_to_ned_rotation(lat, lon);
        line.clear();
        push_epoch_ns(
            &mut line,
            s.time.week as f64,
            s.time.tow,
            &GeoPos { lat, lon, h },
            &(c * s.cov * c.transpose()),
            None,
            if s.fixed { 1 } else { 2 },
            s.sats,
        );
        w.write_all(&line)?;
    }
    w.flush()?;
    drop(w);
    publish(path)?;
    Ok(())
}

/// The fix's metrics of a run: time to first fix, the outages of the fix and the time to
/// fix again, the ratio's minimum and median over the fixed epochs and the others.
fn print_fix_metrics(run: &RtkRun) {
    let (fixed_ratios, other_ratios) = run.ratios();
    let ratios = |(min, median): (f64, f64)| {
        if min.is_nan() {
            "none".to_string()
        } else {
            format!("min {min:.1}, median {median:.1}")
        }
    };
    let refix = run.refix_times();
    out!(
        "time to first fix {}; {} outage{} of the fix{}; ratio of the fixed epochs: {}; of the others: {}",
        run.time_to_first_fix().map_or("never".into(), |t| format!("{t:.0} s")),
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
        ratios(fixed_ratios),
        ratios(other_ratios)
    );
}

/// `ins-gnss rtk`: solve, print, write, compare.
pub fn run(
    rover: &Path,
    base: &Path,
    navs: &[PathBuf],
    base_pos: Option<Vector3<f64>>,
    out: Option<&Path>,
    opt: &RtkOptions,
    against: Option<&Path>,
) -> Result<(), CliError> {
    let run = solve_files(rover, base, navs, base_pos, opt)?;
    let fixed: Vec<Vector3<f64>> =
        run.solutions.iter().filter(|s| s.fixed).map(|s| s.pos).collect();
    out!(
        "{}: {} of {} epochs solved, {} fixed ({:.1} %){}",
        rover.display(),
        run.solutions.len(),
        run.epochs,
        fixed.len(),
        100.0 * run.fix_rate(),
        if run.failures.is_empty() {
            String::new()
        } else {
            format!(
                "; unsolved: {}",
                run.failures.iter().map(|(k, v)| format!("{v} {k}")).collect::<Vec<_>>().join(", ")
            )
        }
    );
    if !fixed.is_empty() {
        let (hs, vs, mean) = scatter(&fixed);
        let (lat, lon, h) = ecef_to_geodetic(&mean);
        out!(
            "fixed: mean {:.9}° {:.9}° {:.4} m, baseline {:.3} m; scatter about it: horizontal {:.4} m, vertical {:.4} m (RMS)",
            lat.to_degrees(),
            lon.to_degrees(),
            h,
            (mean - run.base).norm(),
            hs,
            vs
        );
    }
    print_fix_metrics(&run);
    if let Some(out) = out {
        write_pos(out, &run, opt)?;
        out!("wrote {}", out.display());
    }
    if let Some(a) = against {
        let theirs = read_pos(a)?;
        let ours: Vec<(f64, Vector3<f64>)> =
            run.solutions.iter().map(|s| (s.time.tow, s.pos)).collect();
        let (n, rms, d) = compare(&ours, &theirs);
        let (matched, far) = far_fixes(&run, &theirs, WRONG_FIX);
        out!(
            "against {} ({} epochs): {n} common, 3D RMS difference {rms:.4} m, mean offset N {:.4} E {:.4} D {:.4} m; {far} of the {matched} fixed epochs in common more than {:.0} cm from it (wrong fixes, if it is the truth)",
            a.display(),
            theirs.len(),
            d.x,
            d.y,
            d.z,
            100.0 * WRONG_FIX
        );
    }
    Ok(())
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
