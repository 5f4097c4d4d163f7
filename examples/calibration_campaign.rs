//! The calibration states over a corpus (the calibration issue, item 2): the simulator's
//! 600 s drive (a MEMS IMU, standing 20 s first, turns, a 3° climb, two stops) with
//! RTK-grade fixes at 1 Hz (white, σ 2, 2, 5 cm N, E, D), run through the program as a
//! user makes them (no `[init]`, the default gate), one seed per draw of the IMU's and the
//! fixes' errors.
//!
//! `cargo run --release --features campaigns --example calibration_campaign [SEEDS]` (default 20) prints, per
//! cell, the calibration's errors at the end against the truth (the lever arm and the
//! mounting per axis; the time offset), the share of seeds within the bars, the σ the run reports
//! and the horizontal RMS against the truth (with the share of epochs beyond the run's own
//! 99 % ellipse) beside the run given the true values by hand:
//!
//! - `lever`: the antenna 1.0 m from the IMU, `(0.6, −0.5, −0.62)` m, declared `[0, 0, 0]`,
//!   `calibrate.lever_arm` on; and the same run without the state (the error a
//!   wrong lever arm leaves);
//! - `late 0.3 s`, `late 5 s`: the IMU's stamps late by that much, the lever arm known,
//!   `calibrate.time_offset` on (the start's search applies the coarse offset, the
//!   state refines it);
//! - `on time`: the stamps right, the time offset estimated: is it within 3σ of 0, and
//!   does the start name an offset (an alarm)?
//! - `both`: the lever arm unknown and the stamps 0.3 s late;
//! - `NHC, mounting …`: the IMU mounted at roll 0°, pitch 1°, yaw 2° in a car without
//!   sideslip, the non-holonomic constraint on: the mounting given by hand, declared
//!   zero, and declared zero with `calibrate.mounting` (the bar: pitch and yaw within
//!   0.2°; the roll, which the constraint cannot see, reported as such).

#[path = "../tests/everyday/mod.rs"]
mod everyday;

use std::sync::Arc;

use everyday::*;
use ins_gnss::run::{run_in_memory, Inputs};
use nalgebra::Vector3;
use rayon::prelude::*;

/// What one run gave.
#[derive(Clone, Debug, Default)]
struct Cal {
    refused: Option<String>,
    /// Lever-arm error per axis (m) and its σ.
    lever: Option<(Vector3<f64>, Vector3<f64>)>,
    /// Time-offset error (s) and its σ.
    offset: Option<(f64, f64)>,
    /// Mounting error per angle (deg) and its σ.
    mount: Option<(Vector3<f64>, Vector3<f64>)>,
    /// The start named or applied an offset.
    alarm: bool,
    rms: f64,
    /// Share of epochs beyond the run's own 99 % horizontal ellipse.
    beyond: f64,
}

