//! The backward recursion over the replayed segments, and the smoothed variances.

use super::*;

/// What the backward recursion carries from one segment into the one before it, besides
/// the covariance [`Backward::carried_p`] (and `Λ`, left in [`Backward::bigs`]).
pub(super) enum Carried<X: Manifold>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// The smoothed estimate at the start of the later segment (an update lies between);
    /// the covariance is its `Pˢ`.
    Smoothed { x: X },
    /// `λ` and `Λ` at the start of the later segment, which continues this one: they go on
    /// through the boundary unchanged; the covariance is the one there (this segment's
    /// end's) and `delta = P λ` the later segment's smoothed correction there.
    Adjoint { lambda: OVector<f64, X::Dim>, delta: OVector<f64, X::Dim> },
}

/// The backward recursion: what it carries into the segment before, and the rows of the
/// last segment done. The covariances are kept in buffers of their own, written in place
/// (moving and zeroing them as values cost 8 % of the recursion's time on the day).
pub(super) struct Backward<X: Manifold>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    pub(super) carried: Carried<X>,
    /// The covariance that goes with `carried`.
    pub(super) carried_p: Cov<X::Dim>,
    /// `Λ`, in one of the two (`bigs[cur]`), the next one written into the other; after a
    /// segment, `bigs[cur]` is `Λ₀`, the later segment's `Λ` for a continued one.
    pub(super) bigs: [Cov<X::Dim>; 2],
    pub(super) cur: usize,
    /// `Pₙ Λₙ` where a continued segment's end wants variances.
    pub(super) pl: Cov<X::Dim>,
    pub(super) rows: Vec<SmoothedRow<X>>,
    /// `λᵢ` of the segment being smoothed.
    pub(super) lambdas: Vec<OVector<f64, X::Dim>>,
    /// `Φᵢᵀ` of the segment being smoothed, formed here when the replay did not form
    /// them (on this thread, where they are used: see
    /// [`ProcessModel::transition_transposed`]).
    pub(super) phi_ts: Vec<Cov<X::Dim>>,
    /// How `Λ` goes through a segment.
    pub(super) form: AdjointForm,
    /// `Ψ`, the product of the segment's transitions so far, in one of the two
    /// (`psis[1]` after an odd number of steps), for [`AdjointForm::Accumulated`].
    pub(super) psis: [Cov<X::Dim>; 2],
}

