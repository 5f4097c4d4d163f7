//! The segments' storage: written in batches, read back a window at a time, replayed.

use super::*;

/// Bytes of closed segments held before one write to the storage, and read back at a
/// time by the backward pass.
pub(super) const WRITE_BYTES: usize = 1 << 20;

/// Steps per batch between the threads of [`SegmentSmoother::smooth_threaded`].
pub(super) const BATCH_STEPS: usize = 256;

/// Batches the replay of [`SegmentSmoother::smooth_threaded`] runs ahead of the recursion
/// before it waits, and the number it waits for the recursion to come down to.
pub(super) const AHEAD_HIGH: usize = 16;
/// See [`AHEAD_HIGH`].
pub(super) const AHEAD_LOW: usize = 4;

/// The storage and the segment offsets, for reading segments back: a window of about
/// [`WRITE_BYTES`] that ends at the segment asked for (the backward pass reads the
/// segments last to first, so one read serves many).
pub(super) struct Store<'a, S> {
    pub(super) store: &'a mut S,
    pub(super) offsets: &'a [u64],
    /// The numbers read (the storage's bytes read into them in place).
    pub(super) window: Vec<f64>,
    /// Where in the storage `window` starts, bytes.
    pub(super) at: u64,
    /// The storage file, cut off after each window read: what the backward pass has used it
    /// never reads again, and a scratch file's pages dropped before they are written back
    /// are never written to the disk (the day's 2.7 GB would be, while the smoothed
    /// outputs are being written).
    pub(super) shrink: Option<&'a std::fs::File>,
}

/// One segment replayed: its nominal states and transitions, step by step, and the
/// covariances at its ends.
pub(super) struct Replayed<X: Manifold, U>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// `x̂ᵢ` for `i = 0..=n` (`0`: the segment's start).
    pub(super) xs: Vec<X>,
    /// `P₀` first; `Pᵢ` for every `i` when the segment was replayed with its covariance
    /// ([`END_REPLAY`]).
    pub(super) ps: Vec<Cov<X::Dim>>,
    /// `Pₙ⁻¹` for `Pₙ` the covariance before the update that follows the segment, when one
    /// does (or why `Pₙ` has no inverse); formed by the replay, which has a core to spare,
    /// not by the recursion, which is the backward pass's longest thread.
    pub(super) p_end_inv: Option<Result<Cov<X::Dim>, FilterError>>,
    /// `Φᵢᵀ`, `i < n`, when the segment was replayed with its covariance ([`END_REPLAY`]),
    /// which forms them anyway; empty otherwise (the recursion forms them, see
    /// [`ProcessModel::transition_transposed`]).
    pub(super) phi_ts: Vec<Cov<X::Dim>>,
    /// End time, interval, flags and input of each step.
    pub(super) steps: Vec<(f64, f64, u16, U)>,
    /// The stretches the recursion takes as one step each, where the forward pass
    /// propagated the covariance over several ([`CONTINUES`]) and the model folds inputs
    /// ([`ProcessModel::fold_input`]): the step each ends before, its folded input and its
    /// interval. Empty: every step on its own.
    pub(super) units: Vec<(usize, U, f64)>,
    /// The segment continues the one before it (no update at its start).
    pub(super) continues: bool,
    /// The prediction fading and noise adjustment of the segment's steps.
    pub(super) fading: f64,
    pub(super) q: QAdjust<X::Dim>,
}

impl<X: Manifold, U> Default for Replayed<X, U>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    fn default() -> Self {
        Self {
            xs: Vec::new(),
            ps: Vec::new(),
            p_end_inv: None,
            phi_ts: Vec::new(),
            steps: Vec::new(),
            units: Vec::new(),
            continues: false,
            fading: 1.0,
            q: QAdjust::Keep,
        }
    }
}

impl<X: Manifold, U> Replayed<X, U>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// How many steps the recursion takes: the stretches ([`units`](Self::units)), or
    /// every step.
    pub(super) fn taken(&self) -> usize {
        if self.units.is_empty() {
            self.steps.len()
        } else {
            self.units.len()
        }
    }

    /// Step `j` of those the recursion takes: the point it starts from, how many of the
    /// segment's steps it covers, its input and its interval.
    pub(super) fn taken_step(&self, j: usize) -> (usize, usize, &U, f64) {
        if self.units.is_empty() {
            let (_, dt, _, u) = &self.steps[j];
            (j, 1, u, *dt)
        } else {
            let first = if j == 0 { 0 } else { self.units[j - 1].0 };
            let (last, u, dt) = &self.units[j];
            (first, last - first, u, *dt)
        }
    }
}

/// The upper triangle of `p`, column by column, appended to `out`.
pub(super) fn push_upper<N: DimName>(out: &mut Vec<f64>, p: &Cov<N>)
where
    DefaultAllocator: DimAlloc<N>,
{
    let n = N::DIM;
    for c in 0..n {
        out.extend_from_slice(&p.as_slice()[c * n..c * n + c + 1]);
    }
}

