//! What `[init]` does not give, found from the static start and the in-motion fit.

use super::*;

/// What the start found in the data: the static start (and whether it lasts
/// `align.min_static`), the in-motion fit, the heading bank's answer.
pub(super) struct Found<'a> {
    pub still: &'a StaticStart,
    pub is_static: bool,
    pub motion: Option<&'a MotionFit>,
    pub bank: Option<&'a BankHeading>,
    /// The gyro bias's 1σ the heading drifts with, rad/s.
    pub bias_std: f64,
}

/// Fill `[init]` from the static start, the heading bank and the in-motion fit.
pub(super) fn fill_init(
    config: &Config,
    init: &mut InitialParts,
    report: &mut Vec<String>,
    found: &Found<'_>,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
) -> Result<(), String> {
    let Found { still, is_static, motion, bank, bias_std } = *found;
    let i = init.clone();
    if let (true, Some(b), None) = (is_static, bank, i.attitude) {
        fill_from_bank(config, init, report, still, b, gnss, t0)?;
        return fill_rest(config, init, report, still, is_static, motion);
    }
    // moving, and the fit cannot tell the heading (too little motion for its span, fixes
    // too noisy for the speed): the bank from the first sample
    let fit_heading =
        motion.is_some_and(|m| m.att_std.z.hypot(0.25f64.to_radians()) <= MAX_HEADING_STD);
    let mut bank_says = String::new();
    if !is_static
        && i.attitude.is_none()
        && !fit_heading
        && let Some(b) = moving_bank(config, imu, gnss, t0, bias_std)
    {
        if b.bank.std.hypot(0.25f64.to_radians()) <= MAX_HEADING_STD {
            fill_from_moving_bank(config, init, report, &b, gnss, t0)?;
            return fill_rest(config, init, report, still, is_static, None);
        }
        bank_says = format!(
            "; a bank of {BANK_SIZE} headings over {} fixes leaves it at ±{:.0}°",
            b.bank.fixes,
            b.bank.std.to_degrees()
        );
    }
    if i.attitude.is_none()
        && let Some(a) = antenna_heading(config, imu, gnss, t0)
    {
        let took =
            fill_from_antennas(config, init, report, still, is_static, motion, imu, gnss, t0, a)?;
        if took && motion.is_none() {
            return fill_rest(config, init, report, still, is_static, None);
        }
    }
    let i = init.clone();
    let need_motion = i.attitude.is_none() || i.position.is_none() || i.velocity.is_none();
    let m = match motion {
        Some(m) => m,
        None if need_motion => return Err(no_motion_fit(config, &i, t0)),
        None => {
            // only 1σ or the gyro bias missing
            return fill_rest(config, init, report, still, is_static, None);
        }
    };
    let span = format!("{} fixes over {:.3}–{:.3} s", m.fixes, m.t_a, m.t_b);
    if i.attitude.is_none() {
        attitude_from_motion(init, report, found, m, &span, &bank_says)?;
    }
    if i.position.is_none() {
        position_from_motion(config, init, report, found, m, &span, gnss, t0);
    }
    if i.velocity.is_none() {
        velocity_from_motion(init, report, found, m, &span);
    }
    fill_rest(config, init, report, still, is_static, Some(m))
}

/// The refusal when the parts of the initial state that need the in-motion fit are
/// missing and the fit found nothing.
fn no_motion_fit(config: &Config, i: &InitialParts, t0: f64) -> String {
    format!(
        "cannot find the initial {} from the data: fewer than 8 GNSS fixes, or no motion to \
         tell the heading, within `align.max_time` = {} s of the start ({t0:.3} s); give \
         `init.attitude`, `init.position` and `init.velocity`, or a longer `align.max_time`",
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
    )
}

