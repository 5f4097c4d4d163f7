//! A user defines a manifold of their own — the unit sphere S² with a tangent-plane
//! retraction — and runs the public law harness on it, exactly as the project does on
//! its built-in types: a sampler is passed in (no trait to implement, no newtype), and a
//! composite state built with `composite_state!` gets its laws in one line.

use manifolds::testing::Sampler;
use manifolds::{composite_state, Manifold, Tangent, R3};
use nalgebra::{Const, Matrix3x2, Vector2, Vector3};
use proptest::prelude::*;
use proptest::strategy::BoxedStrategy;

/// A unit direction. Tangent basis at `d`: two unit vectors orthogonal to `d`, chosen
/// deterministically. `d ⊕ δ = Exp` along the great circle of `B δ`; `e ⊖ d` is its inverse.
#[derive(Clone, Debug, PartialEq)]
struct Direction(Vector3<f64>);

impl Direction {
    fn basis(&self) -> Matrix3x2<f64> {
        let d = self.0;
        let helper = if d.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
        let b1 = d.cross(&helper).normalize();
        let b2 = d.cross(&b1);
        Matrix3x2::from_columns(&[b1, b2])
    }
}

impl Manifold for Direction {
    type Dim = Const<2>;

    fn origin() -> Self {
        Direction(Vector3::z())
    }

    fn oplus(&self, delta: &Vector2<f64>) -> Self {
        let v = self.basis() * delta;
        let t = v.norm();
        if t < 1e-12 {
            return Direction((self.0 + v).normalize());
        }
        Direction((self.0 * t.cos() + v * (t.sin() / t)).normalize())
    }

    fn ominus(&self, origin: &Self) -> Vector2<f64> {
        let c = origin.0.dot(&self.0).clamp(-1.0, 1.0);
        let perp = self.0 - origin.0 * c;
        let s = perp.norm();
        if s < 1e-15 {
            return Vector2::zeros();
        }
        let angle = s.atan2(c);
        origin.basis().transpose() * (perp * (angle / s))
    }

    fn is_finite(&self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }
    // Jacobians: the trait's numerical defaults; the harness still checks the laws.
}

fn direction_sampler() -> Sampler<Direction> {
    let points = prop::array::uniform3(-1.0f64..1.0)
        .prop_filter("not tiny", |a| a.iter().map(|v| v * v).sum::<f64>() > 1e-2)
        .prop_map(|a| Direction(Vector3::new(a[0], a[1], a[2]).normalize()))
        .boxed();
    let tangents: BoxedStrategy<Tangent<Direction>> = prop::array::uniform2(-2.0f64..2.0)
        .prop_filter("inside the chart", |a| (a[0] * a[0] + a[1] * a[1]).sqrt() < 3.0)
        .prop_map(|a| Vector2::new(a[0], a[1]))
        .boxed();
    Sampler::new(points, tangents).with_boundary(vec![
        Vector2::new(core::f64::consts::PI - 1e-3, 0.0),
        Vector2::new(0.0, -(core::f64::consts::PI - 1e-3)),
    ])
}

const TOL: manifolds::testing::LawTolerance =
    manifolds::testing::LawTolerance { law: 1e-9, jacobian: 1e-5, step: 1e-6 };

manifolds::manifold_law_tests!(direction_laws, Direction, sampler = direction_sampler(), tol = TOL);

composite_state! {
    /// A pointing state: a direction and an angular rate.
    struct Pointing {
        dir: Direction => DIR,
        rate: R3 => RATE,
    }
}

// The composite's laws: one line, the built-in part sampled by `Sampler::of()`.
manifolds::manifold_law_tests!(
    pointing_laws,
    Pointing,
    sampler = Pointing::law_sampler(direction_sampler(), Sampler::of()),
    tol = TOL
);
