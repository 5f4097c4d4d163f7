//! A run on a ROS recording (`[data.ros]`): its messages read once into the IMU and GNSS
//! formats' rows, and the configuration completed from it (the IMU rate, and the noise
//! when asked).

use super::*;
use crate::config::FromRecording;
use ins_gnss_io::ros::{Recording, Selection, Stamps};

/// The configuration keys of the three topics, named in errors.
const TOPIC_KEYS: [&str; 3] =
    ["data.ros.imu_topic", "data.ros.fix_topic", "data.ros.odometry_topic"];

/// rad/√s → deg/√h, and m/s/√s → m/s/√h.
const PER_ROOT_SECOND_TO_PER_ROOT_HOUR: f64 = 60.0;

/// Read `config`'s recording: the configuration the run uses (the rate, the IMU format,
/// and the noise when asked, from the recording), the rows, and the summary's lines
/// about it.
pub(crate) fn open_recording(config: &Config) -> Result<(Config, Inputs), RunError> {
    let Some(ros) = &config.data.ros else {
        return Err(bad_map("data.ros", "no recording configured".into()));
    };
    config.require_inputs().map_err(RunError::Config)?;
    let select = Selection {
        imu: ros.imu_topic.clone(),
        fix: ros.fix_topic.clone(),
        odometry: ros.odometry_topic.clone(),
        use_odometry: config.vehicle.odometer.is_some(),
        stamps: match ros.stamps {
            crate::config::StampsName::Header => Stamps::Header,
            crate::config::StampsName::Receive => Stamps::Receive,
        },
    };
    let rec = Recording::read(&ros.recording, &select, TOPIC_KEYS)?;
    let mut from = FromRecording::default();
    let mut notes = Vec::new();
    let rate = rec.imu_rate().ok_or_else(|| {
        RunError::NoData(format!(
            "{}: fewer than two IMU messages on {}, or their stamps do not advance",
            rec.path.display(),
            rec.imu_topic.0
        ))
    })?;
    let container = match rec.container {
        ins_gnss_io::ros::Container::Bag => "ROS 1 bag",
        ins_gnss_io::ros::Container::Mcap => "MCAP",
    };
    notes.push(format!(
        "recording {} ({container}, {} stamps): IMU {} (frame {}) {} messages, median rate \
         {rate:.2} Hz{}",
        rec.path.display(),
        match select.stamps {
            Stamps::Header => "header",
            Stamps::Receive => "receive",
        },
        rec.imu_topic.0,
        rec.imu_topic.1,
        rec.imu.len(),
        if config.data.imu_rate == 0.0 { " (data.imu_rate)" } else { "" },
    ));
    from.imu_rate = rate;
    let imu_rate = if config.data.imu_rate == 0.0 { rate } else { config.data.imu_rate };
    if ros.imu_noise_from_covariance {
        from.noise = Some(noise_from_covariance(&rec, imu_rate, &mut notes)?);
    }
    from_transforms(&rec, ros.base_frame.as_deref(), config, &mut from, &mut notes);
    let (imu, imu_width, longest) = rec.imu_rows();
    if let Some((topic, frame)) = &rec.odometry_topic {
        notes.push(format!(
            "odometer: {topic} (child frame {frame}) {} messages, its forward speed linear \
             between messages (longest interval {longest:.2} s)",
            rec.odometry.len()
        ));
    }
    let quality = config.gnss.quality.factors().map_err(|e| bad_map("gnss.quality", e))?;
    let (gnss, dropped) = rec.fix_rows(&quality, config.gnss.position_std, "gnss.position_std")?;
    notes.push(format!(
        "fixes: {} (frame {}) {} messages, σ from their covariances, {dropped} without a position or of a dropped \
         quality left out",
        rec.fix_topic.0,
        rec.fix_topic.1,
        rec.fixes.len()
    ));
    let cfg = config.completed_by_recording(&from).map_err(|message| {
        RunError::Config(crate::config::ConfigError { path: ros.recording.clone(), message })
    })?;
    let inputs = Inputs::Recording {
        imu: imu.into(),
        imu_width,
        gnss: gnss.into(),
        names: (rec.imu_name(), rec.fix_name()),
        notes,
    };
    Ok((cfg, inputs))
}

