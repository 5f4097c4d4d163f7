//! Checks of any model's analytic Jacobians against central differences through ⊕/⊖
//! ([`manifolds::numdiff`]), feature `testing`. A mismatch is checked again with ten times
//! the step, so that a numerical reference spoilt by cancellation in the model is reported
//! as such ([`JacobianMismatch::step_spread`]) rather than blamed on the analytic Jacobian.
//!
//! ```
//! use estimator_core::harness::{check_measurement_model, check_process_model};
//! use estimator_core::linear::{LinearMeasurement, LinearProcess};
//! use nalgebra::{Matrix1x2, Matrix2, Vector2};
//!
//! let process = LinearProcess { F: Matrix2::new(1.0, 0.1, 0.0, 1.0), Q: Matrix2::identity() };
//! check_process_model(&process, &Vector2::new(1.0, 2.0), &(), 0.1, 1e-7).unwrap();
//! let sensor = LinearMeasurement::<1, 2>::new(Matrix1x2::new(1.0, 0.0));
//! check_measurement_model(&sensor, &Vector2::new(1.0, 2.0), 1e-7).unwrap();
//! ```
//!
//! Over any scalar: the `_in` functions take the model's scalar `T` and the default
//! tolerances scale with its ε ([`jacobian_tolerance`], [`agreement_tolerance`]).

use core::fmt;

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, OMatrix};

use manifolds::{numdiff, DimAlloc, Manifold, Tangent};

use crate::dims::{FilterAlloc, StateDim};
use crate::scalar::FilterScalar;
use crate::traits::{MeasurementModel, ProcessModel};

/// The relative tolerance of an analytic Jacobian against central differences for models
/// over the scalar `T`: 1e-6 in `f64` as the law harness's, `100 ε^(2/3)` (2.4e-3) in `f32`.
pub fn jacobian_tolerance<T: FilterScalar>() -> f64 {
    manifolds::testing::LawTolerance::for_scalar::<T>().jacobian
}

/// The relative agreement required between a model's combined calls (`step`,
/// `linearize`, `step_covariance`) and its separate ones: 1e-9 in `f64`, `100 ε` in `f32`.
pub fn agreement_tolerance<T: FilterScalar>() -> f64 {
    STEP_AGREEMENT.max(100.0 * T::EPS_F64)
}

/// An analytic Jacobian that disagrees with its numerical reference.
#[derive(Clone, Debug)]
pub struct JacobianMismatch {
    /// Which Jacobian.
    pub what: &'static str,
    /// Largest absolute difference.
    pub max_error: f64,
    /// The tolerance it exceeded (already scaled).
    pub tolerance: f64,
    /// Row and column of the largest difference.
    pub at: (usize, usize),
    /// Analytic and numerical values there.
    pub values: (f64, f64),
    /// When set, the numerical reference itself is unreliable: differences with the step
    /// `h` and with `10 h` disagree by this much (more than the tolerance), so the
    /// mismatch is a loss of precision in the model's evaluation (cancellation, a kink),
    /// not necessarily a wrong analytic Jacobian.
    pub step_spread: Option<f64>,
}

impl fmt::Display for JacobianMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: entry {:?} analytic {:.9e} vs numerical {:.9e} (|Δ| {:.3e} > tol {:.3e})",
            self.what, self.at, self.values.0, self.values.1, self.max_error, self.tolerance
        )?;
        if let Some(s) = self.step_spread {
            write!(
                f,
                "; the numerical reference is unreliable here: steps h and 10h disagree by \
                 {s:.3e} (cancellation or a kink in the model; try another step or point)"
            )?;
        }
        if self.what == "process transition Φ" {
            write!(
                f,
                "; a first-order Φ = I + F dt is off by O((‖F‖ dt)²) from an exact \
                 propagate: compute Φ and Q_d with `discretize::van_loan`, or check with a \
                 tolerance of that order"
            )?;
        }
        Ok(())
    }
}

impl std::error::Error for JacobianMismatch {}

