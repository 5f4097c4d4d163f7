//! [`SegmentSmoother`] and what serves it (the documentation is on the item).

use core::marker::PhantomData;
use core::sync::atomic::Ordering;
use std::io::{Read, Seek, SeekFrom, Write};

use nalgebra::{DefaultAllocator, DimName, OVector};

use manifolds::{DimAlloc, Manifold};

use crate::adapt::{NoiseStrategy, QAdjust};
use crate::backend::{static_predict, CovBackend};
use crate::dims::Cov;
use crate::error::FilterError;
use crate::filter::{fading_over, ErrorStateFilter};
use crate::kernels;
use crate::linalg::cholesky;
use crate::smoother::{reframe, Reframe};
use crate::traits::ProcessModel;

mod backward;
mod recorder;
mod spill;
mod store;

use backward::*;
pub use recorder::StepRecorder;
pub use spill::{Spill, AFTER_FORMS};
use store::*;

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
// A step is stored as its flags ([`MARKED`], [`AFTER`], [`VARIANCES`], [`STAMPED`],
// [`CONTINUES`], and the input's form over [`FORM_SHIFT`]), its end time and interval
// unless [`STAMPED`], and its input ([`Spill::spill`], or [`Spill::spill_after`] when
// [`AFTER`]).

/// Step flag: the step ends at an output epoch.
const MARKED: u16 = 1;
/// Step flag: the input is stored after the step before it ([`Spill::spill_after`]).
const AFTER: u16 = 2;
/// Step flag: the output epoch wants the smoothed variances too (the segment ends there).
const VARIANCES: u16 = 4;
/// Step flag: the step's end time and interval are its input's ([`Spill::stamp`]) and are
/// not stored.
const STAMPED: u16 = 8;
/// The input's form ([`Spill::spill_after`]) is the flags over this.
const FORM_SHIFT: u32 = 4;
/// Step flag (above the forms): the forward pass did not propagate the covariance at the
/// step's end, but over a stretch of steps that goes on past it
/// ([`StepRecorder::covariance_continues`]).
const CONTINUES: u16 = 1 << (FORM_SHIFT + 4);
/// Flags are below this.
const FLAGS_END: u16 = CONTINUES << 1;
/// Segment end: the next segment continues this one (its start covariance is this end's).
const END_OPEN: f64 = 0.0;
/// Segment end: an update follows; the covariance before it is stored after the steps.
const END_PRIOR: f64 = 1.0;
/// Segment end: an update follows and its prior covariance was not recorded: the
/// backward pass replays the covariance through the segment.
const END_REPLAY: f64 = 2.0;

/// How the backward recursion carries `Λ` through a segment (the smoothed states are the
/// same either way; the smoothed variances agree to rounding).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AdjointForm {
    /// `Λᵢ = Φᵢᵀ Λᵢ₊₁ Φᵢ` at every step ([`ProcessModel::adjoint_sandwich`]).
    #[default]
    PerStep,
    /// The segment's transition `Ψ = Φₙ₋₁ ⋯ Φ₀` accumulated backwards (`Ψ ← Ψ Φᵢ`,
    /// [`ProcessModel::times_transition`]), then `Λ₀ = Ψᵀ Λₙ Ψ` once per segment: one
    /// product a step instead of two (a sandwich), the same `Λ₀` in exact arithmetic.
    Accumulated,
}

