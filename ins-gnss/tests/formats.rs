//! File formats: write → read round trips are lossless to printed precision, and every
//! kind of bad input is an error naming file and line (or a counted skip).

use std::io::Cursor;
use std::path::Path;

use ins_gnss::config::Config;
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::imu::ImuSample;
use ins_gnss_core::GeoPos;
use ins_gnss_io::formats::{write_gnss, write_imu, write_nav};
use ins_gnss_io::{
    BadLinePolicy, GnssReader, ImuFormat, ImuReader, LineErrorKind, NavReader, NavRecord,
};
use nalgebra::Vector3;
use proptest::prelude::*;

fn imu_reader(text: &str, policy: BadLinePolicy) -> ImuReader<Cursor<Vec<u8>>> {
    ImuReader::new(
        Cursor::new(text.as_bytes().to_vec()),
        Path::new("imu.txt"),
        ImuFormat::Increments,
        200.0,
        5.0,
        policy,
    )
}

fn read_all_imu(
    text: &str,
    policy: BadLinePolicy,
) -> Result<Vec<ImuSample>, ins_gnss_io::LineError> {
    let mut r = imu_reader(text, policy);
    let mut v = Vec::new();
    while let Some(s) = r.next_sample()? {
        v.push(s);
    }
    Ok(v)
}

fn imu_error_kind(text: &str) -> (usize, LineErrorKind) {
    let e = read_all_imu(text, BadLinePolicy::Error).unwrap_err();
    assert!(e.to_string().starts_with("imu.txt:"), "{e}");
    (e.line, e.kind)
}

const GOOD: &str = "1.000 1e-4 2e-4 3e-4 0.01 0.02 -0.049\n1.005 1e-4 2e-4 3e-4 0.01 0.02 -0.049\n";

