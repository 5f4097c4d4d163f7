//! Reproduction of the χ²-gated IAKF paper's simulation (paper `iakf-chi-square`, §4):
//! a car with accelerations and turns; gyro bias 5°/h, ARW 0.5°/√h, accelerometer bias
//! 400 µg; GNSS position at 1 Hz with 3 m noise and interference at 400–450 s (noise × 8,
//! up to ≈ 24 m) that the receiver does not report. Filters: `fixed` (KF), `sage-husa`
//! (the paper's AKF), `iakf` (the `1/k` reading, EpochScaled, our default) and `iakf-raw` (Raw), and the
//! paper's IAKF without our convergence guard (`iakf-unguarded`).
//!
//! Each row is the mean ± std over the seeds of the per-run mean and maximum |east|,
//! |north| and horizontal error (truth at 1 Hz, from 30 s on); per-seed results go to a
//! CSV. Seeds run in parallel (rayon).
//!
//! Run: `cargo run --release --features campaigns --example repro_iakf [SEEDS] [CSV] [paper-noise]` (defaults
//! 50, `repro-out/iakf_seeds.csv`, the original scenario; `paper-noise` runs
//! `iakf-chi-square-paper-noise.toml`, whose GNSS error is like the paper's Table 2).

use std::io::Write;

use estimator::adaptive::AnyStrategy;
use estimator::estimator_core::NoObserver;
use estimator::ins_gnss::imu::{BiasModel, DEG_PER_H};
use estimator::ins_gnss::{GnssConfig, InitialState, InitialStd, InsModel, InsState, Navigator};
use estimator::manifolds::{Manifold, Tangent};
use ins_gnss::scenario::Scenario;
use ins_gnss_sim::{simulate_from, ExactImu, GnssSim, ImuErrors, Trajectory};
use nalgebra::Vector3;
use rayon::prelude::*;

/// The filters; `iakf-unguarded` is the paper's IAKF without our re-admission guard
/// (`max_consecutive` = ∞), to show what the guard costs under sustained interference.
pub const STRATEGIES: [&str; 5] = ["fixed", "sage-husa", "iakf", "iakf-raw", "iakf-unguarded"];

pub fn strategy(name: &str) -> AnyStrategy {
    match name {
        "iakf-unguarded" => {
            let mut s = estimator::adaptive::Iakf::default();
            s.max_consecutive = u32::MAX;
            AnyStrategy::Iakf(s)
        }
        other => other.parse().expect("known strategy"),
    }
}
/// The paper's scenario, shared with `ins-gnss simulate`: the car drive, the IMU errors
/// and the GNSS receiver (`ins-gnss/scenarios/iakf-chi-square.toml`).
pub fn scenario() -> Scenario {
    Scenario::parse(
        include_str!("../ins-gnss/scenarios/iakf-chi-square.toml"),
        "iakf-chi-square.toml",
    )
    .expect("the bundled scenario parses")
}

/// The same drive with GNSS noise like the paper's Table 2 (mean horizontal error ≈ 2.9 m,
/// maximum ≈ 24 m): `ins-gnss/scenarios/iakf-chi-square-paper-noise.toml`.
pub fn paper_noise_scenario() -> Scenario {
    Scenario::parse(
        include_str!("../ins-gnss/scenarios/iakf-chi-square-paper-noise.toml"),
        "iakf-chi-square-paper-noise.toml",
    )
    .expect("the bundled scenario parses")
}

/// Mean and maximum horizontal error of the GNSS fixes themselves over a run, m.
pub fn gnss_errors(traj: &Trajectory, gnss: &GnssSim, seed: u64) -> (f64, f64) {
    let data = simulate_from(
        &ExactImu { samples: Vec::new(), kinematics: vec![traj.at(traj.start_time())] },
        traj,
        &imu(),
        gnss,
        seed,
    );
    let e: Vec<f64> = data
        .gnss
        .iter()
        .map(|g| {
            let d = g.pos.ominus(&traj.at(g.t).pos);
            d.x.hypot(d.y)
        })
        .collect();
    (e.iter().sum::<f64>() / e.len() as f64, e.iter().fold(0.0_f64, |m, v| m.max(*v)))
}

pub fn imu() -> ImuErrors {
    scenario().imu_errors()
}

