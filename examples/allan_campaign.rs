//! The Allan fit against simulated IMUs of known noise (issue 75's campaign): three
//! grades, 2 h at 200 Hz, `SEEDS` seeds (default 20), one axis per seed and grade —
//! white noise, bias instability (flicker, simulated as a bank of first-order
//! Gauss–Markov processes two per decade from 1 s to 10⁵ s, whose Allan variance is flat
//! to a few per cent over the band; the truth `B` is that floor / 0.664) and a rate random
//! walk. `cargo run --release --features campaigns --example allan_campaign [SEEDS] [HOURS]`.
//!
//! The grades are our own error models after datasheet figures: a tactical MEMS (ARW
//! 0.3 °/√h, BI 5 °/h, RRW 10 °/h/√h), an industrial MEMS (2 °/√h, 25 °/h, 60 °/h/√h) and a
//! consumer MEMS (15 °/√h, 100 °/h, 300 °/h/√h); the fit is judged on a gyro axis (it
//! does not know which sensor it reads). Then `ins-gnss allan`'s static check on 10 min
//! of six axes (accelerometers with white noise of 0.03, 0.1, 0.5 m/s/√h): at rest, and
//! with a 10 s turn of 5 °/s and a 2 s push of 1 m/s².

use ins_gnss::allan::{check_static, Record};
use ins_gnss_core::allan::{analyse, FLICKER_FLOOR};
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

const DEG: f64 = std::f64::consts::PI / 180.0;

/// Increments of one axis: white noise `n` (per √s), the bank's flicker (variance `c`
/// per process, time constants `consts`) and a rate random walk `k` (per s√s), plus
/// `rate(t)` (the motion), every `dt` for `samples`.
#[allow(clippy::too_many_arguments)]
fn simulate(
    rng: &mut StdRng,
    n: f64,
    c: f64,
    consts: &[f64],
    k: f64,
    dt: f64,
    samples: usize,
    rate: impl Fn(f64) -> f64,
) -> Vec<f64> {
    let mut g = || -> f64 { StandardNormal.sample(rng) };
    let decay: Vec<(f64, f64)> = consts
        .iter()
        .map(|t| {
            let a = (-dt / t).exp();
            (a, (c * (1.0 - a * a)).sqrt())
        })
        .collect();
    let mut gm: Vec<f64> = decay.iter().map(|_| c.sqrt() * g()).collect();
    let mut rw = 0.0;
    (0..samples)
        .map(|i| {
            let mut r = n / dt.sqrt() * g() + rw + rate(i as f64 * dt);
            for (v, (a, s)) in gm.iter_mut().zip(&decay) {
                *v = a * *v + s * g();
                r += *v;
            }
            rw += k * dt.sqrt() * g();
            r * dt
        })
        .collect()
}

