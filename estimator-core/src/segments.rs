//! A fixed-interval smoother for long, high-rate runs: the forward pass is stored per
//! *segment* (the predictions between two updates, at most `max_steps` of them), on disk
//! or any other seekable storage, and every step is rebuilt by replaying the segment.
//!
//! [`RtsSmoother`](crate::RtsSmoother) keeps `(x̂⁺, P⁺, Φ, x̂⁻, P⁻)` of every prediction in
//! memory: about 3 `N × N` matrices per step, 17 GB for a day of 100 Hz IMU data with 15
//! states. [`SegmentSmoother`] keeps, per segment, the posterior `(x̂⁺, P⁺)` it starts from,
//! the covariance `Pₙ` it ends with when an update follows (given by
//! [`StepRecorder::before_update`]), the strategy's prediction fading and process-noise
//! adjustment (constant within a segment: strategies change them only at updates) and the
//! inputs `(u, dt)` of its steps — two covariances per update instead of three per step —
//! in its storage, and in memory only the start offset of each segment.
//!
//! The backward pass reads the segments last to first. It replays each one's nominal
//! states and transitions `Φᵢ` with the model (no covariance) and runs the RTS recursion
//! through it in its adjoint form (Bryson & Frazier; Bierman 1977 §X), which needs no
//! inverse inside a segment and no covariance between its ends:
//!
//! ```text
//! at the segment's end n (the prior of the next segment's first update), with
//! d = x̂ˢ ⊖ x̂ₙ and Σ = G(x̂ₙ, d)⁻¹ Pˢ G(x̂ₙ, d)⁻ᵀ (Pˢ taken into the prior's frame):
//!   λₙ = Pₙ⁻¹ d,           Λₙ = Pₙ⁻¹ − Pₙ⁻¹ Σ Pₙ⁻¹
//! backwards through the steps:
//!   λᵢ = Φᵢᵀ λᵢ₊₁,          Λᵢ = Φᵢᵀ Λᵢ₊₁ Φᵢ
//! at the start, and forwards through the steps (the smoothed corrections δᵢ = Pᵢ λᵢ):
//!   δ₀ = P₀ λ₀,            δᵢ₊₁ = α Φᵢ δᵢ + Q̃ᵢ λᵢ₊₁,      x̂ˢᵢ = x̂ᵢ ⊕ δᵢ
//!   Pˢ₀ = P₀ − P₀ Λ₀ P₀    (and Pˢₙ = Pₙ − Pₙ Λₙ Pₙ where the variances are asked)
//! ```
//!
//! which is the RTS gain `Cᵢ = Pᵢ Φᵢᵀ Pᵢ₊₁⁻¹` applied step by step (`δᵢ = Cᵢ δᵢ₊₁`
//! with `δᵢ₊₁ = Pᵢ₊₁ λᵢ₊₁`); the forward sweep is `Pᵢ₊₁ λᵢ₊₁` expanded with the
//! prediction `Pᵢ₊₁ = Φᵢ (α Pᵢ) Φᵢᵀ + Q̃ᵢ` (`α` the fading, `Q̃ᵢ` the adjusted `Q_d`, whose
//! product with a vector the model gives: [`ProcessModel::noise_times`]), so the
//! covariances inside a segment are never formed. The frames are those of
//! [`RtsSmoother`](crate::RtsSmoother) (see its module): inside a segment there is no
//! update, so the smoothed error stays in the frames of the replayed nominals; `Pˢ` is
//! taken into the prior's frame at the segment's end and out to the smoothed estimate's
//! (`G(x̂ᵢ, δᵢ) Pˢᵢ G(x̂ᵢ, δᵢ)ᵀ`) where it is reported. Both smoothers give the same
//! numbers, on a vector space (`tests/segment_smoother.rs`) and on SO(3) × R³
//! (`tests/smoother_manifold.rs`), to 1e-9.
//!
//! The forward pass records through [`StepRecorder::before_predict`], called with the
//! filter before each prediction, and [`StepRecorder::before_update`], before each update;
//! a new segment starts whenever the filter's update counter moved (an update, accepted or
//! refused, may change `x̂`, `P`, the fading and the noise adjustment), the segment is full,
//! or its last step asked for variances. Steps are *marked* when their end is an output
//! epoch; the backward pass returns the smoothed state there, and the smoothed variances
//! where [`StepRecorder::mark_variances`] asked for them (such a step ends its segment, so
//! its covariance is stored). A segment whose end covariance was not given (an update
//! without `before_update`) is replayed with its covariance, as the filter predicted it.
//!
//! What keeps the second pass close to the cost of the first:
//! - the replay forms each step's nominal and `Φᵀ` only
//!   ([`ProcessModel::step_transition`]); the recursion's `Φᵀ Λ Φ` is the model's
//!   structured product ([`ProcessModel::adjoint_sandwich`]; the INS model runs its
//!   prediction kernel on the transposed pattern), the rest products with vectors;
//! - a segment closed for length, not by an update, is *continued*: `λ` and `Λ` go through
//!   its boundary as they are, without the smoothed covariance and the Cholesky factor an
//!   update boundary needs;
//! - at an update boundary, `Pₙ⁻¹` is formed by the replay's thread with the segment, not
//!   by the recursion's (the longer of the two);
//! - an input that repeats the step before's (an IMU input carries the previous sample)
//!   is stored once, and only what the step before does not give
//!   ([`Spill::spill_after`]: a steady-rate IMU sample is its six increments); a step
//!   whose end time and interval are its input's ([`Spill::stamp`]) is stored without
//!   them; closed segments are written and read back about a megabyte at a time, as the
//!   numbers they are (no conversion), and a storage file is cut behind the reads (what
//!   the backward pass has used is dropped from the page cache before it is written back
//!   to the disk, if it was not yet).
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
use crate::linalg::cholesky;
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
    /// The most numbers [`spill_after`](Self::spill_after) writes (`≤ LEN`).
    const AFTER_LEN: usize = Self::LEN;
    /// Write the value, which follows `before` (the previous step's input), in fewer
    /// numbers when `before` and those numbers rebuild it exactly: returns the *form* of
    /// what was written (below [`AFTER_FORMS`]; [`after_len`](Self::after_len) numbers),
    /// or `None` (nothing written). An IMU input that repeats the previous sample stores
    /// only the new one, and of it only what the previous one does not give. The default
    /// never shortens.
    fn spill_after(&self, before: &Self, out: &mut [f64]) -> Option<u8> {
        let _ = (before, out);
        None
    }
    /// How many numbers [`spill_after`](Self::spill_after) writes in `form`.
    fn after_len(form: u8) -> usize {
        let _ = form;
        Self::AFTER_LEN
    }
    /// Rebuild a value from what [`spill_after`](Self::spill_after) wrote in `form`.
    fn unspill_after(v: &[f64], form: u8, before: &Self) -> Self {
        let _ = (before, form);
        Self::unspill(v)
    }
    /// The end time and the interval of the step this input drives, when the input
    /// carries them: a step whose own are the same bits is stored without them. Default:
    /// `None`.
    fn stamp(&self) -> Option<(f64, f64)> {
        None
    }
}

