//! The strategies on the sample data, as measured in `docs/history/results.md` (full runs:
//! `cargo run --release --features campaigns --example repro_sample_data`), on a reduced seed count, on the
//! repository's copy of the sample data.
//!
//! Measured conclusions asserted here: with interference injected into navego's GNSS
//! (+4σ unreported, 60 s), Sage–Husa lowers the window's horizontal RMS against the
//! fixed filter, and the AFKF (which blames the innovations on the prediction) more than
//! doubles it; on drive-0708 with the YAML's noise as given (`static_floor = false`) and no
//! gate the fixed filter scores ≈ 13.5 m (KF-GINS 12.4 m) and the R-estimating strategies
//! (IAE, Sage–Husa) more than double the outage drift.

#[allow(dead_code)]
#[path = "../examples/repro_sample_data.rs"]
mod repro;

fn data() -> std::path::PathBuf {
    repro::data_dir().expect("the repository's data/ directory")
}

#[test]
fn navego_with_injected_interference() {
    let dir = data();
    let rows = repro::navego(&dir, 3).unwrap();
    let mean = |name: &str, i: usize| {
        let v: Vec<f64> = rows.iter().filter(|r| r.1 == name).map(|r| r.2[i]).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let (fixed, sage) = (mean("fixed", 1), mean("sage-husa", 1));
    // Xia's AFKF as written reads the unreported noise as a prior too confident and follows
    // the fixes; the guarded default holds its fading off when it does not help
    let (afkf, guarded) = (mean("afkf-faithful", 1), mean("afkf", 1));
    eprintln!(
        "window horizontal RMS over 3 seeds: fixed {fixed:.3} m, sage-husa {sage:.3} m, afkf-faithful {afkf:.3} m, afkf {guarded:.3} m"
    );
    assert!(sage < 0.95 * fixed, "Sage–Husa {sage} vs fixed {fixed}");
    assert!(afkf > 2.0 * fixed, "AFKF as written {afkf} vs fixed {fixed}");
    assert!(guarded < afkf, "the guarded AFKF {guarded} vs as written {afkf}");
}

#[test]
fn drive_0708_outage_scores() {
    let scores = repro::drive(&data()).unwrap();
    let score = |name: &str| scores.iter().find(|s| s.0 == name).unwrap().1;
    let fixed = score("fixed");
    eprintln!("outage scores: {scores:?}");
    assert!((fixed - 13.46).abs() < 0.1, "fixed: {fixed} (measured 13.457 m)");
    for name in ["iae", "sage-husa"] {
        assert!(score(name) > 1.5 * fixed, "{name}: {} vs fixed {fixed}", score(name));
    }
}
