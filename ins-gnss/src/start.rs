//! Before the filter starts: the first seconds of the IMU and GNSS data are checked
//! against the declared units, axes and rate, and what `[init]` (and, with
//! `imu_noise.from_static`, `[imu_noise]`) does not give is found from them.
//!
//! | part | from |
//! |---|---|
//! | roll, pitch | levelling over the static start ([`detect_static`]), else the in-motion alignment |
//! | heading | the in-motion alignment ([`align_in_motion`]: any heading, no forward-motion assumption) |
//! | position, velocity | the in-motion alignment's fit to the first fixes (lever arm included); velocity 0 on a static start |
//! | gyro bias | the static start's mean rate less the Earth rate, else 0 |
//! | ARW, VRW | the static start's per-axis σ × √dt (`imu_noise.from_static`) |
//!
//! Every check refuses with the key to change and the value that would fit, and stays
//! silent when the data cannot tell.

use nalgebra::Vector3;

use crate::config::Config;
use ins_gnss_core::align::{
    align_in_motion, detect_static, fit_span, static_gyro_bias, time_offset, turn_ratio, MotionFit,
    StaticStart, TimeOffset, TurnRatio,
};
use ins_gnss_core::earth::normal_gravity;
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::imu::{ImuSample, DEG_PER_H, DEG_PER_SQRT_H, M_S_PER_SQRT_H};
use ins_gnss_core::init::level;
use ins_gnss_core::io::columns::{unit_factor, Quantity};

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

/// The longest static start (s) after which `align.max_time` still counts: the start's
/// data are read up to `align.max_time` + this after the start, so that a vehicle that
/// stands still for up to ten minutes before it drives (an alignment practice) aligns on
/// its first minutes of motion.
pub const STATIC_ALLOWANCE: f64 = 600.0;

/// The largest heading σ (rad) the self-start accepts: the error-state filter's
/// linearisation holds to about this.
const MAX_HEADING_STD: f64 = 20.0 * core::f64::consts::PI / 180.0;

/// The χ² gain (in units of the fit's χ² per degree of freedom) by which a mirror image
/// must beat the best rotation before a left-handed frame is refused.
const MIRROR_DECISIVE: f64 = 100.0;

/// What the start of the data gave: the completed configuration and, for the run
/// summary, how each part of the initial state was obtained.
#[derive(Clone, Debug)]
pub struct Start {
    /// The configuration with `[init]` (and the noise, with `from_static`) filled in.
    pub config: Config,
    /// One line per part found from the data (empty when everything was given).
    pub report: Vec<String>,
}

fn fmt3(v: [f64; 3], digits: usize) -> String {
    format!("[{:.digits$}, {:.digits$}, {:.digits$}]", v[0], v[1], v[2])
}

