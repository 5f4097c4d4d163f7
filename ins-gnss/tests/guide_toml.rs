//! Every TOML block of the README and of the guide (`docs/guide/*.md`) is a configuration
//! the program takes: a whole one as it is, a fragment over a minimal configuration. The
//! keys are refused when unknown, so a renamed key in the types fails here until the
//! documentation follows.

use ins_gnss::config::{Config, ConfigKind};
use std::path::Path;

/// A configuration with the required keys, under the fragments.
const MINIMAL: &str = r#"
[data]
imu = "IMU.txt"
gnss = "GNSS.txt"
imu_rate = 100.0
[imu_noise]
arw = [0.3, 0.3, 0.3]
vrw = [0.03, 0.03, 0.03]
gyro_bias_std = [10.0, 10.0, 10.0]
accel_bias_std = [100.0, 100.0, 100.0]
corr_time = 1.0
"#;

/// `over` laid over `base`, table by table.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

#[test]
fn every_toml_block_of_the_docs_is_a_configuration() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = vec![root.join("README.md")];
    let mut guide: Vec<_> = std::fs::read_dir(root.join("docs/guide"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    guide.sort();
    files.extend(guide);
    let mut checked = 0;
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let mut lines = text.lines().enumerate();
        while let Some((start, line)) = lines.next() {
            if line.trim_end() != "```toml" {
                continue;
            }
            let block: String = lines
                .by_ref()
                .take_while(|(_, l)| !l.starts_with("```"))
                .map(|(_, l)| l.to_owned() + "\n")
                .collect();
            let at = format!("{}:{}", file.display(), start + 1);
            let over: toml::Table = toml::from_str(&block).unwrap_or_else(|e| panic!("{at}: {e}"));
            let mut config: toml::Table = toml::from_str(MINIMAL).unwrap();
            merge(&mut config, over);
            let text = toml::to_string(&config).unwrap();
            Config::parse(&text, ConfigKind::Toml, Path::new("."))
                .unwrap_or_else(|e| panic!("{at}: not a configuration: {e}"));
            checked += 1;
        }
    }
    assert!(checked >= 3, "{checked} blocks");
}
