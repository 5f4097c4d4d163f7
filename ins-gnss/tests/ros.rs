//! robot_localization's Husky bag (`data/ros-husky/test1.bag`) run as it is through
//! `[data.ros]` (IMU, NavSatFix, odometry; no `[init]`, the IMU noise from the messages'
//! covariances), its MCAP copies giving the same outputs byte for byte, and the verdict
//! naming the heading the in-motion alignment got wrong on it.

use ins_gnss_io::ros::{Recording, Selection};
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ins-gnss"))
}

fn husky() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/ros-husky")
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("estimator-ros-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The shipped configuration with `recording` and `extra` lines in `[data.ros]`, written
/// into `dir`.
fn config(dir: &Path, recording: &Path, extra: &str) -> PathBuf {
    let text = std::fs::read_to_string(husky().join("husky.toml")).unwrap();
    let text = text.replace(
        "recording = \"test1.bag\"",
        &format!("recording = {:?}\n{extra}", recording.display().to_string()),
    );
    let path = dir.join("husky.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// [`config`] with a heading given (a hand-written `[init]` attitude: the in-motion fit's
/// 141.4°, with which the track follows the fixes to 0.6 m, against 12.9 m with the
/// course's −49°): the bag as shipped is refused, neither the fit (±22°, its residuals'
/// persistence counted) nor the bank of headings (±47°) telling its heading.
fn config_with_heading(dir: &Path, recording: &Path) -> PathBuf {
    let path = config(dir, recording, "");
    let text = std::fs::read_to_string(&path).unwrap().replace(
        "[imu]\n",
        "[init]\nattitude = [0.0, 0.0, 141.4]\nattitude_std = [2.0, 2.0, 10.0]\n\n[imu]\n",
    );
    std::fs::write(&path, text).unwrap();
    path
}

fn run(config: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    bin().arg("run").arg(config).arg("--out").arg(out).arg("--quiet").args(extra).output().unwrap()
}

/// Horizontal distance (m) between two latitude/longitude pairs (deg), locally flat.
fn horizontal(a: (f64, f64), b: (f64, f64)) -> f64 {
    let r = 6_378_137.0;
    let dn = (a.0 - b.0).to_radians() * r;
    let de = (a.1 - b.1).to_radians() * r * a.0.to_radians().cos();
    dn.hypot(de)
}

/// `nav.txt` in `out` against the bag's fixes: the horizontal RMS at the fixes' times
/// (nearest row), the distance of the row nearest the last fix from it, the track's and
/// the fixes' start-to-end distances (m), and the fixes compared.
fn against_fixes(out: &Path) -> (f64, f64, f64, f64, usize) {
    let rec = Recording::read(
        &husky().join("test1.bag"),
        &Selection::default(),
        ["data.ros.imu_topic", "data.ros.fix_topic", "data.ros.odometry_topic"],
    )
    .unwrap();
    let offset = rec.gpst_offset();
    let nav: Vec<Vec<f64>> = std::fs::read_to_string(out.join("nav.txt"))
        .unwrap()
        .lines()
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .collect();
    let (mut sum, mut n, mut last) = (0.0, 0, f64::NAN);
    for f in &rec.fixes {
        let t = f.t + offset;
        let k = nav.partition_point(|r| r[1] < t);
        if k == 0 || k == nav.len() {
            continue;
        }
        let r = if t - nav[k - 1][1] < nav[k][1] - t { &nav[k - 1] } else { &nav[k] };
        let d = horizontal((r[2], r[3]), (f.position[0], f.position[1]));
        sum += d * d;
        n += 1;
        last = d;
    }
    let (a, b) = (&nav[0], &nav[nav.len() - 1]);
    let (f0, f1) = (&rec.fixes[0].position, &rec.fixes[rec.fixes.len() - 1].position);
    let track = horizontal((a[2], a[3]), (b[2], b[3]));
    let fixes = horizontal((f0[0], f0[1]), (f1[0], f1[1]));
    ((sum / n as f64).sqrt(), last, track, fixes, n)
}

#[test]
fn the_husky_bag_runs_with_a_heading_given_and_its_mcap_copies_give_the_same_bytes() {
    let dir = temp("husky");
    let bag = husky().join("test1.bag");
    let out = dir.join("bag");
    // as shipped, the heading cannot be told (see the next test); given it, the run is
    // read from the bag and written
    let cfg = config_with_heading(&dir, &bag);
    let o = run(&cfg, &out, &["--report", "--accept-inconsistent"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("recording") && stdout.contains("/imu/data (frame imu_link) 11865"));
    assert!(stdout.contains("median rate 30.01 Hz"), "{stdout}");
    assert!(stdout.contains("ARW 12.550 deg/√h"), "{stdout}");
    for f in ["nav.txt", "std.txt", "nav.pos", "updates.csv", "report.html"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // nav.txt against the fixes (read from the bag by the library): the track follows
    // them (0.59 m RMS measured; the fixes' own σ is 0.8–1.2 m) and ends near the last
    let (rms, last, track, fixes, n) = against_fixes(&out);
    eprintln!(
        "husky as shipped: {n} fixes, horizontal RMS {rms:.2} m, {last:.2} m from the last \
         fix; start to end {track:.2} m (the fixes: {fixes:.2} m; robot_localization's \
         answer: {:.1} m)",
        40.0454f64.hypot(76.9988)
    );
    assert!(n > 980 && rms < 1.0, "{n} fixes, RMS {rms:.2} m");
    assert!(last < 1.0 && (track - fixes).abs() < 1.0, "{last} {track} {fixes}");

    // MCAP copies, ROS 1 and ROS 2 CDR messages: the same run, byte for byte
    for (name, flag) in [("ros1.mcap", None), ("cdr.mcap", Some("--cdr"))] {
        let mcap = dir.join(name);
        let o = bin().arg("mcap").arg(&bag).arg(&mcap).args(flag).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out_m = dir.join(format!("out-{name}"));
        let o = run(&config_with_heading(&dir, &mcap), &out_m, &["--accept-inconsistent"]);
        assert!(o.status.success());
        for f in ["nav.txt", "std.txt", "nav.pos", "updates.csv", "imu_errors.txt"] {
            let a = std::fs::read(out.join(f)).unwrap();
            let b = std::fs::read(out_m.join(f)).unwrap();
            assert!(a == b, "{name}: {f} differs from the bag's");
        }
    }
    // a copy that fails (a bag cut short) leaves the earlier MCAP as it was, and no
    // partial file
    let cut = dir.join("cut.bag");
    let bytes = std::fs::read(&bag).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let mcap = dir.join("ros1.mcap");
    let before = std::fs::read(&mcap).unwrap();
    let o = bin().arg("mcap").arg(&cut).arg(&mcap).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && stderr.contains("rosbag reindex"), "{stderr}");
    assert!(std::fs::read(&mcap).unwrap() == before, "the earlier copy was touched");
    assert!(!dir.join("ros1.mcap.partial").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_untold_heading_is_refused_and_a_given_heading_uses_the_odometer() {
    let dir = temp("heading");
    let bag = husky().join("test1.bag");
    // as shipped: until the fit's σ counted its fixes' persistence, the in-motion alignment
    // put the heading about 190° from the course at a σ of a few degrees, the filter drove
    // backward and the odometer check flagged it; now neither the fit nor the bank of
    // headings can tell the heading, and the run says so instead of starting reversed
    let o = run(&config(&dir, &bag, ""), &dir.join("a"), &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("finds the heading (") && stderr.contains("a bank of 16 headings"),
        "{stderr}"
    );
    assert!(stderr.contains("`init.attitude`"), "{stderr}");
    // the heading of the first fixes' course given (a hand-written [init]): the odometer
    // is used and nothing about it is flagged
    let text = std::fs::read_to_string(config(&dir, &bag, "")).unwrap().replace(
        "[imu]\n",
        "[init]\nattitude = [0.0, 0.0, -49.0]\nattitude_std = [2.0, 2.0, 10.0]\n\n[imu]\n",
    );
    let cfg = dir.join("given.toml");
    std::fs::write(&cfg, text).unwrap();
    let o = run(&cfg, &dir.join("b"), &["--accept-inconsistent"]);
    let (rms, last, track, fixes, n) = against_fixes(&dir.join("b"));
    eprintln!(
        "husky, heading given, odometer on: {n} fixes, horizontal RMS {rms:.2} m, {last:.2} m \
         from the last fix; start to end {track:.2} m (the fixes: {fixes:.2} m)"
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("odometer: for"), "{stderr}");
    let used = stdout
        .split("odometer ")
        .filter_map(|s| s.split(' ').next()?.parse::<usize>().ok())
        .next()
        .unwrap_or(0);
    assert!(used > 2000, "odometer updates {used}: {stdout}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_mounting_and_lever_arm_come_from_tf_static() {
    // robot_localization's launch file gives its players base_link → imu_link; written into
    // an MCAP copy on /tf_static, it replaces the configuration's mounting and odometer
    // lever arm: the same run as the hand-written ones, to the rounding of 1.570796327
    let dir = temp("tf");
    let bag = husky().join("test1.bag");
    let mcap = dir.join("tf.mcap");
    let tf = "0 -0.3 0.52 -1.570796327 0 1.570796327 base_link imu_link";
    let o =
        bin().arg("mcap").arg(&bag).arg(&mcap).args(["--static-transform", tf]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(config_with_heading(&dir, &mcap)).unwrap();
    let text: String = text
        .lines()
        .filter(|l| !l.starts_with("mounting =") && !l.starts_with("lever_arm ="))
        .map(|l| format!("{l}\n"))
        .collect();
    let cfg = dir.join("tf.toml");
    std::fs::write(&cfg, text).unwrap();
    let o = run(&cfg, &dir.join("tf"), &["--accept-inconsistent"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("imu.mounting from /tf_static (base_link → imu_link)"), "{stdout}");
    assert!(stdout.contains("vehicle.odometer.lever_arm from /tf_static"), "{stdout}");
    let o = run(&config_with_heading(&dir, &bag), &dir.join("hand"), &["--accept-inconsistent"]);
    assert!(o.status.success());
    let rows = |d: &str| -> Vec<Vec<f64>> {
        std::fs::read_to_string(dir.join(d).join("nav.txt"))
            .unwrap()
            .lines()
            .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    let (a, b) = (rows("tf"), rows("hand"));
    assert_eq!(a.len(), b.len());
    let mut worst = [0.0f64; 11];
    for (x, y) in a.iter().zip(&b) {
        for k in 0..11 {
            worst[k] = worst[k].max((x[k] - y[k]).abs());
        }
    }
    // lat/lon (deg), height (m), velocity (m/s), attitude (deg)
    assert!(worst[2] < 1e-8 && worst[3] < 1e-8 && worst[4] < 1e-3, "{worst:?}");
    assert!(worst[5..8].iter().all(|&d| d < 1e-4), "{worst:?}");
    assert!(worst[8..11].iter().all(|&d| d < 1e-3), "{worst:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
