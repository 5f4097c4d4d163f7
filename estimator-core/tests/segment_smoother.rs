//! The segment-wise smoother (storage + replay + adjoint recursion) against the
//! step-by-step RTS smoother and the batch least-squares solution: same means and
//! variances on a linear-Gaussian problem to 1e-9, whatever the segment length, with
//! refused updates and an adapted process noise in the forward pass, with the
//! covariances before the updates recorded or replayed, and the variances asked at every
//! step, at some or at none.

#![allow(non_snake_case)]

use std::io::Cursor;

use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{
    Adaptation, AdjointForm, ErrorStateFilter, FixedNoise, NoiseStrategy, QAdjust, RtsSmoother,
    SegmentSmoother, SmoothedRow, StepRecorder, Verdict,
};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

/// Refuses every measurement whose NIS is above 4; after update 7 doubles `Q`, after
/// update 25 adds `0.01 I` per second to it.
#[derive(Clone, Debug, Default)]
struct Quirky;

impl NoiseStrategy for Quirky {
    fn adapt<N: nalgebra::DimName, M: nalgebra::DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        nalgebra::DefaultAllocator: estimator_core::FilterAlloc<N, M>,
    {
        if a.nis > 4.0 {
            a.verdict = Verdict::Rejected;
        }
        if a.epoch == 7 {
            a.q = QAdjust::Scale(2.0);
        }
        if a.epoch == 25 {
            a.q = QAdjust::AddRate(nalgebra::OMatrix::<f64, N, N>::identity() * 0.01);
        }
    }
}

struct Case {
    z: Vec<Option<f64>>,
    dt: f64,
    process: LinearProcess<2>,
    H: Matrix1x2<f64>,
    R: Matrix1<f64>,
}

fn case() -> Case {
    let dt = 0.5;
    let z = (0..80)
        .map(|k| {
            let t = (k + 1) as f64 * dt;
            // gaps, and two outliers the strategy refuses
            let v = 0.3 * t + (t * 0.7).sin() * 2.0 + if k == 20 || k == 50 { 30.0 } else { 0.0 };
            (k % 7 != 3 && !(30..40).contains(&k)).then_some(v)
        })
        .collect();
    Case {
        z,
        dt,
        process: LinearProcess {
            F: Matrix2::new(1.0, dt, 0.0, 1.0),
            Q: Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.05,
        },
        H: Matrix1x2::new(1.0, 0.0),
        R: Matrix1::new(0.4),
    }
}

/// The step-by-step smoother's estimates, the segment smoother's rows (in time order) and
/// its number of segments.
type Both = (Vec<estimator_core::Smoothed<Vector2<f64>>>, Vec<SmoothedRow<Vector2<f64>>>, usize);

/// How the forward pass tells the segment smoother.
#[derive(Clone, Copy, Debug)]
struct Recording {
    max_steps: usize,
    /// The covariance before each update is recorded (`before_update`), or replayed.
    priors: bool,
    /// Variances asked every this many steps (0: never).
    variances_every: usize,
    /// Where the recorder says it will not read the covariance (`reads_covariance`), it is
    /// shown a filter whose covariance is garbage.
    garble_unread: bool,
    /// How the backward pass carries `Λ`.
    adjoint: AdjointForm,
}

/// The forward pass feeding both smoothers.
fn both<A: NoiseStrategy>(c: &Case, strategy: A, max_steps: usize) -> Both {
    let how = Recording {
        max_steps,
        priors: true,
        variances_every: 1,
        garble_unread: false,
        adjoint: AdjointForm::PerStep,
    };
    both_recorded(c, strategy, how)
}

fn both_recorded<A: NoiseStrategy>(c: &Case, strategy: A, how: Recording) -> Both {
    both_counted(c, strategy, how).0
}

