//! The model traits: what a user implements to put a system into the filter.

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, OMatrix, OVector};

use manifolds::{DimAlloc, Manifold, Tangent};

use crate::dims::{Cov, FilterAlloc, StateDim};
use crate::scalar::FilterScalar;
use crate::stream::StreamId;

/// Jacobians of one prediction step, defined at zero error in the tangent spaces.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct ProcessJacobians<N: DimName, T: FilterScalar = f64>
where
    DefaultAllocator: Allocator<N, N>,
{
    /// Error-state transition `Φ = ∂(f(x ⊕ δ) ⊖ f(x))/∂δ` over the step.
    pub Phi: Cov<N, T>,
    /// Discrete process-noise covariance `Q_d` of the step (may depend on the state).
    pub Q: Cov<N, T>,
}

/// Measurement Jacobian `H = ∂(h(x ⊕ δ) ⊖ h(x))/∂δ` at `δ = 0`.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct MeasurementJacobians<M: DimName, N: DimName, T: FilterScalar = f64>
where
    DefaultAllocator: Allocator<M, N>,
{
    /// `∂h/∂δx` through ⊕ on the state and ⊖ on the measurement.
    pub H: OMatrix<T, M, N>,
}

/// A process model `x_{k+1} = f(x_k, u_k, dt)` with its error-state Jacobians.
///
/// Contract: stateless (evaluating it never mutates it); `Phi` is the Jacobian of
/// `f(x ⊕ δ) ⊖ f(x)` at `δ = 0` (right perturbation, see [`manifolds::Manifold`]);
/// `check_process_model` verifies it against
/// central differences.
///
/// ```
/// use estimator_core::{ProcessJacobians, ProcessModel};
/// use nalgebra::{Matrix2, Vector2};
///
/// /// 1-D constant velocity: state (position, velocity).
/// struct Cv { q: f64 }
/// impl ProcessModel for Cv {
///     type State = Vector2<f64>;
///     type Input = ();
///     fn propagate(&self, x: &Vector2<f64>, _: &(), dt: f64) -> Vector2<f64> {
///         Vector2::new(x[0] + dt * x[1], x[1])
///     }
///     fn jacobians(&self, _: &Vector2<f64>, _: &(), dt: f64) -> ProcessJacobians<nalgebra::U2> {
///         let Phi = Matrix2::new(1.0, dt, 0.0, 1.0);
///         // Q = q · [dt³/3 dt²/2; dt²/2 dt] (white-noise acceleration)
///         let Q = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * self.q;
///         ProcessJacobians { Phi, Q }
///     }
/// }
/// ```
pub trait ProcessModel<T: FilterScalar = f64>
where
    DefaultAllocator: DimAlloc<StateDim<Self::State, T>>,
{
    /// The state manifold.
    type State: Manifold<T>;
    /// The input (IMU sample, control …); `()` for autonomous models.
    type Input;

    /// Propagate the nominal state over `dt` seconds.
    fn propagate(&self, x: &Self::State, u: &Self::Input, dt: T) -> Self::State;

    /// Transition and process noise of the step from `x` over `dt`.
    fn jacobians(&self, x: &Self::State, u: &Self::Input, dt: T) -> ProcessJacobiansOf<Self, T>;

    /// The transition `Φ` alone (what a smoother's backward pass needs). The default takes
    /// it from [`jacobians`](Self::jacobians); override it when `Q_d` costs work of its own.
    fn transition(
        &self,
        x: &Self::State,
        u: &Self::Input,
        dt: T,
    ) -> Cov<StateDim<Self::State, T>, T> {
        self.jacobians(x, u, dt).Phi
    }

    /// The weighted mean of propagated sigma points, for the unscented prediction
    /// (FilterPy's `x_mean_fn`): `weights` are the points' mean weights, in order. `None`
    /// (the default) takes the mean on the manifold, the fixed-point iteration
    /// [`manifold_mean`](crate::unscented::manifold_mean). Override it to reproduce a
    /// recipe's own mean, e.g. an angle's `atan2(Σ wᵢ sin θᵢ, Σ wᵢ cos θᵢ)`.
    fn sigma_mean(&self, points: &[Self::State], weights: &[T]) -> Option<Self::State> {
        let _ = (points, weights);
        None
    }

    /// Both at once; override when they share work (mechanization and its Jacobians).
    fn step(
        &self,
        x: &Self::State,
        u: &Self::Input,
        dt: T,
    ) -> (Self::State, ProcessJacobiansOf<Self, T>) {
        (self.propagate(x, u, dt), self.jacobians(x, u, dt))
    }

    /// True when [`propagate_covariance`](Self::propagate_covariance) returns an exactly
    /// symmetric matrix, so the filter can skip symmetrising it. Default false.
    const SYMMETRIC_PROPAGATION: bool = false;

    /// True when [`step_covariance`](Self::step_covariance) is overridden to propagate
    /// without forming `Φ` and `Q_d` (the INS model). The static back-end then calls it and
    /// cannot check `Q_d`: the model is responsible for its noise, and
    /// `check_combined_calls` (feature `testing`)
    /// checks its `Q_d` and compares the fused step with the dense one. Default false: the
    /// back-ends form `Q_d` and check it (`check_process_noise`) at every prediction.
    const FUSED_STEP_COVARIANCE: bool = false;

    /// `out ← Φ P Φᵀ + Q`. The dense default (`crate::kernels::dense_sandwich`) costs
    /// about `1.5 N³` multiply-adds; override it to exploit the sparsity of Φ (the INS
    /// model does). `out` need not be symmetric on return; the filter symmetrises it.
    #[allow(non_snake_case)]
    fn propagate_covariance(
        &self,
        P: &Cov<StateDim<Self::State, T>, T>,
        jac: &ProcessJacobians<StateDim<Self::State, T>, T>,
        out: &mut Cov<StateDim<Self::State, T>, T>,
    ) {
        // P⁻ = Φ P Φᵀ + Q_d
        T::dense_sandwich(&jac.Phi, P, &jac.Q, out);
    }

    /// The whole prediction in one call: returns `x⁺` and writes `out ← Φ P Φᵀ + Q_d`.
    /// The default is [`step`](Self::step) then
    /// [`propagate_covariance`](Self::propagate_covariance); override it when `Φ` and
    /// `Q_d` need not be formed as dense matrices (the INS model keeps only their non-zero
    /// blocks). The static back-end's filter calls it unless the strategy has adjusted
    /// `Q_d` ([`QAdjust`](crate::QAdjust)); the law harness checks it against the separate
    /// calls. The symmetry contract is that of `propagate_covariance`.
    #[allow(non_snake_case)]
    fn step_covariance(
        &self,
        x: &Self::State,
        u: &Self::Input,
        dt: T,
        P: &Cov<StateDim<Self::State, T>, T>,
        out: &mut Cov<StateDim<Self::State, T>, T>,
    ) -> Self::State {
        let (x_next, jac) = self.step(x, u, dt);
        self.propagate_covariance(P, &jac, out);
        x_next
    }

    /// [`step_covariance`](Self::step_covariance) that also writes the transition's
    /// transpose `Φᵀ` into `phi_t`: what a smoother's replay needs of each step. The
    /// default is [`transition`](Self::transition) then `step_covariance`; a model whose
    /// fused step forms `Φ` anyway (the INS model) hands it over instead. The prediction
    /// must be bit for bit that of `step_covariance` (the harness checks it).
    #[allow(non_snake_case)]
    fn step_covariance_adjoint(
        &self,
        x: &Self::State,
        u: &Self::Input,
        dt: T,
        P: &Cov<StateDim<Self::State, T>, T>,
        out: &mut Cov<StateDim<Self::State, T>, T>,
        phi_t: &mut Cov<StateDim<Self::State, T>, T>,
    ) -> Self::State {
        self.transition(x, u, dt).transpose_to(phi_t);
        self.step_covariance(x, u, dt, P, out)
    }

    /// The transition's transpose `Φᵀ` alone, written into `phi_t`: what a smoother's
    /// backward pass needs of a replayed step, whose nominal states the replay gives
    /// ([`propagate`](Self::propagate)). The default transposes
    /// [`transition`](Self::transition); override it when `Φ` costs less than the
    /// Jacobians (the harness checks it against them). The backward pass forms it on the
    /// thread that uses it: `Φᵀ` handed from a replay thread to the recursion's cost more
    /// in moving its cache lines between cores than forming it (`docs/history/benches.md`).
    fn transition_transposed(
        &self,
        x: &Self::State,
        u: &Self::Input,
        dt: T,
        phi_t: &mut Cov<StateDim<Self::State, T>, T>,
    ) {
        self.transition(x, u, dt).transpose_to(phi_t);
    }

    /// `out ← Q_d v` for the step from `x` over `dt` whose transition's transpose is
    /// `phi_t`, given `phi_t_v = Φᵀ v` too (a smoother's forward sweep of the smoothed
    /// mean, which has both). The default forms `Q_d` ([`jacobians`](Self::jacobians));
    /// override it when `Q_d` has a structure that makes the product cheap (the INS model:
    /// `Q_d = Φ E Φᵀ + E` with a block-diagonal `E`).
    #[allow(clippy::too_many_arguments)]
    fn noise_times(
        &self,
        x: &Self::State,
        u: &Self::Input,
        dt: T,
        phi_t: &Cov<StateDim<Self::State, T>, T>,
        v: &OVector<T, StateDim<Self::State, T>>,
        phi_t_v: &OVector<T, StateDim<Self::State, T>>,
        out: &mut OVector<T, StateDim<Self::State, T>>,
    ) {
        let _ = (phi_t, phi_t_v);
        self.jacobians(x, u, dt).Q.mul_to(v, out);
    }

    /// `out ← Φᵀ Λ Φ` for a symmetric `Λ`, given `Φᵀ` (`phi_t`): the adjoint step of a
    /// smoother's backward pass. The result must be exactly symmetric. The dense default
    /// costs about `1.5 N³` multiply-adds; override it to exploit the sparsity of `Φ` (the
    /// INS model does).
    fn adjoint_sandwich(
        &self,
        phi_t: &Cov<StateDim<Self::State, T>, T>,
        lambda: &Cov<StateDim<Self::State, T>, T>,
        out: &mut Cov<StateDim<Self::State, T>, T>,
    ) {
        T::dense_sandwich(phi_t, lambda, &Cov::<StateDim<Self::State, T>, T>::zeros(), out);
    }

    /// `out ← M Φ` for any square `M`, given `Φᵀ` (`phi_t`): a smoother's product of a
    /// segment's transitions `Ψ = Φₙ₋₁ ⋯ Φ₀`, accumulated backwards one step at a time
    /// (the segment smoother's `AdjointForm::Accumulated`). The dense default
    /// costs `N³` multiply-adds; override it to skip the zeros of `Φ` (the INS model does).
    fn times_transition(
        &self,
        m: &Cov<StateDim<Self::State, T>, T>,
        phi_t: &Cov<StateDim<Self::State, T>, T>,
        out: &mut Cov<StateDim<Self::State, T>, T>,
    ) {
        T::mat_mul(m, &phi_t.transpose(), out);
    }

    /// Fold input `u` into `sum`, the combined input of a stretch of steps whose
    /// covariance is propagated as one step ([`ErrorStateFilter::predict_covariance`]
    /// over the stretch's summed interval; `sum` is `None` at the stretch's first step).
    /// Returns `false` when the model has no such combined step (the default, which
    /// leaves `sum` alone): a smoother then takes every step of such a stretch on its own.
    ///
    /// [`ErrorStateFilter::predict_covariance`]: crate::ErrorStateFilter::predict_covariance
    fn fold_input(&self, sum: &mut Option<Self::Input>, u: &Self::Input) -> bool {
        let _ = (sum, u);
        false
    }
}

