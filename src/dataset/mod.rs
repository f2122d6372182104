//! Datasets: what one twin run produced, as a directory of files.
//!
//! ```text
//! DIR/
//!   meta.json          settings, true parameters, seeds and summary (schema: [`meta`])
//!   truth.parquet      the [`Recording`], one row per physics step     (or truth.csv)
//!   measured.parquet   the [`Measured`] stream, one row per sample       (or measured.csv)
//! ```
//! Every column is `f64` with its unit in its name ([`truth_columns`], [`measured_columns`]);
//! every value is finite. Both formats give back exactly the values written (same bits):
//! Parquet stores IEEE doubles, CSV the shortest decimal that parses back to the same double.
//! The time step and the sample rate, which are not columns, are `meta.twin.physics.dt_s`
//! and `meta.measurement.rate_hz`.
//!
//! [`Dataset::write`] is atomic and deterministic: the same dataset gives byte-identical
//! files. [`Dataset::read`] detects the format and checks the columns, their lengths against
//! `meta.json` and every value.

mod atomic;
pub mod bulk;
mod columns;
mod csv;
pub mod generate;
pub mod meta;
mod parquet;
pub mod schedule;

use std::io::Write;
use std::path::Path;
use std::str::FromStr;

pub use columns::{measured_columns, truth_columns};
pub use meta::{Meta, SCHEMA_VERSION};

use crate::error::{Error, Result};
use crate::measurement::Log;
use crate::measurement::clean::regularize_stamps;
use crate::measurement::columns::CleanOptions;
use crate::twin::record::{Measured, Recording};

/// Name of the metadata file.
const META_FILE: &str = atomic::MARKER;
/// File stem of the ground-truth table.
const TRUTH: &str = "truth";
/// File stem of the measured table.
const MEASURED: &str = "measured";

/// File format of the two tables (`meta.json` is always JSON).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Apache Parquet, Snappy-compressed `DOUBLE` columns (`.parquet`).
    Parquet,
    /// Comma-separated text with a header row (`.csv`).
    Csv,
}

impl Format {
    /// File name extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Parquet => "parquet",
            Format::Csv => "csv",
        }
    }

    /// The format of the dataset in `dir`, from which `truth.*` file it has. Errors
    /// ([`Error::Dataset`]) when it has neither or both.
    pub fn detect(dir: &Path) -> Result<Format> {
        let has = |f: Format| table_path(dir, TRUTH, f).is_file();
        match (has(Format::Parquet), has(Format::Csv)) {
            (true, false) => Ok(Format::Parquet),
            (false, true) => Ok(Format::Csv),
            (found_parquet, _) => Err(Error::Dataset {
                path: dir.to_path_buf(),
                message: if found_parquet {
                    "has both truth.parquet and truth.csv".into()
                } else {
                    "has neither truth.parquet nor truth.csv (not a dataset?)".into()
                },
            }),
        }
    }

    fn write_table(self, path: &Path, names: &[String], cols: &[&[f64]]) -> Result<()> {
        match self {
            Format::Parquet => parquet::write(path, names, cols),
            Format::Csv => csv::write(path, names, cols),
        }
    }

    fn read_table(self, path: &Path, names: &[String]) -> Result<Vec<Vec<f64>>> {
        match self {
            Format::Parquet => parquet::read(path, names),
            Format::Csv => csv::read(path, names),
        }
    }
}

impl FromStr for Format {
    type Err = Error;

    /// `parquet` or `csv`.
    fn from_str(s: &str) -> Result<Format> {
        [Format::Parquet, Format::Csv]
            .into_iter()
            .find(|f| f.extension() == s)
            .ok_or_else(|| {
                Error::InvalidInput(format!(
                    "unknown dataset format '{s}' (valid: parquet, csv)"
                ))
            })
    }
}

/// A twin run: metadata, ground truth and measurements.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// Settings, true parameters and summary; its `robot.dof`, `twin.physics.dt_s`,
    /// `measurement.rate_hz` and `summary` row counts must agree with the records.
    pub meta: Meta,
    /// Ground truth at the physics rate.
    pub truth: Recording,
    /// The logged stream.
    pub measured: Measured,
}

