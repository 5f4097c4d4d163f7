//! The project's own bad-input suite: more than a hundred malformed files, configurations,
//! scenarios and command lines, each run through the `ins-gnss` binary. For every case:
//! no panic, a non-zero exit, the message names the file and line or the key (the
//! expected text), and the earlier output in the output directory is byte-identical
//! afterwards. A few cases of input that only looks odd (a byte-order mark, a compressed
//! file) must succeed.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ins-gnss"))
}

/// A short simulated dataset, a good configuration for it, and a good earlier output.
struct Base {
    dir: PathBuf,
    imu: Vec<String>,
    gnss: Vec<String>,
    config: String,
    scenario: String,
    /// The earlier output every failing run must leave as it was.
    out: PathBuf,
}

const SCENARIO: &str = r#"
seed = 3
[start]
time = 1000.0
position = [45.0, 7.6, 240.0]
speed = 5.0
yaw = 30.0
[[segment]]
kind = "straight"
duration = 20.0
[[segment]]
kind = "turn"
duration = 10.0
rate = 5.0
[imu]
rate = 50.0
arw = 0.3
vrw = 0.1
gyro_bias_std = 10.0
accel_bias_std = 100.0
corr_time = 1.0
[gnss]
rate = 1.0
position_std = [1.0, 1.0, 2.0]
[init]
attitude_std = [1.0, 1.0, 3.0]
velocity_std = [0.1, 0.1, 0.1]
position_std = [2.0, 2.0, 3.0]
"#;

fn base(tag: &str) -> Base {
    let dir =
        std::env::temp_dir().join(format!("estimator-bad-input-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scenario = dir.join("scenario.toml");
    std::fs::write(&scenario, SCENARIO).unwrap();
    let data = dir.join("data");
    let o = bin().arg("simulate").arg(&scenario).arg("--out").arg(&data).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lines = |name: &str| {
        std::fs::read_to_string(data.join(name)).unwrap().lines().map(String::from).collect()
    };
    // the generated configuration, with absolute paths so that cases can live elsewhere
    let config = std::fs::read_to_string(data.join("config.toml"))
        .unwrap()
        .replace("\"IMU.txt\"", &format!("{:?}", data.join("IMU.txt")))
        .replace("\"GNSS.txt\"", &format!("{:?}", data.join("GNSS.txt")))
        .replace("\"truth.nav\"", &format!("{:?}", data.join("truth.nav")));
    let out = dir.join("earlier-output");
    let cfg = dir.join("good.toml");
    std::fs::write(&cfg, &config).unwrap();
    let o = bin().arg("run").arg(&cfg).arg("--out").arg(&out).arg("--quiet").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    Base {
        imu: lines("IMU.txt"),
        gnss: lines("GNSS.txt"),
        config,
        scenario: SCENARIO.into(),
        out,
        dir,
    }
}

/// Every file of a directory with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && !p.to_string_lossy().ends_with(".partial"))
        .map(|p| (p.clone(), std::fs::read(&p).unwrap()))
        .collect()
}

/// One case: the arguments of the run and the texts its error message must contain.
struct Case {
    name: String,
    args: Vec<String>,
    expect: Vec<String>,
    /// The directory whose earlier contents must survive.
    keep: PathBuf,
}

struct Suite<'a> {
    base: &'a Base,
    cases: Vec<Case>,
}

