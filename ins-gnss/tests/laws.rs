//! The manifold law harness on the geodetic position and on the 15- and 21-state INS states: the
//! ⊕/⊖ identities, every analytic Jacobian (including the reset Jacobian and its blocks)
//! against central differences.
//!
//! Differences are taken with 1 mm steps: a geodetic coordinate near 0.5 rad moved by
//! 1e-6 m changes by 1.6e-13 rad, too close to its rounding for a 1e-6 step.

use ins_gnss_core::{GeoPos, InsState};
use manifolds::testing::{arb_rn, arb_rotation_vector, arb_so3, Sampler};
use proptest::prelude::*;
use proptest::strategy::BoxedStrategy;

fn arb_geopos() -> BoxedStrategy<GeoPos> {
    (-1.4..1.4f64, -3.1..3.1f64, -100.0..5000.0f64)
        .prop_map(|(lat, lon, h)| GeoPos::new(lat, lon, h))
        .boxed()
}

fn geopos_sampler() -> Sampler<GeoPos> {
    Sampler::new(arb_geopos(), arb_rn::<3>(1e4))
}

/// The INS state's sampler from one sampler per field (`composite_state!` provides
/// `law_sampler`). No chart-boundary tangents for the attitude: a 1 mm difference step
/// would cross the rotation chart's boundary (π − 1e-4); `So3`'s own law tests cover the
/// boundary with 1e-6 steps.
fn ins_sampler() -> Sampler<InsState> {
    InsState::law_sampler(
        Sampler::new(arb_so3(), arb_rotation_vector(3.0)),
        Sampler::new(arb_rn::<3>(50.0), arb_rn::<3>(10.0)),
        Sampler::new(arb_geopos(), arb_rn::<3>(1e3)),
        Sampler::new(arb_rn::<3>(1e-2), arb_rn::<3>(1e-2)),
        Sampler::new(arb_rn::<3>(1e-1), arb_rn::<3>(1e-2)),
    )
}

const MM: manifolds::testing::LawTolerance =
    manifolds::testing::LawTolerance { law: 1e-9, jacobian: 1e-5, step: 1e-3 };

manifolds::manifold_law_tests!(geopos_laws, GeoPos, sampler = geopos_sampler(), tol = MM);
manifolds::manifold_law_tests!(ins_state_laws, InsState, sampler = ins_sampler(), tol = MM);

/// The 21-state INS state: the 15-state one and two scale-factor vectors.
fn ins21_sampler() -> Sampler<ins_gnss_core::scale::InsState21> {
    ins_gnss_core::scale::InsState21::law_sampler(
        ins_sampler(),
        Sampler::new(arb_rn::<3>(1e-2), arb_rn::<3>(1e-3)),
        Sampler::new(arb_rn::<3>(1e-2), arb_rn::<3>(1e-3)),
    )
}

manifolds::manifold_law_tests!(
    ins_state21_laws,
    ins_gnss_core::scale::InsState21,
    sampler = ins21_sampler(),
    tol = MM
);
