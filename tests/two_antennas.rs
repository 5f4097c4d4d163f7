//! Heading from two antennas, the CI subset of `examples/two_antennas.rs`: the simulator's
//! drive with a moving-base receiver (a 1 m baseline along the forward axis measured at
//! 0.2° σ, and one across the vehicle), four GNSS outages of 60 s in which the fixes and
//! the headings are both lost; runs as a user makes them (no `[init]`, the default gate).
//!
//! The laws: the heading's RMS error stays within 0.3° through the outages; the start
//! takes its heading from the antennas at the first fix, within 3σ of the truth, standing
//! and moving; without the antennas the same drive's heading is worse.

use crate::everyday::*;
use ins_gnss::run::{run_in_memory, Inputs, Results, RunSummary};
use nalgebra::Vector3;
use rayon::prelude::*;

fn run(d: &AntennaDrive, gnss: std::sync::Arc<[f64]>, extra: &str) -> (RunSummary, Results) {
    let cfg = config_of(&d.data, extra);
    let inputs = Inputs::Arrays { imu: d.data.imu.clone(), imu_width: 7, gnss, gnss_width: 7 };
    run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs).unwrap()
}

fn initial_yaw_error(d: &AntennaDrive, r: &Results) -> f64 {
    let first = r.nav[0];
    let k = d.yaw.partition_point(|y| y.0 < first[0] - 1e-6);
    ins_gnss_core::heading::wrap(first[9].to_radians() - d.yaw[k].1).to_degrees()
}

#[test]
fn the_heading_holds_through_60_s_outages() {
    let cells = [(Vector3::new(1.0, 0.0, 0.0), 1u64), (Vector3::new(0.0, 1.0, 0.0), 2)];
    let outs: Vec<_> = cells
        .par_iter()
        .map(|&(b, seed)| {
            let d = antenna_drive(seed, b, 0.2, 0.0);
            let g = gnss_rows(&d.data, Errors::White([0.02, 0.02, 0.05]), 1.0, seed);
            let with = run(&d, g.clone(), "");
            let without = run(&d, g.clone(), "[gnss.heading]\nuse_headings = false\n");
            let smoothed = run(&d, g, "[filter]\nsmooth = true\n").1;
            std::fs::remove_file(&d.headings).ok();
            (b, d, with, without, smoothed)
        })
        .collect();
    for (b, d, (s, r), (_, r0), rs) in outs {
        let (smooth_all, smooth_outages, _) = heading_errors(&d.yaw, &rs.smoothed_nav, 0.0);
        let (all, outages, worst) = heading_errors(&d.yaw, &r.nav, 0.0);
        let (all0, outages0, _) = heading_errors(&d.yaw, &r0.nav, 0.0);
        eprintln!(
            "baseline {b:?}: heading RMS {all:.3}° (outages {outages:.3}°, worst {worst:.3}°); \
             without the antennas {all0:.3}° ({outages0:.3}°); smoothed {smooth_all:.3}° \
             ({smooth_outages:.3}°)"
        );
        assert!(!rs.smoothed_nav.is_empty());
        assert!(smooth_outages <= outages, "smoothing made the outages worse");
        assert!(outages <= 0.3 && all <= 0.3, "{b:?}: {all}° / {outages}° in the outages");
        assert!(outages < outages0, "the antennas made it worse: {outages} against {outages0}");
        let line = s.start.iter().find(|l| l.contains("two antennas")).expect("the start's line");
        assert!(line.contains("at the first fix"), "{line}");
        let e0 = initial_yaw_error(&d, &r);
        assert!(e0.abs() <= 3.0 * 0.2_f64.hypot(0.05), "initial heading {e0}° off");
        let used = r.updates.iter().filter(|u| u.stream.to_string() == "gnss-heading").count();
        assert!(used >= 350, "{used} heading updates (360 fixes outside the outages)");
    }
}

#[test]
fn a_moving_start_takes_its_heading_at_the_first_fix() {
    let d = antenna_drive(3, Vector3::new(1.0, 0.0, 0.0), 0.2, 0.0);
    let g = gnss_rows(&d.data, Errors::White([0.02, 0.02, 0.05]), 1.0, 3);
    // 45 s: driving straight at 15 m/s; the first fix at 45 s
    let (s, r) = run(&d, g, "[data]\nstart_time = 44.5\n");
    std::fs::remove_file(&d.headings).ok();
    let line = s.start.iter().find(|l| l.contains("two antennas")).expect("the start's line");
    assert!(line.contains("(45.000 s)"), "{line}");
    let e0 = initial_yaw_error(&d, &r);
    eprintln!("{}\ninitial heading error {e0:.3}°", s.lines().join("\n"));
    let antennas = s.lines().into_iter().find(|l| l.starts_with("two antennas:")).unwrap();
    assert!(antennas.contains("refused") && !antennas.contains("found no fix"), "{antennas}");
    assert!(e0.abs() <= 3.0 * 0.2_f64.hypot(0.05), "initial heading {e0}° off");
    let (all, outages, _) = heading_errors(&d.yaw, &r.nav, 0.0);
    assert!(all <= 0.3 && outages <= 0.3, "{all}° / {outages}°");
}

#[test]
fn a_heading_sigma_declared_5_times_too_small_is_learned_and_named() {
    let d = antenna_drive(4, Vector3::new(1.0, 0.0, 0.0), 0.2, 0.0);
    let g = gnss_rows(&d.data, Errors::White([0.02, 0.02, 0.05]), 1.0, 4);
    let (s, r) = run(&d, g, "[gnss.heading]\nreplace_std = true\nstd = 0.04\n");
    std::fs::remove_file(&d.headings).ok();
    let learned = s.learned.iter().find(|l| l.stream == "gnss-heading").expect("learned");
    eprintln!("{}", s.learned_line().unwrap());
    // (the variance factor; σ × 3.8 on this seed against the truth's 5: the learner's
    // residuals shrink with the filter's heading σ, which the declared σ made small)
    let sigma_factor = learned.factor.sqrt();
    assert!((3.0..=6.5).contains(&sigma_factor), "σ factor {sigma_factor}");
    let line = s.learned_line().unwrap();
    assert!(line.contains("gnss.heading.std"), "{line}");
    let (all, outages, _) = heading_errors(&d.yaw, &r.nav, 0.0);
    assert!(all <= 0.3 && outages <= 0.3, "{all}° / {outages}°");
}

#[test]
fn a_receiver_whose_first_headings_are_missing_starts_on_a_later_one() {
    let d = antenna_drive(5, Vector3::new(1.0, 0.0, 0.0), 0.2, 0.0);
    // the moving-base solution takes its first three epochs to come
    let text = std::fs::read_to_string(&d.headings).unwrap();
    let rest: Vec<&str> = text.lines().skip(3).collect();
    std::fs::write(&d.headings, rest.join("\n") + "\n").unwrap();
    let g = gnss_rows(&d.data, Errors::White([0.02, 0.02, 0.05]), 1.0, 5);
    let (s, r) = run(&d, g, "");
    std::fs::remove_file(&d.headings).ok();
    let line = s.start.iter().find(|l| l.contains("two antennas")).expect("the start's line");
    assert!(line.contains("at a later fix"), "{line}");
    let e0 = initial_yaw_error(&d, &r);
    assert!(e0.abs() <= 3.0 * 0.2_f64.hypot(0.05), "initial heading {e0}° off");
}
