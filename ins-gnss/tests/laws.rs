//! The manifold law harness on the geodetic position and on the 15-state INS state: the
//! ⊕/⊖ identities, every analytic Jacobian (including the reset Jacobian and its blocks)
//! against central differences.
//!
//! Differences are taken with 1 mm steps: a geodetic coordinate near 0.5 rad moved by
//! 1e-6 m changes by 1.6e-13 rad, too close to its rounding for a 1e-6 step.

use ins_gnss::{GeoPos, InsState};
use manifolds::testing::{arb_rn, arb_rotation_vector, arb_so3, concat_tangent, LawSampler};
use manifolds::{Manifold, Tangent};
use proptest::prelude::*;
use proptest::strategy::BoxedStrategy;

fn arb_geopos() -> BoxedStrategy<GeoPos> {
    (-1.4..1.4f64, -3.1..3.1f64, -100.0..5000.0f64)
        .prop_map(|(lat, lon, h)| GeoPos::new(lat, lon, h))
        .boxed()
}

/// A local newtype over `$inner` whose ⊕/⊖ and Jacobians are `$inner`'s (the sampler
/// trait is foreign, and so are the types).
macro_rules! forwarding_manifold {
    ($name:ident, $inner:ty) => {
        #[derive(Clone, Debug)]
        struct $name($inner);

        impl Manifold for $name {
            type Dim = <$inner as Manifold>::Dim;
            fn origin() -> Self {
                $name(<$inner>::origin())
            }
            fn oplus(&self, d: &Tangent<Self>) -> Self {
                $name(self.0.oplus(d))
            }
            fn ominus(&self, o: &Self) -> Tangent<Self> {
                self.0.ominus(&o.0)
            }
            fn is_finite(&self) -> bool {
                self.0.is_finite()
            }
            fn oplus_jacobians(&self, d: &Tangent<Self>) -> manifolds::OplusJacobians<Self> {
                let j = self.0.oplus_jacobians(d);
                manifolds::OplusJacobians { J_y_x: j.J_y_x, J_y_delta: j.J_y_delta }
            }
            fn oplus_jacobian_delta(&self, d: &Tangent<Self>) -> manifolds::TangentMatrix<Self> {
                self.0.oplus_jacobian_delta(d)
            }
            fn reset_blocks(
                &self,
                d: &Tangent<Self>,
                visit: &mut dyn FnMut(usize, nalgebra::DMatrixView<'_, f64>),
            ) {
                self.0.reset_blocks(d, visit)
            }
            fn oplus_reset(
                &self,
                d: &Tangent<Self>,
                visit: &mut dyn FnMut(usize, nalgebra::DMatrixView<'_, f64>),
            ) -> Self {
                $name(self.0.oplus_reset(d, visit))
            }
            fn ominus_jacobians(&self, o: &Self) -> manifolds::OminusJacobians<Self> {
                let j = self.0.ominus_jacobians(&o.0);
                manifolds::OminusJacobians { J_d_y: j.J_d_y, J_d_x: j.J_d_x }
            }
        }
    };
}

forwarding_manifold!(Pos, GeoPos);
forwarding_manifold!(Ins, InsState);

impl LawSampler for Pos {
    fn arb_point() -> BoxedStrategy<Self> {
        arb_geopos().prop_map(Pos).boxed()
    }
    fn arb_tangent() -> BoxedStrategy<Tangent<Self>> {
        arb_rn::<3>(1e4)
    }
}

impl LawSampler for Ins {
    fn arb_point() -> BoxedStrategy<Self> {
        (arb_so3(), arb_rn::<3>(50.0), arb_geopos(), arb_rn::<3>(1e-2), arb_rn::<3>(1e-1))
            .prop_map(|(att, vel, pos, bg, ba)| Ins(InsState { att, vel, pos, bg, ba }))
            .boxed()
    }
    fn arb_tangent() -> BoxedStrategy<Tangent<Self>> {
        (arb_rotation_vector(3.0), arb_rn::<3>(10.0), arb_rn::<3>(1e3), arb_rn::<6>(1e-2))
            .prop_map(|(a, v, p, b)| {
                concat_tangent::<Self>(&[a.as_slice(), v.as_slice(), p.as_slice(), b.as_slice()])
            })
            .boxed()
    }
    // No chart-boundary tangents: a 1 mm difference step would cross the rotation chart's
    // boundary (π − 1e-4); `So3`'s own law tests cover the boundary with 1e-6 steps.
}

const MM: manifolds::testing::LawTolerance =
    manifolds::testing::LawTolerance { law: 1e-9, jacobian: 1e-5, step: 1e-3 };

manifolds::manifold_law_tests!(geopos_laws, Pos, MM);
manifolds::manifold_law_tests!(ins_state_laws, Ins, MM);