/// Check the data of the run's first seconds (`imu` and `gnss` after `t0`, the start
/// time) and complete `config` from them. The error names the configuration key to
/// change.
pub fn prepare(
    config: &Config,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
) -> Result<Start, String> {
    // (both in time order: the readers refuse time going backwards)
    let imu = &imu[imu.partition_point(|s| s.t <= t0 + 1e-9)..];
    let gnss = &gnss[gnss.partition_point(|e| e.t <= t0 + 1e-9)..];
    let mut config = config.clone();
    let mut report = Vec::new();
    let a = config.align.clone();
    let need_init = !config.init.is_complete();
    let need_noise = config.imu_noise.from_static;
    if imu.is_empty() || !looks_at_data(&config) {
        return Ok(Start { config, report });
    }
    let g = gnss.first().map_or(9.80, |e| normal_gravity(e.pos.lat, e.pos.h));
    let (still, is_static) = static_start(&config, imu, gnss, t0);

    if a.checks {
        check_rate(&config, imu)?;
        check_accel_unit(&config, imu, &still, g)?;
        check_gyro_at_rest(&config, &still)?;
    }
    let lever = Vector3::from(config.gnss.lever_arm);
    let bias0 = if is_static { still.mean_w } else { Vector3::zeros() };
    // what is left of the gyro bias: the static mean's noise (and the Earth rate it
    // holds), else a consumer MEMS turn-on bias
    let bias_std = if is_static {
        still.mean_w_std().norm() + 15.0 * DEG_PER_H
    } else {
        config.init.gyro_bias_std.map_or(DEFAULT_GYRO_BIAS_STD, |v| v[2]) * DEG_PER_H
    };
    // `align.max_time` counts from the motion's start: a vehicle that stands still for
    // minutes before it drives (an alignment practice) is aligned on its first minutes of
    // motion, the static span included
    let max_time =
        if is_static { a.max_time + still.duration().min(STATIC_ALLOWANCE) } else { a.max_time };
    let fit = |scale: f64| {
        align_in_motion(
            imu,
            gnss,
            t0,
            &(bias0 * scale),
            scale,
            &lever,
            max_time,
            a.heading_std.to_radians(),
            bias_std,
        )
    };
    let motion = if need_init || a.checks { fit(1.0) } else { None };
    if a.checks {
        let turns = turn_ratio(imu, gnss, t0, t0 + max_time);
        if let Some(m) = &motion {
            // the fit stops once the heading is known, which may be before the first
            // turn, and its span is chosen for the heading: a mirror image shows only
            // when the motion turned, so it is judged on the whole span (no early stop)
            // and only when the course turned (the early fit of navego's ADIS16405, a
            // straight drive with a large gyro bias, looked like one)
            let turned = turns.is_some_and(|t| t.turned > 30f64.to_radians());
            let whole =
                if turned { fit_span(imu, gnss, t0, &bias0, &lever, t0 + max_time) } else { None };
            check_motion(&config, m, whole.as_ref(), &fit)?;
        }
        if let Some(t) = turns {
            check_turns(&config, &t, a.max_time)?;
        }
        if let Some(t) = time_offset(imu, gnss, t0, t0 + max_time, MAX_TIME_OFFSET) {
            check_time_offset(&config, &t, &mut report)?;
        }
        let (roll, _) = match (&motion, is_static) {
            (_, true) => level(&still.mean_f),
            (Some(m), false) => {
                let (r, p, _) = m.att.euler();
                (r, p)
            }
            (None, false) => (0.0, 0.0),
        };
        if roll.abs() > core::f64::consts::FRAC_PI_2 {
            return Err(format!(
                "{}: the IMU reads gravity along its +z axis (roll {:.1}°: the body frame is \
                 upside down, where FRD has z down): FRD data declared `axes = \"flu\"` (or \
                 the reverse), or a mounting not stated; set `data.imu_columns.axes` or \
                 `imu.mounting` so that z points down",
                axes_key(&config),
                roll.to_degrees()
            ));
        }
    }

    if need_noise {
        if !is_static {
            return Err(format!(
                "`imu_noise.from_static`: the start is static for {:.1} s ({:.3}–{:.3} s); at \
                 least `align.min_static` = {} s are needed to measure the noise: give \
                 `imu_noise.arw` and `imu_noise.vrw` instead",
                still.duration(),
                still.span.0,
                still.span.1,
                a.min_static
            ));
        }
        let arw = still.arw() / DEG_PER_SQRT_H;
        let vrw = still.vrw() / M_S_PER_SQRT_H;
        config.imu_noise.arw = arw.into();
        config.imu_noise.vrw = vrw.into();
        config.imu_noise.from_static = false;
        report.push(format!(
            "noise from the static start {:.3}–{:.3} s ({:.1} s): ARW {} deg/√h, VRW {} m/s/√h",
            still.span.0,
            still.span.1,
            still.duration(),
            fmt3(arw.into(), 3),
            fmt3(vrw.into(), 3)
        ));
    }

    if !need_noise && is_static {
        noise_floor(&mut config, &mut report, &still);
    }
    if need_init {
        fill_init(&mut config, &mut report, &still, is_static, motion.as_ref(), gnss, t0)?;
    }
    Ok(Start { config, report })
}

