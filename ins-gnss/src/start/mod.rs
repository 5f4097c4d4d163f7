//! Before the filter starts: the first seconds of the IMU and GNSS data are checked
//! against the declared units, axes and rate, and what `[init]` (and, with
//! `imu_noise.from_static`, `[imu_noise]`) does not give is found from them.
//!
//! | part | from |
//! |---|---|
//! | roll, pitch | levelling over the static start ([`detect_static`]), else the in-motion alignment |
//! | heading | after a static start, the bank of hypotheses over the motion that follows ([`heading_bank`]); moving, the in-motion alignment ([`align_in_motion`]: any heading, no forward-motion assumption), or the bank when it cannot tell |
//! | position, velocity | the static start's first fix and 0; moving, the in-motion alignment's fit to the first fixes (lever arm included) |
//! | gyro bias | the static start's mean rate less the Earth rate, else 0 |
//! | ARW, VRW | the static start's per-axis σ × √dt (`imu_noise.from_static`) |
//!
//! Every check refuses with the key to change and the value that would fit, and stays
//! silent when the data cannot tell.

use nalgebra::Vector3;

use crate::config::{Config, InitialParts};
use ins_gnss_core::align::{
    align_in_motion, detect_static, fit_span, heading_bank, static_gyro_bias, time_offset,
    turn_ratio, BankHeading, BankStart, MotionFit, StaticStart, TimeOffset, TurnRatio, Wheels,
    BANK_SIZE,
};
use ins_gnss_core::earth::{geodetic_to_local_ned, normal_gravity};
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::imu::{ImuNoise, ImuSample, DEG_PER_H, DEG_PER_SQRT_H, MGAL, M_S_PER_SQRT_H};
use ins_gnss_core::init::level;
use ins_gnss_core::navigator::InitialState;
use ins_gnss_core::GeoPos;
use ins_gnss_io::columns::{unit_factor, Quantity};

mod bank;
mod checks;
mod fill;
mod starter;

use bank::*;
use checks::*;
pub use checks::{ACCEL_SPAN, MAX_TIME_OFFSET, RATE_SAMPLES, TIME_OFFSET_REFUSED};
use fill::*;
pub use starter::{start_on, start_time, Look, Starter};

/// The gyro bias 1σ without a static start to measure it, deg/h. On navego (no static
/// start; the filter's bias estimates settle at 12–70 deg/h) the forward horizontal RMS
/// with this prior given as `init.gyro_bias_std` is 1.414 m at 48, 1.413 m at 100, 1.418 m
/// at 400 and 1.430 m at 1000 deg/h (the alignment fits the horizontal biases itself).
pub const DEFAULT_GYRO_BIAS_STD: f64 = 100.0;

/// How much noisier at rest than declared an axis must be before
/// `imu_noise.static_floor` raises its ARW or VRW: the σ of a static start of
/// `align.min_static` (5 s) at 100 Hz is known to ±3 % (1/√(2N)), and at-rest noise that
/// is not white (vibration) makes the √dt scaling approximate; drive-0708's engine shakes
/// the axes 1.6–27× above KF-GINS's generic figures.
pub const FLOOR_FACTOR: f64 = 1.5;

/// Seconds of a static start the mirror-image check's fit takes before the motion.
const MIRROR_LEAD: f64 = 10.0;

/// The largest heading σ (rad) the self-start accepts: the error-state filter's
/// linearisation holds to about this.
const MAX_HEADING_STD: f64 = 20.0 * core::f64::consts::PI / 180.0;

/// The χ² gain (in units of the fit's χ² per degree of freedom) by which a mirror image
/// must beat the best rotation before a left-handed frame is refused.
const MIRROR_DECISIVE: f64 = 100.0;

