//! The evidence the fixes' error bank rests on (the everyday-GNSS issue): the filter's
//! log-likelihood of the fixes over a grid of persisting-error hypotheses — correlation
//! times 33, 100, 300 s, σ 0.5–1.4× the truth's — beside each run's outages' score or
//! horizontal RMS and its share of epochs beyond its own 99 % ellipse, for fixes that
//! wander as the single points do (1.5/1.5/3 m, τ 100 s, over 0.3 m white).
//!
//! `cargo run --release --features campaigns --example fix_error_likelihood [DATA] [SEEDS] [DECLARED]`: `DATA`
//! `sim drive` (default), `navego`, or a drive-0708 configuration
//! (`kf-gins-outage15.yaml`, `aided-noinit.toml`); `SEEDS` 1 to N (3); `DECLARED` the
//! factor on the σ the fixes declare (1); `told` after them: the white part given its true
//! σ (0.3 m) and not learned, the gate's learning off. Otherwise each hypothesis states the persisting part
//! (`gnss.errors.sigma`, `tau`) and learns the white part from the residuals, as the
//! bank's runs do, and is scored as they are (after the first 100 fixes). What it shows:
//! along the ridge where σ²/τ is constant the likelihood is nearly flat (the data cannot
//! tell 0.5× at 33 s from the truth or from 1.4× at 300 s); off it, the hypotheses that
//! under-cover (σ too small for their τ) are tens to hundreds of log-units less likely.
//! Hence the bank's rule: of the hypotheses within the margin of the best, the longest τ.
//!
//! `fine` in place of `told`: σ on a fine grid at τ 300 s (1.5 × 1.025ⁱ × the truth's, 16
//! steps), the way the bank's σ walk sees one profile; `fine-no-outages` the same with a
//! drive-0708 configuration's fixes taken from `GNSS-RTK.txt.zst` (no outages) instead of
//! `GNSS-RTK-outage10x15.txt.zst`. What it showed (`aided-noinit.toml 1 1 fine`) while
//! that configuration had a ZUPT that fired as the car crept: the likelihood jumped by
//! ~1,500 log-units between neighbouring σ — the run after an outage went one of two ways
//! (the gate matched `R` to the returning innovations, or took them at full weight while
//! they kept their direction) — and was smooth without the outages; without that ZUPT it
//! is smooth either way (−2,396 at 1.5×, −2,375 at 1.87×, −2,387 at 2.17×).
#[path = "../tests/everyday/mod.rs"]
mod everyday;
use everyday::*;
use ins_gnss::run::{run_in_memory, Inputs, Results, RunSummary};

fn main() {
    let set = std::env::args().nth(1).unwrap_or_else(|| "sim drive".into());
    let seeds: u64 = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let declared: f64 = std::env::args().nth(3).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    // (`told`: the white part given its true σ and not learned, the gate's learning off)
    let told = std::env::args().nth(4).is_some_and(|a| a == "told");
    // (`fine`: a fine σ grid at τ 300 s; `fine-no-outages`: drive-0708's fixes without outages)
    let fine = std::env::args().nth(4).is_some_and(|a| a.starts_with("fine"));
    let no_outages = std::env::args().nth(4).is_some_and(|a| a == "fine-no-outages");
    let e = Errors::Wander([1.5, 1.5, 3.0], 100.0, 0.3);
    for seed in 1..=seeds {
        let sim;
        let mut real;
        let d = match set.as_str() {
            "sim drive" => {
                sim = sim_drive(seed);
                &sim
            }
            "navego" => {
                real = navego();
                &real
            }
            s => {
                real = drive_0708(s);
                if no_outages {
                    let (g, w) = rows(&data_dir("drive-0708").join("GNSS-RTK.txt.zst"));
                    real.fixes = g
                        .chunks(w)
                        .map(|r| [r[0], r[1].to_radians(), r[2].to_radians(), r[3]])
                        .collect();
                }
                &real
            }
        };
        let g = gnss_rows(d, e, declared, seed);
        let (taus, ks): (&[f64], Vec<f64>) = if fine {
            (&[300.0], (0..16).map(|i| 1.5 * 1.025f64.powi(i)).collect())
        } else {
            (&[33.3, 100.0, 300.0], vec![0.5, 0.7, 1.0, 1.4])
        };
        for &tau in taus {
            for &k in &ks {
                let mut extra = format!(
                    "[gnss.errors]\nmodel = \"persisting\"\n\
                     sigma = [{}, {}, {}]\ntau = {tau}\nlearn = {}\n",
                    1.5 * k,
                    1.5 * k,
                    3.0 * k,
                    !told
                );
                if told {
                    extra +=
                        "[gnss]\nposition_std = [0.3, 0.3, 0.3]\n[filter.gate]\nlearn = false\n";
                }
                let cfg = config_of(d, &extra);
                let inputs = Inputs::Arrays {
                    imu: d.imu.clone(),
                    imu_width: 7,
                    gnss: g.clone(),
                    gnss_width: 7,
                };
                let (s, r): (RunSummary, Results) =
                    run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs).unwrap();
                let ll: f64 =
                    s.streams.iter().filter(|x| x.gnss).map(|x| x.log_likelihood_settled).sum();
                let t0 = r.nav.first().map_or(0.0, |x| x[0]);
                let (score, beyond) = score(d, &r, t0);
                println!(
                    "seed {seed} tau {tau:6.0} k {k:.3}: ll {ll:10.1} score {score:.3} beyond {:.1} %",
                    beyond * 100.0
                );
            }
        }
    }
}
