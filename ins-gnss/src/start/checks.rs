//! The checks of the data against the declared rate, units, axes, mounting and the
//! IMU–GNSS time offset.

use super::*;

/// The column map's key for the axes, or the mounting's.
pub(super) fn axes_key(config: &Config) -> &'static str {
    if config.data.imu_columns.is_some() {
        "`data.imu_columns.axes`"
    } else {
        "`imu.mounting`"
    }
}

/// How many sample intervals after the first the IMU rate check takes the median of.
pub const RATE_SAMPLES: usize = 1000;

/// The span (s) from the first sample over which a start in motion has its mean specific
/// force checked against gravity (a car's accelerations are a fraction of it).
pub const ACCEL_SPAN: f64 = 5.0;

/// The median sample interval against `data.imu_rate`.
pub(super) fn check_rate(config: &Config, imu: &[ImuSample]) -> Result<(), String> {
    let mut dts: Vec<f64> = imu.iter().skip(1).take(RATE_SAMPLES).map(|s| s.dt).collect();
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
pub(super) fn unit_near(
    q: Quantity,
    factor: f64,
    candidates: &[&'static str],
) -> Option<&'static str> {
    candidates
        .iter()
        .filter_map(|u| unit_factor(q, u).ok().map(|f| (u, (f / factor).ln().abs())))
        .filter(|(_, d)| *d < 0.15)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(u, _)| *u)
}

pub(super) fn rates(config: &Config) -> bool {
    config.imu_format() == ins_gnss_io::ImuFormat::Rates
}

