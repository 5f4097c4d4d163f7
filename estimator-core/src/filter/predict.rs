//! The prediction: whole, or its state and covariance halves at different rates.

use super::*;

#[allow(non_snake_case)]
impl<T: FilterScalar, X: Manifold<T>, A: NoiseStrategy<T>, B: CovBackend<X::Dim, T>>
    ErrorStateFilter<X, A, B, T>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// Propagate to the absolute time `t` (s): [`predict`](Self::predict) over
    /// `t − time()`, after which the filter's time is `t` exactly — stamps compare equal
    /// however many steps led there (a sum of steps drifts: 200 steps of 0.1 s sum to
    /// 20.000000000000014). A `t` before the filter's time is an error; on `Err` the
    /// filter is unchanged.
    pub fn predict_to<PM>(&mut self, model: &PM, u: &PM::Input, t: f64) -> Result<(), FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        let dt = t - self.time;
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(FilterError::InvalidTimeStep { dt });
        }
        self.predict(model, u, T::lit(dt))?;
        self.time = t;
        Ok(())
    }

    /// Propagate over `dt ≥ 0` seconds with `model` and input `u`:
    /// `x̂⁻ = f(x̂, u, dt)`, `P⁻ = λ Φ P Φᵀ + Q_d` (λ = 1 unless the strategy fades), by the
    /// back-end's [`CovBackend::predict`]. `Q_d` is checked (finite, symmetric, positive
    /// semi-definite) whenever it is formed; on `Err` the filter is unchanged.
    pub fn predict<PM>(&mut self, model: &PM, u: &PM::Input, dt: T) -> Result<(), FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        let x_next = self.propagate_covariance_at(model, None, u, dt)?;
        self.x = x_next;
        self.commit();
        self.time += dt.to_f64();
        Ok(())
    }

    /// The state's half of a prediction: `x̂⁻ = f(x̂, u, dt)` and the clock advanced by
    /// `dt`, the covariance left as it is. With
    /// [`predict_covariance`](Self::predict_covariance) this propagates the covariance
    /// at a lower rate than the state (PX4's EKF2 does so): several state steps, then one
    /// covariance step over their whole interval with their inputs combined, taken before
    /// any update. Between the two the covariance is that of the last covariance step.
    /// On `Err` the filter is unchanged.
    pub fn predict_state<PM>(&mut self, model: &PM, u: &PM::Input, dt: T) -> Result<(), FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        if !(dt.is_finite() && dt >= T::zero()) {
            return Err(FilterError::InvalidTimeStep { dt: dt.to_f64() });
        }
        let x_next = model.propagate(&self.x, u, dt);
        if !x_next.is_finite() {
            return Err(FilterError::NonFinite { what: "propagated state" });
        }
        self.x = x_next;
        self.time += dt.to_f64();
        Ok(())
    }

    /// The covariance's half of a prediction: `P⁻ = λⁿ Φ P Φᵀ + Q_d` with `Φ` and `Q_d`
    /// of `model` at the state `x_ref` (the state where the interval began), input `u` and
    /// interval `dt`, as [`predict`](Self::predict) forms them; `n = steps`, the state
    /// steps this covariance step stands for (a strategy's fading λ is per prediction).
    /// The state and the clock are left as they are (see
    /// [`predict_state`](Self::predict_state)). On `Err` the filter is unchanged.
    pub fn predict_covariance<PM>(
        &mut self,
        model: &PM,
        x_ref: &X,
        u: &PM::Input,
        dt: T,
        steps: u32,
    ) -> Result<(), FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        self.propagate_covariance_at(model, Some((x_ref, steps)), u, dt)?;
        self.commit();
        Ok(())
    }

    /// `λⁿ Φ P Φᵀ + Q_d` at `x_ref` and over `n` steps (default: the filter's state, one
    /// step) into the next buffer (committed by the caller), `Q_Σ` carried along; returns
    /// `f(x_ref, u, dt)`.
    fn propagate_covariance_at<PM>(
        &mut self,
        model: &PM,
        x_ref: Option<(&X, u32)>,
        u: &PM::Input,
        dt: T,
    ) -> Result<X, FilterError>
    where
        PM: ProcessModel<T, State = X>,
    {
        if !(dt.is_finite() && dt >= T::zero()) {
            return Err(FilterError::InvalidTimeStep { dt: dt.to_f64() });
        }
        let fading = self.strategy.prediction_fading();
        if !(fading.is_finite() && fading > 0.0) {
            return Err(FilterError::NonFinite { what: "strategy prediction fading λ" });
        }
        let (x, fading) = match x_ref {
            Some((x, steps)) => (x, T::lit(fading_over(fading, steps))),
            None => (&self.x, T::lit(fading)),
        };
        let (P, next, aux) = Self::split(&mut self.bufs, self.cur);
        // the back-end owns the path: the model's structured products on the static one,
        // dense products on the heap ones
        let x_next = self.backend.predict(model, x, u, dt, P, fading, &self.q_adjust, next)?;
        if !x_next.is_finite() {
            return Err(FilterError::NonFinite { what: "propagated state" });
        }
        B::check_finite("propagated covariance P", next)?;
        // the invariant: in full when the strategy changed the prediction (a fading λ, an
        // adapted Q), else on the diagonal
        let touched = fading != T::one() || !matches!(self.q_adjust, QAdjust::Keep);
        Self::check_positive_definite(next, touched, "prediction", &self.strategy)?;
        if self.strategy.tracks_process_noise() {
            // Q_Σ ← Φ Q_Σ Φᵀ + Q_d, by the same path (into the auxiliary buffer, swapped in
            // only when it succeeded, so that `Err` leaves Q_Σ as it was)
            let q_sum =
                self.q_sum.get_or_insert_with(|| B::from_static(&Cov::<X::Dim, T>::zeros()));
            self.backend.predict(model, x, u, dt, q_sum, T::one(), &self.q_adjust, aux)?;
            B::check_finite("accumulated process noise Q_Σ", aux)?;
            core::mem::swap(q_sum, aux);
        }
        Ok(x_next)
    }

    /// Take up a prediction made outside [`predict`](Self::predict) (the sigma-point
    /// one): the propagated state and covariance (checked), the interval, and the
    /// transition and process noise that carry `Q_Σ` for a strategy that tracks it. On
    /// `Err` the filter is unchanged.
    #[cfg(feature = "std")]
    pub(crate) fn finish_prediction(
        &mut self,
        x: X,
        P: Cov<X::Dim, T>,
        dt: f64,
        Phi: &Cov<X::Dim, T>,
        Q: &Cov<X::Dim, T>,
    ) -> Result<(), FilterError> {
        if !x.is_finite() {
            return Err(FilterError::NonFinite { what: "propagated state" });
        }
        let P = B::from_static(&checked_symmetric("propagated covariance P⁻", P)?);
        if self.strategy.tracks_process_noise() {
            let q_sum =
                self.q_sum.get_or_insert_with(|| B::from_static(&Cov::<X::Dim, T>::zeros()));
            let mut next = Phi * B::as_static(q_sum).as_ref() * Phi.transpose() + Q;
            symmetrize(&mut next);
            check_finite("accumulated process noise Q_Σ", &next)?;
            *q_sum = B::from_static(&next);
        }
        let next = (self.cur + 1) % 3;
        self.bufs[next] = P;
        self.x = x;
        self.commit();
        self.time += dt;
        Ok(())
    }
}

/// A strategy's prediction fading `λ` over one covariance step that stands for `steps`
/// state steps: `λⁿ` (the fading is per prediction). The smoother's backward pass takes
/// it so too, where it replays or sweeps such a stretch.
pub(crate) fn fading_over(fading: f64, steps: u32) -> f64 {
    if fading != 1.0 {
        fading.powi(steps.max(1) as i32)
    } else {
        fading
    }
}
