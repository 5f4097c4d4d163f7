//! The 21-state INS: the 15-state error state plus gyro and accelerometer scale factors
//! (KF-GINS's state), built as a composite of the same framework.
//!
//! Sensor model (per axis, `s` a small fraction, e.g. 1000 ppm = 1e-3): the IMU measures
//! `ω̃ = (1 + s_g) ω + b_g`, `f̃ = (1 + s_a) f + b_a`, and the mechanization uses
//! `ω = ω̃ ⊘ (1 + s_g) − b_g` (the bias in the corrected units; to first order the same
//! as KF-GINS's `(ω̃ − b_g) ⊘ (1 + s_g)`). The error of a scale factor acts over one step
//! like a bias error of `diag(ω) δs_g` (`diag(f) δs_a`), so the transition columns of the
//! scale factors are those of the biases times `diag(ω)` (`diag(f)`):
//!
//! ```text
//! δθ̇ = … − δb_g − diag(ω) δs_g          δv̇ = … − R̂ δb_a − R̂ diag(f) δs_a
//! δṡ = −s/τ + w   (Gauss–Markov, as the biases; 0 for a random walk)
//! ```
//!
//! Error state `[δθ, δv, δp, δb_g, δb_a, δs_g, δs_a]` (21). Measurement models of the
//! 15-state filter apply through [`OnNav`](crate::navigator::OnNav) (their `H` padded
//! with zeros).

use estimator_core::{ProcessJacobians, ProcessModel};
use manifolds::{composite_state, R3};
use nalgebra::{Const, SMatrix, Vector3};

use crate::imu::{BiasModel, ImuSample};
use crate::model::{ImuInput, InsModel};
use crate::state::InsState;

composite_state! {
    /// The 15-state INS state and the IMU scale factors: the nominal state of the 21-state
    /// filter. Tangent dimension `Const<21>`; blocks `NAV` (15), `SG`, `SA`.
    pub struct InsState21 {
        /// Attitude, velocity, position, biases.
        pub nav: InsState => NAV,
        /// Gyro scale factors (fractions).
        pub sg: R3 => SG,
        /// Accelerometer scale factors (fractions).
        pub sa: R3 => SA,
    }
}

/// 21×21 matrices of the error state.
pub type M21 = SMatrix<f64, 21, 21>;

/// Scale-factor process noise, in the convention of the biases of
/// [`ImuNoise`](crate::imu::ImuNoise): the steady-state σ of a Gauss–Markov process, or the
/// density (1/√s) of a random walk, following the IMU's bias model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScaleFactorNoise {
    /// Gyro scale factors (fraction, or fraction/√s).
    pub gyro: Vector3<f64>,
    /// Accelerometer scale factors.
    pub accel: Vector3<f64>,
}

impl ScaleFactorNoise {
    /// From datasheet values: a σ in ppm and the correlation time `tau` (s) of the bias
    /// model: the steady-state σ for Gauss–Markov, the density `σ √(2/τ)` for a random
    /// walk (as the biases, [`ImuNoise::from_datasheet`](crate::imu::ImuNoise::from_datasheet)).
    pub fn from_ppm(
        gyro_ppm: Vector3<f64>,
        accel_ppm: Vector3<f64>,
        model: BiasModel,
        tau: f64,
    ) -> Self {
        let k = match model {
            BiasModel::RandomWalk => (2.0 / tau).sqrt(),
            _ => 1.0,
        };
        Self { gyro: gyro_ppm * (1e-6 * k), accel: accel_ppm * (1e-6 * k) }
    }
}

/// The 21-state process model: the 15-state [`InsModel`] on scale-corrected increments,
/// and the scale factors as Gauss–Markov processes (or random walks) like the biases.
#[derive(Clone, Debug)]
pub struct InsModel21 {
    /// The 15-state model (mechanization, IMU noise, bias model).
    pub base: InsModel,
    /// Scale-factor noise.
    pub scale: ScaleFactorNoise,
}

fn divide(s: &ImuSample, sg: &Vector3<f64>, sa: &Vector3<f64>) -> ImuSample {
    ImuSample {
        dtheta: s.dtheta.component_div(&sg.add_scalar(1.0)),
        dvel: s.dvel.component_div(&sa.add_scalar(1.0)),
        ..*s
    }
}

impl InsModel21 {
    /// The increments with the scale factors of `x` removed.
    pub fn scale_corrected(x: &InsState21, u: &ImuInput) -> ImuInput {
        ImuInput {
            prev: u.prev.as_ref().map(|p| divide(p, &x.sg, &x.sa)),
            cur: divide(&u.cur, &x.sg, &x.sa),
        }
    }

    /// Decay of a Gauss–Markov state over `dt` (1 for a random walk and KF-GINS's held
    /// form).
    fn decay(&self, dt: f64) -> f64 {
        match self.base.noise.bias_model {
            BiasModel::GaussMarkov { tau } if tau > 0.0 => (-dt / tau).exp(),
            _ => 1.0,
        }
    }

    /// Driving-noise density² of the scale factors.
    fn psd(&self) -> (Vector3<f64>, Vector3<f64>) {
        let s = &self.scale;
        match self.base.noise.bias_model {
            BiasModel::GaussMarkov { tau } | BiasModel::GaussMarkovHeld { tau } if tau > 0.0 => {
                (s.gyro.map(|v| 2.0 * v * v / tau), s.accel.map(|v| 2.0 * v * v / tau))
            }
            _ => (s.gyro.map(|v| v * v), s.accel.map(|v| v * v)),
        }
    }