/// |f| at rest (or over the first seconds) against normal gravity.
pub(super) fn check_accel_unit(
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
        let t_end = imu[0].t + ACCEL_SPAN;
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
pub(super) fn check_gyro_at_rest(config: &Config, still: &StaticStart) -> Result<(), String> {
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
pub(super) fn gyro_unit_error(config: &Config, factor: f64, why: &str) -> String {
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

/// A left-handed frame: the fit over the whole span (`mirror`) fits decisively better as a
/// mirror image.
pub(super) fn check_mirror(config: &Config, mirror: Option<&MotionFit>) -> Result<(), String> {
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
    Ok(())
}

/// A gyro unit: the fit `m` misfits grossly and the rates scaled by 57.3 or 1/57.3
/// (`fit(scale)`) fit decisively better, and consistently (residuals under 3σ).
pub(super) fn check_gyro_unit(
    config: &Config,
    m: &MotionFit,
    fit: &dyn Fn(f64) -> Option<MotionFit>,
) -> Result<(), String> {
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
                // (and refused only for another unit that is consistent, DESIGN.md
                // decision 12: fixes declared ten times more precise than they are leave
                // every unit a gross misfit, and one of them may fit their wander a few
                // times better — drive-0708 with a 3 m wander declared 0.15 m: 19.3σ as
                // declared, 3.7σ with the rates 57× larger, the declared unit right)
                let consistent = alt.residual < 3.0;
                let fits = alt.residual < m.residual / 5.0 && share(&alt) >= share(m);
                let explains = share(&alt) > 0.8 && share(m) < 0.5;
                if consistent && (fits || explains) {
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

/// The likelihood ratio of the offset found against the stamps as they are beyond which
/// the stamps are refused (DESIGN.md decision 12: refuse only when the declared
/// hypothesis loses overwhelmingly).
pub const TIME_OFFSET_LIKELIHOOD_RATIO: f64 = 1e6;

/// The likelihood ratio beyond which an offset (beyond 3σ) is named in the start's
/// report, the stamps kept.
pub const TIME_OFFSET_REPORTED: f64 = 1e2;

/// An IMU whose time stamps are off the GNSS's: the gyro's turns fit the course better
/// shifted, decisively — the course turned 30° or more, the offset is beyond 3σ, and the
/// likelihood of the residuals shifted against as stamped, `(misfit₀ / misfit_best)^{n/2}`
/// for Gaussian residuals with `n` the pairs' worth as independent samples
/// ([`TimeOffset::effective_pairs`]: fixes whose errors wander give course errors that
/// persist from pair to pair), is beyond [`TIME_OFFSET_LIKELIHOOD_RATIO`]. From
/// [`TIME_OFFSET_REFUSED`] on it is refused naming `data.imu_time_offset` with the value
/// that fits; a smaller one, or one whose ratio is only beyond [`TIME_OFFSET_REPORTED`],
/// is reported and the run goes on as stamped.
///
/// With `calibrate.time_offset` on, a decisive offset is not refused: the value
/// that fits is returned, for the run to apply to the IMU's stamps (the filter's state
/// refines what is left).
pub(super) fn check_time_offset(
    config: &Config,
    t: &TimeOffset,
    report: &mut Vec<String>,
) -> Result<Option<f64>, String> {
    // (the simulated drive, one 90° turn: within 20 ms of 0.3 s and 5 s, none on time,
    // `start_from_data::an_imu_stamped_late_is_named_with_its_offset`; on 20 drives with
    // fixes of centimetres, none named on time, `examples/calibration_campaign.rs`)
    let n = t.effective_pairs();
    let persisting = (n / t.pairs as f64).recip().sqrt();
    let log_ratio = 0.5 * n * (t.misfit_zero / t.misfit_best.max(1e-300)).ln();
    let clear = t.turned >= 30f64.to_radians()
        && log_ratio > TIME_OFFSET_REPORTED.ln()
        && t.offset.abs() > 3.0 * t.std * persisting;
    if !clear {
        return Ok(None);
    }
    let decisive = log_ratio > TIME_OFFSET_LIKELIHOOD_RATIO.ln();
    let fix = config.data.imu_time_offset - t.offset;
    let what = format!(
        "the gyro's turns match the GNSS course {:.3} s (σ {:.3} s) {} the IMU's time stamps \
         say (over {} pairs of moving fixes; misfit {:.4} rad² shifted against {:.4} as \
         stamped, likelihood ratio {:.0e})",
        t.offset.abs(),
        t.std,
        if t.offset > 0.0 { "earlier than" } else { "later than" },
        t.pairs,
        t.misfit_best,
        t.misfit_zero,
        log_ratio.min(700.0).exp()
    );
    if config.calibrate.any() && t.offset.abs() < TIME_OFFSET_REFUSED {
        // (the filter's state estimates an offset this small, its line the summary's; and
        // a lever arm being calibrated slips the antenna's course in turns, `l_x / u`
        // seconds of apparent offset that the declared lever arm does not explain)
        return Ok(None);
    }
    if decisive && config.calibrate.time_offset {
        report.push(format!(
            "IMU–GNSS time offset: {what}: applied to the IMU's stamps (`data.imu_time_offset = \
             {fix:.3}`; `calibrate.time_offset` refines it)"
        ));
        return Ok(Some(fix));
    }
    if decisive && t.offset.abs() >= TIME_OFFSET_REFUSED {
        return Err(format!(
            "`data.imu_time_offset` = {}: {what}: the IMU and the GNSS are on different \
             clocks (a leap second, a latency, a time zone); set `data.imu_time_offset = \
             {fix:.3}`",
            config.data.imu_time_offset
        ));
    }
    let why = if decisive {
        format!("below {TIME_OFFSET_REFUSED} s")
    } else {
        format!("not decisive (below {TIME_OFFSET_LIKELIHOOD_RATIO:.0e})")
    };
    report.push(format!(
        "IMU–GNSS time offset: {what}; {why}, kept as stamped (`data.imu_time_offset = \
         {fix:.3}` would apply it)"
    ));
    Ok(None)
}

/// The GNSS course's turns against the gyro's (a straight start hides a gyro unit from
/// the in-motion fit): a slope near 57 or 1/57 names the unit, a negative one the axes.
pub(super) fn check_turns(config: &Config, t: &TurnRatio, max_time: f64) -> Result<(), String> {
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
