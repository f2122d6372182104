//! The runs manifest of a designed identification set, `runs.toml`, which `identify --runs`
//! reads: one `[[run]]` per excitation with the path of the log the user records (relative
//! to the manifest) and the payload mounted during it.
//!
//! ```toml
//! # columns = "ur-rtde"       # optional default for every run: a map file or preset
//! # power = "bus"             # optional default signal
//! [[run]]
//! log = "logs/excitation_01.csv"   # relative to the manifest
//! payload = "none"                 # none | built-in name | payload TOML path | "a.toml+b.toml"
//! # segments = "0-60"              # optional
//! ```
//! Payload files are copied into `payloads/` next to the manifest ([`portable_payload`]), so
//! that the directory resolves on its own wherever it is moved.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::io::write_atomic;
use crate::model::builtin::is_payload_name;

/// One run of the manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedRun {
    /// The excitation to run, a file next to the manifest (`excitation_01.csv`).
    pub excitation: String,
    /// Where the user saves the log, relative to the manifest (`logs/excitation_01.csv`).
    pub log: String,
    /// Payload mounted during the run, resolvable from the manifest's directory.
    pub payload: String,
}

/// The log path of excitation `k` (1-based) in the manifest: `logs/excitation_01.csv`.
pub fn log_path(k: usize) -> String {
    format!("logs/excitation_{k:02}.csv")
}

/// A TOML basic string holding `s`.
fn quoted(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The manifest text: `header` lines as comments (what to record), commented defaults,
/// then one `[[run]]` per entry of `runs`.
pub fn manifest_toml(header: &[String], runs: &[PlannedRun]) -> String {
    let mut out = String::new();
    for line in header {
        let _ = writeln!(out, "# {line}");
    }
    out.push_str(
        "#\n# Defaults for every run (uncomment and adapt; docs/guide/log-columns.md):\n\
         # columns = \"ur-rtde\"   # the log's column map: a map file or preset\n\
         # power = \"bus\"         # the power signal: per-motor | total | bus | grid\n",
    );
    for run in runs {
        let _ = write!(
            out,
            "\n# {}\n[[run]]\nlog = {}\npayload = {}\n# segments = \"0-60\"   # optional: the log's time ranges (s) that are the excitation\n",
            run.excitation,
            quoted(&run.log),
            quoted(&run.payload)
        );
    }
    out
}

/// `spec` (`none`, a built-in payload name, a payload TOML path relative to `from`, or
/// several joined by `+`) rewritten to resolve from `dir`: built-in names stay, each file is
/// copied into `dir/payloads/` under its own name (prefixed `k_` when another file already
/// took the name) and named by that path (`payloads/tool.payload.toml`). `copied` remembers
/// the files copied so far (source, path in `dir`) so that a file used by several runs is
/// copied once.
///
/// Errors: a part that is neither a built-in name nor a file, a file that cannot be read or
/// written.
pub fn portable_payload(
    spec: &str,
    from: &Path,
    dir: &Path,
    copied: &mut Vec<(PathBuf, String)>,
) -> Result<String> {
    if spec.trim() == "none" {
        return Ok("none".into());
    }
    let mut parts = Vec::new();
    for part in spec.split('+').map(str::trim) {
        if is_payload_name(part) {
            parts.push(part.to_string());
            continue;
        }
        let source = from.join(part);
        let io = |source_err: std::io::Error, path: &Path| Error::Io {
            path: path.to_path_buf(),
            source: source_err,
        };
        let canonical = source.canonicalize().map_err(|e| {
            Error::InvalidInput(format!(
                "payload '{part}' is neither a built-in name nor a readable file ({e})"
            ))
        })?;
        if let Some((_, name)) = copied.iter().find(|(p, _)| *p == canonical) {
            parts.push(name.clone());
            continue;
        }
        let file_name = canonical
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_else(|| "payload.toml".into());
        let name = if copied
            .iter()
            .any(|(_, n)| *n == format!("payloads/{file_name}"))
        {
            format!("payloads/{}_{file_name}", copied.len() + 1)
        } else {
            format!("payloads/{file_name}")
        };
        let text = std::fs::read(&canonical).map_err(|e| io(e, &canonical))?;
        let target = dir.join(&name);
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).map_err(|e| io(e, parent))?;
        }
        write_atomic(&target, &text)?;
        copied.push((canonical, name.clone()));
        parts.push(name);
    }
    Ok(parts.join("+"))
}
