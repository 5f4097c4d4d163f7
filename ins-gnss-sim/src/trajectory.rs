//! [`Trajectory`] and what serves it (the documentation is on the item).

use core::fmt;

use manifolds::So3;
use nalgebra::Vector3;

use ins_gnss_core::earth::{earth_rate_ned, gravity_ned, radii, transport_rate};
use ins_gnss_core::GeoPos;

/// One piece of motion; rates are constant within it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Length, s (rounded to the 1 ms grid).
    pub duration: f64,
    /// Along-track acceleration, m/s².
    pub accel: f64,
    /// Yaw rate, rad/s.
    pub yaw_rate: f64,
    /// Pitch rate, rad/s.
    pub pitch_rate: f64,
}

impl Segment {
    /// Constant velocity.
    pub fn straight(duration: f64) -> Self {
        Self { duration, accel: 0.0, yaw_rate: 0.0, pitch_rate: 0.0 }
    }
    /// Constant speed, constant yaw rate (rad/s; positive turns right in NED).
    pub fn turn(duration: f64, yaw_rate: f64) -> Self {
        Self { duration, accel: 0.0, yaw_rate, pitch_rate: 0.0 }
    }
    /// Speed up at `accel` m/s².
    pub fn accelerate(duration: f64, accel: f64) -> Self {
        Self { duration, accel, yaw_rate: 0.0, pitch_rate: 0.0 }
    }
    /// Slow down at `decel` m/s² (positive number).
    pub fn decelerate(duration: f64, decel: f64) -> Self {
        Self { duration, accel: -decel, yaw_rate: 0.0, pitch_rate: 0.0 }
    }
    /// Change pitch at `pitch_rate` rad/s (climb when positive).
    pub fn climb(duration: f64, pitch_rate: f64) -> Self {
        Self { duration, accel: 0.0, yaw_rate: 0.0, pitch_rate }
    }
    /// Stand still (the speed must be zero when the segment starts).
    pub fn stop(duration: f64) -> Self {
        Self::straight(duration)
    }
}

/// The state of motion at the start of a trajectory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Start {
    /// Time, s.
    pub t: f64,
    /// Position.
    pub pos: GeoPos,
    /// Speed, m/s.
    pub speed: f64,
    /// Yaw, rad.
    pub yaw: f64,
    /// Pitch, rad.
    pub pitch: f64,
}

/// A trajectory that cannot be built.
#[derive(Clone, Debug, PartialEq)]
pub enum TrajectoryError {
    /// The speed went negative inside a segment.
    NegativeSpeed {
        /// Index of the segment.
        segment: usize,
    },
    /// A segment has a non-positive or non-finite duration or a non-finite rate.
    BadSegment {
        /// Index of the segment.
        segment: usize,
    },
    /// No segment at all.
    NoSegments,
    /// The start is not finite, or not on the Earth (|latitude| ≥ 89.9°, height outside
    /// −1 km…+100 km, speed negative or above 2 km/s).
    BadStart,
}

impl fmt::Display for TrajectoryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TrajectoryError::NegativeSpeed { segment } => {
                write!(
                    f,
                    "segment {segment}: the speed would become negative (decelerate less or for shorter)"
                )
            }
            TrajectoryError::NoSegments => write!(f, "the trajectory has no segment"),
            TrajectoryError::BadStart => write!(
                f,
                "the start is not finite or not physical (|latitude| < 89.9°, height within \
                 −1 km…+100 km, speed within 0…2 km/s)"
            ),
            TrajectoryError::BadSegment { segment } => {
                write!(f, "segment {segment}: duration must be positive and every rate finite")
            }
        }
    }
}

impl std::error::Error for TrajectoryError {}

/// The truth at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kinematics {
    /// Time, s.
    pub t: f64,
    /// Attitude `R_nb`.
    pub att: So3,
    /// NED velocity, m/s.
    pub vel: Vector3<f64>,
    /// Position.
    pub pos: GeoPos,
    /// `ω_ib^b`, rad/s.
    pub w_ib_b: Vector3<f64>,
    /// `f^b`, m/s².
    pub f_b: Vector3<f64>,
}

