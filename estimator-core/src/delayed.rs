//! [`Replay`] and what serves it (the documentation is on the item).

use std::collections::VecDeque;
use std::rc::Rc;

use nalgebra::DefaultAllocator;

use manifolds::Manifold;

use crate::adapt::NoiseStrategy;
use crate::backend::CovBackend;
use crate::dims::{Cov, FilterAlloc, StateDim};
use crate::error::FilterError;
use crate::filter::ErrorStateFilter;
use crate::smoother::{FixedLagSmoother, Lag, RtsSmoother, Smoothed};
use crate::traits::{MeasurementModel, ProcessModel};

/// An update as the history keeps it.
type Apply<X, A, B> = Rc<dyn Fn(&mut ErrorStateFilter<X, A, B>) -> Result<(), FilterError>>;

/// A prediction of the caller's as the history keeps it: the filter over an interval,
/// returning the step's transition when the caller gave it (for a smoother).
type Step<X, A, B> = Rc<
    dyn Fn(
        &mut ErrorStateFilter<X, A, B>,
        f64,
    ) -> Result<Option<Cov<<X as Manifold>::Dim>>, FilterError>,
>;

/// Two time stamps closer than this, relative to their size (at least 1 s), are the same
/// epoch.
pub const STAMP_TOLERANCE: f64 = 1e-9;

/// Whether `a` and `b` are the same epoch ([`STAMP_TOLERANCE`]).
fn same_epoch(a: f64, b: f64) -> bool {
    (a - b).abs() <= STAMP_TOLERANCE * a.abs().max(b.abs()).max(1.0)
}

/// The smoother a [`Replay`] records its final predictions in: the whole run
/// ([`Replay::with_smoother`]) or a window ([`Replay::with_fixed_lag`]).
#[derive(Clone, Debug)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(bound(
        serialize = "X: serde::Serialize, Cov<X::Dim>: serde::Serialize",
        deserialize = "X: serde::Deserialize<'de>, Cov<X::Dim>: serde::Deserialize<'de>"
    ))
)]
pub enum ReplaySmoother<X: Manifold>
where
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    /// Fixed interval: every prediction since the start.
    Interval(RtsSmoother<X>),
    /// Fixed lag: the predictions of the last lag.
    FixedLag(FixedLagSmoother<X>),
}

impl<X: Manifold> ReplaySmoother<X>
where
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    /// `f.predict(model, u, dt)`, recorded in the smoother (its
    /// [`RtsSmoother::predict`] or [`FixedLagSmoother::predict`]).
    pub fn predict<A, B, PM>(
        &mut self,
        f: &mut ErrorStateFilter<X, A, B>,
        model: &PM,
        u: &PM::Input,
        dt: f64,
    ) -> Result<(), FilterError>
    where
        A: NoiseStrategy,
        B: CovBackend<X::Dim>,
        PM: ProcessModel<State = X>,
    {
        match self {
            ReplaySmoother::Interval(s) => s.predict(f, model, u, dt),
            ReplaySmoother::FixedLag(s) => s.predict(f, model, u, dt),
        }
    }

    fn predict_with<A, B>(
        &mut self,
        f: &mut ErrorStateFilter<X, A, B>,
        step: impl FnOnce(&mut ErrorStateFilter<X, A, B>) -> Result<Cov<X::Dim>, FilterError>,
    ) -> Result<(), FilterError>
    where
        A: NoiseStrategy,
        B: CovBackend<X::Dim>,
    {
        match self {
            ReplaySmoother::Interval(s) => s.predict_with(f, step),
            ReplaySmoother::FixedLag(s) => s.predict_with(f, step),
        }
    }

    /// The smoothed estimates from `f`'s posterior: every one since the start (fixed
    /// interval) or the window's, oldest first (fixed lag).
    pub fn smooth<A, B>(
        &self,
        f: &ErrorStateFilter<X, A, B>,
    ) -> Result<Vec<Smoothed<X>>, FilterError>
    where
        A: NoiseStrategy,
        B: CovBackend<X::Dim>,
    {
        match self {
            ReplaySmoother::Interval(s) => s.smooth(f),
            ReplaySmoother::FixedLag(s) => s.smooth(f),
        }
    }
}

enum Event<X: Manifold, A: NoiseStrategy, B: CovBackend<X::Dim>, U>
where
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    /// The model's prediction with input `u`.
    Predict {
        u: U,
        dt: f64,
    },
    /// A prediction of the caller's.
    Step {
        step: Step<X, A, B>,
        dt: f64,
    },
    Update {
        apply: Apply<X, A, B>,
    },
}