/// [`both_recorded`], and how many predictions the recorder said it would not read the
/// covariance of.
fn both_counted<A: NoiseStrategy>(c: &Case, strategy: A, how: Recording) -> (Both, usize) {
    let sensor = LinearMeasurement::new(c.H);
    let mut f =
        ErrorStateFilter::new(Vector2::new(0.5, -0.2), Matrix2::new(4.0, 0.5, 0.5, 1.0), strategy)
            .unwrap();
    let mut rts = RtsSmoother::new();
    let mut seg =
        SegmentSmoother::new(Cursor::new(Vec::new()), how.max_steps).with_adjoint_form(how.adjoint);
    let mut unread = 0;
    for (k, z) in c.z.iter().enumerate() {
        if seg.reads_covariance(f.epoch()) {
            seg.before_predict(&f, &(), c.dt, true);
        } else {
            unread += 1;
            let mut shown = f.clone();
            if how.garble_unread {
                shown.set_covariance(Matrix2::new(1e6, -3.0, -3.0, 7e4)).unwrap();
            }
            seg.before_predict(&shown, &(), c.dt, true);
        }
        rts.predict(&mut f, &c.process, &(), c.dt).unwrap();
        if let Some(z) = z {
            if how.priors {
                seg.before_update(&f);
            }
            f.update(&sensor, &Vector1::new(*z), &c.R).unwrap();
        }
        if how.variances_every > 0 && (k + 1) % how.variances_every == 0 {
            seg.mark_variances();
        }
    }
    let segments = {
        seg.finish_recording().unwrap();
        seg.segments()
    };
    let mut chunks = Vec::new();
    seg.smooth(&f, &c.process, |rows| {
        chunks.push(rows.to_vec());
        Ok(())
    })
    .unwrap();
    let rows: Vec<_> = chunks.into_iter().rev().flatten().collect();
    ((rts.smooth(&f).unwrap(), rows, segments), unread)
}

/// `reads_covariance` tells the truth: where it says the next `before_predict` does not
/// read the filter's covariance, a garbled covariance there changes no smoothed row (bit
/// for bit), whatever the segment length, the variance epochs and whether the covariances
/// before the updates are recorded; it says so on a share of the steps (which a caller with
/// a covariance at a lower rate than the state then need not bring to now).
#[test]
fn the_covariance_is_read_only_where_the_recorder_says() {
    let c = case();
    let mut unread_total = 0;
    for max_steps in [3, 100] {
        for priors in [true, false] {
            for variances_every in [0, 4] {
                let adjoint = AdjointForm::PerStep;
                let how =
                    Recording { max_steps, priors, variances_every, garble_unread: false, adjoint };
                let ((_, clean, _), unread) = both_counted(&c, Quirky, how);
                let how = Recording { garble_unread: true, ..how };
                let ((_, garbled, _), again) = both_counted(&c, Quirky, how);
                assert_eq!(unread, again);
                assert_eq!(clean.len(), garbled.len());
                for (a, b) in clean.iter().zip(&garbled) {
                    assert_eq!((a.time, a.x, a.var), (b.time, b.x, b.var), "{how:?}");
                }
                unread_total += unread;
            }
        }
    }
    assert!(unread_total > 40, "{unread_total}");
}

