//! What `[init]` does not give, found from the static start and the in-motion fit.

use super::*;

/// Fill `[init]` from the static start and the in-motion fit.
pub(super) fn fill_init(
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