impl<X: Manifold, A: NoiseStrategy, B: CovBackend<X::Dim>, U: Clone> Event<X, A, B, U>
where
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    /// The interval of a prediction (`None` for an update).
    fn dt(&self) -> Option<f64> {
        match self {
            Event::Predict { dt, .. } | Event::Step { dt, .. } => Some(*dt),
            Event::Update { .. } => None,
        }
    }

    /// The same prediction over `dt` instead.
    fn with_dt(&self, dt: f64) -> Self {
        match self {
            Event::Predict { u, .. } => Event::Predict { u: u.clone(), dt },
            Event::Step { step, .. } => Event::Step { step: step.clone(), dt },
            Event::Update { apply } => Event::Update { apply: apply.clone() },
        }
    }
}

impl<X: Manifold, A: NoiseStrategy, B: CovBackend<X::Dim>, U: Clone> Clone for Event<X, A, B, U>
where
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    fn clone(&self) -> Self {
        match self {
            Event::Predict { u, dt } => Event::Predict { u: u.clone(), dt: *dt },
            Event::Step { step, dt } => Event::Step { step: step.clone(), dt: *dt },
            Event::Update { apply } => Event::Update { apply: apply.clone() },
        }
    }
}

/// A filter with a replay history for delayed measurements.
///
/// Delayed measurements: a measurement stamped in the past is applied at its own time, by
/// replaying a bounded history of predictions and updates.
///
/// [`Replay`] owns the filter and the process model and keeps, for the last
/// `history` seconds, the filter as it was at the history's start and every event since
/// (the input and interval of each prediction, each update). A measurement stamped at
/// `t` earlier than the filter's time goes into the history at `t` — a prediction that
/// spans `t` is split in two with the same input, as an on-time filter would have split
/// it — and the history is replayed from its start. The result is the filter that would
/// have seen the measurement on time, exactly (the same operations in the same order;
/// `tests/delayed.rs`: to 1e-9 and in fact bit for bit). A measurement older than the
/// history is refused ([`FilterError::TooLate`]); on any `Err` the filter and the history
/// are unchanged.
///
/// Any update and any prediction can be kept: [`Replay::update_with_at`] takes a closure
/// that updates the filter (iterated, unscented, with an observer — whatever it does), and
/// [`Replay::predict_with`] one that propagates it over a given interval (the sigma-point
/// prediction), which the history may split at a delayed measurement's time.
///
/// A smoother composes with it: [`Replay::with_smoother`] records each prediction in an
/// [`RtsSmoother`] when it leaves the history (final: no late measurement can change it),
/// and [`Replay::smooth`] smooths everything so far — the on-time filter's smoothed
/// trajectory, bit for bit (`tests/delayed.rs`). [`Replay::with_fixed_lag`] records in a
/// [`FixedLagSmoother`] instead: [`Replay::lagged`] is then the on-time filter's
/// `x(t − lag | t)`, late measurements included, bit for bit. [`Replay::checkpoint`] and
/// [`Replay::resume`] write and read it back ([`ReplayCheckpoint`]).
///
/// Time stamps are compared within [`STAMP_TOLERANCE`] (relative): the filter's clock sums
/// its intervals (200 steps of 0.1 s make 20.000000000000014), so a measurement stamped
/// 20.0 belongs to that epoch — after the updates already applied there, never as a
/// prediction split into a step of 1e-14 s.
///
/// Cost: a delayed measurement replays the history (its events since the history's start);
/// every event is also applied a second time when it leaves the history (to move the
/// history's start on), so a filter in a `Replay` does about twice the work of a bare one,
/// plus the replays. Each update event holds its model, measurement and noise in an `Rc`.
pub struct Replay<X, A, B, PM>
where
    X: Manifold,
    A: NoiseStrategy,
    B: CovBackend<X::Dim>,
    PM: ProcessModel<State = X>,
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    model: PM,
    history: f64,
    start: ErrorStateFilter<X, A, B>,
    events: VecDeque<Event<X, A, B, PM::Input>>,
    filter: ErrorStateFilter<X, A, B>,
    replays: u64,
    /// The smoother's recording of the events that left the history (final).
    smoother: Option<ReplaySmoother<X>>,
}

