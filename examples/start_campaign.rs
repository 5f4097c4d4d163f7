//! The start campaign (the decisions issue): simulated cars standing 0 s to 20 min before
//! they drive, headed anywhere, with navego's two IMUs, drive-0708's and a noisy consumer
//! MEMS, on RTK or single-point fixes (declared with their true σ); a car driving
//! backwards; a person standing 10 s and then walking tight turns in a yard; a slow rover
//! with 5 m fixes — run as a user runs them: no `[init]`, the datasheet's noise, the
//! default gate.
//!
//! `cargo run --release --features campaigns --example start_campaign [SEEDS] [FILTER]` (`SEEDS`: `N` for 1 to
//! N, or `A-B`; `FILTER` keeps the cells whose name contains it) prints one row per cell:
//! runs, refused, flagged (exit 3), runs whose heading lies within 3σ at every `std.txt`
//! epoch and from 30 s on, runs whose first velocity lies within 3σ, the median and largest
//! of each run's worst heading error over its σ, the median worst heading error, the
//! median horizontal RMS, and (walks, rovers, the backwards car) the RMS over that of the
//! same run given the true initial state; the first refusal's message. `EXTRA`:
//! configuration lines for every run; `VERBOSE=1`: each run on stderr; `ORACLE=1`: every
//! cell run given the true initial state as well (its RMS ratio in the row; with
//! `VERBOSE`, its heading's coverage on stderr).

#[path = "../tests/everyday/mod.rs"]
mod everyday;

use everyday::start::*;
use rayon::prelude::*;

/// A cell: its name, the data set of a seed, the fixes, and whether to run it given the
/// true initial state as well.
type Cell = (String, Box<dyn Fn(u64) -> (everyday::Data, Motion) + Sync>, Fixes, bool);

fn main() {
    let arg = std::env::args().nth(1).unwrap_or_else(|| "50".into());
    let (first, last): (u64, u64) = match arg.split_once('-') {
        Some((a, b)) => (a.parse().unwrap_or(1), b.parse().unwrap_or(50)),
        None => (1, arg.parse().unwrap_or(50)),
    };
    let only = std::env::args().nth(2).unwrap_or_default();
    let extra = std::env::var("EXTRA").unwrap_or_default();
    println!(
        "| cell | runs | refused | flagged | heading ≤ 3σ throughout | … from 30 s | start velocity ≤ 3σ | worst heading error / σ (median / largest) | median worst heading error | median RMS (m) | RMS ÷ true start (median / largest; ≤ 1.2) | first refusal |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut cells: Vec<Cell> = Vec::new();
    for fixes in [Fixes::Rtk, Fixes::SinglePoint] {
        for grade in GRADES {
            for standing in [0.0, 10.0, 60.0, 300.0, 1200.0] {
                let name = format!("car, {} | {:?} | standing {standing} s", grade.name, fixes);
                cells.push((
                    name,
                    Box::new(move |s| standing_car(s, standing, &grade)),
                    fixes,
                    false,
                ));
            }
        }
    }
    for fixes in [Fixes::Rtk, Fixes::SinglePoint] {
        let grade = GRADES[2];
        let name = format!("car backwards, {} | {:?} | standing 10 s", grade.name, fixes);
        cells.push((name, Box::new(move |s| reversing_car(s, 10.0, &grade)), fixes, true));
    }
    for standing in [10.0, 0.0] {
        for fixes in [Fixes::Rtk1cm, Fixes::SinglePoint] {
            let name = format!("yard walk, walker | {fixes:?} | standing {standing} s");
            cells.push((name, Box::new(move |s| yard_walk(s, standing)), fixes, true));
        }
    }
    cells.push((
        "slow rover, rover | White5m | moving".into(),
        Box::new(slow_rover),
        Fixes::White5m,
        true,
    ));
    for (name, make, fixes, oracle) in &cells {
        if !name.contains(&only) {
            continue;
        }
        let outs: Vec<(StartOutcome, Option<StartOutcome>)> = (first..=last)
            .into_par_iter()
            .map(|seed| {
                let (d, motion) = make(seed);
                let o = judge_start(&d, &motion, *fixes, seed, &extra);
                let t = (*oracle || std::env::var_os("ORACLE").is_some()).then(|| {
                    let init = format!("{}{extra}", true_init(&d, &motion));
                    judge_start(&d, &motion, *fixes, seed, &init)
                });
                if std::env::var("VERBOSE").is_ok() {
                    eprintln!(
                        "{name} seed {seed}: {o:?} true start: {:?}",
                        t.as_ref().map(|t| (t.rms, t.heading_covered, t.worst_ratio, t.worst_t))
                    );
                }
                (o, t)
            })
            .collect();
        println!("{}", start_row(name, &outs));
    }
}
