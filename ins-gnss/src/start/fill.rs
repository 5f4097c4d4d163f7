//! What `[init]` does not give, found from the static start and the in-motion fit.

use super::*;

/// Fill `[init]` from the static start and the in-motion fit.
#[allow(clippy::too_many_arguments)]
pub(super) fn fill_init(
    config: &mut Config,
    report: &mut Vec<String>,
    still: &StaticStart,
    is_static: bool,
    motion: Option<&MotionFit>,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
) -> Result<(), String> {
    let i = config.init.clone();
    if i.attitude.is_none() {
        if let Some(a) = antenna_heading(config, imu, gnss, t0) {
            let took =
                fill_from_antennas(config, report, still, is_static, motion, imu, gnss, t0, a)?;
            if took && motion.is_none() {
                return fill_rest(config, report, still, is_static, None);
            }
        }
    }
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
                (ins_gnss_core::GeoPos::new(lat, lon, h), e.pos_std, e.t)
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
pub(super) fn fill_rest(
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

/// The headings of two antennas at the first fixes that have one (up to
/// [`ANTENNA_CANDIDATES`]): time, measured baseline heading and its σ (rad), when the run
/// uses them.
struct AntennaStart {
    list: Vec<(f64, f64, f64)>,
    baseline: Vector3<f64>,
}

/// How many of the first fixes' headings the start compares before it takes one.
const ANTENNA_CANDIDATES: usize = 5;

fn antenna_heading(
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

/// The attitude from the levelling (static start, in-motion fit, else the first second's
/// mean specific force) and the heading of two antennas at the first fix, turned back to
/// the start time by the gyro; without an in-motion fit, the position from the first fix
/// and the velocity (0 standing, else the fixes').
#[allow(clippy::too_many_arguments)]
fn fill_from_antennas(
    config: &mut Config,
    report: &mut Vec<String>,
    still: &StaticStart,
    is_static: bool,
    motion: Option<&MotionFit>,
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t0: f64,
    a: AntennaStart,
) -> Result<bool, String> {
    let i = config.init.clone();
    let (roll, pitch, how, tilt_std) = if is_static {
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
    };
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
    config.init.attitude = Some([roll.to_degrees(), pitch.to_degrees(), yaw.to_degrees()]);
    if i.attitude_std.is_none() {
        config.init.attitude_std =
            Some([tilt_std.to_degrees(), tilt_std.to_degrees(), yaw_std.to_degrees()]);
    }
    let s = config.init.attitude_std.unwrap_or_default();
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
    let lever = Vector3::from(config.gnss.lever_arm);
    let e = &gnss[0];
    if i.position.is_none() {
        let (lat, lon, h) =
            ins_gnss_core::earth::local_ned_to_geodetic(e.pos.tuple(), &-att.rotate(&lever));
        config.init.position = Some([lat.to_degrees(), lon.to_degrees(), h]);
        if i.position_std.is_none() {
            config.init.position_std = Some(e.pos_std.map(|v| v.max(0.01)).into());
        }
        report.push(format!(
            "init: position {:.8}°, {:.8}°, {:.3} m from the GNSS fix at {:.3} s (lever arm \
             applied), σ {} m",
            lat.to_degrees(),
            lon.to_degrees(),
            h,
            e.t,
            fmt3(config.init.position_std.unwrap_or_default(), 3)
        ));
    }
    if i.velocity.is_none() {
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
    Ok(true)
}