impl Dataset {
    /// Write the dataset to the directory `dir` (created, or replaced if it holds a dataset or
    /// is empty), tables in `format`.
    ///
    /// The files are written into a temporary sibling directory `.{name}.tmp-{pid}` that is
    /// renamed to `dir` when complete; an existing dataset at `dir` is replaced only then. A
    /// failure or a crash never leaves a partly written dataset at `dir`.
    ///
    /// Errors: [`Error::InvalidInput`] when the records disagree with `meta` or with each
    /// other's lengths, or hold a non-finite value (names table, column and row), or when
    /// `dir` exists and is neither empty nor a dataset; [`Error::Io`] for file system errors
    /// (e.g. a missing parent directory).
    pub fn write(&self, dir: &Path, format: Format) -> Result<()> {
        check_meta(&self.meta).map_err(Error::InvalidInput)?;
        let dof = self.meta.robot.dof;
        let truth = columns::columns(columns::TRUTH, &self.truth, dof, TRUTH)?;
        let measured = columns::columns(columns::MEASURED, &self.measured, dof, MEASURED)?;
        self.check_agreement().map_err(Error::InvalidInput)?;
        let meta = serde_json::to_vec_pretty(&self.meta)
            .map_err(|e| Error::InvalidInput(format!("meta cannot be serialised: {e}")))?;
        atomic::write_dir(dir, |tmp| {
            for (stem, names, cols) in [
                (TRUTH, truth_columns(dof), &truth),
                (MEASURED, measured_columns(dof), &measured),
            ] {
                columns::ensure_finite(stem, &names, cols)?;
                format.write_table(&table_path(tmp, stem, format), &names, cols)?;
            }
            write_file(&tmp.join(META_FILE), &meta)
        })
    }

    /// Read the dataset in `dir` (Parquet or CSV, detected by [`Format::detect`]).
    ///
    /// Errors name the file and, where there is one, the column and row: [`Error::Io`] for a
    /// missing or unreadable file, [`Error::Dataset`] for malformed `meta.json` (or an
    /// unsupported `schema_version`), an unreadable or truncated Parquet file, missing,
    /// unexpected or non-`f64` columns, null or non-finite cells, and tables whose row counts
    /// differ from `meta.json`; [`Error::Table`] for a CSV cell that is not a finite number.
    pub fn read(dir: &Path) -> Result<Dataset> {
        let meta = read_meta(&dir.join(META_FILE))?;
        let format = Format::detect(dir)?;
        let dof = meta.robot.dof;
        let read = |stem: &str, names: &[String], rows: usize| -> Result<Vec<Vec<f64>>> {
            let path = table_path(dir, stem, format);
            let cols = format.read_table(&path, names)?;
            let found = cols.first().map_or(0, Vec::len);
            if found != rows {
                return Err(Error::Dataset {
                    path,
                    message: format!(
                        "{found} rows, but meta.json (summary.{stem}_rows) says {rows}"
                    ),
                });
            }
            Ok(cols)
        };
        let truth_cols = read(TRUTH, &truth_columns(dof), meta.summary.truth_rows)?;
        let measured_cols = read(MEASURED, &measured_columns(dof), meta.summary.measured_rows)?;
        let mut truth: Recording = columns::record(columns::TRUTH, dof, truth_cols);
        truth.dt = meta.twin.physics.dt;
        let mut measured: Measured = columns::record(columns::MEASURED, dof, measured_cols);
        measured.rate_hz = meta.measurement.rate_hz;
        Ok(Dataset {
            meta,
            truth,
            measured,
        })
    }

    /// What a user of the robot would have of this run: the logged stream (positions, total
    /// power of the kind the logger recorded, per-motor power) and the known payload
    /// timeline; no truth. Jittered time stamps are replaced by their uniform grid, as
    /// reading the log from a file does ([`crate::measurement::clean::regularize`]).
    /// Errors: a payload record that is not physical.
    pub fn log(&self, source: &str) -> Result<Log> {
        let m = &self.measured;
        let mut t_s = m.t.clone();
        let period = match t_s.as_slice() {
            [a, b, ..] => b - a,
            _ => 0.0,
        };
        let uniform = t_s
            .iter()
            .enumerate()
            .all(|(k, t)| (t - t_s[0] - k as f64 * period).abs() <= 1e-9);
        if !uniform
            && regularize_stamps(&mut t_s, CleanOptions::default().max_jitter_periods).is_some()
        {
            // The grid's first stamp may fall before the run's start: the log starts at 0.
            let first = t_s[0].min(0.0);
            t_s.iter_mut().for_each(|t| *t -= first);
        }
        Ok(Log {
            source: source.to_string(),
            robot: Some(self.meta.robot.name.clone()),
            t_s,
            q_rad: m.q.clone(),
            dq_rad_s: None,
            power_w: m.p_total.clone(),
            signal: self.meta.measurement.power_signal,
            motor_power_w: Some(m.p_joint.clone()),
            power_averaged: self.meta.measurement.power_averaging,
            payloads: self
                .meta
                .payloads
                .iter()
                .map(|p| p.event())
                .collect::<Result<_>>()?,
        })
    }

