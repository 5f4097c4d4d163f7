//! A probe of the decisions issue's heading bank on the slow rover (0.42 m/s, white 5 m
//! fixes, no static start): for each seed, 16 whole filters started at headings 22.5°
//! apart (σ `HALF` each, default 11.25°; roll, pitch, velocity and position from the
//! truth, the position and velocity with the σ a start from the fixes would have), run
//! over the first `END` seconds (default: the whole 480 s), weighted by their fixes'
//! log-likelihood after the first 100 fixes; then one run started at the likeliest heading
//! with σ the mixture's spread, judged as the start campaign judges (heading within 3σ at
//! every `std.txt` epoch, horizontal RMS) beside the run given the true initial state.
//!
//! `cargo run --release --features campaigns --example heading_bank_probe [SEEDS] [END] [HALF]`
//!
//! What it measured (2026-12-06, 8 seeds): over the first 120 s (the start's span) the
//! likeliest weighs 0.08–0.24 and the spread is 54–107° (a constant-speed rover's heading
//! shows only through its turns); over the whole run 0.50–0.74 and 16–27°, the likeliest
//! within 3–40° of the truth. `docs/history/results.md`, "Decisions by likelihood, step 2".

#[path = "../tests/everyday/mod.rs"]
mod everyday;
use everyday::start::*;
use everyday::{config_of, gnss_rows};
use ins_gnss::run::{run_in_memory, Inputs};
use rayon::prelude::*;

fn main() {
    // (the seeds, the span the bank looks at, each hypothesis's heading σ in degrees)
    let seeds: u64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    let end: f64 = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(1e9);
    let half: f64 = std::env::args().nth(3).and_then(|s| s.parse().ok()).unwrap_or(11.25);
    for seed in 1..=seeds {
        let (d, motion) = slow_rover(seed);
        let t = d.imu[0];
        let m = &motion[motion.partition_point(|m| m.0 < t - 1e-6).min(motion.len() - 1)];
        let p = d.truth[0];
        let truth = m.2.to_degrees();
        let init = |psi: f64, s: f64, end: f64| {
            format!(
                "[data]\nend_time = {end}\n[init]\nattitude = [{}, {}, {psi}]\nvelocity = [{}, {}, {}]\nposition = [{}, {}, {}]\n\
                 attitude_std = [1.0, 1.0, {s}]\nvelocity_std = [0.3, 0.3, 0.3]\nposition_std = [5.0, 5.0, 5.0]\n",
                m.4[0].to_degrees(),
                m.4[1].to_degrees(),
                m.1[0],
                m.1[1],
                m.1[2],
                p[1].to_degrees(),
                p[2].to_degrees(),
                p[3]
            )
        };
        let lls: Vec<f64> = (0..16)
            .into_par_iter()
            .map(|k| {
                let psi = -180.0 + 22.5 * k as f64;
                let cfg = config_of(&d, &init(psi, half, end));
                let gnss = gnss_rows(&d, Fixes::White5m.errors(), 1.0, seed);
                let inputs =
                    Inputs::Arrays { imu: d.imu.clone(), imu_width: 7, gnss, gnss_width: 7 };
                match run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs) {
                    Ok((s, _)) => {
                        s.streams.iter().filter(|s| s.gnss).map(|s| s.log_likelihood_settled).sum()
                    }
                    Err(e) => {
                        eprintln!("{e}");
                        f64::NAN
                    }
                }
            })
            .collect();
        let best = lls.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let kb = lls.iter().position(|&l| l == best).unwrap();
        let psib = -180.0 + 22.5 * kb as f64;
        let w: Vec<f64> = lls.iter().map(|l| (l - best).exp()).collect();
        let sw: f64 = w.iter().sum();
        let var: f64 = w
            .iter()
            .enumerate()
            .map(|(k, wk)| {
                let d = (((-180.0 + 22.5 * k as f64) - psib + 540.0) % 360.0) - 180.0;
                wk / sw * d * d
            })
            .sum();
        let sig = (var + half * half).sqrt();
        let o = judge_start(&d, &motion, Fixes::White5m, seed, &init(psib, sig, 1e9));
        let tr = judge_start(&d, &motion, Fixes::White5m, seed, &true_init(&d, &motion));
        println!(
            "seed {seed} truth {truth:.1} best {psib} σ {sig:.1} w_best {:.2}: covered {} after30 {} worst {:.2} rms {:.2} true-start rms {:.2} refused {:?}",
            w[kb] / sw,
            o.heading_covered,
            o.heading_covered_after,
            o.worst_ratio,
            o.rms,
            tr.rms,
            o.refused.map(|s| s.chars().take(80).collect::<String>())
        );
    }
}
