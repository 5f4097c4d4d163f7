//! `ins-gnss rtk` on the shipped real baseline (GEONET 0759 rover, 3040 base, 3.3 km,
//! GPS L1 + L2, 30 s, one hour): against RTKLIB's static RTK of the same files with the
//! same base position (`rnx2rtkp -p 3 -f 2 -r -3978242.4348 3382841.1715 3649902.7667
//! -o h3.pos 07590920.05o 30400920.05o 07590920.05n`, Debian's rtklib 2.4.3: 115 of 115
//! epochs fixed, mean 35.160875026° 139.613838576° 70.2767 m).

use ins_gnss::rtk::{solve_files, RtkRun};
use ins_gnss_core::earth::{ecef_to_ned_rotation, geodetic_to_ecef};
use ins_gnss_core::raw::rtk::{RtkMode, RtkOptions};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/rinex-rtklib").join(name)
}

/// RTKLIB's static solution's mean (ECEF).
fn reference() -> Vector3<f64> {
    geodetic_to_ecef(35.160875026f64.to_radians(), 139.613838576f64.to_radians(), 70.2767)
}

fn solve(mode: RtkMode, frequencies: usize) -> RtkRun {
    let opt = RtkOptions { mode, frequencies, ..Default::default() };
    solve_files(
        &data("07590920.05o.zst"),
        &data("30400920.05o.zst"),
        &[data("07590920.05n.zst")],
        None,
        &opt,
    )
    .unwrap()
}

/// Each fixed epoch's horizontal and vertical distance (m) from the reference.
fn errors(run: &RtkRun) -> Vec<(f64, f64)> {
    let r = reference();
    let (lat, lon, _) = ins_gnss_core::earth::ecef_to_geodetic(&r);
    let c = ecef_to_ned_rotation(lat, lon);
    run.solutions
        .iter()
        .filter(|s| s.fixed)
        .map(|s| {
            let d = c * (s.pos - r);
            (d.x.hypot(d.y), d.z.abs())
        })
        .collect()
}

/// Static, L1 + L2: every epoch solved and fixed, each within 1 cm horizontally and 1.5 cm
/// vertically of RTKLIB's solution (ours: 4 mm 3D RMS from it epoch by epoch).
#[test]
fn static_rtk_fixes_every_epoch_where_rtklib_does() {
    let run = solve(RtkMode::Static, 2);
    assert_eq!((run.epochs, run.solutions.len()), (120, 120), "{:?}", run.failures);
    assert_eq!(run.fix_rate(), 1.0);
    let e = errors(&run);
    let worst = e.iter().fold((0.0f64, 0.0f64), |a, b| (a.0.max(b.0), a.1.max(b.1)));
    assert!(worst.0 < 0.010 && worst.1 < 0.015, "largest distance from RTKLIB's: {worst:?}");
}

/// Kinematic (the position free each epoch), L1 + L2: at least 95 % of the epochs fixed,
/// none of them a wrong fix (10 cm from the static reference: a cycle is 19 cm), and the
/// reported σ of the fixed epochs covers their error (≤ 5 % beyond 3σ in any axis).
#[test]
fn kinematic_rtk_fixes_without_wrong_fixes() {
    let run = solve(RtkMode::Kinematic, 2);
    assert!(run.fix_rate() >= 0.95, "fix rate {:.3}", run.fix_rate());
    let e = errors(&run);
    let wrong = e.iter().filter(|(h, v)| h.hypot(*v) > 0.10).count();
    assert_eq!(wrong, 0, "{wrong} wrong fixes");
    let r = reference();
    let beyond = run
        .solutions
        .iter()
        .filter(|s| s.fixed)
        .filter(|s| (0..3).any(|i| (s.pos[i] - r[i]).abs() > 3.0 * s.cov[(i, i)].sqrt()))
        .count();
    assert!(beyond as f64 <= 0.05 * e.len() as f64, "{beyond} of {} beyond 3σ", e.len());
}

/// The `.pos` written reads back (RTKLIB's layout) to the solutions, Q = 1 on fixed epochs.
#[test]
fn the_pos_file_reads_back() {
    let opt = RtkOptions { mode: RtkMode::Static, ..Default::default() };
    let run = solve(RtkMode::Static, 2);
    let dir = tempfile_dir();
    let path = dir.join("rtk.pos");
    ins_gnss::rtk::write_pos(&path, &run, &opt).unwrap();
    let back = ins_gnss::spp::read_pos(&path).unwrap();
    assert_eq!(back.len(), run.solutions.len());
    for ((t, p), s) in back.iter().zip(&run.solutions) {
        assert!((t - s.time.tow).abs() < 1e-3 && (p - s.pos).norm() < 1e-3, "{t} {p} {:?}", s);
    }
    let text = std::fs::read_to_string(&path).unwrap();
    let q1 = text
        .lines()
        .filter(|l| !l.starts_with('%'))
        .filter(|l| l.split_whitespace().nth(5) == Some("1"))
        .count();
    assert_eq!(q1, run.solutions.len());
    std::fs::remove_dir_all(dir).unwrap();
}

fn tempfile_dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("rtk-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}
