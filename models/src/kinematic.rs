//! Linear kinematic models for any number of axes `D`: constant velocity (state
//! `(p, v)`), constant acceleration (`(p, v, a)`), the Singer model and the current
//! statistical (CS) model (`(p, v, a)` with a first-order Markov acceleration).
//!
//! All are linear, so `Φ` is exact and the error-state filter on them is the linear
//! Kalman filter. Noise, per axis, with white-noise intensity `q`:
//!
//! ```text
//! CV (white acceleration):  Q = q [T³/3  T²/2; T²/2  T]
//! CA (white jerk):          Q = q [T⁵/20 T⁴/8 T³/6; T⁴/8 T³/3 T²/2; T³/6 T²/2 T]
//! Singer:  ȧ = −α a + w,  E[w²] = 2ασ_m²     (Singer 1970, IEEE Trans. AES-6(4))
//! CS:      ȧ = −α (a − ā) + w,  E[w²] = 2ασ_a²(ā)   (Zhou & Kumar 1984, IEE Proc. F 131)
//! ```
//!
//! Tangent order: all positions, then all velocities, then all accelerations.

use estimator_core::{DimAlloc, ProcessJacobians, ProcessModel};
use manifolds::Manifold;
use nalgebra::{Const, DefaultAllocator, DimNameAdd, DimNameSum, OMatrix, SMatrix, SVector};

use crate::cs::CsVariance;

/// State of a constant-velocity model on `D` axes: (position, velocity).
pub type CvState<const D: usize> = (SVector<f64, D>, SVector<f64, D>);
/// State of the acceleration models on `D` axes: (position, velocity, acceleration).
pub type CaState<const D: usize> = (SVector<f64, D>, SVector<f64, D>, SVector<f64, D>);

type Dim2<const D: usize> = DimNameSum<Const<D>, Const<D>>;
type Dim3<const D: usize> = DimNameSum<Dim2<D>, Const<D>>;

/// `m ⊗ diag(scale(0), …, scale(d−1))` for a 2×2 or 3×3 per-axis matrix, written into a
/// tangent-sized matrix (positions, then velocities, then accelerations).
fn kron<const K: usize, S: nalgebra::DimName>(
    m: &SMatrix<f64, K, K>,
    d: usize,
    scale: impl Fn(usize) -> f64,
) -> OMatrix<f64, S, S>
where
    DefaultAllocator: DimAlloc<S>,
{
    let mut out = OMatrix::<f64, S, S>::zeros();
    for a in 0..d {
        let s = scale(a);
        for bi in 0..K {
            for bj in 0..K {
                out[(bi * d + a, bj * d + a)] = m[(bi, bj)] * s;
            }
        }
    }
    out
}

/// Constant velocity on `D` axes with white-acceleration intensity `q` (m²/s³) per axis.
#[derive(Clone, Debug)]
pub struct ConstantVelocity<const D: usize> {
    /// White-acceleration intensity per axis, m²/s³.
    pub q: SVector<f64, D>,
}

impl<const D: usize> ProcessModel for ConstantVelocity<D>
where
    Const<D>: DimNameAdd<Const<D>>,
    DefaultAllocator: DimAlloc<Dim2<D>>,
{
    type State = CvState<D>;
    type Input = ();

    fn propagate(&self, x: &CvState<D>, _: &(), dt: f64) -> CvState<D> {
        (x.0 + x.1 * dt, x.1)
    }

    fn jacobians(
        &self,
        _: &CvState<D>,
        _: &(),
        T: f64,
    ) -> ProcessJacobians<<CvState<D> as Manifold>::Dim> {
        let phi = SMatrix::<f64, 2, 2>::new(1.0, T, 0.0, 1.0);
        let q = SMatrix::<f64, 2, 2>::new(T.powi(3) / 3.0, T * T / 2.0, T * T / 2.0, T);
        ProcessJacobians { Phi: kron(&phi, D, |_| 1.0), Q: kron(&q, D, |a| self.q[a]) }
    }
}

/// Constant acceleration on `D` axes with white-jerk intensity `q` (m²/s⁵) per axis.
#[derive(Clone, Debug)]
pub struct ConstantAcceleration<const D: usize> {
    /// White-jerk intensity per axis, m²/s⁵.
    pub q: SVector<f64, D>,
}

fn ca_phi(T: f64) -> SMatrix<f64, 3, 3> {
    SMatrix::<f64, 3, 3>::new(1.0, T, T * T / 2.0, 0.0, 1.0, T, 0.0, 0.0, 1.0)
}

