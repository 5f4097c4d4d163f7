//! The adaptation hook: a small test strategy scales P⁻, replaces R, rejects, adjusts Q
//! and keeps per-stream state; the filter applies and reports every decision.

#![allow(non_snake_case)]

use crate::common;

use common::close;
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{
    Adaptation, ErrorStateFilter, FilterAlloc, FixedNoise, NoiseStrategy, PriorScaling, QAdjust,
    StreamId, StreamMap, UpdateLog, Verdict,
};
use nalgebra::{DefaultAllocator, DimName, Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

/// Rejects when NIS > gate; on the 2nd, 4th … update of *each stream* doubles R and
/// scales P⁻ by 1.5; counts updates per stream.
#[derive(Clone, Default)]
struct TestStrategy {
    gate: f64,
    counts: StreamMap<u32>,
    scaling: PriorScaling,
}

impl NoiseStrategy for TestStrategy {
    fn name(&self) -> &'static str {
        "test"
    }
    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let n = self.counts.get_or_insert_with(a.stream, || 0);
        *n += 1;
        if a.nis > self.gate {
            a.verdict = Verdict::Rejected;
            a.reason = "nis above gate";
        } else if n.is_multiple_of(2) {
            a.R = a.R_nominal * 2.0;
            a.prior_scale = 1.5;
            a.prior_scaling = self.scaling;
            a.verdict = Verdict::Inflated;
            a.reason = "even update";
            a.factors.lambda_p = 1.5;
            a.factors.lambda_r = 2.0;
            a.q = QAdjust::Scale(3.0);
        }
    }
}

fn pos() -> LinearMeasurement<1, 2> {
    LinearMeasurement::new(Matrix1x2::new(1.0, 0.0)).on_stream("pos")
}
fn vel() -> LinearMeasurement<1, 2> {
    LinearMeasurement::new(Matrix1x2::new(0.0, 1.0)).on_stream("vel")
}

#[test]
fn fixed_noise_is_zero_sized() {
    assert_eq!(core::mem::size_of::<FixedNoise>(), 0);
}

#[test]
fn inflation_equals_an_update_with_scaled_prior_and_noise() {
    let p0 = Matrix2::new(2.0, 0.3, 0.3, 1.0);
    let x0 = Vector2::new(0.5, -0.2);
    let r = Matrix1::new(0.4);
    let strategy = TestStrategy { gate: 1e9, scaling: PriorScaling::Full, ..Default::default() };
    let mut f = ErrorStateFilter::new(x0, p0, strategy).unwrap();
    let rep1 = f.update(&pos(), &Vector1::new(1.0), &r).unwrap();
    assert_eq!(rep1.verdict, Verdict::Accepted);
    let after_first = *f.covariance();
    let x_first = *f.state();
    let rep2 = f.update(&pos(), &Vector1::new(1.2), &r).unwrap();
    assert_eq!(rep2.verdict, Verdict::Inflated);
    assert_eq!(rep2.reason, "even update");
    assert!((rep2.factors.lambda_p - 1.5).abs() < 1e-15);

    // The same second update done by hand with a fixed filter on 1.5·P and 2·R.
    let mut reference = ErrorStateFilter::new(x_first, after_first * 1.5, FixedNoise).unwrap();
    reference.update(&pos(), &Vector1::new(1.2), &(r * 2.0)).unwrap();
    assert!(close(f.state(), reference.state(), 1e-12));
    assert!(close(&f.covariance(), &reference.covariance(), 1e-12));

    // The requested Q scaling applies to the following predictions.
    let q = Matrix2::identity() * 0.1;
    let process = LinearProcess { F: Matrix2::identity(), Q: q };
    let before = *f.covariance();
    f.predict(&process, &(), 1.0).unwrap();
    assert!(close(&f.covariance(), &(before + q * 3.0), 1e-12));
}

#[test]
fn rejection_leaves_state_and_covariance_and_is_reported() {
    let mut f = ErrorStateFilter::new(
        Vector2::zeros(),
        Matrix2::identity(),
        TestStrategy { gate: 4.0, ..Default::default() },
    )
    .unwrap();
    let mut log = UpdateLog::default();
    let rep =
        f.update_observed(&pos(), &Vector1::new(100.0), &Matrix1::new(1.0), &mut log).unwrap();
    assert_eq!(rep.verdict, Verdict::Rejected);
    assert!((rep.nis - 100.0 * 100.0 / 2.0).abs() < 1e-9);
    assert!(f.state().norm() < 1e-15);
    assert!(close(&f.covariance(), &Matrix2::identity(), 1e-15));
    assert_eq!(log.counts(), (0, 0, 1));
    assert_eq!(log.entries[0].reason, "nis above gate");
    assert_eq!(f.epoch(), 1);
}