/// The attitude from the in-motion fit (levelled on the static start when there is
/// one); refused when the fit cannot tell the heading (`bank_says` what the bank found).
fn attitude_from_motion(
    init: &mut InitialParts,
    report: &mut Vec<String>,
    found: &Found<'_>,
    m: &MotionFit,
    span: &str,
    bank_says: &str,
) -> Result<(), String> {
    let Found { still, is_static, .. } = *found;
    let given_std = init.attitude_std.is_some();
    let (m_roll, m_pitch, m_yaw) = m.att.euler();
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
            "the in-motion alignment finds the heading ({:.1}°) only to ±{:.0}° \
             ({span}){bank_says}: too little motion; give `init.attitude` (and \
             `init.attitude_std`), or a longer `align.max_time`",
            m_yaw.to_degrees(),
            yaw_std.to_degrees()
        ));
    }
    let tilt_std = if is_static {
        0.5f64.to_radians()
    } else {
        m.att_std.x.max(m.att_std.y).max(0.5f64.to_radians())
    };
    init.attitude = Some(Vector3::new(roll, pitch, m_yaw));
    if !given_std {
        init.attitude_std = Some(Vector3::new(tilt_std, tilt_std, yaw_std));
    }
    let s = init.attitude_std.unwrap_or_default().map(f64::to_degrees);
    report.push(format!(
        "init: roll {:.3}°, pitch {:.3}° {how}, σ {:.2}°; heading {:.3}° from the in-motion \
         alignment ({span}), σ {:.2}°",
        roll.to_degrees(),
        pitch.to_degrees(),
        s[0],
        m_yaw.to_degrees(),
        s[2]
    ));
    Ok(())
}

/// The position from a fix moved back to the start by the fit's attitude and lever arm.
#[allow(clippy::too_many_arguments)]
fn position_from_motion(
    config: &Config,
    init: &mut InitialParts,
    report: &mut Vec<String>,
    found: &Found<'_>,
    m: &MotionFit,
    span: &str,
    gnss: &[GnssEpoch],
    t0: f64,
) {
    let Found { still, is_static, .. } = *found;
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
            (ins_gnss_core::GeoPos::new(lat, lon, h), e.pos_std, e.t)
        }
        None => {
            let (pos, std) = m.position_from_first_fix(&lever);
            (pos, std, m.t_a + m.first_fix.0)
        }
    };
    let (lat, lon, h) = pos.tuple();
    init.position = Some(pos);
    if init.position_std.is_none() {
        // floored at 1 cm
        init.position_std = Some(std.map(|v| v.max(0.01)));
    }
    let s = init.position_std.unwrap_or_default().into();
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

/// The velocity: 0 on a static start, else the in-motion fit's.
fn velocity_from_motion(
    init: &mut InitialParts,
    report: &mut Vec<String>,
    found: &Found<'_>,
    m: &MotionFit,
    span: &str,
) {
    let (v, sd, how) = if found.is_static {
        (Vector3::zeros(), Vector3::repeat(0.02), "0 on the static start".to_string())
    } else {
        (m.vel, m.vel_std.map(|v| v.max(0.05)), format!("from the in-motion alignment ({span})"))
    };
    set_velocity(init, report, v, sd, &how);
}

/// The initial velocity `v` (and its 1σ `sd` where none is given), with its report line
/// (`how` it was found).
fn set_velocity(
    init: &mut InitialParts,
    report: &mut Vec<String>,
    v: Vector3<f64>,
    sd: Vector3<f64>,
    how: &str,
) {
    init.velocity = Some(v);
    if init.velocity_std.is_none() {
        init.velocity_std = Some(sd);
    }
    report.push(format!(
        "init: velocity {} m/s {how}, σ {} m/s",
        fmt3(v.into(), 3),
        fmt3(init.velocity_std.unwrap_or_default().into(), 3)
    ));
}