#[test]
fn segments_replayed_from_storage_give_the_step_by_step_smoother() {
    let c = case();
    let forms = [AdjointForm::PerStep, AdjointForm::Accumulated];
    for (max_steps, adjoint) in [1, 3, 1000].into_iter().flat_map(|m| forms.map(|f| (m, f))) {
        for priors in [true, false] {
            for variances_every in [1, 3, 0] {
                let how =
                    Recording { max_steps, priors, variances_every, garble_unread: false, adjoint };
                let (rts, rows, segments) = both_recorded(&c, Quirky, how);
                assert!(segments > 10, "{segments} segments");
                // rts has the start too; rows are the step ends
                assert_eq!(rows.len(), rts.len() - 1);
                for (k, (r, s)) in rows.iter().zip(&rts[1..]).enumerate() {
                    assert!((r.time - s.time).abs() < 1e-12);
                    let asked = variances_every > 0 && (k + 1) % variances_every == 0;
                    assert_eq!(r.var.is_some(), asked, "{how:?}: step {k}");
                    for i in 0..2 {
                        let scale = s.x.abs().max().max(1.0);
                        let dx = (r.x[i] - s.x[i]).abs();
                        assert!(dx < 1e-9 * scale, "{how:?}: {} vs {}", r.x, s.x);
                        let v = s.p[(i, i)];
                        if let Some(var) = &r.var {
                            let dv = (var[i] - v).abs();
                            assert!(
                                dv < 1e-9 * v.max(1e-3),
                                "{how:?} {}: {} vs {v}",
                                r.time,
                                var[i]
                            );
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn the_segments_see_the_adapted_noise_and_the_refusals() {
    // the same data with fixed noise smooths differently: the strategy's Q and refusals
    // reached the replay
    let c = case();
    let (_, quirky, _) = both(&c, Quirky, 1000);
    let (_, fixed, _) = both(&c, FixedNoise, 1000);
    let d = quirky.iter().zip(&fixed).map(|(a, b)| (a.x - b.x).norm()).fold(0.0, f64::max);
    assert!(d > 0.5, "largest difference {d}");
}

/// Storage that takes `room` bytes, then refuses to write.
struct Small {
    inner: Cursor<Vec<u8>>,
    room: usize,
    /// A number written over the stored bytes at this byte offset when they are read back.
    poke: Option<(usize, f64)>,
}

impl std::io::Write for Small {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        if self.inner.get_ref().len() + b.len() > self.room {
            return Err(std::io::Error::new(std::io::ErrorKind::StorageFull, "full"));
        }
        self.inner.write(b)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl std::io::Read for Small {
    fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
        let start = self.inner.position() as usize;
        let n = self.inner.read(b)?;
        if let Some((at, v)) = self.poke {
            for (i, byte) in v.to_le_bytes().into_iter().enumerate() {
                if (start..start + n).contains(&(at + i)) {
                    b[at + i - start] = byte;
                }
            }
        }
        Ok(n)
    }
}

impl std::io::Seek for Small {
    fn seek(&mut self, p: std::io::SeekFrom) -> std::io::Result<u64> {
        self.inner.seek(p)
    }
}

#[test]
fn a_storage_failure_is_reported_by_the_recording_and_the_smoothing() {
    let c = case();
    let sensor = LinearMeasurement::new(c.H);
    let run = |room: usize| {
        let mut f =
            ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), FixedNoise).unwrap();
        let mut seg =
            SegmentSmoother::new(Small { inner: Cursor::new(Vec::new()), room, poke: None }, 4);
        for z in &c.z {
            seg.before_predict(&f, &(), c.dt, true);
            f.predict(&c.process, &(), c.dt).unwrap();
            if let Some(z) = z {
                f.update(&sensor, &Vector1::new(*z), &c.R).unwrap();
            }
        }
        let mut rows = 0;
        let result = seg.smooth(&f, &c.process, |r| {
            rows += r.len();
            Ok(())
        });
        (result, rows)
    };
    let (ok, rows) = run(usize::MAX);
    assert!(ok.is_ok());
    assert_eq!(rows, c.z.len());
    let (full, rows) = run(2000);
    match full {
        Err(estimator_core::SmootherError::Io(e)) => {
            assert_eq!(e.kind(), std::io::ErrorKind::StorageFull)
        }
        other => panic!("expected a storage error, got {other:?}"),
    }
    assert_eq!(rows, 0, "no row from a partial recording");
}

/// A storage that reads back other numbers than were written where the layout has flags
/// (the continuation flag of the first segment, the flags of its first step) or a step
/// count is refused as corrupt, not smoothed into wrong numbers.
#[test]
fn corrupt_flags_in_the_storage_are_refused() {
    let c = case();
    let sensor = LinearMeasurement::new(c.H);
    let run = |poke: Option<(usize, f64)>| {
        let mut f =
            ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), FixedNoise).unwrap();
        let storage = Small { inner: Cursor::new(Vec::new()), room: usize::MAX, poke };
        let mut seg = SegmentSmoother::new(storage, 4);
        for z in &c.z {
            seg.before_predict(&f, &(), c.dt, true);
            f.predict(&c.process, &(), c.dt).unwrap();
            if let Some(z) = z {
                f.update(&sensor, &Vector1::new(*z), &c.R).unwrap();
            }
        }
        seg.smooth(&f, &c.process, |_| Ok(()))
    };
    assert!(run(None).is_ok());
    // a segment: 6 header numbers (steps, time, fading, noise tag, continuation, end), the
    // state (2), the covariance's triangle (3), then per step: flags, end, interval, input
    let (continuation, end, first_flags) = (4 * 8, 5 * 8, (6 + 2 + 3) * 8);
    // flags: out of range, not whole, stored after a step before the first, without the
    // end time and interval on an input that does not carry them, an input form without
    // an input stored after the one before; and a step count (the first number) too large
    // for memory: refused, no overflow
    let cases = [
        (continuation, 0.5),
        (end, 3.0),
        (first_flags, 512.0),
        (first_flags, 1.5),
        (first_flags, 2.0),
        (first_flags, 8.0),
        (first_flags, 16.0),
        (0, 1e300),
    ];
    for (at, value) in cases {
        match run(Some((at, value))) {
            Err(estimator_core::SmootherError::Corrupt(_)) => {}
            other => panic!("{value} at byte {at}: expected a corrupt storage, got {other:?}"),
        }
    }
}

/// A commanded acceleration over an interval, with the interval's end time: an input that
/// carries its step's times ([`Spill::stamp`]) and is stored after the one before in a
/// shorter form when it can ([`Spill::spill_after`]).
#[derive(Clone, Debug, PartialEq)]
struct Push {
    t: f64,
    dt: f64,
    a: f64,
}

/// Forms: the interval is the one before's; the time is the one before's plus the interval.
const SAME_DT: u8 = 1;
const NEXT_T: u8 = 2;

impl estimator_core::Spill for Push {
    const LEN: usize = 3;
    fn spill(&self, out: &mut [f64]) {
        out.copy_from_slice(&[self.t, self.dt, self.a]);
    }
    fn unspill(v: &[f64]) -> Self {
        Push { t: v[0], dt: v[1], a: v[2] }
    }
    fn spill_after(&self, before: &Self, out: &mut [f64]) -> Option<u8> {
        let mut form = 0;
        let mut at = 0;
        if self.dt.to_bits() == before.dt.to_bits() {
            form |= SAME_DT;
        } else {
            out[at] = self.dt;
            at += 1;
        }
        if (before.t + self.dt).to_bits() == self.t.to_bits() {
            form |= NEXT_T;
        } else {
            out[at] = self.t;
            at += 1;
        }
        out[at] = self.a;
        Some(form)
    }
    fn after_len(form: u8) -> usize {
        1 + usize::from(form & SAME_DT == 0) + usize::from(form & NEXT_T == 0)
    }
    fn unspill_after(v: &[f64], form: u8, before: &Self) -> Self {
        let mut at = 0;
        let dt = if form & SAME_DT != 0 {
            before.dt
        } else {
            at += 1;
            v[0]
        };
        let t = if form & NEXT_T != 0 {
            before.t + dt
        } else {
            at += 1;
            v[at - 1]
        };
        Push { t, dt, a: v[at] }
    }
    fn stamp(&self) -> Option<(f64, f64)> {
        Some((self.t, self.dt))
    }
}

/// Position and velocity driven by [`Push`].
struct Pushed;

impl estimator_core::ProcessModel for Pushed {
    type State = Vector2<f64>;
    type Input = Push;
    fn propagate(&self, x: &Vector2<f64>, u: &Push, dt: f64) -> Vector2<f64> {
        Vector2::new(x[0] + dt * x[1] + 0.5 * dt * dt * u.a, x[1] + dt * u.a)
    }
    fn jacobians(
        &self,
        _: &Vector2<f64>,
        _: &Push,
        dt: f64,
    ) -> estimator_core::ProcessJacobians<nalgebra::U2> {
        let q = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.05;
        estimator_core::ProcessJacobians { Phi: Matrix2::new(1.0, dt, 0.0, 1.0), Q: q }
    }
}

/// Inputs stored in their short forms, and steps stored without the times their inputs
/// carry, replay to the step-by-step smoother's estimates; a step whose own times differ
/// from its input's (the filter clock off the stamps) keeps its own.
#[test]
fn inputs_with_their_own_times_and_short_forms_replay_exactly() {
    let sensor = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0));
    let R = Matrix1::new(0.4);
    let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), FixedNoise).unwrap();
    let mut rts = RtsSmoother::new();
    let mut seg = SegmentSmoother::new(Cursor::new(Vec::new()), 16);
    let mut t = 0.0;
    let mut times = Vec::new();
    for k in 0..120 {
        // a steady interval with a few irregular ones, and a time stamp off the sum
        let dt = if k % 17 == 5 { 0.37 } else { 0.25 };
        t = if k % 23 == 11 { t + dt + 1e-9 } else { t + dt };
        let u = Push { t, dt, a: (k as f64 * 0.3).sin() };
        // the filter's clock on the stamps, except on a few steps
        let start = if k % 31 == 7 { t - dt + 1e-7 } else { t - dt };
        f.set_time(start);
        seg.before_predict(&f, &u, dt, true);
        rts.predict(&mut f, &Pushed, &u, dt).unwrap();
        times.push(start + dt);
        if k % 4 == 3 {
            seg.before_update(&f);
            f.update(&sensor, &Vector1::new((t * 0.4).sin() * 3.0), &R).unwrap();
        }
        if k % 5 == 0 {
            seg.mark_variances();
        }
    }
    seg.finish_recording().unwrap();
    // a segment's head (at most 14 numbers), its first step in full (at most 6), every
    // other step in at most 3 numbers (flags, input in a short form): 6 in full
    let bound = 8 * (seg.segments() * (14 + 6) + 3 * 120);
    assert!(seg.stored_bytes() as usize <= bound, "{} bytes stored", seg.stored_bytes());
    let mut chunks = Vec::new();
    seg.smooth(&f, &Pushed, |rows| {
        chunks.push(rows.to_vec());
        Ok(())
    })
    .unwrap();
    let rows: Vec<_> = chunks.into_iter().rev().flatten().collect();
    let expected = rts.smooth(&f).unwrap();
    assert_eq!(rows.len(), times.len());
    for (k, (r, s)) in rows.iter().zip(&expected[1..]).enumerate() {
        assert_eq!(r.time.to_bits(), times[k].to_bits(), "step {k}");
        let scale = s.x.abs().max().max(1.0);
        assert!((r.x - s.x).abs().max() < 1e-9 * scale, "step {k}: {} vs {}", r.x, s.x);
        if let Some(var) = &r.var {
            for i in 0..2 {
                assert!((var[i] - s.p[(i, i)]).abs() < 1e-9 * s.p[(i, i)].max(1e-3));
            }
        }
    }
}

