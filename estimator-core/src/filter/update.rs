//! The update in named steps: innovate → adapt → gain → correct (update and inject) →
//! finish, as the module table gives them.

use super::*;

#[allow(non_snake_case)]
impl<T: FilterScalar, X: Manifold<T>, A: NoiseStrategy<T>, B: CovBackend<X::Dim, T>>
    ErrorStateFilter<X, A, B, T>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// Update with measurement `z` of `model` and noise `R` (checked: finite, symmetric,
    /// positive definite). Returns the report; a rejected measurement is `Ok` with
    /// `verdict = Rejected`. On `Err` the state and covariance are unchanged.
    pub fn update<MM>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement, T>, T>,
    ) -> Result<UpdateReport<StateDim<MM::Measurement, T>, T>, FilterError>
    where
        MM: MeasurementModel<T, State = X>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement, T>>,
    {
        self.update_observed(model, z, R, &mut NoObserver)
    }

    /// [`update`](Self::update) with an observer that receives the report.
    pub fn update_observed<MM, O>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement, T>, T>,
        observer: &mut O,
    ) -> Result<UpdateReport<StateDim<MM::Measurement, T>, T>, FilterError>
    where
        MM: MeasurementModel<T, State = X>,
        O: Observer<T>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement, T>>,
    {
        self.update_with_gain(model, z, R, observer).map(|(report, _)| report)
    }

    /// [`update_observed`](Self::update_observed) that also returns the gain actually
    /// used, `K = P⁻* Hᵀ S*⁻¹` (`N × M`; `None` when the measurement was rejected).
    #[allow(clippy::type_complexity)]
    pub fn update_with_gain<MM, O>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement, T>, T>,
        observer: &mut O,
    ) -> Result<
        (
            UpdateReport<StateDim<MM::Measurement, T>, T>,
            Option<OMatrix<T, X::Dim, StateDim<MM::Measurement, T>>>,
        ),
        FilterError,
    >
    where
        MM: MeasurementModel<T, State = X>,
        O: Observer<T>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement, T>>,
    {
        let inn = self.innovate(model, z, R)?;
        let decision = self.adapt(model.stream(), &inn, R);
        let mut report = self.report_of(&inn, &decision);
        if decision.verdict == Verdict::Rejected {
            self.reject(&decision, &report, observer);
            return Ok((report, None));
        }
        let (x_new, K) = match self.correct(&inn, &decision, R, &mut report) {
            Ok(v) => v,
            Err(e) => {
                self.restore_strategy();
                return Err(e);
            }
        };
        self.finish(x_new, &K, &decision, &report, observer);
        Ok((report, Some(K)))
    }

    /// Put back the strategy as it was before step *adapt* (an update that fails after it
    /// leaves the strategy unchanged too).
    pub(crate) fn restore_strategy(&mut self) {
        if let Some(saved) = &mut self.saved {
            core::mem::swap(&mut self.strategy, saved);
        }
    }

    /// The report of an update as the strategy decided it (the adapted NIS follows in
    /// [`correct`](Self::correct)).
    pub(crate) fn report_of<M: DimName>(
        &self,
        inn: &Innovated<X::Dim, M, T>,
        d: &Decision<X::Dim, M, T>,
    ) -> UpdateReport<M, T>
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        UpdateReport {
            stream: d.stream,
            epoch: d.epoch,
            time: self.time,
            innovation: inn.r().clone(),
            S: inn.S.clone(),
            nis: inn.nis,
            nis_adapted: f64::NAN,
            verdict: d.verdict,
            reason: d.reason,
            factors: d.factors,
            prior_scaling_fallback: false,
            not_helping: d.not_helping,
            log_likelihood: log_likelihood(&inn.chol_S, inn.nis),
        }
    }

    /// A rejected measurement: counted, the strategy's process-noise request taken up,
    /// the observer told; state and covariance unchanged.
    pub(crate) fn reject<M: DimName, O: Observer<T>>(
        &mut self,
        d: &Decision<X::Dim, M, T>,
        report: &UpdateReport<M, T>,
        observer: &mut O,
    ) where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        self.epoch = d.epoch;
        self.apply_q(&d.q);
        observer.on_update(report);
    }

    /// Step *innovate*: `r = z ⊖ h(x̂⁻)` and `H` (checked finite), `P⁻ Hᵀ`,
    /// `S = H P⁻ Hᵀ + R` and its Cholesky factor, the NIS `rᵀ S⁻¹ r`, and `H Q_Σ Hᵀ` for a
    /// strategy that tracks the process noise since the last update.
    #[allow(non_snake_case, clippy::type_complexity)]
    pub(crate) fn innovate<MM>(
        &mut self,
        model: &MM,
        z: &MM::Measurement,
        R: &Cov<StateDim<MM::Measurement, T>, T>,
    ) -> Result<Innovated<X::Dim, StateDim<MM::Measurement, T>, T>, FilterError>
    where
        MM: MeasurementModel<T, State = X>,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement, T>>,
    {
        if !z.is_finite() {
            return Err(FilterError::NonFinite { what: "measurement z" });
        }
        check_covariance("measurement noise R", R)?;
        // (kept as the returned pair: destructuring it would copy `H`)
        let innovation = model.innovation(&self.x, z);
        check_finite("innovation r = z ⊖ h(x)", &innovation.0)?;
        check_finite("measurement Jacobian H", &innovation.1.H)?;
        let H = &innovation.1.H;
        // S = H P⁻ Hᵀ + R
        let PHt = self.backend.p_times_ht(H, &self.bufs[self.cur]);
        let mut HPHt =
            OMatrix::<T, StateDim<MM::Measurement, T>, StateDim<MM::Measurement, T>>::zeros();
        T::mat_mul(H, &PHt, &mut HPHt);
        let mut S = &HPHt + R;
        symmetrize(&mut S);
        // H Q_Σ Hᵀ for a strategy that tracks the process noise since the last update
        let QHt = match (&self.q_sum, self.strategy.tracks_process_noise()) {
            (Some(q_sum), true) => Some(self.backend.p_times_ht(H, q_sum)),
            _ => None,
        };
        let HQHt = QHt.as_ref().map(|QHt| {
            let mut m =
                OMatrix::<T, StateDim<MM::Measurement, T>, StateDim<MM::Measurement, T>>::zeros();
            T::mat_mul(H, QHt, &mut m);
            symmetrize(&mut m);
            m
        });
        let chol_S = cholesky("innovation covariance S = H P Hᵀ + R", S.clone())?;
        // NIS = rᵀ S⁻¹ r
        let nis = whitened_norm_sq(&chol_S, &innovation.0).to_f64();
        Ok(Innovated { innovation, PHt, HPHt, S, chol_S, QHt, HQHt, nis })
    }

    /// Step *adapt*: the strategy's decision on the innovation — the verdict, the prior's
    /// scale `λ_P`, the noise `R*`, a process-noise request. The strategy as it was is
    /// kept, so that a later failure can restore it.
    #[allow(non_snake_case)]
    pub(crate) fn adapt<M: DimName>(
        &mut self,
        stream: crate::StreamId,
        inn: &Innovated<X::Dim, M, T>,
        R: &Cov<M, T>,
    ) -> Decision<X::Dim, M, T>
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        let epoch = self.epoch + 1;
        let mut a = Adaptation {
            stream,
            epoch,
            time: self.time,
            innovation: inn.r(),
            H: inn.H(),
            P_prior: CovView::new(&self.bufs[self.cur]),
            HPHt: &inn.HPHt,
            HQHt: inn.HQHt.as_ref(),
            R_nominal: R,
            S: &inn.S,
            nis: inn.nis,
            prior_scale: 1.0,
            prior_scaling: PriorScaling::default(),
            scale_propagated_only: false,
            R: R.clone(),
            verdict: Verdict::Accepted,
            reason: "",
            factors: Default::default(),
            q: QAdjust::Keep,
            not_helping: false,
        };
        // The strategy's windows change in `adapt`; a failure after it restores them, so that
        // `Err` leaves the strategy unchanged too (a copy of a zero-sized strategy is free;
        // the copy is refilled in place, see `saved`).
        match &mut self.saved {
            Some(saved) => saved.clone_from(&self.strategy),
            None => self.saved = Some(self.strategy.clone()),
        }
        self.strategy.adapt(&mut a);
        // The outputs are copied out field by field: moving the whole `Adaptation`, or its
        // `q` by value, copies a whole covariance (the `AddRate` variant's room) each time,
        // which cost more than the update's own products. `clone` of `q` copies only the
        // variant present.
        Decision {
            stream: a.stream,
            epoch,
            prior_scale: a.prior_scale,
            prior_scaling: a.prior_scaling,
            propagated_only: a.scale_propagated_only && inn.QHt.is_some(),
            verdict: a.verdict,
            reason: a.reason,
            factors: a.factors,
            q: a.q.clone(),
            R: a.R,
            not_helping: a.not_helping,
        }
    }

    /// Steps *gain*, *update* and *inject* for an accepted (or adapted) measurement: `S*`
    /// and the adapted NIS, the prior `P⁻*`, `K = P⁻* Hᵀ S*⁻¹` and `δx = K r`, the updated
    /// covariance into the next buffer (Joseph or the chosen form), then `x̂ ⊕ δx` with the
    /// reset `G P Gᵀ`. Returns the new state and the gain; the current buffer is untouched.
    #[allow(non_snake_case, clippy::type_complexity)]
    fn correct<M: DimName>(
        &mut self,
        inn: &Innovated<X::Dim, M, T>,
        d: &Decision<X::Dim, M, T>,
        R: &Cov<M, T>,
        report: &mut UpdateReport<M, T>,
    ) -> Result<(X, OMatrix<T, X::Dim, M>), FilterError>
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        let prior_scale = d.prior_scale;
        if !(prior_scale.is_finite() && prior_scale > 0.0) {
            return Err(FilterError::NonFinite { what: "strategy prior scale λ_P" });
        }
        let Innovated { PHt, HPHt, QHt, HQHt, .. } = inn;
        let (r, H) = (inn.r(), inn.H());
        // The scaled part B of P⁻: P⁻ itself, or Φ_Σ P Φ_Σᵀ = P⁻ − Q_Σ (Xia), and
        // P⁻* = P⁻ + (λ − 1) B (or its restriction to the measurement subspace), so
        // S* = H P⁻ Hᵀ + (λ − 1) H B Hᵀ + R*, P⁻* Hᵀ = P⁻ Hᵀ + (λ − 1) B Hᵀ.
        let differences = match (&QHt, &HQHt) {
            (Some(QHt), Some(HQHt)) if d.propagated_only => Some((PHt - QHt, HPHt - HQHt)),
            _ => None,
        };
        let (BHt, HBHt) = match &differences {
            Some((BHt, HBHt)) => (BHt, HBHt),
            None => (PHt, HPHt),
        };
        let adapted = Self::adapted_innovation(d, R, inn, HBHt, report)?;
        let (chol, S_used) = match &adapted {
            Some((chol, S)) => (chol, S),
            None => (&inn.chol_S, &report.S),
        };

        let mut backend = core::mem::take(&mut self.backend);
        let form = self.form;
        let (P, next, aux) = Self::split(&mut self.bufs, self.cur);
        let (scaled, fallback) =
            Self::scale_prior(&mut backend, (P, aux), d, (BHt, HBHt), self.q_sum.as_ref());
        report.prior_scaling_fallback = fallback;
        // P⁻* Hᵀ = P⁻ Hᵀ + (λ − 1) B Hᵀ (both scalings)
        let scaled_PHt = (prior_scale != 1.0).then(|| PHt + BHt * T::lit(prior_scale - 1.0));
        let PHt_used = scaled_PHt.as_ref().unwrap_or(PHt);
        // K = P⁻* Hᵀ S*⁻¹ (S* = L Lᵀ; two substitutions over the columns of P⁻* Hᵀ)
        let mut K = PHt_used.clone();
        T::right_solve_cholesky(chol.l_dirty(), &mut K);
        let mut dx = OMatrix::<T, X::Dim, nalgebra::U1>::zeros();
        T::mat_mul(&K, r, &mut dx);

        let prior: &B::Cov = if scaled { aux } else { P };
        // Joseph: P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ, or short: P = P⁻ − K H P⁻
        backend.update(prior, &K, H, PHt_used, &d.R, S_used, form, next);
        let x_new = if self.reset == ResetMode::Exact {
            // P ← G P Gᵀ with G = ∂(x ⊕ δ)/∂δ at the injected δx, block by block
            let next = &mut self.bufs[(self.cur + 1) % 3];
            self.x.oplus_reset(&dx, &mut |o, b| backend.reset_block(next, o, b))
        } else {
            self.x.oplus(&dx)
        };
        self.backend = backend;
        check_finite("state correction δx", &dx)?;
        if !x_new.is_finite() {
            return Err(FilterError::NonFinite { what: "updated state" });
        }
        B::check_finite("updated covariance P", &self.bufs[(self.cur + 1) % 3])?;
        // the invariant: in full when the strategy changed the update (a scaled prior, an
        // adapted R), else on the diagonal (a Joseph update of a positive definite prior
        // with a positive definite R is positive definite)
        Self::check_positive_definite(
            &self.bufs[(self.cur + 1) % 3],
            adapted.is_some(),
            "update",
            &self.strategy,
        )?;
        Ok((x_new, K))
    }

    /// `S* = λ_P H P⁻ Hᵀ + R*` and its factor when the strategy changed `λ_P` or `R`
    /// (both scalings give `H P⁻* = λ_P H P⁻`); `None` when it changed neither (then `S`
    /// and its factor stand). Sets the report's adapted NIS, log-likelihood and a
    /// deflation verdict.
    #[allow(non_snake_case, clippy::type_complexity)]
    pub(crate) fn adapted_innovation<M: DimName>(
        d: &Decision<X::Dim, M, T>,
        R: &Cov<M, T>,
        inn: &Innovated<X::Dim, M, T>,
        HBHt: &OMatrix<T, M, M>,
        report: &mut UpdateReport<M, T>,
    ) -> Result<Option<(nalgebra::Cholesky<T, M>, OMatrix<T, M, M>)>, FilterError>
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        // (compared as slices: nalgebra's `!=` walks a strided iterator, several times slower)
        let adapted = d.prior_scale != 1.0 || d.R.as_slice() != R.as_slice();
        if !adapted {
            report.nis_adapted = inn.nis;
            return Ok(None);
        }
        check_covariance("adapted measurement noise R*", &d.R)?;
        let mut S_used = &inn.HPHt + HBHt * T::lit(d.prior_scale - 1.0) + &d.R;
        symmetrize(&mut S_used);
        let chol = cholesky("adapted innovation covariance S*", S_used.clone())?;
        report.nis_adapted = whitened_norm_sq(&chol, inn.r()).to_f64();
        // an adaptation that made S smaller along the innovation deflated it
        if report.verdict == Verdict::Inflated && report.nis_adapted > inn.nis {
            report.verdict = Verdict::Deflated;
        }
        report.log_likelihood = log_likelihood(&chol, report.nis_adapted);
        Ok(Some((chol, S_used)))
    }

    /// `P⁻* = P⁻ + (λ_P − 1) B` into `aux`, whole or along the measurement subspace
    /// `(HB)ᵀ (HBHᵀ)⁻¹ (HB)` (`B = P⁻`, or `P⁻ − Q_Σ` when the strategy scales the
    /// propagated part only). Returns whether the prior was scaled and whether the
    /// subspace scaling fell back to the whole of `B`.
    #[allow(non_snake_case, clippy::type_complexity)]
    fn scale_prior<M: DimName>(
        backend: &mut B,
        (P, aux): (&B::Cov, &mut B::Cov),
        d: &Decision<X::Dim, M, T>,
        (BHt, HBHt): (&OMatrix<T, X::Dim, M>, &OMatrix<T, M, M>),
        q_sum: Option<&B::Cov>,
    ) -> (bool, bool)
    where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        let prior_scale = d.prior_scale;
        if prior_scale == 1.0 {
            return (false, false);
        }
        let subspace = match d.prior_scaling {
            PriorScaling::MeasurementSubspace => Some(subspace_factor(HBHt, BHt)),
            PriorScaling::Full => None,
        };
        match subspace {
            Some(Some(U)) => backend.scale_add(P, T::one(), T::lit(prior_scale - 1.0), &U, &U, aux),
            Some(None) => {
                // the prior has no variance the measurement sees (H B Hᵀ = 0): there is
                // nothing to scale along its subspace, and the gain is zero whatever λ is
                return (false, true);
            }
            None => {
                let HB = BHt.transpose();
                backend.scale_add(P, T::lit(prior_scale), T::zero(), &HB, &HB, aux);
                if let (true, Some(q_sum)) = (d.propagated_only, q_sum) {
                    // λ P⁻ − (λ − 1) Q_Σ = P⁻ + (λ − 1)(P⁻ − Q_Σ)
                    sub_scaled(aux, T::lit(prior_scale - 1.0), q_sum, X::Dim::DIM);
                }
            }
        }
        (true, false)
    }

    /// The last step: the new state and covariance become current, the process noise
    /// accumulated since the last update starts again, the strategy sees the gain used
    /// and the observer the report.
    #[allow(non_snake_case)]
    fn finish<M: DimName, O: Observer<T>>(
        &mut self,
        x_new: X,
        K: &OMatrix<T, X::Dim, M>,
        d: &Decision<X::Dim, M, T>,
        report: &UpdateReport<M, T>,
        observer: &mut O,
    ) where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        self.x = x_new;
        self.commit();
        self.after_correction(K, d, report, observer);
    }

    /// After the state and covariance of an accepted update are in place: the process
    /// noise accumulated since the last update starts again, the strategy sees the gain
    /// used (and may request process noise), the observer gets the report.
    #[allow(non_snake_case)]
    pub(crate) fn after_correction<M: DimName, O: Observer<T>>(
        &mut self,
        K: &OMatrix<T, X::Dim, M>,
        d: &Decision<X::Dim, M, T>,
        report: &UpdateReport<M, T>,
        observer: &mut O,
    ) where
        DefaultAllocator: FilterAlloc<X::Dim, M>,
    {
        if let Some(q_sum) = &mut self.q_sum {
            // the next update's propagated part starts from this posterior
            for c in 0..X::Dim::DIM {
                q_sum.col_mut(c).fill(T::zero());
            }
        }
        self.epoch = d.epoch;
        self.apply_q(&d.q);
        let innovation = &report.innovation;
        let mut post =
            PostUpdate { stream: d.stream, time: self.time, K, innovation, q: QAdjust::Keep };
        self.strategy.after_update(&mut post);
        self.apply_q(&post.q);
        observer.on_update(report);
    }

    /// Take up the strategy's process-noise request (by reference, for the reason given
    /// in `update_observed`).
    fn apply_q(&mut self, q: &QAdjust<X::Dim, T>) {
        match q {
            QAdjust::Keep => {}
            QAdjust::Model => self.q_adjust = QAdjust::Keep,
            other => self.q_adjust = other.clone(),
        }
    }
}

