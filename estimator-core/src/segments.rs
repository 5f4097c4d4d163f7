//! A fixed-interval smoother for long, high-rate runs: the forward pass is stored per
//! *segment* (the predictions between two updates, at most `max_steps` of them), on disk
//! or any other seekable storage, and every step is rebuilt by replaying the segment.
//!
//! [`RtsSmoother`](crate::RtsSmoother) keeps `(x̂⁺, P⁺, Φ, x̂⁻, P⁻)` of every prediction in
//! memory: about 3 `N × N` matrices per step, 17 GB for a day of 100 Hz IMU data with 15
//! states. [`SegmentSmoother`] keeps, per segment, the posterior `(x̂⁺, P⁺)` it starts from,
//! the strategy's prediction fading and process-noise adjustment (constant within a
//! segment: strategies change them only at updates) and the inputs `(u, dt)` of its steps —
//! one covariance per update instead of three per step — in its storage, and in memory
//! only the start offset of each segment.
//!
//! The backward pass reads the segments last to first. It replays each one from its
//! `(x̂⁺, P⁺)` with the model (the forward pass's `x̂ᵢ`, `Pᵢ`, `Φᵢ` on the static back-end) and runs the
//! RTS recursion through it in its adjoint form (Bryson & Frazier; Bierman 1977 §X),
//! which needs no inverse inside a segment:
//!
//! ```text
//! at the segment's end n (the prior of the next segment's first update), with
//! d = x̂ˢ ⊖ x̂ₙ and Σ = G(x̂ₙ, d)⁻¹ Pˢ G(x̂ₙ, d)⁻ᵀ (Pˢ taken into the prior's frame):
//!   λₙ = Pₙ⁻¹ d,           Λₙ = Pₙ⁻¹ − Pₙ⁻¹ Σ Pₙ⁻¹
//! backwards through the steps:
//!   λᵢ = Φᵢᵀ λᵢ₊₁,          Λᵢ = Φᵢᵀ Λᵢ₊₁ Φᵢ
//!   x̂ˢᵢ = x̂ᵢ ⊕ Pᵢ λᵢ,        Pˢᵢ = Pᵢ − Pᵢ Λᵢ Pᵢ
//! ```
//!
//! which is the RTS gain `Cᵢ = Pᵢ Φᵢᵀ Pᵢ₊₁⁻¹` applied step by step (`δᵢ = Cᵢ δᵢ₊₁`
//! with `δᵢ₊₁ = Pᵢ₊₁ λᵢ₊₁`). The frames are those of [`RtsSmoother`](crate::RtsSmoother)
//! (see its module): inside a segment there is no update, so the smoothed error stays in
//! the frames of the replayed nominals; `Pˢ` is taken into the prior's frame at the
//! segment's end and out to the smoothed estimate's (`G(x̂ᵢ, δᵢ) Pˢᵢ G(x̂ᵢ, δᵢ)ᵀ`) where it
//! is reported. At a segment's start `Pˢ` is formed whole; in between only the reported
//! variances, from the entries of `Pᵢ Λᵢ Pᵢ` that the diagonal and the reset blocks need.
//! Both smoothers give the same numbers, on a vector space (`tests/segment_smoother.rs`)
//! and on SO(3) × R³ (`tests/smoother_manifold.rs`), to 1e-9.
//!
//! The forward pass records through [`StepRecorder::before_predict`], called with the
//! filter before each prediction; a new segment starts whenever the filter's update
//! counter moved (an update, accepted or refused, may change `x̂`, `P`, the fading and the
//! noise adjustment) or the segment is full. Steps are *marked* when their end is an
//! output epoch; the backward pass returns the smoothed state and variances there.
//!
//! What the smoother does not see: an update's prior scaling (a strategy's `λ_P`) — the
//! segment's end uses the propagated `Pₙ`, not the scaled prior the update used. For
//! fixed noise, an adaptive `R` or an adapted `Q` the recursion is exact.

use core::marker::PhantomData;
use std::io::{Read, Seek, SeekFrom, Write};

use nalgebra::{DefaultAllocator, DimName, OVector, SVector};

use manifolds::{DimAlloc, Manifold};