impl<X: Manifold> Backward<X>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    pub(super) fn start<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        filter: &ErrorStateFilter<X, A, B>,
        form: AdjointForm,
    ) -> Self {
        Self {
            carried: Carried::Smoothed { x: filter.state().clone() },
            carried_p: filter.covariance().into_owned(),
            bigs: [Cov::<X::Dim>::zeros(), Cov::<X::Dim>::zeros()],
            cur: 0,
            pl: Cov::<X::Dim>::zeros(),
            rows: Vec::new(),
            lambdas: Vec::new(),
            phi_ts: Vec::new(),
            form,
            psis: [Cov::<X::Dim>::zeros(), Cov::<X::Dim>::zeros()],
        }
    }

    /// Smooth through one replayed segment (rows in time order in `self.rows`).
    ///
    /// The recursion takes the steps the forward pass propagated the covariance over:
    /// every step, or the stretches of several where it did so at a lower rate than the
    /// state (`seg.units`: one transition and one noise over each stretch's inputs folded,
    /// as the forward pass took them). Inside a stretch the smoothed correction is
    /// interpolated in time between the stretch's ends.
    pub(super) fn segment<U, PM>(
        &mut self,
        seg: &Replayed<X, U>,
        model: &PM,
    ) -> Result<(), SmootherError>
    where
        PM: ProcessModel<State = X, Input = U>,
    {
        let xs = &seg.xs;
        let count = seg.steps.len();
        let taken = seg.taken();
        let stretched = !seg.units.is_empty();
        // the transitions the replay formed (one per step taken, when it replayed the
        // covariance), or this segment's own buffer to form them in
        // (taken out of `self` for the segment: it is borrowed beside `self`'s other parts)
        let formed = !seg.phi_ts.is_empty();
        let mut own = core::mem::take(&mut self.phi_ts);
        if !formed {
            own.resize(taken, Cov::<X::Dim>::zeros());
        }
        let end_flags = seg.steps[count - 1].2;
        let zero = OVector::<f64, X::Dim>::zeros();
        self.lambdas.resize(taken + 1, zero.clone());
        // the smoothed correction at the end, which a stretch's interpolation reaches
        let mut end_delta = None;
        // the segment's end: λₙ, Λₙ (into `bigs[cur]`), and its row's state and variances
        let p = &mut self.carried_p;
        let (end_x, end_var) = match &self.carried {
            Carried::Adjoint { lambda, delta } => {
                // (Λₙ is the later segment's Λ₀, left in `bigs[cur]`)
                self.lambdas[taken].copy_from(lambda);
                let var = (end_flags & VARIANCES != 0).then(|| {
                    kernels::mat_mul(&*p, &self.bigs[self.cur], &mut self.pl); // Pₙ Λₙ
                    variances_out_of(&xs[count], delta, p, &self.pl)
                });
                if stretched {
                    end_delta = Some(delta.clone());
                }
                (xs[count].oplus(delta), var)
            }
            Carried::Smoothed { x } => {
                // the later segment's smoothed start is this end's smoothed value (its
                // variances those of Pˢ, in the frame of x̂ˢ); then Pˢ into the frame of
                // the prior x̂ₙ (Σ), and λ = Pₙ⁻¹ d, Λ = Pₙ⁻¹ − Pₙ⁻¹ Σ Pₙ⁻¹
                let var = (end_flags & VARIANCES != 0).then(|| p.diagonal());
                let inv = seg.p_end_inv.as_ref().ok_or(SmootherError::Corrupt("segment end"))?;
                let d = x.ominus(&xs[count]);
                reframe(&xs[count], &d, p, Reframe::Into)?;
                let inv = inv.as_ref().map_err(|e| e.clone())?;
                kernels::mat_mul(inv, &d, &mut self.lambdas[taken]);
                // −(Pₙ⁻¹ Σ Pₙ⁻¹ − Pₙ⁻¹) as one sandwich (Pₙ⁻¹ is symmetric), exactly symmetric
                let big = &mut self.bigs[self.cur];
                kernels::dense_sandwich(inv, &*p, &negated(inv), big);
                negate(big);
                if stretched {
                    end_delta = Some(d);
                }
                (x.clone(), var)
            }
        };
        // backwards: λⱼ = Φⱼᵀ λⱼ₊₁, and Λⱼ = Φⱼᵀ Λⱼ₊₁ Φⱼ step by step or Ψ ← Ψ Φⱼ (from
        // Ψ = Φₘ₋₁); each covariance-sized value in one of two buffers, the next one written
        // into the other (no swap: swapping two covariances copies three)
        let accumulate = self.form == AdjointForm::Accumulated;
        for j in (0..taken).rev() {
            if !formed {
                let (first, _, u, dt) = seg.taken_step(j);
                model.transition_transposed(&xs[first], u, dt, &mut own[j]);
            }
            let phi_ts = if formed { &seg.phi_ts } else { &own };
            let (done, later) = self.lambdas.split_at_mut(j + 1);
            kernels::mat_mul(&phi_ts[j], &later[0], &mut done[j]);
            if accumulate {
                let [a, b] = &mut self.psis;
                let (from, to) = if (taken - 1 - j).is_multiple_of(2) { (a, b) } else { (b, a) };
                if j + 1 == taken {
                    phi_ts[j].transpose_to(to); // (I Φ)
                } else {
                    model.times_transition(from, &phi_ts[j], to);
                }
            } else {
                let [a, b] = &mut self.bigs;
                let (from, to) = if self.cur == 0 { (a, b) } else { (b, a) };
                model.adjoint_sandwich(&phi_ts[j], from, to);
                self.cur = 1 - self.cur;
            }
        }
        if accumulate {
            // Λ₀ = Ψᵀ Λₙ Ψ
            let psi_t = self.psis[taken % 2].transpose();
            let [a, b] = &mut self.bigs;
            let (from, to) = if self.cur == 0 { (a, b) } else { (b, a) };
            kernels::dense_sandwich(&psi_t, from, &Cov::<X::Dim>::zeros(), to);
            self.cur = 1 - self.cur;
        }
        let phi_ts = if formed { &seg.phi_ts } else { &own };
        // the start: δ₀ = P₀ λ₀, and what goes into the segment before (Λ₀ stays in
        // `bigs[cur]`)
        let (x0, p0) = (&xs[0], &seg.ps[0]);
        let mut mu = zero.clone();
        kernels::mat_mul(p0, &self.lambdas[0], &mut mu);
        let p = &mut self.carried_p;
        self.carried = if seg.continues {
            p.copy_from(p0);
            Carried::Adjoint { lambda: self.lambdas[0].clone(), delta: mu.clone() }
        } else {
            // Pˢ₀ = −(P₀ Λ₀ P₀ − P₀) as one sandwich, exactly symmetric
            kernels::dense_sandwich(p0, &self.bigs[self.cur], &negated(p0), p);
            negate(p);
            reframe(x0, &mu, p, Reframe::OutOf)?;
            let x_s = x0.oplus(&mu);
            if !x_s.is_finite() || kernels::non_finite_in(p.as_slice()) {
                return Err(FilterError::NonFinite { what: "smoothed state or covariance" }.into());
            }
            Carried::Smoothed { x: x_s }
        };
        if seg.steps[..count - 1].iter().any(|(_, _, flags, _)| flags & VARIANCES != 0) {
            return Err(SmootherError::Corrupt("variances asked inside a segment"));
        }
        // forwards: δⱼ₊₁ = Pⱼ₊₁ λⱼ₊₁ = α Φⱼ δⱼ + Q̃ⱼ λⱼ₊₁ (Pⱼ₊₁ = Φⱼ (α Pⱼ) Φⱼᵀ + Q̃ⱼ, and
        // Pⱼ Φⱼᵀ λⱼ₊₁ = Pⱼ λⱼ = δⱼ; over a stretch of n steps the fading is αⁿ), the marked
        // steps' states x̂ᵢ ⊕ δᵢ
        self.rows.clear();
        let (mut phi_mu, mut q_lambda, mut extra) = (zero.clone(), zero.clone(), zero.clone());
        // δ at the start of a stretch, and at a step inside it
        let (mut before, mut inside) = (zero.clone(), zero);
        for j in 0..taken {
            let (first, n, u, dt) = seg.taken_step(j);
            if stretched {
                before.copy_from(&mu);
            }
            if j + 1 < taken {
                let next = &self.lambdas[j + 1];
                phi_ts[j].tr_mul_to(&mu, &mut phi_mu);
                let here = &self.lambdas[j]; // Φⱼᵀ λⱼ₊₁
                model.noise_times(&xs[first], u, dt, &phi_ts[j], next, here, &mut q_lambda);
                match &seg.q {
                    QAdjust::Keep | QAdjust::Model => {}
                    QAdjust::Scale(s) => q_lambda *= *s,
                    QAdjust::AddRate(rate) => {
                        rate.mul_to(next, &mut extra);
                        q_lambda.axpy(dt, &extra, 1.0);
                    }
                }
                let fading = fading_over(seg.fading, n as u32);
                for ((m, a), b) in mu.iter_mut().zip(phi_mu.iter()).zip(q_lambda.iter()) {
                    *m = fading * a + b;
                }
            } else if let Some(end) = &end_delta {
                mu.copy_from(end);
            }
            if !stretched {
                if j + 1 < taken && seg.steps[j].2 & MARKED != 0 {
                    self.rows.push(SmoothedRow {
                        time: seg.steps[j].0,
                        x: xs[j + 1].oplus(&mu),
                        var: None,
                    });
                }
                continue;
            }
            // the marked steps the stretch covers (the segment's last is the end's, below):
            // δ in time between the stretch's ends
            let mut elapsed = 0.0;
            for k in first..(first + n).min(count - 1) {
                let (t, step_dt, flags, _) = &seg.steps[k];
                elapsed += step_dt;
                if flags & MARKED == 0 {
                    continue;
                }
                let x = if k + 1 == first + n {
                    xs[k + 1].oplus(&mu)
                } else {
                    let w = if dt > 0.0 { elapsed / dt } else { 1.0 };
                    for ((v, a), b) in inside.iter_mut().zip(before.iter()).zip(mu.iter()) {
                        *v = a + w * (b - a);
                    }
                    xs[k + 1].oplus(&inside)
                };
                self.rows.push(SmoothedRow { time: *t, x, var: None });
            }
        }
        self.phi_ts = own;
        if end_flags & MARKED != 0 {
            let time = seg.steps[count - 1].0;
            self.rows.push(SmoothedRow { time, x: end_x, var: end_var });
        }
        let finite = |r: &SmoothedRow<X>| {
            r.x.is_finite() && r.var.as_ref().is_none_or(|v| !kernels::non_finite_in(v.as_slice()))
        };
        if !self.rows.iter().all(finite) {
            return Err(FilterError::NonFinite { what: "smoothed state or variance" }.into());
        }
        Ok(())
    }
}