/// What the start of the data gave, in SI units: the initial state and the IMU noise the
/// filter starts from (the configuration's, completed from the data; the configuration
/// itself is not changed) and, for the run summary, how each part was obtained.
#[derive(Clone, Debug)]
pub struct Start {
    /// The start time (the configured one, or the first IMU sample's), s.
    pub time: f64,
    /// The initial state's parts: `[init]`'s, and what the data gave (complete once the
    /// start has looked at the data).
    pub init: InitialParts,
    /// The IMU noise: `[imu_noise]`'s, measured on the static start
    /// (`imu_noise.from_static`) or raised to what it shows (`imu_noise.static_floor`).
    pub noise: ImuNoise,
    /// The IMU time offset (`data.imu_time_offset`, s) the start's search applies, when it
    /// applies one.
    pub time_offset: Option<f64>,
    /// One line per part found from the data (empty when everything was given).
    pub report: Vec<String>,
    /// The end of the static start the initial state was found on (s), over which the
    /// filter takes ZARU: still by the IMU, the heading must not drift while the position
    /// fixes cannot tell it (a car standing 20 min with a consumer MEMS drifted 15–30° at
    /// a σ of 4°, its vertical gyro bias learned wrongly through the Earth rate).
    pub still_until: Option<f64>,
}

impl Start {
    /// The start at `time` of a run that does not look at the data: the configuration's
    /// initial state and noise.
    pub fn given(config: &Config, time: f64) -> Self {
        Self {
            time,
            init: config.initial_parts(),
            noise: config.imu_noise(),
            time_offset: None,
            report: Vec::new(),
            still_until: None,
        }
    }

    /// The initial state at the start time.
    pub fn initial_state(&self) -> InitialState {
        self.init.initial_state(self.time)
    }
}

fn fmt3(v: [f64; 3], digits: usize) -> String {
    format!("[{:.digits$}, {:.digits$}, {:.digits$}]", v[0], v[1], v[2])
}

/// Check the data of the run's first seconds (`imu` and `gnss` after `t0`, the start
/// time) and complete the initial state and noise of `config` from them. The error names
/// the configuration key to change.
fn prepare(
    config: &Config,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
) -> Result<Start, String> {
    // (both in time order: the readers refuse time going backwards)
    let (imu, gnss) = after(imu, gnss, t0);
    let mut start = Start::given(config, t0);
    let need_init = !config.init.is_complete();
    if imu.is_empty() || !config.start_looks_at_data() {
        return Ok(start);
    }
    let scene = Scene::new(config, imu, gnss, t0);
    let (still, is_static) = (&scene.still, scene.is_static);
    if config.align.checks {
        let g = gnss.first().map_or(9.80, |e| normal_gravity(e.pos.lat, e.pos.h));
        check_rate(config, imu)?;
        check_accel_unit(config, imu, still, g)?;
        check_gyro_at_rest(config, still)?;
    }
    // (a moving-base receiver's heading, when there is one, is taken before the bank)
    let bank = (is_static
        && config.init.attitude.is_none()
        && antenna_heading(config, imu, gnss, t0).is_none())
    .then(|| static_bank(config, still, imu, gnss, scene.bias_std))
    .flatten();
    let mut motion = if need_init || config.align.checks {
        scene.fit_from(config, t0, scene.max_time, 1.0)
    } else {
        None
    };
    if config.align.checks {
        check_motion(config, &scene, &mut motion, &mut start)?;
    }
    if config.imu_noise.from_static {
        noise_from_static(config, &scene, &mut start)?;
    } else if let (quiet, true, what) = noise_span(config, imu, gnss, t0, (*still, is_static)) {
        noise_floor(config, &mut start.noise, &mut start.report, &quiet, what);
    }
    if need_init {
        let found = Found {
            still,
            is_static,
            motion: motion.as_ref(),
            bank: bank.as_ref(),
            bias_std: scene.bias_std,
        };
        fill_init(config, &mut start.init, &mut start.report, &found, imu, gnss, t0)?;
    }
    // started from a static start: ZARU over it (unless ZUPT and ZARU are asked for over
    // the whole run)
    start.still_until = (need_init && bank.is_some()).then_some(still.span.1);
    if let (Some(t), None) = (start.still_until, &config.vehicle.zupt) {
        start.report.push(format!(
            "ZARU over the static start {:.3}–{t:.3} s (the IMU still; `[vehicle.zupt]` for \
             ZUPT and ZARU at every stop)",
            still.span.0
        ));
    }
    Ok(start)
}