/// Forms of [`Spill::spill_after`] (they share a step's flags with the smoother's own).
pub const AFTER_FORMS: u8 = 16;

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

    /// Called with the filter just before an update (or the first of several at one
    /// time): a recorder that stores the covariance a stretch of predictions ends with
    /// takes it here. Without this call the backward pass rebuilds that covariance by
    /// replaying the stretch. Default: nothing.
    fn before_update<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
    ) {
        let _ = filter;
    }

    /// The end of the last recorded prediction is an epoch at which the smoothed
    /// variances are wanted too (the prediction is marked as well). Default: nothing.
    fn mark_variances(&mut self) {}

    /// Whether this recorder keeps the predictions (a smoother's replay needs every one
    /// as [`ErrorStateFilter::predict`] takes it); `false` lets the caller take
    /// shortcuts such as a covariance at a lower rate. Default: `true`.
    fn records(&self) -> bool {
        true
    }
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

    #[inline]
    fn records(&self) -> bool {
        false
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

    #[inline]
    fn before_update<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
    ) {
        if let Some(r) = self {
            r.before_update(filter);
        }
    }

    #[inline]
    fn mark_variances(&mut self) {
        if let Some(r) = self {
            r.mark_variances();
        }
    }

    #[inline]
    fn records(&self) -> bool {
        self.as_ref().is_some_and(|r| r.records())
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
    /// The smoothed variances (diagonal of `Pˢ`), at the epochs that asked for them
    /// ([`StepRecorder::mark_variances`]).
    pub var: Option<OVector<f64, X::Dim>>,
}