/// ARW (deg/√h) and VRW (m/s/√h) from the IMU messages' covariances at `imu_rate` Hz
/// (`data.ros.imu_noise_from_covariance`), with their note.
fn noise_from_covariance(
    rec: &Recording,
    imu_rate: f64,
    notes: &mut Vec<String>,
) -> Result<([f64; 3], [f64; 3]), RunError> {
    let Some((w, f)) = rec.imu_sigma() else {
        return Err(bad_map(
            "data.ros.imu_noise_from_covariance",
            format!(
                "the IMU messages on {} give no covariances (all zero or −1): give \
                 `imu_noise.arw` and `imu_noise.vrw`",
                rec.imu_topic.0
            ),
        ));
    };
    let root_dt = (1.0 / imu_rate).sqrt() * PER_ROOT_SECOND_TO_PER_ROOT_HOUR;
    let (arw, vrw) = (w.map(|s| s.to_degrees() * root_dt), f.map(|s| s * root_dt));
    notes.push(format!(
        "IMU noise from the messages' covariances: σ {:.4} rad/s, {:.4} m/s² per sample → \
         ARW {:.3} deg/√h, VRW {:.4} m/s/√h (x axis)",
        w[0], f[0], arw[0], vrw[0]
    ));
    Ok((arw, vrw))
}

/// The mounting and lever arms from the recording's static transforms, where the
/// configuration (`cfg`) leaves them: the IMU's frame in the body frame (`base` or the
/// odometry's child frame, else `base_link`; ROS's FLU turned into FRD), and from the IMU
/// the antenna (the fixes' frame) and the body origin (the odometer's point).
fn from_transforms(
    rec: &Recording,
    base: Option<&str>,
    cfg: &Config,
    from: &mut FromRecording,
    notes: &mut Vec<String>,
) {
    use nalgebra::{Matrix3, Vector3};
    if rec.transforms.is_empty() || cfg.imu.mounting.is_some() {
        return;
    }
    let base = base
        .map(str::to_string)
        .or_else(|| rec.odometry_topic.as_ref().map(|(_, child)| child.clone()))
        .unwrap_or_else(|| "base_link".into());
    let Some((r, t_imu)) = rec.transform(&base, &rec.imu_topic.1) else {
        notes.push(format!(
            "/tf_static: no chain from {base} to the IMU's frame {} (imu.mounting: the sensor \
             axes are the body's)",
            rec.imu_topic.1
        ));
        return;
    };
    // FLU (ROS) → FRD (the filter's body frame)
    let flip = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    let c_bs = flip * r;
    let rows = [0, 1, 2].map(|i| [c_bs[(i, 0)], c_bs[(i, 1)], c_bs[(i, 2)]]);
    from.mounting = Some(rows);
    let (roll, pitch, yaw) = nalgebra::Rotation3::from_matrix(&c_bs).euler_angles();
    notes.push(format!(
        "imu.mounting from /tf_static ({base} → {}): roll {:.2}°, pitch {:.2}°, yaw {:.2}° \
         (FRD body)",
        rec.imu_topic.1,
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees()
    ));
    let from_imu = |t: Vector3<f64>| -> [f64; 3] { (flip * (t - t_imu)).into() };
    if cfg.gnss.lever_arm == [0.0; 3]
        && let Some((_, t_ant)) = rec.transform(&base, &rec.fix_topic.1)
    {
        let lever = from_imu(t_ant);
        from.lever_arm = Some(lever);
        notes.push(format!(
            "gnss.lever_arm from /tf_static ({base} → {}): {lever:?} m (FRD)",
            rec.fix_topic.1
        ));
    }
    if cfg.vehicle.odometer.as_ref().is_some_and(|o| o.lever_arm == [0.0; 3]) {
        let lever = from_imu(Vector3::zeros());
        from.odometer_lever_arm = Some(lever);
        notes.push(format!(
            "vehicle.odometer.lever_arm from /tf_static ({base}'s origin): {lever:?} m (FRD)"
        ));
    }
}