#[test]
fn strategy_state_is_kept_per_stream() {
    let mut f = ErrorStateFilter::new(
        Vector2::zeros(),
        Matrix2::identity(),
        TestStrategy { gate: 1e9, ..Default::default() },
    )
    .unwrap();
    let mut log = UpdateLog::default();
    let r = Matrix1::new(1.0);
    // pos, vel, pos, vel: each stream sees its own 1st and 2nd update.
    for m in [pos(), vel(), pos(), vel()] {
        f.update_observed(&m, &Vector1::new(0.1), &r, &mut log).unwrap();
    }
    let verdicts: Vec<_> = log.entries.iter().map(|e| e.verdict).collect();
    assert_eq!(
        verdicts,
        [Verdict::Accepted, Verdict::Accepted, Verdict::Inflated, Verdict::Inflated]
    );
    assert_eq!(f.strategy().counts.len(), 2);
    assert_eq!(f.strategy().counts.get(StreamId::named("pos")), Some(&2));
    assert_ne!(log.entries[0].stream, log.entries[1].stream);
}

/// A strategy that breaks the contract (NaN R) makes the update fail cleanly.
#[derive(Clone)]
struct Broken;
impl NoiseStrategy for Broken {
    fn name(&self) -> &'static str {
        "broken"
    }
    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        a.R[(0, 0)] = f64::NAN;
        a.verdict = Verdict::Inflated;
    }
}

#[test]
fn contract_breaking_strategy_gives_typed_error_and_unchanged_filter() {
    let mut f = ErrorStateFilter::new(Vector2::new(1.0, 2.0), Matrix2::identity(), Broken).unwrap();
    let e = f.update(&pos(), &Vector1::new(0.0), &Matrix1::new(1.0)).unwrap_err();
    assert_eq!(e, estimator_core::FilterError::NonFinite { what: "adapted measurement noise R*" });
    assert!((f.state() - Vector2::new(1.0, 2.0)).norm() < 1e-15);
    assert!(close(&f.covariance(), &Matrix2::identity(), 1e-15));
}

#[test]
fn subspace_scaling_gives_the_full_scaling_correction_without_inflating_unseen_directions() {
    // State (position, velocity, an unobserved bias); only position is measured.
    use nalgebra::{Matrix1x3, Matrix3, Vector3};
    let p0 = Matrix3::new(2.0, 0.3, 0.1, 0.3, 1.0, 0.0, 0.1, 0.0, 5.0);
    let x0 = Vector3::new(0.5, -0.2, 0.0);
    let sensor = LinearMeasurement::new(Matrix1x3::new(1.0, 0.0, 0.0));
    let r = Matrix1::new(0.4);
    let z = Vector1::new(1.7);
    let run = |scaling| {
        let strategy = TestStrategy { gate: 1e9, scaling, ..Default::default() };
        let mut f = ErrorStateFilter::new(x0, p0, strategy).unwrap();
        f.update(&sensor, &Vector1::new(0.5), &r).unwrap(); // first: accepted
        let before = *f.covariance();
        f.update(&sensor, &z, &r).unwrap(); // second: λ = 1.5
        (before, *f.state(), *f.covariance())
    };
    let (_, x_full, p_full) = run(PriorScaling::Full);
    let (before, x_sub, p_sub) = run(PriorScaling::MeasurementSubspace);
    // Same gain, same correction.
    assert!(close(&x_sub, &x_full, 1e-12));
    // The measured component's posterior agrees; the unobserved bias is not inflated:
    // with subspace scaling its variance can only shrink, with full scaling it grows.
    assert!((p_sub[(0, 0)] - p_full[(0, 0)]).abs() < 1e-12);
    assert!(p_sub[(2, 2)] <= before[(2, 2)] + 1e-12);
    assert!(p_full[(2, 2)] > before[(2, 2)] * 1.4);
}

#[test]
fn a_failed_update_restores_the_strategy() {
    // Broken counts per stream before breaking R: the count must not survive the failure.
    #[derive(Clone, Default)]
    struct CountsThenBreaks(StreamMap<u32>);
    impl NoiseStrategy for CountsThenBreaks {
        fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
        where
            DefaultAllocator: FilterAlloc<N, M>,
        {
            *self.0.get_or_insert_with(a.stream, || 0) += 1;
            if a.nis > 4.0 {
                a.R[(0, 0)] = -1.0;
            }
        }
    }
    let mut f =
        ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), CountsThenBreaks::default())
            .unwrap();
    f.update(&pos(), &Vector1::new(0.1), &Matrix1::new(1.0)).unwrap();
    assert_eq!(f.strategy().0.get(pos().stream), Some(&1));
    let e = f.update(&pos(), &Vector1::new(100.0), &Matrix1::new(1.0)).unwrap_err();
    assert!(matches!(e, estimator_core::FilterError::NotPositiveDefinite { .. }), "{e}");
    assert_eq!(f.strategy().0.get(pos().stream), Some(&1), "the failed update's count stayed");
    assert_eq!(f.strategy().name(), "CountsThenBreaks", "default name: the type's");
}