impl<const D: usize> ProcessModel for ConstantAcceleration<D>
where
    Const<D>: DimNameAdd<Const<D>>,
    Dim2<D>: DimNameAdd<Const<D>>,
    DefaultAllocator: DimAlloc<Dim3<D>>,
{
    type State = CaState<D>;
    type Input = ();

    fn propagate(&self, x: &CaState<D>, _: &(), T: f64) -> CaState<D> {
        (x.0 + x.1 * T + x.2 * (T * T / 2.0), x.1 + x.2 * T, x.2)
    }

    fn jacobians(
        &self,
        _: &CaState<D>,
        _: &(),
        T: f64,
    ) -> ProcessJacobians<<CaState<D> as Manifold>::Dim> {
        let (t2, t3, t4, t5) = (T * T, T.powi(3), T.powi(4), T.powi(5));
        let q = SMatrix::<f64, 3, 3>::new(
            t5 / 20.0,
            t4 / 8.0,
            t3 / 6.0, //
            t4 / 8.0,
            t3 / 3.0,
            t2 / 2.0, //
            t3 / 6.0,
            t2 / 2.0,
            T,
        );
        ProcessJacobians { Phi: kron(&ca_phi(T), D, |_| 1.0), Q: kron(&q, D, |a| self.q[a]) }
    }
}

/// `Φ` of the first-order Markov acceleration (Singer and CS), per axis. Written with
/// `expm1` and, for `αT < 1e-3`, the series of `(αT − 1 + e^{−αT})/α²`, so that it tends
/// to the constant-acceleration `Φ` without cancellation.
pub fn markov_phi(alpha: f64, T: f64) -> SMatrix<f64, 3, 3> {
    let x = alpha * T;
    // (x − 1 + e^{−x})/x² = 1/2 − x/6 + x²/24 − x³/120 + …
    let g = if x < 1e-3 {
        0.5 - x / 6.0 + x * x / 24.0 - x.powi(3) / 120.0
    } else {
        (x + (-x).exp_m1()) / (x * x)
    };
    // (1 − e^{−x})/x
    let h = if x < 1e-8 { 1.0 - x / 2.0 } else { -(-x).exp_m1() / x };
    SMatrix::<f64, 3, 3>::new(
        1.0,
        T,
        T * T * g, //
        0.0,
        1.0,
        T * h, //
        0.0,
        0.0,
        (-x).exp(),
    )
}

/// Singer's `Q / (2ασ²)` per axis: `∫₀ᵀ Φ(s) e₃e₃ᵀ Φ(s)ᵀ ds` for `ȧ = −α a + w`, by Van
/// Loan's method (C. F. Van Loan, "Computing integrals involving the matrix exponential",
/// IEEE Trans. AC-23(3), 1978): one 6×6 matrix exponential, accurate for every `αT`
/// (Singer's closed form, eq. 12 of Singer 1970, cancels catastrophically for small `αT`;
/// the tests compare the two where the closed form is accurate).
pub fn singer_q_unit(alpha: f64, T: f64) -> SMatrix<f64, 3, 3> {
    // A = [[0,1,0],[0,0,1],[0,0,−α]], G Q_c Gᵀ = e₃e₃ᵀ
    let mut m = SMatrix::<f64, 6, 6>::zeros();
    let a = SMatrix::<f64, 3, 3>::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -alpha);
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-a * T));
    m[(2, 5)] = T;
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&(a.transpose() * T));
    let e = m.exp();
    let phi = e.fixed_view::<3, 3>(3, 3).transpose();
    let q = phi * e.fixed_view::<3, 3>(0, 3);
    (q + q.transpose()) * 0.5
}

/// Singer's closed form of [`singer_q_unit`] (Singer 1970, eq. 12), accurate for
/// `αT ≳ 0.5`; kept as an independent check.
pub fn singer_q_closed_form(alpha: f64, T: f64) -> SMatrix<f64, 3, 3> {
    let (a, x) = (alpha, alpha * T);
    let e1 = (-x).exp();
    let e2 = (-2.0 * x).exp();
    let q11 = (1.0 - e2 + 2.0 * x + 2.0 * x.powi(3) / 3.0 - 2.0 * x * x - 4.0 * x * e1)
        / (2.0 * a.powi(5));
    let q12 = (e2 + 1.0 - 2.0 * e1 + 2.0 * x * e1 - 2.0 * x + x * x) / (2.0 * a.powi(4));
    let q13 = (1.0 - e2 - 2.0 * x * e1) / (2.0 * a.powi(3));
    let q22 = (4.0 * e1 - 3.0 - e2 + 2.0 * x) / (2.0 * a.powi(3));
    let q23 = (e2 + 1.0 - 2.0 * e1) / (2.0 * a * a);
    let q33 = (1.0 - e2) / (2.0 * a);
    SMatrix::<f64, 3, 3>::new(q11, q12, q13, q12, q22, q23, q13, q23, q33)
}

