//! SO(2), planar rotations (headings, bearings), stored as an angle in (−π, π].
//!
//! `θ ⊕ δ = wrap(θ + δ)`, `φ ⊖ θ = wrap(φ − θ)`: the group is commutative, so left and
//! right perturbations coincide and every Jacobian of ⊕/⊖ is ±1.

use core::f64::consts::PI;

use nalgebra::{Const, Matrix1, Matrix2, Vector1};

use crate::traits::{Manifold, OminusJacobians, OplusJacobians};
// without `std`, the floats' functions (sin_cos) are nalgebra's (libm)
#[cfg(not(feature = "std"))]
use nalgebra::ComplexField as _;

/// Wrap an angle into (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    if a > -PI && a <= PI {
        return a;
    }
    // (`f64::rem_euclid`, which `core` lacks, spelled out: the same numbers)
    let m = 2.0 * PI;
    let r = (a + PI) % m;
    let w = if r < 0.0 { r + m } else { r } - PI;
    if w <= -PI {
        w + 2.0 * PI
    } else {
        w
    }
}

/// A planar rotation by `angle` (radians, kept in (−π, π]).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct So2 {
    angle: f64,
}

impl So2 {
    /// From an angle in radians (wrapped).
    pub fn new(angle: f64) -> Self {
        Self { angle: wrap_angle(angle) }
    }

    /// The angle in (−π, π].
    pub fn angle(&self) -> f64 {
        self.angle
    }

    /// The rotation matrix.
    pub fn matrix(&self) -> Matrix2<f64> {
        let (s, c) = self.angle.sin_cos();
        Matrix2::new(c, -s, s, c)
    }
}

impl Manifold for So2 {
    type Dim = Const<1>;

    fn origin() -> Self {
        Self { angle: 0.0 }
    }

    fn oplus(&self, delta: &Vector1<f64>) -> Self {
        Self::new(self.angle + delta.x)
    }

    fn ominus(&self, origin: &Self) -> Vector1<f64> {
        Vector1::new(wrap_angle(self.angle - origin.angle))
    }

    fn is_finite(&self) -> bool {
        self.angle.is_finite()
    }

    fn oplus_jacobians(&self, _delta: &Vector1<f64>) -> OplusJacobians<Self> {
        OplusJacobians { J_y_x: Matrix1::identity(), J_y_delta: Matrix1::identity() }
    }

    fn ominus_jacobians(&self, _origin: &Self) -> OminusJacobians<Self> {
        OminusJacobians { J_d_y: Matrix1::identity(), J_d_x: -Matrix1::identity() }
    }
}