/// The gyro bias and the 1σ that the data cannot give.
pub(super) fn fill_rest(
    config: &Config,
    init: &mut InitialParts,
    report: &mut Vec<String>,
    still: &StaticStart,
    is_static: bool,
    m: Option<&MotionFit>,
) -> Result<(), String> {
    let i = init.clone();
    if i.gyro_bias.is_none() {
        if is_static {
            let att = init.attitude.map(|a| manifolds::So3::from_euler(a.x, a.y, a.z));
            let lat = init.position.map_or(0.0, |p| p.lat);
            let b = match att {
                Some(att) => static_gyro_bias(still, &att, lat),
                None => still.mean_w,
            };
            init.gyro_bias = Some(b);
            if i.gyro_bias_std.is_none() {
                // the mean's white noise, and the instability over the run (the
                // configured Gauss–Markov σ, else 10 deg/h), at least 1 deg/h
                let instability = config.imu_noise.gyro_bias_std.unwrap_or([10.0; 3]);
                let mean = still.mean_w_std() / DEG_PER_H;
                let std = Vector3::from_fn(|k, _| mean[k].hypot(instability[k]).max(1.0));
                init.gyro_bias_std = Some(std * DEG_PER_H);
            }
            report.push(format!(
                "init: gyro bias {} deg/h from the static start {:.3}–{:.3} s, σ {} deg/h",
                fmt3((b / DEG_PER_H).into(), 2),
                still.span.0,
                still.span.1,
                fmt3((init.gyro_bias_std.unwrap_or_default() / DEG_PER_H).into(), 1)
            ));
        } else {
            init.gyro_bias = Some(Vector3::zeros());
            if i.gyro_bias_std.is_none() {
                init.gyro_bias_std = Some(Vector3::repeat(DEFAULT_GYRO_BIAS_STD * DEG_PER_H));
                report.push(format!(
                    "init: gyro bias 0, σ {DEFAULT_GYRO_BIAS_STD} deg/h (no static start of \
                     `align.min_static` = {} s to measure it)",
                    config.align.min_static
                ));
            }
        }
    }
    if i.accel_bias.is_none() {
        init.accel_bias = Some(Vector3::zeros());
    }
    if i.accel_bias_std.is_none() {
        init.accel_bias_std = Some(Vector3::from(crate::config::DEFAULT_ACCEL_BIAS_STD) * MGAL);
    }
    // 1σ asked for without the value: defaults that the data would have given
    let d = core::f64::consts::PI / 180.0;
    let fit = m.map(|m| (m.att_std.map(|v| v.max(0.5 * d)), m.pos_std, m.vel_std));
    if init.attitude_std.is_none() {
        init.attitude_std = Some(fit.map_or(Vector3::new(1.0, 1.0, 5.0) * d, |f| f.0));
    }
    if init.position_std.is_none() {
        init.position_std = Some(fit.map_or(Vector3::repeat(5.0), |f| f.1.map(|v| v.max(0.01))));
    }
    if init.velocity_std.is_none() {
        init.velocity_std = Some(fit.map_or(Vector3::repeat(0.1), |f| f.2.map(|v| v.max(0.02))));
    }
    if init.gyro_bias_std.is_none() {
        init.gyro_bias_std = Some(Vector3::repeat(DEFAULT_GYRO_BIAS_STD * DEG_PER_H));
    }
    Ok(())
}

/// The headings of two antennas at the first fixes that have one (up to
/// [`ANTENNA_CANDIDATES`]): time, measured baseline heading and its σ (rad), when the run
/// uses them.
pub(super) struct AntennaStart {
    list: Vec<(f64, f64, f64)>,
    baseline: Vector3<f64>,
}

/// How many of the first fixes' headings the start compares before it takes one.
const ANTENNA_CANDIDATES: usize = 5;

pub(super) fn antenna_heading(
    config: &Config,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
) -> Option<AntennaStart> {
    let cfg = config.gnss.heading.config()?;
    let end = imu.last()?.t;
    // the first fixes with a heading (a moving-base receiver may need a few epochs)
    let list: Vec<(f64, f64, f64)> = gnss
        .iter()
        .filter(|e| e.t >= t0 && e.t <= end)
        .filter_map(|e| e.heading.map(|m| (e.t, m.heading, cfg.heading_std(&m))))
        .filter(|m| m.1.is_finite())
        .take(ANTENNA_CANDIDATES)
        .collect();
    (!list.is_empty()).then_some(AntennaStart { list, baseline: cfg.baseline })
}

/// Of the candidates' headings turned back to the start (`yaws`: yaw at the start and its
/// σ, rad), the first that at least half of the others agree with (within 3σ of both and
/// 0.5°): a wrong fix of the moving-base receiver at the first epoch is not the start's
/// heading. `None` when none has that support.
fn agreed(yaws: &[(f64, f64)]) -> Option<usize> {
    let n = yaws.len();
    (0..n).find(|&i| {
        let support = (0..n)
            .filter(|&j| j != i)
            .filter(|&j| {
                let d = ins_gnss_core::heading::wrap(yaws[i].0 - yaws[j].0).abs();
                d <= 3.0 * yaws[i].1.hypot(yaws[j].1) + 0.5f64.to_radians()
            })
            .count();
        2 * support >= n - 1
    })
}

