//! Safety: adversarial innovation sequences (huge, tiny, all zero, alternating sign, long
//! constant bias) fed to every strategy through the filter. After every step R*, Q and P
//! must stay symmetric positive definite and finite: the filter verifies R* and the
//! strategy's P⁻ scale on each update (a violation is an `Err`), and the test checks P and
//! the requested Q adjustment itself.

#![allow(non_snake_case)]

use adaptive::{AnyStrategy, Iae, STRATEGY_NAMES};
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, NoiseStrategy, QAdjust};
use nalgebra::{SMatrix, SVector};
use proptest::prelude::*;

#[derive(Clone, Debug)]
enum Pattern {
    Huge,
    Tiny,
    Zero,
    Alternating,
    ConstantBias,
}

fn measurements(p: &Pattern, scale: f64, n: usize) -> Vec<SVector<f64, 3>> {
    (0..n)
        .map(|k| match p {
            Pattern::Huge => SVector::<f64, 3>::from_element(1e12 * scale),
            Pattern::Tiny => SVector::<f64, 3>::from_element(1e-12 * scale),
            Pattern::Zero => SVector::<f64, 3>::zeros(),
            Pattern::Alternating => {
                SVector::<f64, 3>::from_element(if k % 2 == 0 { 1e3 } else { -1e3 } * scale)
            }
            Pattern::ConstantBias => SVector::<f64, 3>::new(50.0, -20.0, 5.0) * scale,
        })
        .collect()
}

fn is_spd<const N: usize>(m: &SMatrix<f64, N, N>) -> bool {
    let scale = m.abs().max().max(f64::MIN_POSITIVE);
    m.iter().all(|v| v.is_finite())
        && (m - m.transpose()).abs().max() <= 1e-9 * scale
        && m.cholesky().is_some()
}

fn check(strategy: AnyStrategy, pattern: &Pattern, scale: f64) -> Result<(), TestCaseError> {
    let name = strategy.name();
    let H = SMatrix::<f64, 3, 6>::from_fn(|r, c| if r == c { 1.0 } else { 0.0 });
    let mut F = SMatrix::<f64, 6, 6>::identity();
    for i in 0..3 {
        F[(i, i + 3)] = 1.0;
    }
    let process = LinearProcess { F, Q: SMatrix::<f64, 6, 6>::identity() * 1e-3 };
    let sensor = LinearMeasurement::new(H);
    let R = SMatrix::<f64, 3, 3>::identity();
    let mut f =
        ErrorStateFilter::new(SVector::<f64, 6>::zeros(), SMatrix::identity(), strategy).unwrap();
    for (k, z) in measurements(pattern, scale, 120).iter().enumerate() {
        f.predict(&process, &(), 1.0)
            .map_err(|e| TestCaseError::fail(format!("{name} {pattern:?} predict {k}: {e}")))?;
        f.update(&sensor, z, &R)
            .map_err(|e| TestCaseError::fail(format!("{name} {pattern:?} update {k}: {e}")))?;
        prop_assert!(is_spd(&f.covariance()), "{name} {pattern:?}: P not SPD at {k}");
        match f.process_noise_adjustment() {
            QAdjust::AddRate(q) => {
                // Q̂ = K Ĉ Kᵀ is PSD by construction: symmetric, finite, no negative
                // eigenvalue beyond rounding.
                prop_assert!(q.iter().all(|v| v.is_finite()));
                let min = q.symmetric_eigenvalues().min();
                prop_assert!(
                    min >= -1e-9 * q.abs().max().max(1e-300),
                    "{name}: Q eigenvalue {min}"
                );
            }
            QAdjust::Scale(s) => prop_assert!(s.is_finite() && *s > 0.0),
            _ => {}
        }
    }
    Ok(())
}

fn pattern() -> impl Strategy<Value = Pattern> {
    prop_oneof![
        Just(Pattern::Huge),
        Just(Pattern::Tiny),
        Just(Pattern::Zero),
        Just(Pattern::Alternating),
        Just(Pattern::ConstantBias),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn every_strategy_stays_spd_and_finite(
        which in 0..STRATEGY_NAMES.len(),
        p in pattern(),
        scale in prop_oneof![Just(1.0), -1.0f64..1.0, 1e-3f64..1e3],
    ) {
        let s: AnyStrategy = STRATEGY_NAMES[which].parse().unwrap();
        check(s, &p, scale)?;
    }

    #[test]
    fn iae_with_q_adaptation_stays_spd(p in pattern(), scale in 1e-3f64..1e3) {
        check(AnyStrategy::Iae(Iae::default().with_q_adaptation()), &p, scale)?;
    }
}

#[test]
fn every_pattern_for_every_strategy_once() {
    // The exhaustive grid, deterministic, so no combination is left to chance.
    for name in STRATEGY_NAMES {
        for p in [
            Pattern::Huge,
            Pattern::Tiny,
            Pattern::Zero,
            Pattern::Alternating,
            Pattern::ConstantBias,
        ] {
            check(name.parse().unwrap(), &p, 1.0).unwrap();
        }
    }
}