/// The diagonal of `G S Gᵀ` for `S = P − P Λ P` and `G = G(x, δ)`: the smoothed
/// variances in the frame of `x ⊕ δ`, from the entries of `S` that the reset blocks touch
/// (`S` is not formed; outside the blocks the variance is `S`'s diagonal). `pl = P Λ`.
pub(super) fn variances_out_of<X: Manifold>(
    x: &X,
    delta: &manifolds::Tangent<X>,
    p: &Cov<X::Dim>,
    pl: &Cov<X::Dim>,
) -> OVector<f64, X::Dim>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    let n = X::Dim::DIM;
    // diag(P Λ P)[i] = Σ_k (PΛ)[i, k] P[k, i] = Σ_k (PΛ)[i, k] P[i, k]: whole columns of
    // both, all rows at once (a row-by-row dot product waits on each addition)
    let mut var = OVector::<f64, X::Dim>::zeros();
    let (ps, pls) = (p.as_slice(), pl.as_slice());
    for k in 0..n {
        let (pc, plc) = (&ps[k * n..(k + 1) * n], &pls[k * n..(k + 1) * n]);
        for (v, (a, b)) in var.iter_mut().zip(plc.iter().zip(pc)) {
            *v += a * b;
        }
    }
    for (i, v) in var.iter_mut().enumerate() {
        *v = ps[i * n + i] - *v;
    }
    let s = |r: usize, c: usize| p[(r, c)] - pl.row(r).dot(&p.column(c).transpose());
    x.reset_blocks(delta, &mut |o, b| {
        let d = b.nrows();
        // the block of S once (up to 6 × 6 on the stack), then its image through G
        const MAX: usize = 6;
        let mut block = [[0.0f64; MAX]; MAX];
        if d <= MAX {
            for (j, row) in block.iter_mut().enumerate().take(d) {
                for (l, e) in row.iter_mut().enumerate().take(d) {
                    *e = s(o + j, o + l);
                }
            }
        }
        let entry = |j: usize, l: usize| if d <= MAX { block[j][l] } else { s(o + j, o + l) };
        for i in 0..d {
            let mut v = 0.0;
            for j in 0..d {
                let gij = b[(i, j)];
                if gij == 0.0 {
                    continue;
                }
                for l in 0..d {
                    let gil = b[(i, l)];
                    if gil != 0.0 {
                        v += gij * gil * entry(j, l);
                    }
                }
            }
            var[o + i] = v;
        }
    });
    var
}

