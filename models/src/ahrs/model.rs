//! The AHRS state, process model (three variants) and measurement model.

use estimator_core::{
    FilterScalar, MeasurementJacobians, MeasurementModel, ProcessJacobians, ProcessModel,
};
use manifolds::{composite_state, hat, right_jacobian, So3, R3};
use nalgebra::{Const, Matrix3, SMatrix, SVector, Vector3};

use crate::cs::CsVariance;

composite_state! {
    /// Attitude, gyro drift and maneuvering acceleration (or accelerometer bias), over the
    /// scalar `T` (`f64` unless named; `AhrsState<f32>` for a single-precision filter).
    pub struct AhrsState<T> {
        /// Attitude `R_nb` (body FRD → NED).
        pub att: So3 => ATT,
        /// Gyro drift, rad/s.
        pub bg: R3 => BG,
        /// Body-frame maneuvering acceleration (m/s²), or the accelerometer bias for the
        /// conventional variant.
        pub acc: R3 => ACC,
    }
}

/// How the third state block evolves.
#[derive(Clone, Debug)]
pub enum AccelModel {
    /// Conventional 9-state EKF: the block is an accelerometer bias, a random walk of
    /// intensity `q` ((m/s²)²/s); maneuvering acceleration is not modelled.
    None {
        /// Bias random-walk intensity.
        q: f64,
    },
    /// Modified 9-state EKF: maneuvering acceleration as a random walk of fixed intensity
    /// `q` ((m/s²)²/s).
    RandomWalk {
        /// Intensity.
        q: f64,
    },
    /// CS-MAEKF: current statistical model with maneuver frequency `alpha` and the
    /// adaptive variance law; discrete `Q_a = σ_a²(ā)(1 − e^{−2αT})` per axis with ā the
    /// current estimate.
    CurrentStatistical {
        /// Maneuver frequency α, 1/s (paper: 1/60).
        alpha: f64,
        /// Variance law.
        variance: CsVariance,
    },
}

/// Gyro noise figures shared by every variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AhrsTuning {
    /// Gyro white noise intensity, rad²/s (ARW²).
    pub gyro_psd: f64,
    /// Gyro drift random-walk intensity, (rad/s)²/s.
    pub drift_psd: f64,
}

/// The AHRS process model.
#[derive(Clone, Debug)]
pub struct AhrsModel {
    /// Gyro noise.
    pub tuning: AhrsTuning,
    /// The third block's model.
    pub accel: AccelModel,
}

impl AhrsModel {
    /// Whether the third block is a maneuvering acceleration (not a bias).
    pub fn models_acceleration(&self) -> bool {
        !matches!(self.accel, AccelModel::None { .. })
    }
}

/// The input of one AHRS prediction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AhrsInput<T: FilterScalar = f64> {
    /// Measured angular rate `ω_m` (rad/s), held over the step.
    pub gyro: Vector3<T>,
    /// Current mean acceleration ā (m/s², body) for the CS model: the latest estimate,
    /// held fixed over the step (an input, not a state, so `Φ_aa = e^{−αT}`).
    pub abar: Vector3<T>,
}

/// Over any scalar: the model's figures (`f64`, its configuration) are rounded to `T` where
/// they enter the step.
impl<T: FilterScalar> ProcessModel<T> for AhrsModel {
    type State = AhrsState<T>;
    type Input = AhrsInput<T>;

    /// `R⁺ = R Exp((ω_m − b_g) T)`; CS: `a⁺ = e^{−αT} a + (1 − e^{−αT}) ā` (so `a⁺ = a`
    /// when ā is the current estimate); other variants hold the third block.
    fn propagate(&self, x: &AhrsState<T>, u: &AhrsInput<T>, dt: T) -> AhrsState<T> {
        let acc = match &self.accel {
            AccelModel::CurrentStatistical { alpha, .. } => {
                let e = (-T::lit(*alpha) * dt).exp();
                x.acc * e + u.abar * (T::one() - e)
            }
            _ => x.acc,
        };
        AhrsState { att: x.att * So3::exp(&((u.gyro - x.bg) * dt)), bg: x.bg, acc }
    }

    fn jacobians(
        &self,
        x: &AhrsState<T>,
        u: &AhrsInput<T>,
        dt: T,
    ) -> ProcessJacobians<Const<9>, T> {
        let l = T::lit;
        let phi_w = (u.gyro - x.bg) * dt;
        let mut Phi = SMatrix::<T, 9, 9>::identity();
        Phi.fixed_view_mut::<3, 3>(0, 0).copy_from(&So3::exp(&phi_w).matrix().transpose());
        Phi.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-right_jacobian(&phi_w) * dt));
        let mut q = SVector::<T, 9>::zeros();
        for i in 0..3 {
            q[i] = l(self.tuning.gyro_psd) * dt;
            q[3 + i] = l(self.tuning.drift_psd) * dt;
        }
        match &self.accel {
            AccelModel::None { q: qa } | AccelModel::RandomWalk { q: qa } => {
                for i in 0..3 {
                    q[6 + i] = l(*qa) * dt;
                }
            }
            AccelModel::CurrentStatistical { alpha, variance } => {
                let alpha = l(*alpha);
                let e = (-alpha * dt).exp();
                let decay = T::one() - (-l(2.0) * alpha * dt).exp();
                for i in 0..3 {
                    Phi[(6 + i, 6 + i)] = e;
                    q[6 + i] = l(variance.variance(u.abar[i].to_f64())) * decay;
                }
            }
        }
        ProcessJacobians { Phi, Q: SMatrix::<T, 9, 9>::from_diagonal(&q) }
    }
}

/// Accelerometer and magnetometer, stacked: `z = [f_b; m_b]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AhrsMeasurement<T: FilterScalar = f64> {
    /// Gravity in NED, m/s² (down positive).
    pub g_n: Vector3<T>,
    /// Earth magnetic field in NED (any unit; the magnetometer's).
    pub m_n: Vector3<T>,
}

impl<T: FilterScalar> MeasurementModel<T> for AhrsMeasurement<T> {
    type State = AhrsState<T>;
    type Measurement = SVector<T, 6>;

    /// `f = a − R_nbᵀ g_n`, `m = R_nbᵀ m_n`.
    fn predict(&self, x: &AhrsState<T>) -> SVector<T, 6> {
        let r_bn = x.att.inverse();
        let f = x.acc - r_bn.rotate(&self.g_n);
        let m = r_bn.rotate(&self.m_n);
        SVector::<T, 6>::from_iterator(f.iter().chain(m.iter()).copied())
    }

    /// `H_f = [−[(R_nbᵀ g)×], 0, I]`, `H_m = [[(R_nbᵀ m_n)×], 0, 0]`.
    fn jacobian(&self, x: &AhrsState<T>) -> MeasurementJacobians<Const<6>, Const<9>, T> {
        let r_bn = x.att.inverse();
        let mut H = SMatrix::<T, 6, 9>::zeros();
        H.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-hat(&r_bn.rotate(&self.g_n))));
        H.fixed_view_mut::<3, 3>(0, 6).copy_from(&Matrix3::identity());
        H.fixed_view_mut::<3, 3>(3, 0).copy_from(&hat(&r_bn.rotate(&self.m_n)));
        MeasurementJacobians { H }
    }
}
