//! Files: atomic writes and CSV tables of joint-space samples.
//!
//! Every file powertwin writes goes through [`write_atomic`]: the bytes go to a temporary
//! file in the target directory, which is then renamed over the target, so a crash never
//! leaves a half-written file.

pub mod table;

use std::io::Write;
use std::path::Path;

use crate::error::{Error, Result};

/// A name made safe for file names and Rerun entity paths: ASCII letters, digits and dots
/// are kept, every run of other characters becomes one `_`, with none at either end (e.g.
/// `"tool + 2 kg"` gives `"tool_2_kg"`).
pub fn slug(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    s.split('_')
        .filter(|p| !p.is_empty())
        .collect::<Vec<_>>()
        .join("_")
}

/// A [`tempfile::Builder`] for a temporary sibling named `{prefix}XXXXXX{suffix}` (random
/// part), created with the permissions `File::create` / `create_dir` would give (0o666 or
/// 0o777 less the umask on Unix), not tempfile's private 0o600 / 0o700: the file or directory
/// is renamed into place and must end up as readable as one written directly.
pub(crate) fn sibling_builder<'a>(
    prefix: &'a str,
    suffix: &'a str,
    dir: bool,
) -> tempfile::Builder<'a, 'a> {
    let mut b = tempfile::Builder::new();
    b.prefix(prefix).suffix(suffix);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        b.permissions(std::fs::Permissions::from_mode(if dir {
            0o777
        } else {
            0o666
        }));
    }
    #[cfg(not(unix))]
    let _ = dir;
    b
}

/// Write `contents` to `path` atomically: a temporary file with a random name in the same
/// directory ([`tempfile`]), synced, then renamed over `path`; on failure it is removed.
pub fn write_atomic(path: &Path, contents: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| Error::InvalidInput(format!("{} is not a file path", path.display())))?;
    let io = |e| Error::io(path, e);
    let prefix = format!(".{}.", file_name.to_string_lossy());
    let mut tmp = sibling_builder(&prefix, ".tmp", false)
        .tempfile_in(dir)
        .map_err(io)?;
    tmp.write_all(contents).map_err(io)?;
    tmp.as_file().sync_all().map_err(io)?;
    tmp.persist(path).map_err(|e| io(e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_writes_replace_the_file_and_leave_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.json");
        write_atomic(&path, b"one").unwrap();
        write_atomic(&path, b"two").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
        // As readable as a file created directly (tempfile's own default is 0o600).
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let direct = dir.path().join("direct");
            std::fs::File::create(&direct).unwrap();
            let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode();
            assert_eq!(mode(&path), mode(&direct));
        }
        assert!(write_atomic(&dir.path().join("missing/a.json"), b"x").is_err());
        assert!(write_atomic(Path::new("/"), b"x").is_err());
    }
}
