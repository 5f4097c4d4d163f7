//! The adaptive layer's promise as property tests: over random models of two shapes here
//! (a user's attitude filter, SO(3) × R³ with unit-vector measurements whose `H P Hᵀ` is
//! rank-deficient; constant velocity with a redundant row) and the INS in the umbrella's
//! `tests/strategy_invariant.rs`, with mismatched noise, disturbances and outliers, every
//! strategy with and without the gross-error gate:
//!
//! - `P` symmetric positive definite after every prediction and update, and no step
//!   refused (the invariant could also hold by refusing: these models must not need it);
//! - no fallback of the subspace scaling (a rank-deficient `H P Hᵀ` is no fallback);
//! - behind the gate, the guarded strategies' NEES bounded (mean ≤ 5× the dimension);
//! - and, as a rate over a fixed corpus of the same random cases, the guarded fading
//!   strategies rarely far worse than the fixed filter, where the faithful ones often are.
//!
//! Reverted to the Cholesky solve of `H B Hᵀ` (the subspace scaling before the pivoted
//! elimination), the attitude property fails at once: `afkf` leaves P with a negative
//! eigenvalue or the subspace scaling falls back (`docs/history/results.md`).

#![allow(non_snake_case)]

#[path = "common/attitude.rs"]
mod attitude;
use crate::common;

use adaptive::{AnyStrategy, GrossErrorGate, STRATEGY_NAMES};
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, NoiseStrategy};
use nalgebra::{SMatrix, SVector};
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

fn behind<A: NoiseStrategy>(s: A, gated: bool) -> GrossErrorGate<A> {
    if gated {
        GrossErrorGate::new(s, 1e-6, 10)
    } else {
        GrossErrorGate::disabled(s)
    }
}

fn faithful(name: &str) -> bool {
    name.ends_with("-faithful")
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10, .. ProptestConfig::default() })]

    #[test]
    fn attitude_filter_keeps_p_positive_definite(
        seed in 0u64..10_000,
        true_sigma_factor in 0.3f64..3.0,
        disturbance_factor in 1.0f64..20.0,
        outliers in 0usize..8,
        rate in 0.05f64..1.5,
    ) {
        let sc = attitude::Scenario {
            duration: 30.0,
            imu_hz: 50.0,
            true_sigma_factor,
            disturbance: (10.0, 20.0),
            disturbance_factor,
            outliers,
            rate,
            seed,
            ..attitude::Scenario::default()
        };
        let data = attitude::simulate(&sc);
        for name in STRATEGY_NAMES {
            for gated in [false, true] {
                let s: AnyStrategy = name.parse().unwrap();
                let mut bad = None;
                let out = attitude::run(behind(s, gated), &sc, &data, 5.0, |step, k, p| {
                    if bad.is_none() && !attitude::is_pd(p) {
                        bad = Some(format!("{step} {k}: {p}"));
                    }
                });
                prop_assert!(bad.is_none(), "{name} gated={gated}: P not PD after {}", bad.unwrap());
                prop_assert_eq!(out.errors, 0, "{} gated={}: {:?}", name, gated, out.first_error);
                prop_assert_eq!(out.fallbacks, 0, "{} gated={}: subspace fallbacks", name, gated);
                if gated && !faithful(name) && true_sigma_factor <= 1.5 {
                    prop_assert!(out.nees <= 30.0, "{} gated: NEES {:.1}", name, out.nees);
                }
            }
        }
    }

    #[test]
    fn constant_velocity_with_a_redundant_row_keeps_p_positive_definite(
        seed in 0u64..10_000,
        q_true_factor in 0.1f64..30.0,
        sigma_factor in 0.2f64..5.0,
        outlier_rate in 0.0f64..0.2,
        step_factor in 1.0f64..50.0,
    ) {
        // position x, y, z and x again: H P Hᵀ has rank 3 of 4
        let H = SMatrix::<f64, 4, 6>::from_fn(|r, c| if c == r % 3 { 1.0 } else { 0.0 });
        let dt = 1.0;
        let process = LinearProcess { F: common::F(dt), Q: common::Q(dt, 0.002) };
        let R = SMatrix::<f64, 4, 4>::identity();
        let mut rng = StdRng::seed_from_u64(seed);
        let lq = common::Q(dt, 0.002 * q_true_factor).cholesky().unwrap().l();
        let mut x = SVector::<f64, 6>::from_column_slice(&[0.0, 0.0, 0.0, 5.0, -2.0, 1.0]);
        let mut zs = Vec::new();
        for k in 0..150 {
            x = common::F(dt) * x + lq * SVector::<f64, 6>::from_fn(|_, _| rng.sample(StandardNormal));
            let sigma = sigma_factor * if k >= 75 { step_factor.sqrt() } else { 1.0 };
            let mut v = SVector::<f64, 4>::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal) * sigma);
            if rng.random::<f64>() < outlier_rate {
                v += SVector::<f64, 4>::repeat(50.0);
            }
            zs.push(H * x + v);
        }
        let sensor = LinearMeasurement::new(H);
        for name in STRATEGY_NAMES {
            for gated in [false, true] {
                let s: AnyStrategy = name.parse().unwrap();
                let mut f = ErrorStateFilter::new(SVector::<f64, 6>::zeros(), SMatrix::identity() * 10.0, behind(s, gated)).unwrap();
                for (k, z) in zs.iter().enumerate() {
                    f.predict(&process, &(), dt).map_err(|e| TestCaseError::fail(format!("{name} predict {k}: {e}")))?;
                    prop_assert!(attitude::is_pd(&f.covariance()), "{} gated={}: P after predict {}", name, gated, k);
                    let r = f.update(&sensor, z, &R).map_err(|e| TestCaseError::fail(format!("{name} update {k}: {e}")))?;
                    prop_assert!(!r.prior_scaling_fallback, "{} gated={}: fallback at {}", name, gated, k);
                    prop_assert!(attitude::is_pd(&f.covariance()), "{} gated={}: P after update {}", name, gated, k);
                }
            }
        }
    }
}