#[test]
fn a_prior_the_measurement_cannot_see_is_left_as_it_is_and_reported() {
    // A sensor that sees nothing of the state: H P⁻ Hᵀ = 0, so the prior has nothing to
    // scale along the measurement's subspace; it is used as it is (the gain is zero
    // whatever λ is), and the report says so.
    let blind = LinearMeasurement::new(Matrix1x2::new(0.0, 0.0)).on_stream("blind");
    let strategy = TestStrategy { gate: 1e9, ..Default::default() };
    let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), strategy).unwrap();
    let first = f.update(&blind, &Vector1::new(0.0), &Matrix1::new(1.0)).unwrap();
    assert!(!first.prior_scaling_fallback, "first update: λ = 1, nothing scaled");
    let second = f.update(&blind, &Vector1::new(0.0), &Matrix1::new(1.0)).unwrap();
    assert_eq!(second.verdict, Verdict::Inflated);
    assert!(second.prior_scaling_fallback, "nothing to scale along the subspace");
    assert!(second.summary().prior_scaling_fallback);
    assert!((f.covariance()[(1, 1)] - 1.0).abs() < 1e-12, "P unchanged, not scaled whole");
    // with a sensor that sees the state, no fallback
    let third = f.update(&pos(), &Vector1::new(0.0), &Matrix1::new(1.0)).unwrap();
    let fourth = f.update(&pos(), &Vector1::new(0.0), &Matrix1::new(1.0)).unwrap();
    assert!(!third.prior_scaling_fallback && !fourth.prior_scaling_fallback);
}

#[test]
fn a_rank_deficient_measurement_is_scaled_along_what_it_sees() {
    // Two rows that see the same combination: H P Hᵀ has rank 1. The subspace scaling
    // inflates that direction by λ (so H P⁻* Hᵀ = λ H P⁻ Hᵀ) and leaves the unseen one,
    // with no fallback.
    let twice = LinearMeasurement::new(nalgebra::Matrix2::new(1.0, 0.0, 1.0, 0.0));
    let strategy = TestStrategy { gate: 1e9, ..Default::default() };
    let p0 = Matrix2::new(2.0, 0.5, 0.5, 1.0);
    let mut f = ErrorStateFilter::new(Vector2::zeros(), p0, strategy).unwrap();
    f.update(&twice, &Vector2::new(1.0, 1.0), &Matrix2::identity()).unwrap();
    let p1 = f.covariance().into_owned();
    // the second update: λ = 1.5 and R* = 2 R (the test strategy's even update)
    let r = f.update(&twice, &Vector2::new(1.0, 1.0), &Matrix2::identity()).unwrap();
    assert!(!r.prior_scaling_fallback);
    assert_eq!(r.factors.lambda_p, 1.5);
    // the posterior equals the textbook update of P⁻* = P⁻ + (λ − 1) P⁻Hᵀ(HP⁻Hᵀ)⁺HP⁻,
    // here the one-row form P⁻* = P⁻ + (λ − 1) p pᵀ / p₁₁ with p = P⁻ e₁
    let p = p1.column(0).into_owned();
    let prior = p1 + p * p.transpose() * (0.5 / p1[(0, 0)]);
    let h = nalgebra::Matrix2::new(1.0, 0.0, 1.0, 0.0);
    let rr = Matrix2::identity() * 2.0;
    let s = h * prior * h.transpose() + rr;
    let k = prior * h.transpose() * s.try_inverse().unwrap();
    let ikh = Matrix2::identity() - k * h;
    let post = ikh * prior * ikh.transpose() + k * rr * k.transpose();
    assert!((f.covariance().into_owned() - post).abs().max() < 1e-12, "{}", f.covariance());
}

/// A strategy that replaces R by `factor` × R and says "inflated".
#[derive(Clone)]
struct ScaleR(f64);

impl NoiseStrategy for ScaleR {
    fn name(&self) -> &'static str {
        "scale-r"
    }
    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        a.R = a.R_nominal * self.0;
        a.verdict = Verdict::Inflated;
        a.reason = "R scaled";
    }
}

#[test]
fn a_smaller_adapted_noise_is_reported_as_deflated() {
    let (x0, p0, r) = (Vector2::new(0.0, 0.0), Matrix2::identity(), Matrix1::new(1.0));
    for (factor, verdict) in [(4.0, Verdict::Inflated), (0.25, Verdict::Deflated)] {
        let mut f = ErrorStateFilter::new(x0, p0, ScaleR(factor)).unwrap();
        let rep = f.update(&pos(), &Vector1::new(1.0), &r).unwrap();
        assert_eq!(rep.verdict, verdict, "R × {factor}");
        assert_eq!((rep.nis_adapted > rep.nis), factor < 1.0);
    }
    assert_eq!(Verdict::Deflated.as_str(), "deflated");
}
