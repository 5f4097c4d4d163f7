//! The start campaign's CI subset (the full table: `cargo run --release --example
//! start_campaign`, in `docs/history/results.md`): cars that stand 5 and 20 minutes before they
//! drive, a car driving backwards and a person standing before a yard walk, RTK fixes, no
//! `[init]` — each starts (no refusal) with its heading inside its own 3σ. Before the bank
//! of heading hypotheses, a car standing 300 s was refused on 7 of 10 seeds ("the file's
//! angle increments are not in rad", or the heading "only to ±176°") and one standing 20
//! min on 8 of 10, or started 90–163° off at a σ of a degree.

use crate::everyday::start::*;

fn run(
    make: impl Fn(u64) -> (crate::everyday::Data, Motion),
    fixes: Fixes,
    seeds: u64,
) -> Vec<StartOutcome> {
    (1..=seeds)
        .map(|seed| {
            let (d, motion) = make(seed);
            judge_start(&d, &motion, fixes, seed, "")
        })
        .collect()
}

fn refusals(outs: &[StartOutcome]) -> Vec<&str> {
    outs.iter().filter_map(|o| o.refused.as_deref()).collect()
}

#[test]
fn a_car_standing_five_minutes_starts_with_its_heading_covered() {
    let outs = run(|s| standing_car(s, 300.0, &GRADES[2]), Fixes::Rtk, 3);
    assert!(refusals(&outs).is_empty(), "{:?}", refusals(&outs));
    // (over 20 seeds not every run stays within 3σ at every epoch: the worst reach about
    // 3.3σ, under a degree, some 20 s into the motion; `docs/history/results.md`)
    let covered = outs.iter().filter(|o| o.heading_covered).count();
    assert!(covered >= 2, "{covered} of 3 within 3σ throughout");
    for (k, o) in outs.iter().enumerate() {
        let (e, r, t) = (o.worst_error, o.worst_ratio, o.worst_t);
        assert!(r < 4.0, "seed {}: heading error {e:.2}° = {r:.2}σ at {t:.0} s", k + 1);
        assert!(e < 2.0, "seed {}: heading error {e:.2}°", k + 1);
        let v = o.velocity_error;
        assert!(o.velocity_covered, "seed {}: start velocity {v:.3} m/s off", k + 1);
    }
}

#[test]
fn a_car_standing_twenty_minutes_with_a_noisy_mems_starts_with_its_heading_covered() {
    let outs = run(|s| standing_car(s, 1200.0, &GRADES[3]), Fixes::Rtk, 1);
    assert!(refusals(&outs).is_empty(), "{:?}", refusals(&outs));
    let o = &outs[0];
    assert!(
        o.heading_covered,
        "heading error {:.2}° = {:.2}σ at {:.0} s",
        o.worst_error, o.worst_ratio, o.worst_t
    );
    assert!(o.worst_error < 5.0, "heading error {:.2}°", o.worst_error);
}

#[test]
fn a_car_driving_backwards_and_a_standing_walker_start_as_well_as_from_the_truth() {
    for (name, outs, truth) in [
        ("backwards car", run(|s| reversing_car(s, 10.0, &GRADES[2]), Fixes::Rtk, 2), {
            (1..=2u64)
                .map(|s| {
                    let (d, m) = reversing_car(s, 10.0, &GRADES[2]);
                    judge_start(&d, &m, Fixes::Rtk, s, &true_init(&d, &m)).rms
                })
                .collect::<Vec<f64>>()
        }),
        ("yard walk", run(|s| yard_walk(s, 10.0), Fixes::Rtk1cm, 2), {
            (1..=2u64)
                .map(|s| {
                    let (d, m) = yard_walk(s, 10.0);
                    judge_start(&d, &m, Fixes::Rtk1cm, s, &true_init(&d, &m)).rms
                })
                .collect::<Vec<f64>>()
        }),
    ] {
        assert!(refusals(&outs).is_empty(), "{name}: {:?}", refusals(&outs));
        for (k, (o, t)) in outs.iter().zip(&truth).enumerate() {
            assert!(
                o.heading_covered,
                "{name} seed {}: heading error {:.2}° = {:.2}σ",
                k + 1,
                o.worst_error,
                o.worst_ratio
            );
            assert!(
                o.velocity_covered,
                "{name} seed {}: start velocity {:.3} m/s off",
                k + 1,
                o.velocity_error
            );
            assert!(
                o.rms <= 1.2 * t,
                "{name} seed {}: {:.3} m against {:.3} m from the true start",
                k + 1,
                o.rms,
                t
            );
        }
    }
}