/// Header numbers before the state: steps, start time, fading, noise-adjustment tag,
/// whether the segment continues the one before it (no update between them), and what
/// its end holds ([`END_OPEN`], [`END_PRIOR`], [`END_REPLAY`]).
const HEAD: usize = 6;
// A step is stored as its flags ([`MARKED`], [`AFTER`], [`VARIANCES`], [`STAMPED`], and
// the input's form over [`FORM_SHIFT`]), its end time and interval unless [`STAMPED`], and
// its input ([`Spill::spill`], or [`Spill::spill_after`] when [`AFTER`]).

/// Step flag: the step ends at an output epoch.
const MARKED: u8 = 1;
/// Step flag: the input is stored after the step before it ([`Spill::spill_after`]).
const AFTER: u8 = 2;
/// Step flag: the output epoch wants the smoothed variances too (the segment ends there).
const VARIANCES: u8 = 4;
/// Step flag: the step's end time and interval are its input's ([`Spill::stamp`]) and are
/// not stored.
const STAMPED: u8 = 8;
/// The input's form ([`Spill::spill_after`]) is the flags over this.
const FORM_SHIFT: u32 = 4;
/// Segment end: the next segment continues this one (its start covariance is this end's).
const END_OPEN: f64 = 0.0;
/// Segment end: an update follows; the covariance before it is stored after the steps.
const END_PRIOR: f64 = 1.0;
/// Segment end: an update follows and its prior covariance was not recorded: the
/// backward pass replays the covariance through the segment.
const END_REPLAY: f64 = 2.0;

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
    /// The covariance before the first update after the open segment's last step (upper
    /// triangle by columns), when [`before_update`](StepRecorder::before_update) took it.
    prior: Vec<f64>,
    prior_taken: bool,
    /// The last step asked for variances: the segment closes after it.
    close_next: bool,
    /// Where the open segment's last step's flags are.
    last_flags: usize,
    /// Closed segments not written yet (written as their bytes in the machine's order: the
    /// storage is read back by the same process).
    pending: Vec<f64>,
    /// The first storage error of the forward pass (recording stops there).
    error: Option<std::io::Error>,
    /// The storage file again ([`on_file`](Self::on_file)): the backward pass cuts off
    /// what it has read ([`Store::shrink`]).
    shrink: Option<std::fs::File>,
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
        let shrink = file.try_clone()?;
        Ok(Self { shrink: Some(shrink), ..Self::new(file, max_steps) })
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
            prior: Vec::new(),
            prior_taken: false,
            close_next: false,
            last_flags: 0,
            pending: Vec::new(),
            error: None,
            shrink: None,
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
    /// Close the open segment; `updated`: an update (or the end of the run) follows it,
    /// so its end covariance is stored if it was taken.
    fn close(&mut self, updated: bool) {
        if self.open_steps == 0 {
            return;
        }
        self.open[0] = self.open_steps as f64;
        self.open[5] = match (updated, self.prior_taken) {
            (false, _) => END_OPEN,
            (true, true) => {
                self.open.extend_from_slice(&self.prior);
                END_PRIOR
            }
            (true, false) => END_REPLAY,
        };
        self.prior_taken = false;
        let start = self.pending.len();
        self.pending.extend_from_slice(&self.open);
        self.open.clear();
        self.open_steps = 0;
        self.last_input = None;
        let end = self.stored_bytes() + (8 * (self.pending.len() - start)) as u64;
        self.offsets.push(end);
        // closed segments go to the storage about a megabyte at a time (one write per
        // segment made a system call per update)
        if 8 * self.pending.len() >= WRITE_BYTES {
            self.write_pending();
        }
    }

    /// Write the closed segments not written yet.
    fn write_pending(&mut self) {
        if self.error.is_none() {
            if let Err(e) = self.store.write_all(bytemuck::cast_slice(&self.pending)) {
                self.error = Some(e);
            }
        }
        self.pending.clear();
    }

    fn start<A: NoiseStrategy, B: CovBackend<X::Dim>>(&mut self, f: &ErrorStateFilter<X, A, B>) {
        let q = f.process_noise_adjustment();
        let (tag, len) = q_len(q);
        let o = &mut self.open;
        let continues = f64::from(u8::from(self.continues));
        let start = [0.0, f.time(), f.strategy().prediction_fading(), tag, continues, END_OPEN];
        o.extend_from_slice(&start);
        match q {
            QAdjust::Scale(s) => o.push(*s),
            QAdjust::AddRate(m) => o.extend_from_slice(m.as_slice()),
            _ => {}
        }
        debug_assert_eq!(o.len(), HEAD + len);
        let at = o.len();
        o.resize(at + X::LEN, 0.0);
        f.state().spill(&mut o[at..]);
        push_upper(o, &f.covariance());
    }

    /// The last segment ends at the filter's final state: without an update after its
    /// last step, the filter's covariance is that end's.
    fn end_with<A: NoiseStrategy, B: CovBackend<X::Dim>>(&mut self, f: &ErrorStateFilter<X, A, B>) {
        if self.last_epoch == Some(f.epoch()) {
            StepRecorder::<X, U>::before_update(self, f);
        }
    }

    /// End the recording and set up the backward pass: the recursion from the filter's
    /// final posterior, and the reader of the storage.
    fn backward<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
    ) -> Result<(Backward<X>, Store<'_, S>), SmootherError> {
        self.end_with(filter);
        self.finish_recording()?;
        let store = Store {
            store: &mut self.store,
            offsets: &self.offsets,
            window: Vec::new(),
            at: 0,
            shrink: self.shrink.as_ref(),
        };
        Ok((Backward::start(filter), store))
    }

    /// End the forward pass: the storage error that stopped recording, if any.
    pub fn finish_recording(&mut self) -> std::io::Result<()> {
        self.close(true);
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
        let (mut back, mut store) = self.backward(filter)?;
        let mut seg = Replayed::default();
        for k in (0..store.offsets.len() - 1).rev() {
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
        let (mut back, mut store) = self.backward(filter)?;
        let segments = store.offsets.len() - 1;
        std::thread::scope(|scope| -> Result<(), SmootherError> {
            // replayed segments one way in batches of about `BATCH_STEPS` steps (a thread
            // wake-up per segment costs more than a short segment's work), the batches back
            // for reuse; a batch is replayed into in place, its first `used` segments
            // filled (a segment moved by value copies its covariances, several kilobytes)
            type Batch<X, U> = (Vec<Replayed<X, U>>, usize);
            let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Batch<X, U>, _>>(2);
            let (back_tx, back_rx) = std::sync::mpsc::channel::<Vec<Replayed<X, U>>>();
            scope.spawn(move || {
                let mut batch: Vec<Replayed<X, U>> = Vec::new();
                let (mut used, mut steps) = (0, 0);
                for k in (0..segments).rev() {
                    if used == 0 {
                        if let Ok(b) = back_rx.try_recv() {
                            batch = b;
                        }
                    }
                    if used == batch.len() {
                        batch.push(Replayed::default());
                    }
                    let seg = &mut batch[used];
                    if let Err(e) = store.replay(k, model, seg) {
                        let _ = tx.send(Err(e));
                        return;
                    }
                    steps += seg.steps.len();
                    used += 1;
                    if steps >= BATCH_STEPS || k == 0 {
                        if tx.send(Ok((core::mem::take(&mut batch), used))).is_err() {
                            return;
                        }
                        (used, steps) = (0, 0);
                    }
                }
            });
            for batch in rx {
                let (batch, used) = batch?;
                for seg in &batch[..used] {
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
    /// The numbers read (the storage's bytes read into them in place).
    window: Vec<f64>,
    /// Where in the storage `window` starts, bytes.
    at: u64,
    /// The storage file, cut off after each window read: what the backward pass has used it
    /// never reads again, and a scratch file's pages dropped before they are written back
    /// are never written to the disk (the day's 2.7 GB would be, while the smoothed
    /// outputs are being written).
    shrink: Option<&'a std::fs::File>,
}

/// One segment replayed: its nominal states and transitions, step by step, and the
/// covariances at its ends.
struct Replayed<X: Manifold, U>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    /// `x̂ᵢ` for `i = 0..=n` (`0`: the segment's start).
    xs: Vec<X>,
    /// `P₀` first; `Pᵢ` for every `i` when the segment was replayed with its covariance
    /// ([`END_REPLAY`]).
    ps: Vec<Cov<X::Dim>>,
    /// `Pₙ⁻¹` for `Pₙ` the covariance before the update that follows the segment, when one
    /// does (or why `Pₙ` has no inverse); formed by the replay, which has a core to spare,
    /// not by the recursion, which is the backward pass's longest thread.
    p_end_inv: Option<Result<Cov<X::Dim>, FilterError>>,
    /// `Φᵢᵀ`, `i < n`.
    phi_ts: Vec<Cov<X::Dim>>,
    /// End time, interval, flags and input of each step.
    steps: Vec<(f64, f64, u8, U)>,
    /// The segment continues the one before it (no update at its start).
    continues: bool,
    /// The prediction fading and noise adjustment of the segment's steps.
    fading: f64,
    q: QAdjust<X::Dim>,
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
            continues: false,
            fading: 1.0,
            q: QAdjust::Keep,
        }
    }
}

/// The upper triangle of `p`, column by column, appended to `out`.
fn push_upper<N: DimName>(out: &mut Vec<f64>, p: &Cov<N>)
where
    DefaultAllocator: DimAlloc<N>,
{
    let n = N::DIM;
    for c in 0..n {
        out.extend_from_slice(&p.as_slice()[c * n..c * n + c + 1]);
    }
}

/// A covariance from its upper triangle (as [`push_upper`] wrote it) at the start of `v`.
fn read_upper<N: DimName>(v: &[f64], p: &mut Cov<N>)
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
        seg.ps.resize(if replay { count + 1 } else { 1 }, Cov::<X::Dim>::zeros());
        seg.phi_ts.resize(count, Cov::<X::Dim>::zeros());
        read_upper(&v[at..], &mut seg.ps[0]);
        at += tri;
        for _ in 0..count {
            let flags = *v.get(at).ok_or(corrupt("segment length"))?;
            if !((0.0..256.0).contains(&flags) && flags.fract() == 0.0) {
                return Err(corrupt("step flags"));
            }
            let flags = flags as u8;
            let (after, stamped) = (flags & AFTER != 0, flags & STAMPED != 0);
            let form = flags >> FORM_SHIFT;
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
            seg.steps.push((end, dt, flags & (MARKED | VARIANCES), u));
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
        if replay {
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
            p_end = Some(seg.ps[count].clone());
        } else {
            // the nominal states and the transitions only
            for (k, (_, dt, _, u)) in seg.steps.iter().enumerate() {
                let x_next = model.step_transition(&seg.xs[k], u, *dt, &mut seg.phi_ts[k]);
                seg.xs.push(x_next);
            }
        }
        seg.p_end_inv = p_end.map(|p| {
            cholesky("smoother: predicted covariance Pₙ", p)
                .map(|chol| inverse_from_cholesky(&chol))
        });
        Ok(())
    }
}

/// What the backward recursion carries from one segment into the one before it, besides
/// the covariance [`Backward::carried_p`] (and `Λ`, left in [`Backward::bigs`]).
enum Carried<X: Manifold>
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
struct Backward<X: Manifold>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    carried: Carried<X>,
    /// The covariance that goes with `carried`.
    carried_p: Cov<X::Dim>,
    /// `Λ`, in one of the two (`bigs[cur]`), the next one written into the other; after a
    /// segment, `bigs[cur]` is `Λ₀`, the later segment's `Λ` for a continued one.
    bigs: [Cov<X::Dim>; 2],
    cur: usize,
    /// `Pₙ Λₙ` where a continued segment's end wants variances.
    pl: Cov<X::Dim>,
    rows: Vec<SmoothedRow<X>>,
    /// `λᵢ` of the segment being smoothed.
    lambdas: Vec<OVector<f64, X::Dim>>,
}