/// A covariance from its upper triangle (as [`push_upper`] wrote it) at the start of `v`.
pub(super) fn read_upper<N: DimName>(v: &[f64], p: &mut Cov<N>)
where
    DefaultAllocator: DimAlloc<N>,
{
    // the columns' upper parts copied whole, then the lower triangle from them, column
    // by column (writing both halves value by value, the lower one across the columns, was
    // 8 % of the replay's time on a run with an update every ten steps)
    let n = N::DIM;
    let d = p.as_mut_slice();
    let mut at = 0;
    for c in 0..n {
        d[c * n..=c * n + c].copy_from_slice(&v[at..=at + c]);
        at += c + 1;
    }
    for c in 0..n {
        for r in c + 1..n {
            d[c * n + r] = d[r * n + c];
        }
    }
}

impl<S: Read + Seek> Store<'_, S> {
    /// Read segment `k` and replay it into `seg`.
    pub(super) fn replay<X, U, PM>(
        &mut self,
        k: usize,
        model: &PM,
        seg: &mut Replayed<X, U>,
    ) -> Result<(), SmootherError>
    where
        X: Manifold + Spill,
        U: Spill,
        PM: ProcessModel<State = X, Input = U>,
        DefaultAllocator: DimAlloc<X::Dim>,
    {
        let n = X::Dim::DIM;
        let (from, to) = (self.offsets[k], self.offsets[k + 1]);
        let held = self.at..self.at + 8 * self.window.len() as u64;
        if !(held.contains(&from) && to <= held.end) {
            // the window that ends with this segment (offsets are whole numbers of f64)
            let start = from.min(to.saturating_sub(WRITE_BYTES as u64));
            self.store.seek(SeekFrom::Start(start))?;
            self.window.resize(((to - start) / 8) as usize, 0.0);
            self.store.read_exact(bytemuck::cast_slice_mut(&mut self.window))?;
            self.at = start;
            if let Some(file) = self.shrink {
                // everything after this window belongs to later segments, done (the window
                // itself may start inside an earlier segment, read again with the next
                // window); an optimisation: a file that cannot be cut is read as it is
                let _ = file.set_len(to);
            }
        }
        let v = &self.window[((from - self.at) / 8) as usize..((to - self.at) / 8) as usize];
        let corrupt = SmootherError::Corrupt;
        if v.len() < HEAD {
            return Err(corrupt("segment header"));
        }
        let (count, tag, end) = (v[0] as usize, v[3], v[5]);
        seg.fading = v[2];
        seg.continues = match v[4] {
            0.0 => false,
            1.0 => true,
            _ => return Err(corrupt("segment continuation flag")),
        };
        if ![END_OPEN, END_PRIOR, END_REPLAY].contains(&end) {
            return Err(corrupt("segment end"));
        }
        let (q, qn) = match tag as u8 {
            0 => (QAdjust::Keep, 0),
            1 => (QAdjust::Scale(*v.get(HEAD).ok_or(corrupt("noise scale"))?), 1),
            2 => {
                let m = v.get(HEAD..HEAD + n * n).ok_or(corrupt("noise rate"))?;
                (QAdjust::AddRate(Cov::<X::Dim>::from_column_slice(m)), n * n)
            }
            _ => return Err(corrupt("noise adjustment tag")),
        };
        seg.q = q;
        let mut at = HEAD + qn;
        let tri = n * (n + 1) / 2;
        // (a corrupt count must not overflow the bound it is checked against; a step is
        // at least its flags)
        let least = at.checked_add(X::LEN + tri).and_then(|head| head.checked_add(count));
        if least.is_none_or(|least| v.len() < least) || count == 0 {
            return Err(corrupt("segment length"));
        }
        seg.xs.clear();
        seg.steps.clear();
        seg.xs.push(X::unspill(&v[at..at + X::LEN]));
        at += X::LEN;
        // the covariances and transitions are written in place (a segment's buffers are
        // reused: they grow to the longest segment once, then are only overwritten)
        let replay = end == END_REPLAY;
        seg.ps.resize(1, Cov::<X::Dim>::zeros());
        read_upper(&v[at..], &mut seg.ps[0]);
        at += tri;
        for _ in 0..count {
            let flags = *v.get(at).ok_or(corrupt("segment length"))?;
            if !((0.0..f64::from(FLAGS_END)).contains(&flags) && flags.fract() == 0.0) {
                return Err(corrupt("step flags"));
            }
            let flags = flags as u16;
            let (after, stamped) = (flags & AFTER != 0, flags & STAMPED != 0);
            let form = ((flags & (CONTINUES - 1)) >> FORM_SHIFT) as u8;
            if form != 0 && !after {
                return Err(corrupt("step flags"));
            }
            let mut times = None;
            at += 1;
            if !stamped {
                let t = v.get(at..at + 2).ok_or(corrupt("segment length"))?;
                times = Some((t[0], t[1]));
                at += 2;
            }
            let len = if after { U::after_len(form).min(U::AFTER_LEN) } else { U::LEN };
            let payload = v.get(at..at + len).ok_or(corrupt("segment length"))?;
            let u = match (after, seg.steps.last()) {
                (true, Some((.., before))) => U::unspill_after(payload, form, before),
                (true, None) => return Err(corrupt("first step stored after another")),
                (false, _) => U::unspill(payload),
            };
            let (end, dt) = match times.or_else(|| u.stamp()) {
                Some(times) => times,
                None => return Err(corrupt("step without its times")),
            };
            seg.steps.push((end, dt, flags & (MARKED | VARIANCES | CONTINUES), u));
            at += len;
        }
        let mut p_end = None;
        if end == END_PRIOR {
            let stored = v.get(at..at + tri).ok_or(corrupt("segment end covariance"))?;
            let mut p = Cov::<X::Dim>::zeros();
            read_upper(stored, &mut p);
            p_end = Some(p);
            at += tri;
        }
        if at != v.len() {
            return Err(corrupt("segment length"));
        }
        seg.units.clear();
        if seg.steps.iter().any(|(_, _, flags, _)| flags & CONTINUES != 0) {
            fold_stretches(model, &seg.steps, &mut seg.units);
        }
        let taken = seg.taken();
        seg.ps.resize(if replay { taken + 1 } else { 1 }, Cov::<X::Dim>::zeros());
        // (over stretches the recursion forms its own transitions, on its thread)
        let formed = replay && seg.units.is_empty();
        seg.phi_ts.resize(if formed { taken } else { 0 }, Cov::<X::Dim>::zeros());
        if formed {
            // the covariance is not stored at the end: replayed by the static back-end's
            // path (the model's fused product where it has one), with the segment's fading
            // and noise adjustment, Φᵀ on the side
            for (k, (_, dt, _, u)) in seg.steps.iter().enumerate() {
                let x = &seg.xs[k];
                let (done, next) = seg.ps.split_at_mut(k + 1);
                let phi_t = Some(&mut seg.phi_ts[k]);
                let x_next = static_predict(
                    model,
                    x,
                    u,
                    *dt,
                    &done[k],
                    seg.fading,
                    &seg.q,
                    &mut next[0],
                    phi_t,
                )?;
                seg.xs.push(x_next);
            }
        } else {
            // the nominal states
            for (k, (_, dt, _, u)) in seg.steps.iter().enumerate() {
                let x_next = model.propagate(&seg.xs[k], u, *dt);
                seg.xs.push(x_next);
            }
            if replay {
                // and the covariance over the forward pass's stretches, as it propagated
                // it (`ErrorStateFilter::predict_covariance`: at the stretch's first state,
                // over its folded input and interval, the fading once per step)
                let mut first = 0;
                for (j, (last, u, dt)) in seg.units.iter().enumerate() {
                    let fading = fading_over(seg.fading, (last - first) as u32);
                    let (done, next) = seg.ps.split_at_mut(j + 1);
                    static_predict(
                        model,
                        &seg.xs[first],
                        u,
                        *dt,
                        &done[j],
                        fading,
                        &seg.q,
                        &mut next[0],
                        None,
                    )?;
                    first = *last;
                }
            }
        }
        if replay {
            p_end = Some(seg.ps[taken].clone());
        }
        seg.p_end_inv = p_end.map(|p| {
            cholesky("smoother: predicted covariance Pₙ", p)
                .map(|chol| inverse_from_cholesky(&chol))
        });
        Ok(())
    }
}

/// The stretches of `steps` (each ends at a step without [`CONTINUES`], or at the last
/// step), their inputs folded ([`ProcessModel::fold_input`]), into `units` (left empty
/// when the model does not fold).
fn fold_stretches<X, U, PM>(
    model: &PM,
    steps: &[(f64, f64, u16, U)],
    units: &mut Vec<(usize, U, f64)>,
) where
    X: Manifold,
    PM: ProcessModel<State = X, Input = U>,
    DefaultAllocator: DimAlloc<X::Dim>,
{
    let (mut sum, mut interval) = (None, 0.0);
    for (k, (_, dt, flags, u)) in steps.iter().enumerate() {
        if !model.fold_input(&mut sum, u) {
            units.clear();
            return;
        }
        // (summed in the order the forward pass sums them)
        interval += dt;
        if flags & CONTINUES == 0 || k + 1 == steps.len() {
            let Some(folded) = sum.take() else {
                units.clear();
                return;
            };
            units.push((k + 1, folded, interval));
            interval = 0.0;
        }
    }
}
