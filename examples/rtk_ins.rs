//! RTK aided by an INS, against RTK alone, on simulated drives: the 630 s drive of
//! `tests/rtk_drive.rs` (rover and base under one sky, 1.6–4.9 km apart, GPS L1 or L1 +
//! L2 at 1 Hz) with a consumer MEMS IMU at 200 Hz (`ins_gnss_sim::scenarios::mems_imu`:
//! ARW 0.3°/√h, VRW 0.1 m/s/√h, turn-on biases 50°/h and 500 mGal), the filter started
//! from the truth with σ 1°, 0.1 m/s, 3 m.
//!
//! Each epoch the INS filter's predicted position (and its covariance) is the RTK filter's
//! prior for the rover instead of the single point with σ 30 m
//! (`Rtk::step_with_prior`); what the epoch's double differences add beyond that prior
//! (`information_beyond`: the information form run backwards) goes back into the INS
//! filter as a position fix with its full covariance. Alone, the same RTK filter and
//! observations (`Rtk::step` with the single point).
//!
//! Cells: L1 or L1 + L2; the sky open, a 30 s tunnel (300–330 s), a 60 s canyon of the 3
//! highest satellites (300–360 s), or cycle slips the receiver does not flag. Per run: the
//! fix rate, wrong fixes (fixed epochs more than 10 cm from the truth), the INS
//! position's horizontal RMS at the epochs and its NEES (3 when the covariance is right),
//! the error at the canyon's end.
//!
//! `cargo run --release --features campaigns --example rtk_ins [SEEDS] [LEAST SUCCESS RATE, default 0.999] [tactical]`

use std::path::Path;

use gnss::rtk::{RtkMode, RtkOptions};
use ins_gnss_sim::scenarios;

#[path = "../tests/rtk_drive.rs"]
#[allow(dead_code)]
mod rtk_drive;
use rtk_drive::{Drive, Run, Sky};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(10);
    let min_ps: f64 = std::env::args().nth(2).and_then(|a| a.parse().ok()).unwrap_or(0.999);
    let drive = Drive::new(Path::new(env!("CARGO_MANIFEST_DIR")))?;
    // `tactical` as a third argument: the same IMU 10× better in bias and 3× in noise
    let mut imu = scenarios::mems_imu();
    if std::env::args().nth(3).as_deref() == Some("tactical") {
        imu.noise.arw /= 3.0;
        imu.noise.vrw /= 3.0;
        imu.noise.gyro_bias /= 10.0;
        imu.noise.accel_bias /= 10.0;
        imu.gyro_turn_on /= 10.0;
        imu.accel_turn_on /= 10.0;
    }
    let exact = ins_gnss_sim::ExactImu::new(drive.trajectory(), 200.0);
    let cells = [
        (1usize, Sky::Open),
        (2, Sky::Open),
        (1, Sky::Tunnel),
        (2, Sky::Tunnel),
        (1, Sky::Canyon),
        (2, Sky::Canyon),
        (1, Sky::Slips),
        (2, Sky::Slips),
    ];
    let mut table: Vec<[Vec<Run>; 2]> = cells.iter().map(|_| [Vec::new(), Vec::new()]).collect();
    for seed in 0..seeds {
        let data = drive.imu(&exact, &imu, seed);
        for (k, &(freqs, sky)) in cells.iter().enumerate() {
            let (rover, base_obs, truth) = drive.simulate(seed, sky);
            let opt = RtkOptions::for_frequencies(RtkMode::Kinematic, freqs);
            let alone = drive.alone(&rover, &base_obs, &truth, &opt, sky);
            // the INS-aided filter asks the float covariance's promise too: a wrong fix it
            // took would move the INS, whose prediction would hold the next ones wrong; its
            // code is white (with the code biases as states, σ 0.3 m, τ 60 s, the L1 cells
            // fixed less and wrongly more: `RTK_CODE_BIAS=σ[,τ]` turns them on, to compare)
            let mut opt_ins = RtkOptions { min_success_rate: min_ps, code_bias_sigma: 0.0, ..opt };
            rtk_drive::code_biases_from_env(&mut opt_ins);
            let with =
                drive.with_ins(&data, imu.noise, &rover, &base_obs, &truth, &opt_ins, sky)?;
            eprintln!(
                "seed {seed} L{freqs} {sky:?}: alone {}/{} fixed, {} wrong, H RMS {:.3} m; with INS {}/{} fixed, {} wrong, {} gated, INS H RMS {:.3} m, NEES {:.2}, end {:?} refix {:?} / alone end {:?} refix {:?}",
                alone.fixed,
                alone.epochs,
                alone.wrong,
                (alone.h2 / alone.n.max(1) as f64).sqrt(),
                with.fixed,
                with.epochs,
                with.wrong,
                with.gated,
                (with.h2 / with.n.max(1) as f64).sqrt(),
                with.nees / with.n.max(1) as f64,
                with.end,
                with.refix,
                alone.end,
                alone.refix,
            );
            table[k][0].push(alone);
            table[k][1].push(with);
        }
    }
    println!("{seeds} seeds; wrong: a fixed epoch > 10 cm from the truth\n");
    println!(
        "| cell | RTK alone: fix rate (worst seed), wrong | RTK + INS: fix rate (worst seed), wrong | INS position H RMS, m; NEES/3 | error at the outage's end, m: median / worst (alone) | fixed again after it, s: median / worst (alone) |"
    );
    println!("|---|---|---|---|---|---|");
    for (k, &(freqs, sky)) in cells.iter().enumerate() {
        let [a, w] = &table[k];
        let rate = |r: &[Run]| {
            let v: Vec<f64> = r.iter().map(|x| x.fixed as f64 / x.epochs.max(1) as f64).collect();
            let min = v.iter().copied().fold(f64::INFINITY, f64::min);
            let wrong: usize = r.iter().map(|x| x.wrong).sum();
            let fixed: usize = r.iter().map(|x| x.fixed).sum();
            format!(
                "{:.1} % ({:.1} %), {wrong} of {fixed}",
                100.0 * v.iter().sum::<f64>() / v.len() as f64,
                100.0 * min
            )
        };
        let med = |mut v: Vec<f64>| -> String {
            v.sort_by(f64::total_cmp);
            match v.len() {
                0 => "–".into(),
                n => format!("{:.2} / {:.2}", v[n / 2], v[n - 1]),
            }
        };
        let h = (w.iter().map(|x| x.h2).sum::<f64>() / w.iter().map(|x| x.n).sum::<usize>() as f64)
            .sqrt();
        let nees = w.iter().map(|x| x.nees).sum::<f64>()
            / w.iter().map(|x| x.n).sum::<usize>() as f64
            / 3.0;
        println!(
            "| L{} {sky:?} | {} | {} | {h:.3}; {nees:.2} | {} ({}) | {} ({}) |",
            if freqs == 1 { "1" } else { "1+L2" },
            rate(a),
            rate(w),
            med(w.iter().filter_map(|x| x.end).collect()),
            med(a.iter().filter_map(|x| x.end).collect()),
            med(w.iter().filter_map(|x| x.refix).collect()),
            med(a.iter().filter_map(|x| x.refix).collect()),
        );
    }
    Ok(())
}
