//! A small campaign of the program's automatic decisions, as CI's share of
//! `benches/campaign.py` (which runs the full one: ≥ 50 seeds per cell, the table in
//! `docs/history/results.md`): navego with KF-GINS's YAML as shipped and with `noinit.toml` (no
//! `[init]`), 1 km GNSS errors at random bearings on 10 % and 50 % of the fixes, from the
//! first fix and after the first minute, three seeds of this file's own per cell. Each run
//! is the program as a user runs it (no `--no-gate`, no `--accept-inconsistent`).
//!
//! The laws, over every run: no run is refused before it starts (the start's checks and
//! alignment leave gross errors out); no run ends beyond 5 m horizontal RMS; at 10 % every
//! run exits 0 (gross errors are the data's quality, not the run's inconsistency) with
//! the refused share in its summary; and a run beyond 5 m would have to exit 3.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::sample_data;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ins-gnss"))
}

fn unpack(path: &Path) -> String {
    let mut text = String::new();
    let f = std::fs::File::open(path).unwrap();
    if path.extension().is_some_and(|e| e == "zst") {
        zstd::stream::read::Decoder::new(f).unwrap().read_to_string(&mut text).unwrap();
    } else {
        std::io::BufReader::new(f).read_to_string(&mut text).unwrap();
    }
    text
}

/// The GNSS text with `rate` of the fixes from `start` s after the first moved `size` m at
/// a random bearing (seeded).
fn corrupt(text: &str, rate: f64, start: f64, size: f64, seed: u64) -> (String, usize) {
    let mut rng = StdRng::seed_from_u64(seed);
    let (mut out, mut moved, mut t0) = (String::new(), 0, None);
    for line in text.lines() {
        let mut f: Vec<String> = line.split_whitespace().map(str::to_string).collect();
        let (u, b): (f64, f64) = (rng.random(), rng.random::<f64>() * std::f64::consts::TAU);
        if f.len() >= 4 && !line.trim_start().starts_with('#') {
            let t: f64 = f[0].parse().unwrap();
            let t0 = *t0.get_or_insert(t);
            if t >= t0 + start && u < rate {
                let lat: f64 = f[1].parse().unwrap();
                let lon: f64 = f[2].parse().unwrap();
                let r = 6_378_137.0;
                f[1] = format!("{:.10}", lat + (size * b.cos() / r).to_degrees());
                f[2] = format!(
                    "{:.10}",
                    lon + (size * b.sin() / (r * lat.to_radians().cos())).to_degrees()
                );
                moved += 1;
            }
        }
        out.push_str(&f.join(" "));
        out.push('\n');
    }
    (out, moved)
}

/// One run's outcome: exit status, horizontal RMS against the truth, refused share.
#[derive(Debug)]
struct Outcome {
    label: String,
    exit: i32,
    horizontal: f64,
    refused: f64,
    stderr: String,
}