/// `m ← −m`, over the matrix's slice (nalgebra's `neg_mut` and `-m` went element by
/// element through a strided iterator, a byte's sign flip at a time: 5 % of the
/// recursion's samples on the day).
pub(super) fn negate<N: DimName>(m: &mut Cov<N>)
where
    DefaultAllocator: DimAlloc<N>,
{
    for v in m.as_mut_slice() {
        *v = -*v;
    }
}

/// `−m` (see [`negate`]).
pub(super) fn negated<N: DimName>(m: &Cov<N>) -> Cov<N>
where
    DefaultAllocator: DimAlloc<N>,
{
    let mut out = m.clone();
    negate(&mut out);
    out
}

/// `A⁻¹` of a symmetric positive-definite `A = L Lᵀ` from its Cholesky factor, exactly
/// symmetric: `W = L⁻¹` by forward substitution, then the lower triangle of `Wᵀ W`,
/// mirrored (about `N³/3` multiply-adds in plain loops over columns; nalgebra's
/// `Cholesky::inverse` solves against the identity column by column, several times
/// slower at the smoother's sizes).
pub(super) fn inverse_from_cholesky<N: DimName>(chol: &nalgebra::Cholesky<f64, N>) -> Cov<N>
where
    DefaultAllocator: DimAlloc<N>,
{
    let n = N::DIM;
    let l = chol.l_dirty();
    // W = L⁻¹, lower triangular, column by column: W[j, j] = 1/L[j, j],
    // W[i, j] = −(Σ_{j ≤ k < i} L[i, k] W[k, j]) / L[i, i]
    let mut w = Cov::<N>::zeros();
    for j in 0..n {
        w[(j, j)] = 1.0 / l[(j, j)];
        for i in j + 1..n {
            let mut v = 0.0;
            for k in j..i {
                v += l[(i, k)] * w[(k, j)];
            }
            w[(i, j)] = -v / l[(i, i)];
        }
    }
    // A⁻¹[i, j] = Σ_{k ≥ i} W[k, i] W[k, j] for i ≥ j
    let mut inv = Cov::<N>::zeros();
    for j in 0..n {
        for i in j..n {
            let (ci, cj) = (w.column(i), w.column(j));
            let v = ci.rows_range(i..).dot(&cj.rows_range(i..));
            inv[(i, j)] = v;
            inv[(j, i)] = v;
        }
    }
    inv
}
