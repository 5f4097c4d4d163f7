//! The README's and the guide's (`docs/guide/*.md`) code blocks, checked: every TOML
//! block is a configuration the program takes (a whole one as it is, a fragment over a
//! minimal configuration; unknown keys are refused, so a renamed key in the types fails
//! here until the documentation follows), and every `ins-gnss` command of the shell blocks,
//! run as written (the test's build of the program, from a folder that sees the
//! repository's `data/` and `ins-gnss/scenarios/`), must succeed; so must the demo
//! (`cargo run --release -p ins-gnss`, the program without arguments). The shell blocks'
//! other lines are the commands CI itself runs (`cargo test --workspace`,
//! `python/run-tests`, `firmware/check`, the no_std build) or examples with their own
//! tests (`cargo run --example …`); synopses (a line with `[`, `|` or a placeholder in
//! capitals) are not commands. The Python blocks run in `python/tests/test_guide.py`.

use ins_gnss::config::{Config, ConfigKind};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").canonicalize().unwrap()
}

/// The blocks fenced as `lang` in the README and the guide's chapters: where each starts
/// (`file:line` of its fence) and its lines with their 1-based line numbers.
fn blocks(lang: &str) -> Vec<(String, Vec<(usize, String)>)> {
    let root = root();
    let mut files = vec![root.join("README.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root.join("docs/guide"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    guide.sort();
    files.extend(guide);
    let fence = format!("```{lang}");
    let mut out = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let name = file.file_name().unwrap().to_string_lossy().to_string();
        let mut lines = text.lines().enumerate();
        while let Some((start, line)) = lines.next() {
            if line.trim_end() != fence {
                continue;
            }
            let body = lines
                .by_ref()
                .take_while(|(_, l)| !l.starts_with("```"))
                .map(|(k, l)| (k + 1, l.to_owned()))
                .collect();
            out.push((format!("{name}:{}", start + 1), body));
        }
    }
    out
}

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
    let mut checked = 0;
    for (at, body) in blocks("toml") {
        let block: String = body.iter().map(|(_, l)| l.clone() + "\n").collect();
        let over: toml::Table = toml::from_str(&block).unwrap_or_else(|e| panic!("{at}: {e}"));
        let mut config: toml::Table = toml::from_str(MINIMAL).unwrap();
        merge(&mut config, over);
        let text = toml::to_string(&config).unwrap();
        Config::parse(&text, ConfigKind::Toml, Path::new("."))
            .unwrap_or_else(|e| panic!("{at}: not a configuration: {e}"));
        checked += 1;
    }
    assert!(checked >= 3, "{checked} blocks");
}

/// The `ins-gnss` command lines of the shell blocks: (where, the arguments, the file a
/// `>` sends the output to).
fn commands() -> Vec<(String, Vec<String>, Option<String>)> {
    let mut out = Vec::new();
    for (block, body) in blocks("sh") {
        let file = block.split(':').next().unwrap_or("").to_string();
        let mut pending = String::new();
        for (k, line) in body {
            let code = line.split(" #").next().unwrap_or("").trim_end();
            let code = if code.trim_start().starts_with('#') { "" } else { code };
            if let Some(head) = code.strip_suffix('\\') {
                pending.push_str(head);
                continue;
            }
            let full = std::mem::take(&mut pending) + code;
            let full = full.trim();
            let args = if let Some(rest) = full.strip_prefix("cargo run --release -p ins-gnss") {
                rest.trim().strip_prefix("--").unwrap_or(rest).trim().to_string()
            } else if let Some(rest) = full.strip_prefix("ins-gnss ") {
                rest.to_string()
            } else {
                continue;
            };
            let synopsis = args.contains('[')
                || args.contains('|')
                || args
                    .split_whitespace()
                    .any(|w| w.len() > 2 && w.chars().all(|c| c.is_ascii_uppercase()));
            if synopsis {
                continue;
            }
            let (args, to) = match args.split_once('>') {
                Some((a, f)) => (a.trim().to_string(), Some(f.trim().to_string())),
                None => (args, None),
            };
            out.push((
                format!("{file}:{k}"),
                args.split_whitespace().map(str::to_string).collect(),
                to,
            ));
        }
    }
    out
}

/// `from`'s folders made again under `to`, its files linked; earlier runs' output folders
/// (`out*`) left out.
fn mirror(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap();
        if path.is_dir() {
            if !name.to_string_lossy().starts_with("out") {
                mirror(&path, &to.join(name));
            }
        } else {
            std::os::unix::fs::symlink(&path, to.join(name)).unwrap();
        }
    }
}

#[test]
fn every_ins_gnss_command_of_the_docs_runs() {
    let root = root();
    let work = std::env::temp_dir().join(format!("estimator-doc-commands-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(work.join("ins-gnss")).unwrap();
    // the data's folders are made here and their files linked, so that what a command
    // writes beside its configuration (an `outputpath`) lands here, not in the repository
    mirror(&root.join("data"), &work.join("data"));
    std::os::unix::fs::symlink(root.join("ins-gnss/scenarios"), work.join("ins-gnss/scenarios"))
        .unwrap();
    let list = commands();
    assert!(list.len() >= 8, "{list:?}");
    assert!(list.iter().any(|(_, a, _)| a.is_empty()), "the demo");
    for (at, args, to) in &list {
        let out = Command::new(env!("CARGO_BIN_EXE_ins-gnss"))
            .args(args)
            .current_dir(&work)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{at}: `ins-gnss {}` exited {:?}:\n{}",
            args.join(" "),
            out.status.code(),
            String::from_utf8_lossy(&out.stderr)
        );
        if let Some(file) = to {
            std::fs::write(work.join(file), &out.stdout).unwrap();
        }
    }
    std::fs::remove_dir_all(&work).unwrap();
}
