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

/// Write `contents` to `path` atomically (temporary file in the same directory + rename).
pub fn write_atomic(path: &Path, contents: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| Error::InvalidInput(format!("{} is not a file path", path.display())))?;
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        file_name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(contents)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}
