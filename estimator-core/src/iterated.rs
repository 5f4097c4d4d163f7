//! [`update_iterated`] and what serves it (the documentation is on the item).

use nalgebra::{DefaultAllocator, OMatrix};

use manifolds::Manifold;

use crate::backend::CovBackend;
use crate::dims::{Cov, FilterAlloc, StateDim};
use crate::error::FilterError;
use crate::filter::ErrorStateFilter;
use crate::filter::ResetMode;
use crate::linalg::{check_finite, cholesky, symmetrize, whitened_norm_sq};
use crate::report::{NoObserver, Observer, UpdateReport};
use crate::smoother::{reframe, Reframe};
use crate::traits::MeasurementModel;
use crate::{NoiseStrategy, Verdict};

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
    /// The strategy's verdict on the innovation at the prior (`Rejected`: nothing changed,
    /// no iteration).
    pub verdict: crate::Verdict,
    /// The update's report as a plain update gives it (stream, adapted NIS, reason, the
    /// strategy's factors, the subspace fallback and `not_helping` flags), dimension-free;
    /// [`update_iterated_observed`](ErrorStateFilter::update_iterated_observed) returns it
    /// whole.
    pub update: crate::UpdateSummary,
}

impl<X, A, B> ErrorStateFilter<X, A, B>
where
    X: Manifold,
    A: NoiseStrategy,
    B: CovBackend<X::Dim>,
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    /// The iterated update (below): at most `max_iterations`
    /// linearisations (≥ 1), stopping when a step's norm is at most `tolerance`. On `Err`
    /// the state and covariance are unchanged.
    ///
    /// The iterated update: Gauss–Newton on the manifold for a measurement too nonlinear for
    /// one linearisation (the iterated error-state filter of IKFoM and FAST-LIO).
    ///
    /// From the prior `x⁻, P⁻`, each iteration `j` linearises the measurement at `x_j`
    /// (`r_j = z ⊖ h(x_j)`, `H_j`), moves the prior into `x_j`'s tangent space with the
    /// Jacobian of `⊖` (`δ_j = x_j ⊖ x⁻`, `J_j = ∂(x_j ⊖ x⁻)/∂x_j`, `P_j = J_j⁻¹ P⁻ J_j⁻ᵀ`),
    /// and takes the maximum-a-posteriori step
    ///
    /// `Δ_j = K_j (r_j + H_j J_j⁻¹ δ_j) − J_j⁻¹ δ_j`, `K_j = P_j H_jᵀ (H_j P_j H_jᵀ + R)⁻¹`,
    ///
    /// `x_{j+1} = x_j ⊕ Δ_j`, until `‖Δ_j‖ ≤ tolerance` or `max_iterations`. The covariance is
    /// the Joseph form at the last linearisation, `(I − K H) P_j (I − K H)ᵀ + K R Kᵀ`, taken
    /// to the new estimate by the reset `G(x_j, Δ_j)` as the plain update does (under
    /// [`ResetMode::Exact`]). One iteration is the plain error-state update (on SO(3) too). Without the transport `J_j` (taking it as
    /// the identity) the iteration still converges on a curved state, but to a slightly
    /// different point and more slowly.
    ///
    /// The update goes through the same steps as the plain one before and after the
    /// iterations: the innovation at the prior is judged by the noise strategy (the gate's
    /// verdict; a rejected measurement changes nothing), the iterations use the strategy's
    /// `R*` and its prior scale `λ_P` (on the whole prior), and the strategy and the observer
    /// receive the update's report and last gain, so adaptation, gating and telemetry work
    /// for iterated updates as for plain ones.
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
        self.update_iterated_observed(model, z, R, max_iterations, tolerance, &mut NoObserver)
            .map(|(report, _)| report)
    }

    /// [`update_iterated`](Self::update_iterated) with an observer that receives the
    /// update's report; also returns that report (`S`, NIS and adapted NIS at the prior,
    /// the verdict and the strategy's factors).
    #[allow(clippy::type_complexity)]
    pub fn update_iterated_observed<MM, O>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement>>,
        max_iterations: usize,
        tolerance: f64,
        observer: &mut O,
    ) -> Result<(IteratedReport, UpdateReport<StateDim<MM::Measurement>>), FilterError>
    where
        MM: MeasurementModel<State = X>,
        O: Observer,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement>>,
    {
        // the innovation at the prior and the strategy's decision on it, as a plain update
        let inn = self.innovate(model, z, R)?;
        let decision = self.adapt(model.stream(), &inn, R);
        let mut update = self.report_of(&inn, &decision);
        let mut report = IteratedReport {
            iterations: 0,
            converged: false,
            nis: inn.nis,
            post_fit: f64::NAN,
            verdict: decision.verdict,
            update: update.summary(),
        };
        if decision.verdict == Verdict::Rejected {
            self.reject(&decision, &update, observer);
            return Ok((report, update));
        }
        let lambda = decision.prior_scale;
        if !(lambda.is_finite() && lambda > 0.0) {
            self.restore_strategy();
            return Err(FilterError::NonFinite { what: "strategy prior scale λ_P" });
        }
        if let Err(e) = Self::adapted_innovation(&decision, R, &inn, &inn.HPHt, &mut update) {
            self.restore_strategy();
            return Err(e);
        }
        report.update = update.summary();
        match self.iterate(model, z, &decision.R, lambda, max_iterations, tolerance, &mut report) {
            Ok(k) => {
                self.after_correction(&k, &decision, &update, observer);
                Ok((report, update))
            }
            Err(e) => {
                self.restore_strategy();
                Err(e)
            }
        }
    }

    /// The Gauss–Newton iterations from the prior (scaled by `lambda`) with noise `R`;
    /// sets the state and covariance and returns the last gain.
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn iterate<MM>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement>>,
        lambda: f64,
        max_iterations: usize,
        tolerance: f64,
        report: &mut IteratedReport,
    ) -> Result<OMatrix<f64, X::Dim, StateDim<MM::Measurement>>, FilterError>
    where
        MM: MeasurementModel<State = X>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement>>,
    {
        let prior = self.state().clone();
        let mut p_prior = self.covariance().into_owned();
        if lambda != 1.0 {
            p_prior *= lambda;
        }
        let mut x = prior.clone();
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
        Ok(k)
    }
}