/// A long forward pass of the linear case (30,000 steps, an update every second step)
/// recorded into `seg` and smoothed on one thread or two: the rows in time order and the
/// bytes recorded.
fn long_run<S: std::io::Read + std::io::Write + std::io::Seek + Send>(
    seg: SegmentSmoother<Vector2<f64>, (), S>,
    threaded: bool,
) -> (Vec<SmoothedRow<Vector2<f64>>>, u64) {
    let (result, stored) = long_run_into(seg, threaded, usize::MAX);
    (result.unwrap(), stored)
}

/// The smoothed rows of a run, or why its backward pass failed.
type Smoothed = Result<Vec<SmoothedRow<Vector2<f64>>>, estimator_core::SmootherError>;

/// [`long_run`] with a sink that fails at its `fail_at`-th call.
fn long_run_into<S: std::io::Read + std::io::Write + std::io::Seek + Send>(
    mut seg: SegmentSmoother<Vector2<f64>, (), S>,
    threaded: bool,
    fail_at: usize,
) -> (Smoothed, u64) {
    let dt = 0.01;
    let process = LinearProcess {
        F: Matrix2::new(1.0, dt, 0.0, 1.0),
        Q: Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.05,
    };
    let sensor = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0));
    let (P0, R) = (Matrix2::new(4.0, 0.5, 0.5, 1.0), Matrix1::new(0.4));
    let mut f = ErrorStateFilter::new(Vector2::new(0.5, -0.2), P0, FixedNoise).unwrap();
    for k in 0..30_000 {
        seg.before_predict(&f, &(), dt, true);
        f.predict(&process, &(), dt).unwrap();
        if k % 2 == 1 {
            seg.before_update(&f);
            let t = (k + 1) as f64 * dt;
            f.update(&sensor, &Vector1::new(0.3 * t + (t * 0.7).sin()), &R).unwrap();
        }
        if k % 10 == 9 {
            seg.mark_variances();
        }
    }
    let mut chunks = Vec::new();
    let sink = |rows: &[SmoothedRow<Vector2<f64>>]| {
        if chunks.len() == fail_at {
            // (time for a threaded replay to get as far ahead as it goes, and wait)
            std::thread::sleep(std::time::Duration::from_millis(50));
            return Err(std::io::Error::other("the sink fails"));
        }
        chunks.push(rows.to_vec());
        Ok(())
    };
    seg.finish_recording().unwrap();
    let stored = seg.stored_bytes();
    let done = if threaded {
        seg.smooth_threaded(&f, &process, sink)
    } else {
        seg.smooth(&f, &process, sink)
    };
    (done.map(|()| chunks.into_iter().rev().flatten().collect()), stored)
}