/// Roll, pitch, how they were found and their 1σ (rad) for the heading of two antennas:
/// levelled on the static start, else the in-motion fit's, else the first second's mean
/// specific force.
fn tilt_for_antennas(
    still: &StaticStart,
    is_static: bool,
    motion: Option<&MotionFit>,
    imu: &[ImuSample],
    t0: f64,
) -> (f64, f64, String, f64) {
    if is_static {
        let (r, p) = level(&still.mean_f);
        let how = format!("levelled over the static start ({:.1} s)", still.duration());
        (r, p, how, 0.5f64.to_radians())
    } else if let Some(m) = motion {
        let (r, p, _) = m.att.euler();
        let how = format!("from the in-motion alignment ({} fixes)", m.fixes);
        (r, p, how, m.att_std.x.max(m.att_std.y).max(0.5f64.to_radians()))
    } else {
        // the first second's mean specific force: a moving vehicle's accelerations tilt
        // it, hence the wide σ
        let first: Vec<&ImuSample> = imu.iter().take_while(|s| s.t <= t0 + 1.0).collect();
        let dt: f64 = first.iter().map(|s| s.dt).sum();
        let f = first.iter().fold(Vector3::zeros(), |acc, s| acc + s.dvel) / dt.max(1e-9);
        let (r, p) = level(&f);
        (r, p, "levelled over the first second (no static start)".to_string(), 3f64.to_radians())
    }
}

/// The attitude from the levelling (static start, in-motion fit, else the first second's
/// mean specific force) and the heading of two antennas at the first fix, turned back to
/// the start time by the gyro; without an in-motion fit, the position from the first fix
/// and the velocity (0 standing, else the fixes').
#[allow(clippy::too_many_arguments)]
fn fill_from_antennas(
    config: &Config,
    init: &mut InitialParts,
    report: &mut Vec<String>,
    still: &StaticStart,
    is_static: bool,
    motion: Option<&MotionFit>,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
    a: AntennaStart,
) -> Result<bool, String> {
    let i = init.clone();
    let (roll, pitch, how, tilt_std) = tilt_for_antennas(still, is_static, motion, imu, t0);
    // each heading turned back from its fix to the start time along the gyro (level axes)
    let tilted = manifolds::So3::from_euler(roll, pitch, 0.0).rotate(&a.baseline);
    let yaws: Vec<(f64, f64)> = a
        .list
        .iter()
        .map(|&(t, psi, std)| {
            let turn: f64 = imu
                .iter()
                .filter(|s| s.t > t0 && s.t <= t + 1e-9)
                .map(|s| (s.dtheta.y * roll.sin() + s.dtheta.z * roll.cos()) / pitch.cos())
                .sum();
            (ins_gnss_core::heading::wrap(psi - tilted.y.atan2(tilted.x) - turn), std)
        })
        .collect();
    let Some(k) = agreed(&yaws) else {
        report.push(format!(
            "start: the two antennas' headings at the first {} fixes disagree beyond their σ \
             (turned back to the start: {} deg; wrong fixes of the moving-base receiver, or \
             `gnss.heading.std` too small): the heading from the motion instead, the \
             antennas' headings judged by the filter's gate",
            yaws.len(),
            yaws.iter().map(|y| format!("{:.2}", y.0.to_degrees())).collect::<Vec<_>>().join(", ")
        ));
        return Ok(false);
    };
    let (yaw, std) = yaws[k];
    let at = a.list[k].0;
    let which = match gnss.first() {
        Some(f) if f.t == at => "the first fix".to_string(),
        _ => "a later fix".to_string(),
    };
    let yaw_std = std.hypot(0.05f64.to_radians());
    init.attitude = Some(Vector3::new(roll, pitch, yaw));
    if i.attitude_std.is_none() {
        init.attitude_std = Some(Vector3::new(tilt_std, tilt_std, yaw_std));
    }
    let s = init.attitude_std.unwrap_or_default().map(f64::to_degrees);
    report.push(format!(
        "init: roll {:.3}°, pitch {:.3}° {how}, σ {:.2}°; heading {:.3}° from the two antennas \
         at {which} ({at:.3} s), σ {:.2}°",
        roll.to_degrees(),
        pitch.to_degrees(),
        s[0],
        yaw.to_degrees(),
        s[2]
    ));
    if motion.is_some() {
        return Ok(true);
    }
    let att = manifolds::So3::from_euler(roll, pitch, yaw);
    first_fix_start(config, init, report, is_static, &att, gnss, t0)?;
    Ok(true)
}