    /// What the scale columns and rows of `Φ` are made of, for the step of the
    /// scale-corrected input `v`: the bias-corrected rate and specific force (the scale
    /// columns are the bias columns times them) and the scale factors' decay.
    fn scale_terms(&self, x: &InsState21, v: &ImuInput) -> (Vector3<f64>, Vector3<f64>, f64) {
        let h = v.cur.dt;
        let (w, f) = if h > 0.0 {
            (v.cur.dtheta / h - x.nav.bg, v.cur.dvel / h - x.nav.ba)
        } else {
            (Vector3::zeros(), Vector3::zeros())
        };
        (w, f, self.decay(h))
    }

    fn next(&self, x: &InsState21, u: &ImuInput, nav: InsState) -> InsState21 {
        let k = self.decay(u.cur.dt);
        InsState21 { nav, sg: x.sg * k, sa: x.sa * k }
    }
}

impl ProcessModel for InsModel21 {
    type State = InsState21;
    type Input = ImuInput;

    fn propagate(&self, x: &InsState21, u: &ImuInput, dt: f64) -> InsState21 {
        let v = Self::scale_corrected(x, u);
        self.next(x, u, self.base.propagate(&x.nav, &v, dt))
    }

    fn jacobians(&self, x: &InsState21, u: &ImuInput, dt: f64) -> ProcessJacobians<Const<21>> {
        self.step(x, u, dt).1
    }

    fn fold_input(&self, sum: &mut Option<ImuInput>, u: &ImuInput) -> bool {
        u.fold_into(sum);
        true
    }

    fn step(
        &self,
        x: &InsState21,
        u: &ImuInput,
        dt: f64,
    ) -> (InsState21, ProcessJacobians<Const<21>>) {
        let v = Self::scale_corrected(x, u);
        let (nav, j15) = self.base.step(&x.nav, &v, dt);
        let h = v.cur.dt;
        let (w, f, decay) = self.scale_terms(x, &v);
        let mut Phi = M21::zeros();
        Phi.fixed_view_mut::<15, 15>(0, 0).copy_from(&j15.Phi);
        for k in 0..3 {
            for r in 0..9 {
                Phi[(r, 15 + k)] = j15.Phi[(r, 9 + k)] * w[k];
                Phi[(r, 18 + k)] = j15.Phi[(r, 12 + k)] * f[k];
            }
        }
        let (qg, qa) = self.psd();
        let mut Q = M21::zeros();
        Q.fixed_view_mut::<15, 15>(0, 0).copy_from(&j15.Q);
        for k in 0..3 {
            Phi[(15 + k, 15 + k)] = decay;
            Phi[(18 + k, 18 + k)] = decay;
            Q[(15 + k, 15 + k)] = qg[k] * h;
            Q[(18 + k, 18 + k)] = qa[k] * h;
        }
        (self.next(x, u, nav), ProcessJacobians { Phi, Q })
    }

    /// `Φᵀ` of [`step`](ProcessModel::step) from the 15-state model's, without `Q_d`.
    fn transition_transposed(&self, x: &InsState21, u: &ImuInput, dt: f64, phi_t: &mut M21) {
        let v = Self::scale_corrected(x, u);
        let mut t15 = SMatrix::<f64, 15, 15>::zeros();
        self.base.transition_transposed(&x.nav, &v, dt, &mut t15);
        let (w, f, decay) = self.scale_terms(x, &v);
        // Φᵀ[(c, r)] = Φ[(r, c)]: step's Φ, transposed
        phi_t.fill(0.0);
        phi_t.fixed_view_mut::<15, 15>(0, 0).copy_from(&t15);
        for k in 0..3 {
            for r in 0..9 {
                phi_t[(15 + k, r)] = t15[(9 + k, r)] * w[k];
                phi_t[(18 + k, r)] = t15[(12 + k, r)] * f[k];
            }
            phi_t[(15 + k, 15 + k)] = decay;
            phi_t[(18 + k, 18 + k)] = decay;
        }
    }

    /// `Q_d v`: the 15-state model's product on the navigation block, the scale
    /// factors' diagonal noise on the rest.
    fn noise_times(
        &self,
        x: &InsState21,
        u: &ImuInput,
        dt: f64,
        phi_t: &M21,
        v: &nalgebra::SVector<f64, 21>,
        phi_t_v: &nalgebra::SVector<f64, 21>,
        out: &mut nalgebra::SVector<f64, 21>,
    ) {
        // the navigation block of Φᵀ v is the 15-state one's: Φ's scale columns only add
        // rows 15..21 to Φᵀ v
        let t15: SMatrix<f64, 15, 15> = phi_t.fixed_view::<15, 15>(0, 0).into_owned();
        let v15: nalgebra::SVector<f64, 15> = v.fixed_rows::<15>(0).into_owned();
        let w15: nalgebra::SVector<f64, 15> = phi_t_v.fixed_rows::<15>(0).into_owned();
        let mut o15 = nalgebra::SVector::<f64, 15>::zeros();
        // (the 15-state noise depends on the attitude and the interval, which the scale
        // correction of the increments leaves as they are)
        self.base.noise_times(&x.nav, u, dt, &t15, &v15, &w15, &mut o15);
        out.fixed_rows_mut::<15>(0).copy_from(&o15);
        let h = u.cur.dt;
        let (qg, qa) = self.psd();
        for k in 0..3 {
            out[15 + k] = qg[k] * h * v[15 + k];
            out[18 + k] = qa[k] * h * v[18 + k];
        }
    }
}
