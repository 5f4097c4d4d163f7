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
//! What keeps the second pass close to the cost of the first:
//! - the replay takes each step's `Φᵀ` from the model's fused prediction
//!   ([`ProcessModel::step_covariance_adjoint`]) and the recursion's `Φᵀ Λ Φ` from the
//!   model's structured product ([`ProcessModel::adjoint_sandwich`]; the INS model runs
//!   its prediction kernel on the transposed pattern);
//! - a segment closed for length, not by an update, is *continued*: `λ` and `Λ` go through
//!   its boundary as they are, without the smoothed covariance and the Cholesky factor an
//!   update boundary needs;
//! - `P Λ` and the variances are formed only at marked steps, the variances as one pass
//!   over whole columns;
//! - an input that repeats the step before's (an IMU input carries the previous sample)
//!   is stored once ([`Spill::spill_after`]), and closed segments are written and read
//!   back about a megabyte at a time.
//!
//! What the smoother does not see: an update's prior scaling (a strategy's `λ_P`) — the
//! segment's end uses the propagated `Pₙ`, not the scaled prior the update used. For
//! fixed noise, an adaptive `R` or an adapted `Q` the recursion is exact.

use core::marker::PhantomData;
use std::io::{Read, Seek, SeekFrom, Write};

use nalgebra::{DefaultAllocator, DimName, OVector, SVector};

use manifolds::{DimAlloc, Manifold};

use crate::adapt::{NoiseStrategy, QAdjust};
use crate::backend::{static_predict, CovBackend};
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
    /// How many numbers [`spill_after`](Self::spill_after) writes (`≤ LEN`).
    const AFTER_LEN: usize = Self::LEN;
    /// Write the value, which follows `before` (the previous step's input), in
    /// [`AFTER_LEN`](Self::AFTER_LEN) numbers when `before` and those numbers rebuild it
    /// exactly; `false` (nothing written) otherwise. An IMU input that repeats the
    /// previous sample stores only the new one. The default never shortens.
    fn spill_after(&self, before: &Self, out: &mut [f64]) -> bool {
        let _ = (before, out);
        false
    }
    /// Rebuild a value from what [`spill_after`](Self::spill_after) wrote.
    fn unspill_after(v: &[f64], before: &Self) -> Self {
        let _ = before;
        Self::unspill(v)
    }
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

/// Header numbers before the state: steps, start time, fading, noise-adjustment tag,
/// and whether the segment continues the one before it (no update between them).
const HEAD: usize = 5;
/// Numbers per step before the input: end time, interval, flags (bit 0: marked; bit 1:
/// the input is stored after the step before it, [`Spill::spill_after`]).
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
    /// The input of the open segment's last step (the next one may be stored after it).
    last_input: Option<U>,
    last_epoch: Option<u64>,
    /// The next segment continues the last one (it was closed for length, not an update).
    continues: bool,
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
            last_input: None,
            last_epoch: None,
            continues: false,
            bytes: Vec::new(),
            error: None,
            _types: PhantomData,
        }
    }

    /// Number of segments recorded so far (closed ones).
    pub fn segments(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Bytes recorded so far (the last megabyte or so may not be written to the storage
    /// yet: see [`finish_recording`](Self::finish_recording)).
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
    U: Spill + Clone,
    S: Read + Write + Seek,
    DefaultAllocator: DimAlloc<X::Dim>,
{
    fn close(&mut self) {
        if self.open_steps == 0 {
            return;
        }
        self.open[0] = self.open_steps as f64;
        let start = self.bytes.len();
        for v in &self.open {
            self.bytes.extend_from_slice(&v.to_le_bytes());
        }
        self.open.clear();
        self.open_steps = 0;
        self.last_input = None;
        let end = self.stored_bytes() + (self.bytes.len() - start) as u64;
        self.offsets.push(end);
        // closed segments go to the storage about a megabyte at a time (one write per
        // segment made a system call per update)
        if self.bytes.len() >= WRITE_BYTES {
            self.write_pending();
        }
    }

    /// Write the closed segments not written yet.
    fn write_pending(&mut self) {
        if self.error.is_none() {
            if let Err(e) = self.store.write_all(&self.bytes) {
                self.error = Some(e);
            }
        }
        self.bytes.clear();
    }

    fn start<A: NoiseStrategy, B: CovBackend<X::Dim>>(&mut self, f: &ErrorStateFilter<X, A, B>) {
        let n = X::Dim::DIM;
        let q = f.process_noise_adjustment();
        let (tag, len) = q_len(q);
        let o = &mut self.open;
        let continues = f64::from(u8::from(self.continues));
        o.extend_from_slice(&[0.0, f.time(), f.strategy().prediction_fading(), tag, continues]);
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
        self.write_pending();
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
        let mut store =
            Store { store: &mut self.store, offsets: &self.offsets, bytes: Vec::new(), at: 0 };
        for k in (0..self.offsets.len() - 1).rev() {
            store.replay(k, model, &mut seg)?;
            back.segment(&seg, model)?;
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
        let mut store =
            Store { store: &mut self.store, offsets: &self.offsets, bytes: Vec::new(), at: 0 };
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
                    back.segment(seg, model)?;
                    sink(&back.rows)?;
                }
                let _ = back_tx.send(batch);
            }
            Ok(())
        })
    }
}