/// A [`Replay`] as it can be written and read back ([`Replay::checkpoint`],
/// [`Replay::resume`]; with the feature `serde` it implements `Serialize` and
/// `Deserialize`): the filter up to date, the smoother's recording with the history's
/// events in it, the history's length and the replay count.
///
/// The history's events hold the caller's closures, which no format can write, so a
/// checkpoint *closes* the history: the resumed `Replay` starts its history at the
/// checkpoint's time and refuses ([`FilterError::TooLate`]) a measurement stamped before
/// it, which the run that never stopped could still have applied. Everything else is the
/// same, bit for bit: the filter, and the smoothed trajectory when the smoother records
/// (`tests/checkpoint.rs`). Checkpoint where no measurement older than now is still on its
/// way (after a GNSS outage, at a pause), or keep the late ones for the resumed run's
/// history by stamping them no earlier than the checkpoint.
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(bound(
        serialize = "ErrorStateFilter<X, A, B>: serde::Serialize, \
                     ReplaySmoother<X>: serde::Serialize",
        deserialize = "ErrorStateFilter<X, A, B>: serde::Deserialize<'de>, \
                       ReplaySmoother<X>: serde::Deserialize<'de>"
    ))
)]
#[derive(Clone, Debug)]
pub struct ReplayCheckpoint<X, A, B>
where
    X: Manifold,
    A: NoiseStrategy,
    B: CovBackend<X::Dim>,
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    /// The filter, up to date.
    pub filter: ErrorStateFilter<X, A, B>,
    /// The smoother's recording, the history's predictions included (`None` without
    /// [`Replay::with_smoother`] or [`Replay::with_fixed_lag`]).
    pub smoother: Option<ReplaySmoother<X>>,
    /// The history's length, s.
    pub history: f64,
    /// How many times the history was replayed.
    pub replays: u64,
}

