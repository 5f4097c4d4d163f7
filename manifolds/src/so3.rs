//! SO(3), the rotation group, on a unit quaternion.
//!
//! Error definition (right / body-frame perturbation): `R_true = R̂ · Exp(δθ)`, so `δθ`
//! is expressed in the body frame of `R̂` (Solà, Deray & Atchuthan, "A micro Lie theory
//! for state estimation in robotics", 2018, eq. 25–26 with the right ⊕).

use core::ops::Mul;

use nalgebra::{Const, Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

use crate::scalar::Real;
use crate::traits::{Manifold, OminusJacobians, OplusJacobians};

// Below `T::SMALL_ANGLE` (1e-2 in f64) the closed forms lose digits to cancellation and the
// Taylor series (accurate to `θ⁶`, ≈ 1e-12 relative at 1e-2, far better in practice) are
// used.

/// A rotation, stored as a unit quaternion (`R_ab`: maps frame-`b` vectors into frame `a`),
/// over `f64` unless named.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct So3<T: Real = f64> {
    q: UnitQuaternion<T>,
}

/// Skew-symmetric matrix `[v×]` with `[v×] w = v × w`.
#[inline]
pub fn hat<T: Real>(v: &Vector3<T>) -> Matrix3<T> {
    let z = T::zero();
    Matrix3::new(z, -v.z, v.y, v.z, z, -v.x, -v.y, v.x, z)
}

/// The quaternion of `Exp(φ)`, `(cos(θ/2), sin(θ/2) φ/θ)`, before normalisation (unit
/// to rounding): callers that multiply it into a product normalise once at the end.
#[inline]
fn exp_quaternion<T: Real>(phi: &Vector3<T>) -> Quaternion<T> {
    let c = T::lit;
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let (w, k) = if t < T::SMALL_ANGLE {
        // sin(θ/2)/θ = ½ − θ²/48 + θ⁴/3840
        (c(1.0) - t2 / c(8.0) + t2 * t2 / c(384.0), c(0.5) - t2 / c(48.0) + t2 * t2 / c(3840.0))
    } else {
        ((c(0.5) * t).cos(), (c(0.5) * t).sin() / t)
    };
    Quaternion::new(w, k * phi.x, k * phi.y, k * phi.z)
}

/// Right Jacobian of SO(3), `Jr(φ)`: `Exp(φ + δ) ≈ Exp(φ) Exp(Jr(φ) δ)`.
///
/// `Jr(φ) = I − (1 − cos θ)/θ² [φ×] + (θ − sin θ)/θ³ [φ×]²`, θ = |φ|.
#[inline]
pub fn right_jacobian<T: Real>(phi: &Vector3<T>) -> Matrix3<T> {
    let c = T::lit;
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let (a, b) = if t < T::SMALL_ANGLE {
        (
            c(0.5) - t2 / c(24.0) + t2 * t2 / c(720.0),
            c(1.0) / c(6.0) - t2 / c(120.0) + t2 * t2 / c(5040.0),
        )
    } else {
        let s = (c(0.5) * t).sin();
        (c(2.0) * s * s / t2, (t - t.sin()) / (t2 * t))
    };
    let K = hat(phi);
    Matrix3::identity() - K * a + K * K * b
}

/// Inverse of the right Jacobian, `Jr⁻¹(φ) = I + ½[φ×] + (1/θ² − cot(θ/2)/(2θ)) [φ×]²`.
///
/// The `cot(θ/2)` form stays accurate up to θ → π (where `1 + cos θ` and `sin θ` would
/// both vanish).
pub fn right_jacobian_inverse<T: Real>(phi: &Vector3<T>) -> Matrix3<T> {
    let l = T::lit;
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let c = if t < T::SMALL_ANGLE {
        l(1.0) / l(12.0) + t2 / l(720.0) + t2 * t2 / l(30240.0)
    } else {
        l(1.0) / t2 - l(1.0) / (l(2.0) * t * (l(0.5) * t).tan())
    };
    let K = hat(phi);
    Matrix3::identity() + K * l(0.5) + K * K * c
}

/// Left Jacobian, `Jl(φ) = Jr(−φ)`.
pub fn left_jacobian<T: Real>(phi: &Vector3<T>) -> Matrix3<T> {
    right_jacobian(&(-phi))
}

/// Inverse of the left Jacobian, `Jl⁻¹(φ) = Jr⁻¹(−φ)`.
pub fn left_jacobian_inverse<T: Real>(phi: &Vector3<T>) -> Matrix3<T> {
    right_jacobian_inverse(&(-phi))
}

impl<T: Real> So3<T> {
    /// The identity rotation.
    pub fn identity() -> Self {
        Self { q: UnitQuaternion::identity() }
    }

    /// From a unit quaternion (renormalised).
    #[inline]
    pub fn from_quaternion(q: UnitQuaternion<T>) -> Self {
        Self { q: UnitQuaternion::new_normalize(q.into_inner()) }
    }

    /// From a quaternion that is already unit, taken as it is (no renormalisation: a
    /// stored rotation read back bit for bit).
    #[inline]
    pub fn from_unit_quaternion_unchecked(q: UnitQuaternion<T>) -> Self {
        Self { q }
    }