use crate::adapt::{NoiseStrategy, QAdjust};
use crate::backend::{CovBackend, StaticCov};
use crate::dims::Cov;
use crate::error::FilterError;
use crate::filter::ErrorStateFilter;
use crate::kernels;
use crate::linalg::{cholesky, symmetrize};
use crate::smoother::{reframe, Reframe};
use crate::traits::ProcessModel;

/// A value stored exactly as `LEN` numbers (states and inputs a [`SegmentSmoother`]
/// writes to its storage).
pub trait Spill: Sized {
    /// How many numbers.
    const LEN: usize;
    /// Write the value into `out` (`out.len() == LEN`).
    fn spill(&self, out: &mut [f64]);
    /// Read it back from `v` (`v.len() == LEN`).
    fn unspill(v: &[f64]) -> Self;
}

impl<const D: usize> Spill for SVector<f64, D> {
    const LEN: usize = D;
    fn spill(&self, out: &mut [f64]) {
        out.copy_from_slice(self.as_slice());
    }
    fn unspill(v: &[f64]) -> Self {
        Self::from_column_slice(v)
    }
}

impl Spill for () {
    const LEN: usize = 0;
    fn spill(&self, _: &mut [f64]) {}
    fn unspill(_: &[f64]) -> Self {}
}

impl Spill for f64 {
    const LEN: usize = 1;
    fn spill(&self, out: &mut [f64]) {
        out[0] = *self;
    }
    fn unspill(v: &[f64]) -> Self {
        v[0]
    }
}

/// Why a smoothing pass failed.
#[derive(Debug)]
pub enum SmootherError {
    /// Reading or writing the storage, or the caller's sink.
    Io(std::io::Error),
    /// A replayed prediction failed, a prior covariance had no Cholesky factor, or a
    /// smoothed value was not finite.
    Filter(FilterError),
    /// The storage does not hold what was written (truncated or changed underneath).
    Corrupt(&'static str),
}

impl core::fmt::Display for SmootherError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SmootherError::Io(e) => write!(f, "smoother storage: {e}"),
            SmootherError::Filter(e) => write!(f, "smoother: {e}"),
            SmootherError::Corrupt(what) => write!(f, "smoother storage is corrupt: {what}"),
        }
    }
}

impl std::error::Error for SmootherError {}

impl From<std::io::Error> for SmootherError {
    fn from(e: std::io::Error) -> Self {
        SmootherError::Io(e)
    }
}

impl From<FilterError> for SmootherError {
    fn from(e: FilterError) -> Self {
        SmootherError::Filter(e)
    }
}

/// What a forward pass tells a recorder: the filter before each prediction, with the
/// prediction's input and interval. `()` records nothing.
pub trait StepRecorder<X: Manifold, U>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// Called with the filter just before `filter.predict(model, u, dt)`; `mark` says that
    /// the prediction ends at an output epoch.
    fn before_predict<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
        u: &U,
        dt: f64,
        mark: bool,
    );
}

impl<X: Manifold, U> StepRecorder<X, U> for ()
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    #[inline]
    fn before_predict<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        _: &ErrorStateFilter<X, A, B>,
        _: &U,
        _: f64,
        _: bool,
    ) {
    }
}

impl<X: Manifold, U, R: StepRecorder<X, U>> StepRecorder<X, U> for Option<R>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    #[inline]
    fn before_predict<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
        u: &U,
        dt: f64,
        mark: bool,
    ) {
        if let Some(r) = self {
            r.before_predict(filter, u, dt, mark);
        }
    }
}

/// A smoothed output epoch.
#[derive(Clone, Debug)]
pub struct SmoothedRow<X: Manifold>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// Time, s.
    pub time: f64,
    /// The smoothed state.
    pub x: X,
    /// The smoothed variances (diagonal of `Pˢ`).
    pub var: OVector<f64, X::Dim>,
}

/// Header numbers before the state: steps, start time, fading, noise-adjustment tag.
const HEAD: usize = 4;
/// Numbers per step before the input: end time, interval, mark.
const STEP: usize = 3;

