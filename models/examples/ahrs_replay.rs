//! Run the CS-MAEKF AHRS over a recorded sensor sequence on the host, printing what the
//! firmware example prints under QEMU (`firmware/`), and compare the two.
//!
//! ```sh
//! cargo run -p models --example ahrs_replay -- firmware/data/flight.bin
//! cargo run -p models --example ahrs_replay -- firmware/data/flight.bin --compare qemu.txt
//! ```
//!
//! Every 100th sample and the last one give a line `att k roll pitch yaw` (radians, `{:.15e}`).
//! With `--compare FILE` the firmware's lines are read from FILE and the largest difference
//! is printed; the exit status is 1 if it exceeds 1e-9 rad or a line is missing.

use models::ahrs::onboard::cs_maekf_model;
use models::ahrs::{Ahrs, AhrsMeasurement, Recording};

fn fail(msg: String) -> ! {
    eprintln!("ahrs_replay: {msg}");
    std::process::exit(1);
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
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
    let model = cs_maekf_model(rec.gyro_noise, rec.rate);
    let meas = AhrsMeasurement { g_n: rec.g_n, m_n: rec.m_n };
    let mut ahrs =
        Ahrs::new(model, meas, rec.att0, rec.rate).unwrap_or_else(|e| fail(format!("start: {e}")));
    let mut lines = Vec::new();
    for k in 0..rec.len() {
        let [g, a, m] = rec.sample(k).expect("k < len");
        ahrs.step(&g, &a, &m).unwrap_or_else(|e| fail(format!("sample {k}: {e}")));
        if (k + 1) % 100 == 0 || k + 1 == rec.len() {
            let (r, p, y) = ahrs.state().att.euler();
            lines.push((k + 1, [r, p, y]));
        }
    }
    let Some(file) = compare else {
        for (k, e) in &lines {
            println!("att {k} {:.15e} {:.15e} {:.15e}", e[0], e[1], e[2]);
        }
        return;
    };
    let text = std::fs::read_to_string(&file).unwrap_or_else(|e| fail(format!("{file}: {e}")));
    let theirs: Vec<(usize, [f64; 3])> = text
        .lines()
        .filter_map(|l| l.strip_prefix("att "))
        .map(|l| {
            let v: Vec<&str> = l.split_whitespace().collect();
            let num = |i: usize| -> f64 {
                v.get(i)
                    .and_then(|s| s.parse().ok())
                    .unwrap_or_else(|| fail(format!("{file}: bad line `att {l}`")))
            };
            let k = v
                .first()
                .and_then(|s| s.parse().ok())
                .unwrap_or_else(|| fail(format!("{file}: bad line `att {l}`")));
            (k, [num(1), num(2), num(3)])
        })
        .collect();
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
    println!("{} attitude lines compared, largest difference {worst:.3e} rad", lines.len());
    if worst > 1e-9 {
        fail(format!(
            "the firmware's attitude differs from the host's by {worst:.3e} rad (> 1e-9)"
        ));
    }
}
