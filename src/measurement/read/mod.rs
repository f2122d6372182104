//! Reading a user's own log (CSV or Parquet) into [`Log`]s, with a [`ReadReport`] of
//! everything repaired, dropped or estimated on the way.
//!
//! - **Format**: Parquet when the file starts with `PAR1`, else CSV with a header row (the
//!   delimiter is the map's or sniffed from the header: `,`, `;`, tab or space, the last
//!   being what UR's RTDE `record.py` writes). Parquet columns may be any integer or float
//!   type, or a timestamp type (its own unit then applies); an ISO-8601 time column may be
//!   text in either format.
//! - **Columns and units** come from a [`ColumnMap`] (or powertwin's own names without one)
//!   and are converted to SI. Times become seconds from the first sample; the first time
//!   stamp itself (s, e.g. Unix time) is reported.
//! - **Missing cells** (empty, `NaN`, `NA`, `null`, or absent from a short CSV row): an error
//!   naming the file, row and column, unless the map sets `[clean] drop_missing = true`, then
//!   the row is dropped and counted. Any other text is always an error naming the row and
//!   column. Extra fields at the end of a CSV row (a trailing delimiter) are ignored.
//! - Rows are named as a spreadsheet shows them for CSV (`row 2` is the first data row,
//!   the header being row 1) and as `data row N` (1-based) for Parquet.
//! - The time base is then repaired ([`crate::measurement::clean`]), the power-vs-joint lag
//!   estimated and, if asked, applied ([`crate::measurement::lag`]).
//! - A corrupt Parquet file is an error, also where the Parquet decoder panics on it.
//!
//! [`read_log`] runs its stages in this order: `files` opens the file and reads the wanted
//! columns, then `stages` drops rows with missing cells, converts to SI, repairs the time
//! base, splits at gaps and resamples, aligns the power by its lag, and cuts the logs.

mod files;
mod stages;

pub use files::parse_iso8601;

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::measurement::Log;
use crate::measurement::columns::{ColumnMap, PowerKind};
use crate::measurement::lag::LagEstimate;

use files::LogFile;
use stages::Wanted;

/// What to do with the power-vs-joint lag (`--power-lag`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum LagOption {
    /// Estimate and report it, do not apply it.
    #[default]
    Report,
    /// Estimate it and align the power by it.
    Auto,
    /// Align the power by this lag, s (positive: the power is late); no estimate.
    Fixed(f64),
}

impl FromStr for LagOption {
    type Err = Error;

    /// `report`, `auto`, or a lag in seconds.
    fn from_str(s: &str) -> Result<Self> {
        match s.trim() {
            "report" => Ok(LagOption::Report),
            "auto" => Ok(LagOption::Auto),
            other => match other.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(LagOption::Fixed(v)),
                _ => Err(Error::InvalidInput(format!(
                    "power lag '{other}' is not 'auto', 'report' or a finite number of seconds"
                ))),
            },
        }
    }
}

/// Options of [`read_log`] besides the column map.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReadOptions {
    /// The power kind, overriding the map's (`--power`).
    pub power: Option<PowerKind>,
    /// The power lag.
    pub lag: LagOption,
}

/// Everything [`read_log`] did to a file; printed by the CLI so nothing is dropped silently.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReadReport {
    /// The file.
    pub source: String,
    /// Data rows in the file.
    pub rows: usize,
    /// The first time stamp in the file, s (Unix time for timestamps); times in the logs
    /// are seconds from it.
    pub t0_s: f64,
    /// Median sample period of the file, s.
    pub median_period_s: f64,
    /// RMS deviation of the sample periods (gaps left out) from the median, s.
    pub period_jitter_s: f64,
    /// Rows dropped for an empty or NaN cell (`drop_missing`).
    pub missing_rows_dropped: usize,
    /// Rows merged into the row before for the same time stamp (averaged).
    pub duplicates_merged: usize,
    /// Steps of more than pi unwrapped in joints declared `wrapped`.
    pub unwrapped_jumps: usize,
    /// Steps of more than pi in joints not declared `wrapped` (left as they are).
    pub suspect_jumps: usize,
    /// Gaps found (the log is split at each).
    pub gaps: usize,
    /// Samples in pieces too short to keep, dropped.
    pub short_piece_samples_dropped: usize,
    /// Samples averaged per block to reach the working rate (1: none).
    pub decimation: usize,
    /// Gap-free pieces whose jittered stamps were replaced by their uniform grid, and the
    /// largest stamp deviation from the grid among them, s.
    pub regularized_pieces: usize,
    /// Largest stamp deviation from the grid in a regularized piece, s.
    pub regularized_max_dev_s: f64,
    /// Sample rate worked at, Hz (median).
    pub working_rate_hz: f64,
    /// Rests of at least `long_rest_s` (kept): how many and their total duration, s.
    pub long_rests: usize,
    /// Total duration of those rests, s.
    pub long_rest_total_s: f64,
    /// The estimated lag of the power behind the joints (None when not estimated).
    pub lag: Option<LagEstimate>,
    /// Why the lag could not be estimated, if it could not.
    pub lag_note: Option<String>,
    /// Lag applied to the power, s (0: none).
    pub lag_applied_s: f64,
    /// Samples at the ends dropped because the shifted power falls outside the log.
    pub lag_trimmed: usize,
    /// The pieces returned: time ranges, s from the first sample, and sample counts.
    pub pieces: Vec<(f64, f64, usize)>,
    /// What in the log looks wrong but was read as it is: a rate below 10 Hz, a joint
    /// stepping by more than pi, negative DC-bus or grid power, power that does not follow
    /// the motion or never reaches 5 W.
    pub warnings: Vec<String>,
}

