//! Opening (with decompression) and atomic publishing of files.

use super::*;

pub use ::gnss::input::Input;

/// Open a file for buffered reading, with a located error; `.gz`, `.zst` (`.zstd`) and
/// `.xz` files are decompressed as they are read (users' logs are often compressed; the
/// GNSS crate's [`gnss::input::open`](::gnss::input::open)).
pub fn open(path: &Path) -> Result<Input, LineError> {
    ::gnss::input::open(path).map_err(|e| LineError {
        path: path.to_path_buf(),
        line: 0,
        kind: LineErrorKind::Io(e),
    })
}

/// `path` with `.partial` appended: where an output is written until it is complete and
/// renamed into place ([`create_partial`], [`publish`]).
pub fn partial_path(path: &Path) -> std::path::PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".partial");
    std::path::PathBuf::from(s)
}

/// Create `path.partial` for writing: the output `path` itself is untouched until
/// [`publish`] renames the finished file over it, so a failed or interrupted run never
/// destroys an earlier result.
pub fn create_partial(path: &Path) -> std::io::Result<BufWriter<File>> {
    create(&partial_path(path))
}

/// Rename the finished `path.partial` over `path` (atomic on one file system).
///
/// On Unix, a `path` with another hard link (the program keeps an earlier result aside
/// that way while a run writes) is unlinked first when the finished file is there, which
/// loses nothing: its data stays under the other name. Renaming onto a free name spares
/// the flush that ext4 (`auto_da_alloc`) does when a rename replaces a file, about 2 ms
/// per 10 MB written here, on the run's critical path.
pub fn publish(path: &Path) -> std::io::Result<()> {
    let partial = partial_path(path);
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let file = |p: &Path| std::fs::symlink_metadata(p).ok().filter(|m| m.is_file());
        if file(&partial).is_some() && file(path).is_some_and(|m| m.nlink() > 1) {
            std::fs::remove_file(path)?;
        }
    }
    std::fs::rename(partial, path)
}

/// Write `contents` whole to `path.partial` and [`publish`] it: an earlier `path` stays
/// until the new one is complete. The error names the file that failed.
pub fn write_published(path: &Path, contents: impl AsRef<[u8]>) -> Result<(), String> {
    let partial = partial_path(path);
    std::fs::write(&partial, contents).map_err(|e| format!("{}: {e}", partial.display()))?;
    publish(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Create a file for buffered writing (truncating it).
pub fn create(path: &Path) -> std::io::Result<BufWriter<File>> {
    Ok(BufWriter::with_capacity(1 << 16, File::create(path)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `publish` puts the finished file in place whether or not the old one has another
    /// name; a hard link to the old one (how the program keeps an earlier result aside)
    /// still holds the old bytes, and a missing `.partial` is an error that leaves the
    /// old file.
    #[test]
    fn published_files_replace_the_old_and_leave_its_other_links() {
        let dir = std::env::temp_dir().join(format!("publish-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let (out, kept) = (dir.join("nav.txt"), dir.join("kept.txt"));
        std::fs::write(&out, "old\n").unwrap();
        std::fs::hard_link(&out, &kept).unwrap();
        std::fs::write(partial_path(&out), "new\n").unwrap();
        publish(&out).unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "new\n");
        assert_eq!(std::fs::read_to_string(&kept).unwrap(), "old\n");
        assert!(!partial_path(&out).exists());
        // without another link, and onto a free name
        std::fs::write(partial_path(&out), "newer\n").unwrap();
        publish(&out).unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "newer\n");
        let fresh = dir.join("fresh.txt");
        std::fs::write(partial_path(&fresh), "first\n").unwrap();
        publish(&fresh).unwrap();
        assert_eq!(std::fs::read_to_string(&fresh).unwrap(), "first\n");
        // nothing to publish: an error, the linked old file untouched
        std::fs::hard_link(&out, dir.join("kept2.txt")).unwrap();
        assert!(publish(&out).is_err());
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "newer\n");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// `write_published` replaces the file when the write succeeds; a write that fails (a
    /// full disk: its `.partial` is `/dev/full`) names the `.partial` and leaves the
    /// earlier file as it was.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_failed_write_names_its_file_and_keeps_the_earlier_one() {
        let dir = std::env::temp_dir().join(format!("write-published-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("report.html");
        write_published(&out, "first\n").unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "first\n");
        std::os::unix::fs::symlink("/dev/full", partial_path(&out)).unwrap();
        let e = write_published(&out, "second\n").unwrap_err();
        assert!(e.contains("report.html.partial") && e.contains("No space left"), "{e}");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "first\n");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