/// Bytes of closed segments held before one write to the storage, and read back at a
/// time by the backward pass.
const WRITE_BYTES: usize = 1 << 20;

/// Steps per batch between the threads of [`SegmentSmoother::smooth_threaded`].
const BATCH_STEPS: usize = 256;

/// The storage and the segment offsets, for reading segments back: a window of about
/// [`WRITE_BYTES`] that ends at the segment asked for (the backward pass reads the
/// segments last to first, so one read serves many).
struct Store<'a, S> {
    store: &'a mut S,
    offsets: &'a [u64],
    bytes: Vec<u8>,
    /// Where in the storage `bytes` starts.
    at: u64,
}

/// One segment replayed: its states, covariances and transitions, step by step.
struct Replayed<X: Manifold, U>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// `x̂ᵢ` and `Pᵢ` for `i = 0..=n` (`0`: the segment's start).
    xs: Vec<X>,
    ps: Vec<Cov<X::Dim>>,
    /// `Φᵢᵀ`, `i < n`.
    phi_ts: Vec<Cov<X::Dim>>,
    /// End time, interval, mark and input of each step.
    steps: Vec<(f64, f64, bool, U)>,
    /// The segment continues the one before it (no update at its start).
    continues: bool,
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
            phi_ts: Vec::new(),
            steps: Vec::new(),
            continues: false,
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
        let held = self.at..self.at + self.bytes.len() as u64;
        if !(held.contains(&from) && to <= held.end) {
            // the window that ends with this segment
            let start = from.min(to.saturating_sub(WRITE_BYTES as u64));
            self.store.seek(SeekFrom::Start(start))?;
            self.bytes.resize((to - start) as usize, 0);
            self.store.read_exact(&mut self.bytes)?;
            self.at = start;
        }
        let bytes = &self.bytes[(from - self.at) as usize..(to - self.at) as usize];
        let values = &mut seg.values;
        values.clear();
        values.extend(bytes.chunks_exact(8).map(|b| {
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
        seg.continues = match v[4] {
            0.0 => false,
            1.0 => true,
            _ => return Err(corrupt("segment continuation flag")),
        };
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
        // (a corrupt count must not overflow the bound it is checked against)
        let least = count
            .checked_mul(STEP + U::AFTER_LEN.min(U::LEN))
            .and_then(|steps| steps.checked_add(at + X::LEN + tri));
        if least.is_none_or(|least| v.len() < least) || count == 0 {
            return Err(corrupt("segment length"));
        }
        seg.xs.clear();
        seg.steps.clear();
        seg.xs.push(X::unspill(&v[at..at + X::LEN]));
        at += X::LEN;
        // the covariances and transitions are written in place (a segment's buffers are
        // reused: they grow to the longest segment once, then are only overwritten)
        seg.ps.resize(count + 1, Cov::<X::Dim>::zeros());
        seg.phi_ts.resize(count, Cov::<X::Dim>::zeros());
        let p0 = &mut seg.ps[0];
        for c in 0..n {
            for r in 0..=c {
                p0[(r, c)] = v[at];
                p0[(c, r)] = v[at];
                at += 1;
            }
        }
        for _ in 0..count {
            let flags = *v.get(at + 2).ok_or(corrupt("segment length"))?;
            let (mark, after) = match flags {
                0.0 => (false, false),
                1.0 => (true, false),
                2.0 => (false, true),
                3.0 => (true, true),
                _ => return Err(corrupt("step flags")),
            };
            let len = if after { U::AFTER_LEN } else { U::LEN };
            let payload = v.get(at + STEP..at + STEP + len).ok_or(corrupt("segment length"))?;
            let u = match (after, seg.steps.last()) {
                (true, Some((.., before))) => U::unspill_after(payload, before),
                (true, None) => return Err(corrupt("first step stored after another")),
                (false, _) => U::unspill(payload),
            };
            seg.steps.push((v[at], v[at + 1], mark, u));
            at += STEP + len;
        }
        if at != v.len() {
            return Err(corrupt("segment length"));
        }
        // replay by the static back-end's path (the model's fused product where it has
        // one), with the segment's fading and noise adjustment, Φᵀ on the side
        for (k, (_, dt, _, u)) in seg.steps.iter().enumerate() {
            let x = &seg.xs[k];
            let (done, next) = seg.ps.split_at_mut(k + 1);
            let phi_t = Some(&mut seg.phi_ts[k]);
            let x_next =
                static_predict(model, x, u, *dt, &done[k], fading, &q, &mut next[0], phi_t)?;
            seg.xs.push(x_next);
        }
        Ok(())
    }
}

/// What the backward recursion carries from one segment into the one before it.
enum Carried<X: Manifold>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// The smoothed estimate at the start of the later segment (an update lies between).
    Smoothed { x: X, p: Cov<X::Dim> },
    /// `λ` and `Λ` at the start of the later segment, which continues this one: they go on
    /// through the boundary unchanged.
    Adjoint { lambda: OVector<f64, X::Dim>, big: Cov<X::Dim> },
}