/// What [`prepare`] sees of the start of the data: the samples and epochs after `t0`, the
/// static start, and what the in-motion fit takes from them.
struct Scene<'a> {
    imu: &'a [ImuSample],
    gnss: &'a [GnssEpoch],
    t0: f64,
    still: StaticStart,
    /// Whether the static start lasts `align.min_static`.
    is_static: bool,
    lever: Vector3<f64>,
    /// The gyro bias taken off the rates: the static start's mean rate, else 0.
    bias0: Vector3<f64>,
    /// What is left of the gyro bias, rad/s.
    bias_std: f64,
    /// The accelerometer bias the datasheet declares, m/s².
    accel_bias_std: f64,
    /// How long after `t0` the fit looks ([`motion_span`]).
    max_time: f64,
}

impl<'a> Scene<'a> {
    fn new(config: &Config, imu: &'a [ImuSample], gnss: &'a [GnssEpoch], t0: f64) -> Self {
        let (still, is_static) = static_start(config, imu, gnss, t0);
        let bias0 = if is_static { still.mean_w } else { Vector3::zeros() };
        // what is left of the gyro bias: the static mean's noise (and the Earth rate it
        // holds), else a consumer MEMS turn-on bias
        let bias_std = if is_static {
            still.mean_w_std().norm() + 15.0 * DEG_PER_H
        } else {
            config.init.gyro_bias_std.map_or(DEFAULT_GYRO_BIAS_STD, |v| v[2]) * DEG_PER_H
        };
        // the accelerometer bias the datasheet declares (its instability), considered by
        // the fit: its σ then counts what such a bias moves it by
        let accel_bias_std = config
            .imu_noise
            .accel_bias_std
            .map_or(0.0, |v| v.iter().fold(0.0, |a: f64, b| a.max(*b)))
            * MGAL;
        // `align.max_time` counts from the motion's start: a vehicle that stands still for
        // minutes before it drives (an alignment practice) is aligned on its first minutes
        // of motion, the static span included
        let max_time = motion_span(config, &still, is_static);
        let lever = Vector3::from(config.gnss.lever_arm);
        Self { imu, gnss, t0, still, is_static, lever, bias0, bias_std, accel_bias_std, max_time }
    }

    /// The in-motion fit from `t_a` over `span` s with the gyro's rates scaled by `scale`.
    fn fit_from(&self, config: &Config, t_a: f64, span: f64, scale: f64) -> Option<MotionFit> {
        align_in_motion(
            self.imu,
            self.gnss,
            t_a,
            &(self.bias0 * scale),
            scale,
            &self.lever,
            span,
            config.align.heading_std.to_radians(),
            self.bias_std,
            self.accel_bias_std,
        )
    }
}