/// Compare two matrices with a tolerance relative to `max(1, max|numeric|)`.
pub fn compare<T: FilterScalar, R: DimName, C: DimName>(
    what: &'static str,
    analytic: &OMatrix<T, R, C>,
    numeric: &OMatrix<T, R, C>,
    rel_tol: f64,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: Allocator<R, C>,
{
    let scale = numeric.iter().fold(1.0_f64, |m, v| m.max(v.to_f64().abs()));
    let tolerance = rel_tol * scale;
    let mut worst = (0.0_f64, (0, 0));
    for c in 0..C::DIM {
        for r in 0..R::DIM {
            let d = (analytic[(r, c)].to_f64() - numeric[(r, c)].to_f64()).abs();
            // A NaN entry counts as an infinite difference.
            let d = if d.is_nan() { f64::INFINITY } else { d };
            if d > worst.0 {
                worst = (d, (r, c));
            }
        }
    }
    if worst.0 <= tolerance {
        Ok(())
    } else {
        let at = worst.1;
        Err(JacobianMismatch {
            what,
            max_error: worst.0,
            tolerance,
            at,
            values: (analytic[at].to_f64(), numeric[at].to_f64()),
            step_spread: None,
        })
    }
}

/// [`compare`] against a numerical Jacobian at step `h`; on a mismatch, the same at `10 h`
/// tells a wrong analytic Jacobian (both steps agree with each other) from an unreliable
/// numerical one (they do not: [`JacobianMismatch::step_spread`]).
fn compare_two_steps<T: FilterScalar, R: DimName, C: DimName>(
    what: &'static str,
    analytic: &OMatrix<T, R, C>,
    numeric: impl Fn(T) -> OMatrix<T, R, C>,
    h: f64,
    rel_tol: f64,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: Allocator<R, C>,
{
    let fine = numeric(T::lit(h));
    let Err(mut e) = compare(what, analytic, &fine, rel_tol) else {
        return Ok(());
    };
    let coarse = numeric(T::lit(10.0 * h));
    if let Err(spread) = compare(what, &coarse, &fine, rel_tol) {
        e.step_spread = Some(spread.max_error);
    }
    Err(e)
}

/// Check a process model's `Φ` against `∂(f(x ⊕ δ) ⊖ f(x))/∂δ` by central differences
/// (step 1e-6 in every tangent direction), and its combined calls against the separate
/// ones ([`check_combined_calls`]).
pub fn check_process_model<PM: ProcessModel>(
    model: &PM,
    x: &PM::State,
    u: &PM::Input,
    dt: f64,
    rel_tol: f64,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: DimAlloc<StateDim<PM::State>>,
{
    check_process_model_with_step(model, x, u, dt, rel_tol, 1e-6)
}

/// [`check_process_model`] with a chosen difference step (states with large coordinates,
/// such as geodetic positions, need steps of about 1e-3 to stay above rounding).
pub fn check_process_model_with_step<PM: ProcessModel>(
    model: &PM,
    x: &PM::State,
    u: &PM::Input,
    dt: f64,
    rel_tol: f64,
    step: f64,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: DimAlloc<StateDim<PM::State>>,
{
    check_process_model_in::<f64, PM>(model, x, u, dt, rel_tol, step)
}

/// [`check_process_model_with_step`] for a model over the scalar `T` (e.g. `f32`, with
/// step [`T::DIFF_STEP`](manifolds::Real::DIFF_STEP) and [`jacobian_tolerance`]); the
/// combined calls agree to [`agreement_tolerance`].
pub fn check_process_model_in<T: FilterScalar, PM: ProcessModel<T>>(
    model: &PM,
    x: &PM::State,
    u: &PM::Input,
    dt: T,
    rel_tol: f64,
    step: f64,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: DimAlloc<StateDim<PM::State, T>>,
{
    let jac = model.jacobians(x, u, dt);
    let numeric = |h| numdiff::jacobian_between(x, |xp| model.propagate(xp, u, dt), h);
    compare_two_steps("process transition Φ", &jac.Phi, numeric, step, rel_tol)?;
    check_combined_calls_in::<T, PM>(model, x, u, dt)
}

/// The part of [`check_process_model`] that holds for every model, also one whose `Φ` is
/// only a first-order approximation of its `propagate` (the INS model): `step` agrees
/// with `propagate` and `jacobians`, and `propagate_covariance` and `step_covariance`
/// with the dense `Φ P Φᵀ + Q` (to 1e-9 relative, and exactly symmetric when the model
/// says so), and the smoother's products (`adjoint_sandwich`, `times_transition`,
/// `transition_transposed`, `noise_times`) with their dense forms.
pub fn check_combined_calls<PM: ProcessModel>(
    model: &PM,
    x: &PM::State,
    u: &PM::Input,
    dt: f64,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: DimAlloc<StateDim<PM::State>>,
{
    check_combined_calls_in::<f64, PM>(model, x, u, dt)
}

/// [`check_combined_calls`] for a model over the scalar `T`, to [`agreement_tolerance`].
pub fn check_combined_calls_in<T: FilterScalar, PM: ProcessModel<T>>(
    model: &PM,
    x: &PM::State,
    u: &PM::Input,
    dt: T,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: DimAlloc<StateDim<PM::State, T>>,
{
    let agree = agreement_tolerance::<T>();
    let jac = model.jacobians(x, u, dt);
    // the Q_d a fused step folds in unseen by the filter must be a covariance
    if let Err(e) = crate::linalg::check_process_noise("the model", &jac.Q) {
        let (at, value) = ((0, 0), (f64::NAN, f64::NAN));
        let max_error = match e {
            crate::FilterError::InvalidProcessNoise { value, .. } => value,
            _ => f64::NAN,
        };
        return Err(JacobianMismatch {
            what: "process noise Q_d is not a covariance (finite, symmetric, PSD)",
            max_error,
            tolerance: 0.0,
            at,
            values: value,
            step_spread: None,
        });
    }
    // `step` (often an override sharing work) must agree with the two separate calls.
    let x_next = model.propagate(x, u, dt);
    let (x_step, jac_step) = model.step(x, u, dt);
    let gap = x_step.ominus(&x_next);
    compare("step: state vs propagate", &gap, &gap.map(|_| T::zero()), agree)?;
    compare("step: Φ vs jacobians", &jac_step.Phi, &jac.Phi, agree)?;
    compare("step: Q vs jacobians", &jac_step.Q, &jac.Q, agree)?;
    // `propagate_covariance` and `step_covariance` (structured overrides) must give the
    // dense Φ P Φᵀ + Q, for a P with every entry non-zero.
    type Square<PM, T> = OMatrix<
        T,
        StateDim<<PM as ProcessModel<T>>::State, T>,
        StateDim<<PM as ProcessModel<T>>::State, T>,
    >;
    let a = Square::<PM, T>::from_fn(|r, c| T::lit(((r * 7 + c * 3) % 11) as f64 * 0.1 - 0.5));
    let P = &a * a.transpose() + Square::<PM, T>::identity();
    let dense = &jac.Phi * &P * jac.Phi.transpose() + &jac.Q;
    let mut out = P.clone() * T::lit(f64::NAN);
    model.propagate_covariance(&P, &jac, &mut out);
    let sym = |m: &Square<PM, T>| (m + m.transpose()) * T::lit(0.5);
    compare("propagate_covariance vs Φ P Φᵀ + Q", &sym(&out), &dense, agree)?;
    let mut fused = P.clone() * T::lit(f64::NAN);
    let x_fused = model.step_covariance(x, u, dt, &P, &mut fused);
    let gap = x_fused.ominus(&x_next);
    compare("step_covariance: state vs propagate", &gap, &gap.map(|_| T::zero()), agree)?;
    compare("step_covariance vs Φ P Φᵀ + Q", &sym(&fused), &dense, agree)?;
    if PM::SYMMETRIC_PROPAGATION {
        // the flag promises exact symmetry: the filter skips symmetrising
        compare("propagate_covariance symmetric", &out, &out.transpose(), 0.0)?;
        compare("step_covariance symmetric", &fused, &fused.transpose(), 0.0)?;
    }
    // a smoother's replay: `step_covariance_adjoint` must predict as `step_covariance`
    // does (the covariance bit for bit) and hand over Φᵀ; `adjoint_sandwich` must be Φᵀ Λ Φ, exactly
    // symmetric
    let mut replayed = P.clone() * T::lit(f64::NAN);
    let mut phi_t = P.clone() * T::lit(f64::NAN);
    let x_adj = model.step_covariance_adjoint(x, u, dt, &P, &mut replayed, &mut phi_t);
    let gap = x_adj.ominus(&x_fused);
    // (⊖ of two equal states may give rounding noise, not exactly zero, on SO(3))
    compare("step_covariance_adjoint: state", &gap, &gap.map(|_| T::zero()), agree)?;
    compare("step_covariance_adjoint: covariance", &replayed, &fused, 0.0)?;
    compare("step_covariance_adjoint: Φᵀ vs jacobians", &phi_t.transpose(), &jac.Phi, agree)?;
    let mut adjoint = P.clone() * T::lit(f64::NAN);
    model.adjoint_sandwich(&phi_t, &P, &mut adjoint);
    let dense = jac.Phi.transpose() * &P * &jac.Phi;
    compare("adjoint_sandwich vs Φᵀ Λ Φ", &adjoint, &dense, agree)?;
    compare("adjoint_sandwich symmetric", &adjoint, &adjoint.transpose(), 0.0)?;
    // `times_transition` must be M Φ for any M (here a non-symmetric one)
    let m = OMatrix::<T, StateDim<PM::State, T>, StateDim<PM::State, T>>::from_fn(|r, c| {
        T::lit(((r * 7 + c * 3 + 1) % 11) as f64 * 0.2 - 1.0)
    });
    let mut m_phi = P.clone() * T::lit(f64::NAN);
    model.times_transition(&m, &phi_t, &mut m_phi);
    compare("times_transition vs M Φ", &m_phi, &(&m * &jac.Phi), agree)?;
    // a replay without covariances: `transition_transposed` must hand over the
    // Jacobians' Φᵀ; `noise_times` must be Q_d v
    let mut phi_t2 = P.clone() * T::lit(f64::NAN);
    model.transition_transposed(x, u, dt, &mut phi_t2);
    compare("transition_transposed vs jacobians", &phi_t2.transpose(), &jac.Phi, agree)?;
    let v = OMatrix::<T, StateDim<PM::State, T>, nalgebra::U1>::from_fn(|r, _| {
        T::lit(((r * 5 + 2) % 7) as f64 * 0.3 - 0.9)
    });
    let mut qv = v.clone() * T::lit(f64::NAN);
    let phi_t_v = &phi_t2 * &v;
    model.noise_times(x, u, dt, &phi_t2, &v, &phi_t_v, &mut qv);
    compare("noise_times vs Q_d v", &qv, &(&jac.Q * &v), agree)?;
    Ok(())
}

/// Relative agreement required between a model's combined call (`step`, `linearize`) and
/// its separate ones: the same formulas, up to rounding.
const STEP_AGREEMENT: f64 = 1e-9;

/// Check a measurement model's `H` against `∂(h(x ⊕ δ) ⊖ h(x))/∂δ` by central
/// differences (step 1e-6), and its `linearize` against `predict` and `jacobian` (to 1e-9
/// relative).
pub fn check_measurement_model<MM: MeasurementModel>(
    model: &MM,
    x: &MM::State,
    rel_tol: f64,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: FilterAlloc<StateDim<MM::State>, StateDim<MM::Measurement>>,
{
    check_measurement_model_with_step(model, x, rel_tol, 1e-6)
}

/// [`check_measurement_model`] with a chosen difference step.
pub fn check_measurement_model_with_step<MM: MeasurementModel>(
    model: &MM,
    x: &MM::State,
    rel_tol: f64,
    step: f64,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: FilterAlloc<StateDim<MM::State>, StateDim<MM::Measurement>>,
{
    check_measurement_model_in::<f64, MM>(model, x, rel_tol, step)
}

/// [`check_measurement_model_with_step`] for a model over the scalar `T` (e.g. `f32`, with
/// step [`T::DIFF_STEP`](manifolds::Real::DIFF_STEP) and [`jacobian_tolerance`]); the
/// combined calls agree to [`agreement_tolerance`].
pub fn check_measurement_model_in<T: FilterScalar, MM: MeasurementModel<T>>(
    model: &MM,
    x: &MM::State,
    rel_tol: f64,
    step: f64,
) -> Result<(), JacobianMismatch>
where
    DefaultAllocator: FilterAlloc<StateDim<MM::State, T>, StateDim<MM::Measurement, T>>,
{
    let agree = agreement_tolerance::<T>();
    let analytic = model.jacobian(x).H;
    let numeric = |h| numdiff::jacobian_between(x, |xp| model.predict(xp), h);
    compare_two_steps("measurement Jacobian H", &analytic, numeric, step, rel_tol)?;
    // `linearize` (often an override sharing work) must agree with the two separate calls.
    let (z_hat, jac) = model.linearize(x);
    let gap = z_hat.ominus(&model.predict(x));
    compare("linearize: h(x) vs predict", &gap, &gap.map(|_| T::zero()), agree)?;
    compare("linearize: H vs jacobian", &jac.H, &analytic, agree)?;
    // `innovation` (the filter's call) must agree with `linearize` and `residual`, at a
    // measurement a little away from the prediction.
    let offset = Tangent::<MM::Measurement, T>::from_fn(|i, _| T::lit(1e-3 * (i as f64 + 1.0)));
    let z = z_hat.oplus(&offset);
    let (r, jac) = model.innovation(x, &z);
    compare("innovation: r vs residual", &r, &model.residual(&z, &z_hat), agree)?;
    compare("innovation: H vs jacobian", &jac.H, &analytic, agree)
}

/// Numerical Jacobian of any map between manifolds, `∂(f(x ⊕ ε) ⊖ f(x))/∂ε`, for
/// checking Jacobians that are not part of a model trait (e.g. a continuous-time `F`).
pub fn numerical_jacobian<X: Manifold, Y: Manifold>(
    x: &X,
    f: impl Fn(&X) -> Y,
    step: f64,
) -> OMatrix<f64, Y::Dim, X::Dim>
where
    DefaultAllocator: DimAlloc<X::Dim> + DimAlloc<Y::Dim> + Allocator<Y::Dim, X::Dim>,
{
    numdiff::jacobian_between(x, f, step)
}
