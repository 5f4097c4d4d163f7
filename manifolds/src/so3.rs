//! SO(3), the rotation group, on a unit quaternion.
//!
//! Error definition (right / body-frame perturbation): `R_true = R̂ · Exp(δθ)`, so `δθ`
//! is expressed in the body frame of `R̂` (Solà, Deray & Atchuthan, "A micro Lie theory
//! for state estimation in robotics", 2018, eq. 25–26 with the right ⊕).

use core::ops::Mul;

use nalgebra::{Const, Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};
// without `std`, the floats' functions (sqrt, sin, cos, tan, atan2) are nalgebra's (libm)
#[cfg(not(feature = "std"))]
use nalgebra::{ComplexField as _, RealField as _};

use crate::traits::{Manifold, OminusJacobians, OplusJacobians};

/// Below this rotation angle the closed forms lose digits to cancellation and the
/// Taylor series (accurate to `θ⁶` ≈ 1e-12 relative here, far better in practice) are used.
const SMALL_ANGLE: f64 = 1e-2;

/// A rotation, stored as a unit quaternion (`R_ab`: maps frame-`b` vectors into frame `a`).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct So3 {
    q: UnitQuaternion<f64>,
}

/// Skew-symmetric matrix `[v×]` with `[v×] w = v × w`.
#[inline]
pub fn hat(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The quaternion of `Exp(φ)`, `(cos(θ/2), sin(θ/2) φ/θ)`, before normalisation (unit
/// to rounding): callers that multiply it into a product normalise once at the end.
#[inline]
fn exp_quaternion(phi: &Vector3<f64>) -> Quaternion<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let (w, k) = if t < SMALL_ANGLE {
        // sin(θ/2)/θ = ½ − θ²/48 + θ⁴/3840
        (1.0 - t2 / 8.0 + t2 * t2 / 384.0, 0.5 - t2 / 48.0 + t2 * t2 / 3840.0)
    } else {
        ((0.5 * t).cos(), (0.5 * t).sin() / t)
    };
    Quaternion::new(w, k * phi.x, k * phi.y, k * phi.z)
}

/// Right Jacobian of SO(3), `Jr(φ)`: `Exp(φ + δ) ≈ Exp(φ) Exp(Jr(φ) δ)`.
///
/// `Jr(φ) = I − (1 − cos θ)/θ² [φ×] + (θ − sin θ)/θ³ [φ×]²`, θ = |φ|.
#[inline]
pub fn right_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let (a, b) = if t < SMALL_ANGLE {
        (0.5 - t2 / 24.0 + t2 * t2 / 720.0, 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0)
    } else {
        let s = (0.5 * t).sin();
        (2.0 * s * s / t2, (t - t.sin()) / (t2 * t))
    };
    let K = hat(phi);
    Matrix3::identity() - K * a + K * K * b
}

/// Inverse of the right Jacobian, `Jr⁻¹(φ) = I + ½[φ×] + (1/θ² − cot(θ/2)/(2θ)) [φ×]²`.
///
/// The `cot(θ/2)` form stays accurate up to θ → π (where `1 + cos θ` and `sin θ` would
/// both vanish).
pub fn right_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let c = if t < SMALL_ANGLE {
        1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
    } else {
        1.0 / t2 - 1.0 / (2.0 * t * (0.5 * t).tan())
    };
    let K = hat(phi);
    Matrix3::identity() + K * 0.5 + K * K * c
}

/// Left Jacobian, `Jl(φ) = Jr(−φ)`.
pub fn left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    right_jacobian(&(-phi))
}

/// Inverse of the left Jacobian, `Jl⁻¹(φ) = Jr⁻¹(−φ)`.
pub fn left_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    right_jacobian_inverse(&(-phi))
}

impl So3 {
    /// The identity rotation.
    pub fn identity() -> Self {
        Self { q: UnitQuaternion::identity() }
    }

    /// From a unit quaternion (renormalised).
    #[inline]
    pub fn from_quaternion(q: UnitQuaternion<f64>) -> Self {
        Self { q: UnitQuaternion::new_normalize(q.into_inner()) }
    }

    /// From a quaternion that is already unit, taken as it is (no renormalisation: a
    /// stored rotation read back bit for bit).
    #[inline]
    pub fn from_unit_quaternion_unchecked(q: UnitQuaternion<f64>) -> Self {
        Self { q }
    }

