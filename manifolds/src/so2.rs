//! SO(2), planar rotations (headings, bearings), stored as an angle in (−π, π].
//!
//! `θ ⊕ δ = wrap(θ + δ)`, `φ ⊖ θ = wrap(φ − θ)`: the group is commutative, so left and
//! right perturbations coincide and every Jacobian of ⊕/⊖ is ±1.

use nalgebra::{Const, Matrix1, Matrix2, Vector1};

use crate::coeffs::Coeffs;
use crate::scalar::Real;
use crate::traits::{Manifold, OminusJacobians, OplusJacobians};

/// Wrap an angle into (−π, π].
pub fn wrap_angle<T: Real>(a: T) -> T {
    let pi = T::pi();
    if a > -pi && a <= pi {
        return a;
    }
    // (`f64::rem_euclid`, which `core` lacks, spelled out: the same numbers)
    let m = T::two_pi();
    let r = (a + pi) % m;
    let w = if r < T::zero() { r + m } else { r } - pi;
    if w <= -pi {
        w + T::two_pi()
    } else {
        w
    }
}

/// A planar rotation by `angle` (radians, kept in (−π, π]), over `f64` unless named.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct So2<T: Real = f64> {
    angle: T,
}

impl<T: Real> So2<T> {
    /// From an angle in radians (wrapped).
    pub fn new(angle: T) -> Self {
        Self { angle: wrap_angle(angle) }
    }

    /// The angle in (−π, π].
    pub fn angle(&self) -> T {
        self.angle
    }

    /// The same rotation over another scalar (the angle rounded to it, then wrapped).
    pub fn cast<U: Real>(&self) -> So2<U> {
        So2::new(U::lit(self.angle.to_f64()))
    }

    /// The rotation matrix.
    pub fn matrix(&self) -> Matrix2<T> {
        let (s, c) = self.angle.sin_cos();
        Matrix2::new(c, -s, s, c)
    }
}

impl<T: Real> Manifold<T> for So2<T> {
    type Dim = Const<1>;

    fn origin() -> Self {
        Self { angle: T::zero() }
    }

    fn oplus(&self, delta: &Vector1<T>) -> Self {
        Self::new(self.angle + delta.x)
    }

    fn ominus(&self, origin: &Self) -> Vector1<T> {
        Vector1::new(wrap_angle(self.angle - origin.angle))
    }

    fn is_finite(&self) -> bool {
        self.angle.is_finite()
    }

    fn oplus_jacobians(&self, _delta: &Vector1<T>) -> OplusJacobians<Self, T> {
        OplusJacobians { J_y_x: Matrix1::identity(), J_y_delta: Matrix1::identity() }
    }

    fn ominus_jacobians(&self, _origin: &Self) -> OminusJacobians<Self, T> {
        OminusJacobians { J_d_y: Matrix1::identity(), J_d_x: -Matrix1::identity() }
    }
}

// (here, where the angle is reachable as stored: `So2::new` would wrap it again)
impl<T: Real> Coeffs<T> for So2<T> {
    /// The angle, rad, in (−π, π].
    const LEN: usize = 1;
    fn coeffs(&self, out: &mut [T]) {
        out[0] = self.angle();
    }
    fn from_coeffs(c: &[T]) -> Self {
        Self { angle: c[0] }
    }
}
