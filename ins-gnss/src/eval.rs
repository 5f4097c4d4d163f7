//! Evaluation of a navigation result against a truth (or reference) file: RMS, maximum
//! and mean of the NED position errors, horizontal, 3-D, velocity, roll, pitch, yaw, over
//! the whole run after a skip and per time window (e.g. GNSS outages). Streaming: the
//! truth is interpolated linearly between its two records around each result epoch.

use std::path::Path;

use nalgebra::Vector3;
use serde::Serialize;

use crate::earth::geodetic_to_local_ned;
use crate::io::{LineError, NavReader, NavRecord};
use manifolds::wrap_angle;

/// Running statistics of one error component.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Stat {
    /// Root mean square.
    pub rms: f64,
    /// Maximum absolute value.
    pub max: f64,
    /// Mean (signed).
    pub mean: f64,
    #[serde(skip)]
    sum: f64,
    #[serde(skip)]
    sum_sq: f64,
    #[serde(skip)]
    n: usize,
}

impl Stat {
    fn push(&mut self, v: f64) {
        self.sum += v;
        self.sum_sq += v * v;
        self.n += 1;
        self.max = self.max.max(v.abs());
        self.rms = (self.sum_sq / self.n as f64).sqrt();
        self.mean = self.sum / self.n as f64;
    }

    /// Number of samples.
    pub fn count(&self) -> usize {
        self.n
    }
}

/// All statistics of one time span.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Stats {
    /// Span label.
    pub label: String,
    /// Epochs compared.
    pub epochs: usize,
    /// North, east, down position error, m.
    pub north: Stat,
    /// East.
    pub east: Stat,
    /// Down.
    pub down: Stat,
    /// Horizontal, m.
    pub horizontal: Stat,
    /// 3-D position, m.
    pub position_3d: Stat,
    /// Velocity N, E, D and 3-D, m/s.
    pub vel_north: Stat,
    /// Velocity E.
    pub vel_east: Stat,
    /// Velocity D.
    pub vel_down: Stat,
    /// Velocity 3-D.
    pub velocity_3d: Stat,
    /// Roll, deg.
    pub roll: Stat,
    /// Pitch, deg.
    pub pitch: Stat,
    /// Yaw, deg (wrapped to ±180°).
    pub yaw: Stat,
}

impl Stats {
    fn new(label: String) -> Self {
        Self { label, ..Default::default() }
    }

    fn push(&mut self, dp: &Vector3<f64>, dv: &Vector3<f64>, da: &Vector3<f64>) {
        self.epochs += 1;
        self.north.push(dp.x);
        self.east.push(dp.y);
        self.down.push(dp.z);
        self.horizontal.push((dp.x * dp.x + dp.y * dp.y).sqrt());
        self.position_3d.push(dp.norm());
        self.vel_north.push(dv.x);
        self.vel_east.push(dv.y);
        self.vel_down.push(dv.z);
        self.velocity_3d.push(dv.norm());
        self.roll.push(da.x);
        self.pitch.push(da.y);
        self.yaw.push(da.z);
    }
}

/// The evaluation result.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Evaluation {
    /// After the skip, whole run.
    pub overall: Stats,
    /// Per requested window.
    pub windows: Vec<Stats>,
    /// Result epochs without truth around them (outside the truth's span).
    pub unmatched: usize,
}

fn interpolate(a: &NavRecord, b: &NavRecord, t: f64) -> NavRecord {
    let u = if b.t > a.t { ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0) } else { 0.0 };
    let lerp = |x: f64, y: f64| x + (y - x) * u;
    let att = Vector3::new(
        a.att.x + wrap_angle(b.att.x - a.att.x) * u,
        a.att.y + wrap_angle(b.att.y - a.att.y) * u,
        a.att.z + wrap_angle(b.att.z - a.att.z) * u,
    );
    NavRecord {
        week: a.week,
        t,
        pos: crate::position::GeoPos {
            lat: lerp(a.pos.lat, b.pos.lat),
            lon: lerp(a.pos.lon, b.pos.lon),
            h: lerp(a.pos.h, b.pos.h),
        },
        vel: a.vel + (b.vel - a.vel) * u,
        att,
    }
}

/// Errors `(NED position m, velocity m/s, attitude deg)` of `r` against truth `t`.
pub fn errors(r: &NavRecord, t: &NavRecord) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let dp = geodetic_to_local_ned(t.pos.tuple(), r.pos.tuple());
    let d = 180.0 / core::f64::consts::PI;
    let da = Vector3::new(
        wrap_angle(r.att.x - t.att.x) * d,
        wrap_angle(r.att.y - t.att.y) * d,
        wrap_angle(r.att.z - t.att.z) * d,
    );
    (dp, r.vel - t.vel, da)
}

/// Evaluate `result` against `truth`, skipping the first `skip` seconds of the result,
/// with extra statistics inside each `(t0, t1)` window (absolute times).
pub fn evaluate(
    result: &Path,
    truth: &Path,
    skip: f64,
    windows: &[(f64, f64)],
) -> Result<Evaluation, LineError> {
    let mut res = NavReader::open(result)?;
    let mut tru = NavReader::open(truth)?;
    let mut ev = Evaluation {
        overall: Stats::new(format!("after {skip} s")),
        windows: windows.iter().map(|(a, b)| Stats::new(format!("{a}–{b}"))).collect(),
        unmatched: 0,
    };
    let (mut t0, mut t1) = (tru.next_record()?, tru.next_record()?);
    let mut first_t = None;
    while let Some(r) = res.next_record()? {
        let start = *first_t.get_or_insert(r.t);
        // Advance the truth bracket until t1 ≥ r.t.
        while let (Some(_), Some(b)) = (&t0, &t1) {
            if b.t >= r.t {
                break;
            }
            t0 = t1;
            t1 = tru.next_record()?;
        }
        let truth_here = match (&t0, &t1) {
            (Some(a), Some(b)) if a.t <= r.t + 1e-9 && b.t >= r.t - 1e-9 => interpolate(a, b, r.t),
            (Some(a), _) if (a.t - r.t).abs() < 1e-6 => *a,
            _ => {
                ev.unmatched += 1;
                continue;
            }
        };
        let (dp, dv, da) = errors(&r, &truth_here);
        if r.t - start >= skip {
            ev.overall.push(&dp, &dv, &da);
        }
        for (w, (a, b)) in ev.windows.iter_mut().zip(windows) {
            if r.t >= *a && r.t <= *b {
                w.push(&dp, &dv, &da);
            }
        }
    }
    Ok(ev)
}
