//! Planar robot models on the pose `(R², SO(2))`: a unicycle process model and a
//! range-bearing landmark measurement whose bearing lives on SO(2).
//!
//! Error definition: `p_true = p̂ + δp` (world frame), `θ_true = θ̂ ⊕ δθ`.

use estimator_core::{MeasurementJacobians, MeasurementModel, ProcessJacobians, ProcessModel};
use manifolds::{So2, R1, R2};
use nalgebra::{Matrix2x3, Matrix3, Vector2, Vector3, U2, U3};

/// A planar pose: position in the world frame and heading.
pub type Pose2 = (R2, So2);

/// Unicycle kinematics with input `(v, ω)` (m/s, rad/s):
/// `p' = p + v dt [cos θ, sin θ]`, `θ' = θ + ω dt`.
/// Noise: white speed and turn-rate errors with standard deviations `sigma_v`, `sigma_w`.
#[derive(Clone, Copy, Debug)]
pub struct Unicycle {
    /// Speed noise, m/s.
    pub sigma_v: f64,
    /// Turn-rate noise, rad/s.
    pub sigma_w: f64,
}

impl ProcessModel for Unicycle {
    type State = Pose2;
    type Input = (f64, f64);

    fn propagate(&self, x: &Pose2, u: &(f64, f64), dt: f64) -> Pose2 {
        let th = x.1.angle();
        (x.0 + Vector2::new(th.cos(), th.sin()) * u.0 * dt, So2::new(th + u.1 * dt))
    }

    #[allow(non_snake_case)]
    fn jacobians(&self, x: &Pose2, u: &(f64, f64), dt: f64) -> ProcessJacobians<U3> {
        let (s, c) = x.1.angle().sin_cos();
        let mut Phi = Matrix3::identity();
        // δp' = δp + v dt [−sin θ, cos θ] δθ
        Phi[(0, 2)] = -u.0 * dt * s;
        Phi[(1, 2)] = u.0 * dt * c;
        // Q = G diag(σv², σω²) Gᵀ with G = dt [[cos θ, 0], [sin θ, 0], [0, 1]]
        let G = nalgebra::Matrix3x2::new(c * dt, 0.0, s * dt, 0.0, 0.0, dt);
        let qc = nalgebra::Matrix2::new(self.sigma_v.powi(2), 0.0, 0.0, self.sigma_w.powi(2));
        // A tiny floor keeps Q positive definite along the unexcited direction.
        let Q = G * qc * G.transpose() + Matrix3::from_diagonal(&Vector3::repeat(1e-12));
        ProcessJacobians { Phi, Q }
    }
}

/// Range (m) and bearing (SO(2), relative to the heading) to a known landmark.
/// The residual is taken through ⊖, so bearings near ±π give small residuals.
#[derive(Clone, Copy, Debug)]
pub struct RangeBearing {
    /// Landmark position in the world frame, m.
    pub landmark: Vector2<f64>,
}

impl MeasurementModel for RangeBearing {
    type State = Pose2;
    type Measurement = (R1, So2);

    fn predict(&self, x: &Pose2) -> (R1, So2) {
        let d = self.landmark - x.0;
        (R1::new(d.norm()), So2::new(d.y.atan2(d.x) - x.1.angle()))
    }

    fn jacobian(&self, x: &Pose2) -> MeasurementJacobians<U2, U3> {
        let d = self.landmark - x.0;
        let r2 = d.norm_squared();
        let r = r2.sqrt();
        MeasurementJacobians {
            H: Matrix2x3::new(-d.x / r, -d.y / r, 0.0, d.y / r2, -d.x / r2, -1.0),
        }
    }
}