/// The segment-wise fixed-interval smoother.
///
/// `S` is the storage: a file for long runs ([`SegmentSmoother::on_file`]), or a
/// `std::io::Cursor<Vec<u8>>` in memory.
///
/// A fixed-interval smoother for long, high-rate runs: the forward pass is stored per
/// *segment* (the predictions between two updates, at most `max_steps` of them), on disk
/// or any other seekable storage, and every step is rebuilt by replaying the segment.
///
/// [`RtsSmoother`](crate::RtsSmoother) keeps `(x̂⁺, P⁺, Φ, x̂⁻, P⁻)` of every prediction in
/// memory: about 3 `N × N` matrices per step, 17 GB for a day of 100 Hz IMU data with 15
/// states. [`SegmentSmoother`] keeps, per segment, the posterior `(x̂⁺, P⁺)` it starts from,
/// the covariance `Pₙ` it ends with when an update follows (given by
/// [`StepRecorder::before_update`]), the strategy's prediction fading and process-noise
/// adjustment (constant within a segment: strategies change them only at updates) and the
/// inputs `(u, dt)` of its steps — two covariances per update instead of three per step —
/// in its storage, and in memory only the start offset of each segment.
///
/// The backward pass reads the segments last to first. It replays each one's nominal
/// states and transitions `Φᵢ` with the model (no covariance) and runs the RTS recursion
/// through it in its adjoint form (Bryson & Frazier; Bierman 1977 §X), which needs no
/// inverse inside a segment and no covariance between its ends:
///
/// ```text
/// at the segment's end n (the prior of the next segment's first update), with
/// d = x̂ˢ ⊖ x̂ₙ and Σ = G(x̂ₙ, d)⁻¹ Pˢ G(x̂ₙ, d)⁻ᵀ (Pˢ taken into the prior's frame):
///   λₙ = Pₙ⁻¹ d,           Λₙ = Pₙ⁻¹ − Pₙ⁻¹ Σ Pₙ⁻¹
/// backwards through the steps:
///   λᵢ = Φᵢᵀ λᵢ₊₁,          Λᵢ = Φᵢᵀ Λᵢ₊₁ Φᵢ
/// at the start, and forwards through the steps (the smoothed corrections δᵢ = Pᵢ λᵢ):
///   δ₀ = P₀ λ₀,            δᵢ₊₁ = α Φᵢ δᵢ + Q̃ᵢ λᵢ₊₁,      x̂ˢᵢ = x̂ᵢ ⊕ δᵢ
///   Pˢ₀ = P₀ − P₀ Λ₀ P₀    (and Pˢₙ = Pₙ − Pₙ Λₙ Pₙ where the variances are asked)
/// ```
///
/// which is the RTS gain `Cᵢ = Pᵢ Φᵢᵀ Pᵢ₊₁⁻¹` applied step by step (`δᵢ = Cᵢ δᵢ₊₁`
/// with `δᵢ₊₁ = Pᵢ₊₁ λᵢ₊₁`); the forward sweep is `Pᵢ₊₁ λᵢ₊₁` expanded with the
/// prediction `Pᵢ₊₁ = Φᵢ (α Pᵢ) Φᵢᵀ + Q̃ᵢ` (`α` the fading, `Q̃ᵢ` the adjusted `Q_d`, whose
/// product with a vector the model gives: [`ProcessModel::noise_times`]), so the
/// covariances inside a segment are never formed. The frames are those of
/// [`RtsSmoother`](crate::RtsSmoother) (see its module): inside a segment there is no
/// update, so the smoothed error stays in the frames of the replayed nominals; `Pˢ` is
/// taken into the prior's frame at the segment's end and out to the smoothed estimate's
/// (`G(x̂ᵢ, δᵢ) Pˢᵢ G(x̂ᵢ, δᵢ)ᵀ`) where it is reported. Both smoothers give the same
/// numbers, on a vector space (`tests/segment_smoother.rs`) and on SO(3) × R³
/// (`tests/smoother_manifold.rs`), to 1e-9.
///
/// The forward pass records through [`StepRecorder::before_predict`], called with the
/// filter before each prediction, and [`StepRecorder::before_update`], before each update;
/// a new segment starts whenever the filter's update counter moved (an update, accepted or
/// refused, may change `x̂`, `P`, the fading and the noise adjustment), the segment is full,
/// or its last step asked for variances. Steps are *marked* when their end is an output
/// epoch; the backward pass returns the smoothed state there, and the smoothed variances
/// where [`StepRecorder::mark_variances`] asked for them (such a step ends its segment, so
/// its covariance is stored). A segment whose end covariance was not given (an update
/// without `before_update`) is replayed with its covariance, as the filter predicted it.
///
/// A forward pass that propagates the covariance at a lower rate than the state (one
/// covariance step over a stretch of predictions: [`ErrorStateFilter::predict_state`] at
/// each, [`ErrorStateFilter::predict_covariance`] over their inputs folded) says so with
/// [`StepRecorder::covariance_continues`] at each prediction its stretch goes on past; a
/// stretch also ends with its segment. When the model folds inputs
/// ([`ProcessModel::fold_input`]) the recursion then takes the stretches as the forward
/// pass did: in the equations above a step `i` is a stretch of `n` predictions, with the
/// transition and noise over its folded input and summed interval and the fading `αⁿ`,
/// and the smoothed correction at a prediction inside a stretch is interpolated in time
/// between the stretch's ends (`δ = δₐ + w (δ_b − δₐ)`, `w` the share of the stretch's
/// interval elapsed; the nominal state there is replayed as it was). Each stretch's end
/// is then the step-by-step smoother of the filter as it ran
/// (`tests/segment_smoother.rs`), at the cost of one transition per stretch instead of
/// one per prediction.
///
/// What keeps the second pass close to the cost of the first:
/// - the replay forms each step's nominal state only ([`ProcessModel::propagate`]), the
///   recursion each step's `Φᵀ` as it comes to it
///   ([`ProcessModel::transition_transposed`]: formed on the thread that uses it, not
///   handed between cores); its `Φᵀ Λ Φ` is the model's
///   structured product ([`ProcessModel::adjoint_sandwich`]; the INS model runs its
///   prediction kernel on the transposed pattern), the rest products with vectors; with
///   [`AdjointForm::Accumulated`] the recursion carries the segment's transition `Ψ`
///   instead (`Ψ ← Ψ Φᵢ`, [`ProcessModel::times_transition`]: one structured product a
///   step instead of a sandwich's two) and forms `Λ₀ = Ψᵀ Λₙ Ψ` once per segment;
/// - a segment closed for length, not by an update, is *continued*: `λ` and `Λ` go through
///   its boundary as they are, without the smoothed covariance and the Cholesky factor an
///   update boundary needs;
/// - at an update boundary, `Pₙ⁻¹` is formed by the replay's thread with the segment, not
///   by the recursion's (the longer of the two);
/// - an input that repeats the step before's (an IMU input carries the previous sample)
///   is stored once, and only what the step before does not give
///   ([`Spill::spill_after`]: a steady-rate IMU sample is its six increments); a step
///   whose end time and interval are its input's ([`Spill::stamp`]) is stored without
///   them; closed segments are written and read back about a megabyte at a time, as the
///   numbers they are (no conversion), and a storage file is cut behind the reads (what
///   the backward pass has used is dropped from the page cache before it is written back
///   to the disk, if it was not yet).
///
/// What the smoother does not see: an update's prior scaling (a strategy's `λ_P`) — the
/// segment's end uses the propagated `Pₙ`, not the scaled prior the update used. For
/// fixed noise, an adaptive `R` or an adapted `Q` the recursion is exact.
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
    /// How the backward pass carries `Λ` ([`with_adjoint_form`](Self::with_adjoint_form)).
    adjoint: AdjointForm,
    /// The covariances before the updates are not stored but replayed
    /// ([`with_replayed_priors`](Self::with_replayed_priors)).
    replay_priors: bool,
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
            adjoint: AdjointForm::PerStep,
            replay_priors: false,
            _types: PhantomData,
        }
    }

    /// How the backward pass carries `Λ` through a segment (default
    /// [`AdjointForm::PerStep`]).
    pub fn with_adjoint_form(mut self, form: AdjointForm) -> Self {
        self.adjoint = form;
        self
    }

    /// Store no covariance before an update ([`StepRecorder::before_update`] takes none):
    /// the backward pass rebuilds it by replaying the segment's covariance from its start,
    /// as the forward pass propagated it (every step, or its stretches: see
    /// [`StepRecorder::covariance_continues`]), on the replay's side. One covariance per
    /// update in the storage instead of two, for a covariance step per step taken in the
    /// backward pass (default: stored).
    pub fn with_replayed_priors(mut self, replay: bool) -> Self {
        self.replay_priors = replay;
        self
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
        if self.error.is_none()
            && let Err(e) = self.store.write_all(bytemuck::cast_slice(&self.pending))
        {
            self.error = Some(e);
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
        Ok((Backward::start(filter, self.adjoint), store))
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
    /// while this one runs the recursion (the same numbers). The replay is the lighter
    /// part (the nominal states; the recursion forms the transitions). It runs up to 16
    /// batches of about 256 steps ahead, then waits until the recursion has taken all but
    /// 4: woken once per batch instead, the scheduler put it on the recursion's core each
    /// time, before the recursion, with the other core idle (`docs/history/benches.md`).
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
        // batches the replay is ahead by (sent, not yet taken by the recursion; a stopped
        // recursion sets none, and a parked replay goes on, to find it gone)
        let ahead = std::sync::atomic::AtomicUsize::new(0);
        std::thread::scope(|scope| -> Result<(), SmootherError> {
            // replayed segments one way in batches of about `BATCH_STEPS` steps (a thread
            // wake-up per segment costs more than a short segment's work), the batches back
            // for reuse; a batch is replayed into in place, its first `used` segments
            // filled (a segment moved by value copies its covariances, several kilobytes)
            type Batch<X, U> = (Vec<Replayed<X, U>>, usize);
            let (tx, rx) = std::sync::mpsc::channel::<Result<Batch<X, U>, _>>();
            let (back_tx, back_rx) = std::sync::mpsc::channel::<Vec<Replayed<X, U>>>();
            let ahead = &ahead;
            let replay = scope.spawn(move || {
                let mut batch: Vec<Replayed<X, U>> = Vec::new();
                let (mut used, mut steps) = (0, 0);
                for k in (0..segments).rev() {
                    if used == 0
                        && let Ok(b) = back_rx.try_recv()
                    {
                        batch = b;
                    }
                    if used == batch.len() {
                        batch.push(Replayed::default());
                    }
                    let seg = &mut batch[used];
                    if let Err(e) = store.replay(k, model, seg) {
                        ahead.fetch_add(1, Ordering::SeqCst);
                        let _ = tx.send(Err(e));
                        return;
                    }
                    steps += seg.steps.len();
                    used += 1;
                    if steps >= BATCH_STEPS || k == 0 {
                        ahead.fetch_add(1, Ordering::SeqCst);
                        if tx.send(Ok((core::mem::take(&mut batch), used))).is_err() {
                            return;
                        }
                        (used, steps) = (0, 0);
                        // far enough ahead: wait until the recursion has taken all but
                        // `AHEAD_LOW` (a wake-up per batch put the replay on the
                        // recursion's core, before it, each time: 30 % of its time)
                        while ahead.load(Ordering::SeqCst) >= AHEAD_HIGH {
                            std::thread::park();
                        }
                    }
                }
            });
            let release = Release(ahead, replay.thread().clone());
            for batch in rx {
                if ahead.fetch_sub(1, Ordering::SeqCst) == AHEAD_LOW + 1 {
                    release.1.unpark();
                }
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

/// Clears its count and wakes its thread when dropped: the recursion of
/// [`SegmentSmoother::smooth_threaded`], however it ends, releases a replay that waits.
struct Release<'a>(&'a std::sync::atomic::AtomicUsize, std::thread::Thread);

impl Drop for Release<'_> {
    fn drop(&mut self) {
        self.0.store(0, Ordering::SeqCst);
        self.1.unpark();
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
                flags |= AFTER | (u16::from(form) << FORM_SHIFT);
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
        if self.open_steps > 0 && !self.prior_taken && !self.replay_priors {
            self.prior.clear();
            push_upper(&mut self.prior, &filter.covariance());
            self.prior_taken = true;
        }
    }

    /// A stretch opens (and its covariance is stored) after an update, after the most
    /// steps a segment holds and after an epoch of variances.
    fn reads_covariance(&self, epoch: u64) -> bool {
        self.open_steps == 0
            || self.last_epoch != Some(epoch)
            || self.open_steps >= self.max_steps
            || self.close_next
    }

    fn covariance_continues(&mut self) {
        if self.open_steps > 0 {
            let flags = &mut self.open[self.last_flags];
            *flags = f64::from(*flags as u16 | CONTINUES);
        }
    }

    fn mark_variances(&mut self) {
        if self.open_steps > 0 {
            let flags = &mut self.open[self.last_flags];
            *flags = f64::from(*flags as u16 | MARKED | VARIANCES);
            self.close_next = true;
        }
    }
}