/// Per run: (mean |E|, mean |N|, mean horizontal, max |E|, max |N|, max horizontal), m.
pub fn run(
    exact: &ExactImu,
    traj: &Trajectory,
    gnss: &GnssSim,
    seed: u64,
    strategy: &str,
) -> [f64; 6] {
    let errors = imu();
    let data = simulate_from(exact, traj, &errors, gnss, seed);
    let deg = core::f64::consts::PI / 180.0;
    const G: f64 = 9.80665;
    let std = InitialStd {
        att: Vector3::new(0.5 * deg, 0.5 * deg, 2.0 * deg),
        vel: Vector3::repeat(0.1),
        pos: Vector3::repeat(3.0),
        bg: Vector3::repeat(5.5 * DEG_PER_H),
        ba: Vector3::repeat(450e-6 * G),
    };
    // The filter starts with a small, seeded error inside its P0.
    let mut d = Tangent::<InsState>::zeros();
    let s = |k: u64| ((seed * 7 + k * 13) % 11) as f64 / 10.0 - 0.5;
    for i in 0..3 {
        d[i] = std.att[i] * s(i as u64);
        d[6 + i] = std.pos[i] * s(3 + i as u64);
    }
    let truth0 = &data.truth[0].state;
    let x0 = InsState { bg: Vector3::zeros(), ba: Vector3::zeros(), ..truth0.oplus(&d) };
    let init = InitialState { time: data.truth[0].t, state: x0, std };
    let model = InsModel::wgs84(errors.noise.with_bias_model(BiasModel::RandomWalk));
    let strategy = self::strategy(strategy);
    let mut nav =
        Navigator::new(&init, model, strategy, GnssConfig::default()).expect("valid start");
    let (mut sum, mut max, mut n) = ([0.0; 3], [0.0_f64; 3], 0.0);
    let mut out = Vec::with_capacity(4);
    for (k, (sample, epochs)) in data.replay().enumerate() {
        out.clear();
        nav.process_into(sample, epochs, &mut NoObserver, &mut out).expect("filter step");
        if sample.t >= 30.0 && (sample.t - sample.t.round()).abs() < 1e-6 {
            let e = nav.state().pos.ominus(&data.truth[k + 1].state.pos);
            let v = [e.y.abs(), e.x.abs(), (e.x * e.x + e.y * e.y).sqrt()];
            for i in 0..3 {
                sum[i] += v[i];
                max[i] = max[i].max(v[i]);
            }
            n += 1.0;
        }
    }
    [sum[0] / n, sum[1] / n, sum[2] / n, max[0], max[1], max[2]]
}

/// The paper's receiver: position at 1 Hz, σ 3 m (5 m down), noise × 8 at 400–450 s.
pub fn gnss() -> GnssSim {
    scenario().gnss_sim().expect("valid receiver")
}

#[allow(dead_code)] // the test that includes this file as a module does not call it
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let seeds: u64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(50);
    let csv =
        std::path::PathBuf::from(args.next().unwrap_or_else(|| "repro-out/iakf_seeds.csv".into()));
    let paper_noise = args.next().as_deref() == Some("paper-noise");
    let sc = if paper_noise { paper_noise_scenario() } else { scenario() };
    let traj = sc.trajectory()?;
    let exact = ExactImu::new(&traj, 100.0);
    let gnss = sc.gnss_sim()?;
    let ge: Vec<(f64, f64)> = (0..seeds).map(|s| gnss_errors(&traj, &gnss, s)).collect();
    println!(
        "GNSS fixes' own horizontal error over a run ({} scenario): mean {:.2} m, max {:.2} m (means over seeds)",
        if paper_noise { "paper-noise" } else { "original" },
        ge.iter().map(|g| g.0).sum::<f64>() / ge.len() as f64,
        ge.iter().map(|g| g.1).sum::<f64>() / ge.len() as f64
    );
    let jobs: Vec<(u64, &str)> =
        (0..seeds).flat_map(|s| STRATEGIES.iter().map(move |n| (s, *n))).collect();
    let results: Vec<(u64, &str, [f64; 6])> =
        jobs.par_iter().map(|&(s, n)| (s, n, run(&exact, &traj, &gnss, s, n))).collect();

    if let Some(dir) = csv.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let mut f = std::io::BufWriter::new(std::fs::File::create(&csv)?);
    writeln!(
        f,
        "seed,strategy,mean_east,mean_north,mean_horizontal,max_east,max_north,max_horizontal"
    )?;
    for (s, n, r) in &results {
        writeln!(
            f,
            "{s},{n},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
            r[0], r[1], r[2], r[3], r[4], r[5]
        )?;
    }
    println!("{} seeds; per-seed results in {}\n", seeds, csv.display());
    println!(
        "| filter | mean E (m) | mean N (m) | mean horizontal (m) | max E (m) | max N (m) | max horizontal (m) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for name in STRATEGIES {
        let rows: Vec<&[f64; 6]> = results.iter().filter(|r| r.1 == name).map(|r| &r.2).collect();
        let n = rows.len() as f64;
        let cell = |i: usize| {
            let m = rows.iter().map(|r| r[i]).sum::<f64>() / n;
            let sd =
                (rows.iter().map(|r| (r[i] - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
            format!("{m:.3} ± {sd:.3}")
        };
        println!(
            "| {name} | {} | {} | {} | {} | {} | {} |",
            cell(0),
            cell(1),
            cell(2),
            cell(3),
            cell(4),
            cell(5)
        );
    }
    println!(
        "\nPaper (one run): mean horizontal KF 1.316, AKF 1.279, IAKF 1.198 m; max 8.668, 5.845, 5.234 m."
    );
    Ok(())
}
