//! KF-GINS YAML configurations (keys as in its `dataset/kf-gins.yaml`).

use std::path::PathBuf;

use yaml_rust2::{Yaml, YamlLoader};

use super::*;

pub(crate) fn num(y: &Yaml) -> Option<f64> {
    match y {
        Yaml::Real(s) => s.parse().ok(),
        Yaml::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

pub(crate) fn get<'a>(doc: &'a Yaml, key: &str) -> Result<&'a Yaml, String> {
    let mut node = doc;
    for part in key.split('.') {
        node = &node[part];
    }
    if node.is_badvalue() || node.is_null() {
        Err(format!("missing key `{key}`"))
    } else {
        Ok(node)
    }
}

pub(crate) fn scalar(doc: &Yaml, key: &str) -> Result<f64, String> {
    num(get(doc, key)?).ok_or_else(|| format!("key `{key}` must be a number"))
}

pub(crate) fn triple(doc: &Yaml, key: &str) -> Result<[f64; 3], String> {
    let v = get(doc, key)?;
    let arr = v.as_vec().ok_or_else(|| format!("key `{key}` must be a list of 3 numbers"))?;
    if arr.len() != 3 {
        return Err(format!("key `{key}` must have 3 numbers, has {}", arr.len()));
    }
    let mut out = [0.0; 3];
    for (o, y) in out.iter_mut().zip(arr) {
        *o = num(y).ok_or_else(|| format!("key `{key}` must contain numbers"))?;
    }
    Ok(out)
}

pub(crate) fn text(doc: &Yaml, key: &str) -> Result<String, String> {
    get(doc, key)?
        .as_str()
        .map(str::to_string)
        .ok_or_else(|| format!("key `{key}` must be a string"))
}

/// The keys of a KF-GINS configuration (top level, and under `imunoise`).
pub(crate) const KEYS: [&str; 22] = [
    "imupath",
    "gnsspath",
    "outputpath",
    "imudatalen",
    "imudatarate",
    "starttime",
    "endtime",
    "initpos",
    "initvel",
    "initatt",
    "initgyrbias",
    "initaccbias",
    "initgyrscale",
    "initaccscale",
    "initposstd",
    "initvelstd",
    "initattstd",
    "initbgstd",
    "initbastd",
    "initsgstd",
    "initsastd",
    "antlever",
];
pub(crate) const NOISE_KEYS: [&str; 7] =
    ["arw", "vrw", "gbstd", "abstd", "gsstd", "asstd", "corrtime"];

/// Refuse a key that is not KF-GINS's (a misspelt key would otherwise be silently
/// ignored), suggesting the closest one.
pub(crate) fn check_keys(node: &Yaml, known: &[&str], prefix: &str) -> Result<(), String> {
    let Some(map) = node.as_hash() else { return Ok(()) };
    for key in map.keys() {
        let name = key.as_str().unwrap_or("");
        if name == "imunoise" && prefix.is_empty() {
            continue;
        }
        if !known.contains(&name) {
            let best = known
                .iter()
                .map(|k| (strsim::levenshtein(name, k), *k))
                .min()
                .filter(|(d, _)| *d <= 3)
                .map(|(_, k)| format!(" (did you mean `{prefix}{k}`?)"))
                .unwrap_or_default();
            return Err(format!("unknown key `{prefix}{name}`{best}"));
        }
    }
    Ok(())
}

