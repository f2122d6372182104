//! A runs manifest: several logs, each with its own payload (and, where they differ, its own
//! column map, power kind and segments), read as one set of [`Log`]s (`--runs runs.toml`).
//!
//! # File format (TOML)
//! ```toml
//! columns = "ur-rtde"        # default column map of every run: a map file or preset; optional
//! power = "bus"              # default power kind (per-motor | total | bus | grid); optional
//!
//! [[run]]
//! log = "logs/excitation_01.csv"
//! payload = "none"           # none | built-in name | payload TOML path | "a.toml+b.toml"
//!
//! [[run]]
//! log = "logs/excitation_02.csv"
//! payload = "gripper_and_3kg.toml"
//! segments = "0-60"          # optional: all | auto | START-END,... (s from the log's start)
//! columns = "my_map.toml"    # optional per-run override of the default; power too
//!
//! [[run]]
//! log = "logs/pick_place.csv"
//! payload_events = "pick_place_payloads.toml"   # a payload timeline instead of `payload`
//! ```
//! Every run names its payload: `payload` (`"none"` for a bare flange) or `payload_events`
//! (a timeline file as `--payload-events` reads, [`crate::model::payload::timeline_from_file`]),
//! not both. Relative paths (logs, payload files, timelines, column maps) are relative to the
//! manifest's directory. Unknown keys are errors. Every error names the manifest file and the
//! run (1-based index and its log as written).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::measurement::Log;
use crate::measurement::columns::{ColumnMap, PowerKind, UR_RTDE};
use crate::measurement::read::{LagOption, ReadOptions, ReadReport, read_log};
use crate::measurement::segments::{MoveOptions, SegmentSpec, select};
use crate::model::payload::{PayloadEvent, resolve, timeline_from_file};

/// The manifest as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestFile {
    columns: Option<String>,
    power: Option<PowerKind>,
    #[serde(default)]
    run: Vec<toml::Table>,
}

/// One `[[run]]` as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RunEntry {
    log: PathBuf,
    payload: Option<String>,
    payload_events: Option<PathBuf>,
    segments: Option<String>,
    columns: Option<String>,
    power: Option<PowerKind>,
}

/// One run of a manifest, its paths resolved and its payloads read.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Position in the manifest, 1-based.
    pub index: usize,
    /// The log as the manifest writes it (for messages).
    pub log_as_written: String,
    /// The log file, resolved against the manifest's directory.
    pub log: PathBuf,
    /// Column map (the run's, else the manifest's default; `None`: powertwin's own names).
    pub columns: Option<ColumnMap>,
    /// Power kind overriding the map's (the run's, else the manifest's default).
    pub power: Option<PowerKind>,
    /// Parts of the log to use.
    pub segments: SegmentSpec,
    /// Payloads at the flange on the log's clock, s (empty: none throughout).
    pub payloads: Vec<PayloadEvent>,
}

impl Run {
    /// `run K (LOG)`, as messages name the run.
    pub fn label(&self) -> String {
        format!("run {} ({})", self.index, self.log_as_written)
    }
}

/// A runs manifest: its file and its runs, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// The manifest file (for messages).
    pub path: PathBuf,
    /// The runs, in the manifest's order (at least one).
    pub runs: Vec<Run>,
}

impl Manifest {
    /// Read and check a manifest file (see the module docs): every log exists, every payload,
    /// timeline, column map and segment list parses. Errors ([`Error::Toml`]) name the file
    /// and, for a run's problem, the run.
    pub fn from_file(path: &Path) -> Result<Manifest> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        Manifest::from_toml_str(&text, path, dir)
    }

    /// Parse a manifest's text; `path` names it in messages, `dir` resolves relative paths.
    pub fn from_toml_str(text: &str, path: &Path, dir: &Path) -> Result<Manifest> {
        let err = |message: String| Error::Toml {
            file: path.display().to_string(),
            message,
        };
        let file: ManifestFile =
            toml::from_str(text).map_err(|e| err(e.to_string().trim_end().to_string()))?;
        if file.run.is_empty() {
            return Err(err(
                "no [[run]]: list each log as [[run]] log = \"...\" payload = \"...\"".into(),
            ));
        }
        let defaults = Defaults {
            columns: file.columns.as_deref(),
            power: file.power,
            dir,
        };
        let runs = file
            .run
            .into_iter()
            .enumerate()
            .map(|(k, table)| {
                let written = match table.get("log") {
                    Some(toml::Value::String(s)) => s.clone(),
                    _ => "no log".to_string(),
                };
                parse_run(table, k + 1, &written, &defaults)
                    .map_err(|e| err(format!("run {} ({written}): {}", k + 1, message(e))))
            })
            .collect::<Result<Vec<Run>>>()?;
        Ok(Manifest {
            path: path.to_path_buf(),
            runs,
        })
    }

    /// Read `run`'s log (the power aligned as `lag` says), cut its segments and give every
    /// piece the run's payloads: the pieces (one unless the log has gaps or several segments)
    /// and the read report. Errors name the manifest and the run.
    pub fn read_run(&self, run: &Run, lag: LagOption) -> Result<(Vec<Log>, ReadReport)> {
        let opts = ReadOptions {
            power: run.power,
            lag,
        };
        let moves = run
            .columns
            .as_ref()
            .map_or(MoveOptions::default(), |m| MoveOptions {
                rest_speed_rad_s: m.clean.rest_speed_rad_s,
                ..MoveOptions::default()
            });
        let read = || -> Result<(Vec<Log>, ReadReport)> {
            let (pieces, report) = read_log(&run.log, run.columns.as_ref(), &opts)?;
            let mut logs = select(&pieces, &run.segments, &moves)?;
            for log in &mut logs {
                log.payloads = run.payloads.clone();
            }
            Ok((logs, report))
        };
        read().map_err(|e| {
            Error::InvalidInput(format!(
                "{}: {}: {}",
                self.path.display(),
                run.label(),
                message(e)
            ))
        })
    }
}

