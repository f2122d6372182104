//! Writing a whole directory atomically.
//!
//! The files go into a fresh temporary sibling `.{name}.XXXXXX.tmp` (random name, from
//! [`tempfile`]; removed on failure), which is renamed to the target once complete. An existing target is first renamed aside to `.{name}.old-{pid}`,
//! then the new directory is renamed in and the old one removed. At no time does the target
//! path hold a partly written directory: a crash leaves either the old dataset, the new one,
//! or (between the two renames) none, with both complete copies in the hidden siblings.
//! One writer per target directory at a time.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// The file whose presence marks an existing directory as a dataset that may be replaced.
pub(crate) const MARKER: &str = "meta.json";

/// Create (or replace) `dir` (and its missing parents) with the files that `fill` writes into
/// the directory it is given.
///
/// An existing `dir` is replaced only if it is an empty directory or contains `meta.json`
/// (so that a mistyped path never deletes unrelated files); anything else is refused with
/// [`Error::InvalidInput`]. When `fill` or any file operation fails, the temporary directory
/// is removed and `dir` is left as it was.
pub(crate) fn write_dir(dir: &Path, fill: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let (parent, name) = split(dir)?;
    check_replaceable(dir)?;
    // Missing parents are created, as `mkdir -p` would.
    std::fs::create_dir_all(&parent).map_err(|e| Error::io(&parent, e))?;
    let old = parent.join(format!(".{name}.old-{}", std::process::id()));
    // A leftover of a crashed run that had our process id.
    remove_if_present(&old)?;
    // Removed when dropped, i.e. on every early return below.
    let prefix = format!(".{name}.");
    let tmp_dir = crate::io::sibling_builder(&prefix, ".tmp", true)
        .tempdir_in(&parent)
        .map_err(|e| Error::io(&parent, e))?;
    let tmp = tmp_dir.path().to_path_buf();
    fill(&tmp).and_then(|()| sync_dir(&tmp).map_err(|e| Error::io(&tmp, e)))?;
    let replaced = dir.exists();
    if replaced {
        std::fs::rename(dir, &old).map_err(|e| Error::io(dir, e))?;
    }
    if let Err(e) = std::fs::rename(&tmp, dir) {
        if replaced {
            let _ = std::fs::rename(&old, dir);
        }
        return Err(Error::io(dir, e));
    }
    // The directory now lives at `dir`: nothing left to clean up.
    let _ = tmp_dir.keep();
    let synced = sync_dir(&parent).map_err(|e| Error::io(&parent, e));
    if replaced {
        // The new dataset is in place; a copy of the old one that cannot be removed is only
        // a hidden leftover.
        let _ = std::fs::remove_dir_all(&old);
    }
    synced
}

/// The parent directory (`.` for a bare name) and the final component of `dir`.
fn split(dir: &Path) -> Result<(PathBuf, String)> {
    let name = dir
        .file_name()
        .ok_or_else(|| {
            Error::InvalidInput(format!(
                "{} cannot be a dataset directory (it has no final name component)",
                dir.display()
            ))
        })?
        .to_string_lossy()
        .into_owned();
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok((parent, name))
}

/// Refuse to replace anything but a missing path, an empty directory or a dataset.
fn check_replaceable(dir: &Path) -> Result<()> {
    let meta = match std::fs::symlink_metadata(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(Error::io(dir, e)),
        Ok(m) => m,
    };
    let refuse = |why: &str| {
        Err(Error::InvalidInput(format!(
            "refusing to replace {}: {why}",
            dir.display()
        )))
    };
    if !meta.is_dir() {
        return refuse("it exists and is not a directory");
    }
    if dir.join(MARKER).is_file() {
        return Ok(());
    }
    let mut entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    if entries.next().is_some() {
        return refuse(&format!(
            "it is a non-empty directory without {MARKER}, not a dataset"
        ));
    }
    Ok(())
}

/// Remove a directory tree if it exists.
fn remove_if_present(path: &Path) -> Result<()> {
    match std::fs::remove_dir_all(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::io(path, e)),
        _ => Ok(()),
    }
}

/// Flush a directory's entries to disk (no-op where directories cannot be opened).
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    #[cfg(unix)]
    std::fs::File::open(dir)?.sync_all()?;
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}