impl Suite<'_> {
    fn case_dir(&self, name: &str) -> PathBuf {
        let d = self.base.dir.join("cases").join(name);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// `ins-gnss run CONFIG --out <earlier output>` with the configuration text `config`.
    fn run_config(&mut self, name: &str, config: String, expect: &[&str]) {
        let d = self.case_dir(name);
        let path = d.join("config.toml");
        std::fs::write(&path, config).unwrap();
        self.run_file(name, path, expect);
    }

    fn run_file(&mut self, name: &str, config: PathBuf, expect: &[&str]) {
        let out = self.base.out.display().to_string();
        let args =
            vec!["run".into(), config.display().to_string(), "--out".into(), out, "--quiet".into()];
        self.push(name, args, expect, self.base.out.clone());
    }

    fn push(&mut self, name: &str, args: Vec<String>, expect: &[&str], keep: PathBuf) {
        let expect = expect.iter().map(|s| s.to_string()).collect();
        self.cases.push(Case { name: name.into(), args, expect, keep });
    }

    /// A mutated copy of the base dataset's `file` (`IMU.txt` or `GNSS.txt`) in the case's
    /// directory, the rest of the configuration as in the base.
    fn data_file(
        &mut self,
        name: &str,
        file: &str,
        mutate: impl Fn(&mut Vec<String>),
        expect: &[&str],
    ) {
        let mut lines =
            if file == "IMU.txt" { self.base.imu.clone() } else { self.base.gnss.clone() };
        mutate(&mut lines);
        let path = self.case_dir(name).join(file);
        std::fs::write(&path, lines.join("\n") + "\n").unwrap();
        let original = format!("{:?}", self.base.dir.join("data").join(file));
        let config = self.base.config.replace(&original, &format!("{path:?}"));
        self.run_config(name, config, expect);
    }

    fn imu(&mut self, name: &str, mutate: impl Fn(&mut Vec<String>), expect: &[&str]) {
        self.data_file(name, "IMU.txt", mutate, expect)
    }

    fn gnss(&mut self, name: &str, mutate: impl Fn(&mut Vec<String>), expect: &[&str]) {
        self.data_file(name, "GNSS.txt", mutate, expect)
    }

    /// The base configuration with `from` replaced by `to` (which must occur).
    fn toml(&mut self, name: &str, from: &str, to: &str, expect: &[&str]) {
        assert!(self.base.config.contains(from), "{name}: `{from}` not in the configuration");
        let config = self.base.config.replacen(from, to, 1);
        self.run_config(name, config, expect);
    }

    fn yaml(&mut self, name: &str, text: &str, expect: &[&str]) {
        let d = self.case_dir(name);
        let path = d.join("kf-gins.yaml");
        std::fs::write(&path, text).unwrap();
        self.run_file(name, path, expect);
    }

    /// `ins-gnss simulate` of the base scenario with `from` replaced by `to`, into the
    /// directory of the base dataset (which must survive).
    fn scenario(&mut self, name: &str, from: &str, to: &str, expect: &[&str]) {
        assert!(self.base.scenario.contains(from), "{name}: `{from}` not in the scenario");
        let d = self.case_dir(name);
        let path = d.join("scenario.toml");
        std::fs::write(&path, self.base.scenario.replacen(from, to, 1)).unwrap();
        let data = self.base.dir.join("data");
        let args = vec![
            "simulate".into(),
            path.display().to_string(),
            "--out".into(),
            data.display().to_string(),
        ];
        self.push(name, args, expect, data);
    }
}

/// A YAML configuration for the base dataset in KF-GINS's keys.
fn yaml(base: &Base) -> String {
    format!(
        "imupath: {:?}\ngnsspath: {:?}\noutputpath: out\nimudatalen: 7\nimudatarate: 50\n\
         starttime: 1000.0\nendtime: -1\ninitpos: [45.0, 7.6, 240.0]\ninitvel: [4.33, 2.5, 0.0]\n\
         initatt: [0.0, 0.0, 30.0]\ninitgyrbias: [0, 0, 0]\ninitaccbias: [0, 0, 0]\n\
         initposstd: [2.0, 2.0, 3.0]\ninitvelstd: [0.1, 0.1, 0.1]\ninitattstd: [1.0, 1.0, 3.0]\n\
         initbgstd: [50, 50, 50]\ninitbastd: [500, 500, 500]\nimunoise:\n  arw: [0.3, 0.3, 0.3]\n\
         \x20 vrw: [0.1, 0.1, 0.1]\n  gbstd: [10, 10, 10]\n  abstd: [100, 100, 100]\n\
         \x20 corrtime: 1.0\nantlever: [0.0, 0.0, 0.0]\n",
        base.dir.join("data/IMU.txt"),
        base.dir.join("data/GNSS.txt"),
    )
}

/// The configuration with `name` in `section` set to `value` (a scalar), or its element
/// `index` (an array written one element per line).
fn edit(config: &str, section: &str, name: &str, index: Option<usize>, value: &str) -> String {
    let mut lines: Vec<String> = config.lines().map(String::from).collect();
    let start = lines.iter().position(|l| l == section).unwrap_or_else(|| panic!("{section}"));
    let at = (start..lines.len())
        .find(|&i| lines[i].starts_with(&format!("{name} = ")))
        .unwrap_or_else(|| panic!("{section} {name}"));
    match index {
        None => lines[at] = format!("{name} = {value}"),
        Some(k) => lines[at + 1 + k] = format!("    {value},"),
    }
    lines.join("\n") + "\n"
}

fn set_field(lines: &mut [String], line: usize, col: usize, value: &str) {
    let mut f: Vec<String> = lines[line - 1].split_whitespace().map(String::from).collect();
    f[col] = value.into();
    lines[line - 1] = f.join(" ");
}