/// A sink that fails stops the threaded backward pass with its error, early and late in
/// the pass: the replay, which waits whenever it is far enough ahead, is released (the
/// pass is run on a thread of its own and must end within a minute).
#[test]
fn a_failing_sink_stops_the_threaded_pass() {
    for fail_at in [0, 1, 500, 14_990] {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let seg = SegmentSmoother::new(Cursor::new(Vec::new()), 64);
            let _ = tx.send(long_run_into(seg, true, fail_at).0.map(|rows| rows.len()));
        });
        let done = rx.recv_timeout(std::time::Duration::from_secs(60));
        match done {
            Ok(Err(estimator_core::SmootherError::Io(e))) => {
                assert_eq!(e.to_string(), "the sink fails", "failing at call {fail_at}")
            }
            other => panic!("failing at call {fail_at}: {other:?}"),
        }
    }
}

/// A file's storage is read back about a megabyte at a time and cut behind each read:
/// across the windows of a run several megabytes long (segments straddle their edges)
/// the rows are those of the same run kept in memory, bit for bit, on one thread and on
/// two, and the file is left shorter than it was written.
#[test]
fn a_long_run_on_file_is_read_back_window_by_window_and_cut_behind() {
    let (expected, stored) = long_run(SegmentSmoother::new(Cursor::new(Vec::new()), 64), false);
    assert!(stored > 2 << 20, "{stored} bytes: too few windows");
    assert_eq!(expected.len(), 30_000);
    for threaded in [false, true] {
        let path = std::env::temp_dir()
            .join(format!("segment-smoother-{}-{threaded}.tmp", std::process::id()));
        let (rows, on_file) = long_run(SegmentSmoother::on_file(&path, 64).unwrap(), threaded);
        let left = std::fs::metadata(&path).unwrap().len();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(on_file, stored);
        assert!(left <= 1 << 20, "{left} of {stored} bytes left in the file");
        assert_eq!(rows.len(), expected.len());
        for (r, e) in rows.iter().zip(&expected) {
            assert_eq!(r.time.to_bits(), e.time.to_bits());
            assert_eq!(r.x, e.x, "threaded {threaded}: at {}", r.time);
            assert_eq!(r.var, e.var, "threaded {threaded}: at {}", r.time);
        }
    }
}

