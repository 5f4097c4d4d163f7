//! A failed or untrusted run never destroys an earlier result: the output folder is kept
//! aside while the run writes, and put back when it fails.

use super::*;

/// The file a run judged untrustworthy leaves in its output directory (its diagnosis):
/// a later run may replace that result whatever its own verdict, where it replaces a
/// result without the file only with one that is not judged untrustworthy either.
pub const UNTRUSTED_MARK: &str = "UNTRUSTED.txt";

/// `dir` with `suffix` added to its last component (a directory beside it).
pub(super) fn sibling(dir: &Path, suffix: &str) -> PathBuf {
    let name = dir.file_name().map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    dir.with_file_name(format!("{name}{suffix}"))
}

/// The files of `dir` kept aside in a directory beside it (a hard link each, a copy where
/// links cannot be made): the run's outputs replace the files in `dir` by renames, which
/// leave the kept ones as they were.
pub(super) fn keep_aside(dir: &Path) -> Result<PathBuf, CliError> {
    let kept = sibling(dir, ".kept");
    if kept.exists() {
        std::fs::remove_dir_all(&kept).map_err(|e| format!("{}: {e}", kept.display()))?;
    }
    std::fs::create_dir_all(&kept).map_err(|e| format!("{}: {e}", kept.display()))?;
    for entry in std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))? {
        let path = entry.map_err(|e| format!("{}: {e}", dir.display()))?.path();
        let name = path.file_name().unwrap_or_default();
        if !path.is_file() || path.extension().is_some_and(|e| e == "partial") {
            continue;
        }
        let to = kept.join(name);
        if std::fs::hard_link(&path, &to).is_err() {
            std::fs::copy(&path, &to).map_err(|e| format!("{}: {e}", to.display()))?;
        }
    }
    Ok(kept)
}

/// Whether two paths hold the same file (the same inode on Unix; the same length and
/// modification time elsewhere).
pub(super) fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => {
            #[cfg(unix)]
            {
                use std::os::unix::fs::MetadataExt;
                x.ino() == y.ino() && x.dev() == y.dev()
            }
            #[cfg(not(unix))]
            {
                x.len() == y.len() && x.modified().ok() == y.modified().ok()
            }
        }
        _ => false,
    }
}

/// An untrusted run over a trusted result: the files the run wrote in `dir` move to
/// `beside` (an earlier one there is replaced), and the kept ones go back into `dir`.
pub(super) fn put_back(kept: &Path, dir: &Path, beside: &Path) -> Result<(), CliError> {
    let err = |p: &Path, e: std::io::Error| format!("{}: {e}", p.display());
    if beside.exists() {
        std::fs::remove_dir_all(beside).map_err(|e| err(beside, e))?;
    }
    std::fs::create_dir_all(beside).map_err(|e| err(beside, e))?;
    for entry in std::fs::read_dir(dir).map_err(|e| err(dir, e))? {
        let path = entry.map_err(|e| err(dir, e))?.path();
        let name = path.file_name().unwrap_or_default();
        if path.is_file() && !same_file(&path, &kept.join(name)) {
            let to = beside.join(name);
            std::fs::rename(&path, &to).map_err(|e| err(&to, e))?;
        }
    }
    for entry in std::fs::read_dir(kept).map_err(|e| err(kept, e))? {
        let path = entry.map_err(|e| err(kept, e))?.path();
        let to = dir.join(path.file_name().unwrap_or_default());
        // (a rename onto another link of the same file does nothing)
        if same_file(&path, &to) {
            std::fs::remove_file(&path).map_err(|e| err(&path, e))?;
        } else {
            std::fs::rename(&path, &to).map_err(|e| err(&to, e))?;
        }
    }
    std::fs::remove_dir(kept).map_err(|e| err(kept, e))?;
    Ok(())
}

/// Removes a report and plots an earlier run left in `dir` that this run did not write
/// (they would describe another result), saying so.
pub(super) fn remove_stale(dir: &Path, report: bool, figures: &[PathBuf]) -> Result<(), CliError> {
    let mut names: Vec<&str> = crate::plot::FILES.to_vec();
    if !report {
        names.push("report.html");
    }
    for name in names {
        let p = dir.join(name);
        if p.is_file() && !figures.contains(&p) {
            std::fs::remove_file(&p).map_err(|e| format!("{}: {e}", p.display()))?;
            out!("removed {} (an earlier run's, not this result's)", p.display());
        }
    }
    Ok(())
}
