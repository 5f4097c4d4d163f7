//! drive-0708 (real car, consumer MEMS, RTK, ten 15 s GNSS outages) with land-vehicle
//! aiding: the outage score (RMS over the outages of the maximum horizontal drift, against
//! `ref_rtkfix.txt` at its own epochs; KF-GINS 12.4 m) per configuration — no aiding,
//! NHC, ZUPT/ZARU, both — a sensitivity sweep of the NHC noise and rate, and every
//! strategy with the aiding on. The gross-error gate is open, as in the KF-GINS
//! comparison.
//!
//! Run: `cargo run --release --example drive_aided`. The aiding settings are those of
//! `data/drive-0708/aided.toml`.

#[allow(dead_code)]
#[path = "repro_sample_data.rs"]
mod sample;

use ins_gnss::config::{Config, FilterSection, GateSection, VehicleSection};
use ins_gnss::eval::read_reference;
use ins_gnss::run::load_inputs;
use rayon::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = sample::data_dir().ok_or("no sample data")?.join("drive-0708");
    let aided = Config::load(&dir.join("aided.toml"))?;
    let open_gate = FilterSection {
        gate: GateSection { enabled: false, ..Default::default() },
        ..aided.filter.clone()
    };
    let base = Config { filter: open_gate, vehicle: VehicleSection::default(), ..aided.clone() };
    let (imu, gnss) = load_inputs(&base)?;
    let reference = read_reference(&sample::sample_data::file(&dir, "ref_rtkfix.txt"))?;
    let text = std::fs::read_to_string(dir.join("outage_windows_15s.json"))?;
    let windows: Vec<(f64, f64)> =
        serde_json::from_str::<Vec<[f64; 2]>>(&text)?.into_iter().map(|w| (w[0], w[1])).collect();
    let score = |cfg: &Config, strategy: &str| -> Result<(f64, f64), String> {
        let (ev, _) = sample::run_eval(cfg, strategy, &imu, &gnss, &reference, 0.0, &windows)?;
        Ok((ev.windows_rms_of_max_horizontal, ev.windows_rms_of_max_vertical))
    };
    let with = |nhc: bool, zupt: bool| Config {
        vehicle: VehicleSection {
            nhc: if nhc { aided.vehicle.nhc.clone() } else { None },
            zupt: if zupt { aided.vehicle.zupt.clone() } else { None },
            odometer: None,
        },
        ..base.clone()
    };

    println!(
        "drive-0708, ten 15 s outages, gate open; RMS over outages of the maximum drift (m)\n"
    );
    println!("| configuration | horizontal | vertical |");
    println!("|---|---|---|");
    let generic = Config::load(&dir.join("kf-gins-outage15.yaml"))?;
    let generic = Config { filter: base.filter.clone(), ..generic };
    for states in [15, 21] {
        let mut g = generic.clone();
        g.filter.states = states;
        let (h, v) = score(&g, "fixed")?;
        println!(
            "| {states} states, kf-gins-outage15.yaml as it is (generic MEMS noise) | {h:.3} | {v:.3} |"
        );
    }
    let mut g = generic.clone();
    (g.filter.states, g.init.gyro_scale_std, g.init.accel_scale_std) =
        (21, [1000.0; 3], [1000.0; 3]);
    let (h, v) = score(&g, "fixed")?;
    println!(
        "| 21 states, kf-gins-outage15.yaml with initial scale-factor σ 1000 ppm | {h:.3} | {v:.3} |"
    );
    for (name, states, nhc, zupt) in [
        ("15 states, aided.toml's measured noise, no aiding", 15, false, false),
        ("21 states, no aiding", 21, false, false),
        ("21 states + NHC", 21, true, false),
        ("21 states + ZUPT/ZARU", 21, false, true),
        ("21 states + NHC + ZUPT/ZARU (aided.toml)", 21, true, true),
        ("15 states + NHC + ZUPT/ZARU", 15, true, true),
    ] {
        let mut c = with(nhc, zupt);
        c.filter.states = states;
        let (h, v) = score(&c, "fixed")?;
        println!("| {name} | {h:.3} | {v:.3} |");
    }
    // Mounting angles from a first pass (aided.toml without vehicle aiding, no reference):
    // the body-frame velocity's direction above 5 m/s, median over the drive.
    let (pitch, yaw) = first_pass_mounting(&with(false, false), &imu, &gnss)?;
    let mut c = with(true, true);
    if let Some(n) = c.vehicle.nhc.as_mut() {
        n.mounting = [0.0, pitch, yaw];
    }
    let (h, v) = score(&c, "fixed")?;
    println!(
        "| 21 states + NHC + ZUPT/ZARU, mounting from a first pass (pitch {pitch:.2}°, yaw {yaw:.2}°) | {h:.3} | {v:.3} |"
    );
    println!("| KF-GINS (21 states) | 12.4 | 1.08 |");

    let nhc = aided.vehicle.nhc.clone().ok_or("aided.toml has no [vehicle.nhc]")?;
    println!("\nNHC sensitivity (NHC + ZUPT/ZARU, fixed noise): horizontal score (m)\n");
    let stds = [0.02, 0.05, 0.1, 0.2, 0.5];
    let intervals = [0.01, 0.1, 0.5];
    println!("| interval \\ σ (m/s) | {} |", stds.map(|s| format!("{s}")).join(" | "));
    println!("|---|{}", "---|".repeat(stds.len()));
    for dt in intervals {
        let row: Vec<String> = stds
            .par_iter()
            .map(|&s| {
                let mut c = with(true, true);
                let n = c.vehicle.nhc.as_mut().expect("on");
                (n.std, n.interval) = ([s, s], dt);
                score(&c, "fixed").map(|r| format!("{:.3}", r.0))
            })
            .collect::<Result<_, String>>()?;
        println!("| {dt} s | {} |", row.join(" | "));
    }
    println!("\n(aided.toml: σ = {:?} m/s, interval {} s)", nhc.std, nhc.interval);

    println!("\nEvery strategy with NHC + ZUPT/ZARU (the aiding streams keep fixed noise):\n");
    println!("| strategy | horizontal | vertical |");
    println!("|---|---|---|");
    let all = with(true, true);
    let rows: Vec<(&str, (f64, f64))> = sample::STRATEGIES
        .par_iter()
        .map(|&n| score(&all, n).map(|r| (n, r)))
        .collect::<Result<_, String>>()?;
    for (n, (h, v)) in rows {
        println!("| {n} | {h:.3} | {v:.3} |");
    }
    Ok(())
}

/// The IMU's pitch and yaw on the car (degrees) from a run's own estimates: wherever the
/// speed exceeds 5 m/s, the direction of the body-frame velocity (a car moves along its
/// axis), median over the drive.
fn first_pass_mounting(
    cfg: &Config,
    imu: &[estimator::ins_gnss::ImuSample],
    gnss: &[estimator::ins_gnss::GnssEpoch],
) -> Result<(f64, f64), String> {
    let (mut pitch, mut yaw) = (Vec::new(), Vec::new());
    ins_gnss::run::run_slices(
        cfg,
        "fixed".parse().map_err(|e| format!("{e}"))?,
        imu,
        gnss,
        |k, _, x| {
            if k % 10 == 0 && x.vel.norm() > 5.0 {
                let v = x.att.matrix().tr_mul(&x.vel);
                yaw.push(v.y.atan2(v.x).to_degrees());
                pitch.push((-v.z).atan2(v.x).to_degrees());
            }
        },
    )
    .map_err(|e| e.to_string())?;
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // the IMU's pitch relative to the car is minus the velocity's elevation in the body
    // frame; its yaw minus the velocity's azimuth
    Ok((-median(&mut pitch), -median(&mut yaw)))
}