/// The slowest rate powertwin is built for, Hz: below it a warning says the route between
/// samples is uncertain.
const MIN_RATE_HZ: f64 = 10.0;

/// The warnings of a read: a rate below [`MIN_RATE_HZ`], a joint that steps by more than pi
/// (`jump`), DC-bus or grid power that goes clearly negative (below -2 % of its highest
/// value: such a meter never reads negative, beyond its noise), power that stays within 1 W
/// while a joint moves over 0.01 rad, and power that never reaches 5 W (an arm that moves
/// draws more: likely kW).
fn warnings(
    logs: &[Log],
    kind: PowerKind,
    median_period_s: f64,
    jump: Option<String>,
) -> Vec<String> {
    let mut w = Vec::new();
    if 1.0 / median_period_s < MIN_RATE_HZ {
        w.push(format!(
            "sampled at {:.2} Hz, below the {MIN_RATE_HZ} Hz powertwin is built for: the motion \
             between samples is guessed, so energies of fast motions are uncertain beyond \
             their intervals",
            1.0 / median_period_s
        ));
    }
    w.extend(jump);
    let power = || logs.iter().flat_map(|l| l.power_w.iter().copied());
    let lowest = power().fold(f64::INFINITY, f64::min);
    let highest = power().fold(f64::NEG_INFINITY, f64::max);
    if matches!(kind, PowerKind::Bus | PowerKind::Grid) && lowest < -0.02 * highest.abs() {
        w.push(format!(
            "the {} power goes down to {lowest:.1} W, but such a meter never reads negative: \
             if it is the motors' signed sum, read it as `--power total`",
            if kind == PowerKind::Bus {
                "DC-bus"
            } else {
                "grid"
            }
        ));
    }
    let moves = logs.iter().any(|l| {
        l.q_rad.iter().any(|q| {
            let (lo, hi) = q
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(*v), b.max(*v))
                });
            hi - lo > 0.01
        })
    });
    if moves && highest - lowest < 1.0 {
        w.push(format!(
            "the power stays within {:.3} W while the joints move: an arm's power follows its \
             motion, so this column is not its power (or the meter holds its reading)",
            highest - lowest
        ));
    }
    if highest.max(-lowest) < 5.0 {
        w.push(format!(
            "the power never reaches 5 W (largest {:.3} W): is it logged in kW? Say so in a \
             column map (the power column's unit = \"kW\")",
            highest.max(-lowest)
        ));
    }
    w
}

impl fmt::Display for ReadReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {} rows, median period {:.6} s ({:.1} Hz), jitter {:.2e} s RMS, first time stamp {} s",
            self.source,
            self.rows,
            self.median_period_s,
            1.0 / self.median_period_s,
            self.period_jitter_s,
            self.t0_s
        )?;
        writeln!(
            f,
            "  dropped rows with missing cells: {}; duplicated time stamps merged: {}; wraps unwrapped: {}; suspect jumps > pi (not unwrapped): {}",
            self.missing_rows_dropped,
            self.duplicates_merged,
            self.unwrapped_jumps,
            self.suspect_jumps
        )?;
        writeln!(
            f,
            "  gaps: {} ({} samples in too-short pieces dropped); {}; rests >= long_rest_s kept: {} ({:.1} s)",
            self.gaps,
            self.short_piece_samples_dropped,
            match self.decimation {
                1 => format!("worked at {:.1} Hz (no averaging)", self.working_rate_hz),
                d => format!(
                    "block-averaged {d} samples -> {:.1} Hz",
                    self.working_rate_hz
                ),
            },
            self.long_rests,
            self.long_rest_total_s
        )?;
        writeln!(
            f,
            "  jittered stamps replaced by their uniform grid in {} piece(s) (largest deviation {:.2e} s)",
            self.regularized_pieces, self.regularized_max_dev_s
        )?;
        match (&self.lag, &self.lag_note) {
            (Some(l), _) => writeln!(
                f,
                "  power lag behind joints: {:+.4} s (fit R^2 {:.4}; {:.4} at zero lag)",
                l.lag_s, l.r2, l.r2_at_zero
            )?,
            (None, Some(n)) => writeln!(f, "  power lag not estimated: {n}")?,
            (None, None) => writeln!(f, "  power lag not estimated")?,
        }
        writeln!(
            f,
            "  power lag applied: {:+.4} s ({} end samples trimmed)",
            self.lag_applied_s, self.lag_trimmed
        )?;
        for w in &self.warnings {
            writeln!(f, "  warning: {w}")?;
        }
        let pieces: Vec<String> = self
            .pieces
            .iter()
            // Adding 0 turns a -0 of rounding into 0.
            .map(|(a, b, n)| format!("{:.3}-{:.3} s ({n} samples)", a + 0.0, b + 0.0))
            .collect();
        write!(f, "  pieces: {}", pieces.join(", "))
    }
}

