//! The configuration reference, generated from the configuration types (`build.rs` reads
//! the `serde` structs and their doc comments), with each key's unit and example from
//! [`UNITS`] and its default from the types' own defaults.

/// A section (TOML table) of the configuration.
#[derive(Clone, Copy, Debug)]
pub struct SectionDoc {
    /// Dotted path, `data.imu_columns`.
    pub path: &'static str,
    /// What it is (the field's doc comment).
    pub doc: &'static str,
    /// Present only when wanted: its presence turns something on or describes the file.
    pub optional: bool,
    /// Must be present (no default).
    pub required: bool,
}

/// A key of a section.
#[derive(Clone, Copy, Debug)]
pub struct KeyDoc {
    /// The section's path (empty: top level).
    pub section: &'static str,
    /// The key.
    pub name: &'static str,
    /// Its TOML type.
    pub ty: &'static str,
    /// What it means (the field's doc comment).
    pub doc: &'static str,
    /// `serde` supplies a value when the key is absent.
    pub has_default: bool,
    /// Absent means "not set" (found from the data, or the feature off).
    pub optional: bool,
    /// The names an enumeration accepts, with their meaning.
    pub values: &'static [(&'static str, &'static str)],
    /// The enumeration's default name.
    pub enum_default: Option<&'static str>,
}

include!(concat!(env!("OUT_DIR"), "/config_keys.rs"));