fn one(d: &Data, gnss: Arc<[f64]>, extra: &str, late: f64, mounting: Vector3<f64>) -> Cal {
    let cfg = config_of(d, extra);
    let inputs = Inputs::Arrays { imu: d.imu.clone(), imu_width: 7, gnss, gnss_width: 7 };
    let (summary, results) = match run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs) {
        Ok(r) => r,
        Err(e) => return Cal { refused: Some(e.to_string()), ..Default::default() },
    };
    match std::env::var("VERBOSE").as_deref() {
        Ok("2") => eprintln!("{}", summary.lines().join("\n")),
        Ok(_) => eprintln!("{}", summary.calibration.map(|c| c.line()).unwrap_or_default()),
        _ => {}
    }
    let t0 = results.nav.first().map_or(0.0, |x| x[0]);
    let (rms, beyond) = score(d, &results, t0);
    let c = summary.calibration;
    Cal {
        refused: None,
        lever: c.and_then(|c| c.lever_arm).map(|(l, s, _)| (l - Vector3::from(LEVER), s)),
        offset: c.and_then(|c| c.time_offset).map(|(o, s, _, _)| (o - late, s)),
        mount: c.and_then(|c| c.mounting).map(|(m, s, _)| (m - mounting.map(f64::to_degrees), s)),
        alarm: summary.start.iter().any(|l| l.contains("time offset")),
        rms,
        beyond,
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let seeds: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    let lever = format!("[gnss]\nlever_arm = [{}, {}, {}]\n", LEVER[0], LEVER[1], LEVER[2]);
    let zero = "[gnss]\nlever_arm = [0.0, 0.0, 0.0]\n".to_string();
    let cal_lever = "[calibrate]\nlever_arm = true\n";
    let cal_time = "[calibrate]\ntime_offset = true\n";
    let cal_both = "[calibrate]\nlever_arm = true\ntime_offset = true\n";
    let nhc = "[vehicle.nhc]\n";
    let cal_mount = "[calibrate]\nmounting = true\n";
    let mount = Vector3::new(0.0, 1.0, 2.0).map(f64::to_radians);
    let none = Vector3::zeros();
    // (name, IMU lateness, mounting, configuration, the bar on the offset's error)
    let cells: Vec<(&str, f64, Vector3<f64>, String, f64)> = vec![
        ("lever known (by hand)", 0.0, none, lever.clone(), f64::NAN),
        ("lever declared 0, no state", 0.0, none, zero.clone(), f64::NAN),
        ("lever declared 0, state on", 0.0, none, format!("{zero}{cal_lever}"), f64::NAN),
        ("lever declared true, state on", 0.0, none, format!("{lever}{cal_lever}"), f64::NAN),
        ("late 0.3 s, offset state", 0.3, none, format!("{lever}{cal_time}"), 0.005),
        ("late 5 s, offset state", 5.0, none, format!("{lever}{cal_time}"), 0.010),
        ("on time, offset state", 0.0, none, format!("{lever}{cal_time}"), f64::NAN),
        ("lever 0 + late 0.3 s, both", 0.3, none, format!("{zero}{cal_both}"), 0.005),
        (
            "NHC, mounting 0/1/2° known",
            0.0,
            mount,
            format!("{lever}{nhc}mounting = [0.0, 1.0, 2.0]\n"),
            f64::NAN,
        ),
        ("NHC, mounting declared 0, no state", 0.0, mount, format!("{lever}{nhc}"), f64::NAN),
        (
            "NHC, mounting declared 0, state on",
            0.0,
            mount,
            format!("{lever}{nhc}{cal_mount}"),
            f64::NAN,
        ),
    ];
    println!(
        "| cell | refused | lever |err| x / y / z (median, cm) | x, y within 5 cm | within 3σ (all axes) | \
         reported σ x / y / z (median, cm) | offset |err| (median, ms) | within bar | \
         |offset| ≤ 3σ | mounting |err| roll / pitch / yaw (median, °) | pitch, yaw within 0.2° | \
         reported σ roll / pitch / yaw (median, °) | start named an offset | horizontal RMS (median, m) | beyond the 99 % ellipse (mean) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, late, mounting, extra, bar) in &cells {
        let outs: Vec<Cal> = (1..=seeds)
            .into_par_iter()
            .map(|seed| {
                let d = mounted_drive(seed, *late, *mounting);
                let g = gnss_rows(&d, Errors::White([0.02, 0.02, 0.05]), 1.0, seed);
                one(&d, g, extra, *late, *mounting)
            })
            .collect();
        let ok: Vec<&Cal> = outs.iter().filter(|c| c.refused.is_none()).collect();
        for c in outs.iter().filter(|c| c.refused.is_some()) {
            eprintln!("{name}: refused: {}", c.refused.as_deref().unwrap_or(""));
        }
        let n = ok.len();
        let axis =
            |k: usize| median(ok.iter().filter_map(|c| c.lever.map(|l| l.0[k].abs())).collect());
        let sig = |k: usize| median(ok.iter().filter_map(|c| c.lever.map(|l| l.1[k])).collect());
        let has_lever = ok.iter().any(|c| c.lever.is_some());
        let within = ok
            .iter()
            .filter(|c| c.lever.is_some_and(|l| l.0.x.abs() <= 0.05 && l.0.y.abs() <= 0.05))
            .count();
        let in_3s_lever = ok
            .iter()
            .filter(|c| c.lever.is_some_and(|l| (0..3).all(|k| l.0[k].abs() <= 3.0 * l.1[k])))
            .count();
        let has_offset = ok.iter().any(|c| c.offset.is_some());
        let off = median(ok.iter().filter_map(|c| c.offset.map(|o| o.0.abs())).collect());
        let in_bar = ok.iter().filter(|c| c.offset.is_some_and(|o| o.0.abs() <= *bar)).count();
        let in_3s = ok.iter().filter(|c| c.offset.is_some_and(|o| o.0.abs() <= 3.0 * o.1)).count();
        let alarms = ok.iter().filter(|c| c.alarm).count();
        let has_mount = ok.iter().any(|c| c.mount.is_some());
        let m_err =
            |k: usize| median(ok.iter().filter_map(|c| c.mount.map(|m| m.0[k].abs())).collect());
        let m_sig = |k: usize| median(ok.iter().filter_map(|c| c.mount.map(|m| m.1[k])).collect());
        let m_in = ok
            .iter()
            .filter(|c| c.mount.is_some_and(|m| m.0.y.abs() <= 0.2 && m.0.z.abs() <= 0.2))
            .count();
        let rms = median(ok.iter().map(|c| c.rms).collect());
        let beyond = ok.iter().map(|c| c.beyond).sum::<f64>() / n.max(1) as f64;
        let dash = || "—".to_string();
        println!(
            "| {name} | {} of {seeds} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {alarms}/{n} | {rms:.3} | {:.1} % |",
            seeds as usize - n,
            if has_lever {
                format!("{:.1} / {:.1} / {:.1}", 100.0 * axis(0), 100.0 * axis(1), 100.0 * axis(2))
            } else {
                dash()
            },
            if has_lever { format!("{within}/{n}") } else { dash() },
            if has_lever { format!("{in_3s_lever}/{n}") } else { dash() },
            if has_lever {
                format!("{:.1} / {:.1} / {:.1}", 100.0 * sig(0), 100.0 * sig(1), 100.0 * sig(2))
            } else {
                dash()
            },
            if has_offset { format!("{:.2}", 1e3 * off) } else { dash() },
            if has_offset && bar.is_finite() { format!("{in_bar}/{n}") } else { dash() },
            if has_offset { format!("{in_3s}/{n}") } else { dash() },
            if has_mount {
                format!("{:.2} / {:.2} / {:.2}", m_err(0), m_err(1), m_err(2))
            } else {
                dash()
            },
            if has_mount { format!("{m_in}/{n}") } else { dash() },
            if has_mount {
                format!("{:.2} / {:.2} / {:.2}", m_sig(0), m_sig(1), m_sig(2))
            } else {
                dash()
            },
            100.0 * beyond,
        );
    }
}