/// The checks on the motion: a mirror image, the gyro's unit, the turns, the time offset
/// (applied in `start` when its search says so) and an upside-down frame. After a static
/// start a gyro unit judged on the motion alone may replace `motion`.
fn check_motion(
    config: &Config,
    scene: &Scene<'_>,
    motion: &mut Option<MotionFit>,
    start: &mut Start,
) -> Result<(), String> {
    let Scene { imu, gnss, t0, is_static, max_time, .. } = *scene;
    let (still, a) = (&scene.still, &config.align);
    let turns = turn_ratio(imu, gnss, t0, t0 + max_time);
    if let Some(m) = motion.as_ref() {
        // the fit stops once the heading is known, which may be before the first turn,
        // and its span is chosen for the heading: a mirror image shows only when the
        // motion turned, so it is judged on the whole span (no early stop) and only when
        // the course turned (the early fit of navego's ADIS16405, a straight drive with a
        // large gyro bias, looked like one)
        // (after a static start, from `MIRROR_LEAD` before its end: gravity over a still
        // span lets a mirror image show, a long one lets every error grow over the double
        // integral — cars standing 5–20 min looked mirrored on 7 of 80 runs)
        let turned = turns.is_some_and(|t| t.turned > 30f64.to_radians());
        let t_a = if is_static { (still.span.1 - MIRROR_LEAD).max(t0) } else { t0 };
        let whole = if turned {
            fit_span(imu, gnss, t_a, &scene.bias0, &scene.lever, t0 + max_time)
        } else {
            None
        };
        check_mirror(config, whole.as_ref())?;
        let fit = |t_a: f64, span: f64| move |s: f64| scene.fit_from(config, t_a, span, s);
        if let Err(e) = check_gyro_unit(config, m, &fit(t0, max_time)) {
            // after a static start, a gyro unit is refused only when the motion alone
            // shows it as well: integrated over a long static span, the specific force's
            // double integral takes up the tilt's and the accelerometer's every error (a
            // clean car standing 200 s fitted its track worse than with a gyro scaled 57×
            // down)
            if !is_static {
                return Err(e);
            }
            let t_s = still.span.1;
            let m = scene.fit_from(config, t_s, a.max_time, 1.0).ok_or(e.clone())?;
            check_gyro_unit(config, &m, &fit(t_s, a.max_time)).map_err(|_| e)?;
            *motion = Some(m);
        }
    }
    if let Some(t) = turns {
        check_turns(config, &t, a.max_time)?;
    }
    if let Some(t) = time_offset(imu, gnss, t0, t0 + max_time, MAX_TIME_OFFSET, &scene.lever) {
        start.time_offset = check_time_offset(config, &t, &mut start.report)?;
    }
    check_upright(config, scene, motion.as_ref())
}

/// Refuse a frame whose roll (levelled on the static start, else the in-motion fit's)
/// says the IMU is upside down.
fn check_upright(
    config: &Config,
    scene: &Scene<'_>,
    motion: Option<&MotionFit>,
) -> Result<(), String> {
    let (roll, _) = match (motion, scene.is_static) {
        (_, true) => level(&scene.still.mean_f),
        (Some(m), false) => {
            let (r, p, _) = m.att.euler();
            (r, p)
        }
        (None, false) => (0.0, 0.0),
    };
    if roll.abs() > core::f64::consts::FRAC_PI_2 {
        return Err(format!(
            "{}: the IMU reads gravity along its +z axis (roll {:.1}°: the body frame is \
             upside down, where FRD has z down): FRD data declared `axes = \"flu\"` (or the \
             reverse), or a mounting not stated; set `data.imu_columns.axes` or \
             `imu.mounting` so that z points down",
            axes_key(config),
            roll.to_degrees()
        ));
    }
    Ok(())
}

/// `imu_noise.from_static`: the ARW and VRW measured on the static start, which must last
/// `align.min_static`.
fn noise_from_static(config: &Config, scene: &Scene<'_>, start: &mut Start) -> Result<(), String> {
    let found = (scene.still, scene.is_static);
    let (quiet, enough, what) = noise_span(config, scene.imu, scene.gnss, scene.t0, found);
    let still = &quiet;
    if !enough {
        return Err(format!(
            "`imu_noise.from_static`: the IMU shows the start still for {:.1} s ({:.3}–{:.3} s); at \
             least `align.min_static` = {} s are needed to measure the noise: give \
             `imu_noise.arw` and `imu_noise.vrw` instead",
            still.duration(),
            still.span.0,
            still.span.1,
            config.align.min_static
        ));
    }
    start.noise.arw = still.arw();
    start.noise.vrw = still.vrw();
    let arw = still.arw() / DEG_PER_SQRT_H;
    let vrw = still.vrw() / M_S_PER_SQRT_H;
    start.report.push(format!(
        "noise from the {} {:.3}–{:.3} s ({:.1} s): ARW {} deg/√h, VRW {} m/s/√h",
        what,
        still.span.0,
        still.span.1,
        still.duration(),
        fmt3(arw.into(), 3),
        fmt3(vrw.into(), 3)
    ));
    Ok(())
}