/// A constant velocity whose inputs fold (there are none: a stretch's step is the model's
/// over the stretch's interval), for a covariance propagated once per stretch of steps.
struct Folding;

impl estimator_core::ProcessModel for Folding {
    type State = Vector2<f64>;
    type Input = ();
    fn propagate(&self, x: &Vector2<f64>, _: &(), dt: f64) -> Vector2<f64> {
        Vector2::new(x[0] + dt * x[1], x[1])
    }
    fn jacobians(
        &self,
        _: &Vector2<f64>,
        _: &(),
        dt: f64,
    ) -> estimator_core::ProcessJacobians<nalgebra::U2> {
        estimator_core::ProcessJacobians {
            Phi: Matrix2::new(1.0, dt, 0.0, 1.0),
            Q: Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.05,
        }
    }
    fn fold_input(&self, sum: &mut Option<()>, _: &()) -> bool {
        *sum = Some(());
        true
    }
}

/// The forward pass of [`case`] with the covariance propagated once per `stretch` steps
/// (and before each update, and wherever the recorder reads it), told to a segment
/// smoother (`covariance_continues` inside a stretch); beside it a filter that takes one
/// step per stretch, told to the step-by-step RTS smoother. Returns the segment smoother's
/// rows, the RTS smoother's estimates and, per step, the forward pass's nominal state after
/// it and the state its stretch started from (with the time there), and the bytes stored.
#[allow(clippy::type_complexity)]
fn stretched(
    c: &Case,
    stretch: usize,
    max_steps: usize,
    adjoint: AdjointForm,
    replayed_priors: bool,
) -> (
    Vec<SmoothedRow<Vector2<f64>>>,
    Vec<estimator_core::Smoothed<Vector2<f64>>>,
    Vec<(Vector2<f64>, f64, Vector2<f64>)>,
    u64,
) {
    let sensor = LinearMeasurement::new(c.H);
    let (x0, p0) = (Vector2::new(0.5, -0.2), Matrix2::new(4.0, 0.5, 0.5, 1.0));
    let mut f = ErrorStateFilter::new(x0, p0, Quirky).unwrap();
    let mut g = ErrorStateFilter::new(x0, p0, Quirky).unwrap();
    let mut rts = RtsSmoother::new();
    let mut seg = SegmentSmoother::new(Cursor::new(Vec::new()), max_steps)
        .with_adjoint_form(adjoint)
        .with_replayed_priors(replayed_priors);
    // the open stretch: the state and time it started from, its interval and steps
    let mut pending: Option<(Vector2<f64>, f64, f64, u32)> = None;
    let settle = |f: &mut ErrorStateFilter<_, Quirky>,
                  g: &mut ErrorStateFilter<_, Quirky>,
                  rts: &mut RtsSmoother<Vector2<f64>>,
                  pending: &mut Option<(Vector2<f64>, f64, f64, u32)>| {
        if let Some((x, _, dt, n)) = pending.take() {
            f.predict_covariance(&Folding, &x, &(), dt, n).unwrap();
            rts.predict(g, &Folding, &(), dt).unwrap();
        }
    };
    let mut nominal = Vec::new();
    for (k, z) in c.z.iter().enumerate() {
        if seg.reads_covariance(f.epoch()) {
            settle(&mut f, &mut g, &mut rts, &mut pending);
        }
        seg.before_predict(&f, &(), c.dt, true);
        let open = pending.get_or_insert((*f.state(), f.time(), 0.0, 0));
        open.2 += c.dt;
        open.3 += 1;
        let (start, start_time, full) = (open.0, open.1, open.3 as usize == stretch);
        if !full {
            seg.covariance_continues();
        }
        f.predict_state(&Folding, &(), c.dt).unwrap();
        nominal.push((*f.state(), start_time, start));
        if full {
            settle(&mut f, &mut g, &mut rts, &mut pending);
        }
        if let Some(z) = z {
            settle(&mut f, &mut g, &mut rts, &mut pending);
            seg.before_update(&f);
            f.update(&sensor, &Vector1::new(*z), &c.R).unwrap();
            g.update(&sensor, &Vector1::new(*z), &c.R).unwrap();
        }
        if k % 10 == 9 {
            // (the segment ends here, so the stretch does: the next step reads the
            // covariance)
            seg.mark_variances();
        }
    }
    settle(&mut f, &mut g, &mut rts, &mut pending);
    seg.finish_recording().unwrap();
    let bytes = seg.stored_bytes();
    let mut chunks = Vec::new();
    seg.smooth(&f, &Folding, |rows| {
        chunks.push(rows.to_vec());
        Ok(())
    })
    .unwrap();
    let rows: Vec<_> = chunks.into_iter().rev().flatten().collect();
    (rows, rts.smooth(&g).unwrap(), nominal, bytes)
}

