//! Runs that start themselves from the data: no `[init]`, noise from the static start, a
//! stated sensor mounting, and logs whose units or axes do not match the configuration,
//! each refused with the key to change.

use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ins-gnss"))
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("estimator-start-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `ins-gnss simulate` of `scenario` (a file of `scenarios/`, with `edit` applied) into
/// `dir`.
fn simulate(scenario: &str, dir: &Path, edit: impl Fn(String) -> String) {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join(scenario),
    )
    .unwrap();
    std::fs::write(dir.join("scenario.toml"), edit(text)).unwrap();
    let out = bin()
        .arg("simulate")
        .arg(dir.join("scenario.toml"))
        .arg("--out")
        .arg(dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// The configuration text without its `[init]` section.
fn without_init(config: &str) -> String {
    without_section(config, "[init]")
}

/// The configuration text without its section `header`.
fn without_section(config: &str, header: &str) -> String {
    let mut out = String::new();
    let mut skip = false;
    for line in config.lines() {
        if line.starts_with('[') {
            skip = line.trim() == header;
        }
        if !skip {
            out += line;
            out += "\n";
        }
    }
    out
}

/// `ins-gnss run CONFIG --out DIR --quiet`: (success, stdout, stderr).
fn run(config: &Path, out: &Path) -> (bool, String, String) {
    let o = bin().arg("run").arg(config).arg("--out").arg(out).arg("--quiet").output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Horizontal RMS of `dir/nav.txt` against `truth` after `skip` seconds.
fn horizontal_rms(dir: &Path, truth: &Path, skip: f64) -> f64 {
    let out = bin()
        .arg("eval")
        .arg(dir.join("nav.txt"))
        .arg(truth)
        .args(["--json", "--skip", &skip.to_string()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["overall"]["horizontal"]["rms"].as_f64().unwrap()
}

fn rows(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .collect()
}

#[test]
fn a_simulated_drive_without_init_scores_within_ten_percent_of_the_given_state() {
    let dir = temp("noinit");
    simulate("drive.toml", &dir, |s| s);
    let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    std::fs::write(dir.join("noinit.toml"), without_init(&config)).unwrap();
    let (ok, _, err) = run(&dir.join("config.toml"), &dir.join("given"));
    assert!(ok, "{err}");
    let (ok, stdout, err) = run(&dir.join("noinit.toml"), &dir.join("found"));
    assert!(ok, "{err}");
    // the summary says how each part was found
    for part in ["init: roll", "heading", "init: position", "init: velocity", "init: gyro bias"] {
        assert!(stdout.contains(part), "{part} missing from:\n{stdout}");
    }
    let truth = dir.join("truth.nav");
    let (given, found) = (
        horizontal_rms(&dir.join("given"), &truth, 20.0),
        horizontal_rms(&dir.join("found"), &truth, 20.0),
    );
    assert!(found <= 1.1 * given + 0.05, "from the data {found:.3} m, given {given:.3} m");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A car that stands five minutes before it drives (a common alignment practice) starts
/// with no `[init]` and no `[align]` settings: `align.max_time` counts from the motion's
/// start, and the position is the static start's first fix (not the fit's, whose vertical
/// takes up an accelerometer bias). It failed to start before ("no motion to tell the
/// heading within `align.max_time` = 120 s"). The drive's GNSS interference and outage
/// windows move with the drive (an interference window inside the static start ends the
/// static span: its fixes look like motion).
#[test]
fn a_car_that_stands_five_minutes_before_it_drives_starts_from_the_data() {
    let dir = temp("stand");
    simulate("drive.toml", &dir, |s| {
        s.replacen("kind = \"stop\"\nduration = 10.0", "kind = \"stop\"\nduration = 300.0", 1)
            .replace("start = 50.0\nend = 65.0", "start = 340.0\nend = 355.0")
            .replace("start = 80.0\nend = 95.0", "start = 370.0\nend = 385.0")
    });
    let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    // (the simulator writes the defaults of `[align]`: none of them is given here)
    let bare = without_section(&without_init(&config), "[align]");
    assert!(!bare.contains("[align]") && !bare.contains("[init]"));
    std::fs::write(dir.join("noinit.toml"), bare).unwrap();
    let (ok, _, err) = run(&dir.join("config.toml"), &dir.join("given"));
    assert!(ok, "{err}");
    let (ok, stdout, err) = run(&dir.join("noinit.toml"), &dir.join("found"));
    assert!(ok, "{err}");
    assert!(stdout.contains("levelled over the static start (3"), "{stdout}");
    assert!(stdout.contains("the first of the static start"), "{stdout}");
    let truth = dir.join("truth.nav");
    let (given, found) = (
        horizontal_rms(&dir.join("given"), &truth, 300.0),
        horizontal_rms(&dir.join("found"), &truth, 300.0),
    );
    // (measured: 1.86 m from the data, 0.93 m given; the drive after the stop is 100 s
    // with a 15 s outage, whose drift sets both)
    eprintln!("stands 300 s: from the data {found:.3} m, given {given:.3} m");
    assert!(found <= 2.5 * given, "from the data {found:.3} m, given {given:.3} m");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An IMU stamped 0.3 s and 5 s late against the GNSS (simulated drive, one 90° turn):
/// the start names `data.imu_time_offset` with the value that fits, within 20 ms — 5 s
/// refused, 0.3 s refused or (when its likelihood ratio is below 1e6) run as stamped and
/// named in the report; on time, no alarm; with the named value applied, the run starts.
#[test]
fn an_imu_stamped_late_is_named_with_its_offset() {
    let dir = temp("late");
    simulate("drive.toml", &dir, |s| s);
    let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    let imu = std::fs::read_to_string(dir.join("IMU.txt")).unwrap();
    let (ok, _, err) = run(&dir.join("config.toml"), &dir.join("on-time"));
    assert!(ok, "on time: {err}");
    assert!(!err.contains("imu_time_offset"), "{err}");
    for late in [0.3, 5.0] {
        let shifted: String = imu
            .lines()
            .map(|l| {
                let mut f: Vec<String> = l.split_whitespace().map(str::to_string).collect();
                if let Some(t) = f.first().and_then(|t| t.parse::<f64>().ok()) {
                    f[0] = format!("{:.6}", t + late);
                }
                f.join(" ") + "\n"
            })
            .collect();
        let name = format!("IMU-late-{late}.txt");
        std::fs::write(dir.join(&name), shifted).unwrap();
        let cfg = config.replacen("imu = \"IMU.txt\"", &format!("imu = \"{name}\""), 1);
        assert!(cfg.contains(&name));
        std::fs::write(dir.join("late.toml"), &cfg).unwrap();
        let (ok, out, err) = run(&dir.join("late.toml"), &dir.join("late"));
        // refused naming the value, or (a likelihood ratio below 1e6: 0.3 s over one
        // turn, about 9e2 measured) run as stamped with the value named in the report
        let named = if ok { "`data.imu_time_offset = " } else { "set `data.imu_time_offset = " };
        let text = if ok { &out } else { &err };
        assert!(ok || late > 0.3 + 1e-9 || err.contains("likelihood ratio"), "{err}");
        assert!(!ok || late < 1.0, "{late} s late ran: {out}");
        let value: f64 = text
            .split(named)
            .nth(1)
            .and_then(|v| v.split('`').next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{late} s late: {out}\n{err}"));
        assert!((value + late).abs() <= 0.02, "{late} s late: {value}");
        // with the value applied it starts
        let fixed = cfg.replace("imu_time_offset = 0.0", &format!("imu_time_offset = {value}"));
        assert!(fixed.contains(&format!("imu_time_offset = {value}")), "{fixed}");
        std::fs::write(dir.join("fixed.toml"), fixed).unwrap();
        let (ok, _, err) = run(&dir.join("fixed.toml"), &dir.join("fixed"));
        assert!(ok, "{late} s late with {value} applied: {err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A handheld walk inside a 16 × 15 m yard (`scenarios/walk.toml`: 1.2 m/s from the first
/// sample, squares both ways, 180° turns, stops; RTK fixes at 4 Hz, with and without
/// velocity) starts with no `[init]`: the alignment counts the metres walked along its
/// fitted path, where it waited for 30 m away from the first fix and never started
/// ("no motion to tell the heading"). The heading is within 3σ of the truth and the
/// outage's largest error within 20 % of the run given the simulator's initial state
/// (`benches/campaign.py --walk`: 50 of 50 seeds each way).
#[test]
fn a_walk_in_a_small_yard_starts_from_the_data_with_and_without_velocity() {
    for velocity in [true, false] {
        let dir = temp(if velocity { "walk-vel" } else { "walk-pos" });
        simulate("walk.toml", &dir, |s| {
            if velocity {
                s
            } else {
                s.lines()
                    .filter(|l| !l.contains("remove for a 7-column"))
                    .collect::<Vec<_>>()
                    .join("\n")
            }
        });
        let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
        std::fs::write(dir.join("noinit.toml"), without_init(&config)).unwrap();
        let (ok, _, err) = run(&dir.join("config.toml"), &dir.join("given"));
        assert!(ok, "{err}");
        let (ok, stdout, err) = run(&dir.join("noinit.toml"), &dir.join("found"));
        assert!(ok, "velocity {velocity}: {err}");
        // the heading and its σ against the truth's at the start (30°)
        let line = stdout.lines().find(|l| l.starts_with("init: roll")).unwrap();
        let after = line.split("heading ").nth(1).unwrap();
        let yaw: f64 = after.split('°').next().unwrap().parse().unwrap();
        let std: f64 =
            after.rsplit("σ ").next().unwrap().trim_end_matches('°').trim().parse().unwrap();
        let truth = dir.join("truth.nav");
        let yaw0 = rows(&truth)[0][10];
        assert!((yaw - yaw0).abs() <= 3.0 * std, "heading {yaw}° ± {std}° against {yaw0}°");
        let score = |run: &str| -> f64 {
            let out = bin()
                .arg("eval")
                .arg(dir.join(run).join("nav.txt"))
                .arg(&truth)
                .args(["--json", "--window", "80,90"])
                .output()
                .unwrap();
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            v["windows"][0]["horizontal"]["max"].as_f64().unwrap()
        };
        let (given, found) = (score("given"), score("found"));
        eprintln!("walk, velocity {velocity}: outage {found:.3} m found, {given:.3} m given");
        assert!(found <= 1.2 * given, "velocity {velocity}: {found:.3} m against {given:.3} m");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

/// The body → sensor axes of the mounting `["-y", "-x", "-z"]` (roll 180°, yaw −90°): the
/// sensor reads `(−b_y, −b_x, −b_z)` (`C_bs` is its own inverse).
fn to_sensor(v: &[f64]) -> [f64; 3] {
    [-v[1], -v[0], -v[2]]
}

#[test]
fn a_stated_mounting_matches_the_square_run_and_a_left_handed_one_is_refused() {
    let dir = temp("mounting");
    simulate("drive.toml", &dir, |s| s);
    let mut imu = String::new();
    for r in rows(&dir.join("IMU.txt")) {
        let (w, f) = (to_sensor(&r[1..4]), to_sensor(&r[4..7]));
        imu += &format!(
            "{:.6} {:.15e} {:.15e} {:.15e} {:.15e} {:.15e} {:.15e}\n",
            r[0], w[0], w[1], w[2], f[0], f[1], f[2]
        );
    }
    std::fs::write(dir.join("IMU_mounted.txt"), imu).unwrap();
    let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    let mounted = |mounting: &str| {
        // (the simulator writes the whole configuration, an empty `[imu]` included)
        config
            .replace("imu = \"IMU.txt\"", "imu = \"IMU_mounted.txt\"")
            .replace("[imu]\n", &format!("[imu]\nmounting = {mounting}\n"))
    };
    let (ok, _, err) = run(&dir.join("config.toml"), &dir.join("square"));
    assert!(ok, "{err}");
    let nav = |d: &str| std::fs::read_to_string(dir.join(d).join("nav.txt")).unwrap();
    for (name, m) in [
        ("axes", r#"["-y", "-x", "-z"]"#),
        ("angles", "[180.0, 0.0, -90.0]"),
        ("matrix", "[[0, -1, 0], [-1, 0, 0], [0, 0, -1]]"),
    ] {
        std::fs::write(dir.join(format!("{name}.toml")), mounted(m)).unwrap();
        let (ok, _, err) = run(&dir.join(format!("{name}.toml")), &dir.join(name));
        assert!(ok, "{name}: {err}");
        let (a, b) = (nav("square"), nav(name));
        assert_eq!(a.lines().count(), b.lines().count());
        for (x, y) in a.lines().zip(b.lines()) {
            for (u, v) in x.split_whitespace().zip(y.split_whitespace()) {
                let (u, v): (f64, f64) = (u.parse().unwrap(), v.parse().unwrap());
                assert!((u - v).abs() <= 1e-6 * u.abs().max(1.0), "{name}\n{x}\n{y}");
            }
        }
    }
    // the simulator's own mounting option: the IMU turned inside the car, its errors off
    // (they are drawn on the sensor's axes, so a mounted IMU's noise is not the square
    // one's), run with the square run's configuration and the rotation stated
    let quiet = |s: String| {
        ["arw = 0.3", "vrw = 0.1", "gyro_bias_std = 10.0", "accel_bias_std = 100.0"]
            .iter()
            .fold(s, |s, line| {
                s.replace(line, &format!("{} = 0.0", line.split(' ').next().unwrap()))
            })
            .replace("gyro_turn_on = [30.0, -20.0, 40.0]", "")
            .replace("accel_turn_on = [300.0, -200.0, 100.0]", "")
    };
    let (sq, sim) = (dir.join("sim_square"), dir.join("sim_mounted"));
    std::fs::create_dir_all(&sq).unwrap();
    std::fs::create_dir_all(&sim).unwrap();
    simulate("drive.toml", &sq, quiet);
    simulate("drive.toml", &sim, |s| {
        quiet(s).replace("[imu]\n", "[imu]\nmounting = [180.0, 0.0, -90.0]\n")
    });
    // (the filter keeps the noisy drive's noise settings: zero noise is no setting)
    let square_config = std::fs::read_to_string(sq.join("config.toml")).unwrap();
    let noise = |c: &str| {
        let a = c.find("[imu_noise]").unwrap();
        let b = a + 1 + c[a + 1..].find("\n[").unwrap();
        c[a..b].to_string()
    };
    let square_config = square_config.replace(&noise(&square_config), &noise(&config));
    std::fs::write(sq.join("config.toml"), &square_config).unwrap();
    std::fs::write(
        sq.join("mounted.toml"),
        square_config
            .replace("imu = \"IMU.txt\"", &format!("imu = {:?}", sim.join("IMU.txt")))
            .replace("[imu]\n", "[imu]\nmounting = [180.0, 0.0, -90.0]\n"),
    )
    .unwrap();
    for (config, out) in [("config.toml", "square_out"), ("mounted.toml", "mounted_out")] {
        let (ok, _, err) = run(&sq.join(config), &sq.join(out));
        assert!(ok, "{config}: {err}");
    }
    let (a, b) = (
        std::fs::read_to_string(sq.join("square_out/nav.txt")).unwrap(),
        std::fs::read_to_string(sq.join("mounted_out/nav.txt")).unwrap(),
    );
    assert_eq!(a.lines().count(), b.lines().count());
    let mut worst = 0f64;
    for (x, y) in a.lines().zip(b.lines()) {
        for (u, v) in x.split_whitespace().zip(y.split_whitespace()) {
            let (u, v): (f64, f64) = (u.parse().unwrap(), v.parse().unwrap());
            worst = worst.max((u - v).abs() / u.abs().max(1.0));
        }
    }
    assert!(worst <= 1e-6, "simulator-mounted against square: relative difference {worst:e}");
    // a mirror image (two axes swapped without a sign) is no mounting
    std::fs::write(dir.join("mirror.toml"), mounted(r#"["y", "x", "z"]"#)).unwrap();
    let (ok, _, err) = run(&dir.join("mirror.toml"), &dir.join("mirror"));
    assert!(!ok && err.contains("`imu.mounting`") && err.contains("left-handed"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A rate log (`t,gx,gy,gz,ax,ay,az` in s, rad/s, m/s², FRD) of the simulated drive, with
/// `convert(t, ω, f)` giving the written row, and its configuration with `columns` (the
/// `[data.imu_columns]` body) and no `[init]`.
fn rate_log(
    dir: &Path,
    name: &str,
    header: &str,
    convert: impl Fn(f64, [f64; 3], [f64; 3]) -> [f64; 7],
    columns: &str,
) -> PathBuf {
    rate_log_with(dir, name, header, convert, columns, without_init)
}

/// [`rate_log`] with `init(config)` giving the configuration's text (with or without
/// `[init]`).
fn rate_log_with(
    dir: &Path,
    name: &str,
    header: &str,
    convert: impl Fn(f64, [f64; 3], [f64; 3]) -> [f64; 7],
    columns: &str,
    init: fn(&str) -> String,
) -> PathBuf {
    let mut text = format!("{header}\n");
    for r in rows(&dir.join("IMU.txt")) {
        let dt = 0.01;
        let w = [r[1] / dt, r[2] / dt, r[3] / dt];
        let f = [r[4] / dt, r[5] / dt, r[6] / dt];
        let v = convert(r[0], w, f);
        text += &v.map(|x| format!("{x:.12e}")).join(",");
        text += "\n";
    }
    std::fs::write(dir.join(format!("{name}.csv")), text).unwrap();
    let config = init(&std::fs::read_to_string(dir.join("config.toml")).unwrap())
        .replace("imu = \"IMU.txt\"", &format!("imu = \"{name}.csv\""))
        .replace("imu_format = \"increments\"", "imu_format = \"rates\"")
        + &format!("\n[data.imu_columns]\n{columns}\n");
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, config).unwrap();
    path
}

#[test]
fn mislabelled_units_axes_and_times_are_refused_with_the_key() {
    let dir = temp("labels");
    // started at a longitude beyond 90° so that a latitude/longitude swap is out of range
    simulate("drive.toml", &dir, |s| {
        s.replace("position = [45.0, 7.6, 240.0]", "position = [40.1, -105.1, 1600.0]")
    });
    let g = 9.80665;
    let h = "t,gx,gy,gz,ax,ay,az";
    let id = |t, w: [f64; 3], f: [f64; 3]| [t, w[0], w[1], w[2], f[0], f[1], f[2]];
    // the correct log runs (a check never refuses it)
    let good = rate_log(&dir, "good", h, id, "");
    let (ok, stdout, err) = run(&good, &dir.join("good_out"));
    assert!(ok, "{err}");
    assert!(stdout.contains("init: roll"), "{stdout}");
    let cases: Vec<(&str, PathBuf, &[&str])> = vec![
        (
            "accelerometer in g declared m/s²",
            rate_log(&dir, "in_g", h, |t, w, f| id(t, w, f.map(|v| v / g)), ""),
            &["`data.imu_columns.accel_unit`", "accel_unit = \"g\""],
        ),
        (
            "accelerometer in mg declared g",
            rate_log(
                &dir,
                "in_mg",
                h,
                |t, w, f| id(t, w, f.map(|v| v / g * 1e3)),
                "accel_unit = \"g\"",
            ),
            &["in_mg.csv:2", "`accel_unit`", "1000× too large"],
        ),
        (
            "gyro in deg/s declared rad/s",
            rate_log(&dir, "in_deg", h, |t, w, f| id(t, w.map(f64::to_degrees), f), ""),
            &["`data.imu_columns.gyro_unit`", "gyro_unit = \"deg/s\""],
        ),
        (
            "gyro in rad/s declared deg/s",
            rate_log(&dir, "in_rad", h, id, "gyro_unit = \"deg/s\""),
            &["`data.imu_columns.gyro_unit`", "gyro_unit = \"rad/s\""],
        ),
        (
            "x and y columns swapped (a left-handed frame)",
            rate_log(&dir, "swap_xy", "t,gy,gx,gz,ay,ax,az", id, ""),
            &["`data.imu_columns.gyro` / `data.imu_columns.accel`", "left-handed"],
        ),
        (
            "FRD declared FLU",
            rate_log(&dir, "flu", h, id, "axes = \"flu\""),
            &["`data.imu_columns.axes`", "upside down"],
        ),
        (
            "ms declared s",
            rate_log(&dir, "ms", h, |t, w, f| id(t * 1e3, w, f), ""),
            &["time_unit", "not in seconds"],
        ),
    ];
    let mut failures = Vec::new();
    for (what, config, needles) in cases {
        let (ok, _, err) = run(&config, &dir.join("out"));
        if ok || !needles.iter().all(|n| err.contains(n)) {
            failures.push(format!("{what}: ok = {ok}, {err}"));
        }
    }
    // latitude and longitude swapped in the GNSS file
    let mut gnss = String::new();
    for r in rows(&dir.join("GNSS.txt")) {
        let mut r = r.clone();
        r.swap(1, 2);
        gnss += &r.iter().map(|v| format!("{v:.12}")).collect::<Vec<_>>().join(" ");
        gnss += "\n";
    }
    std::fs::write(dir.join("GNSS_swapped.txt"), gnss).unwrap();
    let swapped = std::fs::read_to_string(&good)
        .unwrap()
        .replace("gnss = \"GNSS.txt\"", "gnss = \"GNSS_swapped.txt\"");
    std::fs::write(dir.join("swapped.toml"), swapped).unwrap();
    let (ok, _, err) = run(&dir.join("swapped.toml"), &dir.join("out"));
    if ok || !err.contains("swapped") || !err.contains("GNSS_swapped.txt:1") {
        failures.push(format!("latitude/longitude swapped: ok = {ok}, {err}"));
    }
    // a gyro in deg/s beside fixes that declare a single point's σ (15 m) for RTK's
    // centimetres: a course between fixes was taken for noise unless they were 4 × 21 m
    // apart, and no check looked at the turns (the declared σ is a prior: the course is
    // judged on the noise the fixes show; the everyday corpus's fixes declaring ten times
    // their σ, `CORRUPT=gyro-deg`, were not refused before either)
    let mut gnss = String::new();
    for r in rows(&dir.join("GNSS.txt")) {
        // (positions only: a course from a fix's velocity does not ask its position σ)
        let mut r = r[..7].to_vec();
        r[4..7].copy_from_slice(&[15.0, 15.0, 30.0]);
        gnss += &r.iter().map(|v| format!("{v:.12}")).collect::<Vec<_>>().join(" ");
        gnss += "\n";
    }
    std::fs::write(dir.join("GNSS_15m.txt"), gnss).unwrap();
    let in_deg = std::fs::read_to_string(dir.join("in_deg.toml"))
        .unwrap()
        .replace("gnss = \"GNSS.txt\"", "gnss = \"GNSS_15m.txt\"");
    std::fs::write(dir.join("in_deg_15m.toml"), in_deg).unwrap();
    let (ok, _, err) = run(&dir.join("in_deg_15m.toml"), &dir.join("out"));
    if ok || !err.contains("`data.imu_columns.gyro_unit`") {
        failures.push(format!("gyro in deg/s, fixes declaring 15 m: ok = {ok}, {err}"));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// With the whole initial state given, the checks run beside the filter (it does not wait
/// for them): a refusal still stops the run with the key, keeps no partial output and
/// leaves the earlier result untouched.
#[test]
fn with_init_given_the_checks_beside_the_filter_still_refuse() {
    let dir = temp("labels-init");
    simulate("drive.toml", &dir, |s| s);
    let h = "t,gx,gy,gz,ax,ay,az";
    let id = |t, w: [f64; 3], f: [f64; 3]| [t, w[0], w[1], w[2], f[0], f[1], f[2]];
    let keep = |c: &str| c.to_string();
    let out = dir.join("out");
    let good = rate_log_with(&dir, "good", h, id, "", keep);
    let (ok, stdout, err) = run(&good, &out);
    assert!(ok, "{err}");
    assert!(!stdout.contains("init: roll"), "the given state was kept: {stdout}");
    let earlier = std::fs::read(out.join("nav.txt")).unwrap();
    let g = 9.80665;
    let cases: Vec<(&str, PathBuf, &[&str])> = vec![
        (
            "accelerometer in g declared m/s²",
            rate_log_with(&dir, "in_g", h, |t, w, f| id(t, w, f.map(|v| v / g)), "", keep),
            &["`data.imu_columns.accel_unit`", "accel_unit = \"g\""],
        ),
        (
            "gyro in deg/s declared rad/s",
            rate_log_with(&dir, "in_deg", h, |t, w, f| id(t, w.map(f64::to_degrees), f), "", keep),
            &["`data.imu_columns.gyro_unit`", "gyro_unit = \"deg/s\""],
        ),
        (
            "x and y columns swapped (a left-handed frame)",
            rate_log_with(&dir, "swap_xy", "t,gy,gx,gz,ay,ax,az", id, "", keep),
            &["left-handed"],
        ),
        (
            "FRD declared FLU",
            rate_log_with(&dir, "flu", h, id, "axes = \"flu\"", keep),
            &["`data.imu_columns.axes`", "upside down"],
        ),
    ];
    let mut failures = Vec::new();
    for (what, config, needles) in cases {
        let (ok, _, err) = run(&config, &out);
        if ok || !needles.iter().all(|n| err.contains(n)) || err.contains(".partial") {
            failures.push(format!("{what}: ok = {ok}, {err}"));
        }
        let partial: Vec<_> = std::fs::read_dir(&out)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".partial"))
            .map(|e| e.file_name())
            .collect();
        if !partial.is_empty() {
            failures.push(format!("{what}: left {partial:?}"));
        }
        if std::fs::read(out.join("nav.txt")).unwrap() != earlier {
            failures.push(format!("{what}: the earlier nav.txt changed"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    std::fs::remove_dir_all(&dir).unwrap();
}
