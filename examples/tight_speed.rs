//! Tight against loose coupling, timed: a navego-length simulated drive (437 s, IMU at
//! 200 Hz, raw observations at 5 Hz from the shipped navigation file's satellites), the
//! filter alone (the observations prepared beforehand, as a reader would hand them over).
//!
//! `cargo run --release --features campaigns --example tight_speed`

use std::path::Path;
use std::time::Instant;

use estimator_core::{FixedNoise, NoObserver};
use gnss::spp::{prepare, single_point, SppOptions};
use gnss::{read_nav, GpsTime};
use ins_gnss_core::navigator::{ClockInit, RawEpoch, TightConfig};
use ins_gnss_core::tight::{ClockNoise, InsModelTc};
use ins_gnss_core::{GnssConfig, GnssEpoch, InitialState, InitialStd, InsModel, Navigator};
use ins_gnss_sim::raw::{simulate_raw, RawSim};
use ins_gnss_sim::{scenarios, simulate, GnssSim, Segment, Trajectory};
use nalgebra::Vector3;

fn main() {
    let nav =
        read_nav(&Path::new(env!("CARGO_MANIFEST_DIR")).join("data/rinex-rtklib/07590920.05n.zst"))
            .unwrap();
    let kb = nav.klobuchar.unwrap();
    let (start, mut segs) = scenarios::drive_600s();
    // 437 s, navego's length
    let mut total = 0.0;
    segs.retain(|s| {
        let keep = total + s.duration <= 437.0;
        total += s.duration;
        keep
    });
    let used: f64 = segs.iter().map(|s| s.duration).sum();
    segs.push(Segment::straight(437.0 - used));
    let traj = Trajectory::new(start, &segs).unwrap();
    let none = GnssSim::none();
    let data = simulate(&traj, 200.0, &scenarios::mems_imu(), &none, 1);
    let t_gps = GpsTime::from_calendar(2005, 4, 2, 3, 0, 0.0);
    let sim = RawSim { rate_hz: 5.0, ..RawSim::spp_budget(t_gps) };
    let (epochs, _) = simulate_raw(&traj, &nav.ephemerides, &kb, &sim, 1);
    let opt = SppOptions::default();
    let t0 = data.truth[0].t;
    let time_of = |e: &gnss::ObsEpoch| t0 + e.time.diff(&t_gps);
    let raw: Vec<RawEpoch> = epochs
        .iter()
        .map(|e| RawEpoch {
            t: time_of(e),
            time: e.time,
            sats: prepare(e, &nav.ephemerides, &opt).0,
            heading: None,
        })
        .collect();
    let fixes: Vec<GnssEpoch> = epochs
        .iter()
        .filter_map(|e| {
            let s = single_point(e, &nav.ephemerides, Some(&kb), &opt, None).ok()?;
            // positions only (the timed loose run uses no velocity)
            let mut g = GnssEpoch::from_single_point(&s, time_of(e));
            (g.vel, g.vel_cov) = (None, None);
            Some(g)
        })
        .collect();
    let deg = core::f64::consts::PI / 180.0;
    let init = InitialState {
        time: t0,
        state: data.truth[0].state.clone(),
        std: InitialStd {
            att: Vector3::repeat(deg),
            vel: Vector3::repeat(0.1),
            pos: Vector3::repeat(3.0),
            bg: Vector3::repeat(1e-4),
            ba: Vector3::repeat(5e-3),
        },
    };
    let sats: usize = raw.iter().map(|e| e.sats.len()).sum();
    println!(
        "{} IMU samples, {} raw epochs ({:.1} satellites each), {} single-point fixes",
        data.imu.len(),
        raw.len(),
        sats as f64 / raw.len() as f64,
        fixes.len()
    );
    let first = single_point(&epochs[0], &nav.ephemerides, Some(&kb), &opt, None).unwrap();
    let clock = ClockInit { clock: (first.clocks[0].1, 0.0), std: (10.0, 2.0), isb_std: 10.0 };
    let noise = scenarios::mems_imu().noise;
    for round in 0..3 {
        let t = Instant::now();
        let mut n =
            Navigator::new(&init, InsModel::wgs84(noise), FixedNoise, GnssConfig::default())
                .unwrap();
        let (mut k, mut out) = (0, Vec::with_capacity(8));
        for s in &data.imu {
            let a = k;
            while k < fixes.len() && fixes[k].t <= s.t + 1e-9 {
                k += 1;
            }
            out.clear();
            n.process_into(s, &fixes[a..k], &mut NoObserver, &mut out).unwrap();
        }
        let loose = t.elapsed().as_secs_f64();
        let cfg = TightConfig {
            models: opt.clone(),
            klobuchar: kb,
            use_doppler: true,
            error_floor: false,
            carrier: false,
            phase_std: 0.003,
        };
        let t = Instant::now();
        let model = InsModelTc { base: InsModel::wgs84(noise), clock: ClockNoise::default() };
        let mut n =
            Navigator::new((&init, &clock), model, FixedNoise, GnssConfig::default()).unwrap();
        let (mut k, mut out) = (0, Vec::with_capacity(64));
        for s in &data.imu {
            let a = k;
            while k < raw.len() && raw[k].t <= s.t + 1e-9 {
                k += 1;
            }
            out.clear();
            n.process_raw(s, &raw[a..k], &cfg, &mut NoObserver, &mut out).unwrap();
        }
        let tight = t.elapsed().as_secs_f64();
        println!("round {round}: loose {loose:.3} s, tight {tight:.3} s: {:.2}×", tight / loose);
    }
}