fn run(config: &str, rate: f64, start: f64, seed: u64, work: &Path) -> Outcome {
    let d = sample_data::dir(env!("CARGO_MANIFEST_DIR"), "navego");
    let label = format!("{config} {:.0} % from {start} s seed {seed}", rate * 100.0);
    let dir = work.join(label.replace([' ', '%'], "_"));
    std::fs::create_dir_all(&dir).unwrap();
    let (gnss, _) =
        corrupt(&unpack(&sample_data::file(&d, "GNSS-POS.txt")), rate, start, 1000.0, seed);
    let gnss_path = dir.join("gnss.txt");
    std::fs::write(&gnss_path, gnss).unwrap();
    let imu = sample_data::file(&d, "IMU-ADIS16488.txt");
    // the shipped configuration with its two input paths pointed at the run's files
    let (source, name, imu_key, gnss_key) = match config {
        "yaml" => ("kf-gins-ADIS16488.yaml", "run.yaml", "imupath: ", "gnsspath: "),
        _ => ("noinit.toml", "run.toml", "imu = ", "gnss = "),
    };
    let text: Vec<String> = std::fs::read_to_string(d.join(source))
        .unwrap()
        .lines()
        .map(|l| {
            if l.starts_with(imu_key) {
                format!("{imu_key}\"{}\"", imu.display())
            } else if l.starts_with(gnss_key) {
                format!("{gnss_key}\"{}\"", gnss_path.display())
            } else {
                l.to_string()
            }
        })
        .collect();
    let cfg = dir.join(name);
    std::fs::write(&cfg, text.join("\n")).unwrap();
    let out_dir = dir.join("out");
    let o = bin().arg("run").arg(&cfg).arg("--out").arg(&out_dir).arg("--quiet").output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout).to_string();
    let refused = stdout
        .lines()
        .find(|l| l.starts_with("consistency of gnss-"))
        .and_then(|l| l.split(" refused as gross errors, ").nth(1))
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(f64::NAN);
    let mut horizontal = f64::NAN;
    if out_dir.join("nav.txt").exists() {
        let e = bin()
            .arg("eval")
            .arg(out_dir.join("nav.txt"))
            .arg(sample_data::file(&d, "truth.nav"))
            .arg("--json")
            .output()
            .unwrap();
        assert!(e.status.success(), "{}", String::from_utf8_lossy(&e.stderr));
        let v: serde_json::Value = serde_json::from_slice(&e.stdout).unwrap();
        horizontal = v["overall"]["horizontal"]["rms"].as_f64().unwrap();
    }
    let _ = std::fs::remove_dir_all(&dir);
    Outcome {
        label,
        exit: o.status.code().unwrap_or(-1),
        horizontal,
        refused,
        stderr: String::from_utf8_lossy(&o.stderr).to_string(),
    }
}

#[test]
fn navego_with_gross_errors_starts_stays_within_5_m_and_is_flagged_only_when_wrong() {
    let work: PathBuf =
        std::env::temp_dir().join(format!("estimator-campaign-{}", std::process::id()));
    let mut jobs = Vec::new();
    for config in ["yaml", "noinit"] {
        jobs.push((config, 0.0, 0.0, 0));
        for rate in [0.1, 0.5] {
            for start in [0.0, 60.0] {
                for seed in [7, 8, 9] {
                    jobs.push((config, rate, start, seed));
                }
            }
        }
    }
    // two runs at a time (each run is threaded itself)
    let queue = std::sync::Mutex::new(jobs.into_iter());
    let results = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let job = queue.lock().unwrap().next();
                let Some((config, rate, start, seed)) = job else { break };
                let o = run(config, rate, start, seed, &work);
                results.lock().unwrap().push((config, rate, o));
            });
        }
    });
    let _ = std::fs::remove_dir_all(&work);
    let results = results.into_inner().unwrap();
    for (_, _, o) in &results {
        eprintln!(
            "{:32} exit {} horizontal {:7.2} m refused {:5.1} %",
            o.label, o.exit, o.horizontal, o.refused
        );
    }
    let clean = |config: &str| {
        results.iter().find(|(c, r, _)| *c == config && *r == 0.0).unwrap().2.horizontal
    };
    for (config, rate, o) in &results {
        assert!(o.exit == 0 || o.exit == 3, "{}: refused before it ran:\n{}", o.label, o.stderr);
        assert!(o.horizontal <= 5.0, "{}: {:.1} m", o.label, o.horizontal);
        if *rate <= 0.2 {
            assert_eq!(o.exit, 0, "{}: flagged, {:.2} m:\n{}", o.label, o.horizontal, o.stderr);
            assert!(
                o.horizontal <= 1.5 * clean(config),
                "{}: {:.2} m against {:.2} m clean",
                o.label,
                o.horizontal,
                clean(config)
            );
            // the refused share is in the summary, and it is the gross errors' share
            assert!(
                (o.refused - 100.0 * rate).abs() < 4.0 || *rate == 0.0,
                "{}: refused {} %",
                o.label,
                o.refused
            );
        }
    }
}