/// Allan variance of a first-order Gauss–Markov rate of variance 1 and time constant `t`.
fn gm_avar(tau: f64, t: f64) -> f64 {
    let x = tau / t;
    t * t / (tau * tau) * (2.0 * x - 3.0 + 4.0 * (-x).exp() - (-2.0 * x).exp())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    let hours: f64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(2.0);
    let dt = 0.005;
    let samples = (hours * 3600.0 / dt) as usize;
    // the bank: time constants 10^(k/2) s, k = 0 … 10; equal variances c
    let consts: Vec<f64> = (0..=10).map(|k| 10f64.powf(k as f64 / 2.0)).collect();
    let bank_avar = |tau: f64| consts.iter().map(|t| gm_avar(tau, *t)).sum::<f64>();
    // its flatness over the τ a 2 h record fits (10 s … 800 s): the floor at 100 s
    let floor = bank_avar(100.0);
    let ripple = [10.0, 30.0, 300.0, 800.0]
        .iter()
        .map(|t| (bank_avar(*t) / floor).sqrt() - 1.0)
        .fold(0.0_f64, |a, r| a.max(r.abs()));
    println!(
        "bank of {} Gauss–Markov processes: Allan deviation within {:.1} % of its 100 s \
         level over 10–800 s",
        consts.len(),
        100.0 * ripple
    );
    let grades = [
        ("tactical MEMS", 0.3, 5.0, 10.0, 0.03),
        ("industrial MEMS", 2.0, 25.0, 60.0, 0.1),
        ("consumer MEMS", 15.0, 100.0, 300.0, 0.5),
    ];
    for (grade, (name, arw, bi, rrw, vrw)) in grades.into_iter().enumerate() {
        // SI: N rad/√s, B rad/s, K rad/s/√s
        let (n, b, k) = (arw * DEG / 60.0, bi * DEG / 3600.0, rrw * DEG / 3600.0 / 60.0);
        // equal variances c with c · bank_avar(100 s) = FLICKER_FLOOR · B²
        let c = FLICKER_FLOOR * b * b / floor;
        let (mut white, mut inst, mut walk) = (Vec::new(), Vec::new(), Vec::new());
        let (mut refused_static, mut refused_moving) = (0, 0);
        for seed in 0..seeds {
            let mut rng = StdRng::seed_from_u64(seed * 3 + grade as u64);
            let x = simulate(&mut rng, n, c, &consts, k, dt, samples, |_| 0.0);
            let f = analyse(&x, dt).expect("hours are enough");
            white.push(f.white.map(|t| t.value / n - 1.0));
            inst.push(f.instability.map(|t| t.value / b - 1.0));
            walk.push(f.rate_random_walk.map(|t| t.value / k - 1.0));
            // the static check on 10 min of all six axes (accelerometers: white noise
            // `vrw`, gravity on z), at rest and with a 10 s turn of 5 °/s about z and a
            // 2 s push of 1 m/s² along x in the middle
            let short = (600.0 / dt) as usize;
            for moving in [false, true] {
                let turn = move |t: f64| {
                    if moving && (300.0..310.0).contains(&t) {
                        5.0 * DEG
                    } else {
                        0.0
                    }
                };
                let push =
                    move |t: f64| if moving && (300.0..302.0).contains(&t) { 1.0 } else { 0.0 };
                let v = vrw / 60.0;
                let axes = [
                    simulate(&mut rng, n, c, &consts, k, dt, short, |_| 0.0),
                    simulate(&mut rng, n, c, &consts, k, dt, short, |_| 0.0),
                    simulate(&mut rng, n, c, &consts, k, dt, short, turn),
                    simulate(&mut rng, v, 0.0, &[], 0.0, dt, short, push),
                    simulate(&mut rng, v, 0.0, &[], 0.0, dt, short, |_| 0.0),
                    simulate(&mut rng, v, 0.0, &[], 0.0, dt, short, |_| -9.8),
                ];
                let record = Record { axes, dt, source: format!("{name} seed {seed}") };
                match (moving, check_static(&record).is_err()) {
                    (false, true) => refused_static += 1,
                    (true, true) => refused_moving += 1,
                    _ => {}
                }
            }
        }
        let line = |what: &str, v: &[Option<f64>], bar: f64| {
            let found: Vec<f64> = v.iter().flatten().copied().collect();
            let within = found.iter().filter(|e| e.abs() <= bar).count();
            let mut abs: Vec<f64> = found.iter().map(|e| e.abs()).collect();
            abs.sort_by(f64::total_cmp);
            println!(
                "  {what:22} resolved {:2}/{}, within {:.0} %: {:2}/{}, median |error| {:.1} %, \
                 worst {:.1} %",
                found.len(),
                v.len(),
                bar * 100.0,
                within,
                v.len(),
                abs.get(abs.len() / 2).map_or(f64::NAN, |e| e * 100.0),
                abs.last().map_or(f64::NAN, |e| e * 100.0)
            );
        };
        println!("{name} (ARW {arw} °/√h, BI {bi} °/h, RRW {rrw} °/h/√h), {hours} h at 200 Hz:");
        line("white noise", &white, 0.05);
        line("bias instability", &inst, 0.10);
        line("rate random walk", &walk, 0.10);
        println!(
            "  the static check (10 min, six axes, VRW {vrw} m/s/√h): at rest refused \
             {refused_static}/{seeds}; with a 5 °/s turn and a 1 m/s² push refused \
             {refused_moving}/{seeds}"
        );
    }
}
