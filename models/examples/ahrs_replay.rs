//! Run the CS-MAEKF AHRS over a recorded sensor sequence on the host, printing what the
//! firmware example prints under QEMU (`firmware/`), and compare the two.
//!
//! ```sh
//! cargo run -p models --example ahrs_replay -- firmware/data/flight.bin
//! cargo run -p models --example ahrs_replay -- firmware/data/flight.bin --compare qemu.txt
//! cargo run -p models --example ahrs_replay -- firmware/data/flight.bin --f32 --compare qemu.txt
//! ```
//!
//! Every 100th sample and the last one give a line `att k roll pitch yaw` (radians,
//! `{:.15e}`). `--f32` runs the filter in single precision (as the firmware does by
//! default). With `--compare FILE` the firmware's lines are read from FILE and the largest
//! difference is printed; the exit status is 1 if it exceeds the tolerance (1e-9 rad in
//! `f64`, 1e-5 rad in `f32`) or a line is missing.

use estimator_core::FilterScalar;
use models::ahrs::onboard::cs_maekf_model;
use models::ahrs::{Ahrs, AhrsMeasurement, Recording};

fn fail(msg: String) -> ! {
    eprintln!("ahrs_replay: {msg}");
    std::process::exit(1);
}

/// The filter over the recording in the scalar `T`: `(sample, [roll, pitch, yaw])` every
/// 100 samples and at the last.
fn replay<T: FilterScalar>(rec: &Recording<'_>) -> Vec<(usize, [f64; 3])> {
    let model = cs_maekf_model(rec.gyro_noise, rec.rate);
    let meas = AhrsMeasurement { g_n: rec.g_n.map(T::lit), m_n: rec.m_n.map(T::lit) };
    let mut ahrs = Ahrs::<T>::new(model, meas, rec.att0.cast::<T>(), rec.rate)
        .unwrap_or_else(|e| fail(format!("start: {e}")));
    let mut lines = Vec::new();
    for k in 0..rec.len() {
        let [g, a, m] = rec.sample::<T>(k).expect("k < len");
        ahrs.step(&g, &a, &m).unwrap_or_else(|e| fail(format!("sample {k}: {e}")));
        if (k + 1) % 100 == 0 || k + 1 == rec.len() {
            let (r, p, y) = ahrs.state().att.euler();
            lines.push((k + 1, [r.to_f64(), p.to_f64(), y.to_f64()]));
        }
    }
    lines
}

/// The firmware's `att` lines.
fn read_lines(file: &str) -> Vec<(usize, [f64; 3])> {
    let text = std::fs::read_to_string(file).unwrap_or_else(|e| fail(format!("{file}: {e}")));
    text.lines()
        .enumerate()
        .filter_map(|(i, l)| l.strip_prefix("att ").map(|l| (i + 1, l)))
        .map(|(line, l)| {
            let bad =
                || -> ! { fail(format!("{file}:{line}: not `att k roll pitch yaw`: `att {l}`")) };
            let v: Vec<&str> = l.split_whitespace().collect();
            let num = |i: usize| -> f64 {
                v.get(i).and_then(|s| s.parse().ok()).unwrap_or_else(|| bad())
            };
            let k: usize = v.first().and_then(|s| s.parse().ok()).unwrap_or_else(|| bad());
            (k, [num(1), num(2), num(3)])
        })
        .collect()
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let single = args.iter().any(|a| a == "--f32");
    args.retain(|a| a != "--f32");
    let path = args.first().cloned().unwrap_or_else(|| "firmware/data/flight.bin".into());
    let compare = match args.get(1).map(String::as_str) {
        Some("--compare") => {
            Some(args.get(2).cloned().unwrap_or_else(|| fail("--compare FILE".into())))
        }
        Some(other) => fail(format!("unknown argument {other}")),
        None => None,
    };
    let bytes = std::fs::read(&path).unwrap_or_else(|e| fail(format!("{path}: {e}")));
    let rec = Recording::parse(&bytes).unwrap_or_else(|e| fail(format!("{path}: {e}")));
    let lines = if single { replay::<f32>(&rec) } else { replay::<f64>(&rec) };
    let Some(file) = compare else {
        for (k, e) in &lines {
            println!("att {k} {:.15e} {:.15e} {:.15e}", e[0], e[1], e[2]);
        }
        return;
    };
    let theirs = read_lines(&file);
    if theirs.len() != lines.len() {
        fail(format!("{file}: {} attitude lines, the host run has {}", theirs.len(), lines.len()));
    }
    let mut worst = 0.0_f64;
    for ((k, ours), (kt, t)) in lines.iter().zip(&theirs) {
        if k != kt {
            fail(format!("{file}: line for sample {kt}, expected {k}"));
        }
        for i in 0..3 {
            worst = worst.max(manifolds::wrap_angle(ours[i] - t[i]).abs());
        }
    }
    let (scalar, tolerance) = if single { ("f32", 1e-5) } else { ("f64", 1e-9) };
    println!(
        "{} attitude lines compared ({scalar}), largest difference {worst:.3e} rad",
        lines.len()
    );
    if worst > tolerance {
        fail(format!(
            "the firmware's attitude differs from the host's by {worst:.3e} rad (> {tolerance:e})"
        ));
    }
}
