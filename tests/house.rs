//! What `docs/guide/house.md` says of the house and the code can check: the crate graph
//! (each crate imports only the workspace crates its floor allows) and the files' sizes
//! (no source file past `MAX_LINES` lines of non-test code).

use std::path::{Path, PathBuf};

/// The workspace's crates (folder, package name) and the workspace crates each may import
/// in `[dependencies]`: the floors of `house.md`'s table.
const FLOORS: &[(&str, &[&str])] = &[
    ("manifolds", &[]),
    ("estimator-core", &["manifolds"]),
    ("adaptive", &["manifolds", "estimator-core"]),
    ("models", &["manifolds", "estimator-core"]),
    ("ins-gnss-core", &["manifolds", "estimator-core"]),
    ("ins-gnss-sim", &["manifolds", "ins-gnss-core"]),
    (
        "ins-gnss",
        &["manifolds", "estimator-core", "adaptive", "models", "ins-gnss-core", "ins-gnss-sim"],
    ),
    (
        "python",
        &[
            "manifolds",
            "estimator-core",
            "adaptive",
            "models",
            "ins-gnss-core",
            "ins-gnss-sim",
            "ins-gnss",
        ],
    ),
    ("firmware", &["manifolds", "estimator-core", "models"]),
];

/// "Files stay under about 600 lines of non-test code" (`house.md`): the bound the test
/// holds them to.
const MAX_LINES: usize = 700;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The workspace crates named in a manifest's `[dependencies]` (not dev- or build-).
fn workspace_dependencies(manifest: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(manifest).unwrap();
    let names: Vec<&str> = FLOORS.iter().map(|f| f.0).collect();
    let mut inside = false;
    let mut found = Vec::new();
    for line in text.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            inside = line == "[dependencies]";
            continue;
        }
        if !inside {
            continue;
        }
        let key = line.split(['=', '.', ' ']).next().unwrap_or("").trim();
        if names.contains(&key) {
            found.push(key.to_string());
        }
    }
    found
}

#[test]
fn each_crate_imports_only_the_floors_below_it() {
    let mut checked = 0;
    for (dir, allowed) in FLOORS {
        let manifest = root().join(dir).join("Cargo.toml");
        assert!(
            manifest.exists(),
            "{} is gone: update house.md and this table",
            manifest.display()
        );
        for dep in workspace_dependencies(&manifest) {
            assert!(
                allowed.contains(&dep.as_str()),
                "{dir} imports {dep}, above its floor (house.md)"
            );
            checked += 1;
        }
    }
    // the graph is not empty: the reader found the dependencies
    assert!(checked >= 15, "only {checked} workspace dependencies found");
    // a crate the table does not know is a crate house.md does not know
    let members = std::fs::read_to_string(root().join("Cargo.toml")).unwrap();
    let line = members.lines().find(|l| l.starts_with("members")).unwrap();
    for (i, name) in line.split('"').enumerate() {
        if i % 2 == 1 {
            assert!(
                FLOORS.iter().any(|f| f.0 == name),
                "workspace member {name} is not in house.md's table"
            );
        }
    }
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_source_file_is_past_the_house_size() {
    let mut files = Vec::new();
    for (dir, _) in FLOORS {
        let src = root().join(dir).join("src");
        if src.exists() {
            sources(&src, &mut files);
        }
    }
    assert!(files.len() > 100, "only {} source files found", files.len());
    let mut over = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let code = text.lines().take_while(|l| l.trim() != "#[cfg(test)]").count();
        if code > MAX_LINES {
            over.push(format!("{} ({code} lines)", f.strip_prefix(root()).unwrap().display()));
        }
    }
    assert!(over.is_empty(), "past {MAX_LINES} lines of non-test code, to be split: {over:?}");
}