/// Each key's unit and an example value (TOML), by dotted path. An empty example means
/// the default is the example; an example starting with `!` is set in the example file
/// although the key has a default (a working configuration needs it). A key of the configuration types missing here, or a path
/// here that is not a key, fails the tests: the reference cannot go stale.
pub static UNITS: &[(&str, &str, &str)] = &[
    ("data.imu", "—", r#"!"IMU.txt""#),
    ("data.gnss", "—", r#"!"GNSS.txt""#),
    ("data.output", "—", r#""out""#),
    ("data.imu_rate", "Hz", "!100.0"),
    ("data.imu_format", "—", r#""rates""#),
    ("data.start_time", "s (GPS seconds of week)", "456300.0"),
    ("data.end_time", "s", "459000.0"),
    ("data.bad_lines", "—", r#""skip""#),
    ("data.max_gap", "IMU intervals", "5.0"),
    ("data.max_bridge", "IMU intervals", "20.0"),
    ("data.imu_time_offset", "s", "-0.3"),
    ("data.heading", "—", r#""rover-heading.pos""#),
    ("data.truth", "—", r#""truth.nav""#),
    ("data.gnss_format", "—", r#""rtklib""#),
    ("data.nav", "—", r#"["brdc0590.05n"]"#),
    ("data.base", "—", r#""base.obs""#),
    ("data.ros.recording", "—", r#""test1.bag""#),
    ("data.ros.imu_topic", "—", r#""/imu/data""#),
    ("data.ros.fix_topic", "—", r#""/fix""#),
    ("data.ros.odometry_topic", "—", r#""/husky_velocity_controller/odom""#),
    ("data.ros.base_frame", "—", r#""base_footprint""#),
    ("data.ros.stamps", "—", r#""receive""#),
    ("data.ros.imu_noise_from_covariance", "—", "true"),
    ("data.imu_columns.time", "—", r#""t_s""#),
    ("data.imu_columns.time_unit", "—", r#""ms""#),
    ("data.imu_columns.time_offset", "s", "0.0"),
    ("data.imu_columns.gyro", "—", r#"["gyro_x", "gyro_y", "gyro_z"]"#),
    ("data.imu_columns.gyro_unit", "—", r#""deg/s""#),
    ("data.imu_columns.accel", "—", r#"["acc_x", "acc_y", "acc_z"]"#),
    ("data.imu_columns.accel_unit", "—", r#""g""#),
    ("data.imu_columns.axes", "—", r#""flu""#),
    ("data.imu_columns.odometer", "—", r#""wheel_mps""#),
    ("data.imu_columns.odometer_unit", "—", r#""km/h""#),
    ("data.imu_columns.header", "—", "false"),
    ("data.imu_columns.time_scale", "—", r#""unix-utc""#),
    ("data.gnss_columns.time", "—", r#""t_s""#),
    ("data.gnss_columns.time_unit", "—", r#""s""#),
    ("data.gnss_columns.time_offset", "s", "0.0"),
    ("data.gnss_columns.latitude", "—", r#""lat_deg""#),
    ("data.gnss_columns.longitude", "—", r#""lon_deg""#),
    ("data.gnss_columns.angle_unit", "—", r#""rad""#),
    ("data.gnss_columns.height", "—", r#""alt_m""#),
    ("data.gnss_columns.length_unit", "—", r#""m""#),
    ("data.gnss_columns.position_std", "—", r#"["sd_n", "sd_e", "sd_d"]"#),
    ("data.gnss_columns.velocity", "—", r#"["vn", "ve", "vd"]"#),
    ("data.gnss_columns.velocity_frame", "—", r#""enu""#),
    ("data.gnss_columns.velocity_unit", "—", r#""km/h""#),
    ("data.gnss_columns.velocity_std", "—", r#"["sd_vn", "sd_ve", "sd_vd"]"#),
    ("data.gnss_columns.header", "—", "true"),
    ("data.gnss_columns.time_scale", "—", r#""gps-seconds""#),
    ("data.truth_columns.time", "—", r#""t_s""#),
    ("data.truth_columns.time_unit", "—", r#""s""#),
    ("data.truth_columns.time_offset", "s", "0.0"),
    ("data.truth_columns.latitude", "—", r#""lat_deg""#),
    ("data.truth_columns.longitude", "—", r#""lon_deg""#),
    ("data.truth_columns.angle_unit", "—", r#""deg""#),
    ("data.truth_columns.height", "—", r#""alt_m""#),
    ("data.truth_columns.length_unit", "—", r#""m""#),
    ("data.truth_columns.velocity", "—", r#"["vn", "ve", "vd"]"#),
    ("data.truth_columns.velocity_frame", "—", r#""ned""#),
    ("data.truth_columns.velocity_unit", "—", r#""m/s""#),
    ("data.truth_columns.attitude", "—", r#"["roll", "pitch", "heading"]"#),
    ("data.truth_columns.attitude_unit", "—", r#""deg""#),
    ("data.truth_columns.heading", "—", r#""east-counterclockwise""#),
    ("data.truth_columns.header", "—", "true"),
    ("data.truth_columns.time_scale", "—", r#""as-is""#),
    ("init.position", "deg, deg, m", "[30.4447, 114.4718, 20.9]"),
    ("init.velocity", "m/s", "[0.0, 0.0, 0.0]"),
    ("init.attitude", "deg", "[0.85, -2.04, 185.7]"),
    ("init.gyro_bias", "deg/h", "[0.0, 0.0, 0.0]"),
    ("init.accel_bias", "mGal", "[0.0, 0.0, 0.0]"),
    ("init.position_std", "m", "[2.0, 2.0, 3.0]"),
    ("init.velocity_std", "m/s", "[0.1, 0.1, 0.1]"),
    ("init.attitude_std", "deg", "[1.0, 1.0, 3.0]"),
    ("init.gyro_bias_std", "deg/h", "[50.0, 50.0, 50.0]"),
    ("init.accel_bias_std", "mGal", "[250.0, 250.0, 250.0]"),
    ("init.gyro_scale", "ppm", "[0.0, 0.0, 0.0]"),
    ("init.accel_scale", "ppm", "[0.0, 0.0, 0.0]"),
    ("init.gyro_scale_std", "ppm", "[1000.0, 1000.0, 1000.0]"),
    ("init.accel_scale_std", "ppm", "[1000.0, 1000.0, 1000.0]"),
    ("imu.mounting", "axes, deg or —", r#"["-y", "-x", "-z"]"#),
    ("align.static_window", "s", "1.0"),
    ("align.min_static", "s", "5.0"),
    ("align.max_time", "s", "120.0"),
    ("align.heading_std", "deg", "1.0"),
    ("align.checks", "—", "true"),
    ("imu_noise.arw", "deg/√h", "![0.24, 0.24, 0.24]"),
    ("imu_noise.vrw", "m/s/√h", "![0.24, 0.24, 0.24]"),
    ("imu_noise.from_static", "—", "true"),
    ("imu_noise.static_floor", "—", "true"),
    ("imu_noise.gyro_bias_std", "deg/h", "![10.0, 10.0, 10.0]"),
    ("imu_noise.accel_bias_std", "mGal", "![100.0, 100.0, 100.0]"),
    ("imu_noise.corr_time", "h", "!1.0"),
    ("imu_noise.gyro_bias_rw", "deg/h/√h", "[10.0, 10.0, 10.0]"),
    ("imu_noise.gyro_bias_rw_si", "rad/s/√s", "[8.1e-7, 8.1e-7, 8.1e-7]"),
    ("imu_noise.accel_bias_rw", "mGal/√h", "[100.0, 100.0, 100.0]"),
    ("imu_noise.accel_bias_rw_si", "m/s²/√s", "[1.7e-5, 1.7e-5, 1.7e-5]"),
    ("imu_noise.gyro_scale_std", "ppm", "[1000.0, 1000.0, 1000.0]"),
    ("imu_noise.accel_scale_std", "ppm", "[1000.0, 1000.0, 1000.0]"),
    ("imu_noise.bias_model", "—", r#""gauss-markov""#),
    ("gnss.lever_arm", "m (FRD)", "[0.136, -0.301, -0.184]"),
    ("gnss.use_velocity", "—", "false"),
    ("gnss.position_std", "m", "[1.0, 1.0, 2.0]"),
    ("gnss.velocity_std", "m/s", "[0.1, 0.1, 0.2]"),
    ("gnss.coupling", "—", r#""tight""#),
    ("gnss.quality.fix", "factor", "1.0"),
    ("gnss.quality.float", "factor", "2.0"),
    ("gnss.quality.sbas", "factor", "5.0"),
    ("gnss.quality.dgps", "factor", "3.0"),
    ("gnss.quality.single", "factor", "5.0"),
    ("gnss.quality.ppp", "factor", "2.0"),
    ("gnss.quality.drop", "—", r#"["single"]"#),
    ("gnss.tight.elevation_mask", "deg", "10.0"),
    ("gnss.tight.ionosphere", "—", r#""iono-free""#),
    ("gnss.tight.troposphere", "—", r#""off""#),
    ("gnss.tight.doppler", "—", "false"),
    ("gnss.tight.doppler_std", "m/s", "0.2"),
    ("gnss.tight.clock_drift_noise", "m/s/√s", "0.1"),
    ("gnss.tight.error_floor", "—", "true"),
    ("gnss.tight.carrier", "—", "true"),
    ("gnss.tight.phase_std", "m", "0.003"),
    ("gnss.tight.systems", "—", r#"["G", "C"]"#),
    ("gnss.rtk.base_position", "m (ECEF)", "[-3947762.8, 3364399.8, 3699428.5]"),
    ("gnss.rtk.frequencies", "—", "1"),
    ("gnss.rtk.elevation_mask", "deg", "10.0"),
    ("gnss.rtk.ratio", "—", "2.0"),
    ("gnss.rtk.min_success_rate", "probability", "0.99"),
    ("gnss.rtk.max_age", "s", "30.0"),
    ("gnss.errors.model", "—", r#""persisting""#),
    ("gnss.errors.share", "fraction", "0.95"),
    ("gnss.errors.tau", "s", "100.0"),
    ("gnss.errors.sigma", "m (N, E, D)", "[1.5, 1.5, 3.0]"),
    ("gnss.errors.learn", "—", "false"),
    ("gnss.heading.use_headings", "—", "false"),
    ("gnss.heading.baseline", "m (FRD)", "[0.0, 1.2, 0.0]"),
    ("gnss.heading.std", "deg", "0.3"),
    ("gnss.heading.pitch_std", "deg", "0.6"),
    ("gnss.heading.replace_std", "—", "true"),
    ("gnss.heading.pitch", "—", "false"),
    ("calibrate.lever_arm", "—", "true"),
    ("calibrate.lever_arm_std", "m", "0.5"),
    ("calibrate.time_offset", "—", "true"),
    ("calibrate.time_offset_std", "s", "0.05"),
    ("calibrate.mounting", "—", "true"),
    ("calibrate.mounting_std", "deg", "5.0"),
    ("calibrate.odometer", "—", "true"),
    ("calibrate.odometer_scale_std", "%", "2.0"),
    ("calibrate.odometer_lever_arm_std", "m", "0.3"),
    ("filter.strategy", "—", r#""fused""#),
    ("filter.mechanization", "—", r#""flat-earth""#),
    ("filter.streams", "—", r#"{ gnss-position = "fused" }"#),
    ("filter.states", "—", "21"),
    ("filter.smooth", "—", "true"),
    ("filter.covariance_interval", "s", "0"),
    ("filter.smooth_low_scratch", "—", "true"),
    ("filter.gate.enabled", "—", "false"),
    ("filter.gate.probability", "probability", "1e-6"),
    ("filter.gate.readmit_after", "refusals", "10"),
    ("filter.gate.mode", "—", r#""refuse""#),
    ("filter.gate.learn", "—", "false"),
    ("vehicle.nhc.mounting", "deg", "[0.0, 0.0, 1.2]"),
    ("vehicle.nhc.lever_arm", "m (FRD)", "[-1.2, 0.0, 0.8]"),
    ("vehicle.nhc.std", "m/s", "[0.1, 0.1]"),
    ("vehicle.nhc.interval", "s", "0.1"),
    ("vehicle.nhc.min_speed", "m/s", "1.0"),
    ("vehicle.zupt.window", "s", "1.0"),
    ("vehicle.zupt.gyro_max", "deg/s", "0.5"),
    ("vehicle.zupt.accel_std_max", "m/s²", "0.05"),
    ("vehicle.zupt.velocity_std", "m/s", "0.02"),
    ("vehicle.zupt.rate_std", "deg/s", "0.01"),
    ("vehicle.zupt.interval", "s", "0.1"),
    ("vehicle.zupt.max_speed", "m/s", "0.3"),
    ("vehicle.zupt.speed_sigmas", "σ", "3.0"),
    ("vehicle.odometer.lever_arm", "m (FRD)", "[-1.2, 0.0, 0.8]"),
    ("vehicle.odometer.std", "m/s", "0.1"),
    ("vehicle.odometer.interval", "s", "0.1"),
    ("vehicle.odometer.calibration_time", "s", "120.0"),
    ("vehicle.odometer.calibration_samples", "samples", "500.0"),
];

impl KeyDoc {
    /// `section.name`.
    pub fn path(&self) -> String {
        if self.section.is_empty() {
            self.name.to_string()
        } else {
            format!("{}.{}", self.section, self.name)
        }
    }

    fn unit(&self) -> Option<(&'static str, &'static str)> {
        let path = self.path();
        UNITS.iter().find(|(p, _, _)| *p == path).map(|&(_, u, e)| (u, e.trim_start_matches('!')))
    }

    /// Set in the example file: required, or marked so in [`UNITS`].
    fn shown(&self) -> bool {
        let path = self.path();
        (!self.has_default && !self.optional)
            || UNITS.iter().any(|(p, _, e)| *p == path && e.starts_with('!'))
    }
}

/// Keys required unless `[data.ros]` gives a recording: their serde default stands for
/// "not given" and is not written, so the reference shows them as required.
pub const REQUIRED_WITHOUT_RECORDING: [&str; 3] = ["data.imu", "data.gnss", "data.imu_rate"];

/// Every key of the configuration, in the order of the types (sections depth first).
pub fn keys() -> &'static [KeyDoc] {
    KEYS
}

/// Every section.
pub fn sections() -> &'static [SectionDoc] {
    SECTIONS
}

/// The minimal configuration the defaults are read from: the required keys, and every
/// optional table present (empty), so that its keys' defaults show.
fn minimal() -> String {
    let mut text = String::new();
    for s in SECTIONS {
        text.push_str(&format!("[{}]\n", s.path));
        for k in KEYS.iter().filter(|k| k.section == s.path && !k.has_default && !k.optional) {
            let example = k.unit().map(|(_, e)| e).unwrap_or("");
            text.push_str(&format!("{} = {example}\n", k.name));
        }
    }
    text
}

/// Each key's default as TOML text, by path; keys that are not set by default (found
/// from the data, or a feature off) and required keys are absent.
pub fn defaults() -> Result<std::collections::BTreeMap<String, String>, String> {
    let cfg: super::Config = toml::from_str(&minimal()).map_err(|e| e.to_string())?;
    let mut value = toml::Value::try_from(&cfg).map_err(|e| e.to_string())?;
    // the tight, rtk, errors, heading and calibrate sections are left out of a written configuration while they are
    // the default
    if let Some(gnss) = value.get_mut("gnss").and_then(toml::Value::as_table_mut) {
        let tight = toml::Value::try_from(&cfg.gnss.tight).map_err(|e| e.to_string())?;
        gnss.insert("tight".into(), tight);
        let rtk = toml::Value::try_from(&cfg.gnss.rtk).map_err(|e| e.to_string())?;
        gnss.insert("rtk".into(), rtk);
        let errors = toml::Value::try_from(&cfg.gnss.errors).map_err(|e| e.to_string())?;
        gnss.insert("errors".into(), errors);
        let heading = toml::Value::try_from(&cfg.gnss.heading).map_err(|e| e.to_string())?;
        gnss.insert("heading".into(), heading);
    }
    if let Some(top) = value.as_table_mut() {
        let calibrate = toml::Value::try_from(&cfg.calibrate).map_err(|e| e.to_string())?;
        top.insert("calibrate".into(), calibrate);
    }
    let mut out = std::collections::BTreeMap::new();
    for k in KEYS {
        if !k.has_default || k.optional {
            continue;
        }
        let mut v = Some(&value);
        for part in k.section.split('.').filter(|p| !p.is_empty()) {
            v = v.and_then(|v| v.get(part));
        }
        let text = match v.and_then(|v| v.get(k.name)) {
            Some(v) => v.to_string(),
            // left out of a written configuration while it is the default
            None => match k.enum_default {
                Some(e) => format!("{e:?}"),
                None if k.ty.starts_with("array") => "[]".into(),
                None => continue,
            },
        };
        out.insert(k.path(), text);
    }
    Ok(out)
}

/// Words wrapped at `width`, each line prefixed.
fn wrap(text: &str, prefix: &str, width: usize) -> String {
    let mut out = String::new();
    let mut line = String::from(prefix);
    for w in text.split_whitespace() {
        if line.len() > prefix.len() && line.chars().count() + 1 + w.chars().count() > width {
            out.push_str(line.trim_end());
            out.push('\n');
            line = String::from(prefix);
        }
        if line.len() > prefix.len() {
            line.push(' ');
        }
        line.push_str(w);
    }
    if line.len() > prefix.len() {
        out.push_str(&line);
        out.push('\n');
    }
    out
}

fn values_text(k: &KeyDoc) -> String {
    k.values
        .iter()
        .map(|(v, d)| format!("`{v}`: {}", d.trim_end_matches('.')))
        .collect::<Vec<_>>()
        .join("; ")
}

/// A complete commented configuration (`ins-gnss config --example`): every section and
/// key with its meaning, type, unit and default. Required keys are set to an example; a
/// key shown commented out takes the default it shows, or when it has none is found from
/// the data (or its feature stays off); optional tables are commented out whole.
pub fn example() -> Result<String, String> {
    let defaults = defaults()?;
    let mut out = String::from(
        "# ins-gnss run configuration (TOML): every key, generated from the configuration\n\
         # types by `ins-gnss config --example` (the reference with units and defaults:\n\
         # docs/configuration.md). Paths are relative to this file. Units are the datasheet\n\
         # ones: degrees, deg/h, mGal (1e-5 m/s²), deg/√h, m/s/√h, hours. A key commented\n\
         # out takes the value shown when it has a default, else it is found from the data\n\
         # or its feature is off. Unknown keys are refused.\n",
    );
    for s in SECTIONS {
        let c = if s.optional { "# " } else { "" };
        out.push('\n');
        out.push_str(&wrap(s.doc, "# ", 88));
        if s.optional {
            out.push_str("# (optional table: present only when wanted)\n");
        }
        out.push_str(&format!("{c}[{}]\n", s.path));
        for k in KEYS.iter().filter(|k| k.section == s.path) {
            let (unit, example) = k.unit().unwrap_or(("?", ""));
            let default = defaults.get(&k.path());
            let mut doc = k.doc.to_string();
            let mut facts = vec![k.ty.to_string()];
            if unit != "—" {
                facts.push(unit.to_string());
            }
            if !k.has_default && !k.optional {
                facts.push("required".into());
            } else if k.optional {
                facts.push("not set by default".into());
            }
            doc.push_str(&format!(" [{}]", facts.join("; ")));
            out.push_str(&wrap(&doc, &format!("{c}# "), 88));
            // a key with a default shows it (uncommenting it changes nothing)
            let active = !s.optional && k.shown();
            let value = match default {
                Some(d) if !active && (example.is_empty() || !k.optional) => d.clone(),
                _ => example.to_string(),
            };
            let lead = if active { "" } else { "# " };
            out.push_str(&format!("{lead}{} = {value}\n", k.name));
        }
    }
    Ok(out)
}

/// The configuration reference in Markdown (`ins-gnss config --reference`, shipped as
/// `docs/configuration.md`): per section, every key's type, unit, default, an example
/// and its meaning.
pub fn reference() -> Result<String, String> {
    let defaults = defaults()?;
    let cell = |s: &str| s.replace('|', "\\|");
    let mut out = String::from(
        "# Configuration reference\n\n\
         Every key of an `ins-gnss run` configuration (TOML), generated from the\n\
         configuration types by `ins-gnss config --reference`; a test fails when this file\n\
         differs from what the types give, or when a key has no unit or example.\n\
         `ins-gnss config --example` prints a complete commented file\n\
         (`ins-gnss/config.example.toml`). Paths are relative to the configuration file;\n\
         unknown keys are refused with the key named. A KF-GINS YAML is read as it is\n\
         (its keys map onto these).\n",
    );
    for s in SECTIONS {
        out.push_str(&format!("\n## `[{}]`\n\n{}", s.path, s.doc));
        if s.required {
            out.push_str(" Required.");
        } else if s.optional {
            out.push_str(" Optional: present only when wanted.");
        }
        out.push_str(
            "\n\n| key | type | unit | default | example | meaning |\n|---|---|---|---|---|---|\n",
        );
        for k in KEYS.iter().filter(|k| k.section == s.path) {
            let (unit, example) = k.unit().unwrap_or(("?", ""));
            let default = match defaults.get(&k.path()) {
                Some(d) => format!("`{}`", d),
                None if k.optional => "not set".into(),
                None => "**required**".into(),
            };
            let example = if example.is_empty() {
                defaults.get(&k.path()).cloned().unwrap_or_default()
            } else {
                example.to_string()
            };
            let mut meaning = k.doc.to_string();
            if !k.values.is_empty() {
                meaning.push_str(&format!(" Values: {}.", values_text(k)));
            }
            out.push_str(&format!(
                "| `{}` | {} | {} | {} | `{}` | {} |\n",
                k.name,
                cell(k.ty),
                cell(unit),
                cell(&default),
                cell(&example),
                cell(&meaning)
            ));
        }
    }
    Ok(out)
}

#[cfg(feature = "unit-tests")]
#[doc(hidden)]
pub mod tests {
    use super::*;

    pub fn every_key_has_a_unit_and_an_example_and_nothing_else_does() {
        let paths: Vec<String> = KEYS.iter().map(KeyDoc::path).collect();
        let missing: Vec<&String> =
            paths.iter().filter(|p| !UNITS.iter().any(|(u, _, _)| u == p)).collect();
        assert!(missing.is_empty(), "keys without a unit and example in UNITS: {missing:?}");
        let stale: Vec<&str> =
            UNITS.iter().map(|(p, _, _)| *p).filter(|p| !paths.iter().any(|k| k == p)).collect();
        assert!(stale.is_empty(), "UNITS names keys the configuration does not have: {stale:?}");
        let defaults = defaults().unwrap();
        for k in KEYS {
            assert!(!k.doc.is_empty(), "{} has no doc comment", k.path());
            let (_, example) = k.unit().unwrap();
            if !defaults.contains_key(&k.path()) {
                assert!(!example.is_empty(), "{} has neither a default nor an example", k.path());
            }
            if k.has_default && !k.optional && !REQUIRED_WITHOUT_RECORDING.contains(&&*k.path()) {
                assert!(defaults.contains_key(&k.path()), "{}: default not found", k.path());
            }
        }
        assert!(KEYS.len() > 130, "{} keys", KEYS.len());
        // figures the doc comments state
        assert_eq!(crate::start::FLOOR_FACTOR, 1.5, "imu_noise.static_floor's doc says 1.5×");
        assert_eq!(crate::start::STATIC_ALLOWANCE, 3600.0, "align.max_time's doc says 3600 s");
    }

    pub fn every_example_value_is_accepted_by_the_types() {
        // all sections present, every key set to its example (or default)
        let defaults = defaults().unwrap();
        let mut text = String::new();
        for s in SECTIONS {
            text.push_str(&format!("[{}]\n", s.path));
            for k in KEYS.iter().filter(|k| k.section == s.path) {
                let (_, e) = k.unit().unwrap();
                let v = if e.is_empty() { defaults[&k.path()].clone() } else { e.to_string() };
                text.push_str(&format!("{} = {v}\n", k.name));
            }
        }
        let cfg: Result<super::super::Config, _> = toml::from_str(&text);
        assert!(cfg.is_ok(), "{:?}\n{text}", cfg.err());
        // and a misspelt key is refused, so the check above can fail
        let bad = text.replacen("imu_rate", "imu_rat", 1);
        assert!(toml::from_str::<super::super::Config>(&bad).is_err());
    }

    pub fn the_example_file_is_a_valid_configuration_with_every_default() {
        let text = example().unwrap();
        let cfg = super::super::Config::parse(
            &text,
            super::super::ConfigKind::Toml,
            std::path::Path::new("."),
        );
        assert!(cfg.is_ok(), "{:?}", cfg.err());
        // uncommenting a key that has a default changes nothing
        let defaults = defaults().unwrap();
        let parsed = cfg.unwrap();
        let mut uncommented = String::new();
        let mut section: Option<&str> = None;
        let mut changed = 0;
        for line in text.lines() {
            if let Some(h) = line.strip_prefix('[') {
                section = Some(h.trim_end_matches(']'));
            } else if line.starts_with("# [") {
                section = None; // an optional table: left commented out
            }
            let key = line.strip_prefix("# ").and_then(|l| l.split(" = ").next());
            let has_default = match (section, key) {
                (Some(s), Some(name)) => KEYS
                    .iter()
                    .any(|k| k.section == s && k.name == name && defaults.contains_key(&k.path())),
                _ => false,
            };
            if has_default {
                uncommented.push_str(&line[2..]);
                changed += 1;
            } else {
                uncommented.push_str(line);
            }
            uncommented.push('\n');
        }
        assert!(changed > 40, "{changed} keys uncommented");
        let with_defaults = super::super::Config::parse(
            &uncommented,
            super::super::ConfigKind::Toml,
            std::path::Path::new("."),
        );
        assert_eq!(with_defaults.as_ref().ok(), Some(&parsed), "{uncommented}");
    }

    fn shipped(rel: &str) -> String {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    }

    pub fn the_shipped_example_and_reference_are_what_the_types_give() {
        assert!(
            shipped("config.example.toml") == example().unwrap(),
            "ins-gnss/config.example.toml is stale: regenerate it with \
             `cargo run -p ins-gnss -- config --example > ins-gnss/config.example.toml`"
        );
        assert!(
            shipped("../docs/configuration.md") == reference().unwrap(),
            "docs/configuration.md is stale: regenerate it with \
             `cargo run -p ins-gnss -- config --reference > docs/configuration.md`"
        );
    }
}