    /// Check that the records agree with what `meta` says about them (the time step, the
    /// sample rate and the row counts).
    fn check_agreement(&self) -> std::result::Result<(), String> {
        let m = &self.meta;
        if self.truth.dt.to_bits() != m.twin.physics.dt.to_bits() {
            return Err(format!(
                "truth.dt = {} s but meta.twin.physics.dt_s = {} s",
                self.truth.dt, m.twin.physics.dt
            ));
        }
        if self.measured.rate_hz.to_bits() != m.measurement.rate_hz.to_bits() {
            return Err(format!(
                "measured.rate_hz = {} Hz but meta.measurement.rate_hz = {} Hz",
                self.measured.rate_hz, m.measurement.rate_hz
            ));
        }
        let rows = [
            ("truth", self.truth.len(), m.summary.truth_rows),
            ("measured", self.measured.t.len(), m.summary.measured_rows),
        ];
        for (what, have, said) in rows {
            if have != said {
                return Err(format!(
                    "{what} has {have} rows but meta.summary.{what}_rows = {said} (fill the summary with Summary::of)"
                ));
            }
        }
        Ok(())
    }
}

/// Path of a table file in `dir`.
fn table_path(dir: &Path, stem: &str, format: Format) -> std::path::PathBuf {
    dir.join(format!("{stem}.{}", format.extension()))
}

/// Consistency checks of `meta` on its own (the message names the key).
fn check_meta(meta: &Meta) -> std::result::Result<(), String> {
    if meta.schema_version != SCHEMA_VERSION {
        return Err(format!(
            "schema_version {} is not supported (this build reads and writes {SCHEMA_VERSION})",
            meta.schema_version
        ));
    }
    let dof = meta.robot.dof;
    let per_joint = [
        ("robot.joint_names", meta.robot.joint_names.len()),
        ("drives", meta.drives.len()),
    ];
    for (key, len) in per_joint {
        if len != dof {
            return Err(format!("{key} has {len} entries, robot.dof is {dof}"));
        }
    }
    let pairs = [
        (
            "standard_params",
            &meta.standard_params.names,
            &meta.standard_params.values,
        ),
        (
            "base_params",
            &meta.base_params.names,
            &meta.base_params.values,
        ),
    ];
    for (key, names, values) in pairs {
        if names.len() != values.len() {
            return Err(format!(
                "{key} has {} names and {} values",
                names.len(),
                values.len()
            ));
        }
    }
    let rates = [
        ("twin.physics.dt_s", meta.twin.physics.dt),
        ("measurement.rate_hz", meta.measurement.rate_hz),
    ];
    for (key, v) in rates {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("{key} = {v} must be finite and positive"));
        }
    }
    Ok(())
}

/// Read `meta.json`: check `schema_version` first, then parse strictly (unknown keys are
/// errors) and check consistency.
fn read_meta(path: &Path) -> Result<Meta> {
    let bad = |message: String| Error::Dataset {
        path: path.to_path_buf(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not valid JSON: {e}")))?;
    match value.get("schema_version").map(serde_json::Value::as_u64) {
        None => return Err(bad("no schema_version (not a powertwin dataset?)".into())),
        Some(Some(v)) if v == u64::from(SCHEMA_VERSION) => {}
        Some(v) => {
            return Err(bad(format!(
                "schema_version {} is not supported (this build reads {SCHEMA_VERSION})",
                v.map_or_else(|| value["schema_version"].to_string(), |v| v.to_string())
            )));
        }
    }
    let meta: Meta = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    check_meta(&meta).map_err(bad)?;
    Ok(meta)
}

/// Write `bytes` (plus a final newline) to a new file and sync it.
fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |e| Error::io(path, e);
    let mut f = std::fs::File::create(path).map_err(io)?;
    f.write_all(bytes).map_err(io)?;
    f.write_all(b"\n").map_err(io)?;
    f.sync_all().map_err(io)
}