/// An error's message without the "invalid input: " of [`Error::InvalidInput`], to nest it
/// in one naming the manifest and the run.
fn message(e: Error) -> String {
    match e {
        Error::InvalidInput(m) => m,
        other => other.to_string(),
    }
}

/// The manifest's defaults for its runs.
struct Defaults<'a> {
    columns: Option<&'a str>,
    power: Option<PowerKind>,
    dir: &'a Path,
}

/// Check and resolve run `index` (1-based) from its table; errors say what is wrong (the
/// caller names the manifest and the run).
fn parse_run(table: toml::Table, index: usize, written: &str, d: &Defaults) -> Result<Run> {
    let entry: RunEntry = toml::Value::Table(table)
        .try_into()
        .map_err(|e: toml::de::Error| Error::InvalidInput(e.to_string().trim_end().into()))?;
    let log = d.dir.join(&entry.log);
    if !log.is_file() {
        return Err(Error::InvalidInput(format!(
            "log file {} not found",
            log.display()
        )));
    }
    let payloads = match (&entry.payload, &entry.payload_events) {
        (Some(_), Some(_)) => {
            return Err(Error::InvalidInput(
                "give payload or payload_events, not both".into(),
            ));
        }
        (None, None) => {
            return Err(Error::InvalidInput(
                "no payload: give payload = \"none\" for a bare flange, a payload, or payload_events".into(),
            ));
        }
        (Some(spec), None) if spec.trim() == "none" => Vec::new(),
        (Some(spec), None) => vec![PayloadEvent {
            t_s: f64::NEG_INFINITY,
            payload: Some(resolve(spec, d.dir)?),
        }],
        (None, Some(file)) => timeline_from_file(&d.dir.join(file))?,
    };
    let columns = match entry.columns.as_deref().or(d.columns) {
        None => None,
        Some(UR_RTDE) => Some(ColumnMap::ur_rtde()),
        Some(file) => Some(ColumnMap::load(&d.dir.join(file).display().to_string())?),
    };
    let segments = match &entry.segments {
        Some(s) => s.parse()?,
        None => SegmentSpec::All,
    };
    Ok(Run {
        index,
        log_as_written: written.to_string(),
        log,
        columns,
        power: entry.power.or(d.power),
        segments,
        payloads,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Manifest> {
        Manifest::from_toml_str(
            text,
            Path::new("runs.toml"),
            Path::new(env!("CARGO_MANIFEST_DIR")),
        )
    }

    #[test]
    fn runs_take_the_defaults_and_their_overrides() {
        let m = parse(
            "columns = \"ur-rtde\"\npower = \"bus\"\n\
             [[run]]\nlog = \"Cargo.toml\"\npayload = \"none\"\n\
             [[run]]\nlog = \"Cargo.toml\"\npayload = \"liu2018_tool+liu2018_load_2kg\"\n\
             segments = \"0-60\"\npower = \"grid\"\n",
        )
        .unwrap();
        assert_eq!(m.runs.len(), 2);
        assert!(m.runs[0].payloads.is_empty());
        assert_eq!(m.runs[0].power, Some(PowerKind::Bus));
        assert_eq!(m.runs[0].columns, Some(ColumnMap::ur_rtde()));
        assert_eq!(m.runs[1].power, Some(PowerKind::Grid));
        assert_eq!(m.runs[1].segments, SegmentSpec::Ranges(vec![(0.0, 60.0)]));
        let p = m.runs[1].payloads[0].payload.as_ref().unwrap();
        assert!((p.inertia.mass - 3.32).abs() < 1e-9, "{}", p.inertia.mass);
        assert_eq!(m.runs[1].label(), "run 2 (Cargo.toml)");
    }

    #[test]
    fn errors_name_the_manifest_and_the_run() {
        for (text, why) in [
            (
                "[[run]]\nlog = \"Cargo.toml\"\npayload = \"none\"\ncolour = 1\n",
                "colour",
            ),
            ("[[run]]\nlog = \"Cargo.toml\"\n", "no payload"),
            (
                "[[run]]\nlog = \"Cargo.toml\"\npayload = \"anvil\"\n",
                "anvil",
            ),
            (
                "[[run]]\nlog = \"Cargo.toml\"\npayload = \"none\"\nsegments = \"5-1\"\n",
                "5-1",
            ),
            (
                "[[run]]\nlog = \"Cargo.toml\"\npayload = \"none\"\npayload_events = \"x\"\n",
                "not both",
            ),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.starts_with("runs.toml: run 1 (Cargo.toml): "), "{e}");
            assert!(e.contains(why), "{e}");
        }
        let e = parse("[[run]]\nlog = \"missing.csv\"\npayload = \"none\"\n").unwrap_err();
        assert!(
            e.to_string().contains("run 1 (missing.csv): log file"),
            "{e}"
        );
        let e = parse("power = \"bus\"\n").unwrap_err();
        assert!(e.to_string().contains("runs.toml: no [[run]]"), "{e}");
        let e =
            parse("speed = 1\n[[run]]\nlog = \"Cargo.toml\"\npayload = \"none\"\n").unwrap_err();
        assert!(e.to_string().contains("speed"), "{e}");
    }
}
