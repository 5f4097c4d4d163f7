//! The CS-MAEKF paper's claim on the simulated loitering flight, over 20 seeds.
//!
//! Paper: max roll/pitch error ordered CS-MAEKF < modified < conventional, CS-MAEKF's at
//! most 0.6× the modified filter's. **We do not reproduce the second part**: with our
//! reconstruction of the lost membership formulas (and the other readings we tried, see
//! `cargo run --release -p models --example cs_readings`), CS-MAEKF ties the modified
//! filter on maximum error and is slightly better in RMS. This test asserts what we
//! measure; `models::cs` and `docs` say where and why we differ.

use models::ahrs::experiment::run_seed;
use models::ahrs::sim::{LoiteringFlight, SensorErrors};

#[test]
fn conventional_is_far_worse_and_cs_maekf_ties_modified() {
    let flight = LoiteringFlight::default();
    let errors = SensorErrors::default();
    let seeds = 20;
    let (mut max, mut rms) = ([[0.0_f64; 3]; 3], [[0.0_f64; 3]; 3]);
    for seed in 0..seeds {
        let r = run_seed(&flight, &errors, seed).unwrap();
        for v in 0..3 {
            for k in 0..3 {
                max[v][k] += r[v].max[k] / seeds as f64;
                rms[v][k] += r[v].rms[k] / seeds as f64;
            }
        }
    }
    let [conv, modi, cs] = max;
    eprintln!(
        "mean max roll/pitch/yaw: conventional {conv:.2?}, modified {modi:.2?}, cs-maekf {cs:.2?}"
    );
    eprintln!("mean RMS: modified {:.2?}, cs-maekf {:.2?}", rms[1], rms[2]);
    for k in 0..2 {
        // Conventional ≫ both acceleration-aware filters (the paper's first finding).
        assert!(conv[k] > 3.0 * modi[k] && conv[k] > 3.0 * cs[k]);
        // CS-MAEKF within ±15 % of the modified filter on max roll and pitch — not 0.6×.
        assert!((cs[k] / modi[k] - 1.0).abs() < 0.15, "axis {k}: {} vs {}", cs[k], modi[k]);
        // …and no worse in RMS.
        assert!(rms[2][k] <= rms[1][k] * 1.02, "RMS axis {k}");
    }
}

/// From the true initial acceleration, the control (the modified filter with a
/// well-tuned fixed q = 0.1) beats both the paper's modified filter and the CS-MAEKF on
/// maximum roll, pitch and yaw (measured over 50 seeds: 0.93 / 1.21 / 2.41° against
/// 1.41 / 3.38 / 6.04° and 1.37 / 3.56 / 6.34°).
#[test]
fn a_well_tuned_fixed_q_beats_the_adaptive_filter_from_a_fair_start() {
    use models::ahrs::experiment::{run_seed_with_control, Start};
    let (flight, errors) = (LoiteringFlight::default(), SensorErrors::default());
    let seeds = 3;
    let mut mean = [[0.0; 3]; 4];
    for seed in 0..seeds {
        let r = run_seed_with_control(&flight, &errors, seed, Start::KnownAcceleration).unwrap();
        for (m, e) in mean.iter_mut().zip(&r) {
            for (mk, ek) in m.iter_mut().zip(&e.max) {
                *mk += ek / seeds as f64;
            }
        }
    }
    let [_, modified, tuned, cs] = mean;
    eprintln!(
        "fair start, max roll/pitch/yaw: modified {modified:.2?}, tuned {tuned:.2?}, cs {cs:.2?}"
    );
    for k in 0..3 {
        assert!(
            tuned[k] < modified[k] && tuned[k] < cs[k],
            "axis {k}: {tuned:?} {modified:?} {cs:?}"
        );
    }
}