/// The longest static start (s) after which `align.max_time` still counts: the start's
/// data are read up to `align.max_time` after the static start's end (`span_end`), at
/// most this + `align.max_time` after the start, so that a vehicle that stands still for
/// up to an hour before it drives is aligned on its first minutes of motion (the start's
/// samples are held in memory: 17 MB for 20 min at 200 Hz). Until the heading bank it was
/// 600 s, and a car standing 300 s was refused by a fit over its static span.
pub const STATIC_ALLOWANCE: f64 = 3600.0;

/// How long after the start [`prepare`] looks: `align.max_time`, counted from the end of
/// a static start (of up to [`STATIC_ALLOWANCE`]).
fn motion_span(config: &Config, still: &StaticStart, is_static: bool) -> f64 {
    let a = &config.align;
    if is_static {
        a.max_time + still.duration().min(STATIC_ALLOWANCE)
    } else {
        a.max_time
    }
}

/// Where the data [`prepare`] looks at end, from the data read so far (`imu` and `gnss`
/// from the first sample on, the GNSS epochs up to one past the last sample): `t0` (the
/// start time) + `align.max_time`, or later by the static start's duration, and at least
/// the first [`ACCEL_SPAN`] s. `None` while the samples may still end inside the static
/// start (the end is known once the first window after it was read) or hold no GNSS
/// epoch after `t0` (gravity comes from the first). [`prepare`] gives the same answer on
/// data that reach past this end ([`reaches`]) as on any longer span: it looks at nothing
/// later. The program reads the start this far, not [`STATIC_ALLOWANCE`] further.
fn span_end(config: &Config, imu: &[ImuSample], gnss: &[GnssEpoch], t0: f64) -> Option<f64> {
    let after = &imu[imu.partition_point(|s| s.t <= t0 + 1e-9)..];
    let (first, last) = (after.first()?, after.last()?);
    if gnss.last().is_none_or(|e| e.t <= t0 + 1e-9) {
        return None;
    }
    // the static start (or its absence) is final once the window after the span the IMU
    // shows still is complete: `detect_static` stops at the first window that is not
    // still, and judges the fixes' drift over the span before it
    let imu_still = still_imu_span(config, imu, gnss, t0);
    let next = after.get(imu_still.samples)?;
    if last.t <= next.t + config.align.static_window + 1e-9 {
        return None;
    }
    let (still, is_static) = static_start(config, imu, gnss, t0);
    Some((t0 + motion_span(config, &still, is_static)).max(first.t + ACCEL_SPAN))
}

/// Whether `imu` (from the first sample on) holds all [`prepare`] looks at up to `end`
/// ([`span_end`]): a sample whose interval starts after `end`, and the first
/// [`RATE_SAMPLES`] + 1 after `t0`.
fn reaches(imu: &[ImuSample], t0: f64, end: f64) -> bool {
    let after = imu.len() - imu.partition_point(|s| s.t <= t0 + 1e-9);
    after > RATE_SAMPLES && imu.last().is_some_and(|s| s.t - s.dt > end)
}

/// The static start of the data after `t0` (the start time), with the configuration's
/// window, and whether it lasts `align.min_static`.
pub fn static_start(
    config: &Config,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
) -> (StaticStart, bool) {
    let (imu, gnss) = after(imu, gnss, t0);
    let still = detect_static(imu, gnss, config.align.static_window);
    let is_static = still.samples > 0 && still.duration() >= config.align.min_static;
    (still, is_static)
}

/// The span from `t0` the IMU shows still, the fixes' drift not judged
/// ([`still_span`](ins_gnss_core::align::still_span)): once it has ended inside the data
/// read, [`static_start`] has all it judges.
fn still_imu_span(config: &Config, imu: &[ImuSample], gnss: &[GnssEpoch], t0: f64) -> StaticStart {
    let (imu, gnss) = after(imu, gnss, t0);
    ins_gnss_core::align::still_span(imu, gnss, config.align.static_window)
}

