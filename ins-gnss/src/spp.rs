//! `ins-gnss spp`: the single-point solution of a RINEX observation file, written as an
//! RTKLIB `.pos`, and its comparison with another solution of the same file.

use crate::cli::CliError;

use gnss::spp::{single_point, Ionosphere, SppFailure, SppOptions, Troposphere};
use gnss::Spp;
use ins_gnss_core::earth::{ecef_to_geodetic, ecef_to_ned_rotation};
use ins_gnss_core::GeoPos;
use ins_gnss_io::formats::{
    create_partial, partial_path, publish, BadLinePolicy, GnssFormat, GnssReader,
};
use ins_gnss_io::rtklib::{push_epoch_ns, write_header_mode};
use nalgebra::{Matrix3, Vector3};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

/// What a single-point run found.
#[derive(Clone, Debug, Default)]
pub struct SppRun {
    /// Epochs read.
    pub epochs: usize,
    /// The solutions.
    pub solutions: Vec<Spp>,
    /// Epochs without a solution, by reason.
    pub failures: BTreeMap<String, usize>,
    /// Satellites excluded by RAIM, in all.
    pub excluded: usize,
}

impl SppRun {
    /// Each solution's time (GPS seconds of week, as a `.pos` gives them) and ECEF position:
    /// what [`compare`] takes.
    pub fn positions(&self) -> Vec<(f64, Vector3<f64>)> {
        self.solutions.iter().map(|s| (s.solution_time().tow, s.pos)).collect()
    }
}

/// Solves every epoch of `obs` — a RINEX observation file, or a u-blox log (`.ubx`, with
/// the ephemerides of its RXM-SFRBX) — with the ephemerides of `navs` (merged).
pub fn solve_file(obs: &Path, navs: &[&Path], opt: &SppOptions) -> Result<SppRun, CliError> {
    let navs: Vec<std::path::PathBuf> = navs.iter().map(|p| p.to_path_buf()).collect();
    let mut input = crate::raw_input::RawInput::open(obs, &navs)?;
    let mut run = SppRun::default();
    let mut prior: Option<Vector3<f64>> = None;
    while let Some(epoch) = input.next_epoch()? {
        run.epochs += 1;
        let nav = &input.nav;
        match single_point(&epoch, &nav.ephemerides, nav.klobuchar.as_ref(), opt, prior.as_ref()) {
            Ok(s) => {
                prior = Some(s.pos);
                run.excluded += s.excluded.len();
                run.solutions.push(s);
            }
            Err(f) => {
                let key = match f {
                    SppFailure::TooFewSatellites { .. } => "too few satellites",
                    SppFailure::NoConvergence => "no convergence",
                    SppFailure::Singular => "degenerate geometry",
                    SppFailure::Gdop(_) => "GDOP",
                    SppFailure::Residuals { .. } => "residuals fail the χ² check",
                };
                *run.failures.entry(key.to_string()).or_default() += 1;
            }
        }
    }
    Ok(run)
}

/// Writes the solutions as an RTKLIB `.pos` (GPST week and seconds, LLH, NEU σ), atomically.
pub fn write_pos(path: &Path, run: &SppRun, opt: &SppOptions) -> Result<(), CliError> {
    let mode = format!(
        "single point (ionosphere {:?}, troposphere {:?}, elevation mask {:.0}°)",
        opt.ionosphere,
        opt.troposphere,
        opt.elevation_mask.to_degrees()
    );
    let epochs = run.solutions.iter().map(|s| {
        let fix = ins_gnss_core::GnssEpoch::from_single_point(s, 0.0);
        let t = s.solution_time();
        (t.week as f64, t.tow, fix.pos, fix.position_covariance(), 5, s.used.len())
    });
    write_solutions(path, &mode, epochs)
}