/// The static start of the data after `t0` (the start time), with the configuration's
/// window, and whether it lasts `align.min_static`.
pub fn static_start(
    config: &Config,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
) -> (StaticStart, bool) {
    let imu = &imu[imu.partition_point(|s| s.t <= t0 + 1e-9)..];
    let gnss = &gnss[gnss.partition_point(|e| e.t <= t0 + 1e-9)..];
    let still = detect_static(imu, gnss, config.align.static_window);
    let is_static = still.samples > 0 && still.duration() >= config.align.min_static;
    (still, is_static)
}

/// [`prepare`]'s part that needs only the static start: `imu_noise.static_floor` (when
/// `[init]` is complete and the noise given, the rest of `prepare` only checks, beside
/// the filter).
pub fn prepare_floor(config: &Config, imu: &[ImuSample], gnss: &[GnssEpoch], t0: f64) -> Start {
    let mut config = config.clone();
    let mut report = Vec::new();
    let (still, is_static) = static_start(&config, imu, gnss, t0);
    if is_static && !config.imu_noise.from_static {
        noise_floor(&mut config, &mut report, &still);
    }
    Start { config, report }
}

/// `imu_noise.static_floor`: raise each ARW / VRW axis the static start shows
/// [`FLOOR_FACTOR`]× noisier than declared to the measured value.
fn noise_floor(config: &mut Config, report: &mut Vec<String>, still: &StaticStart) {
    if !config.imu_noise.static_floor {
        return;
    }
    let arw = still.arw() / DEG_PER_SQRT_H;
    let vrw = still.vrw() / M_S_PER_SQRT_H;
    let n = &mut config.imu_noise;
    let (arw0, vrw0) = (n.arw, n.vrw);
    let mut raised = false;
    for k in 0..3 {
        if arw[k] > FLOOR_FACTOR * n.arw[k] {
            n.arw[k] = arw[k];
            raised = true;
        }
        if vrw[k] > FLOOR_FACTOR * n.vrw[k] {
            n.vrw[k] = vrw[k];
            raised = true;
        }
    }
    if raised {
        report.push(format!(
            "noise raised to what the IMU shows at rest (static start {:.3}–{:.3} s, {:.1} s): \
             ARW {} deg/√h (declared {}), VRW {} m/s/√h (declared {}); \
             `imu_noise.static_floor = false` keeps the declared",
            still.span.0,
            still.span.1,
            still.duration(),
            fmt3(n.arw, 3),
            fmt3(arw0, 3),
            fmt3(n.vrw, 3),
            fmt3(vrw0, 3)
        ));
    }
}

/// Whether [`prepare`] reads the data at all: checks on, or a part of the configuration
/// to fill.
pub fn looks_at_data(config: &Config) -> bool {
    config.align.checks || fills(config) || floors(config)
}

/// Whether [`prepare`] fills a part of the configuration from the data: `[init]`
/// incomplete or the noise `from_static`. (Otherwise it only checks.)
pub fn fills(config: &Config) -> bool {
    !config.init.is_complete() || config.imu_noise.from_static
}

/// Whether [`prepare_floor`] may change the noise (it reads the data until the static
/// start ends).
pub fn floors(config: &Config) -> bool {
    config.imu_noise.static_floor && !config.imu_noise.from_static
}

/// The column map's key for the axes, or the mounting's.
fn axes_key(config: &Config) -> &'static str {
    if config.data.imu_columns.is_some() {
        "`data.imu_columns.axes`"
    } else {
        "`imu.mounting`"
    }
}

/// The median sample interval against `data.imu_rate`.
fn check_rate(config: &Config, imu: &[ImuSample]) -> Result<(), String> {
    let mut dts: Vec<f64> = imu.iter().skip(1).take(1000).map(|s| s.dt).collect();
    if dts.len() < 10 {
        return Ok(());
    }
    dts.sort_by(f64::total_cmp);
    let median = dts[dts.len() / 2];
    let rate = config.data.imu_rate;
    let ratio = median * rate;
    if !(0.5..=2.0).contains(&ratio) {
        return Err(format!(
            "`data.imu_rate` = {rate} Hz, but the IMU samples are {median:.6} s apart \
             ({:.3} Hz); set `data.imu_rate = {:.3}` (or, if the times are not in seconds, \
             `time_unit` in the column map)",
            1.0 / median,
            1.0 / median
        ));
    }
    Ok(())
}

