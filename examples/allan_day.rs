//! The Allan deviation of a day at 200 Hz (17.28 million samples per axis, six axes):
//! `cargo run --release --features campaigns --example allan_day`. Prints the time of the analysis alone (the
//! axes on the machine's cores, as `ins-gnss allan` analyses them; the
//! samples are generated first: white noise and a rate random walk) and the fitted white
//! noise against the truth.
use std::time::Instant;

use ins_gnss_core::allan::analyse_axes;
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

fn main() {
    let (dt, n_true, k_true, samples) = (0.005_f64, 2e-3, 1e-6, 86_400 * 200);
    let mut rng = StdRng::seed_from_u64(86_400);
    let mut gauss = move || -> f64 { StandardNormal.sample(&mut rng) };
    let axes: Vec<Vec<f64>> = (0..6)
        .map(|_| {
            let mut bias = 0.0;
            (0..samples)
                .map(|_| {
                    bias += k_true * dt.sqrt() * gauss();
                    (bias + n_true / dt.sqrt() * gauss()) * dt
                })
                .collect()
        })
        .collect();
    let t = Instant::now();
    let fits: Vec<_> =
        analyse_axes(&axes, dt).into_iter().map(|f| f.expect("a day is long enough")).collect();
    let took = t.elapsed().as_secs_f64();
    for f in &fits {
        println!(
            "white {:.4e} (truth {n_true:.4e}), rate random walk {:?} (truth {k_true:.1e}), {} points",
            f.white.map_or(f64::NAN, |w| w.value),
            f.rate_random_walk.map(|k| k.value),
            f.curve.len()
        );
    }
    println!("six axes of {samples} samples analysed in {took:.2} s");
}