proptest! {
    #[test]
    fn imu_round_trip(values in prop::collection::vec(prop::array::uniform6(-0.1f64..0.1), 1..50), t0 in 0.0f64..6e5) {
        let samples: Vec<ImuSample> = values.iter().enumerate().map(|(i, v)| ImuSample {
            t: t0 + 0.005 * (i + 1) as f64,
            dt: 0.005,
            dtheta: Vector3::new(v[0], v[1], v[2]) * 1e-2,
            dvel: Vector3::new(v[3], v[4], v[5]),
            // every other sample with an odometer speed: the 8th column round-trips too
            odometer: (i % 2 == 0).then_some(v[0] * 100.0),
        }).collect();
        let mut buf = Vec::new();
        for s in &samples { write_imu(&mut buf, s).unwrap(); }
        let back = read_all_imu(std::str::from_utf8(&buf).unwrap(), BadLinePolicy::Error).unwrap();
        prop_assert_eq!(back.len(), samples.len());
        for (a, b) in samples.iter().zip(&back) {
            // Time is written with 6 decimals: half a unit of the last one, plus the
            // binary rounding of the value written and of the value read back.
            prop_assert!((a.t - b.t).abs() <= 5e-7 + 4.0 * f64::EPSILON * a.t.abs());
            prop_assert!((a.dtheta - b.dtheta).abs().max() <= 1e-12 * a.dtheta.abs().max().max(1e-300) + 1e-300);
            prop_assert!((a.dvel - b.dvel).abs().max() <= 1e-12 * a.dvel.abs().max().max(1e-300) + 1e-300);
            prop_assert_eq!(a.odometer.is_some(), b.odometer.is_some());
            prop_assert!((a.odometer.unwrap_or(0.0) - b.odometer.unwrap_or(0.0)).abs() <= 5e-7 + 1e-15 * a.odometer.unwrap_or(0.0).abs());
        }
    }

    #[test]
    fn gnss_round_trip(lat in -89.0f64..89.0, lon in -179.0f64..179.0, h in -100.0f64..9000.0,
                       s in prop::array::uniform3(0.01f64..50.0), vel in prop::option::of(prop::array::uniform3(-50.0f64..50.0))) {
        let e = GnssEpoch::new(
            1234.5,
            GeoPos::from_degrees(lat, lon, h),
            Vector3::new(s[0], s[1], s[2]),
            vel.map(|v| (Vector3::new(v[0], v[1], v[2]), Vector3::new(0.05, 0.05, 0.1))),
        );
        let mut buf = Vec::new();
        write_gnss(&mut buf, &e).unwrap();
        let mut r = GnssReader::new(Cursor::new(buf), Path::new("gnss.txt"), BadLinePolicy::Error);
        let b = r.next_epoch().unwrap().unwrap();
        prop_assert_eq!(r.columns(), Some(if vel.is_some() { 13 } else { 7 }));
        // 1e-10° ≈ 1e-5 m; h and σ to 1e-4 m; velocity to 1e-5 m/s.
        prop_assert!((b.pos.lat - e.pos.lat).abs().to_degrees() <= 6e-11);
        prop_assert!((b.pos.lon - e.pos.lon).abs().to_degrees() <= 6e-11);
        prop_assert!((b.pos.h - e.pos.h).abs() <= 6e-5);
        prop_assert!((b.pos_std - e.pos_std).abs().max() <= 6e-5);
        if let (Some((v1, s1)), Some((v2, s2))) = (e.vel, b.vel) {
            prop_assert!((v1 - v2).abs().max() <= 6e-6 && (s1 - s2).abs().max() <= 6e-6);
        }
    }

    #[test]
    fn nav_round_trip(lat in -89.0f64..89.0, lon in -179.0f64..179.0, h in -100.0f64..9000.0,
                      v in prop::array::uniform3(-80.0f64..80.0), a in prop::array::uniform3(-3.1f64..3.1)) {
        let r = NavRecord {
            week: 2200.0,
            t: 86400.25,
            pos: GeoPos::from_degrees(lat, lon, h),
            vel: Vector3::new(v[0], v[1], v[2]),
            att: Vector3::new(a[0], a[1] / 2.0, a[2]),
        };
        let mut buf = Vec::new();
        write_nav(&mut buf, &r).unwrap();
        let b = NavReader::new(Cursor::new(buf), Path::new("nav.txt")).next_record().unwrap().unwrap();
        prop_assert!((b.t - r.t).abs() <= 6e-7 && (b.week - r.week).abs() < 0.5);
        prop_assert!((b.pos.lat - r.pos.lat).abs().to_degrees() <= 6e-11);
        prop_assert!((b.pos.lon - r.pos.lon).abs().to_degrees() <= 6e-11);
        prop_assert!((b.pos.h - r.pos.h).abs() <= 6e-5);
        prop_assert!((b.vel - r.vel).abs().max() <= 6e-6);
        prop_assert!((b.att - r.att).abs().max().to_degrees() <= 6e-9);
    }
}

