//! The static start: found in the IMU and GNSS streams, its noise and gyro biases.

use super::*;
use crate::navigator::{FIX_ERROR_SHARE, FIX_ERROR_TAU};

/// What the start of a log shows while it stands still: the span, and the mean and
/// per-axis standard deviation of the rates and specific forces over it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StaticStart {
    /// Samples from the first one that belong to the static span.
    pub samples: usize,
    /// First and last time of the span, s (start of the first interval, end of the last).
    pub span: (f64, f64),
    /// Mean angular rate, rad/s.
    pub mean_w: Vector3<f64>,
    /// Mean specific force, m/s².
    pub mean_f: Vector3<f64>,
    /// Per-axis standard deviation of the rates, rad/s.
    pub std_w: Vector3<f64>,
    /// Per-axis standard deviation of the specific force, m/s².
    pub std_f: Vector3<f64>,
    /// Mean sample interval, s.
    pub dt: f64,
}

impl StaticStart {
    /// No static span: zero samples from `t`.
    fn none(t: f64) -> Self {
        let zero = Vector3::zeros();
        Self {
            samples: 0,
            span: (t, t),
            mean_w: zero,
            mean_f: zero,
            std_w: zero,
            std_f: zero,
            dt: 0.0,
        }
    }

    /// Length of the static span, s.
    pub fn duration(&self) -> f64 {
        self.span.1 - self.span.0
    }

    /// Angular random walk per axis, rad/√s: the rates' σ times √dt (white noise
    /// sampled at `1/dt`; vibration at rest counts, which is the point).
    pub fn arw(&self) -> Vector3<f64> {
        self.std_w * self.dt.sqrt()
    }

    /// Velocity random walk per axis, m/s/√s.
    pub fn vrw(&self) -> Vector3<f64> {
        self.std_f * self.dt.sqrt()
    }

    /// 1σ of the mean rate over the span, per axis, rad/s (white noise only).
    pub fn mean_w_std(&self) -> Vector3<f64> {
        self.std_w / (self.samples.max(1) as f64).sqrt()
    }
}

/// The χ² (2 degrees of freedom) beyond which the fixes' horizontal drift is motion, not
/// noise: a probability of 1e-6 (−2 ln 1e-6) for fixes as noisy as their σ says.
const DRIFT_CHI2: f64 = 27.63;

/// The drift speed (m/s) below which fixes are never taken for motion: real fixes wander
/// by more than their σ says (multipath, a single point's slow errors), and a vehicle
/// that creeps slower than this is not started on by the static test's velocity 0 anyway
/// (its 0.02 m/s σ aside, the fit then has its first fixes).
const DRIFT_SPEED: f64 = 0.1;

/// Whether the GNSS fixes after `t0` up to `tb` drift: the horizontal velocity of a
/// straight-line least-squares fit to them, significant by [`DRIFT_CHI2`] against its σ
/// (from the fixes' σ or their scatter about the line, the larger, inflated by their
/// errors' persistence from fix to fix, plus the slope a single point's slow wander
/// gives), and faster than [`DRIFT_SPEED`]. Fixes 5 m apart in σ do not
/// move beyond 3σ of the first for 100 s at 0.42 m/s (a slow rover), and a window that
/// long is no static start; their line tells the motion within about 40 s.
fn drifting(gnss: &[GnssEpoch], t0: f64, tb: f64) -> bool {
    let span: Vec<&GnssEpoch> =
        gnss.iter().filter(|e| e.t > t0 - 1e-9 && e.t <= tb + 1e-9).collect();
    let Some(first) = span.first() else { return false };
    if span.len() < 5 {
        return false;
    }
    let n = span.len() as f64;
    let t_mean = span.iter().map(|e| e.t).sum::<f64>() / n;
    let stt: f64 = span.iter().map(|e| (e.t - t_mean).powi(2)).sum();
    if stt <= 0.0 {
        return false;
    }
    // (north, east): the slope of the line and the fixes' mean variance
    let (mut slope, mut mean, mut var) = (Vector2::zeros(), Vector2::zeros(), Vector2::zeros());
    let d: Vec<Vector2<f64>> =
        span.iter().map(|e| geodetic_to_local_ned(first.pos.tuple(), e.pos.tuple()).xy()).collect();
    for (e, d) in span.iter().zip(&d) {
        slope += d * ((e.t - t_mean) / stt);
        mean += d / n;
        var += e.pos_std.xy().map(|s| s * s / n);
    }
    // the fixes' noise as they show it about the line (the larger of it and their σ, a
    // prior), and the share of it that persists from fix to fix: errors that wander (a
    // single point's) make a line's slope as many times less certain as the fixes are
    // fewer independent samples than they number, `(1 + ρ)/(1 − ρ)` with their lag-one
    // autocorrelation ρ
    let r: Vec<Vector2<f64>> =
        span.iter().zip(&d).map(|(e, d)| d - mean - slope * (e.t - t_mean)).collect();
    let shown = r.iter().map(|r| r.component_mul(r)).sum::<Vector2<f64>>() / (n - 2.0);
    let lag = r.windows(2).map(|w| w[0].component_mul(&w[1])).sum::<Vector2<f64>>();
    let sq = r.iter().map(|r| r.component_mul(r)).sum::<Vector2<f64>>();
    let inflation = Vector2::from_fn(|k, _| {
        let rho = if sq[k] > 0.0 { (lag[k] / sq[k]).clamp(0.0, 0.95) } else { 0.0 };
        (1.0 + rho) / (1.0 - rho)
    });
    // and a line's slope through fixes whose declared variance persists as the
    // navigator's prior says ([`FIX_ERROR_SHARE`] of it, over [`FIX_ERROR_TAU`]): over a
    // span `T ≪ τ` a random walk of intensity `2 share σ² / τ`, whose least-squares slope
    // has the variance `1.2 q / T`
    let span_t = span[span.len() - 1].t - span[0].t;
    let wander = var * (1.2 * 2.0 * FIX_ERROR_SHARE / FIX_ERROR_TAU / span_t.max(1e-9));
    let var = var.zip_map(&shown, f64::max).component_mul(&inflation);
    let slope_var = (var / stt + wander).map(|v| v.max(1e-12));
    let chi2 = slope.component_mul(&slope).component_div(&slope_var).sum();
    chi2 > DRIFT_CHI2 && slope.norm() > DRIFT_SPEED
}