/// Writes an RTKLIB `.pos` through `PATH.partial`, renamed into place when complete (an
/// earlier file stays until then): the header with `mode`, then one line per epoch —
/// (GPS week, seconds of week, position, its N E D covariance, Q, satellites). A failure
/// names the file.
pub(crate) fn write_solutions(
    path: &Path,
    mode: &str,
    epochs: impl Iterator<Item = (f64, f64, GeoPos, Matrix3<f64>, u8, usize)>,
) -> Result<(), CliError> {
    let partial = partial_path(path);
    let named = |e: std::io::Error| format!("{}: cannot write: {e}", partial.display());
    let mut w = create_partial(path).map_err(named)?;
    let program = format!("ins-gnss {}", env!("CARGO_PKG_VERSION"));
    write_header_mode(&mut w, &program, mode, false).map_err(named)?;
    let mut line = Vec::with_capacity(200);
    for (week, tow, pos, cov, q, ns) in epochs {
        line.clear();
        push_epoch_ns(&mut line, week, tow, &pos, &cov, None, q, ns);
        w.write_all(&line).map_err(named)?;
    }
    w.flush().map_err(named)?;
    drop(w);
    publish(path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(())
}

/// Reads an RTKLIB `.pos` as `(GPS seconds of week, ECEF)` through the library's GNSS
/// reader (any of RTKLIB's layouts and time systems; epochs of `Q = 0` are left out;
/// errors name the file and line).
pub fn read_pos(path: &Path) -> Result<Vec<(f64, Vector3<f64>)>, CliError> {
    let mut r = GnssReader::open(path, BadLinePolicy::Error)?.with_format(GnssFormat::Rtklib);
    let mut out = Vec::new();
    while let Some(e) = r.next_epoch()? {
        out.push((e.t, ins_gnss_io::rtklib::to_ecef(&e.pos)));
    }
    Ok(out)
}

/// Horizontal and vertical scatter (RMS about the mean, m) of ECEF points, in the local
/// frame at their mean; and the mean.
pub fn scatter(points: &[Vector3<f64>]) -> (f64, f64, Vector3<f64>) {
    if points.is_empty() {
        return (f64::NAN, f64::NAN, Vector3::zeros());
    }
    let mean = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let (lat, lon, _) = ecef_to_geodetic(&mean);
    let c: Matrix3<f64> = ecef_to_ned_rotation(lat, lon);
    let (mut hh, mut vv) = (0.0, 0.0);
    for p in points {
        let d = c * (p - mean);
        hh += d.x * d.x + d.y * d.y;
        vv += d.z * d.z;
    }
    let n = points.len() as f64;
    ((hh / n).sqrt(), (vv / n).sqrt(), mean)
}

/// Differences of two solutions at their common epochs: count, 3D RMS, mean NED offset
/// (ours − theirs).
pub fn compare(
    ours: &[(f64, Vector3<f64>)],
    theirs: &[(f64, Vector3<f64>)],
) -> (usize, f64, Vector3<f64>) {
    let mut n = 0;
    let mut ss = 0.0;
    let mut mean = Vector3::zeros();
    let mut j = 0;
    for (t, p) in ours {
        while j < theirs.len() && theirs[j].0 < t - 1e-3 {
            j += 1;
        }
        if j < theirs.len() && (theirs[j].0 - t).abs() <= 1e-3 {
            let d = p - theirs[j].1;
            let (lat, lon, _) = ecef_to_geodetic(p);
            mean += ecef_to_ned_rotation(lat, lon) * d;
            ss += d.norm_squared();
            n += 1;
        }
    }
    if n == 0 {
        return (0, f64::NAN, Vector3::zeros());
    }
    (n, (ss / n as f64).sqrt(), mean / n as f64)
}

/// Parses `--iono`.
pub fn parse_iono(s: &str) -> Result<Ionosphere, String> {
    match s {
        "off" => Ok(Ionosphere::Off),
        "klobuchar" | "brdc" => Ok(Ionosphere::Klobuchar),
        "iono-free" | "if" => Ok(Ionosphere::IonoFree),
        _ => Err(format!("`{s}`: off, klobuchar or iono-free")),
    }
}

/// Parses `--tropo`.
pub fn parse_tropo(s: &str) -> Result<Troposphere, String> {
    let name = if s == "saas" { "saastamoinen" } else { s };
    Troposphere::from_name(name).ok_or_else(|| format!("`{s}`: off, saastamoinen or niell"))
}

/// A system for `spp --systems`: a RINEX letter or a name
/// ([`gnss::System::parse_list`]).
pub fn parse_system(s: &str) -> Result<gnss::System, String> {
    gnss::System::parse_list(&[s]).map(|v| v[0])
}

/// `ins-gnss spp`: solve, write, print a summary (and the comparison with `against`).
pub fn run(
    obs: &Path,
    navs: &[&Path],
    out: Option<&Path>,
    opt: &SppOptions,
    against: Option<&Path>,
) -> Result<(), CliError> {
    let run = solve_file(obs, navs, opt)?;
    let pts: Vec<Vector3<f64>> = run.solutions.iter().map(|s| s.pos).collect();
    let (hs, vs, mean) = scatter(&pts);
    let (lat, lon, h) = ecef_to_geodetic(&mean);
    out!(
        "{}: {} of {} epochs solved ({}), {} RAIM exclusions",
        obs.display(),
        run.solutions.len(),
        run.epochs,
        if run.failures.is_empty() {
            "no failures".to_string()
        } else {
            gnss::rtk::reasons_text(&run.failures)
        },
        run.excluded
    );
    out!(
        "mean {:.9}° {:.9}° {:.3} m; scatter about it: horizontal {:.3} m, vertical {:.3} m (RMS)",
        lat.to_degrees(),
        lon.to_degrees(),
        h,
        hs,
        vs
    );
    if let Some(out) = out {
        write_pos(out, &run, opt)?;
        out!("wrote {}", out.display());
    }
    if let Some(a) = against {
        let theirs = read_pos(a)?;
        let (n, rms, d) = compare(&run.positions(), &theirs);
        let tp: Vec<Vector3<f64>> = theirs.iter().map(|p| p.1).collect();
        let (ths, tvs, _) = scatter(&tp);
        out!(
            "against {} ({} epochs): {n} common, 3D RMS difference {rms:.3} m, mean offset N {:.3} E {:.3} D {:.3} m; its scatter: horizontal {ths:.3} m, vertical {tvs:.3} m",
            a.display(),
            theirs.len(),
            d.x,
            d.y,
            d.z
        );
    }
    Ok(())
}