/// The known unit of `q` closest to `factor` (SI per unit), within 15 %.
fn unit_near(q: Quantity, factor: f64, candidates: &[&'static str]) -> Option<&'static str> {
    candidates
        .iter()
        .filter_map(|u| unit_factor(q, u).ok().map(|f| (u, (f / factor).ln().abs())))
        .filter(|(_, d)| *d < 0.15)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(u, _)| *u)
}

fn rates(config: &Config) -> bool {
    config.imu_format() == ins_gnss_core::io::ImuFormat::Rates
}

/// |f| at rest (or over the first seconds) against normal gravity.
fn check_accel_unit(
    config: &Config,
    imu: &[ImuSample],
    still: &StaticStart,
    g: f64,
) -> Result<(), String> {
    let m = if still.samples > 0 {
        still.mean_f.norm()
    } else {
        // moving from the start: |mean f| over the first 5 s still sits near g (a car's
        // accelerations are a fraction of it); only factors beyond 1.5 are judged
        let t_end = imu[0].t + 5.0;
        let (sum, n) = imu
            .iter()
            .take_while(|s| s.t <= t_end)
            .fold((0.0, 0usize), |(a, n), s| (a + s.specific_force().norm(), n + 1));
        sum / n.max(1) as f64
    };
    let ratio = m / g;
    if (0.67..=1.5).contains(&ratio) || !ratio.is_finite() || m == 0.0 {
        return Ok(());
    }
    let at = if still.samples > 0 { "at rest" } else { "over the first 5 s" };
    let head = format!(
        "the specific force {at} averages {m:.4} m/s² where gravity is {g:.3} m/s² (a factor \
         {:.4} off)",
        g / m
    );
    match &config.data.imu_columns {
        Some(c) if rates(config) => {
            let declared = c.accel_unit.as_deref().unwrap_or("m/s^2");
            let f = unit_factor(Quantity::Acceleration, declared).unwrap_or(1.0) * g / m;
            let fits = unit_near(Quantity::Acceleration, f, &["m/s^2", "g", "mg"]);
            Err(match fits {
                Some(u) => format!(
                    "`data.imu_columns.accel_unit` = \"{declared}\": {head}; the log is in \
                     `{u}`: set `accel_unit = \"{u}\"`"
                ),
                None => format!(
                    "`data.imu_columns.accel_unit` = \"{declared}\": {head}; no known unit \
                     (m/s^2, g, mg) fits: check the accelerometer columns"
                ),
            })
        }
        _ => Err(format!(
            "`data.imu`: {head}; the file's velocity increments (or rates) are not in m/s \
             (m/s²): read it through `[data.imu_columns]` with its `accel_unit`"
        )),
    }
}

/// A gyro that reads tens of degrees per second at rest is in a smaller unit than declared.
fn check_gyro_at_rest(config: &Config, still: &StaticStart) -> Result<(), String> {
    let w = still.mean_w.norm();
    // 20°/s of bias at rest is beyond any gyro; 57× a plausible one (0.35°/s) is not
    if still.samples == 0 || w < 20f64.to_radians() {
        return Ok(());
    }
    let message = format!(
        "the gyro reads {:.3} rad/s ({:.1}°/s) at rest, beyond any gyro's bias",
        w,
        w.to_degrees()
    );
    Err(gyro_unit_error(config, 1.0 / 57.295_779_513_082_32, &message))
}

/// The error for a gyro unit off by `factor` (the rates fit when multiplied by it).
fn gyro_unit_error(config: &Config, factor: f64, why: &str) -> String {
    match &config.data.imu_columns {
        Some(c) => {
            let r = rates(config);
            let declared =
                c.gyro_unit.as_deref().unwrap_or(if r { "rad/s" } else { "rad" }).to_string();
            let (q, candidates): (Quantity, &[&str]) = if r {
                (Quantity::Rate, &["rad/s", "deg/s", "deg/h"])
            } else {
                (Quantity::Angle, &["rad", "deg", "mrad"])
            };
            let f = unit_factor(q, &declared).unwrap_or(1.0) * factor;
            match unit_near(q, f, candidates) {
                Some(u) => format!(
                    "`data.imu_columns.gyro_unit` = \"{declared}\": {why}; the log is in `{u}`: \
                     set `gyro_unit = \"{u}\"`"
                ),
                None => format!(
                    "`data.imu_columns.gyro_unit` = \"{declared}\": {why} (a factor {factor:.3} \
                     off); check the gyro columns"
                ),
            }
        }
        None => format!(
            "`data.imu`: {why} (a factor {factor:.3}): the file's angle increments are not in \
             rad; read it through `[data.imu_columns]` with its `gyro_unit`"
        ),
    }
}

/// What the in-motion fits say of the data: a mirror image (left-handed axes; judged on
/// `mirror`, the whole-span fit, present when the motion turned) and a gyro unit that
/// another one fits far better (on `m`, the alignment's fit).
fn check_motion(
    config: &Config,
    m: &MotionFit,
    mirror: Option<&MotionFit>,
    fit: &dyn Fn(f64) -> Option<MotionFit>,
) -> Result<(), String> {
    // a mirror image that fits decisively better (χ² down by 100 reduced units: the
    // motion turned, so all three axes were seen)
    if let Some(mirror) = mirror.filter(|w| w.mirror > MIRROR_DECISIVE) {
        let key = if config.data.imu_columns.is_some() {
            "`data.imu_columns.gyro` / `data.imu_columns.accel`"
        } else {
            "`imu.mounting`"
        };
        return Err(format!(
            "{key}: the IMU's motion over {:.3}–{:.3} s fits the GNSS track only as a mirror \
             image (a left-handed frame: two axes swapped, or one sign reversed); list the \
             columns in x, y, z order and state the mounting with `imu.mounting` (an axis map \
             such as [\"-y\", \"-x\", \"-z\"] or angles)",
            mirror.t_a, mirror.t_b
        ));
    }
    // only a gross misfit that another unit removes: vibration, a gyro bias or a
    // straight drive leave a few σ that "no rotation at all" can fit as well (seen on
    // the simulated car with vibration: 3.3σ declared, 1.0σ at 1/57). The fits leave
    // gross errors of the fixes out, so a misfit is also a fit that explains fewer than
    // half of its fixes, and another unit is decisive only when it explains at least as
    // large a share of them
    let share = |f: &MotionFit| f.fixes as f64 / (f.fixes + f.rejected).max(1) as f64;
    if m.residual > 10.0 || share(m) < 0.5 {
        let deg = core::f64::consts::PI / 180.0;
        for factor in [1.0 / deg, deg] {
            if let Some(alt) = fit(factor) {
                let fits = alt.residual < m.residual / 5.0 && share(&alt) >= share(m);
                let explains = share(&alt) > 0.8 && share(m) < 0.5 && alt.residual < 3.0;
                if fits || explains {
                    let why = format!(
                        "the IMU's motion fits the GNSS track with residuals of {:.1}σ on \
                         {:.0} % of the fixes as declared and {:.1}σ on {:.0} % with the rates \
                         {factor:.4}× larger",
                        m.residual,
                        100.0 * share(m),
                        alt.residual,
                        100.0 * share(&alt)
                    );
                    return Err(gyro_unit_error(config, factor, &why));
                }
            }
        }
    }
    Ok(())
}

/// The largest IMU–GNSS time offset the start looks for, s.
pub const MAX_TIME_OFFSET: f64 = 10.0;

/// The smallest time offset that refuses the run, s: below it, a clear offset is a line
/// of the run summary.
pub const TIME_OFFSET_REFUSED: f64 = 0.1;

/// An IMU whose time stamps are off the GNSS's: the gyro's turns fit the course better
/// shifted (decisive only: the course turned 30° or more, the shift lowers the misfit by
/// more than 9× its noise, and the offset is beyond 3σ). From [`TIME_OFFSET_REFUSED`] on it is
/// refused naming `data.imu_time_offset` with the value that fits; a smaller one is
/// reported.
fn check_time_offset(
    config: &Config,
    t: &TimeOffset,
    report: &mut Vec<String>,
) -> Result<(), String> {
    let noise = t.misfit_best / (t.pairs - 1) as f64;
    // (the simulated drive, one 90° turn: 0.308 ± 0.037 s found for 0.3 s, the misfit
    // down by 15× its noise; 5.008 s for 5 s; 0.008 s on time)
    let decisive = t.turned >= 30f64.to_radians()
        && t.misfit_zero - t.misfit_best > 9.0 * noise
        && t.offset.abs() > 3.0 * t.std;
    if !decisive {
        return Ok(());
    }
    let fix = config.data.imu_time_offset - t.offset;
    let what = format!(
        "the gyro's turns match the GNSS course {:.3} s (σ {:.3} s) {} the IMU's time stamps \
         say (over {} pairs of moving fixes; misfit {:.4} rad² shifted against {:.4} as \
         stamped)",
        t.offset.abs(),
        t.std,
        if t.offset > 0.0 { "earlier than" } else { "later than" },
        t.pairs,
        t.misfit_best,
        t.misfit_zero
    );
    if t.offset.abs() >= TIME_OFFSET_REFUSED {
        return Err(format!(
            "`data.imu_time_offset` = {}: {what}: the IMU and the GNSS are on different \
             clocks (a leap second, a latency, a time zone); set `data.imu_time_offset = \
             {fix:.3}`",
            config.data.imu_time_offset
        ));
    }
    report.push(format!(
        "IMU–GNSS time offset: {what}; below {TIME_OFFSET_REFUSED} s, kept as stamped \
         (`data.imu_time_offset = {fix:.3}` would apply it)"
    ));
    Ok(())
}

/// The GNSS course's turns against the gyro's (a straight start hides a gyro unit from
/// the in-motion fit): a slope near 57 or 1/57 names the unit, a negative one the axes.
fn check_turns(config: &Config, t: &TurnRatio, max_time: f64) -> Result<(), String> {
    // decisive only: the vehicle turned, and the fitted slope explains the course
    // changes far better than the declared one
    // (an F test of the slope 1 against the fitted one, at far beyond any tail: the
    // course of a car and the gyro's turn part by sideslip and the lever arm, 13 % on
    // navego's velocity fixes)
    let noise = t.misfit_fitted / (t.pairs - 1) as f64;
    if t.turned < 30f64.to_radians() || t.misfit_declared - t.misfit_fitted < 100.0 * noise {
        return Ok(());
    }
    let why = format!(
        "over {} pairs of moving GNSS fixes in the first {max_time} s the course turned {:.3}×          as far as the gyro says",
        t.pairs, t.ratio
    );
    if t.ratio < -0.5 {
        let key = if config.data.imu_columns.is_some() {
            "`data.imu_columns.gyro`"
        } else {
            "`data.imu`"
        };
        return Err(format!(
            "{key}: {why}: the gyro turns the other way from the accelerometer's axes (a \
             sign reversed in the gyro columns only)"
        ));
    }
    if t.ratio.ln().abs() > 5f64.ln() {
        return Err(gyro_unit_error(config, t.ratio, &why));
    }
    Ok(())
}

/// Fill `[init]` from the static start and the in-motion fit.
fn fill_init(
    config: &mut Config,
    report: &mut Vec<String>,
    still: &StaticStart,
    is_static: bool,
    motion: Option<&MotionFit>,
    gnss: &[GnssEpoch],
    t0: f64,
) -> Result<(), String> {
    let i = config.init.clone();
    let need_motion = i.attitude.is_none() || i.position.is_none() || i.velocity.is_none();
    let m = match motion {
        Some(m) => m,
        None if need_motion => {
            return Err(format!(
                "cannot find the initial {} from the data: fewer than 8 GNSS fixes, or no \
                 motion to tell the heading, within `align.max_time` = {} s of the start \
                 ({t0:.3} s); give `init.attitude`, `init.position` and `init.velocity`, or a \
                 longer `align.max_time`",
                [
                    i.attitude.is_none().then_some("attitude"),
                    i.position.is_none().then_some("position"),
                    i.velocity.is_none().then_some("velocity"),
                ]
                .into_iter()
                .flatten()
                .collect::<Vec<_>>()
                .join(", "),
                config.align.max_time
            ))
        }
        None => {
            // only 1σ or the gyro bias missing
            return fill_rest(config, report, still, is_static, None);
        }
    };
    let span = format!("{} fixes over {:.3}–{:.3} s", m.fixes, m.t_a, m.t_b);
    let (m_roll, m_pitch, m_yaw) = m.att.euler();

    if i.attitude.is_none() {
        let (roll, pitch, how) = if is_static {
            let (r, p) = level(&still.mean_f);
            (r, p, format!("levelled over the static start ({:.1} s)", still.duration()))
        } else {
            (m_roll, m_pitch, format!("from the in-motion alignment ({span})"))
        };
        // the heading's σ: the fit's (the vertical gyro bias's drift included), at
        // least 0.25°
        let yaw_std = m.att_std.z.hypot(0.25f64.to_radians());
        if yaw_std > MAX_HEADING_STD {
            return Err(format!(
                "the in-motion alignment finds the heading only to ±{:.0}° ({span}): too \
                 little motion; give `init.attitude` (and `init.attitude_std`), or a longer \
                 `align.max_time`",
                yaw_std.to_degrees()
            ));
        }
        let tilt_std = if is_static {
            0.5f64.to_radians()
        } else {
            m.att_std.x.max(m.att_std.y).max(0.5f64.to_radians())
        };
        config.init.attitude = Some([roll.to_degrees(), pitch.to_degrees(), m_yaw.to_degrees()]);
        if i.attitude_std.is_none() {
            config.init.attitude_std =
                Some([tilt_std.to_degrees(), tilt_std.to_degrees(), yaw_std.to_degrees()]);
        }
        let s = config.init.attitude_std.unwrap_or_default();
        report.push(format!(
            "init: roll {:.3}°, pitch {:.3}° {how}, σ {:.2}°; heading {:.3}° from the in-motion \
             alignment ({span}), σ {:.2}°",
            roll.to_degrees(),
            pitch.to_degrees(),
            s[0],
            m_yaw.to_degrees(),
            s[2]
        ));
    }
    if i.position.is_none() {
        // a fix (not a gross error), back to the start, not the fit's own p₀, whose
        // vertical takes up an accelerometer bias: on a static start the span's first fix
        // (the static test found every fix of the span within 3σ of the first), else the
        // first fix the fit used
        let lever = Vector3::from(config.gnss.lever_arm);
        let still_fix = gnss.iter().find(|e| e.t > t0 && e.t <= still.span.1);
        let (pos, std, at) = match still_fix.filter(|_| is_static) {
            Some(e) => {
                let offset = m.att.rotate(&lever);
                let (lat, lon, h) =
                    ins_gnss_core::earth::local_ned_to_geodetic(e.pos.tuple(), &-offset);
                (ins_gnss_core::position::GeoPos::new(lat, lon, h), e.pos_std, e.t)
            }
            None => {
                let (pos, std) = m.position_from_first_fix(&lever);
                (pos, std, m.t_a + m.first_fix.0)
            }
        };
        let (lat, lon, h) = pos.tuple();
        config.init.position = Some([lat.to_degrees(), lon.to_degrees(), h]);
        if i.position_std.is_none() {
            // floored at 1 cm
            config.init.position_std = Some(std.map(|v| v.max(0.01)).into());
        }
        let s = config.init.position_std.unwrap_or_default();
        report.push(format!(
            "init: position {:.8}°, {:.8}°, {:.3} m from the GNSS fix at {:.3} s (the first \
             of the static start, else the first the alignment used; {span}; lever arm \
             applied), σ {} m",
            lat.to_degrees(),
            lon.to_degrees(),
            h,
            at,
            fmt3(s, 3)
        ));
    }
    if i.velocity.is_none() {
        let (v, sd, how) = if is_static {
            (Vector3::zeros(), Vector3::repeat(0.02), "0 on the static start".to_string())
        } else {
            (
                m.vel,
                m.vel_std.map(|v| v.max(0.05)),
                format!("from the in-motion alignment ({span})"),
            )
        };
        config.init.velocity = Some(v.into());
        if i.velocity_std.is_none() {
            config.init.velocity_std = Some(sd.into());
        }
        report.push(format!(
            "init: velocity {} m/s {how}, σ {} m/s",
            fmt3(v.into(), 3),
            fmt3(config.init.velocity_std.unwrap_or_default(), 3)
        ));
    }
    fill_rest(config, report, still, is_static, Some(m))
}

/// The gyro bias and the 1σ that the data cannot give.
fn fill_rest(
    config: &mut Config,
    report: &mut Vec<String>,
    still: &StaticStart,
    is_static: bool,
    m: Option<&MotionFit>,
) -> Result<(), String> {
    let i = config.init.clone();
    let d = core::f64::consts::PI / 180.0;
    if i.gyro_bias.is_none() {
        if is_static {
            let att = config
                .init
                .attitude
                .map(|a| manifolds::So3::from_euler(a[0] * d, a[1] * d, a[2] * d));
            let lat = config.init.position.map_or(0.0, |p| p[0] * d);
            let b = match att {
                Some(att) => static_gyro_bias(still, &att, lat),
                None => still.mean_w,
            } / DEG_PER_H;
            config.init.gyro_bias = Some(b.into());
            if i.gyro_bias_std.is_none() {
                // the mean's white noise, and the instability over the run (the
                // configured Gauss–Markov σ, else 10 deg/h)
                let instability = config.imu_noise.gyro_bias_std.unwrap_or([10.0; 3]);
                let mean = still.mean_w_std() / DEG_PER_H;
                config.init.gyro_bias_std =
                    Some(Vector3::from_fn(|k, _| mean[k].hypot(instability[k]).max(1.0)).into());
            }
            report.push(format!(
                "init: gyro bias {} deg/h from the static start {:.3}–{:.3} s, σ {} deg/h",
                fmt3(b.into(), 2),
                still.span.0,
                still.span.1,
                fmt3(config.init.gyro_bias_std.unwrap_or_default(), 1)
            ));
        } else {
            config.init.gyro_bias = Some([0.0; 3]);
            if i.gyro_bias_std.is_none() {
                config.init.gyro_bias_std = Some([DEFAULT_GYRO_BIAS_STD; 3]);
                report.push(format!(
                    "init: gyro bias 0, σ {DEFAULT_GYRO_BIAS_STD} deg/h (no static start of \
                     `align.min_static` = {} s to measure it)",
                    config.align.min_static
                ));
            }
        }
    }
    if i.accel_bias.is_none() {
        config.init.accel_bias = Some([0.0; 3]);
    }
    if i.accel_bias_std.is_none() {
        config.init.accel_bias_std = Some(crate::config::DEFAULT_ACCEL_BIAS_STD);
    }
    // 1σ asked for without the value: defaults that the data would have given
    let fit = m.map(|m| (m.att_std.map(|v| v.to_degrees().max(0.5)), m.pos_std, m.vel_std));
    if config.init.attitude_std.is_none() {
        config.init.attitude_std = Some(fit.map_or([1.0, 1.0, 5.0], |f| f.0.into()));
    }
    if config.init.position_std.is_none() {
        config.init.position_std = Some(fit.map_or([5.0; 3], |f| f.1.map(|v| v.max(0.01)).into()));
    }
    if config.init.velocity_std.is_none() {
        config.init.velocity_std = Some(fit.map_or([0.1; 3], |f| f.2.map(|v| v.max(0.02)).into()));
    }
    if config.init.gyro_bias_std.is_none() {
        config.init.gyro_bias_std = Some([DEFAULT_GYRO_BIAS_STD; 3]);
    }
    Ok(())
}