/// The segment-wise fixed-interval smoother (see the [module](self) documentation).
///
/// `S` is the storage: a file for long runs ([`SegmentSmoother::on_file`]), or a
/// `std::io::Cursor<Vec<u8>>` in memory.
#[derive(Debug)]
pub struct SegmentSmoother<X, U, S = std::fs::File> {
    store: S,
    /// Start of each written segment in `store`, bytes; the last entry is the end.
    offsets: Vec<u64>,
    max_steps: usize,
    /// The open segment (header and steps so far), written when it closes.
    open: Vec<f64>,
    open_steps: usize,
    last_epoch: Option<u64>,
    bytes: Vec<u8>,
    /// The first storage error of the forward pass (recording stops there).
    error: Option<std::io::Error>,
    _types: PhantomData<fn(X, U)>,
}

impl<X, U> SegmentSmoother<X, U, std::fs::File> {
    /// Record into a new file at `path` (created, truncated; the caller removes it).
    pub fn on_file(path: &std::path::Path, max_steps: usize) -> std::io::Result<Self> {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)?;
        Ok(Self::new(file, max_steps))
    }
}

impl<X, U, S> SegmentSmoother<X, U, S> {
    /// Record into `store` (written from its current position on), with at most
    /// `max_steps` predictions per segment (the memory of the backward pass: three
    /// `N × N` matrices per step).
    pub fn new(store: S, max_steps: usize) -> Self {
        Self {
            store,
            offsets: vec![0],
            max_steps: max_steps.max(1),
            open: Vec::new(),
            open_steps: 0,
            last_epoch: None,
            bytes: Vec::new(),
            error: None,
            _types: PhantomData,
        }
    }