/// Without an in-motion fit: the position from the first fix (the lever arm turned by
/// `att`) and the velocity (0 standing, else the fix's own or the first two fixes').
fn first_fix_start(
    config: &Config,
    init: &mut InitialParts,
    report: &mut Vec<String>,
    is_static: bool,
    att: &manifolds::So3,
    gnss: &[GnssEpoch],
    t0: f64,
) -> Result<(), String> {
    let lever = Vector3::from(config.gnss.lever_arm);
    let e = &gnss[0];
    if init.position.is_none() {
        let (lat, lon, h) =
            ins_gnss_core::earth::local_ned_to_geodetic(e.pos.tuple(), &-att.rotate(&lever));
        init.position = Some(GeoPos::new(lat, lon, h));
        if init.position_std.is_none() {
            init.position_std = Some(e.pos_std.map(|v| v.max(0.01)));
        }
        report.push(format!(
            "init: position {:.8}°, {:.8}°, {:.3} m from the GNSS fix at {:.3} s (lever arm \
             applied), σ {} m",
            lat.to_degrees(),
            lon.to_degrees(),
            h,
            e.t,
            fmt3(init.position_std.unwrap_or_default().into(), 3)
        ));
    }
    if init.velocity.is_none() {
        let (v, sd, how) = if is_static {
            (Vector3::zeros(), Vector3::repeat(0.02), "0 on the static start".to_string())
        } else if let Some((v, sd)) = e.vel {
            (v, sd.map(|s| s.max(0.05)), format!("the fix's at {:.3} s", e.t))
        } else if let Some(f) = gnss.get(1).filter(|f| f.t > e.t) {
            let dt = f.t - e.t;
            let dp = ins_gnss_core::earth::geodetic_to_local_ned(e.pos.tuple(), f.pos.tuple());
            let sd = (e.pos_std.component_mul(&e.pos_std) + f.pos_std.component_mul(&f.pos_std))
                .map(|v| v.sqrt() / dt + 0.05);
            (dp / dt, sd, format!("from the fixes at {:.3} and {:.3} s", e.t, f.t))
        } else {
            return Err(format!(
                "cannot find the initial velocity from the data: one GNSS fix within \
                 `align.max_time` = {} s of the start ({t0:.3} s); give `init.velocity`",
                config.align.max_time
            ));
        };
        set_velocity(init, report, v, sd, &how);
    }
    Ok(())
}

/// `[init]` on a static start from the heading bank ([`heading_bank`]): roll and pitch
/// levelled, the heading the bank found over the motion after it (the body did not turn
/// while it stood), the position from the static start's first fix, the velocity 0.
fn fill_from_bank(
    config: &Config,
    init: &mut InitialParts,
    report: &mut Vec<String>,
    still: &StaticStart,
    b: &BankHeading,
    gnss: &[GnssEpoch],
    t0: f64,
) -> Result<(), String> {
    let i = init.clone();
    let (roll, pitch) = level(&still.mean_f);
    let yaw_std = b.std.hypot(0.25f64.to_radians());
    if yaw_std > MAX_HEADING_STD {
        return Err(format!(
            "the bank of {BANK_SIZE} headings leaves the heading at ±{:.0}° after {} fixes of \
             motion ({:.3}–{:.3} s): too little motion after the static start; give \
             `init.attitude` (and `init.attitude_std`), or a longer `align.max_time`",
            yaw_std.to_degrees(),
            b.fixes,
            still.span.1,
            b.t_end
        ));
    }
    let att = manifolds::So3::from_euler(roll, pitch, b.heading);
    init.attitude = Some(Vector3::new(roll, pitch, b.heading));
    if i.attitude_std.is_none() {
        let tilt = 0.5f64.to_radians();
        init.attitude_std = Some(Vector3::new(tilt, tilt, yaw_std));
    }
    let s = init.attitude_std.unwrap_or_default().map(f64::to_degrees);
    report.push(format!(
        "init: roll {:.3}°, pitch {:.3}° levelled over the static start ({:.1} s), σ {:.2}°; \
         heading {:.3}° from a bank of {BANK_SIZE} hypotheses over {} fixes of motion \
         ({:.3}–{:.3} s, largest weight {:.3}), σ {:.2}°",
        roll.to_degrees(),
        pitch.to_degrees(),
        still.duration(),
        s[0],
        b.heading.to_degrees(),
        b.fixes,
        still.span.1,
        b.t_end,
        b.weight,
        s[2]
    ));
    if i.position.is_none() {
        position_on_static_start(config, init, report, still, &att, gnss, t0)?;
    }
    if i.velocity.is_none() {
        set_velocity(
            init,
            report,
            Vector3::zeros(),
            Vector3::repeat(0.02),
            "0 on the static start",
        );
    }
    Ok(())
}

