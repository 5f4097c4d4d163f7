//! The χ²-gated IAKF paper's conclusion as we measure it (`docs/history/results.md`), on a
//! reduced seed count that runs in CI: on the paper's scenario the Sage–Husa filter
//! lowers the maximum horizontal error against the fixed KF, and the IAKF with the `Raw`
//! inflation does not (the paper reports the opposite). The full 50-seed table:
//! `cargo run --release --features campaigns --example repro_iakf`.

#[allow(dead_code)]
#[path = "../examples/repro_iakf.rs"]
mod repro;

use ins_gnss_sim::ExactImu;

#[test]
fn iakf_paper_conclusion_as_measured() {
    let traj = repro::scenario().trajectory().unwrap();
    let exact = ExactImu::new(&traj, 100.0);
    let gnss = repro::gnss();
    let seeds = 0..6u64;
    let (e, t, g) = (&exact, &traj, &gnss);
    let mean_max = |name: &str| {
        let v: Vec<f64> = std::thread::scope(|s| {
            let handles: Vec<_> = seeds
                .clone()
                .map(|seed| s.spawn(move || repro::run(e, t, g, seed, name)[5]))
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        v.iter().sum::<f64>() / v.len() as f64
    };
    let fixed = mean_max("fixed");
    let sage = mean_max("sage-husa");
    let iakf = mean_max("iakf-raw");
    eprintln!(
        "mean max horizontal over 6 seeds: fixed {fixed:.2} m, sage-husa {sage:.2} m, iakf-raw {iakf:.2} m"
    );
    assert!(sage < 0.85 * fixed, "Sage–Husa should cut the maximum error: {sage} vs {fixed}");
    assert!(
        iakf > 0.95 * fixed,
        "IAKF (Raw) did not beat the KF in our measurement: {iakf} vs {fixed}"
    );
}

/// With GNSS noise like the paper's Table 2 (`iakf-chi-square-paper-noise.toml`; 50 seeds:
/// fixes' own error mean 3.54 m, max 25.3 m) the ranking does not change: the IAKF
/// (either reading) does not cut the KF's maximum horizontal error by the paper's 35 %
/// (50 seeds: fixed 8.11 m, `iakf` (1/k) 7.80 m, `iakf-raw` 12.93 m), and the `1/k` reading
/// beats the raw one.
#[test]
fn paper_like_noise_does_not_change_the_ranking() {
    let sc = repro::paper_noise_scenario();
    let traj = sc.trajectory().unwrap();
    let exact = ExactImu::new(&traj, 100.0);
    let gnss = sc.gnss_sim().unwrap();
    let (e, t, g) = (&exact, &traj, &gnss);
    let mean_max = |name: &str| {
        let v: Vec<f64> = std::thread::scope(|s| {
            let handles: Vec<_> =
                (0..6u64).map(|seed| s.spawn(move || repro::run(e, t, g, seed, name)[5])).collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        v.iter().sum::<f64>() / v.len() as f64
    };
    let (fixed, raw, epoch) = (mean_max("fixed"), mean_max("iakf-raw"), mean_max("iakf"));
    eprintln!(
        "paper-like noise, mean max horizontal over 6 seeds: fixed {fixed:.2} m, iakf-raw {raw:.2} m, iakf {epoch:.2} m"
    );
    assert!(epoch > 0.65 * fixed, "the paper's 35 % cut would be a change: {epoch} vs {fixed}");
    assert!(epoch < raw, "the 1/k reading beats the raw one: {epoch} vs {raw}");
}