    /// Number of segments recorded so far (closed ones).
    pub fn segments(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Bytes written to the storage so far.
    pub fn stored_bytes(&self) -> u64 {
        *self.offsets.last().unwrap_or(&0)
    }
}

fn q_len<N: DimName>(q: &QAdjust<N>) -> (f64, usize)
where
    DefaultAllocator: DimAlloc<N>,
{
    match q {
        QAdjust::Keep | QAdjust::Model => (0.0, 0),
        QAdjust::Scale(_) => (1.0, 1),
        QAdjust::AddRate(_) => (2.0, N::DIM * N::DIM),
    }
}

impl<X, U, S> SegmentSmoother<X, U, S>
where
    X: Manifold + Spill,
    U: Spill,
    S: Read + Write + Seek,
    DefaultAllocator: DimAlloc<X::Dim>,
{
    fn close(&mut self) {
        if self.open_steps == 0 {
            return;
        }
        self.open[0] = self.open_steps as f64;
        self.bytes.clear();
        for v in &self.open {
            self.bytes.extend_from_slice(&v.to_le_bytes());
        }
        self.open.clear();
        self.open_steps = 0;
        if self.error.is_some() {
            return;
        }
        match self.store.write_all(&self.bytes) {
            Ok(()) => {
                let end = self.stored_bytes() + self.bytes.len() as u64;
                self.offsets.push(end);
            }
            Err(e) => self.error = Some(e),
        }
    }

    fn start<A: NoiseStrategy, B: CovBackend<X::Dim>>(&mut self, f: &ErrorStateFilter<X, A, B>) {
        let n = X::Dim::DIM;
        let q = f.process_noise_adjustment();
        let (tag, len) = q_len(q);
        let o = &mut self.open;
        o.extend_from_slice(&[0.0, f.time(), f.strategy().prediction_fading(), tag]);
        match q {
            QAdjust::Scale(s) => o.push(*s),
            QAdjust::AddRate(m) => o.extend_from_slice(m.as_slice()),
            _ => {}
        }
        debug_assert_eq!(o.len(), HEAD + len);
        let at = o.len();
        o.resize(at + X::LEN, 0.0);
        f.state().spill(&mut o[at..]);
        let p = f.covariance();
        for c in 0..n {
            o.extend_from_slice(&p.as_slice()[c * n..c * n + c + 1]);
        }
    }

    /// End the forward pass: the storage error that stopped recording, if any.
    pub fn finish_recording(&mut self) -> std::io::Result<()> {
        self.close();
        match self.error.take() {
            Some(e) => Err(e),
            None => self.store.flush(),
        }
    }

    /// The backward pass from the filter's final posterior, with the model of the forward
    /// pass. `sink` receives the smoothed marked epochs one segment at a time, in time
    /// order within a call, the segments last to first.
    pub fn smooth<A, B, PM>(
        mut self,
        filter: &ErrorStateFilter<X, A, B>,
        model: &PM,
        mut sink: impl FnMut(&[SmoothedRow<X>]) -> std::io::Result<()>,
    ) -> Result<(), SmootherError>
    where
        A: NoiseStrategy,
        B: CovBackend<X::Dim>,
        PM: ProcessModel<State = X, Input = U>,
    {
        self.finish_recording()?;
        let mut back = Backward::start(filter);
        let mut seg = Replayed::default();
        let mut store = Store { store: &mut self.store, offsets: &self.offsets, bytes: Vec::new() };
        for k in (0..self.offsets.len() - 1).rev() {
            store.replay(k, model, &mut seg)?;
            back.segment(&seg)?;
            sink(&back.rows)?;
        }
        Ok(())
    }

    /// [`smooth`](Self::smooth) with the segments read and replayed on a second thread
    /// while this one runs the recursion (the same numbers; about half the time on two
    /// cores).
    pub fn smooth_threaded<A, B, PM>(
        mut self,
        filter: &ErrorStateFilter<X, A, B>,
        model: &PM,
        mut sink: impl FnMut(&[SmoothedRow<X>]) -> std::io::Result<()>,
    ) -> Result<(), SmootherError>
    where
        A: NoiseStrategy,
        B: CovBackend<X::Dim>,
        PM: ProcessModel<State = X, Input = U> + Sync,
        X: Send,
        U: Send,
        S: Send,
        Cov<X::Dim>: Send,
    {
        self.finish_recording()?;
        let mut back = Backward::start(filter);
        let segments = self.offsets.len() - 1;
        let mut store = Store { store: &mut self.store, offsets: &self.offsets, bytes: Vec::new() };
        std::thread::scope(|scope| -> Result<(), SmootherError> {
            // replayed segments one way in batches of about `BATCH_STEPS` steps (a thread
            // wake-up per segment costs more than a short segment's work), their emptied
            // buffers back for reuse
            type Batch<X, U> = Vec<Replayed<X, U>>;
            let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Batch<X, U>, _>>(2);
            let (back_tx, back_rx) = std::sync::mpsc::channel::<Batch<X, U>>();
            scope.spawn(move || {
                let mut spare: Batch<X, U> = Vec::new();
                let mut batch: Batch<X, U> = Vec::new();
                let mut steps = 0;
                for k in (0..segments).rev() {
                    if spare.is_empty() {
                        if let Ok(b) = back_rx.try_recv() {
                            spare = b;
                        }
                    }
                    let mut seg = spare.pop().unwrap_or_default();
                    if let Err(e) = store.replay(k, model, &mut seg) {
                        let _ = tx.send(Err(e));
                        return;
                    }
                    steps += seg.steps.len();
                    batch.push(seg);
                    if steps >= BATCH_STEPS || k == 0 {
                        steps = 0;
                        if tx.send(Ok(core::mem::take(&mut batch))).is_err() {
                            return;
                        }
                    }
                }
            });
            for batch in rx {
                let batch = batch?;
                for seg in &batch {
                    back.segment(seg)?;
                    sink(&back.rows)?;
                }
                let _ = back_tx.send(batch);
            }
            Ok(())
        })
    }
}

/// Steps per batch between the threads of [`SegmentSmoother::smooth_threaded`].
const BATCH_STEPS: usize = 2048;

/// The storage and the segment offsets, for reading segments back.
struct Store<'a, S> {
    store: &'a mut S,
    offsets: &'a [u64],
    bytes: Vec<u8>,
}

/// One segment replayed: its states, covariances and transitions, step by step.
struct Replayed<X: Manifold, U>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// `x̂ᵢ` and `Pᵢ` for `i = 0..=n` (`0`: the segment's start).
    xs: Vec<X>,
    ps: Vec<Cov<X::Dim>>,
    /// `Φᵢ`, `i < n`.
    phis: Vec<Cov<X::Dim>>,
    /// End time, interval, mark and input of each step.
    steps: Vec<(f64, f64, bool, U)>,
    values: Vec<f64>,
}

impl<X: Manifold, U> Default for Replayed<X, U>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    fn default() -> Self {
        Self {
            xs: Vec::new(),
            ps: Vec::new(),
            phis: Vec::new(),
            steps: Vec::new(),
            values: Vec::new(),
        }
    }
}

