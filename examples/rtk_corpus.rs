//! GNSS-only RTK over simulated drives, seed by seed, beside RTKLIB on the same files: a
//! rover on the 630 s drive of `ins_gnss_sim::scenarios::drive_600s` (1 Hz, the shipped
//! navigation file's GPS satellites on 2005-04-02 03:00), a base station 5 km from its
//! start (the baseline 1.6–4.9 km over the drive), both receivers under one sky
//! (`ins_gnss_sim::raw::simulate_rtk`: the orbit, clock and atmosphere errors of the
//! single point's budget shared, a 1 ppm ionospheric gradient, each its own clock, code
//! biases, noise and ambiguities).
//!
//! Cells: one frequency (L1) or two (L1 + L2); the sky open, closed for 30 s (300–330 s,
//! a tunnel), or open with cycle slips the receiver does not flag (0.2 % per satellite,
//! frequency and epoch, about 20 a run). Per run: the fix rate (fixed over solved epochs), wrong fixes (fixed epochs
//! more than 10 cm from the truth in 3D), the horizontal and vertical RMS of the fixed
//! epochs, the time to the first fix and, after the tunnel, to the fix again. RTKLIB
//! (`rnx2rtkp -p 2 -f F -r BASE`, every other option its default, as
//! `data/rinex-rtklib/rtklib/make.sh` runs it on the real baseline) on the same RINEX files.
//!
//! `cargo run --release --features campaigns --example rtk_corpus [SEEDS] [--no-rtklib] [--keep DIR]` (the drive and
//! the figures: `tests/rtk_drive.rs`)

use std::path::{Path, PathBuf};
use std::process::Command;

use gnss::rtk::{RtkMode, RtkOptions};
use ins_gnss::rtk::solve_files;
use ins_gnss_core::earth::geodetic_to_ecef;
use nalgebra::{Matrix3, Vector3};

#[path = "../tests/rtk_drive.rs"]
#[allow(dead_code)]
mod rtk_drive;
use rtk_drive::{figures, solutions, Drive, Figures, Sky, Solution};

/// RTKLIB's kinematic RTK of the files (`None`: rnx2rtkp failed or is missing).
fn rtklib(dir: &Path, nav: &Path, base: &Vector3<f64>, freqs: usize) -> Option<Vec<Solution>> {
    let out = dir.join("rtklib.pos");
    let status = Command::new("rnx2rtkp")
        .args(["-p", "2", "-f", &freqs.to_string(), "-r"])
        .args([base.x, base.y, base.z].map(|v| format!("{v:.4}")))
        .arg("-o")
        .arg(&out)
        .arg(dir.join("rover.obs"))
        .arg(dir.join("base.obs"))
        .arg(nav)
        .stderr(std::process::Stdio::null())
        .status()
        .ok()?;
    if !status.success() {
        return None;
    }
    let text = std::fs::read_to_string(&out).ok()?;
    Some(
        text.lines()
            .filter(|l| !l.starts_with('%'))
            .filter_map(|l| {
                let v: Vec<f64> = l.split_whitespace().filter_map(|x| x.parse().ok()).collect();
                (v.len() >= 6).then(|| {
                    let p = geodetic_to_ecef(v[2].to_radians(), v[3].to_radians(), v[4]);
                    // sdn sde sdu sdne sdeu sdun (RTKLIB's signed square roots)
                    let sq = |x: f64| x * x.abs();
                    let (n, e, u) = (sq(v[7]), sq(v[8]), sq(v[9]));
                    let (ne, eu, un) = if v.len() >= 13 {
                        (sq(v[10]), sq(v[11]), sq(v[12]))
                    } else {
                        (0.0, 0.0, 0.0)
                    };
                    // (north, east, up → north, east, down)
                    let neu = Matrix3::new(n, ne, un, ne, e, eu, un, eu, u);
                    let flip = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
                    let cov = flip * neu * flip;
                    (v[1], p, v[5] == 1.0, cov)
                })
            })
            .collect(),
    )
}

#[derive(Default)]
struct Cell {
    runs: Vec<Figures>,
}

