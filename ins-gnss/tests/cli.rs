//! The `ins-gnss` binary end to end: simulate → run → eval (JSON), compare, errors with
//! a non-zero exit, and on the sample data the KF-GINS configuration as it is.

use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ins-gnss"))
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("estimator-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn simulate_run_eval_compare() {
    let dir = temp("sim");
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/drive.toml");
    let out = bin().args(["simulate"]).arg(&scenario).arg("--out").arg(&dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in ["IMU.txt", "GNSS.txt", "truth.nav", "config.toml"] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    let out = bin()
        .arg("run")
        .arg(dir.join("config.toml"))
        .args(["--strategy", "iakf", "--quiet", "--plots", "--skip", "10"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("iakf:") && stdout.contains("GNSS epochs"), "{stdout}");
    for f in [
        "nav.txt",
        "std.txt",
        "imu_errors.txt",
        "updates.csv",
        "errors_position.svg",
        "errors_attitude.svg",
        "adaptation.svg",
    ] {
        assert!(dir.join("out").join(f).is_file(), "{f} missing");
    }
    // updates.csv: one row per GNSS epoch with a decision.
    let updates = std::fs::read_to_string(dir.join("out/updates.csv")).unwrap();
    assert!(updates.lines().count() > 50);
    assert!(updates
        .lines()
        .skip(1)
        .all(|l| l.contains("accepted") || l.contains("inflated") || l.contains("rejected")));

    let out = bin()
        .arg("eval")
        .arg(dir.join("out/nav.txt"))
        .arg(dir.join("truth.nav"))
        .args(["--skip", "10", "--window", "80,95", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let horiz = v["overall"]["horizontal"]["rms"].as_f64().unwrap();
    let outage = v["windows"][0]["horizontal"]["max"].as_f64().unwrap();
    assert!(horiz > 0.0 && horiz < 5.0, "horizontal RMS {horiz}");
    assert!(outage > 0.0, "outage window has no statistics");

    let out = bin()
        .arg("compare")
        .arg(dir.join("config.toml"))
        .args(["--strategies", "fixed,sage-husa", "--skip", "10"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("| fixed") && stdout.contains("| sage-husa"), "{stdout}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn errors_exit_non_zero_with_a_message() {
    let out = bin().args(["run", "/nonexistent/config.toml"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/config.toml"));
    let out = bin().args(["eval", "a.txt", "b.txt", "--window", "5,1"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("end must be after start"));
}

#[test]
fn kf_gins_yaml_as_it_is_on_navego() {
    let Some(data) = std::env::var_os("ESTIMATOR_DATA_DIR")
        .map(PathBuf::from)
        .filter(|d| d.join("navego").is_dir())
    else {
        eprintln!("skipped: set ESTIMATOR_DATA_DIR to run this test");
        return;
    };
    let dir = temp("navego");
    let out = bin()
        .arg("run")
        .arg(data.join("navego/kf-gins-ADIS16488.yaml"))
        .arg("--out")
        .arg(&dir)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = bin()
        .arg("eval")
        .arg(dir.join("nav.txt"))
        .arg(data.join("navego/truth.nav"))
        .args(["--skip", "60", "--json"])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let horiz = v["overall"]["horizontal"]["rms"].as_f64().unwrap();
    let yaw = v["overall"]["yaw"]["rms"].as_f64().unwrap();
    eprintln!(
        "ins-gnss run + eval on navego ADIS16488: horizontal RMS {horiz:.3} m, yaw RMS {yaw:.3}°"
    );
    assert!(horiz <= 1.57 && yaw <= 0.57);
    std::fs::remove_dir_all(&dir).unwrap();
}