impl<S: Read + Seek> Store<'_, S> {
    /// Read segment `k` and replay it into `seg`.
    fn replay<X, U, PM>(
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
        self.store.seek(SeekFrom::Start(from))?;
        self.bytes.resize((to - from) as usize, 0);
        self.store.read_exact(&mut self.bytes)?;
        let values = &mut seg.values;
        values.clear();
        values.extend(self.bytes.chunks_exact(8).map(|b| {
            let mut a = [0u8; 8];
            a.copy_from_slice(b);
            f64::from_le_bytes(a)
        }));
        let v = &values[..];
        let corrupt = SmootherError::Corrupt;
        if v.len() < HEAD {
            return Err(corrupt("segment header"));
        }
        let (count, fading, tag) = (v[0] as usize, v[2], v[3]);
        let (q, qn) = match tag as u8 {
            0 => (QAdjust::Keep, 0),
            1 => (QAdjust::Scale(*v.get(HEAD).ok_or(corrupt("noise scale"))?), 1),
            2 => {
                let m = v.get(HEAD..HEAD + n * n).ok_or(corrupt("noise rate"))?;
                (QAdjust::AddRate(Cov::<X::Dim>::from_column_slice(m)), n * n)
            }
            _ => return Err(corrupt("noise adjustment tag")),
        };
        let mut at = HEAD + qn;
        let tri = n * (n + 1) / 2;
        if v.len() != at + X::LEN + tri + count * (STEP + U::LEN) || count == 0 {
            return Err(corrupt("segment length"));
        }
        seg.xs.clear();
        seg.steps.clear();
        seg.xs.push(X::unspill(&v[at..at + X::LEN]));
        at += X::LEN;
        // the covariances and transitions are written in place (a segment's buffers are
        // reused: they grow to the longest segment once, then are only overwritten)
        seg.ps.resize(count + 1, Cov::<X::Dim>::zeros());
        seg.phis.resize(count, Cov::<X::Dim>::zeros());
        let p0 = &mut seg.ps[0];
        for c in 0..n {
            for r in 0..=c {
                p0[(r, c)] = v[at];
                p0[(c, r)] = v[at];
                at += 1;
            }
        }
        for _ in 0..count {
            let u = U::unspill(&v[at + STEP..at + STEP + U::LEN]);
            seg.steps.push((v[at], v[at + 1], v[at + 2] != 0.0, u));
            at += STEP + U::LEN;
        }
        // replay, by the static back-end's path (the model's fused product where it has
        // one), with the segment's fading and noise adjustment; Φ on the side
        let mut backend = StaticCov;
        for (k, (_, dt, _, u)) in seg.steps.iter().enumerate() {
            let x = &seg.xs[k];
            seg.phis[k] = model.transition(x, u, *dt);
            let (done, next) = seg.ps.split_at_mut(k + 1);
            let x_next = backend.predict(model, x, u, *dt, &done[k], fading, &q, &mut next[0])?;
            seg.xs.push(x_next);
        }
        Ok(())
    }
}

/// The backward recursion: the smoothed estimate at the start of the segment after the
/// current one, and the rows of the last segment done.
struct Backward<X: Manifold>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    x_s: X,
    p_s: Cov<X::Dim>,
    rows: Vec<SmoothedRow<X>>,
}