fn cases(base: &Base) -> Vec<Case> {
    let mut s = Suite { base, cases: Vec::new() };
    // --- IMU files (the message names IMU.txt and the line) ---
    s.imu("imu-text", |l| set_field(l, 10, 2, "abc"), &["IMU.txt:10", "not a number"]);
    s.imu("imu-nan", |l| set_field(l, 11, 3, "nan"), &["IMU.txt:11", "NaN"]);
    s.imu("imu-inf", |l| set_field(l, 12, 4, "inf"), &["IMU.txt:12"]);
    s.imu(
        "imu-odometer-speed",
        |l| l[12] = format!("{} 5000.0", l[12]),
        &["IMU.txt:13", "odometer"],
    );
    s.imu(
        "imu-6-columns",
        |l| l[13] = l[13].rsplit_once(' ').unwrap().0.into(),
        &["IMU.txt:14", "columns"],
    );
    s.imu("imu-9-columns", |l| l[14] += " 1 2", &["IMU.txt:15", "columns"]);
    s.imu("imu-backwards", |l| l.swap(20, 21), &["IMU.txt:22", "backwards"]);
    s.imu("imu-duplicate", |l| l[30] = l[29].clone(), &["IMU.txt:31", "duplicate"]);
    s.imu(
        "imu-gap",
        |l| {
            l.drain(40..60);
        },
        &["IMU.txt:41", "gap", "line 40"],
    );
    s.imu("imu-empty", |l| l.clear(), &["IMU.txt", "no data"]);
    s.imu("imu-comments-only", |l| *l = vec!["# nothing".into()], &["IMU.txt", "no data"]);
    s.imu("imu-rates-in-increments", |l| set_field(l, 50, 4, "98.1"), &["IMU.txt:50", "rates"]);
    s.imu("imu-rate-spike", |l| set_field(l, 51, 1, "30"), &["IMU.txt:51", "rates"]);
    s.imu("imu-binary", |l| l[4] = "\u{fffd}\u{1}\u{2}".into(), &["IMU.txt:5"]);
    s.imu("imu-text-header", |l| l.insert(0, "t gx gy gz ax ay az".into()), &["IMU.txt:1"]);
    s.imu("imu-negative-time-step", |l| set_field(l, 60, 0, "0.0"), &["IMU.txt:60", "backwards"]);
    // skip mode bridges short gaps only: a 6 s hole is an error naming both lines
    let mut lines = base.imu.clone();
    lines.drain(100..400);
    let skip_dir = s.case_dir("imu-skip-mode-long-gap");
    let file = skip_dir.join("IMU.txt");
    std::fs::write(&file, lines.join("\n") + "\n").unwrap();
    let config = base
        .config
        .replace(&format!("{:?}", base.dir.join("data/IMU.txt")), &format!("{file:?}"))
        .replace("bad_lines = \"error\"", "bad_lines = \"skip\"");
    s.run_config("imu-skip-mode-long-gap", config, &["IMU.txt:101", "gap", "line 100"]);
    s.imu(
        "imu-long-gap-skip",
        |l| {
            l.drain(100..400);
        },
        &["IMU.txt:101", "gap"],
    );
    for line in [2usize, 77, 150] {
        s.imu(
            &format!("imu-letters-{line}"),
            move |l| set_field(l, line, 5, "1.0x"),
            &[&format!("IMU.txt:{line}")],
        );
    }
    // --- GNSS files ---
    s.gnss("gnss-text", |l| set_field(l, 3, 1, "north"), &["GNSS.txt:3"]);
    s.gnss("gnss-nan", |l| set_field(l, 4, 2, "NaN"), &["GNSS.txt:4"]);
    s.gnss("gnss-columns", |l| l[5] += " 0", &["GNSS.txt:6", "columns"]);
    s.gnss("gnss-latitude", |l| set_field(l, 2, 1, "95.0"), &["GNSS.txt:2", "latitude"]);
    s.gnss("gnss-longitude", |l| set_field(l, 2, 2, "400.0"), &["GNSS.txt:2", "longitude"]);
    s.gnss(
        "gnss-negative-sigma",
        |l| set_field(l, 7, 4, "-1"),
        &["GNSS.txt:7", "standard deviation"],
    );
    s.gnss("gnss-zero-sigma", |l| set_field(l, 7, 5, "0"), &["GNSS.txt:7", "standard deviation"]);
    s.gnss(
        "gnss-huge-sigma",
        |l| set_field(l, 8, 6, "1e200"),
        &["GNSS.txt:8", "standard deviation"],
    );
    s.gnss("gnss-height", |l| set_field(l, 9, 3, "1e7"), &["GNSS.txt:9", "height"]);
    s.gnss("gnss-backwards", |l| l.swap(10, 11), &["GNSS.txt:12", "backwards"]);
    s.gnss("gnss-duplicate", |l| l[12] = l[11].clone(), &["GNSS.txt:13", "duplicate"]);
    s.gnss("gnss-empty", |l| l.clear(), &["GNSS.txt", "no data"]);
    s.gnss(
        "gnss-after-imu",
        |l| shift(l, 1e5),
        &["GNSS.txt", "no GNSS epoch falls inside the IMU span"],
    );
    s.gnss(
        "gnss-before-imu",
        |l| shift(l, -1e4),
        &["GNSS.txt", "no GNSS epoch falls inside the IMU span"],
    );
    s.gnss("gnss-13-then-7", |l| l[3] += " 0 0 0 0.1 0.1 0.1", &["GNSS.txt:4", "columns"]);
    // --- our TOML configuration (the message names the key) ---
    for (key, section, name, index, value) in [
        ("data.start_time", "[data]", "start_time", None, "nan"),
        ("data.start_time", "[data]", "start_time", None, "inf"),
        ("data.start_time", "[data]", "start_time", None, "1000.0\nend_time = 900.0"),
        ("data.imu_rate", "[data]", "imu_rate", None, "0.0"),
        ("data.imu_rate", "[data]", "imu_rate", None, "-5.0"),
        ("data.imu_rate", "[data]", "imu_rate", None, "nan"),
        ("data.imu_rate", "[data]", "imu_rate", None, "1e9"),
        ("data.max_gap", "[data]", "max_gap", None, "0.5"),
        ("data.max_gap", "[data]", "max_gap", None, "nan"),
        ("data.max_bridge", "[data]", "max_bridge", None, "2.0"),
        ("init.position", "[init]", "position", Some(0), "95.0"),
        ("init.position", "[init]", "position", Some(2), "1e6"),
        ("init.position", "[init]", "position", Some(1), "nan"),
        ("init.velocity", "[init]", "velocity", Some(0), "nan"),
        ("init.velocity", "[init]", "velocity", Some(1), "1e5"),
        ("init.attitude", "[init]", "attitude", Some(0), "nan"),
        ("init.gyro_bias", "[init]", "gyro_bias", Some(0), "inf"),
        ("init.position_std", "[init]", "position_std", Some(0), "0.0"),
        ("init.position_std", "[init]", "position_std", Some(0), "-1.0"),
        ("init.velocity_std", "[init]", "velocity_std", Some(1), "nan"),
        ("init.attitude_std", "[init]", "attitude_std", Some(2), "0.0"),
        ("init.gyro_bias_std", "[init]", "gyro_bias_std", Some(0), "-5.0"),
        ("imu_noise.arw", "[imu_noise]", "arw", Some(0), "-0.3"),
        ("imu_noise.arw", "[imu_noise]", "arw", Some(1), "0.0"),
        ("imu_noise.vrw", "[imu_noise]", "vrw", Some(2), "nan"),
        ("imu_noise.gyro_bias_std", "[imu_noise]", "gyro_bias_std", Some(0), "-10.0"),
        ("imu_noise.accel_bias_std", "[imu_noise]", "accel_bias_std", Some(0), "0.0"),
        ("imu_noise.corr_time", "[imu_noise]", "corr_time", None, "0.0"),
        ("imu_noise.corr_time", "[imu_noise]", "corr_time", None, "nan"),
        ("gnss.lever_arm", "[gnss]", "lever_arm", Some(0), "1e9"),
        ("gnss.lever_arm", "[gnss]", "lever_arm", Some(1), "150.0"),
        ("gnss.lever_arm", "[gnss]", "lever_arm", Some(2), "nan"),
        ("filter.strategy", "[filter]", "strategy", None, "\"kalman-ish\""),
        ("filter.gate.probability", "[filter.gate]", "probability", None, "0.7"),
        ("filter.gate.probability", "[filter.gate]", "probability", None, "nan"),
        ("filter.gate.readmit_after", "[filter.gate]", "readmit_after", None, "0"),
        ("filter.states", "[filter]", "states", None, "17"),
        ("filter.covariance_interval", "[filter]", "covariance_interval", None, "-0.5"),
        ("filter.covariance_interval", "[filter]", "covariance_interval", None, "nan"),
        ("init.gyro_scale_std", "[init]", "gyro_scale_std", Some(0), "0.0"),
        ("init.accel_scale", "[init]", "accel_scale", Some(1), "2e5"),
        ("imu_noise.accel_scale_std", "[imu_noise]", "accel_scale_std", Some(2), "nan"),
        ("imu_rate", "[data]", "imu_rate", None, "\"fast\""),
        ("bias_model", "[imu_noise]", "bias_model", None, "\"brownian\""),
        ("mechanization", "[filter]", "mechanization", None, "\"round-earth\""),
        ("imu_format", "[data]", "imu_format", None, "\"angles\""),
        ("bad_lines", "[data]", "bad_lines", None, "\"ignore\""),
    ] {
        let config = edit(&base.config, section, name, index, value);
        let case = format!("toml-{}-{}", key.replace('.', "-"), s.cases.len());
        s.run_config(&case, config, &[key]);
    }
    s.toml("toml-unknown-key", "imu_rate = 50.0", "imu_rat = 50.0", &["imu_rat"]);
    for (key, section) in [
        ("vehicle.nhc.std", "[vehicle.nhc]\nstd = [0.0, 0.1]"),
        ("vehicle.nhc.mounting", "[vehicle.nhc]\nmounting = [200.0, 0.0, 0.0]"),
        ("vehicle.nhc.lever_arm", "[vehicle.nhc]\nlever_arm = [0.0, nan, 0.0]"),
        ("vehicle.nhc.interval", "[vehicle.nhc]\ninterval = -0.1"),
        ("vehicle.zupt.window", "[vehicle.zupt]\nwindow = 0.0"),
        ("vehicle.zupt.max_speed", "[vehicle.zupt]\nmax_speed = -1.0"),
        ("vehicle.zupt.rate_std", "[vehicle.zupt]\nrate_std = inf"),
        ("vehicle.zupt.speed_sigmas", "[vehicle.zupt]\nspeed_sigmas = -1.0"),
        ("vehicle.odometer.std", "[vehicle.odometer]\nstd = 0.0"),
        ("vehicle.odometer.calibration_time", "[vehicle.odometer]\ncalibration_time = nan"),
        ("nhc_std", "[vehicle.nhc]\nnhc_std = 0.1"),
    ] {
        let name = format!("toml-{}", key.replace('.', "-"));
        s.toml(&name, "[vehicle]\n", &format!("[vehicle]\n{section}\n"), &[key]);
    }
    // the calibration states: a prior that is no σ, a mounting nothing sees
    s.toml(
        "toml-calibrate-lever-arm-std",
        "[vehicle]\n",
        "[calibrate]\nlever_arm = true\nlever_arm_std = -1.0\n[vehicle]\n",
        &["calibrate.lever_arm_std"],
    );
    s.toml(
        "toml-calibrate-mounting-unseen",
        "[vehicle]\n",
        "[calibrate]\nmounting = true\n[vehicle]\n",
        &["calibrate.mounting", "vehicle.nhc"],
    );
    s.toml(
        "toml-calibrate-odometer-unseen",
        "[vehicle]\n",
        "[calibrate]\nodometer = true\n[vehicle]\n",
        &["calibrate.odometer", "vehicle.odometer"],
    );
    // two antennas: a baseline with no heading, a σ that is none
    s.toml(
        "toml-heading-vertical-baseline",
        "[vehicle]\n",
        "[gnss.heading]\nbaseline = [0.0, 0.0, 1.0]\n[vehicle]\n",
        &["gnss.heading.baseline"],
    );
    s.toml(
        "toml-heading-std",
        "[vehicle]\n",
        "[gnss.heading]\nstd = 0.0\n[vehicle]\n",
        &["gnss.heading.std"],
    );
    s.toml(
        "toml-unknown-stream",
        "[filter.streams]\n",
        "[filter.streams]\ngps = \"fused\"\n",
        &["filter.streams"],
    );
    s.toml(
        "toml-stream-strategy",
        "[filter.streams]\n",
        "[filter.streams]\ngnss-position = \"nope\"\n",
        &["filter.streams.gnss-position"],
    );
    s.toml(
        "toml-rates-on-increments",
        "imu_format = \"increments\"",
        "imu_format = \"rates\"",
        &["IMU.txt:"],
    );
    s.run_config("toml-not-toml", "this is = = not toml".into(), &["config.toml"]);
    s.run_config("toml-empty", String::new(), &["config.toml", "data"]);
    let missing = base.config.replacen(
        &format!("{:?}", base.dir.join("data/IMU.txt")),
        "\"/nonexistent/IMU.txt\"",
        1,
    );
    s.run_config("toml-missing-imu", missing, &["/nonexistent/IMU.txt"]);
    let missing = base.config.replacen(
        &format!("{:?}", base.dir.join("data/GNSS.txt")),
        "\"/nonexistent/GNSS.txt\"",
        1,
    );
    s.run_config("toml-missing-gnss", missing, &["/nonexistent/GNSS.txt"]);
    // --- KF-GINS YAML ---
    let y = yaml(base);
    for (key, from, to) in [
        ("antlever", "antlever:", "antlevr:"),
        ("endtime", "endtime:", "endtme:"),
        ("initgyrbias", "initgyrbias:", "initgyrbia:"),
        ("imunoise.arw", "  arw:", "  arww:"),
        ("imunoise.corrtime", "  corrtime:", "  corrtim:"),
        ("imupath", "imupath:", "# imupath:"),
        ("imudatalen", "imudatalen: 7", "imudatalen: 9"),
        ("initpos", "initpos: [45.0, 7.6, 240.0]", "initpos: [45.0, 7.6]"),
        ("initvelstd", "initvelstd: [0.1, 0.1, 0.1]", "initvelstd: [0.1, nan, 0.1]"),
        ("imudatarate", "imudatarate: 50", "imudatarate: fast"),
        ("init.position", "initpos: [45.0, 7.6, 240.0]", "initpos: [45.0, 7.6, 2.4e6]"),
        ("gnss.lever_arm", "antlever: [0.0, 0.0, 0.0]", "antlever: [1e9, 0.0, 0.0]"),
        ("imu_noise.arw", "arw: [0.3, 0.3, 0.3]", "arw: [0.0, 0.3, 0.3]"),
        ("starttime", "starttime: 1000.0", "starttime: .nan"),
    ] {
        assert!(y.contains(from), "yaml: {from}");
        let name = format!("yaml-{}-{}", key.replace('.', "-"), s.cases.len());
        s.yaml(&name, &y.replacen(from, to, 1), &[key]);
    }
    s.yaml(
        "yaml-did-you-mean",
        &y.replacen("antlever:", "antlevr:", 1),
        &["did you mean `antlever`"],
    );
    s.yaml("yaml-not-yaml", "[[[:", &["kf-gins.yaml", "YAML"]);
    s.yaml("yaml-empty", "", &["kf-gins.yaml"]);
    // --- scenarios (`simulate`, into the existing dataset) ---
    for (key, from, to) in [
        (
            "segment",
            "[[segment]]\nkind = \"straight\"\nduration = 20.0\n[[segment]]\nkind = \"turn\"\nduration = 10.0\nrate = 5.0\n",
            "",
        ),
        ("imu.rate", "rate = 50.0", "rate = 1e9"),
        ("imu.rate", "rate = 50.0", "rate = 0.0"),
        ("imu.rate", "rate = 50.0", "rate = nan"),
        ("start.speed", "speed = 5.0", "speed = nan"),
        ("start.speed", "speed = 5.0", "speed = -3.0"),
        ("start.position", "position = [45.0", "position = [95.0"),
        ("start.position", "position = [45.0, 7.6, 240.0]", "position = [45.0, 7.6, 1e7]"),
        ("gnss.position_std", "position_std = [1.0, 1.0, 2.0]", "position_std = [0.0, 1.0, 2.0]"),
        ("gnss.rate", "[gnss]\nrate = 1.0", "[gnss]\nrate = 0.0"),
        ("gnss.rate", "[gnss]\nrate = 1.0", "[gnss]\nrate = 500.0"),
        ("segment[0].duration", "duration = 20.0", "duration = -1.0"),
        ("segment[0].duration", "duration = 20.0", "duration = nan"),
        ("segment 0", "kind = \"straight\"", "kind = \"hover\""),
        ("imu.arw", "arw = 0.3", "arw = -0.3"),
        ("imu.corr_time", "corr_time = 1.0", "corr_time = 0.0"),
        ("init.position_std", "position_std = [2.0, 2.0, 3.0]", "position_std = [2.0, 0.0, 3.0]"),
        (
            "gnss.window[0]",
            "position_std = [1.0, 1.0, 2.0]",
            "position_std = [1.0, 1.0, 2.0]\n[[gnss.window]]\nstart = 5.0\nend = 2.0\nkind = \"outage\"",
        ),
        ("unknown field", "seed = 3", "seed = 3\nsede = 4"),
        (
            "raw.troposphere",
            "[init]",
            "[raw]\nnav = \"x.nav\"\nweek = 1316\ntroposphere = \"flat\"\n[init]",
        ),
        (
            "raw.elevation_mask",
            "[init]",
            "[raw]\nnav = \"x.nav\"\nweek = 1316\nelevation_mask = 95.0\n[init]",
        ),
    ] {
        let name = format!("scenario-{}-{}", key.replace(['.', ' ', '[', ']'], "-"), s.cases.len());
        s.scenario(&name, from, to, &[key]);
    }
    // --- command lines ---
    let good = base.dir.join("good.toml").display().to_string();
    let out = base.out.display().to_string();
    let nav = base.out.join("nav.txt").display().to_string();
    let truth = base.dir.join("data/truth.nav").display().to_string();
    for (name, args, expect) in [
        ("cli-skip-nan", vec!["run", &good, "--out", &out, "--skip", "nan"], vec!["--skip"]),
        ("cli-skip-negative", vec!["run", &good, "--out", &out, "--skip=-1"], vec!["--skip"]),
        (
            "cli-covariance-interval-negative",
            vec!["run", &good, "--out", &out, "--covariance-interval=-1"],
            vec!["--covariance-interval"],
        ),
        (
            "cli-covariance-interval-nan",
            vec!["run", &good, "--out", &out, "--covariance-interval", "nan"],
            vec!["--covariance-interval"],
        ),
        (
            "cli-skip-huge",
            vec!["run", &good, "--out", &out, "--truth", &truth, "--skip", "1e9"],
            vec!["no epoch"],
        ),
        (
            "cli-strategy",
            vec!["run", &good, "--out", &out, "--strategy", "bogus"],
            vec!["unknown strategy `bogus`"],
        ),
        (
            "cli-bias-model",
            vec!["run", &good, "--out", &out, "--bias-model", "bogus"],
            vec!["bias model"],
        ),
        (
            "cli-missing-config",
            vec!["run", "/nonexistent.toml", "--out", &out],
            vec!["/nonexistent.toml"],
        ),
        ("cli-eval-window-order", vec!["eval", &nav, &truth, "--window", "5,3"], vec!["window"]),
        ("cli-eval-window-text", vec!["eval", &nav, &truth, "--window", "a,b"], vec!["window"]),
        ("cli-eval-window-nan", vec!["eval", &nav, &truth, "--window", "nan,5"], vec!["window"]),
        ("cli-eval-skip-nan", vec!["eval", &nav, &truth, "--skip", "nan"], vec!["--skip"]),
        ("cli-eval-skip-huge", vec!["eval", &nav, &truth, "--skip", "1e9"], vec!["no epoch"]),
        (
            "cli-eval-missing",
            vec!["eval", "/nonexistent/nav.txt", &truth],
            vec!["/nonexistent/nav.txt"],
        ),
        (
            "cli-eval-truth-missing",
            vec!["eval", &nav, "/nonexistent/truth.nav"],
            vec!["/nonexistent/truth.nav"],
        ),
        (
            "cli-simulate-missing",
            vec!["simulate", "/nonexistent.toml", "--out", &out],
            vec!["/nonexistent.toml"],
        ),
        ("cli-unknown-command", vec!["fly", &good], vec!["fly"]),
        ("cli-run-no-config", vec!["run"], vec!["CONFIG"]),
        (
            "cli-compare-strategy",
            vec!["compare", &good, "--strategies", "fixed,bogus", "--out", &out],
            vec!["bogus"],
        ),
    ] {
        let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
        let expect: Vec<&str> = expect.to_vec();
        s.push(name, args, &expect, base.out.clone());
    }
    // an output directory that cannot be created (below a file): the path is named
    let blocked = base.dir.join("cases/a-file");
    std::fs::write(&blocked, "not a directory").unwrap();
    let below = blocked.join("out").display().to_string();
    s.push(
        "cli-unwritable-out",
        vec!["run".into(), good.clone(), "--out".into(), below, "--quiet".into()],
        &["a-file/out"],
        base.out.clone(),
    );
    // a full disk under each output (its `.partial` file is `/dev/full`): the write or the
    // flush that fails names the file, wherever it is written (the filter thread, the
    // `nav.txt` writer, the σ and update rows' thread, the smoother's writer), and the
    // earlier results in that directory survive
    let forward = ["nav.txt", "std.txt", "imu_errors.txt", "updates.csv", "nav.pos"];
    let smoothed = ["nav_smoothed.txt", "std_smoothed.txt", "nav_smoothed.pos"];
    for (name, smooth) in
        forward.iter().map(|n| (n, false)).chain(smoothed.iter().map(|n| (n, true)))
    {
        let dir = base.dir.join("cases").join(format!("full-{name}"));
        std::fs::create_dir_all(&dir).unwrap();
        for earlier in std::fs::read_dir(&base.out).unwrap() {
            let earlier = earlier.unwrap().path();
            std::fs::copy(&earlier, dir.join(earlier.file_name().unwrap())).unwrap();
        }
        let partial = format!("{name}.partial");
        std::os::unix::fs::symlink("/dev/full", dir.join(&partial)).unwrap();
        let mut args = vec!["run".into(), good.clone(), "--out".into()];
        args.extend([dir.display().to_string(), "--quiet".into()]);
        if smooth {
            args.push("--smooth".into());
        }
        s.push(&format!("full-disk-{name}"), args, &[&partial, "No space left"], dir);
    }
    // eval against a truth that does not overlap the result
    let shifted = base.dir.join("cases/truth-shifted.nav");
    let text: Vec<String> = std::fs::read_to_string(&truth)
        .unwrap()
        .lines()
        .map(|l| {
            let mut f: Vec<String> = l.split_whitespace().map(String::from).collect();
            f[1] = format!("{}", f[1].parse::<f64>().unwrap() + 1e5);
            f.join(" ")
        })
        .collect();
    std::fs::write(&shifted, text.join("\n")).unwrap();
    let shifted = shifted.display().to_string();
    s.push(
        "cli-eval-no-overlap",
        vec!["eval".into(), nav.clone(), shifted.clone()],
        &["no epoch"],
        base.out.clone(),
    );
    s.push(
        "cli-run-truth-no-overlap",
        vec![
            "run".into(),
            good.clone(),
            "--out".into(),
            out.clone(),
            "--truth".into(),
            shifted,
            "--quiet".into(),
        ],
        &["no epoch"],
        base.out.clone(),
    );
    s.cases
}