/// Window statistics for [`detect_static`].
#[derive(Clone, Copy, Debug)]
struct Window {
    end: usize,
    t1: f64,
    n: usize,
    sum_w: Vector3<f64>,
    sum_f: Vector3<f64>,
    sq_w: Vector3<f64>,
    sq_f: Vector3<f64>,
}

impl Window {
    fn mean_w(&self) -> Vector3<f64> {
        self.sum_w / self.n as f64
    }
    fn mean_f(&self) -> Vector3<f64> {
        self.sum_f / self.n as f64
    }
    fn std(sum: &Vector3<f64>, sq: &Vector3<f64>, n: usize) -> Vector3<f64> {
        let n = n as f64;
        (sq / n - (sum / n).component_mul(&(sum / n))).map(|v| v.max(0.0).sqrt())
    }
    fn std_w(&self) -> Vector3<f64> {
        Self::std(&self.sum_w, &self.sq_w, self.n)
    }
    fn std_f(&self) -> Vector3<f64> {
        Self::std(&self.sum_f, &self.sq_f, self.n)
    }
}

/// The static span at the start of `imu`: consecutive windows of `window` seconds that
/// look like the first one (rates and specific force with the same mean and spread, to
/// within what the first window's noise explains plus 0.1 deg/s and 0.05 m/s²) while the
/// specific force stays near gravity (|f| within 0.5 m/s² of normal gravity at the first
/// fix, or of 9.8 without one) and the GNSS fixes of the span measure no speed beyond
/// [`MOVING_SPEED`] and [`MOVING_SIGMAS`] of its σ (their positions alone do not make
/// motion: they jump and wander beyond their declared σ while the IMU shows rest). When
/// the fixes of a span whose IMU never changed drift (a straight line fitted to them moves
/// faster than 0.1 m/s, beyond what their noise and its persistence explain at a
/// probability of 1e-6), nothing was static: a constant velocity from the first sample
/// looks like rest to the IMU. A vibrating vehicle (engine running) is static too: the test is relative to the first window. Returns a span of
/// zero samples when the first window already moves.
pub fn detect_static(imu: &[ImuSample], gnss: &[GnssEpoch], window: f64) -> StaticStart {
    let still = still_span(imu, gnss, window);
    // the IMU unchanged since the first window while the fixes drift over the whole span:
    // a constant velocity from the first sample (a rover moving off before the log
    // began), which the IMU cannot tell from rest; no part of the span was static (judged
    // once, over the span: a test at the end of every window, or of every part of the
    // data read so far, would take a wander for motion as many more times as it is
    // repeated)
    if still.samples > 0 && drifting(gnss, still.span.0, still.span.1) {
        return StaticStart::none(still.span.0);
    }
    still
}

/// The IMU's samples in windows of `window` s from `t0` (a window's end moved on by whole
/// windows over a gap); a last window only when full (a partial one has a noisier mean).
fn windows_of(imu: &[ImuSample], t0: f64, window: f64) -> Vec<Window> {
    let mut windows: Vec<Window> = Vec::new();
    let mut cur = Window {
        end: 0,
        t1: t0 + window,
        n: 0,
        sum_w: Vector3::zeros(),
        sum_f: Vector3::zeros(),
        sq_w: Vector3::zeros(),
        sq_f: Vector3::zeros(),
    };
    for (k, s) in imu.iter().enumerate() {
        if s.t > cur.t1 + 1e-9 && cur.n > 0 {
            windows.push(cur);
            cur = Window {
                end: k,
                t1: cur.t1 + window * ((s.t - cur.t1) / window).ceil().max(1.0),
                n: 0,
                sum_w: Vector3::zeros(),
                sum_f: Vector3::zeros(),
                sq_w: Vector3::zeros(),
                sq_f: Vector3::zeros(),
            };
        }
        let (w, f) = (s.rate(), s.specific_force());
        cur.sum_w += w;
        cur.sum_f += f;
        cur.sq_w += w.component_mul(&w);
        cur.sq_f += f.component_mul(&f);
        cur.n += 1;
        cur.end = k + 1;
    }
    // a last window counts only when full (a partial one has a noisier mean)
    if cur.n > 0 && imu.last().is_some_and(|s| s.t >= cur.t1 - 1e-6) {
        windows.push(cur);
    }
    windows
}

