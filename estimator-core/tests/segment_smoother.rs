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
    Adaptation, ErrorStateFilter, FixedNoise, NoiseStrategy, QAdjust, RtsSmoother, SegmentSmoother,
    SmoothedRow, StepRecorder, Verdict,
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
}

/// The forward pass feeding both smoothers.
fn both<A: NoiseStrategy>(c: &Case, strategy: A, max_steps: usize) -> Both {
    let how = Recording { max_steps, priors: true, variances_every: 1 };
    both_recorded(c, strategy, how)
}

fn both_recorded<A: NoiseStrategy>(c: &Case, strategy: A, how: Recording) -> Both {
    let sensor = LinearMeasurement::new(c.H);
    let mut f =
        ErrorStateFilter::new(Vector2::new(0.5, -0.2), Matrix2::new(4.0, 0.5, 0.5, 1.0), strategy)
            .unwrap();
    let mut rts = RtsSmoother::new();
    let mut seg = SegmentSmoother::new(Cursor::new(Vec::new()), how.max_steps);
    for (k, z) in c.z.iter().enumerate() {
        seg.before_predict(&f, &(), c.dt, true);
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
    (rts.smooth(&f).unwrap(), rows, segments)
}

#[test]
fn segments_replayed_from_storage_give_the_step_by_step_smoother() {
    let c = case();
    for max_steps in [1, 3, 1000] {
        for priors in [true, false] {
            for variances_every in [1, 3, 0] {
                let how = Recording { max_steps, priors, variances_every };
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
    // state (2), the covariance's triangle (3), then per step: end, interval, flags, input
    let (continuation, end, first_flags) = (4 * 8, 5 * 8, (6 + 2 + 3 + 2) * 8);
    // and a step count (the first number) too large for memory: refused, no overflow
    let cases = [
        (continuation, 0.5),
        (end, 3.0),
        (first_flags, 8.0),
        (first_flags, 1.5),
        (first_flags, 2.0),
        (0, 1e300),
    ];
    for (at, value) in cases {
        match run(Some((at, value))) {
            Err(estimator_core::SmootherError::Corrupt(_)) => {}
            other => panic!("{value} at byte {at}: expected a corrupt storage, got {other:?}"),
        }
    }
}