fn shift(lines: &mut [String], dt: f64) {
    for l in lines.iter_mut() {
        let mut f: Vec<String> = l.split_whitespace().map(String::from).collect();
        f[0] = format!("{:.3}", f[0].parse::<f64>().unwrap() + dt);
        *l = f.join(" ");
    }
}

#[test]
fn every_bad_input_is_refused_naming_its_source_and_earlier_results_survive() {
    let base = base("suite");
    let cases = cases(&base);
    assert!(cases.len() >= 100, "{} cases", cases.len());
    let mut failures = Vec::new();
    for c in &cases {
        let before = snapshot(&c.keep);
        let o = bin().args(&c.args).output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr).to_string();
        let mut problems = Vec::new();
        if o.status.success() {
            problems.push("exit status 0".to_string());
        }
        if o.status.code().is_none() || stderr.contains("panicked") {
            problems.push("panicked or killed".to_string());
        }
        for e in &c.expect {
            if !stderr.contains(e.as_str()) {
                problems.push(format!("message lacks `{e}`"));
            }
        }
        if snapshot(&c.keep) != before {
            problems.push(format!("{} changed", c.keep.display()));
        }
        if !problems.is_empty() {
            failures.push(format!(
                "{}: {} — stderr: {}",
                c.name,
                problems.join("; "),
                stderr.trim()
            ));
        }
    }
    eprintln!("{} bad-input cases run, {} failed", cases.len(), failures.len());
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
    let _ = std::fs::remove_dir_all(&base.dir);
}