/// Graceful degradation, judged as a rate: over 40 cases of the random corpus (a fixed
/// seed), every guarded fading strategy behind the gate has an attitude RMS beyond 3× the
/// fixed filter's in at most 2 (5 %); Xia's AFKF as written does in most (the law tells
/// the two apart). Over 1,000 cases (`cargo run --release -p adaptive --example
/// attitude_corpus 1000`): afkf 28, fused-nominal 5, fused 0, against afkf-faithful 907.
#[test]
fn guarded_fading_degrades_gracefully_over_a_corpus() {
    use rand::SeedableRng;
    let names = ["afkf", "fused", "fused-nominal", "iae-qr", "afkf-faithful"];
    let mut rng = StdRng::seed_from_u64(70);
    let cases = 40;
    let mut beyond = [0usize; 5];
    for _ in 0..cases {
        let sc = attitude::corpus_case(&mut rng);
        let data = attitude::simulate(&sc);
        let fixed =
            attitude::run(behind(adaptive::FixedNoise, true), &sc, &data, 5.0, |_, _, _| {});
        for (b, name) in beyond.iter_mut().zip(names) {
            let s: AnyStrategy = name.parse().unwrap();
            let out = attitude::run(behind(s, true), &sc, &data, 5.0, |_, _, _| {});
            *b += usize::from(out.rms_deg > 3.0 * fixed.rms_deg.max(0.2));
        }
    }
    eprintln!(
        "beyond 3× fixed over {cases} cases: {:?}",
        names.iter().zip(beyond).collect::<Vec<_>>()
    );
    for (name, b) in names.iter().zip(beyond).take(4) {
        assert!(b <= 2, "{name}: {b} of {cases} runs beyond 3× the fixed filter");
    }
    assert!(beyond[4] >= cases / 2, "afkf-faithful: {} of {cases}", beyond[4]);
}

/// The typed error: a model whose own covariance propagation breaks `P` (a structured
/// `Φ P Φᵀ + Q` with a slip, here an indefinite result with a positive diagonal) is caught
/// at the first step a strategy touched — the prediction a fading strategy scaled, the
/// update whose `R` a strategy changed — with `CovarianceLost` naming the step and the
/// strategy, and the filter is left as it was. (A plain step is checked on its diagonal
/// only: it is positive definite by construction; the model's slip is
/// `harness::check_combined_calls`'s to find.)
#[test]
fn a_step_that_would_lose_positive_definiteness_is_refused_and_undone() {
    use estimator_core::{
        Adaptation, FilterAlloc, FilterError, ProcessJacobians, ProcessModel, Verdict,
    };
    use nalgebra::{DefaultAllocator, DimName, Matrix2, Vector2, U2};
    struct Slips;
    impl ProcessModel for Slips {
        type State = Vector2<f64>;
        type Input = ();
        fn propagate(&self, x: &Vector2<f64>, _: &(), _: f64) -> Vector2<f64> {
            *x
        }
        fn jacobians(&self, _: &Vector2<f64>, _: &(), _: f64) -> ProcessJacobians<U2> {
            ProcessJacobians { Phi: Matrix2::identity(), Q: Matrix2::zeros() }
        }
        fn propagate_covariance(
            &self,
            _: &Matrix2<f64>,
            _: &ProcessJacobians<U2>,
            out: &mut Matrix2<f64>,
        ) {
            // eigenvalues 3 and −1
            *out = Matrix2::new(1.0, 2.0, 2.0, 1.0);
        }
    }
    /// Doubles `R`: a strategy that changes the update.
    #[derive(Clone)]
    struct DoublesR;
    impl NoiseStrategy for DoublesR {
        fn name(&self) -> &'static str {
            "doubles-r"
        }
        fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
        where
            DefaultAllocator: FilterAlloc<N, M>,
        {
            a.R = a.R_nominal * 2.0;
            a.verdict = Verdict::Inflated;
        }
    }
    let lost = |e: FilterError| match e {
        FilterError::CovarianceLost { step, strategy } => (step, strategy),
        other => panic!("another error: {other}"),
    };
    // a fading strategy touched the prediction: checked there
    let mut f = ErrorStateFilter::new(
        Vector2::zeros(),
        Matrix2::identity(),
        adaptive::Afkf::fading_memory(1.1),
    )
    .unwrap();
    let e = f.predict(&Slips, &(), 0.1).unwrap_err();
    assert_eq!(lost(e.clone()), ("prediction", "afkf"));
    assert_eq!(f.covariance().into_owned(), Matrix2::identity(), "left as it was");
    assert_eq!(f.time(), 0.0);
    let text = e.to_string();
    assert!(text.contains("afkf") && text.contains("unchanged"), "{text}");
    // a plain prediction passes its diagonal check; the update a strategy changes is
    // checked in full and refused
    let mut g = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), DoublesR).unwrap();
    g.predict(&Slips, &(), 0.1).unwrap();
    let sensor = LinearMeasurement::<1, 2>::new(nalgebra::Matrix1x2::new(1.0, 0.0));
    let before = (*g.state(), g.covariance().into_owned());
    let e =
        g.update(&sensor, &nalgebra::Vector1::new(0.5), &nalgebra::Matrix1::new(1.0)).unwrap_err();
    assert_eq!(lost(e), ("update", "doubles-r"));
    assert_eq!((*g.state(), g.covariance().into_owned()), before, "left as it was");
}