/// The samples and epochs after `t0` (the start time).
fn after<'a>(
    imu: &'a [ImuSample],
    gnss: &'a [GnssEpoch],
    t0: f64,
) -> (&'a [ImuSample], &'a [GnssEpoch]) {
    let imu = &imu[imu.partition_point(|s| s.t <= t0 + 1e-9)..];
    (imu, &gnss[gnss.partition_point(|e| e.t <= t0 + 1e-9)..])
}

/// [`prepare`]'s part that needs only the static start: `imu_noise.static_floor` (when
/// `[init]` is complete and the noise given, the rest of `prepare` only checks, beside
/// the filter).
fn prepare_floor(config: &Config, imu: &[ImuSample], gnss: &[GnssEpoch], t0: f64) -> Start {
    let mut start = Start::given(config, t0);
    let found = static_start(config, imu, gnss, t0);
    if let (quiet, true, what) = noise_span(config, imu, gnss, t0, found)
        && !config.imu_noise.from_static
    {
        noise_floor(config, &mut start.noise, &mut start.report, &quiet, what);
    }
    start
}

/// The span the IMU's noise is measured on (`imu_noise.from_static`, `static_floor`),
/// whether it lasts `align.min_static`, and how the report names it: the static start
/// ([`static_start`]'s `found`), else the span from `t0` the IMU shows still. The noise is
/// the IMU's: fixes that drift over a span the IMU shows still (a constant velocity from
/// the first sample, or fixes that wander faster than their declared σ says) make it no
/// static start — no zero velocity, no gyro bias from its mean rate — but its samples show
/// the sensors' noise as well (drive-0708 with a 3 m wander declared 0.15 m: the 33 s the
/// car stands were taken for motion and the datasheet's ARW, 17× below what the IMU shows
/// there, kept: 74–83 m on 3 of 20 seeds against 17–21 m).
fn noise_span(
    config: &Config,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
    (still, is_static): (StaticStart, bool),
) -> (StaticStart, bool, &'static str) {
    if is_static {
        return (still, true, "static start");
    }
    let quiet = still_imu_span(config, imu, gnss, t0);
    let long = quiet.samples > 0 && quiet.duration() >= config.align.min_static;
    (quiet, long, "span the IMU shows still (the fixes drift over it: no static start)")
}

/// `imu_noise.static_floor`: raise each ARW / VRW axis of `noise` (the declared, SI) that
/// `still` ([`noise_span`], named `what` in the report) shows [`FLOOR_FACTOR`]× noisier
/// than declared to the measured value.
fn noise_floor(
    config: &Config,
    noise: &mut ImuNoise,
    report: &mut Vec<String>,
    still: &StaticStart,
    what: &str,
) {
    if !config.imu_noise.static_floor {
        return;
    }
    // (judged in the declared units, as given)
    let (arw0, vrw0) = (config.imu_noise.arw, config.imu_noise.vrw);
    let arw = still.arw() / DEG_PER_SQRT_H;
    let vrw = still.vrw() / M_S_PER_SQRT_H;
    let mut raised = false;
    for k in 0..3 {
        if arw[k] > FLOOR_FACTOR * arw0[k] {
            noise.arw[k] = still.arw()[k];
            raised = true;
        }
        if vrw[k] > FLOOR_FACTOR * vrw0[k] {
            noise.vrw[k] = still.vrw()[k];
            raised = true;
        }
    }
    let n = (noise.arw / DEG_PER_SQRT_H, noise.vrw / M_S_PER_SQRT_H);
    if raised {
        report.push(format!(
            "noise raised to what the IMU shows at rest ({what} {:.3}–{:.3} s, {:.1} s): \
             ARW {} deg/√h (declared {}), VRW {} m/s/√h (declared {}); \
             `imu_noise.static_floor = false` keeps the declared",
            still.span.0,
            still.span.1,
            still.duration(),
            fmt3(n.0.into(), 3),
            fmt3(arw0, 3),
            fmt3(n.1.into(), 3),
            fmt3(vrw0, 3)
        ));
    }
}