impl Cell {
    fn row(&self, name: &str) -> String {
        if self.runs.is_empty() {
            return format!("| {name} | – | | | | | | | |");
        }
        let rates: Vec<f64> =
            self.runs.iter().map(|r| r.fixed as f64 / r.solved.max(1) as f64).collect();
        let mean = rates.iter().sum::<f64>() / rates.len() as f64;
        let min = rates.iter().copied().fold(f64::INFINITY, f64::min);
        let wrong: usize = self.runs.iter().map(|r| r.wrong).sum();
        let fixed: usize = self.runs.iter().map(|r| r.fixed).sum();
        let h = (self.runs.iter().map(|r| r.h2).sum::<f64>() / fixed.max(1) as f64).sqrt();
        let v = (self.runs.iter().map(|r| r.v2).sum::<f64>() / fixed.max(1) as f64).sqrt();
        let worst = self.runs.iter().map(|r| r.worst).fold(0.0, f64::max);
        let median = |mut x: Vec<f64>| {
            x.sort_by(f64::total_cmp);
            match x.len() {
                0 => "–".to_string(),
                n => format!("{:.0} / {:.0}", x[n / 2], x[n - 1]),
            }
        };
        let never = self.runs.iter().filter(|r| r.ttff.is_none()).count();
        let ttff = median(self.runs.iter().filter_map(|r| r.ttff).collect());
        let refix = median(self.runs.iter().filter_map(|r| r.refix).collect());
        let nees = self.runs.iter().map(|r| r.nees).sum::<f64>() / fixed.max(1) as f64 / 3.0;
        let beyond = self.runs.iter().map(|r| r.beyond).sum::<usize>() as f64 / fixed.max(1) as f64;
        format!(
            "| {name} | {:.1} % (min {:.1} %) | {wrong} of {fixed} | {:.1} / {:.1} | {:.1} | {nees:.2}; {:.1} % | {ttff}{} | {refix} |",
            100.0 * mean,
            100.0 * min,
            100.0 * h,
            100.0 * v,
            100.0 * worst,
            100.0 * beyond,
            if never > 0 { format!(" ({never} never)") } else { String::new() },
        )
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seeds: u64 = args.iter().find_map(|a| a.parse().ok()).unwrap_or(20);
    let with_rtklib = !args.iter().any(|a| a == "--no-rtklib");
    let keep = args.iter().position(|a| a == "--keep").map(|i| PathBuf::from(&args[i + 1]));
    let drive = Drive::new(Path::new(env!("CARGO_MANIFEST_DIR")))?;
    let base = drive.base;
    let dir = keep
        .clone()
        .unwrap_or_else(|| std::env::temp_dir().join(format!("rtk-corpus-{}", std::process::id())));
    std::fs::create_dir_all(&dir)?;
    // RTKLIB reads plain RINEX
    let nav_plain = dir.join("nav.05n");
    {
        let mut r = ins_gnss_io::formats::open(&drive.nav_path)?;
        let mut w = std::fs::File::create(&nav_plain)?;
        std::io::copy(&mut r, &mut w)?;
    }
    let cells = [
        (1usize, Sky::Open),
        (2, Sky::Open),
        (1, Sky::Tunnel),
        (2, Sky::Tunnel),
        (1, Sky::Slips),
        (2, Sky::Slips),
    ];
    let mut ours_cells: Vec<Cell> = cells.iter().map(|_| Cell::default()).collect();
    let mut theirs_cells: Vec<Cell> = cells.iter().map(|_| Cell::default()).collect();
    let mut baseline = (f64::INFINITY, 0.0f64);
    for seed in 0..seeds {
        for (k, &(freqs, sky)) in cells.iter().enumerate() {
            let truth = drive.write(&dir, seed, sky)?;
            for tr in &truth {
                let b = (tr.antenna - base).norm();
                baseline = (baseline.0.min(b), baseline.1.max(b));
            }
            let mut opt = RtkOptions::for_frequencies(RtkMode::Kinematic, freqs);
            // (RTK_CODE_BIAS=σ[,τ]: the code biases as states, to compare)
            rtk_drive::code_biases_from_env(&mut opt);
            // (RTK_HOLD=N: fix-and-hold after N consecutive fixes, 0 never; RTK_PS=P: the
            // least success rate of a fix beside the ratio test — to compare)
            if let Ok(v) = std::env::var("RTK_HOLD") {
                opt.hold = v.parse().ok().filter(|&n| n > 0);
            }
            if let Ok(v) = std::env::var("RTK_PS") {
                opt.min_success_rate = v.parse().unwrap_or(0.0);
            }
            // (RTK_MASK=DEG: the elevation mask, to compare)
            if let Ok(v) = std::env::var("RTK_MASK") {
                opt.elevation_mask = v.parse::<f64>().unwrap_or(15.0).to_radians();
            }
            let run = solve_files(
                &dir.join("rover.obs"),
                &dir.join("base.obs"),
                std::slice::from_ref(&drive.nav_path),
                Some(base),
                &opt,
            )?;
            let f = figures(&solutions(&run), &truth, drive.start, sky);
            ours_cells[k].runs.push(f.clone());
            let mut line = format!(
                "seed {seed} L{freqs}{} ours: {}/{} fixed, {} wrong, worst {:.3} m",
                sky.label(),
                f.fixed,
                f.solved,
                f.wrong,
                f.worst
            );
            if with_rtklib && let Some(sol) = rtklib(&dir, &nav_plain, &base, freqs) {
                let g = figures(&sol, &truth, drive.start, sky);
                line += &format!(
                    "; RTKLIB {}/{} fixed, {} wrong, worst {:.3} m",
                    g.fixed, g.solved, g.wrong, g.worst
                );
                theirs_cells[k].runs.push(g);
            }
            // the fixed epochs' mean error (NED, m): a bias the model leaves
            let m = |f: &Figures| f.sum / f.fixed.max(1) as f64;
            line += &format!("; mean NED ours {:.3?}", m(&f).as_slice());
            if let (true, Some(g)) = (with_rtklib, theirs_cells[k].runs.last()) {
                line += &format!(" RTKLIB {:.3?}", m(g).as_slice());
            }
            eprintln!("{line}");
        }
    }
    println!(
        "{seeds} seeds; baseline {:.1}–{:.1} km; wrong: a fixed epoch > 10 cm from the truth (3D)\n",
        baseline.0 / 1e3,
        baseline.1 / 1e3
    );
    println!(
        "| cell | fix rate, mean (worst seed) | wrong fixes | fixed RMS H / V, cm | worst fixed error, cm | fixed: NEES/3; beyond χ²₃ 99 % | first fix, s: median / worst | fixed again after the tunnel, s: median / worst |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (k, &(freqs, sky)) in cells.iter().enumerate() {
        let name = format!("L{}{}", if freqs == 1 { "1" } else { "1+L2" }, sky.label());
        println!("{}", ours_cells[k].row(&format!("ours, {name}")));
        if with_rtklib {
            println!("{}", theirs_cells[k].row(&format!("RTKLIB, {name}")));
        }
    }
    if keep.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok(())
}
