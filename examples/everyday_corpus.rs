//! The everyday-GNSS corpus (the everyday-GNSS issue, item 4): the program's runs as a user
//! makes them — no `[init]` unless the configuration ships one, the default gate, the
//! noise learned — on fixes whose errors are white or wander like a single-point
//! receiver's, declared with their true σ, ten times too small or ten times too large.
//!
//! `cargo run --release --features campaigns --example everyday_corpus [SEEDS] [FILTER]` (`SEEDS`: `N` for 1 to N, or `A-B`) prints one row per cell:
//! the horizontal RMS against the truth (drive-0708: the outages' score against its RTK
//! reference), the same run given the true noise model (the oracle: the errors' true
//! split as states, `gnss.errors.learn = false`, the gate's learning off), their ratio,
//! the share of epochs whose horizontal error lies beyond the run's own 99 % ellipse
//! (σ N and E of `std.txt`, χ²₂ 9.21), the runs refused before they started, flagged
//! (exit 3) and run with the fixes' persisting error as states, and the causes the
//! flagged runs named (`VERBOSE=1`: each seed's on stderr). `FILTER` keeps the cells whose name contains it (ends with
//! it, when it ends in `$`). `EXTRA`: configuration lines merged into the user's runs (a prior
//! to compare); `DUMP=DIR`: each seed's GNSS file written there (for KF-GINS);
//! `CORRUPT=gyro-deg`: the user's runs read angle increments in degrees as if in rad (a
//! mislabelled unit the start must refuse: the refusal's rate over the corpus).
//!
//! The data: the simulator's 600 s drive (a MEMS IMU, standing 20 s first, fixes at 1
//! Hz), drive-0708's real IMU with its RTK fixes moved (both shipped configurations: the
//! KF-GINS YAML with its `[init]`, and `aided-noinit.toml` without), navego's IMU with its
//! truth's positions moved. The errors, per NED axis: white (σ 1, 1, 2 m), or a first-order
//! Gauss–Markov wander over white noise — small (0.5, 0.5, 1 m, τ 30 s, 0.1 m white),
//! medium (1.5, 1.5, 3 m, τ 100 s, 0.3 m; the issue's), large (3, 3, 6 m, τ 300 s,
//! 0.5 m). Each seed draws its own errors (and, simulated, its own IMU).

#[path = "../tests/everyday/mod.rs"]
mod everyday;

use everyday::*;
use rayon::prelude::*;

fn main() {
    // (`N`: seeds 1 to N; `A-B`: seeds A to B)
    let arg = std::env::args().nth(1).unwrap_or_else(|| "20".into());
    let (first, seeds): (u64, u64) = match arg.split_once('-') {
        Some((a, b)) => (a.parse().unwrap_or(1), b.parse().unwrap_or(20)),
        None => (1, arg.parse().unwrap_or(20)),
    };
    let only = std::env::args().nth(2).unwrap_or_default();
    // (EXTRA: configuration lines for the user's runs, e.g. a prior to compare)
    let extra = std::env::var("EXTRA").unwrap_or_default();
    // (CORRUPT: the one corruption known, or none; any other value is refused, not ignored)
    let corrupt = match std::env::var("CORRUPT").as_deref() {
        Ok("gyro-deg") => true,
        Err(std::env::VarError::NotPresent) => false,
        Ok(other) => {
            eprintln!("CORRUPT = {other:?}: the corruptions known are \"gyro-deg\"");
            std::process::exit(2);
        }
        Err(e) => {
            eprintln!("CORRUPT: {e}");
            std::process::exit(2);
        }
    };
    let errors = [
        Errors::White([1.0, 1.0, 2.0]),
        Errors::Wander([0.5, 0.5, 1.0], 30.0, 0.1),
        Errors::Wander([1.5, 1.5, 3.0], 100.0, 0.3),
        Errors::Wander([3.0, 3.0, 6.0], 300.0, 0.5),
    ];
    let real: Vec<Data> =
        vec![drive_0708("kf-gins-outage15.yaml"), drive_0708("aided-noinit.toml"), navego()];
    println!(
        "| data | errors | declared | score (m) | true model (m) | ratio | beyond 99 % | true model beyond | refused | flagged | persisting chosen (median lag) | causes named |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for set in ["sim drive", "drive-0708 yaml", "drive-0708 noinit", "navego noinit"] {
        for e in errors {
            for declared in [0.1, 1.0, 10.0] {
                let name = format!("{set} | {} | ×{declared}", e.name());
                // (a filter ending in `$` matches the name's end)
                let wanted = match only.strip_suffix('$') {
                    Some(end) => name.ends_with(end),
                    None => name.contains(&only),
                };
                if !wanted {
                    continue;
                }
                let outs: Vec<(Outcome, Outcome)> = (first..=seeds)
                    .into_par_iter()
                    .map(|seed| {
                        let sim;
                        let d = match set {
                            "sim drive" => {
                                sim = sim_drive(seed);
                                &sim
                            }
                            s => real.iter().find(|d| d.name == s).unwrap(),
                        };
                        let g = gnss_rows(d, e, declared, seed);
                        if let Ok(dir) = std::env::var("DUMP") {
                            dump(&dir, d, &g, seed);
                        }
                        let corrupted;
                        let user = if corrupt {
                            let mut imu = d.imu.to_vec();
                            for r in imu.chunks_mut(7) {
                                r[1..4].iter_mut().for_each(|v| *v = v.to_degrees());
                            }
                            corrupted = Data { imu: imu.into(), ..d.clone() };
                            &corrupted
                        } else {
                            d
                        };
                        let o = run(user, g.clone(), &extra);
                        // (a corrupted corpus counts refusals: no oracle run)
                        let truth_run = match &o.refused {
                            Some(_) if corrupt => o.clone(),
                            _ => run(d, gnss_rows(d, e, 1.0, seed), &e.oracle()),
                        };
                        // (VERBOSE: each seed's score, the oracle's, and whether it restarted)
                        if std::env::var_os("VERBOSE").is_some() {
                            eprintln!(
                                "{name} seed {seed}: {:.3} m (oracle {:.3} m), persisting {}, lag {:.2}",
                                o.score, truth_run.score, o.persisting, o.lag
                            );
                        }
                        (o, truth_run)
                    })
                    .collect();
                report(&name, &outs);
            }
        }
    }
}