/// First-order Markov acceleration relaxing towards `abar` (zero: Singer; the current
/// mean: CS): `x⁺ = Φ x + U ā` with `U = [T²/2 − Φ₀₂, T − Φ₁₂, 1 − Φ₂₂]`, the response to a
/// constant ā.
fn markov_propagate<const D: usize>(
    x: &CaState<D>,
    abar: &SVector<f64, D>,
    alpha: f64,
    T: f64,
) -> CaState<D> {
    let p = markov_phi(alpha, T);
    let u = [T * T / 2.0 - p[(0, 2)], T - p[(1, 2)], 1.0 - p[(2, 2)]];
    (
        x.0 + x.1 * p[(0, 1)] + x.2 * p[(0, 2)] + abar * u[0],
        x.1 + x.2 * p[(1, 2)] + abar * u[1],
        x.2 * p[(2, 2)] + abar * u[2],
    )
}

/// `Φ` and `Q = 2α σ²(axis) · Q_unit` of the Markov acceleration on `D` axes.
fn markov_jacobians<const D: usize>(
    alpha: f64,
    T: f64,
    sigma2: impl Fn(usize) -> f64,
) -> ProcessJacobians<Dim3<D>>
where
    Const<D>: DimNameAdd<Const<D>>,
    Dim2<D>: DimNameAdd<Const<D>>,
    DefaultAllocator: DimAlloc<Dim3<D>>,
{
    ProcessJacobians {
        Phi: kron(&markov_phi(alpha, T), D, |_| 1.0),
        Q: kron(&singer_q_unit(alpha, T), D, |a| 2.0 * alpha * sigma2(a)),
    }
}

/// The Singer model: zero-mean first-order Markov acceleration with maneuver time constant
/// `1/α` and acceleration variance `σ_m²` per axis.
#[derive(Clone, Debug)]
pub struct Singer<const D: usize> {
    /// Maneuver frequency α (1/s).
    pub alpha: f64,
    /// Acceleration variance per axis, (m/s²)².
    pub sigma2: SVector<f64, D>,
}

impl<const D: usize> ProcessModel for Singer<D>
where
    Const<D>: DimNameAdd<Const<D>>,
    Dim2<D>: DimNameAdd<Const<D>>,
    DefaultAllocator: DimAlloc<Dim3<D>>,
{
    type State = CaState<D>;
    type Input = ();

    /// The CS propagation with a zero mean acceleration.
    fn propagate(&self, x: &CaState<D>, _: &(), T: f64) -> CaState<D> {
        markov_propagate(x, &SVector::zeros(), self.alpha, T)
    }

    fn jacobians(
        &self,
        _: &CaState<D>,
        _: &(),
        T: f64,
    ) -> ProcessJacobians<<CaState<D> as Manifold>::Dim> {
        markov_jacobians::<D>(self.alpha, T, |a| self.sigma2[a])
    }
}

/// The current statistical model: the acceleration relaxes towards the current mean
/// `ā` (the input, usually the latest acceleration estimate), with the variance law of
/// [`CsVariance`] evaluated at `ā` for each axis.
#[derive(Clone, Debug)]
pub struct CurrentStatistical<const D: usize> {
    /// Maneuver frequency α (1/s).
    pub alpha: f64,
    /// Variance law (modified Rayleigh with adapted limits).
    pub variance: CsVariance,
}

impl<const D: usize> ProcessModel for CurrentStatistical<D>
where
    Const<D>: DimNameAdd<Const<D>>,
    Dim2<D>: DimNameAdd<Const<D>>,
    DefaultAllocator: DimAlloc<Dim3<D>>,
{
    type State = CaState<D>;
    /// The current mean acceleration ā per axis.
    type Input = SVector<f64, D>;

    /// `x⁺ = Φ x + U ā` with `U = (I − Φ) [0 0 1]ᵀ`-type input gains.
    fn propagate(&self, x: &CaState<D>, abar: &SVector<f64, D>, T: f64) -> CaState<D> {
        markov_propagate(x, abar, self.alpha, T)
    }

    fn jacobians(
        &self,
        _: &CaState<D>,
        abar: &SVector<f64, D>,
        T: f64,
    ) -> ProcessJacobians<<CaState<D> as Manifold>::Dim> {
        markov_jacobians::<D>(self.alpha, T, |a| self.variance.variance(abar[a]))
    }
}