/// Build our configuration from a KF-GINS YAML text. The scale-factor keys
/// (`initgyrscale`, `initaccscale`, `initsgstd`, `initsastd`, `imunoise.gsstd`,
/// `imunoise.asstd`, all ppm) set the 21-state filter's scale factors; the filter runs
/// 15 states unless `--states 21` (or `filter.states` in TOML) asks for 21. Any other
/// key is refused with the closest known one suggested.
pub fn from_yaml(text_in: &str) -> Result<Config, String> {
    let docs = YamlLoader::load_from_str(text_in).map_err(|e| format!("not valid YAML: {e}"))?;
    let doc = docs.first().ok_or("empty YAML document")?;
    check_keys(doc, &KEYS, "")?;
    check_keys(&doc["imunoise"], &NOISE_KEYS, "imunoise.")?;
    let imudatalen = num(get(doc, "imudatalen").unwrap_or(&Yaml::Integer(7))).unwrap_or(7.0);
    if imudatalen != 7.0 && imudatalen != 8.0 {
        return Err(format!("key `imudatalen` must be 7 or 8, got {imudatalen}"));
    }
    let end = scalar(doc, "endtime").unwrap_or(-1.0);
    let output = text(doc, "outputpath").unwrap_or_else(|_| "out".into());
    Ok(Config {
        data: DataSection {
            imu: PathBuf::from(text(doc, "imupath")?),
            gnss: PathBuf::from(text(doc, "gnsspath")?),
            output: PathBuf::from(output),
            imu_rate: scalar(doc, "imudatarate")?,
            imu_format: ImuFormatName::Increments,
            start_time: Some(scalar(doc, "starttime")?),
            end_time: (end > 0.0).then_some(end),
            bad_lines: PolicyName::Error,
            max_gap: default_max_gap(),
            max_bridge: default_max_bridge(),
            imu_time_offset: 0.0,
            heading: None,
            truth: None,
            imu_columns: None,
            gnss_columns: None,
            gnss_format: Default::default(),
            truth_columns: None,
            nav: Vec::new(),
            base: None,
            ros: None,
        },
        init: InitSection {
            position: Some(triple(doc, "initpos")?),
            velocity: Some(triple(doc, "initvel")?),
            attitude: Some(triple(doc, "initatt")?),
            gyro_bias: Some(triple(doc, "initgyrbias").unwrap_or([0.0; 3])),
            accel_bias: Some(triple(doc, "initaccbias").unwrap_or([0.0; 3])),
            position_std: Some(triple(doc, "initposstd")?),
            velocity_std: Some(triple(doc, "initvelstd")?),
            attitude_std: Some(triple(doc, "initattstd")?),
            gyro_bias_std: Some(triple(doc, "initbgstd")?),
            accel_bias_std: Some(triple(doc, "initbastd")?),
            gyro_scale: triple(doc, "initgyrscale").unwrap_or([0.0; 3]),
            accel_scale: triple(doc, "initaccscale").unwrap_or([0.0; 3]),
            gyro_scale_std: triple(doc, "initsgstd").unwrap_or_else(|_| default_scale_std()),
            accel_scale_std: triple(doc, "initsastd").unwrap_or_else(|_| default_scale_std()),
        },
        imu_noise: NoiseSection {
            arw: triple(doc, "imunoise.arw")?,
            vrw: triple(doc, "imunoise.vrw")?,
            from_static: false,
            static_floor: true,
            gyro_bias_std: Some(triple(doc, "imunoise.gbstd")?),
            accel_bias_std: Some(triple(doc, "imunoise.abstd")?),
            corr_time: Some(scalar(doc, "imunoise.corrtime")?),
            gyro_bias_rw: None,
            gyro_bias_rw_si: None,
            accel_bias_rw: None,
            accel_bias_rw_si: None,
            gyro_scale_std: triple(doc, "imunoise.gsstd").unwrap_or_else(|_| default_scale_std()),
            accel_scale_std: triple(doc, "imunoise.asstd").unwrap_or_else(|_| default_scale_std()),
            bias_model: BiasModelName::default(),
        },
        gnss: GnssSection {
            lever_arm: triple(doc, "antlever").unwrap_or([0.0; 3]),
            ..GnssSection::default()
        },
        imu: ImuSection::default(),
        align: AlignSection::default(),
        filter: FilterSection::default(),
        vehicle: VehicleSection::default(),
        calibrate: CalibrateSection::default(),
    })
}