    /// From a rotation matrix (re-orthonormalised through the quaternion).
    pub fn from_matrix(r: &Matrix3<f64>) -> Self {
        Self { q: UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(r)) }
    }

    /// From Euler angles in radians, aerospace ZYX order: `R_nb = Rz(yaw) Ry(pitch) Rx(roll)`.
    pub fn from_euler(roll: f64, pitch: f64, yaw: f64) -> Self {
        Self { q: UnitQuaternion::from_euler_angles(roll, pitch, yaw) }
    }

    /// Euler angles `(roll, pitch, yaw)` in radians, ZYX order, yaw in (−π, π].
    pub fn euler(&self) -> (f64, f64, f64) {
        self.q.euler_angles()
    }

    /// The exponential map `Exp(φ)`: rotation by |φ| about φ/|φ|.
    #[inline]
    pub fn exp(phi: &Vector3<f64>) -> Self {
        Self { q: UnitQuaternion::new_normalize(exp_quaternion(phi)) }
    }

    /// The logarithm map `Log(R)`, the rotation vector with angle in [0, π].
    pub fn log(&self) -> Vector3<f64> {
        let q = self.q.quaternion();
        // q and −q are the same rotation; take the representative with w ≥ 0.
        let (w, v) = if q.w < 0.0 { (-q.w, -q.imag()) } else { (q.w, q.imag()) };
        let n = v.norm();
        let scale = if n < 1e-10 {
            // θ/n = 2 atan(n/w)/n = (2/w)(1 − (n/w)²/3 + …); the second term is < 1e-20.
            2.0 / w
        } else {
            2.0 * n.atan2(w) / n
        };
        v * scale
    }

    /// The unit quaternion.
    pub fn quaternion(&self) -> &UnitQuaternion<f64> {
        &self.q
    }

    /// The rotation matrix.
    #[inline]
    pub fn matrix(&self) -> Matrix3<f64> {
        self.q.to_rotation_matrix().into_inner()
    }

    /// `Exp(left) · self · Exp(right)` with one normalisation at the end (through
    /// [`exp`](Self::exp) and `*` it would be four).
    #[inline]
    pub fn between_exp(&self, left: &Vector3<f64>, right: &Vector3<f64>) -> So3 {
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
    pub fn rotate(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.q.transform_vector(v)
    }

    /// The angle of the rotation in [0, π].
    pub fn angle(&self) -> f64 {
        self.log().norm()
    }
}

impl Mul for So3 {
    type Output = So3;
    fn mul(self, rhs: So3) -> So3 {
        So3::from_quaternion(self.q * rhs.q)
    }
}

impl Mul<&So3> for &So3 {
    type Output = So3;
    fn mul(self, rhs: &So3) -> So3 {
        So3::from_quaternion(self.q * rhs.q)
    }
}

impl Mul<Vector3<f64>> for &So3 {
    type Output = Vector3<f64>;
    fn mul(self, v: Vector3<f64>) -> Vector3<f64> {
        self.rotate(&v)
    }
}

impl Manifold for So3 {
    type Dim = Const<3>;

    fn origin() -> Self {
        Self::identity()
    }

    /// `R ⊕ δθ = R · Exp(δθ)`, normalised once.
    #[inline]
    fn oplus(&self, delta: &Vector3<f64>) -> Self {
        Self { q: UnitQuaternion::new_normalize(self.q.as_ref() * exp_quaternion(delta)) }
    }

    /// `S ⊖ R = Log(R⁻¹ · S)`.
    fn ominus(&self, origin: &Self) -> Vector3<f64> {
        Self { q: origin.q.inverse() * self.q }.log()
    }

    #[inline]
    fn is_finite(&self) -> bool {
        self.q.coords.iter().all(|c| c.is_finite())
    }

    /// `J_y_x = Exp(δ)ᵀ` (the adjoint of `Exp(δ)⁻¹`), `J_y_δ = Jr(δ)`.
    fn oplus_jacobians(&self, delta: &Vector3<f64>) -> OplusJacobians<Self> {
        OplusJacobians {
            J_y_x: Self::exp(delta).matrix().transpose(),
            J_y_delta: right_jacobian(delta),
        }
    }

    #[inline]
    fn oplus_jacobian_delta(&self, delta: &Vector3<f64>) -> Matrix3<f64> {
        right_jacobian(delta)
    }

    /// With `τ = y ⊖ x`: `J_d_y = Jr⁻¹(τ)`, `J_d_x = −Jl⁻¹(τ)`.
    fn ominus_jacobians(&self, origin: &Self) -> OminusJacobians<Self> {
        let tau = self.ominus(origin);
        OminusJacobians { J_d_y: right_jacobian_inverse(&tau), J_d_x: -left_jacobian_inverse(&tau) }
    }
}
