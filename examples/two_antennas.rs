//! Heading from two antennas over a corpus (the calibration issue, item 3): the
//! simulator's 600 s drive (a MEMS IMU, standing 20 s first, turns, a 3° climb, two
//! stops) with RTK-grade fixes at 1 Hz (white, σ 2, 2, 5 cm) and a moving-base receiver
//! measuring its 1 m baseline at every fix, four GNSS outages of 60 s that take the fixes
//! and the headings; run through the program as a user makes them (no `[init]`, the
//! default gate), one seed per draw of the IMU's, the fixes' and the headings' errors.
//!
//! `cargo run --release --example two_antennas [SEEDS]` (default 20) prints, per cell, the
//! heading's RMS error over the run and inside the outages (median and worst over the
//! seeds), the share of seeds within the bar (0.3° RMS through the outages), the
//! start's heading error at the first fix against its σ, and the same drive without the
//! antennas:
//!
//! - `forward 0.2°`: the baseline along the forward axis, σ 0.2° (the case);
//! - `across 0.2°`: the antennas left–right (the heading the yaw + 90°);
//! - `forward 0.5°`: a shorter baseline's σ;
//! - `moving start`: the run starting at 44.5 s, driving straight at 15 m/s;
//! - `wrong fixes 5 %`: 5 % of the headings 5–30° off, their σ unchanged — the gate's
//!   work;
//! - `single-point fixes`: a moving-base receiver without corrections from a base: the
//!   heading at 0.2°, the fixes a single point's (a Gauss–Markov wander of 1.5/1.5/3 m,
//!   τ 100 s, over 0.3 m white, the true σ declared), and the same declaring a tenth and
//!   ten times that σ.
//!
//! The last two columns: the share of `std.txt`'s rows whose heading error lies beyond
//! 2.576 times the reported heading σ, and whose horizontal position error lies beyond the
//! reported 99 % ellipse (means over the seeds).

#[path = "../tests/everyday/mod.rs"]
mod everyday;

use everyday::*;
use ins_gnss::run::{run_in_memory, Inputs};
use nalgebra::Vector3;
use rayon::prelude::*;

/// Name, baseline (m), heading σ (deg), share of wrong headings, configuration lines,
/// the fixes' errors and the factor on their σ the fixes declare.
type Cell = (&'static str, Vector3<f64>, f64, f64, &'static str, Errors, f64);

#[derive(Clone, Copy, Debug, Default)]
struct Out {
    all: f64,
    outages: f64,
    start: f64,
    start_sigma: f64,
    without: f64,
    refused_headings: usize,
    heading_beyond: f64,
    position_beyond: f64,
}

fn one(seed: u64, cell: &Cell) -> Out {
    let &(_, baseline, sigma, wrong, extra, errors, declared) = cell;
    let d = antenna_drive(seed, baseline, sigma, wrong);
    let g = gnss_rows(&d.data, errors, declared, seed);
    let go = |more: &str| {
        let cfg = config_of(&d.data, &format!("{extra}{more}"));
        let inputs = Inputs::Arrays {
            imu: d.data.imu.clone(),
            imu_width: 7,
            gnss: g.clone(),
            gnss_width: 7,
        };
        run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs).unwrap()
    };
    let (_, r) = go("");
    let (_, r0) = go("[gnss.heading]\nuse_headings = false\n");
    std::fs::remove_file(&d.headings).ok();
    let (all, outages, _) = heading_errors(&d.yaw, &r.nav, 0.0);
    let (_, without, _) = heading_errors(&d.yaw, &r0.nav, 0.0);
    let first = r.nav[0];
    let k = d.yaw.partition_point(|y| y.0 < first[0] - 1e-6);
    let start = ins_gnss_core::heading::wrap(first[9].to_radians() - d.yaw[k].1).to_degrees();
    // std.txt's first row: t, then the σ of position, velocity, attitude (deg): yaw at 9
    let start_sigma = r.std[9];
    let refused_headings = r
        .updates
        .iter()
        .filter(|u| {
            u.stream.to_string() == "gnss-heading" && u.verdict == estimator_core::Verdict::Rejected
        })
        .count();
    // the reported heading σ against the error, at std.txt's rows: beyond 2.576σ
    let (mut n, mut beyond) = (0usize, 0usize);
    for row in r.std.chunks(r.std_width) {
        let k = r.nav.partition_point(|x| x[0] < row[0] - 1e-9);
        let j = d.yaw.partition_point(|y| y.0 < row[0] - 1e-6);
        if let (Some(x), Some(y)) = (r.nav.get(k), d.yaw.get(j))
            && (x[0] - row[0]).abs() < 1e-6
            && (y.0 - row[0]).abs() < 1e-6
        {
            n += 1;
            let e = ins_gnss_core::heading::wrap(x[9].to_radians() - y.1).to_degrees();
            beyond += usize::from(e.abs() > 2.576 * row[9]);
        }
    }
    let heading_beyond = beyond as f64 / n.max(1) as f64;
    let position_beyond = score(&d.data, &r, 0.0).1;
    Out {
        all,
        outages,
        start,
        start_sigma,
        without,
        refused_headings,
        heading_beyond,
        position_beyond,
    }
}