impl<X: Manifold> Backward<X>
where
    DefaultAllocator: DimAlloc<X::Dim>,
{
    fn start<A: NoiseStrategy, B: CovBackend<X::Dim>>(filter: &ErrorStateFilter<X, A, B>) -> Self {
        Self {
            carried: Carried::Smoothed { x: filter.state().clone() },
            carried_p: filter.covariance().into_owned(),
            bigs: [Cov::<X::Dim>::zeros(), Cov::<X::Dim>::zeros()],
            cur: 0,
            pl: Cov::<X::Dim>::zeros(),
            rows: Vec::new(),
            lambdas: Vec::new(),
        }
    }

    /// Smooth through one replayed segment (rows in time order in `self.rows`).
    fn segment<U, PM>(&mut self, seg: &Replayed<X, U>, model: &PM) -> Result<(), SmootherError>
    where
        PM: ProcessModel<State = X, Input = U>,
    {
        let (xs, phi_ts) = (&seg.xs, &seg.phi_ts);
        let count = seg.steps.len();
        let end_flags = seg.steps[count - 1].2;
        let zero = OVector::<f64, X::Dim>::zeros();
        self.lambdas.resize(count + 1, zero.clone());
        // the segment's end: λₙ, Λₙ (into `bigs[cur]`), and its row's state and variances
        let p = &mut self.carried_p;
        let (end_x, end_var) = match &self.carried {
            Carried::Adjoint { lambda, delta } => {
                // (Λₙ is the later segment's Λ₀, left in `bigs[cur]`)
                self.lambdas[count].copy_from(lambda);
                let var = (end_flags & VARIANCES != 0).then(|| {
                    kernels::mat_mul(&*p, &self.bigs[self.cur], &mut self.pl); // Pₙ Λₙ
                    variances_out_of(&xs[count], delta, p, &self.pl)
                });
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
                kernels::mat_mul(inv, &d, &mut self.lambdas[count]);
                // −(Pₙ⁻¹ Σ Pₙ⁻¹ − Pₙ⁻¹) as one sandwich (Pₙ⁻¹ is symmetric), exactly symmetric
                let big = &mut self.bigs[self.cur];
                kernels::dense_sandwich(inv, &*p, &negated(inv), big);
                negate(big);
                (x.clone(), var)
            }
        };
        // backwards: λᵢ = Φᵢᵀ λᵢ₊₁ and Λᵢ = Φᵢᵀ Λᵢ₊₁ Φᵢ, Λ in one of two buffers, the
        // next one written into the other (no swap: swapping two covariances copies three)
        for k in (0..count).rev() {
            let (done, later) = self.lambdas.split_at_mut(k + 1);
            kernels::mat_mul(&phi_ts[k], &later[0], &mut done[k]);
            let [a, b] = &mut self.bigs;
            let (from, to) = if self.cur == 0 { (a, b) } else { (b, a) };
            model.adjoint_sandwich(&phi_ts[k], from, to);
            self.cur = 1 - self.cur;
        }
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
        // forwards: δᵢ₊₁ = Pᵢ₊₁ λᵢ₊₁ = α Φᵢ δᵢ + Q̃ᵢ λᵢ₊₁ (Pᵢ₊₁ = Φᵢ (α Pᵢ) Φᵢᵀ + Q̃ᵢ, and
        // Pᵢ Φᵢᵀ λᵢ₊₁ = Pᵢ λᵢ = δᵢ), the marked steps' states x̂ᵢ ⊕ δᵢ
        self.rows.clear();
        let (mut phi_mu, mut q_lambda, mut extra) = (zero.clone(), zero.clone(), zero);
        for (k, (t, dt, flags, u)) in seg.steps.iter().enumerate().take(count - 1) {
            if flags & VARIANCES != 0 {
                return Err(SmootherError::Corrupt("variances asked inside a segment"));
            }
            let next = &self.lambdas[k + 1];
            phi_ts[k].tr_mul_to(&mu, &mut phi_mu);
            let here = &self.lambdas[k]; // Φᵢᵀ λᵢ₊₁
            model.noise_times(&xs[k], u, *dt, &phi_ts[k], next, here, &mut q_lambda);
            match &seg.q {
                QAdjust::Keep | QAdjust::Model => {}
                QAdjust::Scale(s) => q_lambda *= *s,
                QAdjust::AddRate(rate) => {
                    rate.mul_to(next, &mut extra);
                    q_lambda.axpy(*dt, &extra, 1.0);
                }
            }
            for ((m, a), b) in mu.iter_mut().zip(phi_mu.iter()).zip(q_lambda.iter()) {
                *m = seg.fading * a + b;
            }
            if flags & MARKED != 0 {
                self.rows.push(SmoothedRow { time: *t, x: xs[k + 1].oplus(&mu), var: None });
            }
        }
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
        if updated || self.open_steps >= self.max_steps || self.close_next {
            self.close(updated);
            self.continues = !updated;
            self.last_epoch = Some(epoch);
        }
        // (a covariance taken before an update that did not come is stale now)
        self.prior_taken = false;
        self.close_next = false;
        if self.open_steps == 0 {
            self.start(filter);
        }
        let end = filter.time() + dt;
        let at = self.open.len();
        let stamped = u
            .stamp()
            .is_some_and(|(t, d)| t.to_bits() == end.to_bits() && d.to_bits() == dt.to_bits());
        let mut flags = if mark { MARKED } else { 0 };
        if stamped {
            flags |= STAMPED;
            self.open.push(0.0);
        } else {
            self.open.extend_from_slice(&[0.0, end, dt]);
        }
        self.last_flags = at;
        let payload = self.open.len();
        self.open.resize(payload + U::AFTER_LEN, 0.0);
        let form = match &self.last_input {
            Some(before) => u.spill_after(before, &mut self.open[payload..]),
            None => None,
        };
        match form {
            Some(form) if form < AFTER_FORMS => {
                flags |= AFTER | (form << FORM_SHIFT);
                self.open.truncate(payload + U::after_len(form));
            }
            _ => {
                self.open.resize(payload + U::LEN, 0.0);
                u.spill(&mut self.open[payload..]);
            }
        }
        self.open[at] = f64::from(flags);
        self.last_input = Some(u.clone());
        self.open_steps += 1;
    }

    fn before_update<A: NoiseStrategy, B: CovBackend<X::Dim>>(
        &mut self,
        filter: &ErrorStateFilter<X, A, B>,
    ) {
        if self.open_steps > 0 && !self.prior_taken {
            self.prior.clear();
            push_upper(&mut self.prior, &filter.covariance());
            self.prior_taken = true;
        }
    }

    fn mark_variances(&mut self) {
        if self.open_steps > 0 {
            let flags = &mut self.open[self.last_flags];
            *flags = f64::from(*flags as u8 | MARKED | VARIANCES);
            self.close_next = true;
        }
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

/// `m ← −m`, over the matrix's slice (nalgebra's `neg_mut` and `-m` went element by
/// element through a strided iterator, a byte's sign flip at a time: 5 % of the
/// recursion's samples on the day).
fn negate<N: DimName>(m: &mut Cov<N>)
where
    DefaultAllocator: DimAlloc<N>,
{
    for v in m.as_mut_slice() {
        *v = -*v;
    }
}

/// `−m` (see [`negate`]).
fn negated<N: DimName>(m: &Cov<N>) -> Cov<N>
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