    /// From a rotation matrix (re-orthonormalised through the quaternion).
    pub fn from_matrix(r: &Matrix3<T>) -> Self {
        Self { q: UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(r)) }
    }

    /// From Euler angles in radians, aerospace ZYX order: `R_nb = Rz(yaw) Ry(pitch) Rx(roll)`.
    pub fn from_euler(roll: T, pitch: T, yaw: T) -> Self {
        Self { q: UnitQuaternion::from_euler_angles(roll, pitch, yaw) }
    }

    /// Euler angles `(roll, pitch, yaw)` in radians, ZYX order, yaw in (−π, π].
    pub fn euler(&self) -> (T, T, T) {
        self.q.euler_angles()
    }

    /// The exponential map `Exp(φ)`: rotation by |φ| about φ/|φ|.
    #[inline]
    pub fn exp(phi: &Vector3<T>) -> Self {
        Self { q: UnitQuaternion::new_normalize(exp_quaternion(phi)) }
    }

    /// The logarithm map `Log(R)`, the rotation vector with angle in [0, π].
    pub fn log(&self) -> Vector3<T> {
        let c = T::lit;
        let q = self.q.quaternion();
        // q and −q are the same rotation; take the representative with w ≥ 0.
        let (w, v) = if q.w < T::zero() { (-q.w, -q.imag()) } else { (q.w, q.imag()) };
        let n = v.norm();
        let scale = if n < c(1e-10) {
            // θ/n = 2 atan(n/w)/n = (2/w)(1 − (n/w)²/3 + …); the second term is < 1e-20.
            c(2.0) / w
        } else {
            c(2.0) * n.atan2(w) / n
        };
        v * scale
    }

    /// The unit quaternion.
    pub fn quaternion(&self) -> &UnitQuaternion<T> {
        &self.q
    }

    /// The rotation matrix.
    #[inline]
    pub fn matrix(&self) -> Matrix3<T> {
        self.q.to_rotation_matrix().into_inner()
    }

    /// `Exp(left) · self · Exp(right)` with one normalisation at the end (through
    /// [`exp`](Self::exp) and `*` it would be four).
    #[inline]
    pub fn between_exp(&self, left: &Vector3<T>, right: &Vector3<T>) -> Self {
        let q = exp_quaternion(left) * self.q.as_ref() * exp_quaternion(right);
        Self { q: UnitQuaternion::new_normalize(q) }
    }

    /// The inverse rotation.
    #[inline]
    pub fn inverse(&self) -> Self {
        Self { q: self.q.inverse() }
    }

    /// Rotate a vector: `R v`.
    #[inline]
    pub fn rotate(&self, v: &Vector3<T>) -> Vector3<T> {
        self.q.transform_vector(v)
    }

    /// The angle of the rotation in [0, π].
    pub fn angle(&self) -> T {
        self.log().norm()
    }

    /// The same rotation over another scalar: the quaternion's components rounded to it,
    /// then renormalised.
    pub fn cast<U: Real>(&self) -> So3<U> {
        let q = self.q.quaternion();
        let c = |v: T| U::lit(v.to_f64());
        So3::from_quaternion(UnitQuaternion::new_unchecked(Quaternion::new(
            c(q.w),
            c(q.i),
            c(q.j),
            c(q.k),
        )))
    }
}

impl<T: Real> Mul for So3<T> {
    type Output = So3<T>;
    fn mul(self, rhs: So3<T>) -> So3<T> {
        So3::from_quaternion(self.q * rhs.q)
    }
}

impl<T: Real> Mul<&So3<T>> for &So3<T> {
    type Output = So3<T>;
    fn mul(self, rhs: &So3<T>) -> So3<T> {
        So3::from_quaternion(self.q * rhs.q)
    }
}

impl<T: Real> Mul<Vector3<T>> for &So3<T> {
    type Output = Vector3<T>;
    fn mul(self, v: Vector3<T>) -> Vector3<T> {
        self.rotate(&v)
    }
}

impl<T: Real> Manifold<T> for So3<T> {
    type Dim = Const<3>;

    fn origin() -> Self {
        Self::identity()
    }

    /// `R ⊕ δθ = R · Exp(δθ)`, normalised once.
    #[inline]
    fn oplus(&self, delta: &Vector3<T>) -> Self {
        Self { q: UnitQuaternion::new_normalize(self.q.as_ref() * exp_quaternion(delta)) }
    }

    /// `S ⊖ R = Log(R⁻¹ · S)`.
    fn ominus(&self, origin: &Self) -> Vector3<T> {
        Self { q: origin.q.inverse() * self.q }.log()
    }

    #[inline]
    fn is_finite(&self) -> bool {
        self.q.coords.iter().all(|c| c.is_finite())
    }

    /// `J_y_x = Exp(δ)ᵀ` (the adjoint of `Exp(δ)⁻¹`), `J_y_δ = Jr(δ)`.
    fn oplus_jacobians(&self, delta: &Vector3<T>) -> OplusJacobians<Self, T> {
        OplusJacobians {
            J_y_x: Self::exp(delta).matrix().transpose(),
            J_y_delta: right_jacobian(delta),
        }
    }

    #[inline]
    fn oplus_jacobian_delta(&self, delta: &Vector3<T>) -> Matrix3<T> {
        right_jacobian(delta)
    }

    /// With `τ = y ⊖ x`: `J_d_y = Jr⁻¹(τ)`, `J_d_x = −Jl⁻¹(τ)`.
    fn ominus_jacobians(&self, origin: &Self) -> OminusJacobians<Self, T> {
        let tau = self.ominus(origin);
        OminusJacobians { J_d_y: right_jacobian_inverse(&tau), J_d_x: -left_jacobian_inverse(&tau) }
    }
}