#[test]
fn config_round_trip_through_toml() {
    let cfg =
        Config::load(Path::new(env!("CARGO_MANIFEST_DIR")).join("config.example.toml").as_path())
            .unwrap();
    let text = toml::to_string(&cfg).unwrap();
    let dir = std::env::temp_dir().join(format!("estimator-cfg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("c.toml");
    std::fs::write(&p, text).unwrap();
    let back = Config::load(&p).unwrap();
    // Paths were made absolute by the first load; everything else is equal.
    assert_eq!(back, cfg);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn imu_bad_lines_are_located_errors() {
    assert_eq!(
        imu_error_kind("1.0 1 2 3 4 5\n"),
        (1, LineErrorKind::ColumnCount { expected: vec![7, 8], found: 6 })
    );
    assert_eq!(
        imu_error_kind(&format!("{GOOD}1.010 1e-4 x 3e-4 0.01 0.02 -0.049\n")),
        (3, LineErrorKind::NotNumeric { column: 3, text: "x".into() })
    );
    assert_eq!(
        imu_error_kind(&format!("{GOOD}1.010 1e-4 NaN 3e-4 0.01 0.02 -0.049\n")),
        (3, LineErrorKind::NonFinite { column: 3 })
    );
    assert_eq!(
        imu_error_kind(&format!("{GOOD}1.010 1e-4 inf 3e-4 0.01 0.02 -0.049\n")),
        (3, LineErrorKind::NonFinite { column: 3 })
    );
    assert_eq!(
        imu_error_kind(&format!("{GOOD}1.001 1e-4 2e-4 3e-4 0.01 0.02 -0.049\n")),
        (3, LineErrorKind::TimeBackwards { t: 1.001, previous: 1.005 })
    );
    assert_eq!(
        imu_error_kind(&format!("{GOOD}1.005 1e-4 2e-4 3e-4 0.01 0.02 -0.049\n")),
        (3, LineErrorKind::DuplicateTime { t: 1.005 })
    );
    let (line, kind) = imu_error_kind(&format!("{GOOD}1.100 1e-4 2e-4 3e-4 0.01 0.02 -0.049\n"));
    assert_eq!(line, 3);
    assert!(matches!(kind, LineErrorKind::Gap { .. }));
    // Rates given where increments are expected (a stationary accelerometer: 9.8 m/s²).
    let (line, kind) = imu_error_kind("1.000 0.001 0.002 0.003 0.01 0.02 -9.8\n");
    assert_eq!(line, 1);
    assert!(matches!(kind, LineErrorKind::WrongUnits(m) if m.contains("look like rates")));
    assert_eq!(imu_error_kind("# only a comment\n\n"), (0, LineErrorKind::Empty));
}

#[test]
fn imu_skip_policy_counts_what_it_skips() {
    let text = format!(
        "{GOOD}1.010 1 2\n1.010 1e-4 x 3e-4 0.01 0.02 -0.049\n1.003 1e-4 2e-4 3e-4 0.01 0.02 -0.049\n\
         1.005 1e-4 2e-4 3e-4 0.01 0.02 -0.049\n1.100 1e-4 2e-4 3e-4 0.01 0.02 -0.049\n"
    );
    let mut r = imu_reader(&text, BadLinePolicy::Skip);
    let mut n = 0;
    while r.next_sample().unwrap().is_some() {
        n += 1;
    }
    assert_eq!(n, 3); // two good lines and the bridged gap
    assert_eq!(r.skipped.malformed, 2);
    assert_eq!(r.skipped.backwards, 1);
    assert_eq!(r.skipped.duplicate, 1);
    assert_eq!(r.skipped.gaps, 1);
}

#[test]
fn gnss_bad_input() {
    let read = |t: &str| {
        let mut r = GnssReader::new(
            Cursor::new(t.as_bytes().to_vec()),
            Path::new("gnss.txt"),
            BadLinePolicy::Error,
        );
        let mut out = Vec::new();
        loop {
            match r.next_epoch() {
                Ok(Some(e)) => out.push(e),
                Ok(None) => return Ok(out),
                Err(e) => return Err(e),
            }
        }
    };
    let ok7 = "10 30.0 114.0 20.0 1 1 2\n";
    // A later line with the other column count.
    let e = read(&format!("{ok7}11 30.0 114.0 20.0 1 1 2 0 0 0 0.1 0.1 0.1\n")).unwrap_err();
    assert!(e.to_string().contains("gnss.txt:2"));
    assert_eq!((e.line, e.kind), (2, LineErrorKind::ColumnCount { expected: vec![7], found: 13 }));
    let e = read("10 130.0 114.0 20.0 1 1 2\n").unwrap_err();
    assert!(matches!(e.kind, LineErrorKind::WrongUnits(m) if m.contains("latitude")));
    let e = read("10 30.0 114.0 20.0 1 0 2\n").unwrap_err();
    assert!(matches!(e.kind, LineErrorKind::WrongUnits(m) if m.contains("positive")));
    let e = read(&format!("{ok7}9 30.0 114.0 20.0 1 1 2\n")).unwrap_err();
    assert!(matches!(e.kind, LineErrorKind::TimeBackwards { .. }));
    assert_eq!(read("").unwrap_err().kind, LineErrorKind::Empty);
    assert_eq!(read(ok7).unwrap().len(), 1);
}

#[test]
fn missing_file_and_config_errors_name_what() {
    let e = ImuReader::open(
        Path::new("/nonexistent/imu.txt"),
        ImuFormat::Increments,
        100.0,
        5.0,
        BadLinePolicy::Error,
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("/nonexistent/imu.txt"));
    let dir = std::env::temp_dir().join(format!("estimator-cfgerr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        Config::load(&p).unwrap_err().to_string()
    };
    let example =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("config.example.toml"))
            .unwrap();
    // A mistyped key.
    let msg = write("typo.toml", &example.replace("imu_rate = 100.0", "imu_rat = 100.0"));
    assert!(msg.contains("imu_rat"), "{msg}");
    // A missing key.
    let msg = write("missing.toml", &example.replace("corr_time = 1.0", ""));
    assert!(msg.contains("corr_time"), "{msg}");
    // A value out of range.
    let msg = write("range.toml", &example.replace("imu_rate = 100.0", "imu_rate = -5.0"));
    assert!(msg.contains("data.imu_rate"), "{msg}");
    // An unknown strategy.
    let msg =
        write("strategy.toml", &example.replace("# strategy = \"fixed\"", "strategy = \"magic\""));
    assert!(msg.contains("magic") && msg.contains("sage-husa"), "{msg}");
    // KF-GINS YAML with a key missing.
    let msg = write(
        "kf.yaml",
        "imupath: \"a.txt\"\ngnsspath: \"b.txt\"\nimudatarate: 200\nstarttime: 1\n",
    );
    assert!(msg.contains("initpos"), "{msg}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Compressed inputs read as the plain file does (gzip, zstd, xz), and a corrupt
/// compressed file is an error naming it, not a short read.
#[test]
fn compressed_files_read_like_plain_ones() {
    use std::io::{Read, Write};
    let dir = std::env::temp_dir().join(format!("estimator-compressed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text: String = (0..2000)
        .map(|i| format!("{:.3} 1e-5 -2e-5 3e-5 0.001 -0.002 -0.196\n", 100.0 + i as f64 * 0.01))
        .collect();
    let plain = dir.join("IMU.txt");
    std::fs::write(&plain, &text).unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(text.as_bytes()).unwrap();
    std::fs::write(dir.join("IMU.txt.gz"), gz.finish().unwrap()).unwrap();
    let xz = liblzma::encode_all(text.as_bytes(), 6).unwrap();
    std::fs::write(dir.join("IMU.txt.xz"), &xz).unwrap();
    let zst = zstd::encode_all(text.as_bytes(), 1).unwrap();
    std::fs::write(dir.join("IMU.txt.zst"), zst).unwrap();
    for name in ["IMU.txt", "IMU.txt.gz", "IMU.txt.xz", "IMU.txt.zst"] {
        let mut s = String::new();
        ins_gnss_io::formats::open(&dir.join(name)).unwrap().read_to_string(&mut s).unwrap();
        assert_eq!(s, text, "{name}");
    }
    // a truncated xz stream and garbage named .zst/.gz fail with the file's name
    std::fs::write(dir.join("bad.txt.xz"), &xz[..xz.len() / 2]).unwrap();
    std::fs::write(dir.join("bad.txt.zst"), b"not zstd at all").unwrap();
    std::fs::write(dir.join("bad.txt.gz"), b"not gzip at all").unwrap();
    for name in ["bad.txt.xz", "bad.txt.zst", "bad.txt.gz"] {
        let p = dir.join(name);
        let mut reader =
            ImuReader::open(&p, ImuFormat::Increments, 100.0, 5.0, BadLinePolicy::Error)
                .map(Some)
                .unwrap_or_else(|e| {
                    assert!(e.to_string().contains(name), "{e}");
                    None
                });
        if let Some(r) = reader.as_mut() {
            let mut result = Ok(None);
            for _ in 0..5000 {
                result = r.next_sample();
                if !matches!(result, Ok(Some(_))) {
                    break;
                }
            }
            let e = result.expect_err(name);
            assert!(e.to_string().contains(name), "{e}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