/// The position from the static start's first fix, the lever arm turned by `att`.
fn position_on_static_start(
    config: &Config,
    init: &mut InitialParts,
    report: &mut Vec<String>,
    still: &StaticStart,
    att: &manifolds::So3,
    gnss: &[GnssEpoch],
    t0: f64,
) -> Result<(), String> {
    let Some(e) = gnss.iter().find(|e| e.t > t0 && e.t <= still.span.1) else {
        return Err(format!(
            "no GNSS fix during the static start ({:.3}–{:.3} s) to start from; give \
             `init.position`",
            still.span.0, still.span.1
        ));
    };
    let offset = att.rotate(&Vector3::from(config.gnss.lever_arm));
    let (lat, lon, h) = ins_gnss_core::earth::local_ned_to_geodetic(e.pos.tuple(), &-offset);
    init.position = Some(GeoPos::new(lat, lon, h));
    if init.position_std.is_none() {
        init.position_std = Some(e.pos_std.map(|v| v.max(0.01)));
    }
    report.push(format!(
        "init: position {:.8}°, {:.8}°, {:.3} m from the GNSS fix at {:.3} s (the first of \
         the static start; lever arm applied), σ {} m",
        lat.to_degrees(),
        lon.to_degrees(),
        h,
        e.t,
        fmt3(init.position_std.unwrap_or_default().into(), 3)
    ));
    Ok(())
}

/// `[init]` while moving from the bank ([`moving_bank`]): roll and pitch levelled on the
/// first seconds, the heading the bank found, the velocity of the first fixes' line, the
/// position from the first fix moved back to the start by it.
fn fill_from_moving_bank(
    config: &Config,
    init: &mut InitialParts,
    report: &mut Vec<String>,
    b: &MovingStart,
    gnss: &[GnssEpoch],
    t0: f64,
) -> Result<(), String> {
    let i = init.clone();
    let yaw_std = b.bank.std.hypot(0.25f64.to_radians());
    let att = manifolds::So3::from_euler(b.roll, b.pitch, b.bank.heading);
    init.attitude = Some(Vector3::new(b.roll, b.pitch, b.bank.heading));
    if i.attitude_std.is_none() {
        init.attitude_std = Some(Vector3::new(MOVING_TILT_STD, MOVING_TILT_STD, yaw_std));
    }
    let s = init.attitude_std.unwrap_or_default().map(f64::to_degrees);
    report.push(format!(
        "init: roll {:.3}°, pitch {:.3}° levelled on the first {ACCEL_SPAN} s (moving), σ \
         {:.2}°; heading {:.3}° from a bank of {BANK_SIZE} hypotheses over {} fixes \
         ({t0:.3}–{:.3} s, largest weight {:.3}; the in-motion fit could not tell it), σ {:.2}°",
        b.roll.to_degrees(),
        b.pitch.to_degrees(),
        s[0],
        b.bank.heading.to_degrees(),
        b.bank.fixes,
        b.bank.t_end,
        b.bank.weight,
        s[2]
    ));
    if i.position.is_none() {
        let Some(e) = gnss.iter().find(|e| e.t > t0) else {
            return Err("no GNSS fix after the start; give `init.position`".into());
        };
        let dt = e.t - t0;
        let offset = att.rotate(&Vector3::from(config.gnss.lever_arm)) + b.vel * dt;
        let (lat, lon, h) = ins_gnss_core::earth::local_ned_to_geodetic(e.pos.tuple(), &-offset);
        init.position = Some(GeoPos::new(lat, lon, h));
        if i.position_std.is_none() {
            let std = e.pos_std.zip_map(&b.vel_std, |p, v| p.hypot(v * dt).max(0.01));
            init.position_std = Some(std);
        }
        report.push(format!(
            "init: position {:.8}°, {:.8}°, {:.3} m from the GNSS fix at {:.3} s (moved back by \
             the velocity; lever arm applied), σ {} m",
            lat.to_degrees(),
            lon.to_degrees(),
            h,
            e.t,
            fmt3(init.position_std.unwrap_or_default().into(), 3)
        ));
    }
    if i.velocity.is_none() {
        set_velocity(init, report, b.vel, b.vel_std, "from a line through the first fixes");
    }
    Ok(())
}