impl<X, A, B, PM> Replay<X, A, B, PM>
where
    X: Manifold + 'static,
    A: NoiseStrategy + 'static,
    B: CovBackend<X::Dim> + 'static,
    PM: ProcessModel<State = X>,
    PM::Input: Clone,
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    /// Keep `history` seconds of events for `filter` propagated by `model`.
    pub fn new(filter: ErrorStateFilter<X, A, B>, model: PM, history: f64) -> Self {
        let empty = ReplayCheckpoint { filter, smoother: None, history, replays: 0 };
        Self::resume(empty, model)
    }

    /// Record for a fixed-interval smoother ([`RtsSmoother`]): every prediction is
    /// recorded when it leaves the history, when no late measurement can change it any
    /// more, so the recording is the on-time filter's; [`smooth`](Self::smooth) smooths
    /// it with the history's events. Call it before the first event. A caller's
    /// prediction must then give its transition
    /// ([`predict_with_transition`](Self::predict_with_transition)).
    pub fn with_smoother(mut self) -> Self {
        self.smoother = Some(ReplaySmoother::Interval(RtsSmoother::new()));
        self
    }

    /// Record for a fixed-lag smoother ([`FixedLagSmoother`]) as
    /// [`with_smoother`](Self::with_smoother) does for the fixed-interval one: the window
    /// of the last `lag`, whose estimates [`smooth`](Self::smooth) gives (the oldest,
    /// `x(t − lag | t)`, is [`lagged`](Self::lagged)), those of the on-time filter's
    /// fixed-lag smoother, late measurements included. Call it before the first event.
    pub fn with_fixed_lag(mut self, lag: Lag) -> Self {
        self.smoother = Some(ReplaySmoother::FixedLag(FixedLagSmoother::new(lag)));
        self
    }

    /// The fixed-interval smoother's recording of the predictions that left the history
    /// (`None` without [`with_smoother`](Self::with_smoother)).
    pub fn smoother(&self) -> Option<&RtsSmoother<X>> {
        match &self.smoother {
            Some(ReplaySmoother::Interval(s)) => Some(s),
            _ => None,
        }
    }

    /// The smoothed trajectory of everything so far: the recording, with the events still
    /// in the history recorded on a copy, smoothed ([`RtsSmoother::smooth`]); with
    /// [`with_fixed_lag`](Self::with_fixed_lag), the window's estimates
    /// ([`FixedLagSmoother::smooth`]). Without either, the history's events alone, from
    /// its start.
    pub fn smooth(&self) -> Result<Vec<Smoothed<X>>, FilterError> {
        let mut rec = match &self.smoother {
            Some(s) => s.clone(),
            None => ReplaySmoother::Interval(RtsSmoother::new()),
        };
        let f = self.record_history(&mut rec)?;
        rec.smooth(&f)
    }

    /// The history's events run on a copy of its start and recorded in `rec`: the
    /// up-to-date filter, as a smoother sees it.
    fn record_history(
        &self,
        rec: &mut ReplaySmoother<X>,
    ) -> Result<ErrorStateFilter<X, A, B>, FilterError> {
        let mut f = self.start.clone();
        for e in &self.events {
            run(&mut f, &self.model, e, Some(&mut *rec))?;
        }
        Ok(f)
    }

    /// The oldest estimate of [`smooth`](Self::smooth): with
    /// [`with_fixed_lag`](Self::with_fixed_lag), `x(t − lag | t)`.
    pub fn lagged(&self) -> Result<Smoothed<X>, FilterError> {
        Ok(self.smooth()?.swap_remove(0))
    }

    /// The filter, up to date.
    pub fn filter(&self) -> &ErrorStateFilter<X, A, B> {
        &self.filter
    }

    /// The process model.
    pub fn model(&self) -> &PM {
        &self.model
    }

    /// The filter (up to date) and the model back; the history is dropped.
    pub fn into_inner(self) -> (ErrorStateFilter<X, A, B>, PM) {
        (self.filter, self.model)
    }

    /// The `Replay` as it can be written and read back ([`ReplayCheckpoint`]): the
    /// history's events are applied to a copy of its start (the smoother records them),
    /// so resuming closes the history at now. The `Replay` itself is unchanged.
    pub fn checkpoint(&self) -> Result<ReplayCheckpoint<X, A, B>, FilterError> {
        let mut smoother = self.smoother.clone();
        if let Some(rec) = smoother.as_mut() {
            self.record_history(rec)?;
        }
        Ok(ReplayCheckpoint {
            filter: self.filter.clone(),
            smoother,
            history: self.history,
            replays: self.replays,
        })
    }

    /// Resume from a [`checkpoint`](Self::checkpoint) with the process model: the history
    /// starts at the checkpoint's time.
    pub fn resume(checkpoint: ReplayCheckpoint<X, A, B>, model: PM) -> Self {
        let ReplayCheckpoint { filter, smoother, history, replays } = checkpoint;
        Self {
            model,
            history,
            start: filter.clone(),
            events: VecDeque::new(),
            filter,
            replays,
            smoother,
        }
    }

    /// The time at the start of the history: the oldest time a measurement may carry.
    pub fn oldest(&self) -> f64 {
        self.start.time()
    }

    /// How many times the history was replayed.
    pub fn replays(&self) -> u64 {
        self.replays
    }

    /// Predict with the model; the history's start moves on past events older than the
    /// history. On `Err` nothing changes.
    pub fn predict(&mut self, u: &PM::Input, dt: f64) -> Result<(), FilterError> {
        self.filter.predict(&self.model, u, dt)?;
        self.events.push_back(Event::Predict { u: u.clone(), dt });
        self.trim()
    }

    /// Predict over `dt` by `step(filter, dt)` — any prediction of the caller's, such as
    /// the sigma-point one; a replay may run it over parts of `dt` that add up to it. On
    /// `Err` nothing changes. With a smoother ([`with_smoother`](Self::with_smoother))
    /// the step must give its transition: use
    /// [`predict_with_transition`](Self::predict_with_transition).
    pub fn predict_with(
        &mut self,
        dt: f64,
        step: impl Fn(&mut ErrorStateFilter<X, A, B>, f64) -> Result<(), FilterError> + 'static,
    ) -> Result<(), FilterError> {
        if self.smoother.is_some() {
            return Err(FilterError::Unsupported {
                what: "a caller's prediction without its transition in a smoothed Replay \
                       (use predict_with_transition)",
            });
        }
        self.push_step(dt, Rc::new(move |f, dt| step(f, dt).map(|()| None)))
    }

    /// [`predict_with`](Self::predict_with) for a step that returns its transition `Φ`
    /// (the model's Jacobian, or the sigma points' statistical one:
    /// [`ErrorStateFilter::predict_unscented_transition`]), which a smoother records.
    pub fn predict_with_transition(
        &mut self,
        dt: f64,
        step: impl Fn(&mut ErrorStateFilter<X, A, B>, f64) -> Result<Cov<X::Dim>, FilterError> + 'static,
    ) -> Result<(), FilterError> {
        self.push_step(dt, Rc::new(move |f, dt| step(f, dt).map(Some)))
    }

    fn push_step(&mut self, dt: f64, step: Step<X, A, B>) -> Result<(), FilterError> {
        let mut next = self.filter.clone();
        step(&mut next, dt)?;
        if !same_epoch(next.time(), self.filter.time() + dt) {
            return Err(FilterError::InvalidTimeStep { dt: next.time() - self.filter.time() });
        }
        self.filter = next;
        self.events.push_back(Event::Step { step, dt });
        self.trim()
    }

    /// Update with `z` of `sensor` and noise `R`, measured at `time` (at most the filter's
    /// time): now if `time` is the filter's time, otherwise at its own time by replay.
    /// On `Err` the filter and the history are unchanged.
    pub fn update_at<MM>(
        &mut self,
        sensor: MM,
        z: MM::Measurement,
        R: Cov<StateDim<MM::Measurement>>,
        time: f64,
    ) -> Result<(), FilterError>
    where
        MM: MeasurementModel<State = X> + 'static,
        MM::Measurement: 'static,
        DefaultAllocator: FilterAlloc<X::Dim, StateDim<MM::Measurement>>,
        Cov<StateDim<MM::Measurement>>: 'static,
    {
        self.update_with_at(time, move |f| f.update(&sensor, &z, &R).map(|_| ()))
    }

    /// Apply `apply` — any update of the filter (plain, iterated, unscented, with an
    /// observer) — as measured at `time` (at most the filter's time, within
    /// [`STAMP_TOLERANCE`]): now if `time` is the filter's time, otherwise at its own time
    /// by replay, after the updates already at that time. On `Err` the filter and the
    /// history are unchanged.
    pub fn update_with_at(
        &mut self,
        time: f64,
        apply: impl Fn(&mut ErrorStateFilter<X, A, B>) -> Result<(), FilterError> + 'static,
    ) -> Result<(), FilterError> {
        let now = self.filter.time();
        if !time.is_finite() || (time > now && !same_epoch(time, now)) {
            return Err(FilterError::InvalidTimeStep { dt: now - time });
        }
        if time < self.start.time() && !same_epoch(time, self.start.time()) {
            return Err(FilterError::TooLate {
                delay: now - time,
                history: now - self.start.time(),
            });
        }
        let apply: Apply<X, A, B> = Rc::new(apply);
        if same_epoch(time, now) {
            let mut next = self.filter.clone();
            apply(&mut next)?;
            self.filter = next;
            self.events.push_back(Event::Update { apply });
            return Ok(());
        }
        // the history with the update at its time: after the events that end at or
        // before it, a prediction across it split in two
        let mut events = VecDeque::with_capacity(self.events.len() + 2);
        let mut t = self.start.time();
        let mut placed = false;
        for e in &self.events {
            if let (false, Some(dt)) = (placed, e.dt()) {
                let end = t + dt;
                if same_epoch(time, t) {
                    // at the prediction's start: before it, nothing to split
                    events.push_back(Event::Update { apply: apply.clone() });
                    placed = true;
                } else if end > time && !same_epoch(time, end) {
                    let first = time - t;
                    events.push_back(e.with_dt(first));
                    events.push_back(Event::Update { apply: apply.clone() });
                    events.push_back(e.with_dt(dt - first));
                    placed = true;
                    t = end;
                    continue;
                }
                t = end;
            }
            events.push_back(e.clone());
        }
        if !placed {
            events.push_back(Event::Update { apply });
        }
        let mut filter = self.start.clone();
        for e in &events {
            run(&mut filter, &self.model, e, None)?;
        }
        self.filter = filter;
        self.events = events;
        self.replays += 1;
        Ok(())
    }

    /// Move the history's start on past events that ended more than `history` seconds
    /// before the filter's time.
    fn trim(&mut self) -> Result<(), FilterError> {
        let horizon = self.filter.time() - self.history;
        while let Some(e) = self.events.front() {
            if let Some(dt) = e.dt()
                && self.start.time() + dt > horizon
            {
                break;
            }
            run(&mut self.start, &self.model, e, self.smoother.as_mut())?;
            self.events.pop_front();
        }
        Ok(())
    }
}

/// Apply event `e` to `f`, recording a prediction in `rts` when there is one.
fn run<X, A, B, PM>(
    f: &mut ErrorStateFilter<X, A, B>,
    model: &PM,
    e: &Event<X, A, B, PM::Input>,
    rts: Option<&mut ReplaySmoother<X>>,
) -> Result<(), FilterError>
where
    X: Manifold,
    A: NoiseStrategy,
    B: CovBackend<X::Dim>,
    PM: ProcessModel<State = X>,
    DefaultAllocator: FilterAlloc<X::Dim, X::Dim>,
{
    match (e, rts) {
        (Event::Predict { u, dt }, None) => f.predict(model, u, *dt),
        (Event::Predict { u, dt }, Some(rts)) => rts.predict(f, model, u, *dt),
        (Event::Step { step, dt }, None) => step(f, *dt).map(|_| ()),
        (Event::Step { step, dt }, Some(rts)) => rts.predict_with(f, |f| {
            step(f, *dt)?.ok_or(FilterError::Unsupported {
                what: "a caller's prediction without its transition in a smoothed Replay",
            })
        }),
        (Event::Update { apply }, _) => apply(f),
    }
}
