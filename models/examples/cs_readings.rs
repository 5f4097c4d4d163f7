//! Compare readings of the CS-MAEKF limit rule on the loitering flight (max roll, pitch,
//! yaw error in degrees, mean over 10 seeds).
//!
//! Run: `cargo run --release -p models --example cs_readings`

use std::sync::Arc;

use models::ahrs::experiment::{run, run_with_model, Variant};
use models::ahrs::sim::{LoiteringFlight, SensorErrors};
use models::ahrs::AccelModel;
use models::cs::{
    CsVariance, FixedLimits, GaussianMembership, InterpolatedLimits, LimitRule, RangeLimits,
};

fn main() {
    let flight = LoiteringFlight::default();
    let errors = SensorErrors::default();
    let seeds = 10;
    let range = |up: f64| -> Arc<dyn LimitRule> {
        Arc::new(RangeLimits { a_up: up, a_neg_up: -up, a_th: 10.0, a_neg_th: -10.0 })
    };
    let readings: Vec<(String, Arc<dyn LimitRule>, f64)> = vec![
        ("interpolated |ā|→a_th, floor 0.01".into(), Arc::new(InterpolatedLimits::default()), 0.01),
        ("interpolated |ā|→a_th, floor 0.1".into(), Arc::new(InterpolatedLimits::default()), 0.1),
        ("interpolated |ā|→a_th, floor 0.3".into(), Arc::new(InterpolatedLimits::default()), 0.3),
        ("interpolated |ā|→a_th, floor 0.5".into(), Arc::new(InterpolatedLimits::default()), 0.5),
        ("interpolated |ā|→a_th, floor 1".into(), Arc::new(InterpolatedLimits::default()), 1.0),
        ("interpolated |ā|→a_th, floor 2".into(), Arc::new(InterpolatedLimits::default()), 2.0),
        ("range a_up=2→a_th".into(), range(2.0), 0.01),
        ("range a_up=3→a_th".into(), range(3.0), 0.01),
        ("range a_up=5→a_th".into(), range(5.0), 0.01),
        (
            "fixed ±10 (plain CS)".into(),
            Arc::new(FixedLimits { a_max: 10.0, a_neg_max: -10.0 }),
            0.01,
        ),
    ];
    println!("| reading | max roll | max pitch | max yaw |");
    println!("|---|---|---|---|");
    let mut modified = [0.0; 3];
    for seed in 0..seeds {
        let s = flight.simulate(&errors, seed);
        let e = run(Variant::Modified, &flight, &errors, &s).unwrap();
        for (acc, v) in modified.iter_mut().zip(e.max) {
            *acc += v / seeds as f64;
        }
    }
    println!(
        "| modified (fixed noise) | {:.2} | {:.2} | {:.2} |",
        modified[0], modified[1], modified[2]
    );
    for (name, limits, floor) in readings {
        let mut m = [0.0; 3];
        for seed in 0..seeds {
            let samples = flight.simulate(&errors, seed);
            let variance = CsVariance {
                membership: Arc::new(GaussianMembership::default()),
                limits: limits.clone(),
                floor,
            };
            let mut model = Variant::CsMaekf.model(&errors, flight.rate);
            model.accel = AccelModel::CurrentStatistical { alpha: 1.0 / 60.0, variance };
            let e = run_with_model(&model, &flight, &samples).unwrap();
            for (acc, v) in m.iter_mut().zip(e.max) {
                *acc += v / seeds as f64;
            }
        }
        println!("| {name} | {:.2} | {:.2} | {:.2} |", m[0], m[1], m[2]);
    }
}
