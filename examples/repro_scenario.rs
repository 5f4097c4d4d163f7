//! Monte Carlo comparison of strategies on any `ins-gnss simulate` scenario file: every
//! seed draws new IMU and GNSS errors, every strategy filters the same data, and each row
//! of the table is the mean ± std over seeds of the per-run RMS and maximum errors (after
//! the skip). Per-seed results go to a CSV; the errors of the first seed are plotted
//! (absolute heading and horizontal error against time, one line per strategy).
//!
//! Run: `cargo run --release --features campaigns --example repro_scenario -- SCENARIO [--seeds N]
//! [--strategies a,b,c] [--skip S] [--out DIR]`. Defaults: 50 seeds,
//! `fixed,iae,afkf,fused`, skip 30 s, `repro-out/<scenario name>/`. The fused IAE + AFKF
//! paper's table: `… -- ins-gnss/scenarios/fused-iae-afkf.toml`.

use std::io::Write;
use std::path::{Path, PathBuf};

use ins_gnss::plot;
use ins_gnss::scenario::{MonteCarlo, Scenario, SeedRun};
use rayon::prelude::*;

/// Per-run figures reported, with their column names.
pub const COLUMNS: [&str; 10] = [
    "roll_rms",
    "pitch_rms",
    "heading_rms",
    "roll_max",
    "pitch_max",
    "heading_max",
    "horizontal_rms",
    "horizontal_max",
    "velocity_rms",
    "inflated_or_rejected",
];

/// The figures of one run (degrees, metres, m/s, count).
pub fn figures(r: &SeedRun) -> [f64; 10] {
    let o = &r.eval.overall;
    [
        o.roll.rms,
        o.pitch.rms,
        o.yaw.rms,
        o.roll.max,
        o.pitch.max,
        o.yaw.max,
        o.horizontal.rms,
        o.horizontal.max,
        o.velocity_3d.rms,
        (r.summary.inflated + r.summary.rejected) as f64,
    ]
}

/// Mean and sample standard deviation.
pub fn mean_std(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = v.clone().count() as f64;
    let m = v.clone().sum::<f64>() / n;
    let var = v.map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, var.sqrt())
}

/// Run every `(seed, strategy)` pair in parallel; results in the order of the pairs.
pub fn run_all(
    mc: &MonteCarlo,
    seeds: std::ops::Range<u64>,
    strategies: &[String],
    skip: f64,
) -> Result<Vec<(u64, String, [f64; 10])>, String> {
    let jobs: Vec<(u64, &String)> =
        seeds.flat_map(|s| strategies.iter().map(move |n| (s, n))).collect();
    jobs.par_iter()
        .map(|&(seed, name)| {
            let strategy = name.parse().map_err(|e| format!("{e}"))?;
            let r = mc.run(seed, strategy, skip, &[], |_, _, _| {})?;
            Ok((seed, name.clone(), figures(&r)))
        })
        .collect()
}

fn plot_first_seed(
    mc: &MonteCarlo,
    strategies: &[String],
    skip: f64,
    path: &Path,
) -> Result<(), String> {
    let mut heading = Vec::new();
    let mut horizontal = Vec::new();
    for name in strategies {
        let (mut h, mut p) = (Vec::new(), Vec::new());
        mc.run(0, name.parse().map_err(|e| format!("{e}"))?, skip, &[], |t, r, truth| {
            let (dp, _, da) = ins_gnss::eval::errors(r, truth);
            h.push((t, da.z.abs()));
            p.push((t, (dp.x * dp.x + dp.y * dp.y).sqrt()));
        })?;
        heading.push(h);
        horizontal.push(p);
    }
    let labels: Vec<&str> = strategies.iter().map(String::as_str).collect();
    plot::comparison(
        path,
        &[("absolute heading error (seed 0)", "deg"), ("horizontal position error (seed 0)", "m")],
        &labels,
        &[heading, horizontal],
    )
}

#[allow(dead_code)] // tests include this file as a module
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut scenario = None;
    let (mut seeds, mut skip, mut out) = (50u64, 30.0, None);
    let mut strategies: Vec<String> =
        ["fixed", "iae", "afkf", "fused"].iter().map(|s| s.to_string()).collect();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--seeds" => seeds = value()?.parse()?,
            "--skip" => skip = value()?.parse()?,
            "--out" => out = Some(PathBuf::from(value()?)),
            "--strategies" => strategies = value()?.split(',').map(str::to_string).collect(),
            _ if scenario.is_none() => scenario = Some(PathBuf::from(a)),
            _ => return Err(format!("unexpected argument {a}").into()),
        }
    }
    let scenario =
        scenario.unwrap_or_else(|| PathBuf::from("ins-gnss/scenarios/fused-iae-afkf.toml"));
    let name = scenario.file_stem().and_then(|s| s.to_str()).unwrap_or("scenario").to_string();
    let out = out.unwrap_or_else(|| PathBuf::from("repro-out").join(&name));
    std::fs::create_dir_all(&out)?;
    let mc = MonteCarlo::new(Scenario::load(&scenario)?)?;
    let t = std::time::Instant::now();
    let results = run_all(&mc, 0..seeds, &strategies, skip)?;

    let csv = out.join("seeds.csv");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&csv)?);
    writeln!(f, "seed,strategy,{}", COLUMNS.join(","))?;
    for (s, n, r) in &results {
        let cells: Vec<String> = r.iter().map(|v| format!("{v:.5}")).collect();
        writeln!(f, "{s},{n},{}", cells.join(","))?;
    }
    f.flush()?;
    println!(
        "{}: {seeds} seeds × {} strategies in {:.1} s; per-seed results in {}\n",
        scenario.display(),
        strategies.len(),
        t.elapsed().as_secs_f64(),
        csv.display()
    );
    println!(
        "| strategy | roll RMS ° | pitch RMS ° | heading RMS ° | roll max ° | pitch max ° | heading max ° | horizontal RMS m | horizontal max m | velocity RMS m/s | inflated + rejected |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for name in &strategies {
        let rows: Vec<&[f64; 10]> = results.iter().filter(|r| &r.1 == name).map(|r| &r.2).collect();
        let cells: Vec<String> = (0..COLUMNS.len())
            .map(|i| {
                let (m, s) = mean_std(rows.iter().map(|r| r[i]));
                if i == 9 {
                    format!("{m:.1} ± {s:.1}")
                } else {
                    format!("{m:.3} ± {s:.3}")
                }
            })
            .collect();
        println!("| {name} | {} |", cells.join(" | "));
    }
    let svg = out.join("errors_seed0.svg");
    plot_first_seed(&mc, &strategies, skip, &svg)?;
    println!("\nplot: {}", svg.display());
    Ok(())
}
