//! The fused dual-window filter's readings of what the paper leaves open
//! (ALGORITHMS.md §2.4), each checked on fixed inputs against its defining formula.

use adaptive::{AnyStrategy, FusedDualWindow, GrossTest, RReading};
use estimator_core::{
    Adaptation, CovView, NoiseStrategy, PriorScaling, QAdjust, StreamId, Verdict,
};
use nalgebra::{Matrix2, Matrix3, Vector3};

/// One decision of `s` on innovation `r` with `H P⁻ Hᵀ = hph·I` and `R₀ = I`:
/// (verdict, factor on R₀, λ_P).
fn decide(s: &mut FusedDualWindow, r: Vector3<f64>, hph: f64) -> (Verdict, f64, f64) {
    let h = nalgebra::SMatrix::<f64, 3, 2>::zeros();
    let p = Matrix2::<f64>::identity();
    let hpht = Matrix3::identity() * hph;
    let r0 = Matrix3::identity();
    let s_nom = hpht + r0;
    let mut a = Adaptation {
        stream: StreamId::named("gnss"),
        epoch: 1,
        time: 0.0,
        innovation: &r,
        H: &h,
        P_prior: CovView::new(&p),
        HPHt: &hpht,
        HQHt: None,
        R_nominal: &r0,
        S: &s_nom,
        nis: r.norm_squared() / (1.0 + hph),
        prior_scale: 1.0,
        prior_scaling: PriorScaling::default(),
        scale_propagated_only: false,
        R: r0,
        verdict: Verdict::Accepted,
        reason: "",
        factors: Default::default(),
        q: QAdjust::Keep,
        not_helping: false,
    };
    s.adapt(&mut a);
    (a.verdict, a.R[(0, 0)], a.prior_scale)
}

#[test]
fn nominal_reading_scales_r0_afresh_and_cumulative_converges_to_the_iae_estimate() {
    // |r|² = 27 every epoch: tr Ĉ = 27, H P⁻ Hᵀ = 2 I, R₀ = I
    let r = Vector3::new(3.0, 3.0, 3.0);
    let mut nominal = FusedDualWindow::default().with_r_reading(RReading::Nominal);
    let mut cumulative = FusedDualWindow::default();
    assert_eq!(cumulative.r_reading, RReading::Cumulative, "the default reading");
    nominal.gross_error_dom = 1e9;
    cumulative.gross_error_dom = 1e9;
    let mut last = (0.0, 0.0);
    for _ in 0..60 {
        let (_, f_nom, _) = decide(&mut nominal, r, 2.0);
        let (_, f_cum, _) = decide(&mut cumulative, r, 2.0);
        last = (f_nom, f_cum);
    }
    // nominal: λ_R = tr Ĉ / tr(H P⁻ Hᵀ + R₀) = 27 / 9 = 3, the same at every epoch
    assert!((last.0 - 3.0).abs() < 1e-12, "{}", last.0);
    // cumulative: f_k = f_{k−1} · 27 / (6 + 3 f_{k−1}) → the fixed point 3 f = 27 − 6,
    // i.e. tr R* = tr(Ĉ − H P⁻ Hᵀ): the IAE estimate of R
    assert!((last.1 - 7.0).abs() < 1e-6, "{}", last.1);
}

#[test]
fn window_test_and_censoring_change_what_a_burst_does() {
    let small = Vector3::new(0.5, 0.5, 0.5);
    let big = Vector3::new(6.0, 6.0, 6.0); // |r|²/tr S = 108/6 = 18 > 10
    let run = |mut s: FusedDualWindow| {
        s.max_consecutive_rejections = 100;
        for _ in 0..29 {
            decide(&mut s, small, 1.0);
        }
        decide(&mut s, big, 1.0)
    };
    // single-epoch test: the burst is a gross error
    let nominal = || FusedDualWindow::default().with_r_reading(RReading::Nominal);
    assert_eq!(run(nominal()).0, Verdict::Rejected);
    // window test: 29 small and one big innovation average (29·0.75 + 108)/30 / 6 = 0.72
    let w = run(nominal().with_gross_test(GrossTest::Window));
    assert_eq!(w.0, Verdict::Inflated);
    // censoring: a refused innovation kept out of the windows leaves λ_R where it was;
    // let into them, it raises it at the next epoch
    let next = |uncensored: bool| {
        let mut s = nominal().with_refused_in_windows(uncensored);
        for _ in 0..29 {
            decide(&mut s, small, 1.0);
        }
        decide(&mut s, big, 1.0);
        decide(&mut s, small, 1.0).1
    };
    let (censored, uncensored) = (next(false), next(true));
    assert!(uncensored > 3.0 * censored, "censored {censored}, uncensored {uncensored}");
}

#[test]
fn every_reading_has_a_name() {
    for (name, r, g, w) in [
        ("fused", RReading::Cumulative, GrossTest::SingleEpoch, false),
        ("fused-cumulative", RReading::Cumulative, GrossTest::SingleEpoch, false),
        ("fused-nominal", RReading::Nominal, GrossTest::SingleEpoch, false),
        ("fused-window-test", RReading::Cumulative, GrossTest::Window, false),
        ("fused-uncensored", RReading::Cumulative, GrossTest::SingleEpoch, true),
        ("fused-nominal-uncensored", RReading::Nominal, GrossTest::SingleEpoch, true),
    ] {
        let AnyStrategy::Fused(f) = name.parse::<AnyStrategy>().unwrap() else { panic!("{name}") };
        assert_eq!((f.r_reading, f.gross_test, f.refused_in_windows), (r, g, w), "{name}");
    }
    let AnyStrategy::Iae(iae) = "iae-qr".parse::<AnyStrategy>().unwrap() else { panic!() };
    assert!(iae.adapt_q, "iae-qr adapts Q and R (the paper's IAE)");
    let AnyStrategy::Iae(iae) = "iae".parse::<AnyStrategy>().unwrap() else { panic!() };
    assert!(!iae.adapt_q, "iae adapts R only");
}