/// `U` (`M × N`) with `Uᵀ U = (HB)ᵀ (HBHᵀ)⁺ HB`, the part of `B` the measurement sees,
/// by a pivoted elimination that stops at the directions `B` does not constrain; `None`
/// when it constrains none.
///
/// The elimination runs on `[[HBHᵀ, HB], [BHᵀ, ·]]`: each pivot, the largest remaining
/// diagonal of the Schur complement of `HBHᵀ`, contributes one row `gᵀ` of `U` (the
/// cross-covariance's column over the pivot's square root) and is eliminated. Pivots below
/// `√ε / 100` of the largest diagonal of `HBHᵀ` are left: along them the prior has no
/// variance the measurement sees (`HBHᵀu ≈ 0` gives `BHᵀu ≈ 0`), and dividing by them only
/// multiplies rounding. So `P⁻* = P⁻ + (λ − 1) Uᵀ U` adds a positive semi-definite term
/// whatever the rank of `H B Hᵀ`.
///
/// Why: a measurement whose `H P Hᵀ` is rank-deficient — a unit vector in R³ (`H = [h×]`,
/// the vector's own axis unseen), two rows that see the same combination — has an
/// eigenvalue that is zero to rounding. A Cholesky solve with it either fails (the filter
/// then scaled all of `P⁻`, inflating what no measurement sees) or, with a pivot of rounding
/// size, multiplies the rounding of `H B` by ~1/ε into `P` (on an attitude and gyro-bias
/// model the bias σ grew from 0.009 to 17 rad/s and `P` lost its positive definiteness:
/// `adaptive/examples/attitude_campaign.rs`).
#[allow(non_snake_case)]
fn subspace_factor<T: FilterScalar, N: DimName, M: DimName>(
    HBHt: &OMatrix<T, M, M>,
    BHt: &OMatrix<T, N, M>,
) -> Option<OMatrix<T, M, N>>
where
    DefaultAllocator: FilterAlloc<N, M>,
{
    let m = M::DIM;
    let mut a = HBHt.clone();
    let mut c = BHt.clone();
    let mut u = OMatrix::<T, M, N>::zeros();
    let largest = (0..m).map(|i| a[(i, i)]).fold(T::zero(), |x, d| if d > x { d } else { x });
    let floor = largest * T::default_epsilon().sqrt() * T::lit(0.01);
    let mut rank = 0;
    for k in 0..m {
        // the largest remaining pivot (an eliminated one is zero, below the floor)
        let j = (0..m).fold(0, |b, i| if a[(i, i)] > a[(b, b)] { i } else { b });
        let d = a[(j, j)];
        // (a NaN pivot stops too)
        if d.partial_cmp(&floor) != Some(core::cmp::Ordering::Greater) {
            break;
        }
        let s = T::one() / d.sqrt();
        let la = a.column(j) * s;
        let lc = c.column(j) * s;
        // Schur complements: A ← A − l lᵀ, C ← C − g lᵀ
        a -= &la * la.transpose();
        c -= &lc * la.transpose();
        u.row_mut(k).copy_from(&lc.transpose());
        a[(j, j)] = T::zero();
        rank += 1;
    }
    (rank > 0).then_some(u)
}

/// `out ← out − a Q` for two `n × n` column-major covariances.
fn sub_scaled<T: FilterScalar, C: Entries<T>>(out: &mut C, a: T, q: &C, n: usize) {
    for c in 0..n {
        for (o, v) in out.col_mut(c).iter_mut().zip(q.col(c)) {
            *o -= a * *v;
        }
    }
}

/// `ln N(r; 0, S) = −½ (m ln 2π + ln det S + rᵀ S⁻¹ r)` from the Cholesky factor of `S` and
/// the NIS.
fn log_likelihood<T: FilterScalar, M: nalgebra::DimName>(
    chol: &nalgebra::Cholesky<T, M>,
    nis: f64,
) -> f64
where
    DefaultAllocator: nalgebra::allocator::Allocator<M, M>,
{
    let l = chol.l_dirty();
    let log_det = (0..M::DIM).map(|i| l[(i, i)].to_f64().ln()).sum::<f64>() * 2.0;
    -0.5 * (M::DIM as f64 * (2.0 * core::f64::consts::PI).ln() + log_det + nis)
}