fn main() {
    let seeds: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    let fwd = Vector3::new(1.0, 0.0, 0.0);
    let rtk = Errors::White([0.02, 0.02, 0.05]);
    let single = Errors::Wander([1.5, 1.5, 3.0], 100.0, 0.3);
    let cells: [Cell; 8] = [
        ("forward 0.2°", fwd, 0.2, 0.0, "", rtk, 1.0),
        ("across 0.2°", Vector3::new(0.0, 1.0, 0.0), 0.2, 0.0, "", rtk, 1.0),
        ("forward 0.5°", fwd, 0.5, 0.0, "", rtk, 1.0),
        ("moving start", fwd, 0.2, 0.0, "[data]\nstart_time = 44.5\n", rtk, 1.0),
        ("wrong fixes 5 %", fwd, 0.2, 0.05, "", rtk, 1.0),
        ("single-point fixes", fwd, 0.2, 0.0, "", single, 1.0),
        ("single-point fixes, σ declared ×0.1", fwd, 0.2, 0.0, "", single, 0.1),
        ("single-point fixes, σ declared ×10", fwd, 0.2, 0.0, "", single, 10.0),
    ];
    println!(
        "| cell | heading RMS, median (worst) | in the outages, median (worst) | ≤ 0.3° | start error / σ, worst | without antennas, outages median | headings refused | heading beyond its 99 % (mean) | position beyond its 99 % ellipse (mean) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for cell in &cells {
        let name = cell.0;
        let outs: Vec<Out> = (1..=seeds).into_par_iter().map(|s| one(s, cell)).collect();
        let med = |f: &dyn Fn(&Out) -> f64| {
            let mut v: Vec<f64> = outs.iter().map(f).collect();
            v.sort_by(f64::total_cmp);
            (v[v.len() / 2], v[v.len() - 1])
        };
        let (a, aw) = med(&|o| o.all);
        let (o, ow) = med(&|o| o.outages);
        let within = outs.iter().filter(|o| o.outages <= 0.3 && o.all <= 0.3).count();
        let (_, zw) = med(&|o| (o.start / o.start_sigma).abs());
        let (w, _) = med(&|o| o.without);
        let refused: usize = outs.iter().map(|o| o.refused_headings).sum();
        let mean = |f: &dyn Fn(&Out) -> f64| outs.iter().map(f).sum::<f64>() / outs.len() as f64;
        let hb = 100.0 * mean(&|o| o.heading_beyond);
        let pb = 100.0 * mean(&|o| o.position_beyond);
        println!(
            "| {name} | {a:.3}° ({aw:.3}°) | {o:.3}° ({ow:.3}°) | {within}/{seeds} | {zw:.2}σ | {w:.3}° | {refused} | {hb:.1} % | {pb:.1} % |"
        );
    }
}
