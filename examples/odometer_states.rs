//! The odometer's scale and wheel point as states (`calibrate.odometer`, the calibration
//! issue, item 2) over a corpus: the simulator's 600 s drive (MEMS IMU, standing 20 s,
//! turns, a climb, two stops) with a wheel odometer at the IMU reading 1.5 % fast (0.05 m/s
//! noise), the NHC, RTK-grade fixes at 1 Hz lost in four 60 s outages; runs as a user makes
//! them (no `[init]`, the default gate), one seed per draw of every error.
//!
//! `cargo run --release --example odometer_states [SEEDS]` (default 20) prints, per cell,
//! the outages' score (the RMS of each outage's largest horizontal error; median and
//! worst over the seeds) and, with the states, the scale's and the lateral wheel point's
//! errors at the end against the truth (median, worst), the share of seeds whose every
//! axis lies within 3σ, and the share of epochs whose horizontal error lies beyond the
//! reported 99 % ellipse:
//!
//! - `cascade, wheel point right`: the scale calibrated outside the filter (the default),
//!   `vehicle.odometer.lever_arm` the truth `[0, 0, 0]`;
//! - `cascade, wheel point 0.4 m off`: the same with `[0, −0.4, 0]`;
//! - `states, wheel point right` and `states, wheel point 0.4 m off`: `calibrate.odometer`;
//! - `states, wheel point right, scale prior 0.5 %`: the scale's prior σ a tenth of the
//!   default (one experiment on the states' cost against the cascade).

#[path = "../tests/everyday/mod.rs"]
mod everyday;

use everyday::*;
use ins_gnss::run::{run_in_memory, Inputs};
use rayon::prelude::*;

#[derive(Clone, Copy, Debug, Default)]
struct Out {
    score: f64,
    beyond: f64,
    scale: f64,
    lateral: f64,
    within: bool,
}

fn one(seed: u64, extra: &str) -> Out {
    let d = odometer_drive(seed, 0.015);
    let g = gnss_rows(&d, Errors::White([0.02, 0.02, 0.05]), 1.0, seed);
    let cfg = config_of(&d, extra);
    let inputs = Inputs::Arrays { imu: d.imu.clone(), imu_width: 8, gnss: g, gnss_width: 7 };
    let (s, r) = run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs).unwrap();
    let (score, beyond) = score(&d, &r, 0.0);
    match s.calibration.and_then(|c| c.odometer) {
        Some(((k, _, _), (l, ls, _))) => Out {
            score,
            beyond,
            scale: (k - 0.015).abs(),
            lateral: l.y.abs(),
            within: (0..3).all(|i| l[i].abs() <= 3.0 * ls[i]),
        },
        None => Out { score, beyond, scale: f64::NAN, lateral: f64::NAN, within: false },
    }
}

fn main() {
    let seeds: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    let wrong = "[vehicle.odometer]\nlever_arm = [0.0, -0.4, 0.0]\n";
    let states = "[calibrate]\nodometer = true\n";
    let cells = [
        ("cascade, wheel point right", String::new()),
        ("cascade, wheel point 0.4 m off", wrong.to_string()),
        ("states, wheel point right", states.to_string()),
        ("states, wheel point 0.4 m off", format!("{wrong}{states}")),
        (
            "states, wheel point right, scale prior 0.5 %",
            format!("{states}odometer_scale_std = 0.5\n"),
        ),
    ];
    println!(
        "| cell | outage score, median (worst) | scale |err|, median (worst) | lateral wheel point |err|, median (worst) | every axis within 3σ | position beyond its 99 % ellipse (mean) |"
    );
    println!("|---|---|---|---|---|---|");
    for (name, extra) in &cells {
        let outs: Vec<Out> = (1..=seeds).into_par_iter().map(|s| one(s, extra)).collect();
        let med = |f: &dyn Fn(&Out) -> f64| {
            let mut v: Vec<f64> = outs.iter().map(f).collect();
            v.sort_by(f64::total_cmp);
            (v[v.len() / 2], v[v.len() - 1])
        };
        let (s, sw) = med(&|o| o.score);
        let (k, kw) = med(&|o| 100.0 * o.scale);
        let (l, lw) = med(&|o| 100.0 * o.lateral);
        let within = outs.iter().filter(|o| o.within).count();
        let b = 100.0 * outs.iter().map(|o| o.beyond).sum::<f64>() / outs.len() as f64;
        if k.is_nan() {
            println!("| {name} | {s:.3} m ({sw:.3} m) | — | — | — | {b:.1} % |");
        } else {
            println!(
                "| {name} | {s:.3} m ({sw:.3} m) | {k:.3} % ({kw:.3} %) | {l:.1} cm ({lw:.1} cm) | {within}/{seeds} | {b:.1} % |"
            );
        }
    }
}
