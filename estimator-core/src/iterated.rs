//! The iterated update: Gauss–Newton on the manifold for a measurement too nonlinear for
//! one linearisation (the iterated error-state filter of IKFoM and FAST-LIO).
//!
//! From the prior `x⁻, P⁻`, each iteration `j` linearises the measurement at `x_j`
//! (`r_j = z ⊖ h(x_j)`, `H_j`), moves the prior into `x_j`'s tangent space with the
//! Jacobian of `⊖` (`δ_j = x_j ⊖ x⁻`, `J_j = ∂(x_j ⊖ x⁻)/∂x_j`, `P_j = J_j⁻¹ P⁻ J_j⁻ᵀ`),
//! and takes the maximum-a-posteriori step
//!
//! `Δ_j = K_j (r_j + H_j J_j⁻¹ δ_j) − J_j⁻¹ δ_j`, `K_j = P_j H_jᵀ (H_j P_j H_jᵀ + R)⁻¹`,
//!
//! `x_{j+1} = x_j ⊕ Δ_j`, until `‖Δ_j‖ ≤ tolerance` or `max_iterations`. The covariance is
//! the Joseph form at the last linearisation, `(I − K H) P_j (I − K H)ᵀ + K R Kᵀ`, taken
//! to the new estimate by the reset `G(x_j, Δ_j)` as the plain update does (under
//! [`ResetMode::Exact`]). One iteration is the plain error-state update (on SO(3) too). Without the transport `J_j` (taking it as
//! the identity) the iteration still converges on a curved state, but to a slightly
//! different point and more slowly.
//!
//! The noise strategy is not consulted: `R` is used as given, and the update is not
//! reported to a strategy or an observer.

use nalgebra::{DefaultAllocator, OMatrix};

use manifolds::Manifold;

use crate::backend::CovBackend;
use crate::dims::{Cov, FilterAlloc, StateDim};
use crate::error::FilterError;
use crate::filter::ErrorStateFilter;
use crate::filter::ResetMode;
use crate::linalg::{check_covariance, check_finite, cholesky, symmetrize, whitened_norm_sq};
use crate::smoother::{reframe, Reframe};
use crate::traits::MeasurementModel;
use crate::NoiseStrategy;

/// What an iterated update did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IteratedReport {
    /// Linearisations made.
    pub iterations: usize,
    /// The last step was within the tolerance.
    pub converged: bool,
    /// NIS of the innovation at the prior (`rᵀ S⁻¹ r`, as the plain update reports it).
    pub nis: f64,
    /// The post-fit residual `z ⊖ h(x⁺)` whitened by `R` (`rᵀ R⁻¹ r`).
    pub post_fit: f64,
}

impl<X, A, B> ErrorStateFilter<X, A, B>
where
    X: Manifold,
    A: NoiseStrategy,
    B: CovBackend<X::Dim>,
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    /// The iterated update (see the [module](crate::iterated)): at most `max_iterations`
    /// linearisations (≥ 1), stopping when a step's norm is at most `tolerance`. On `Err`
    /// the state and covariance are unchanged.
    pub fn update_iterated<MM>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement>>,
        max_iterations: usize,
        tolerance: f64,
    ) -> Result<IteratedReport, FilterError>
    where
        MM: MeasurementModel<State = X>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement>>,
    {
        check_covariance("measurement noise R", R)?;
        let prior = self.state().clone();
        let p_prior = self.covariance().into_owned();
        let mut x = prior.clone();
        let mut report =
            IteratedReport { iterations: 0, converged: false, nis: f64::NAN, post_fit: f64::NAN };
        let (mut gain, mut h, mut p_j) = (None, None, p_prior.clone());
        let (mut x_j, mut last_step) = (x.clone(), None);
        for _ in 0..max_iterations.max(1) {
            let (r, jac) = model.innovation(&x, z);
            check_finite("innovation", &r)?;
            let delta = x.ominus(&prior);
            let j_inv = x
                .ominus_jacobians(&prior)
                .J_d_y
                .try_inverse()
                .ok_or(FilterError::NonFinite { what: "inverse of the ⊖ Jacobian" })?;
            p_j = &j_inv * &p_prior * j_inv.transpose();
            symmetrize(&mut p_j);
            let hp = &jac.H * &p_j;
            let mut s = &hp * jac.H.transpose() + R;
            symmetrize(&mut s);
            let chol = cholesky("innovation covariance S", s)?;
            if report.iterations == 0 {
                report.nis = whitened_norm_sq(&chol, &r);
            }
            // K = P Hᵀ S⁻¹ = (S⁻¹ H P)ᵀ
            let k: OMatrix<f64, X::Dim, StateDim<MM::Measurement>> = chol.solve(&hp).transpose();
            let back = &j_inv * &delta;
            let step = &k * (&r + &jac.H * &back) - &back;
            check_finite("iterated step", &step)?;
            x_j = x.clone();
            x = x.oplus(&step);
            report.iterations += 1;
            gain = Some(k);
            h = Some(jac.H);
            let small = step.norm() <= tolerance;
            last_step = Some(step);
            if small {
                report.converged = true;
                break;
            }
        }
        let (k, h) = (gain.expect("one iteration"), h.expect("one iteration"));
        let i_kh = OMatrix::<f64, X::Dim, X::Dim>::identity() - &k * &h;
        let mut p = &i_kh * &p_j * i_kh.transpose() + &k * R * k.transpose();
        symmetrize(&mut p);
        // the reset of the last step, as the plain update's: P ← G P Gᵀ at x_j ⊕ Δ
        if let (ResetMode::Exact, Some(step)) = (self.reset_mode(), &last_step) {
            reframe(&x_j, step, &mut p, Reframe::OutOf)?;
        }
        if !x.is_finite() {
            return Err(FilterError::NonFinite { what: "updated state" });
        }
        let (r, _) = model.innovation(&x, z);
        let r_chol = cholesky("measurement noise R", R.clone())?;
        report.post_fit = whitened_norm_sq(&r_chol, &r);
        let saved = self.state().clone();
        self.set_state(x)?;
        if let Err(e) = self.set_covariance(p) {
            self.set_state(saved)?;
            return Err(e);
        }
        Ok(report)
    }
}