/// The error of a map whose power columns do not fit the power kind `kind`. Without a map
/// of the user's (`header`: the file's columns, for powertwin's own names), the columns
/// those names would need are what is missing.
fn power_column_error(
    e: Error,
    header: Option<&Vec<String>>,
    kind: PowerKind,
    label: &str,
) -> Error {
    Error::InvalidInput(match header {
        Some(header) => {
            let needs = match kind {
                PowerKind::PerMotor => "one p_elec1_W.. column per motor",
                _ => "a P_total_W (or p_total_W) column",
            };
            format!(
                "{label}: no column map given, and power of the kind asked for (--power) needs \
                 {needs} in powertwin's own names (or pass --columns MAP.toml); columns found: {}",
                header.join(", ")
            )
        }
        None => format!("{label}: {e}"),
    })
}

/// Read a log file with `map` (None: powertwin's own column names) into gap-free [`Log`]s
/// (one unless the file has gaps), with the report of what was done. Times are seconds from
/// the file's first sample. See the module docs and [`crate::measurement::clean`].
pub fn read_log(
    path: &Path,
    map: Option<&ColumnMap>,
    opts: &ReadOptions,
) -> Result<(Vec<Log>, ReadReport)> {
    let label = path.display().to_string();
    let file = LogFile::open(path, &label, map.and_then(|m| m.delimiter))?;
    let owned;
    let owned_map = map.is_none();
    let map = match map {
        Some(m) => m,
        None => {
            owned = ColumnMap::powertwin(&file.header, &label)?;
            &owned
        }
    };
    map.validate()
        .map_err(|e| Error::InvalidInput(format!("{label}: column map: {e}")))?;
    let kind = map.kind(opts.power);
    let source = map
        .power_source(kind)
        .map_err(|e| power_column_error(e, owned_map.then_some(&file.header), kind, &label))?;

    let wanted = Wanted::of(map, &source);
    wanted.check_present(&file.header, &label)?;
    let cols = file.read(&wanted.names, map.time.unit)?;
    let rows = cols[0].len();
    let row_name = |k: usize| file.row_name(k);
    if rows < 2 {
        return Err(Error::InvalidInput(format!(
            "{label}: {rows} data rows; a log needs at least 2"
        )));
    }
    let kept = stages::drop_missing(cols, &wanted, map, &label, &row_name)?;
    let missing_rows_dropped = kept.dropped;
    let t0 = kept.cols[0][0];
    let mut frame = stages::to_si(kept, &wanted, map, &source, &label)?;
    let time_base = stages::repair_time_base(&mut frame, map, (t0, &label), &row_name)?;
    let mut resampled = stages::split_and_resample(frame, map, &label, &row_name)?;
    let lag = stages::align_power(&mut resampled.pieces, opts.lag, map, &label)?;
    let logs = stages::into_logs(resampled.pieces, &label, kind);
    let rests = stages::long_rests(&logs, map)?;
    let warnings = warnings(
        &logs,
        kind,
        time_base.median_period_s,
        time_base.jump_warning,
    );
    let report = ReadReport {
        source: label,
        rows,
        t0_s: t0,
        median_period_s: time_base.median_period_s,
        period_jitter_s: time_base.period_jitter_s,
        missing_rows_dropped,
        duplicates_merged: time_base.duplicates_merged,
        unwrapped_jumps: time_base.unwrapped_jumps,
        suspect_jumps: time_base.suspect_jumps,
        gaps: resampled.gaps,
        short_piece_samples_dropped: resampled.short_piece_samples_dropped,
        decimation: resampled.decimation,
        regularized_pieces: resampled.regularized_pieces,
        regularized_max_dev_s: resampled.regularized_max_dev_s,
        working_rate_hz: resampled.working_rate_hz,
        long_rests: rests.count,
        long_rest_total_s: rests.total_s,
        lag: lag.estimate,
        lag_note: lag.note,
        lag_applied_s: lag.applied_s,
        lag_trimmed: lag.trimmed,
        pieces: logs
            .iter()
            .map(|l| (l.t_s[0], l.t_s[l.len() - 1], l.len()))
            .collect(),
        warnings,
    };
    Ok((logs, report))
}