/// A forward pass that propagated the covariance once per stretch of steps is smoothed
/// with the same stretches: at each stretch's end the segment smoother gives the RTS
/// smoother of a filter that took one step per stretch (states and variances to 1e-9),
/// and inside a stretch the nominal state plus the smoothed correction interpolated in
/// time between the stretch's ends; whatever the segment length and the adjoint's form,
/// with refusals and an adapted process noise.
#[test]
fn stretches_of_steps_are_smoothed_as_the_forward_pass_took_them() {
    let c = sparse_case();
    let forms = [AdjointForm::PerStep, AdjointForm::Accumulated];
    for (stretch, max_steps, adjoint) in [(3, 1000), (3, 2), (2, 7), (5, 1000)]
        .into_iter()
        .flat_map(|(s, m)| forms.map(|f| (s, m, f)))
    {
        let (rows, rts, nominal, _) = stretched(&c, stretch, max_steps, adjoint, false);
        assert_eq!(rows.len(), c.z.len());
        let at = |t: f64| rts.iter().find(|s| (s.time - t).abs() < 1e-9);
        let (mut ends, mut inside, mut variances) = (0, 0, 0);
        for (r, (x_nominal, start_time, x_start)) in rows.iter().zip(&nominal) {
            let scale = r.x.abs().max().max(1.0);
            let expected = match at(r.time) {
                Some(s) => {
                    ends += 1;
                    if let Some(var) = &r.var {
                        variances += 1;
                        for i in 0..2 {
                            let v = s.p[(i, i)];
                            assert!((var[i] - v).abs() < 1e-9 * v.max(1e-3), "{var} vs {v}");
                        }
                    }
                    s.x
                }
                None => {
                    // δ at the stretch's ends, and the time between
                    inside += 1;
                    let a = at(*start_time).expect("a stretch starts at an RTS epoch");
                    let (end_row, end_nominal) = rows
                        .iter()
                        .zip(&nominal)
                        .find(|(e, _)| e.time > r.time && at(e.time).is_some())
                        .expect("the stretch ends");
                    let b = at(end_row.time).unwrap();
                    let (da, db) = (a.x - x_start, b.x - end_nominal.0);
                    let w = (r.time - start_time) / (end_row.time - start_time);
                    x_nominal + da + (db - da) * w
                }
            };
            assert!((r.x - expected).norm() < 1e-9 * scale, "{}: {} vs {expected}", r.time, r.x);
        }
        assert!(ends > 20 && inside > 20 && variances > 5, "{ends} {inside} {variances}");
    }
}