impl<X: Manifold> Backward<X>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    fn start<A: NoiseStrategy, B: CovBackend<X::Dim>>(filter: &ErrorStateFilter<X, A, B>) -> Self {
        Self {
            x_s: filter.state().clone(),
            p_s: filter.covariance().into_owned(),
            rows: Vec::new(),
        }
    }

    /// Smooth through one replayed segment (rows in time order in `self.rows`).
    fn segment<U>(&mut self, seg: &Replayed<X, U>) -> Result<(), SmootherError> {
        let (xs, ps, phis) = (&seg.xs, &seg.ps, &seg.phis);
        let count = seg.steps.len();
        // the segment's end: Pˢ into the frame of the prior x̂ₙ (Σ), then
        // λ = Pₙ⁻¹ d, Λ = Pₙ⁻¹ − Pₙ⁻¹ Σ Pₙ⁻¹
        let d = self.x_s.ominus(&xs[count]);
        reframe(&xs[count], &d, &mut self.p_s, Reframe::Into)?;
        let chol = cholesky("smoother: predicted covariance Pₙ", ps[count].clone())?;
        let mut lambda = chol.solve(&d);
        // Pₙ⁻¹ Σ
        let m = chol.solve(&self.p_s);
        // Λ in one of two buffers, the next one written into the other (no swap: swapping
        // two covariances copies three of them)
        let mut bigs = [chol.inverse() - chol.solve(&m.transpose()), Cov::<X::Dim>::zeros()];
        symmetrize(&mut bigs[0]);
        let mut cur = 0;
        self.rows.clear();
        let (mut pl, mut phi_t) = (Cov::<X::Dim>::zeros(), Cov::<X::Dim>::zeros());
        let zero = Cov::<X::Dim>::zeros();
        for k in (0..=count).rev() {
            let (x, p) = (&xs[k], &ps[k]);
            kernels::mat_mul(p, &bigs[cur], &mut pl); // Pᵢ Λᵢ
            if k == 0 {
                let delta = p * &lambda;
                let x_s = x.oplus(&delta);
                let mut p_s = p - &pl * p;
                symmetrize(&mut p_s);
                reframe(x, &delta, &mut p_s, Reframe::OutOf)?;
                if !x_s.is_finite() || p_s.iter().any(|v| !v.is_finite()) {
                    return Err(
                        FilterError::NonFinite { what: "smoothed state or covariance" }.into()
                    );
                }
                self.x_s = x_s;
                self.p_s = p_s;
                break;
            }
            let (t, _, mark, _) = &seg.steps[k - 1];
            if *mark {
                let delta = p * &lambda;
                let var = variances_out_of(x, &delta, p, &pl);
                self.rows.push(SmoothedRow { time: *t, x: x.oplus(&delta), var });
            }
            phis[k - 1].transpose_to(&mut phi_t);
            lambda = &phi_t * &lambda;
            // Λ ← Φᵀ Λ Φ (exactly symmetric)
            let [a, b] = &mut bigs;
            let (from, to) = if cur == 0 { (a, b) } else { (b, a) };
            kernels::dense_sandwich(&phi_t, from, &zero, to);
            cur = 1 - cur;
        }
        self.rows.reverse();
        if self.rows.iter().any(|r| !r.x.is_finite() || r.var.iter().any(|v| !v.is_finite())) {
            return Err(FilterError::NonFinite { what: "smoothed state or variance" }.into());
        }
        Ok(())
    }
}

impl<X, U, S> StepRecorder<X, U> for SegmentSmoother<X, U, S>
where
    X: Manifold + Spill,
    U: Spill,
    S: Read + Write + Seek,
    DefaultAllocator: DimAlloc<X::Dim>,
{
    fn before_predict<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
        u: &U,
        dt: f64,
        mark: bool,
    ) {
        let epoch = filter.epoch();
        if self.last_epoch != Some(epoch) || self.open_steps >= self.max_steps {
            self.close();
            self.last_epoch = Some(epoch);
        }
        if self.open_steps == 0 {
            self.start(filter);
        }
        let end = filter.time() + dt;
        self.open.extend_from_slice(&[end, dt, f64::from(u8::from(mark))]);
        let at = self.open.len();
        self.open.resize(at + U::LEN, 0.0);
        u.spill(&mut self.open[at..]);
        self.open_steps += 1;
    }
}

/// The diagonal of `G S Gᵀ` for `S = P − (PΛ) P` and `G = G(x, δ)`: the smoothed
/// variances in the frame of `x ⊕ δ`, from the entries of `S` that the reset blocks touch
/// (`S` is not formed; outside the blocks the variance is `S`'s diagonal).
fn variances_out_of<X: Manifold>(
    x: &X,
    delta: &manifolds::Tangent<X>,
    p: &Cov<X::Dim>,
    pl: &Cov<X::Dim>,
) -> OVector<f64, X::Dim>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    let s = |r: usize, c: usize| p[(r, c)] - pl.row(r).dot(&p.column(c).transpose());
    let mut var = OVector::<f64, X::Dim>::from_fn(|i, _| s(i, i));
    x.reset_blocks(delta, &mut |o, b| {
        let d = b.nrows();
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
                        v += gij * gil * s(o + j, o + l);
                    }
                }
            }
            var[o + i] = v;
        }
    });
    var
}
