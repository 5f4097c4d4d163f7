//! robot_localization's Husky bag (`data/ros-husky/test1.bag`) run as it is through
//! `[data.ros]` (IMU, NavSatFix, odometry; no `[init]`, the IMU noise from the messages'
//! covariances), its MCAP copies giving the same outputs byte for byte, and its heading
//! found by the start's bank of headings from the wheels (the odometer, the non-holonomic
//! constraint) against a reference from the gyro and the fixes' course.

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

/// The bag as the library reads it (IMU, fixes, odometry).
fn bag() -> Recording {
    Recording::read(
        &husky().join("test1.bag"),
        &Selection::default(),
        ["data.ros.imu_topic", "data.ros.fix_topic", "data.ros.odometry_topic"],
    )
    .unwrap()
}

/// [`config`] with a heading given (a hand-written `[init]` attitude), `heading` degrees.
fn config_with_heading(dir: &Path, recording: &Path, heading: f64) -> PathBuf {
    let path = config(dir, recording, "");
    let text = std::fs::read_to_string(&path).unwrap().replace(
        "[imu]\n",
        &format!(
            "[init]\nattitude = [0.0, 0.0, {heading}]\nattitude_std = [2.0, 2.0, 10.0]\n\n[imu]\n"
        ),
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
    let rec = bag();
    let offset = rec.gpst_offset();
    let nav = table(&out.join("nav.txt"));
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
fn the_husky_bag_runs_as_shipped_and_its_mcap_copies_give_the_same_bytes() {
    let dir = temp("husky");
    let bag = husky().join("test1.bag");
    let out = dir.join("bag");
    // as shipped (no `[init]`: the heading from the start's bank, see the next test), the
    // run is read from the bag and written
    let cfg = config(&dir, &bag, "");
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
    // nav.txt against the fixes (read from the bag by the library): 6.0 m RMS measured,
    // 5.4 m from the last. Not the fixes' own σ (0.8–1.2 m): the fixes' error bank takes
    // them for a persisting error of 15 m over 2700 s and the track follows the IMU and
    // the wheels (a dead reckoning of the gyro's yaw and the odometer's speed alone lies
    // 3.05 m RMS from the fixes about its mean offset; the everyday-GNSS issue). Until 2026-12-07 the track
    // was 0.59 m from them with a reversed heading given by hand and 17.9 m with the right
    // one (the odometer's scale calibrated on samples chosen by the filter's own speed).
    let (rms, last, track, fixes, n) = against_fixes(&out);
    eprintln!(
        "husky as shipped: {n} fixes, horizontal RMS {rms:.2} m, {last:.2} m from the last \
         fix; start to end {track:.2} m (the fixes: {fixes:.2} m; robot_localization's \
         answer: {:.1} m)",
        40.0454f64.hypot(76.9988)
    );
    assert!(n > 980 && rms < 8.0, "{n} fixes, RMS {rms:.2} m");
    assert!(last < 8.0 && (track - fixes).abs() < 8.0, "{last} {track} {fixes}");

    // MCAP copies, ROS 1 and ROS 2 CDR messages: the same run, byte for byte
    for (name, flag) in [("ros1.mcap", None), ("cdr.mcap", Some("--cdr"))] {
        let mcap = dir.join(name);
        let o = bin().arg("mcap").arg(&bag).arg(&mcap).args(flag).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out_m = dir.join(format!("out-{name}"));
        let o = run(&config(&dir, &mcap, ""), &out_m, &["--accept-inconsistent"]);
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

/// An independent heading reference for the bag (deg; GPS time `t`, s): the yaw the
/// gyro's body-down rate integrates (imu_link's −ω_y, `husky.toml`'s mounting) plus the
/// offset and drift (the gyro's bias) that best fit the fixes' course over windows of 10
/// fixes at least 3 m long in which the gyro turned under 5° — the robot drives forward
/// (its odometer reads +1 m/s), so its course is its heading there. Returns the reference
/// at each of `times`, the windows' RMS about it (deg) and their number.
fn gyro_and_course_heading(times: &[f64]) -> (Vec<f64>, f64, usize) {
    let rec = bag();
    let offset = rec.gpst_offset();
    let t: Vec<f64> = rec.imu.iter().map(|s| s.t + offset).collect();
    let mut yaw = vec![0.0f64];
    for k in 1..rec.imu.len() {
        let rate = -0.5 * (rec.imu[k].w[1] + rec.imu[k - 1].w[1]);
        yaw.push(yaw[k - 1] + rate * (t[k] - t[k - 1]));
    }
    let at = |x: f64| {
        let k = t.partition_point(|&v| v < x).clamp(1, t.len() - 1);
        let u = ((x - t[k - 1]) / (t[k] - t[k - 1])).clamp(0.0, 1.0);
        yaw[k - 1] + u * (yaw[k] - yaw[k - 1])
    };
    let f = &rec.fixes;
    let (lat0, lon0) = (f[0].position[0], f[0].position[1]);
    let r = 6_378_137.0;
    let ne = |p: &[f64; 3]| {
        ((p[0] - lat0).to_radians() * r, (p[1] - lon0).to_radians() * r * lat0.to_radians().cos())
    };
    let mut diffs = Vec::new();
    for i in 0..f.len().saturating_sub(10) {
        let ((n0, e0), (n1, e1)) = (ne(&f[i].position), ne(&f[i + 10].position));
        let (ta, tb) = (f[i].t + offset, f[i + 10].t + offset);
        if (n1 - n0).hypot(e1 - e0) < 3.0 || (at(tb) - at(ta)).abs() > 5f64.to_radians() {
            continue;
        }
        let tm = f[i + 5].t + offset;
        diffs.push((tm, (e1 - e0).atan2(n1 - n0) - at(tm)));
    }
    let wrap = |a: f64| a.sin().atan2(a.cos());
    let (sn, cs) = diffs.iter().fold((0.0, 0.0), |(a, b), d| (a + d.1.sin(), b + d.1.cos()));
    let mean = sn.atan2(cs);
    // the drift: a straight line through the windows' residuals about their mean
    let k = diffs.len() as f64;
    let t_mid = diffs.iter().map(|d| d.0).sum::<f64>() / k;
    let r: Vec<(f64, f64)> = diffs.iter().map(|d| (d.0 - t_mid, wrap(d.1 - mean))).collect();
    let r_mean = r.iter().map(|x| x.1).sum::<f64>() / k;
    let drift = r.iter().map(|x| x.0 * (x.1 - r_mean)).sum::<f64>()
        / r.iter().map(|x| x.0 * x.0).sum::<f64>();
    let line = |x: f64| mean + r_mean + drift * (x - t_mid);
    let spread =
        (diffs.iter().map(|d| wrap(d.1 - line(d.0)).powi(2)).sum::<f64>() / k).sqrt().to_degrees();
    let refs = times.iter().map(|&x| wrap(at(x) + line(x)).to_degrees()).collect();
    (refs, spread, diffs.len())
}

/// The rows of a whitespace-separated output file.
fn table(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .collect()
}

#[test]
fn the_heading_is_found_from_the_wheels_and_covered_by_its_sigma_throughout() {
    let dir = temp("heading");
    let bag = husky().join("test1.bag");
    // as shipped, no `[init]`: a robot driving straight at 1 m/s shows its heading to the
    // specific force only in its few turns (the in-motion fit ±22°, the bank of headings on
    // the fixes alone ±47°, refused until 2026-12-07); the bank's members judged also by
    // the wheels — no lateral velocity (`[vehicle.nhc]`), the odometer's forward speed —
    // tell it within the start's 120 s
    let o = run(&config(&dir, &bag, ""), &dir.join("a"), &["--accept-inconsistent"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stdout.contains("from a bank of 16 hypotheses"), "{stdout}");
    // the whole track's heading against the gyro-and-course reference, with its own σ
    // (measured: 1.9° RMS, at most 5.4°, none beyond 3σ; the reference's windows scatter
    // by 11.7° about it, over 529 windows, its drift −2.3° per 100 s)
    let nav = table(&dir.join("a").join("nav.txt"));
    let std = table(&dir.join("a").join("std.txt"));
    let times: Vec<f64> = nav.iter().map(|r| r[1]).collect();
    let (refs, spread, windows) = gyro_and_course_heading(&times);
    assert!(windows > 300 && spread < 20.0, "{windows} windows, {spread:.1}°");
    let (mut sq, mut worst, mut beyond) = (0.0, 0.0f64, 0usize);
    for (r, h) in nav.iter().zip(&refs) {
        let e = (r[10] - h + 540.0).rem_euclid(360.0) - 180.0;
        let k = std.partition_point(|s| s[0] < r[1]).min(std.len() - 1);
        sq += e * e;
        worst = worst.max(e.abs());
        beyond += usize::from(e.abs() > 3.0 * std[k][9]);
    }
    let rms = (sq / nav.len() as f64).sqrt();
    eprintln!(
        "husky heading against the gyro and the course: RMS {rms:.2}°, worst {worst:.2}°, \
         {beyond} of {} epochs beyond 3σ",
        nav.len()
    );
    assert!(rms < 3.0 && beyond == 0, "RMS {rms:.2}°, worst {worst:.2}°, {beyond} beyond 3σ");
    // the odometer is used and nothing about it is flagged (the reversed heading of old)
    assert!(!stderr.contains("odometer: for"), "{stderr}");
    let used = stdout
        .split("odometer ")
        .filter_map(|s| s.split(' ').next()?.parse::<usize>().ok())
        .next()
        .unwrap_or(0);
    assert!(used > 2000, "odometer updates {used}: {stdout}");
    // without the wheels (the IMU and the fixes alone) the heading cannot be told: refused,
    // naming what was tried and the key that would give it
    let bare: String = std::fs::read_to_string(config(&dir, &bag, ""))
        .unwrap()
        .split("[vehicle.nhc]")
        .next()
        .unwrap()
        .into();
    let cfg = dir.join("bare.toml");
    std::fs::write(&cfg, bare).unwrap();
    let o = run(&cfg, &dir.join("b"), &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("finds the heading (") && stderr.contains("a bank of 16 headings"),
        "{stderr}"
    );
    assert!(stderr.contains("`init.attitude`"), "{stderr}");
    // a heading given by hand is taken as given
    let o =
        run(&config_with_heading(&dir, &bag, -22.0), &dir.join("c"), &["--accept-inconsistent"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let first = &table(&dir.join("c").join("nav.txt"))[0];
    assert!((first[10] + 22.0).abs() < 1.0, "{first:?}");
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
    // (the shipped configuration less its mounting and the odometer's lever arm; the
    // non-holonomic constraint's point stays as written)
    let text = std::fs::read_to_string(config(&dir, &mcap, "")).unwrap();
    let mut section = "";
    let mut kept = String::new();
    for l in text.lines() {
        if l.starts_with('[') {
            section = l;
        }
        let odometer_arm = section == "[vehicle.odometer]" && l.starts_with("lever_arm =");
        if !l.starts_with("mounting =") && !odometer_arm {
            kept += &format!("{l}\n");
        }
    }
    let text = kept;
    let cfg = dir.join("tf.toml");
    std::fs::write(&cfg, text).unwrap();
    let o = run(&cfg, &dir.join("tf"), &["--accept-inconsistent"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("imu.mounting from /tf_static (base_link → imu_link)"), "{stdout}");
    assert!(stdout.contains("vehicle.odometer.lever_arm from /tf_static"), "{stdout}");
    let o = run(&config(&dir, &bag, ""), &dir.join("hand"), &["--accept-inconsistent"]);
    assert!(o.status.success());
    let rows = |d: &str| table(&dir.join(d).join("nav.txt"));
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
