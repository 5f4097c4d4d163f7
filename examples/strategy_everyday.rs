//! Every strategy of the program on everyday GNSS: the built-in drive (it stands 20 s
//! before it moves) with single-point-like fixes at 1 Hz whose errors wander — a
//! first-order Gauss–Markov process per axis (σ 1.5 m north/east, 3 m down, correlation
//! time 60 s) over 0.3 m of white noise — declared with σ 0.3×, 1× or 3× the truth, over
//! many seeds, each strategy behind the program's default gate and with the gate open.
//!
//! `cargo run --release --features campaigns --example strategy_everyday [SEEDS]` (default 20) prints, per
//! declared σ and strategy, the mean horizontal RMS after 60 s, the share of epochs whose
//! horizontal error lies beyond the filter's own 99 % ellipse (χ²₂ 9.21; 1 % for a σ that
//! covers the error), the runs whose horizontal RMS exceeds 3× the fixed filter's on the
//! same data, and the steps refused. The filter starts at the truth (σ 1°, 0.1 m/s, 1 m):
//! the start is not what is compared.

use estimator::adaptive::{AnyStrategy, GrossErrorGate, STRATEGY_NAMES};
use estimator::estimator_core::NoObserver;
use estimator::ins_gnss::{GnssConfig, InitialState, InitialStd, InsModel, Navigator};
use estimator::manifolds::Manifold;
use ins_gnss_sim::{scenarios, simulate, GnssSim, SimDataset, Trajectory};
use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

fn gauss(rng: &mut StdRng) -> f64 {
    Distribution::<f64>::sample(&StandardNormal, rng)
}

const GM_SIGMA: [f64; 3] = [1.5, 1.5, 3.0];
const GM_TAU: f64 = 60.0;
const WHITE: f64 = 0.3;

/// The drive with the wandering fixes, declared σ × `declared`.
fn data(seed: u64, declared: f64) -> SimDataset {
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs).unwrap();
    let gnss = GnssSim {
        rate_hz: 1.0,
        pos_sigma: Vector3::repeat(WHITE),
        vel_sigma: None,
        lever_arm: Vector3::new(0.3, 0.0, -1.0),
        windows: vec![],
    };
    let mut d = simulate(&traj, 100.0, &scenarios::mems_imu(), &gnss, seed);
    let mut rng = StdRng::seed_from_u64(seed ^ 0x5eed);
    let phi = (-1.0 / GM_TAU).exp();
    let mut e: Vector3<f64> = Vector3::from_fn(|i, _| GM_SIGMA[i] * gauss(&mut rng));
    let earth = 6.378e6;
    for g in &mut d.gnss {
        // e_k = φ e_{k−1} + √(1 − φ²) σ w (1 s steps)
        e = Vector3::from_fn(|i, _| {
            phi * e[i] + (1.0 - phi * phi).sqrt() * GM_SIGMA[i] * gauss(&mut rng)
        });
        g.pos.lat += e[0] / earth;
        g.pos.lon += e[1] / (earth * g.pos.lat.cos());
        g.pos.h -= e[2];
        g.pos_std =
            Vector3::from_fn(|i, _| declared * (GM_SIGMA[i].powi(2) + WHITE * WHITE).sqrt());
    }
    d
}

#[derive(Clone, Copy, Default)]
struct Outcome {
    rms: f64,
    beyond: f64,
    refused: usize,
}

fn run(d: &SimDataset, name: &str, gated: bool) -> Outcome {
    let t0 = &d.truth[0];
    let std = InitialStd {
        att: Vector3::repeat(1f64.to_radians()),
        vel: Vector3::repeat(0.1),
        pos: Vector3::repeat(1.0),
        bg: Vector3::repeat(1e-4),
        ba: Vector3::repeat(1e-2),
    };
    let init = InitialState { time: t0.t, state: t0.state.clone(), std };
    let cfg = GnssConfig { lever_arm: Vector3::new(0.3, 0.0, -1.0), ..GnssConfig::default() };
    let s: AnyStrategy = name.parse().unwrap();
    let s = if gated { GrossErrorGate::around(s) } else { GrossErrorGate::disabled(s) };
    let model = InsModel::wgs84(scenarios::mems_imu().noise);
    let mut nav = Navigator::new(&init, model, s, cfg).unwrap();
    let mut out = Vec::new();
    let (mut se, mut n, mut beyond, mut refused) = (0.0, 0usize, 0usize, 0usize);
    for (k, (imu, fixes)) in d.replay().enumerate() {
        out.clear();
        if nav.process_into(imu, fixes, &mut NoObserver, &mut out).is_err() {
            refused += 1;
            continue;
        }
        let truth = &d.truth[k + 1];
        if truth.t - t0.t < 60.0 || fixes.is_empty() {
            continue;
        }
        // δ = truth ⊖ estimate; δp is NED metres
        let e = truth.state.ominus(nav.state());
        let h = e.fixed_rows::<2>(6).into_owned();
        let p = nav.covariance().fixed_view::<2, 2>(6, 6).into_owned();
        se += h.norm_squared();
        n += 1;
        match p.cholesky() {
            Some(c) if h.dot(&c.solve(&h)) <= 9.21 => {}
            _ => beyond += 1,
        }
    }
    Outcome { rms: (se / n.max(1) as f64).sqrt(), beyond: beyond as f64 / n.max(1) as f64, refused }
}

fn main() {
    let seeds: u64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(20);
    for declared in [0.3, 1.0, 3.0] {
        let sets: Vec<SimDataset> = (1..=seeds).map(|s| data(s, declared)).collect();
        for gated in [true, false] {
            println!(
                "\ndeclared σ {declared}× the truth, gate {}, {seeds} seeds\n",
                if gated { "default" } else { "open" }
            );
            println!(
                "| strategy | horizontal RMS (m) | beyond the 99 % ellipse | runs > 3× fixed | refused steps |"
            );
            println!("|---|---|---|---|---|");
            let fixed: Vec<Outcome> = sets.par_iter().map(|d| run(d, "fixed", gated)).collect();
            for name in STRATEGY_NAMES {
                let outs: Vec<Outcome> = if name == "fixed" {
                    fixed.clone()
                } else {
                    sets.par_iter().map(|d| run(d, name, gated)).collect()
                };
                let k = outs.len() as f64;
                let rms = outs.iter().map(|o| o.rms).sum::<f64>() / k;
                let beyond = outs.iter().map(|o| o.beyond).sum::<f64>() / k;
                let worse = outs.iter().zip(&fixed).filter(|(o, f)| o.rms > 3.0 * f.rms).count();
                let refused: usize = outs.iter().map(|o| o.refused).sum();
                println!(
                    "| {name} | {rms:.3} | {:.1} % | {worse} of {} | {refused} |",
                    beyond * 100.0,
                    outs.len()
                );
            }
        }
    }
}
