//! RTKLIB solution files: a simulated drive's GNSS written as `.pos` (LLH in GPST
//! date-times with velocity; ECEF in UTC without) runs to the same `nav.txt` as the
//! KF-GINS-format file; the run's `nav.pos` reads back through the same reader, and
//! RTKLIB's own `pos2kml` converts it (required when `ESTIMATOR_REQUIRE_RTKLIB` is set, as
//! `.ci/run` does after installing Debian's `rtklib`).

use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};
use std::process::Command;

use ins_gnss_core::earth::{ecef_to_ned_rotation, geodetic_to_ecef};
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_io::formats::write_gnss;
use ins_gnss_io::rtklib::{civil_from_days, parse_line, PosHeader, QualityFactors};
use ins_gnss_io::{BadLinePolicy, GnssReader, NavReader};
use nalgebra::{Matrix3, Vector3};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ins-gnss"))
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("estimator-rtklib-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// GPS week of the written dates: 2025-08-24 (a Sunday), when GPS − UTC = 18 s.
const WEEK: i64 = 2381;

/// `yyyy/mm/dd hh:mm:ss.sss` of GPS week [`WEEK`], seconds `t` (minus `shift` s).
fn date_time(t: f64, shift: f64) -> String {
    let s = WEEK as f64 * 604_800.0 + t - shift;
    let days = (s / 86_400.0).floor();
    let (y, m, d) = civil_from_days(3657 + days as i64);
    let r = s - days * 86_400.0;
    let (hh, mm) = ((r / 3600.0).floor(), ((r % 3600.0) / 60.0).floor());
    format!("{y:04}/{m:02}/{d:02} {:02}:{:02}:{:09.6}", hh, mm, r - hh * 3600.0 - mm * 60.0)
}

fn signed_root(c: f64) -> f64 {
    c.signum() * c.abs().sqrt()
}

fn epochs(path: &Path) -> Vec<GnssEpoch> {
    let mut r = GnssReader::open(path, BadLinePolicy::Error).unwrap();
    let mut v = Vec::new();
    while let Some(e) = r.next_epoch().unwrap() {
        v.push(e);
    }
    v
}

/// LLH, GPST date-times, velocity: the local covariances as σ and signed roots (NEU).
fn write_llh(path: &Path, es: &[GnssEpoch]) {
    let mut w = std::fs::File::create(path).unwrap();
    writeln!(w, "% program   : a test").unwrap();
    writeln!(w, "%  GPST          latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio    vn(m/s)    ve(m/s)    vu(m/s)      sdvn     sdve     sdvu    sdvne    sdveu    sdvun").unwrap();
    for e in es {
        let (v, sv) = e.vel.unwrap();
        writeln!(
            w,
            "{} {:.11} {:.11} {:.6} 1 9 {:.6} {:.6} {:.6} 0 0 0 0.0 0.0 {:.7} {:.7} {:.7} {:.7} {:.7} {:.7} 0 0 0",
            date_time(e.t, 0.0),
            e.pos.lat.to_degrees(),
            e.pos.lon.to_degrees(),
            e.pos.h,
            e.pos_std.x,
            e.pos_std.y,
            e.pos_std.z,
            v.x,
            v.y,
            -v.z,
            sv.x,
            sv.y,
            sv.z
        )
        .unwrap();
    }
}

/// ECEF, UTC date-times (18 s behind GPST), no velocity: the NED σ rotated into ECEF.
fn write_ecef(path: &Path, es: &[GnssEpoch]) {
    let mut w = std::fs::File::create(path).unwrap();
    writeln!(w, "%  UTC                   x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns   sdx(m)   sdy(m)   sdz(m)  sdxy(m)  sdyz(m)  sdzx(m) age(s)  ratio").unwrap();
    for e in es {
        let r = geodetic_to_ecef(e.pos.lat, e.pos.lon, e.pos.h);
        let c_ne = ecef_to_ned_rotation(e.pos.lat, e.pos.lon);
        let c = c_ne.transpose() * e.position_covariance() * c_ne;
        writeln!(
            w,
            "{} {:.7} {:.7} {:.7} 1 9 {:.9} {:.9} {:.9} {:.9} {:.9} {:.9} 0.0 0.0",
            date_time(e.t, 18.0),
            r.x,
            r.y,
            r.z,
            c[(0, 0)].sqrt(),
            c[(1, 1)].sqrt(),
            c[(2, 2)].sqrt(),
            signed_root(c[(0, 1)]),
            signed_root(c[(1, 2)]),
            signed_root(c[(2, 0)])
        )
        .unwrap();
    }
}

/// Runs `config` with its GNSS file replaced by `gnss`; the `nav.txt` records.
fn run_with(dir: &Path, config: &str, gnss: &Path, name: &str) -> Vec<[f64; 11]> {
    let text = config.replace("gnss = \"GNSS.txt\"", &format!("gnss = {:?}", gnss));
    assert_ne!(text, config);
    let file = dir.join(format!("{name}.toml"));
    std::fs::write(&file, text).unwrap();
    let out = dir.join(format!("o-{name}"));
    let o = bin()
        .arg("run")
        .arg(&file)
        .args(["--quiet", "--accept-inconsistent", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
    std::fs::read_to_string(out.join("nav.txt"))
        .unwrap()
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            v.try_into().unwrap()
        })
        .collect()
}

/// Every field within 1e-6, or within one unit of `nav.txt`'s last printed digit where
/// that is coarser (height 1e-4 m, velocity 1e-5 m/s): inputs that differ by rounding
/// (ECEF at 1e-7 m, Unix times at 1e-6 s) can round a few values the other way.
fn same_to_the_printed_digit(a: &[[f64; 11]], b: &[[f64; 11]], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    let last_digit: [f64; 11] = [0.0, 1e-6, 1e-10, 1e-10, 1e-4, 1e-5, 1e-5, 1e-5, 1e-8, 1e-8, 1e-8];
    for (x, y) in a.iter().zip(b) {
        for i in 0..11 {
            let tolerance = (1.01 * last_digit[i]).max(1e-6);
            assert!(
                (x[i] - y[i]).abs() <= tolerance,
                "{what}, t {} column {i}: {} vs {}",
                x[1],
                x[i],
                y[i]
            );
        }
    }
}

fn max_difference(a: &[[f64; 11]], b: &[[f64; 11]]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn an_rtklib_solution_runs_as_its_kf_gins_twin() {
    let dir = temp("twin");
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join("drive.toml");
    let o = bin().arg("simulate").arg(&scenario).arg("--out").arg(&dir).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    let es = epochs(&dir.join("GNSS.txt"));
    assert!(es.len() > 50 && es[0].vel.is_some());

    // LLH, GPST, with velocity, against the 13-column file
    let base = run_with(&dir, &config, &dir.join("GNSS.txt"), "kf-gins");
    write_llh(&dir.join("llh.pos"), &es);
    let llh = run_with(&dir, &config, &dir.join("llh.pos"), "llh");
    let d = max_difference(&base, &llh);
    assert!(d <= 1e-6, "LLH/GPST .pos against the KF-GINS file: {d:e}");

    // ECEF, UTC, no velocity, against the 7-column file
    let mut seven = Vec::new();
    for e in &es {
        write_gnss(&mut seven, &GnssEpoch::new(e.t, e.pos, e.pos_std, None)).unwrap();
    }
    std::fs::write(dir.join("GNSS7.txt"), seven).unwrap();
    let base7 = run_with(&dir, &config, &dir.join("GNSS7.txt"), "kf-gins-7");
    write_ecef(&dir.join("ecef.pos"), &es);
    let read = epochs(&dir.join("ecef.pos"));
    assert_eq!(read.len(), es.len());
    for (a, b) in read.iter().zip(&es) {
        // the 18 s of UTC put back
        assert!((a.t - b.t).abs() < 1e-6, "{} vs {}", a.t, b.t);
        assert!((a.pos_std - b.pos_std).abs().max() < 1e-6);
    }
    let ecef = run_with(&dir, &config, &dir.join("ecef.pos"), "ecef");
    // through ECEF (positions to 1e-7 m in the file) a value can round the other way in
    // nav.txt's last printed digit
    same_to_the_printed_digit(&base7, &ecef, "ECEF/UTC .pos against the 7-column file");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn quality_scales_sigma_and_drops_what_is_asked() {
    let h = PosHeader::parse("%  GPST   latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio").unwrap();
    let line = |q: u8| {
        format!(
            "2025/08/28 17:30:39.749   40.0966268 -105.1474483 1601.474 {q} 8 0.0100 0.0200 0.0300 0.0100 -0.0050 0.0000 0.0 0.0"
        )
    };
    let mut f = QualityFactors::default();
    let fix = parse_line(&h, &line(1), &f).unwrap().unwrap();
    let float = parse_line(&h, &line(2), &f).unwrap().unwrap();
    let single = parse_line(&h, &line(5), &f).unwrap().unwrap();
    assert!((fix.pos_std - Vector3::new(0.01, 0.02, 0.03)).abs().max() < 1e-12);
    assert!((float.pos_std - 2.0 * fix.pos_std).abs().max() < 1e-12);
    assert!((single.pos_std - 5.0 * fix.pos_std).abs().max() < 1e-12);
    // the covariances: sdne = 0.01 → +1e-4 m²; sdeu = −0.005 → E·U = −2.5e-5, E·D = +2.5e-5
    let c = fix.pos_cov.unwrap();
    let expected = Matrix3::new(1e-4, 1e-4, 0.0, 1e-4, 4e-4, 2.5e-5, 0.0, 2.5e-5, 9e-4);
    assert!((c - expected).abs().max() < 1e-15, "{c}");
    f.drop[5] = true;
    assert!(parse_line(&h, &line(5), &f).unwrap().is_none());
    assert!(parse_line(&h, &line(0), &f).unwrap().is_none(), "Q = 0 is no solution");
    // a covariance that is not one is refused
    let bad =
        "2025/08/28 17:30:39.749 40.0966268 -105.1474483 1601.474 1 8 0.01 0.01 0.03 0.02 0 0 0 0";
    assert!(parse_line(&h, bad, &f).is_err());
    // through the reader, with drops counted
    let text = format!(
        "{}\n{}\n{}\n",
        "%  GPST   latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio",
        line(5),
        line(1).replace("39.749", "40.749")
    );
    let mut r = GnssReader::new(Cursor::new(text), Path::new("a.pos"), BadLinePolicy::Error)
        .with_quality(f);
    let e = r.next_epoch().unwrap().unwrap();
    assert!((e.pos_std.x - 0.01).abs() < 1e-12);
    assert!(r.next_epoch().unwrap().is_none());
    assert_eq!(r.dropped[5], 1);
}

#[test]
fn nav_pos_reads_back_and_rtklib_converts_it() {
    let dir = temp("out");
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join("drive.toml");
    let o = bin().arg("simulate").arg(&scenario).arg("--out").arg(&dir).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.join("out");
    let o = bin()
        .arg("run")
        .arg(dir.join("config.toml"))
        .args(["--quiet", "--accept-inconsistent", "--smooth", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // the rows without a GNSS update are written with Q = 5; read back at face value
    let mut r = GnssReader::open(&out.join("nav.pos"), BadLinePolicy::Error)
        .unwrap()
        .with_quality(QualityFactors { factor: [1.0; 7], drop: [false; 7] });
    let mut pos = Vec::new();
    while let Some(e) = r.next_epoch().unwrap() {
        pos.push(e);
    }
    let std = std::fs::read_to_string(out.join("std.txt")).unwrap();
    let mut sigmas: Vec<Vec<f64>> =
        std.lines().map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect()).collect();
    // std.txt repeats the last epoch's row at the end of the run; nav.pos does not
    sigmas.dedup_by(|a, b| a[0] == b[0]);
    assert_eq!(pos.len(), sigmas.len(), "one .pos epoch per std.txt row");
    let mut nav = NavReader::open(&out.join("nav.txt")).unwrap();
    let mut matched = 0;
    let mut rec = nav.next_record().unwrap();
    for (e, s) in pos.iter().zip(&sigmas) {
        assert!((e.t - s[0]).abs() < 1e-4);
        for i in 0..3 {
            assert!(
                (e.pos_std[i] - s[1 + i]).abs() < 2e-6,
                "σ {i}: {} vs {}",
                e.pos_std[i],
                s[1 + i]
            );
        }
        while rec.is_some_and(|r| r.t < e.t - 1e-5) {
            rec = nav.next_record().unwrap();
        }
        if let Some(r) = rec.filter(|r| (r.t - e.t).abs() < 1e-5) {
            assert!((r.pos.lat - e.pos.lat).abs().to_degrees() <= 1e-9);
            assert!((r.pos.lon - e.pos.lon).abs().to_degrees() <= 1e-9);
            assert!((r.pos.h - e.pos.h).abs() <= 1e-4);
            let (v, _) = e.vel.unwrap();
            assert!((r.vel - v).abs().max() <= 1e-5);
            matched += 1;
        }
    }
    assert!(matched as f64 > 0.99 * pos.len() as f64, "{matched} of {}", pos.len());
    // the smoothed result at the epochs of the forward .pos (and of std_smoothed.txt,
    // whose σ it carries), the positions of nav_smoothed.txt
    let smoothed = epochs(&out.join("nav_smoothed.pos"));
    let times = |v: &[GnssEpoch]| v.iter().map(|e| e.t).collect::<Vec<_>>();
    assert_eq!(times(&smoothed), times(&pos), "nav_smoothed.pos at the epochs of nav.pos");
    let std_s = std::fs::read_to_string(out.join("std_smoothed.txt")).unwrap();
    for (e, line) in smoothed.iter().zip(std_s.lines()) {
        let s: Vec<f64> = line.split_whitespace().map(|x| x.parse().unwrap()).collect();
        assert!((e.t - s[0]).abs() < 1e-4);
        for i in 0..3 {
            assert!((e.pos_std[i] - s[1 + i]).abs() < 2e-6, "smoothed σ {i}");
        }
    }
    let mut nav = NavReader::open(&out.join("nav_smoothed.txt")).unwrap();
    let mut n = 0usize;
    while let Some(r) = nav.next_record().unwrap() {
        let Some(e) = smoothed.get(n).filter(|e| (e.t - r.t).abs() < 1e-4) else { continue };
        assert!((r.pos.lat - e.pos.lat).abs().to_degrees() <= 1e-9);
        assert!((r.pos.lon - e.pos.lon).abs().to_degrees() <= 1e-9);
        n += 1;
    }
    assert_eq!(n, smoothed.len(), "every smoothed .pos epoch is a nav_smoothed.txt row");
    // RTKLIB's own reader: every epoch in the KML track
    let kml = dir.join("nav.kml");
    match Command::new("pos2kml").arg("-o").arg(&kml).arg(out.join("nav.pos")).output() {
        Ok(o) => {
            assert!(o.status.success(), "pos2kml: {}", String::from_utf8_lossy(&o.stderr));
            let text = std::fs::read_to_string(&kml).unwrap();
            let start = text.find("<coordinates>").unwrap();
            let end = text[start..].find("</coordinates>").unwrap() + start;
            let points = text[start..end].lines().filter(|l| l.contains(',')).count();
            assert_eq!(points, pos.len(), "every epoch in the KML");
        }
        Err(e) => {
            assert!(
                std::env::var_os("ESTIMATOR_REQUIRE_RTKLIB").is_none(),
                "pos2kml (Debian package rtklib) is required here: {e}"
            );
            eprintln!("pos2kml not installed: RTKLIB's own reader not run ({e})");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// An IMU log in Unix time (UTC), headerless, beside GNSS in RTKLIB GPST date-times: the
/// 18 s of GPS − UTC are applied and the run is the native one.
#[test]
fn an_imu_in_unix_utc_meets_gnss_in_gpst() {
    let dir = temp("unix");
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join("drive.toml");
    let o = bin().arg("simulate").arg(&scenario).arg("--out").arg(&dir).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    let base = run_with(&dir, &config, &dir.join("GNSS.txt"), "base");
    write_llh(&dir.join("llh.pos"), &epochs(&dir.join("GNSS.txt")));
    // Unix seconds of GPS week WEEK, t: the GPS epoch's Unix time, minus GPS − UTC
    let imu = std::fs::read_to_string(dir.join("IMU.txt")).unwrap();
    let unix: String = imu
        .lines()
        .map(|l| {
            let (t, rest) = l.split_once(' ').unwrap();
            let t: f64 = t.parse().unwrap();
            format!("{:.6} {rest}\n", 315_964_800.0 + WEEK as f64 * 604_800.0 + t - 18.0)
        })
        .collect();
    std::fs::write(dir.join("imu_unix.txt"), unix).unwrap();
    let mapped = config.replace("imu = \"IMU.txt\"", "imu = \"imu_unix.txt\"")
        + "\n[data.imu_columns]\nheader = false\ntime = 0\ntime_scale = \"unix-utc\"\n\
         gyro = [1, 2, 3]\naccel = [4, 5, 6]\n";
    let got = run_with(&dir, &mapped, &dir.join("llh.pos"), "unix");
    same_to_the_printed_digit(&base, &got, "Unix-UTC IMU + GPST .pos against the native run");
    // the same IMU read as GPST (no leap seconds): 18 s off the GNSS, it is not the same
    // run (refused by the start's checks, or another result)
    let wrong = mapped.replace("time_scale = \"unix-utc\"", "time_scale = \"gps-seconds\"");
    let file = dir.join("wrong.toml");
    let text = wrong.replace("gnss = \"GNSS.txt\"", &format!("gnss = {:?}", dir.join("llh.pos")));
    std::fs::write(&file, text).unwrap();
    let o = bin()
        .arg("run")
        .arg(&file)
        .args(["--quiet", "--accept-inconsistent", "--out"])
        .arg(dir.join("o-wrong"))
        .output()
        .unwrap();
    if o.status.success() {
        let nav = std::fs::read_to_string(dir.join("o-wrong").join("nav.txt")).unwrap();
        let t0: f64 = nav.split_whitespace().nth(1).unwrap().parse().unwrap();
        assert!((t0 - base[0][1]).abs() > 17.9, "the IMU's times move by 18 s: {t0}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `$body*hh` with its checksum.
fn sentence(body: &str) -> String {
    let c = body.bytes().fold(0u8, |a, b| a ^ b);
    format!("${body}*{c:02X}\n")
}

/// ddmm.mmmmmmmmmm and its hemisphere.
fn nmea_angle(deg: f64, degree_digits: usize, pos: char, neg: char) -> (String, char) {
    let a = deg.abs();
    let d = a.floor();
    let m = (a - d) * 60.0;
    (format!("{:0w$}{:013.10}", d as i64, m, w = degree_digits), if deg < 0.0 { neg } else { pos })
}

/// The scenario simulated into `dir`: its configuration's text and its fixes, written
/// again as the 7-column `GNSS7.txt` (σ columns, no velocity).
fn simulated_with_seven(scenario: &Path, dir: &Path) -> (String, Vec<GnssEpoch>) {
    let o = bin().arg("simulate").arg(scenario).arg("--out").arg(dir).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    let es = epochs(&dir.join("GNSS.txt"));
    let mut seven = Vec::new();
    for e in &es {
        write_gnss(&mut seven, &GnssEpoch::new(e.t, e.pos, e.pos_std, None)).unwrap();
    }
    std::fs::write(dir.join("GNSS7.txt"), seven).unwrap();
    (config, es)
}

/// An epoch's NMEA fields: the UTC time `hhmmss.ss…`, the date `ddmmyy`, latitude and
/// longitude with their hemispheres.
fn nmea_fields(e: &GnssEpoch) -> (String, String, (String, char), (String, char)) {
    let dt = date_time(e.t, 18.0); // yyyy/mm/dd hh:mm:ss.ssssss, UTC
    let (date, time) = dt.split_once(' ').unwrap();
    let ddmmyy = format!("{}{}{}", &date[8..10], &date[5..7], &date[2..4]);
    let lat = nmea_angle(e.pos.lat.to_degrees(), 2, 'N', 'S');
    let lon = nmea_angle(e.pos.lon.to_degrees(), 3, 'E', 'W');
    (time.replace(':', ""), ddmmyy, lat, lon)
}

/// A log whose fixes state no σ (GGA with its HDOP, no GST; a receiver's single points)
/// and a configuration that gives none: the run takes σ from the HDOP and the fix type's
/// range error as a prior (HDOP 0.9 × 3 m / √2 = 1.9 m on each horizontal axis, against
/// the simulated 1 m and 2 m down), says so, and learns the scale. Over the drive's seeds
/// 1–6 (109 s each), the horizontal RMS against the run given the true σ: median ratio
/// within 1.2 (measured from the 7-column twin: 0.75, 0.71, 1.09, 1.07, 2.18, 2.15; the
/// short drive's spread, either way).
#[test]
fn an_nmea_log_without_sigma_runs_on_its_hdop() {
    let mut ratios = Vec::new();
    for seed in 1..=6u64 {
        let dir = temp(&format!("nmea-hdop-{seed}"));
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join("drive.toml"),
        )
        .unwrap();
        let text = text.replacen("seed = 11", &format!("seed = {seed}"), 1);
        let scenario = dir.with_extension("toml");
        std::fs::write(&scenario, text).unwrap();
        let (config, es) = simulated_with_seven(&scenario, &dir);
        run_with(&dir, &config, &dir.join("GNSS7.txt"), "true-sigma");
        let mut log = String::new();
        for e in &es {
            let (hms, ddmmyy, (lat, ns), (lon, ew)) = nmea_fields(e);
            log += &sentence(&format!("GPRMC,{hms},A,{lat},{ns},{lon},{ew},0.0,0.0,{ddmmyy},,,A"));
            log += &sentence(&format!(
                "GPGGA,{hms},{lat},{ns},{lon},{ew},1,9,0.9,{:.6},M,0.0,M,,",
                e.pos.h
            ));
        }
        std::fs::write(dir.join("gnss.nmea"), &log).unwrap();
        let mut r = GnssReader::open(&dir.join("gnss.nmea"), BadLinePolicy::Error).unwrap();
        let first = r.next_epoch().unwrap().unwrap();
        let h = 0.9 * 3.0 / 2f64.sqrt();
        assert!((first.pos_std - Vector3::new(h, h, 2.0 * h)).abs().max() < 1e-12);
        // the program's own summary names where the σ came from
        let file = dir.join("hdop.toml");
        std::fs::write(&file, config.replace("gnss = \"GNSS.txt\"", "gnss = \"gnss.nmea\""))
            .unwrap();
        let o = bin()
            .arg("run")
            .arg(&file)
            .args(["--accept-inconsistent", "--quiet", "--out"])
            .arg(dir.join("o-hdop"))
            .output()
            .unwrap();
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(out.contains("σ from their HDOP"), "{out}");
        let truth = dir.join("truth.nav");
        let rms = |o: &str| {
            ins_gnss::eval::evaluate(&dir.join(o).join("nav.txt"), &truth, 0.0, &[])
                .unwrap()
                .overall
                .horizontal
                .rms
        };
        let (given, hdop) = (rms("o-true-sigma"), rms("o-hdop"));
        eprintln!("seed {seed}: horizontal RMS, true σ {given:.3} m, σ from HDOP {hdop:.3} m");
        ratios.push(hdop / given);
        std::fs::remove_dir_all(&dir).unwrap();
        std::fs::remove_file(&scenario).ok();
    }
    ratios.sort_by(f64::total_cmp);
    let median = 0.5 * (ratios[2] + ratios[3]);
    assert!(median <= 1.2, "median ratio {median}: {ratios:?}");
}

/// A simulated drive's GNSS as an NMEA log (RMC, GGA, GST; UTC; a geoid separation) runs
/// as the 7-column file; a bad checksum is an error with its line, or a counted skip.
#[test]
fn an_nmea_log_runs_as_its_kf_gins_twin() {
    let dir = temp("nmea");
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join("drive.toml");
    let (config, es) = simulated_with_seven(&scenario, &dir);
    let base = run_with(&dir, &config, &dir.join("GNSS7.txt"), "kf-gins-7");
    let mut log = String::new();
    for e in &es {
        let (hms, ddmmyy, (lat, ns), (lon, ew)) = nmea_fields(e);
        let sep = 47.25;
        log += &sentence(&format!("GPRMC,{hms},A,{lat},{ns},{lon},{ew},0.0,0.0,{ddmmyy},,,D"));
        log += &sentence(&format!(
            "GPGGA,{hms},{lat},{ns},{lon},{ew},4,12,0.8,{:.6},M,{sep},M,1.0,0001",
            e.pos.h - sep
        ));
        log += &sentence(&format!(
            "GPGST,{hms},0.5,0.1,0.1,0.0,{},{},{}",
            e.pos_std.x, e.pos_std.y, e.pos_std.z
        ));
        log += &sentence("GPGSV,3,1,12,01,40,083,46,02,17,308,41,12,07,344,39,14,22,228,45");
    }
    std::fs::write(dir.join("gnss.nmea"), &log).unwrap();
    let nmea = run_with(&dir, &config, &dir.join("gnss.nmea"), "nmea");
    same_to_the_printed_digit(&base, &nmea, "NMEA against the 7-column file");
    // one corrupted character: the line is named; skipped and counted with bad_lines = "skip"
    let k = log.find("GPGGA").unwrap() + 8; // a digit of the first GGA's time
    let mut bytes = log.clone().into_bytes();
    bytes[k] ^= 1;
    std::fs::write(dir.join("bad.nmea"), &bytes).unwrap();
    let mut r = GnssReader::open(&dir.join("bad.nmea"), BadLinePolicy::Error).unwrap();
    let err = loop {
        match r.next_epoch() {
            Ok(Some(_)) => continue,
            Ok(None) => panic!("the corrupted sentence was read"),
            Err(e) => break e,
        }
    };
    assert_eq!(err.line, 2, "{err}");
    assert!(err.to_string().contains("checksum"), "{err}");
    let mut r = GnssReader::open(&dir.join("bad.nmea"), BadLinePolicy::Skip).unwrap();
    let mut n = 0;
    while r.next_epoch().unwrap().is_some() {
        n += 1;
    }
    assert_eq!(r.skipped.malformed, 1);
    assert_eq!(n, es.len() - 1, "the epoch of the bad GGA is lost, the others kept");
    std::fs::remove_dir_all(&dir).unwrap();
}