/// The backward recursion: what it carries into the segment before, and the rows of the
/// last segment done.
struct Backward<X: Manifold>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    carried: Carried<X>,
    rows: Vec<SmoothedRow<X>>,
}

impl<X: Manifold> Backward<X>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    fn start<A: NoiseStrategy, B: CovBackend<X::Dim>>(filter: &ErrorStateFilter<X, A, B>) -> Self {
        let carried =
            Carried::Smoothed { x: filter.state().clone(), p: filter.covariance().into_owned() };
        Self { carried, rows: Vec::new() }
    }

    /// Smooth through one replayed segment (rows in time order in `self.rows`).
    fn segment<U, PM>(&mut self, seg: &Replayed<X, U>, model: &PM) -> Result<(), SmootherError>
    where
        PM: ProcessModel<State = X, Input = U>,
    {
        let (xs, ps, phi_ts) = (&seg.xs, &seg.ps, &seg.phi_ts);
        let count = seg.steps.len();
        // Λ in one of two buffers, the next one written into the other (no swap: swapping
        // two covariances copies three of them)
        let (mut lambda, first) = match &mut self.carried {
            Carried::Adjoint { lambda, big } => (lambda.clone(), big.clone()),
            Carried::Smoothed { x, p } => {
                // the segment's end: Pˢ into the frame of the prior x̂ₙ (Σ), then
                // λ = Pₙ⁻¹ d, Λ = Pₙ⁻¹ − Pₙ⁻¹ Σ Pₙ⁻¹
                let d = x.ominus(&xs[count]);
                reframe(&xs[count], &d, p, Reframe::Into)?;
                let chol = cholesky("smoother: predicted covariance Pₙ", ps[count].clone())?;
                let inv = inverse_from_cholesky(&chol);
                let mut lambda = OVector::<f64, X::Dim>::zeros();
                kernels::mat_mul(&inv, &d, &mut lambda);
                // Pₙ⁻¹ − Pₙ⁻¹ Σ Pₙ⁻¹
                let (mut m, mut big) = (Cov::<X::Dim>::zeros(), Cov::<X::Dim>::zeros());
                kernels::mat_mul(&inv, &*p, &mut m);
                kernels::mat_mul(&m, &inv, &mut big);
                let mut big = inv - big;
                symmetrize(&mut big);
                (lambda, big)
            }
        };
        let mut bigs = [first, Cov::<X::Dim>::zeros()];
        let mut cur = 0;
        self.rows.clear();
        let mut pl = Cov::<X::Dim>::zeros();
        let mut delta = OVector::<f64, X::Dim>::zeros();
        for k in (0..=count).rev() {
            let (x, p) = (&xs[k], &ps[k]);
            if k == 0 {
                self.carried = if seg.continues {
                    Carried::Adjoint { lambda, big: bigs[cur].clone() }
                } else {
                    kernels::mat_mul(p, &bigs[cur], &mut pl); // Pᵢ Λᵢ
                    kernels::mat_mul(p, &lambda, &mut delta);
                    let x_s = x.oplus(&delta);
                    let mut plp = Cov::<X::Dim>::zeros();
                    kernels::mat_mul(&pl, p, &mut plp);
                    let mut p_s = p - plp;
                    symmetrize(&mut p_s);
                    reframe(x, &delta, &mut p_s, Reframe::OutOf)?;
                    if !x_s.is_finite() || p_s.iter().any(|v| !v.is_finite()) {
                        return Err(FilterError::NonFinite {
                            what: "smoothed state or covariance",
                        }
                        .into());
                    }
                    Carried::Smoothed { x: x_s, p: p_s }
                };
                break;
            }
            let (t, _, mark, _) = &seg.steps[k - 1];
            if *mark {
                kernels::mat_mul(p, &bigs[cur], &mut pl); // Pᵢ Λᵢ
                kernels::mat_mul(p, &lambda, &mut delta);
                let var = variances_out_of(x, &delta, p, &pl);
                self.rows.push(SmoothedRow { time: *t, x: x.oplus(&delta), var });
            }
            let phi_t = &phi_ts[k - 1];
            kernels::mat_mul(phi_t, &lambda, &mut delta);
            core::mem::swap(&mut lambda, &mut delta);
            // Λ ← Φᵀ Λ Φ (exactly symmetric)
            let [a, b] = &mut bigs;
            let (from, to) = if cur == 0 { (a, b) } else { (b, a) };
            model.adjoint_sandwich(phi_t, from, to);
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
    U: Spill + Clone,
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
        let updated = self.last_epoch != Some(epoch);
        if updated || self.open_steps >= self.max_steps {
            self.close();
            self.continues = !updated;
            self.last_epoch = Some(epoch);
        }
        if self.open_steps == 0 {
            self.start(filter);
        }
        let end = filter.time() + dt;
        let at = self.open.len();
        self.open.extend_from_slice(&[end, dt, f64::from(u8::from(mark))]);
        let payload = at + STEP;
        self.open.resize(payload + U::AFTER_LEN, 0.0);
        let after = match &self.last_input {
            Some(before) => u.spill_after(before, &mut self.open[payload..]),
            None => false,
        };
        if after {
            self.open[at + 2] += 2.0;
        } else {
            self.open.resize(payload + U::LEN, 0.0);
            u.spill(&mut self.open[payload..]);
        }
        self.last_input = Some(u.clone());
        self.open_steps += 1;
    }
}

/// The diagonal of `G S Gᵀ` for `S = P − P Λ P` and `G = G(x, δ)`: the smoothed
/// variances in the frame of `x ⊕ δ`, from the entries of `S` that the reset blocks touch
/// (`S` is not formed; outside the blocks the variance is `S`'s diagonal). `pl = P Λ`.
fn variances_out_of<X: Manifold>(
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

/// `A⁻¹` of a symmetric positive-definite `A = L Lᵀ` from its Cholesky factor, exactly
/// symmetric: `W = L⁻¹` by forward substitution, then the lower triangle of `Wᵀ W`,
/// mirrored (about `N³/3` multiply-adds in plain loops over columns; nalgebra's
/// `Cholesky::inverse` solves against the identity column by column, several times
/// slower at the smoother's sizes).
fn inverse_from_cholesky<N: DimName>(chol: &nalgebra::Cholesky<f64, N>) -> Cov<N>
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