/// [`case`] with an update every fourth step only (an update ends a stretch), none for a
/// while in the middle.
fn sparse_case() -> Case {
    let mut c = case();
    for (k, z) in c.z.iter_mut().enumerate() {
        if k % 4 != 3 {
            *z = None;
        }
    }
    c
}

/// A smoother that stores no covariance before the updates (`with_replayed_priors`)
/// rebuilds it from the update before as the forward pass propagated it, step by step or
/// over its stretches: every smoothed row, state and variances, is the stored priors' bit
/// for bit, whatever the stretch, the segment length and the adjoint's form.
#[test]
fn replayed_priors_give_the_stored_priors_rows_bit_for_bit() {
    let c = sparse_case();
    let forms = [AdjointForm::PerStep, AdjointForm::Accumulated];
    for (stretch, max_steps, adjoint) in [(1, 1000), (3, 1000), (3, 2), (5, 7)]
        .into_iter()
        .flat_map(|(s, m)| forms.map(|f| (s, m, f)))
    {
        let (stored, .., stored_bytes) = stretched(&c, stretch, max_steps, adjoint, false);
        let (replayed, .., replayed_bytes) = stretched(&c, stretch, max_steps, adjoint, true);
        // (one covariance of three numbers less per update)
        assert!(replayed_bytes < stored_bytes, "{replayed_bytes} of {stored_bytes} bytes");
        assert_eq!(stored.len(), c.z.len());
        assert_eq!(replayed.len(), stored.len());
        let bits = |r: &SmoothedRow<Vector2<f64>>| {
            let var = r.var.map(|v| [v[0].to_bits(), v[1].to_bits()]);
            (r.time.to_bits(), [r.x[0].to_bits(), r.x[1].to_bits()], var)
        };
        for (a, b) in stored.iter().zip(&replayed) {
            assert_eq!(bits(a), bits(b), "stretch {stretch}, {max_steps} steps, {adjoint:?}");
        }
        assert!(stored.iter().filter(|r| r.var.is_some()).count() > 5);
    }
}