/// The horizontal speed (m/s) beyond which a fix's measured velocity (σ `std`, NED) is
/// motion: [`MOVING_SPEED`], or [`MOVING_SIGMAS`] of its larger horizontal σ when that is
/// more (a single point of 4 satellites gives its Doppler velocity to 0.3–1 m/s, and a
/// walker standing still then "moves" at 0.3 m/s on every few fixes).
fn moving_speed(std: &Vector3<f64>) -> f64 {
    MOVING_SPEED.max(MOVING_SIGMAS * std.x.max(std.y))
}

/// The horizontal speed (m/s) a fix's velocity must show to be motion, whatever its σ.
pub const MOVING_SPEED: f64 = 0.3;

/// The multiple of its horizontal σ a fix's speed must exceed to be motion: a standing
/// receiver's speed is Rayleigh-distributed, beyond 4σ on 3 fixes in 10,000.
pub const MOVING_SIGMAS: f64 = 4.0;

/// [`detect_static`] without the fixes' drift: the span the IMU shows still (and no
/// measured velocity contradicts). A reader that stops once this span has ended inside
/// what it read has read all [`detect_static`] judges.
pub fn still_span(imu: &[ImuSample], gnss: &[GnssEpoch], window: f64) -> StaticStart {
    let none = StaticStart::none;
    let Some(first) = imu.first() else { return none(f64::NAN) };
    let t0 = first.t - first.dt;
    let g = gnss.iter().find(|e| e.t >= t0).map_or(9.8, |e| normal_gravity(e.pos.lat, e.pos.h));
    let windows = windows_of(imu, t0, window);
    let Some(w0) = windows.first().copied() else { return none(t0) };
    // (the IMU first: a fix's position far from the first one is no motion while the IMU
    // shows none — fixes jump and wander by more than their declared σ says, and a
    // vehicle does not move without accelerating; a constant velocity from the first
    // sample, which the IMU cannot see, is the fixes' drift below; a measured velocity
    // is motion)
    let moving_gnss = |ta: f64, tb: f64| {
        gnss.iter()
            .filter(|e| e.t >= ta - 1e-9 && e.t <= tb + 1e-9)
            .any(|e| e.vel.is_some_and(|(v, std)| v.xy().norm() > moving_speed(&std)))
    };
    let (m0w, m0f, s0w, s0f) = (w0.mean_w(), w0.mean_f(), w0.std_w(), w0.std_f());
    let deg = core::f64::consts::PI / 180.0;
    let still = |w: &Window, ta: f64| {
        let n = (w.n as f64).sqrt();
        let mf = w.mean_f();
        (mf.norm() - g).abs() < 0.5
            && (w.mean_w() - m0w).norm() <= 3.0 * s0w.norm() / n + 0.1 * deg
            && (mf - m0f).norm() <= 3.0 * s0f.norm() / n + 0.05
            && w.std_w().norm() <= 2.0 * s0w.norm() + 0.2 * deg
            && w.std_f().norm() <= 2.0 * s0f.norm() + 0.1
            && !moving_gnss(ta, w.t1)
    };
    let mut n_windows = 0;
    let mut ta = t0;
    for w in &windows {
        if !still(w, ta) {
            break;
        }
        n_windows += 1;
        ta = w.t1;
    }
    if n_windows == 0 {
        return none(t0);
    }
    let used = &windows[..n_windows];
    let samples = used.last().map_or(0, |w| w.end);
    let sum = |f: fn(&Window) -> Vector3<f64>| used.iter().map(f).sum::<Vector3<f64>>();
    let (sum_w, sum_f, sq_w, sq_f) =
        (sum(|w| w.sum_w), sum(|w| w.sum_f), sum(|w| w.sq_w), sum(|w| w.sq_f));
    let span = (t0, imu[samples - 1].t);
    StaticStart {
        samples,
        span,
        mean_w: sum_w / samples as f64,
        mean_f: sum_f / samples as f64,
        std_w: Window::std(&sum_w, &sq_w, samples),
        std_f: Window::std(&sum_f, &sq_f, samples),
        dt: (span.1 - span.0) / samples as f64,
    }
}

/// The gyro bias of a static start once the attitude is known: the mean rate less the
/// Earth rate seen in the body frame, rad/s.
pub fn static_gyro_bias(s: &StaticStart, att: &So3, lat: f64) -> Vector3<f64> {
    s.mean_w - att.inverse().rotate(&earth_rate_ned(lat))
}