impl Kinematics {
    /// The kinematics of an IMU mounted at the same point with attitude `r_vb` relative to
    /// this (vehicle) frame: `R_nb = R_nv R_vb`, `ω_ib^b = R_vbᵀ ω`, `f^b = R_vbᵀ f`.
    pub fn mounted(&self, r_vb: &So3) -> Kinematics {
        let back = r_vb.inverse();
        Kinematics {
            att: &self.att * r_vb,
            w_ib_b: back.rotate(&self.w_ib_b),
            f_b: back.rotate(&self.f_b),
            ..*self
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct SegState {
    t0: f64,
    t1: f64,
    s0: f64,
    yaw0: f64,
    pitch0: f64,
    seg: Segment,
}

/// Grid step of the position integration, s.
pub const GRID: f64 = 1e-3;

/// Grid nodes per stored checkpoint: the positions between checkpoints are integrated
/// again on demand (the same RK4 steps, so bit for bit the same), which keeps a 24 h
/// trajectory at 2 MB instead of 2 GB.
const CHUNK: usize = 1024;

/// A trajectory with exact kinematics at any time in `[start, end]`.
///
/// Trajectories from segments with exact kinematics.
///
/// Within a segment the speed `s`, yaw `ψ` and pitch `θ` change linearly (constant
/// acceleration, yaw rate and pitch rate; roll is zero, no side-slip), so velocity,
/// attitude, body rates and specific force are closed-form:
///
/// ```text
/// v^n   = s [cos θ cos ψ, cos θ sin ψ, −sin θ]          R_nb = Rz(ψ) Ry(θ)
/// ω_nb^b = [−ψ̇ sin θ, θ̇, ψ̇ cos θ]                      ω_ib^b = ω_nb^b + R_nbᵀ (ω_ie^n + ω_en^n)
/// f^b   = R_nbᵀ (v̇^n + (2ω_ie^n + ω_en^n) × v^n − g^n)
/// ```
///
/// Position integrates `(φ̇, λ̇, ḣ) = (v_N/(R_M+h), v_E/((R_N+h) cos φ), −v_D)` with RK4
/// on a 1 ms grid whose nodes include every segment boundary (RK4 never straddles a
/// discontinuity of the acceleration), and is interpolated between nodes by cubic
/// Hermite polynomials using the exact velocity.
#[derive(Clone, Debug)]
pub struct Trajectory {
    segs: Vec<SegState>,
    /// Position at every `CHUNK`-th grid node (`t = t_start + k·CHUNK·GRID`).
    checkpoints: Vec<GeoPos>,
    /// Number of grid nodes.
    n_nodes: usize,
    t_start: f64,
    /// Identifies the nodes in the per-thread cache (clones share it: same nodes).
    id: u64,
    /// The exact IMU last integrated from this trajectory, with its rate's bits
    /// ([`Trajectory::exact_imu`]; clones share it).
    pub(crate) exact: KeptExact,
}

/// The exact IMU a trajectory keeps: its rate's bits and the samples.
pub(crate) type KeptExact =
    std::sync::Arc<std::sync::Mutex<Option<(u64, std::sync::Arc<crate::ExactImu>)>>>;

/// Identities of trajectories for the node cache.
static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

thread_local! {
    /// The nodes of the chunk last used on this thread: (trajectory id, chunk, nodes
    /// `chunk·CHUNK ..= chunk·CHUNK + CHUNK`). Queries run forward in time, so one chunk
    /// serves a thousand queries.
    static NODES: core::cell::RefCell<(u64, usize, Vec<GeoPos>)> =
        const { core::cell::RefCell::new((u64::MAX, 0, Vec::new())) };
}

/// One RK4 step on the grid from node `i` at `p` (the velocity of cell `i` comes from the
/// segment containing it).
fn rk4_step(segs: &[SegState], t_start: f64, i: usize, p: &GeoPos) -> GeoPos {
    let ta = t_start + i as f64 * GRID;
    let seg = segment_at(segs, ta + 0.5 * GRID);
    let f = |t: f64, p: &GeoPos| -> Vector3<f64> { geodetic_rate(p, &seg_velocity(seg, t)) };
    let add = |p: &GeoPos, k: &Vector3<f64>, c: f64| GeoPos {
        lat: p.lat + k.x * c,
        lon: p.lon + k.y * c,
        h: p.h + k.z * c,
    };
    let k1 = f(ta, p);
    let k2 = f(ta + GRID / 2.0, &add(p, &k1, GRID / 2.0));
    let k3 = f(ta + GRID / 2.0, &add(p, &k2, GRID / 2.0));
    let k4 = f(ta + GRID, &add(p, &k3, GRID));
    add(p, &(k1 + k2 * 2.0 + k3 * 2.0 + k4), GRID / 6.0)
}

impl Trajectory {
    /// Build from a start and segments (durations rounded to the 1 ms grid).
    pub fn new(start: Start, segments: &[Segment]) -> Result<Self, TrajectoryError> {
        if segments.is_empty() {
            return Err(TrajectoryError::NoSegments);
        }
        let finite = [
            start.t,
            start.pos.lat,
            start.pos.lon,
            start.pos.h,
            start.speed,
            start.yaw,
            start.pitch,
        ]
        .iter()
        .all(|v| v.is_finite());
        if !finite
            || start.pos.lat.abs() >= 89.9_f64.to_radians()
            || !(-1_000.0..=100_000.0).contains(&start.pos.h)
            || !(0.0..=2_000.0).contains(&start.speed)
        {
            return Err(TrajectoryError::BadStart);
        }
        let mut segs = Vec::with_capacity(segments.len());
        let (mut t, mut s, mut yaw, mut pitch) = (start.t, start.speed, start.yaw, start.pitch);
        let mut steps_total = 0usize;
        for (i, seg) in segments.iter().enumerate() {
            let ok = seg.duration.is_finite()
                && seg.duration > 0.0
                && seg.accel.is_finite()
                && seg.yaw_rate.is_finite()
                && seg.pitch_rate.is_finite();
            if !ok {
                return Err(TrajectoryError::BadSegment { segment: i });
            }
            let steps = (seg.duration / GRID).round().max(1.0) as usize;
            let d = steps as f64 * GRID;
            let s1 = s + seg.accel * d;
            if s1 < -1e-9 || s < -1e-9 {
                return Err(TrajectoryError::NegativeSpeed { segment: i });
            }
            let t0 = start.t + steps_total as f64 * GRID;
            steps_total += steps;
            let t1 = start.t + steps_total as f64 * GRID;
            segs.push(SegState {
                t0,
                t1,
                s0: s,
                yaw0: yaw,
                pitch0: pitch,
                seg: Segment { duration: d, ..*seg },
            });
            t = t1;
            s = s1.max(0.0);
            yaw += seg.yaw_rate * d;
            pitch += seg.pitch_rate * d;
        }
        let _ = t;
        // RK4 on the grid, keeping every CHUNK-th node.
        let mut checkpoints = Vec::with_capacity(steps_total / CHUNK + 2);
        let mut p = start.pos;
        for i in 0..steps_total {
            if i.is_multiple_of(CHUNK) {
                checkpoints.push(p);
            }
            p = rk4_step(&segs, start.t, i, &p);
        }
        if steps_total.is_multiple_of(CHUNK) {
            checkpoints.push(p);
        }
        let id = NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Ok(Self {
            segs,
            checkpoints,
            n_nodes: steps_total + 1,
            t_start: start.t,
            id,
            exact: Default::default(),
        })
    }

    /// Grid nodes `i` and `i + 1`, from this thread's cache of the chunk holding them.
    fn node_pair(&self, i: usize) -> (GeoPos, GeoPos) {
        let chunk = i / CHUNK;
        NODES.with(|cache| {
            let mut cache = cache.borrow_mut();
            if cache.0 != self.id || cache.1 != chunk || cache.2.is_empty() {
                let first = chunk * CHUNK;
                let last = (first + CHUNK).min(self.n_nodes - 1);
                let nodes = &mut cache.2;
                nodes.clear();
                let mut p = self.checkpoints[chunk];
                nodes.push(p);
                for k in first..last {
                    p = rk4_step(&self.segs, self.t_start, k, &p);
                    nodes.push(p);
                }
                cache.0 = self.id;
                cache.1 = chunk;
            }
            let j = i - chunk * CHUNK;
            (cache.2[j], cache.2[(j + 1).min(cache.2.len() - 1)])
        })
    }

    /// Start time, s.
    pub fn start_time(&self) -> f64 {
        self.t_start
    }

    /// End time, s.
    pub fn end_time(&self) -> f64 {
        self.t_start + (self.n_nodes - 1) as f64 * GRID
    }

    fn segment_at(&self, t: f64) -> &SegState {
        segment_at(&self.segs, t)
    }

    /// Position at `t` (cubic Hermite between grid nodes with exact end velocities).
    pub fn position(&self, t: f64) -> GeoPos {
        let x = ((t - self.t_start) / GRID).clamp(0.0, (self.n_nodes - 1) as f64);
        let i = (x.floor() as usize).min(self.n_nodes.saturating_sub(2));
        let u = x - i as f64;
        let (p0, p1) = self.node_pair(i);
        let (ta, tb) = (self.t_start + i as f64 * GRID, self.t_start + (i + 1) as f64 * GRID);
        let seg = self.segment_at(ta + 0.5 * GRID);
        let d0 = geodetic_rate(&p0, &seg_velocity(seg, ta)) * GRID;
        let d1 = geodetic_rate(&p1, &seg_velocity(seg, tb)) * GRID;
        let (h00, h10, h01, h11) = (
            2.0 * u.powi(3) - 3.0 * u * u + 1.0,
            u.powi(3) - 2.0 * u * u + u,
            -2.0 * u.powi(3) + 3.0 * u * u,
            u.powi(3) - u * u,
        );
        let c = |a: f64, b: f64, da: f64, db: f64| h00 * a + h10 * da + h01 * b + h11 * db;
        GeoPos {
            lat: c(p0.lat, p1.lat, d0.x, d1.x),
            lon: c(p0.lon, p1.lon, d0.y, d1.y),
            h: c(p0.h, p1.h, d0.z, d1.z),
        }
    }

    /// Exact kinematics at `t`; at a segment boundary the segment that starts there is used.
    pub fn at(&self, t: f64) -> Kinematics {
        self.at_in_segment(t, self.segment_at(t))
    }

    fn at_in_segment(&self, t: f64, s: &SegState) -> Kinematics {
        let (_, yaw, pitch) = seg_angles(s, t);
        let att = So3::from_euler(0.0, pitch, yaw);
        let vel = seg_velocity(s, t);
        let acc = seg_acceleration(s, t);
        let pos = self.position(t);
        let w_ie = earth_rate_ned(pos.lat);
        let w_en = transport_rate(pos.lat, pos.h, &vel);
        let w_nb_b = Vector3::new(
            -s.seg.yaw_rate * pitch.sin(),
            s.seg.pitch_rate,
            s.seg.yaw_rate * pitch.cos(),
        );
        let r_bn = att.inverse();
        let w_ib_b = w_nb_b + r_bn.rotate(&(w_ie + w_en));
        let f_b =
            r_bn.rotate(&(acc + (w_ie * 2.0 + w_en).cross(&vel) - gravity_ned(pos.lat, pos.h)));
        Kinematics { t, att, vel, pos, w_ib_b, f_b }
    }

    /// Exact increments `(∫ω_ib^b dt, ∫f^b dt)` over `[ta, tb]`: 4-point Gauss–Legendre on
    /// each 1 ms grid cell (cells never straddle a segment boundary).
    pub fn increments(&self, ta: f64, tb: f64) -> (Vector3<f64>, Vector3<f64>) {
        const X: [f64; 4] = [
            -0.861_136_311_594_052_6,
            -0.339_981_043_584_856_3,
            0.339_981_043_584_856_3,
            0.861_136_311_594_052_6,
        ];
        const W: [f64; 4] = [
            0.347_854_845_137_453_9,
            0.652_145_154_862_546_1,
            0.652_145_154_862_546_1,
            0.347_854_845_137_453_9,
        ];
        let (mut dth, mut dv) = (Vector3::zeros(), Vector3::zeros());
        let ia = ((ta - self.t_start) / GRID).floor() as i64;
        let ib = ((tb - self.t_start) / GRID).ceil() as i64;
        for cell in ia.max(0)..ib.max(0) {
            let c0 = self.t_start + cell as f64 * GRID;
            let (a, b) = (c0.max(ta), (c0 + GRID).min(tb));
            if b <= a {
                continue;
            }
            let seg = self.segment_at(0.5 * (a + b));
            let (half, mid) = (0.5 * (b - a), 0.5 * (a + b));
            for k in 0..4 {
                let kin = self.at_in_segment(mid + half * X[k], seg);
                dth += kin.w_ib_b * (W[k] * half);
                dv += kin.f_b * (W[k] * half);
            }
        }
        (dth, dv)
    }
}

/// The segment containing `t` (at a boundary: the one that starts there).
fn segment_at(segs: &[SegState], t: f64) -> &SegState {
    let i = segs.partition_point(|s| s.t1 <= t);
    &segs[i.min(segs.len() - 1)]
}

fn seg_angles(s: &SegState, t: f64) -> (f64, f64, f64) {
    let tau = t - s.t0;
    (s.s0 + s.seg.accel * tau, s.yaw0 + s.seg.yaw_rate * tau, s.pitch0 + s.seg.pitch_rate * tau)
}

fn seg_velocity(s: &SegState, t: f64) -> Vector3<f64> {
    let (sp, yaw, pitch) = seg_angles(s, t);
    Vector3::new(pitch.cos() * yaw.cos(), pitch.cos() * yaw.sin(), -pitch.sin()) * sp
}

fn seg_acceleration(s: &SegState, t: f64) -> Vector3<f64> {
    let (sp, yaw, pitch) = seg_angles(s, t);
    let (a, r, q) = (s.seg.accel, s.seg.yaw_rate, s.seg.pitch_rate);
    let (sy, cy) = yaw.sin_cos();
    let (sp_, cp) = pitch.sin_cos();
    Vector3::new(cp * cy, cp * sy, -sp_) * a
        + Vector3::new(-sp_ * q * cy - cp * sy * r, -sp_ * q * sy + cp * cy * r, -cp * q) * sp
}

/// `(φ̇, λ̇, ḣ)` for NED velocity `v` at `p`.
fn geodetic_rate(p: &GeoPos, v: &Vector3<f64>) -> Vector3<f64> {
    let (rm, rn) = radii(p.lat);
    Vector3::new(v.x / (rm + p.h), v.y / ((rn + p.h) * p.lat.cos()), -v.z)
}