#[test]
fn odd_but_valid_input_is_read() {
    let base = base("odd");
    let d = base.dir.join("odd");
    std::fs::create_dir_all(&d).unwrap();
    // a byte-order mark on every file, the IMU file gzip-compressed
    let imu = base.imu.join("\n") + "\n";
    let gz = flate2_compress(imu.as_bytes());
    let imu_path = d.join("IMU.txt.gz");
    std::fs::write(&imu_path, gz).unwrap();
    let gnss_path = d.join("GNSS.txt");
    std::fs::write(&gnss_path, format!("\u{feff}{}\n", base.gnss.join("\n"))).unwrap();
    let config = base
        .config
        .replace(&format!("{:?}", base.dir.join("data/IMU.txt")), &format!("{imu_path:?}"))
        .replace(&format!("{:?}", base.dir.join("data/GNSS.txt")), &format!("{gnss_path:?}"));
    let cfg = d.join("config.toml");
    std::fs::write(&cfg, format!("\u{feff}{config}")).unwrap();
    let out = d.join("out");
    let o = bin().arg("run").arg(&cfg).arg("--out").arg(&out).arg("--quiet").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // the same result as from the plain files
    assert_eq!(
        std::fs::read(out.join("nav.txt")).unwrap(),
        std::fs::read(base.out.join("nav.txt")).unwrap()
    );
    let _ = std::fs::remove_dir_all(&base.dir);
}

fn flate2_compress(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}