/// The [`ProcessJacobians`] of a process model (over the scalar `T`).
pub type ProcessJacobiansOf<PM, T = f64> =
    ProcessJacobians<StateDim<<PM as ProcessModel<T>>::State, T>, T>;

/// The [`MeasurementJacobians`] of a measurement model (over the scalar `T`).
pub type JacobiansOf<MM, T = f64> = MeasurementJacobians<
    StateDim<<MM as MeasurementModel<T>>::Measurement, T>,
    StateDim<<MM as MeasurementModel<T>>::State, T>,
    T,
>;

/// A measurement model `z = h(x) ⊕ v`, `v ~ N(0, R)`, where `z` may live on a manifold.
///
/// The residual is `r = z ⊖ h(x̂)` (so a bearing that crosses ±π gives a small residual,
/// not 2π). Contract: stateless; `H = ∂(h(x ⊕ δ) ⊖ h(x))/∂δ` at `δ = 0`, checked by
/// `check_measurement_model`.
pub trait MeasurementModel<T: FilterScalar = f64>
where
    DefaultAllocator: FilterAlloc<StateDim<Self::State, T>, StateDim<Self::Measurement, T>>,
{
    /// The state manifold.
    type State: Manifold<T>;
    /// The measurement manifold (`SVector<f64, M>` for plain vectors).
    type Measurement: Manifold<T>;

    /// Predicted measurement `h(x)`.
    fn predict(&self, x: &Self::State) -> Self::Measurement;

    /// `H` at `x`. Default: central differences through `⊕` on the state and `⊖` on the
    /// measurement (step [`Real::DIFF_STEP`](manifolds::Real::DIFF_STEP)), so a model
    /// used only through sigma points (the unscented update calls `predict` alone) needs
    /// none, and any other model works before its analytic `H` is written; override it
    /// where speed or accuracy matter (the harness compares an override with these
    /// differences).
    fn jacobian(&self, x: &Self::State) -> JacobiansOf<Self, T> {
        MeasurementJacobians {
            H: manifolds::numdiff::jacobian_between(x, |p| self.predict(p), T::DIFF_STEP),
        }
    }

    /// `h(x)` and `H` at once; override when they share work (rotation matrices, Earth
    /// rates). [`innovation`](Self::innovation)'s default, which the filter calls, calls
    /// this one; the harness checks it against the two above.
    fn linearize(&self, x: &Self::State) -> (Self::Measurement, JacobiansOf<Self, T>) {
        (self.predict(x), self.jacobian(x))
    }

    /// Residual `z ⊖ ẑ`.
    fn residual(
        &self,
        z: &Self::Measurement,
        z_hat: &Self::Measurement,
    ) -> Tangent<Self::Measurement, T> {
        z.ominus(z_hat)
    }

    /// The innovation `z ⊖ h(x)` and `H` at `x`: what the filter calls at every update.
    /// Default: [`linearize`](Self::linearize) then [`residual`](Self::residual). Override
    /// when the residual can reuse the prediction's work (the geodetic metric of a GNSS
    /// position); the harness checks the override against those two.
    fn innovation(
        &self,
        x: &Self::State,
        z: &Self::Measurement,
    ) -> (Tangent<Self::Measurement, T>, JacobiansOf<Self, T>) {
        let (z_hat, jac) = self.linearize(x);
        (self.residual(z, &z_hat), jac)
    }

    /// The weighted mean of the sigma points' predicted measurements, for the unscented
    /// update (FilterPy's `z_mean_fn`); `None` (the default): the mean on the manifold, as
    /// [`ProcessModel::sigma_mean`].
    fn sigma_mean(&self, points: &[Self::Measurement], weights: &[T]) -> Option<Self::Measurement> {
        let _ = (points, weights);
        None
    }

    /// The measurement stream this model feeds; adaptive strategies keep one window per
    /// stream. Default: one stream per model type. Override to split one type into
    /// several streams (two antennas, two cameras).
    fn stream(&self) -> StreamId {
        StreamId::of::<Self>()
    }
}
