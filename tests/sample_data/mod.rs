//! The sample datasets for tests and examples: the repository's compressed copies in
//! `data/` (found from the including crate's directory upwards), or, when
//! `ESTIMATOR_DATA_DIR` names a directory with the same layout, that copy (plain or
//! compressed files). Missing data is a failure, never a skip.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The dataset directory `name` (`navego`, `drive-0708`); `manifest_dir` is the including
/// crate's `env!("CARGO_MANIFEST_DIR")`.
pub fn dir(manifest_dir: &str, name: &str) -> PathBuf {
    if let Some(d) = std::env::var_os("ESTIMATOR_DATA_DIR") {
        let d = PathBuf::from(d).join(name);
        if d.is_dir() {
            return d;
        }
    }
    Path::new(manifest_dir)
        .ancestors()
        .map(|a| a.join("data").join(name))
        .find(|d| d.is_dir())
        .unwrap_or_else(|| {
            panic!("sample data `{name}` not found: the repository's data/ is missing")
        })
}

/// The file `name` of a dataset directory, plain or compressed (`.zst`, `.xz`, `.gz`).
pub fn file(dir: &Path, name: &str) -> PathBuf {
    ["", ".zst", ".xz", ".gz"]
        .iter()
        .map(|ext| dir.join(format!("{name}{ext}")))
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("{name} (plain or compressed) not found in {}", dir.display()))
}
