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

use std::fmt;
use std::fs::File;
use std::io::Read;
use std::path::Path;
use std::str::FromStr;

use arrow_array::cast::AsArray;
use arrow_array::types::{
    Float32Type, Float64Type, Int8Type, Int16Type, Int32Type, Int64Type, TimestampMicrosecondType,
    TimestampMillisecondType, TimestampNanosecondType, TimestampSecondType, UInt8Type, UInt16Type,
    UInt32Type, UInt64Type,
};
use arrow_array::{Array, ArrayRef};
use arrow_schema::DataType;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use serde::Serialize;

use crate::error::{Error, Result, catch_decoder_panic};
use crate::measurement::clean::{self, Frame, median_period};
use crate::measurement::columns::{
    AngleUnit, ColumnMap, PowerKind, PowerSource, PowerUnit, RateUnit, TimeUnit,
};
use crate::measurement::lag::{self, LagEstimate};
use crate::measurement::{Log, segments};

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
            "  gaps: {} ({} samples in too-short pieces dropped); block-averaged {} samples -> {:.1} Hz; rests >= long_rest_s kept: {} ({:.1} s)",
            self.gaps,
            self.short_piece_samples_dropped,
            self.decimation,
            self.working_rate_hz,
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
        let pieces: Vec<String> = self
            .pieces
            .iter()
            .map(|(a, b, n)| format!("{a:.3}-{b:.3} s ({n} samples)"))
            .collect();
        write!(f, "  pieces: {}", pieces.join(", "))
    }
}

/// Whether the file is Parquet (starts with the magic `PAR1`).
fn is_parquet(path: &Path) -> Result<bool> {
    let mut magic = [0u8; 4];
    let mut f = File::open(path).map_err(|e| Error::io(path, e))?;
    let n = f.read(&mut magic).map_err(|e| Error::io(path, e))?;
    Ok(n == 4 && &magic == b"PAR1")
}

/// The CSV delimiter: `given`, else the first of `,` `;` tab space found in the header line.
fn delimiter(path: &Path, given: Option<char>) -> Result<u8> {
    if let Some(c) = given {
        return Ok(c as u8);
    }
    let mut f = File::open(path).map_err(|e| Error::io(path, e))?;
    let mut buf = vec![0u8; 64 * 1024];
    let n = f.read(&mut buf).map_err(|e| Error::io(path, e))?;
    let line = buf[..n].split(|&b| b == b'\n').next().unwrap_or(&[]);
    Ok([b',', b';', b'\t', b' ']
        .into_iter()
        .find(|d| line.contains(d))
        .unwrap_or(b','))
}

fn csv_reader(path: &Path, delim: u8) -> Result<csv::Reader<File>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    Ok(csv::ReaderBuilder::new()
        .delimiter(delim)
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(file))
}

/// Run a Parquet read of the file `label`; a panic of the decoder (some corrupt files make
/// parquet 58.4.1 panic) becomes an error like any other unreadable file.
fn guarded<T>(label: &str, read: impl FnOnce() -> Result<T>) -> Result<T> {
    catch_decoder_panic(read).unwrap_or_else(|why| {
        Err(Error::InvalidInput(format!(
            "{label}: corrupt Parquet file: the decoder failed ({why})"
        )))
    })
}

/// Column names of the file.
fn headers(path: &Path, label: &str, parquet: bool, delim: u8) -> Result<Vec<String>> {
    if parquet {
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        let b = guarded(label, || {
            ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| {
                Error::InvalidInput(format!("{label}: not a readable Parquet file: {e}"))
            })
        })?;
        Ok(b.schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect())
    } else {
        let mut r = csv_reader(path, delim)?;
        let h = r
            .headers()
            .map_err(|e| Error::InvalidInput(format!("{label}: row 1: {e}")))?;
        Ok(h.iter().map(str::to_string).collect())
    }
}

/// Parse an ISO-8601 date-time, `YYYY-MM-DD[T ]hh:mm:ss[.fff][Z|+hh:mm|-hh:mm|+hhmm]`
/// (no zone: UTC), to Unix seconds.
pub fn parse_iso8601(s: &str) -> Option<f64> {
    let s = s.trim();
    let b = s.as_bytes();
    if b.len() < 19 || b[4] != b'-' || b[7] != b'-' || !matches!(b[10], b'T' | b't' | b' ') {
        return None;
    }
    if b[13] != b':' || b[16] != b':' {
        return None;
    }
    let num = |r: std::ops::Range<usize>| -> Option<i64> {
        let t = s.get(r)?;
        t.bytes()
            .all(|c| c.is_ascii_digit())
            .then(|| t.parse().ok())?
    };
    let (y, mo, d) = (num(0..4)?, num(5..7)?, num(8..10)?);
    let (h, mi, sec) = (num(11..13)?, num(14..16)?, num(17..19)?);
    if !(1..=12).contains(&mo) || !(1..=31).contains(&d) || h > 23 || mi > 59 || sec > 60 {
        return None;
    }
    let mut rest = &s[19..];
    let mut frac = 0.0;
    if let Some(r) = rest.strip_prefix('.').or_else(|| rest.strip_prefix(',')) {
        let digits = r.bytes().take_while(u8::is_ascii_digit).count();
        if digits == 0 {
            return None;
        }
        frac = format!("0.{}", &r[..digits]).parse().ok()?;
        rest = &r[digits..];
    }
    let offset_s = match rest {
        "" | "Z" | "z" => 0,
        z => {
            let sign = match z.as_bytes()[0] {
                b'+' => 1,
                b'-' => -1,
                _ => return None,
            };
            let z = z[1..].replace(':', "");
            if z.len() != 4 || !z.bytes().all(|c| c.is_ascii_digit()) {
                return None;
            }
            let (zh, zm): (i64, i64) = (z[..2].parse().ok()?, z[2..].parse().ok()?);
            sign * (zh * 3600 + zm * 60)
        }
    };
    // Days from 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
    let yy = if mo <= 2 { y - 1 } else { y };
    let era = yy.div_euclid(400);
    let yoe = yy - era * 400;
    let mp = (mo + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    let secs = days * 86_400 + h * 3600 + mi * 60 + sec - offset_s;
    Some(secs as f64 + frac)
}

/// A missing cell: empty or a NaN spelling.
fn is_missing(cell: &str) -> bool {
    matches!(
        cell.to_ascii_lowercase().as_str(),
        "" | "nan" | "-nan" | "na" | "n/a" | "null" | "none"
    )
}

/// Read the columns `wanted` (by name) of a CSV file; `time` (index into `wanted`) in
/// `unit`. Missing cells become NaN; other bad cells are errors naming the row and column.
fn read_csv(
    path: &Path,
    label: &str,
    delim: u8,
    wanted: &[String],
    time: usize,
    unit: TimeUnit,
) -> Result<Vec<Vec<f64>>> {
    let mut r = csv_reader(path, delim)?;
    let h: Vec<String> = r
        .headers()
        .map_err(|e| Error::InvalidInput(format!("{label}: row 1: {e}")))?
        .iter()
        .map(str::to_string)
        .collect();
    let index: Vec<usize> = wanted
        .iter()
        .map(|w| h.iter().position(|c| c == w).unwrap_or(usize::MAX))
        .collect();
    let mut out = vec![Vec::new(); wanted.len()];
    for (k, rec) in r.records().enumerate() {
        let row = k + 2;
        let rec = rec.map_err(|e| Error::InvalidInput(format!("{label}: row {row}: {e}")))?;
        for (c, &i) in index.iter().enumerate() {
            let cell = rec.get(i).unwrap_or("");
            let v = if is_missing(cell) {
                f64::NAN
            } else if c == time && unit == TimeUnit::Iso8601 {
                parse_iso8601(cell).ok_or_else(|| {
                    Error::InvalidInput(format!(
                        "{label}: row {row}: column '{}': '{cell}' is not an ISO-8601 date-time",
                        wanted[c]
                    ))
                })?
            } else {
                let v: f64 = cell.parse().map_err(|_| {
                    Error::InvalidInput(format!(
                        "{label}: row {row}: column '{}': '{cell}' is not a number",
                        wanted[c]
                    ))
                })?;
                if v.is_infinite() {
                    return Err(Error::InvalidInput(format!(
                        "{label}: row {row}: column '{}' is {v} (must be finite)",
                        wanted[c]
                    )));
                }
                if c == time { v * unit.seconds() } else { v }
            };
            out[c].push(v);
        }
    }
    Ok(out)
}

/// Values of an Arrow array as `f64` (nulls as NaN); timestamp types in seconds; text
/// parsed as ISO-8601 when `iso`. `scale` multiplies plain numbers.
fn arrow_f64(a: &ArrayRef, name: &str, label: &str, iso: bool, scale: f64) -> Result<Vec<f64>> {
    macro_rules! prim {
        ($t:ty, $s:expr) => {
            a.as_primitive::<$t>()
                .iter()
                .map(|v| v.map_or(f64::NAN, |x| x as f64 * $s))
                .collect()
        };
    }
    let v: Vec<f64> = match a.data_type() {
        DataType::Float64 => prim!(Float64Type, scale),
        DataType::Float32 => prim!(Float32Type, scale),
        DataType::Int8 => prim!(Int8Type, scale),
        DataType::Int16 => prim!(Int16Type, scale),
        DataType::Int32 => prim!(Int32Type, scale),
        DataType::Int64 => prim!(Int64Type, scale),
        DataType::UInt8 => prim!(UInt8Type, scale),
        DataType::UInt16 => prim!(UInt16Type, scale),
        DataType::UInt32 => prim!(UInt32Type, scale),
        DataType::UInt64 => prim!(UInt64Type, scale),
        DataType::Timestamp(u, _) => {
            use arrow_schema::TimeUnit as U;
            match u {
                U::Second => prim!(TimestampSecondType, 1.0),
                U::Millisecond => prim!(TimestampMillisecondType, 1e-3),
                U::Microsecond => prim!(TimestampMicrosecondType, 1e-6),
                U::Nanosecond => prim!(TimestampNanosecondType, 1e-9),
            }
        }
        DataType::Utf8 | DataType::LargeUtf8 if iso => {
            let strings: Vec<Option<&str>> = match a.data_type() {
                DataType::Utf8 => a.as_string::<i32>().iter().collect(),
                _ => a.as_string::<i64>().iter().collect(),
            };
            strings
                .into_iter()
                .map(|s| match s {
                    None => Ok(f64::NAN),
                    Some(s) if is_missing(s) => Ok(f64::NAN),
                    Some(s) => parse_iso8601(s).ok_or_else(|| {
                        Error::InvalidInput(format!(
                            "{label}: column '{name}': '{s}' is not an ISO-8601 date-time"
                        ))
                    }),
                })
                .collect::<Result<_>>()?
        }
        other => {
            return Err(Error::InvalidInput(format!(
                "{label}: column '{name}' has type {other}; expected an integer, float or timestamp column{}",
                if iso { " or ISO-8601 text" } else { "" }
            )));
        }
    };
    if let Some(k) = v.iter().position(|x| x.is_infinite()) {
        return Err(Error::InvalidInput(format!(
            "{label}: column '{name}' is infinite at a data row (value {})",
            v[k]
        )));
    }
    Ok(v)
}

/// Read the columns `wanted` of a Parquet file (see [`read_csv`]).
fn read_parquet(
    path: &Path,
    label: &str,
    wanted: &[String],
    time: usize,
    unit: TimeUnit,
) -> Result<Vec<Vec<f64>>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file)
        .map_err(|e| Error::InvalidInput(format!("{label}: not a readable Parquet file: {e}")))?;
    let found: Vec<String> = builder
        .schema()
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .collect();
    let index: Vec<usize> = wanted
        .iter()
        .map(|w| found.iter().position(|c| c == w).unwrap_or(usize::MAX))
        .collect();
    let reader = builder
        .with_batch_size(65_536)
        .build()
        .map_err(|e| Error::InvalidInput(format!("{label}: cannot read: {e}")))?;
    let mut out = vec![Vec::new(); wanted.len()];
    for batch in reader {
        let batch = batch
            .map_err(|e| Error::InvalidInput(format!("{label}: cannot decode (corrupt?): {e}")))?;
        for (c, &i) in index.iter().enumerate() {
            let is_time = c == time;
            let scale = if is_time { unit.seconds() } else { 1.0 };
            let iso = is_time && unit == TimeUnit::Iso8601;
            out[c].extend(arrow_f64(batch.column(i), &wanted[c], label, iso, scale)?);
        }
    }
    Ok(out)
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
    let parquet = is_parquet(path)?;
    let delim = delimiter(path, map.and_then(|m| m.delimiter))?;
    let header = headers(path, &label, parquet, delim)?;
    let owned;
    let map = match map {
        Some(m) => m,
        None => {
            owned = ColumnMap::powertwin(&header, &label)?;
            &owned
        }
    };
    map.validate()
        .map_err(|e| Error::InvalidInput(format!("{label}: column map: {e}")))?;
    let kind = map.kind(opts.power);
    let source = map
        .power_source(kind)
        .map_err(|e| Error::InvalidInput(format!("{label}: {e}")))?;
    let n = map.dof();
    // The columns to read, in this order: time, positions, velocities, power, motors.
    let mut wanted = vec![map.time.column.clone()];
    wanted.extend(map.joints.position.iter().cloned());
    let dq_at = wanted.len();
    wanted.extend(map.joints.velocity.iter().flatten().cloned());
    let p_at = wanted.len();
    match &source {
        PowerSource::Column { name, .. } => wanted.push(name.clone()),
        PowerSource::VoltageCurrent { voltage, current } => {
            wanted.push(voltage.clone());
            wanted.push(current.clone());
        }
        PowerSource::MotorSum => {}
    }
    let motors_at = wanted.len();
    wanted.extend(map.power.motors.iter().flatten().cloned());
    let absent: Vec<&String> = wanted.iter().filter(|w| !header.contains(w)).collect();
    if !absent.is_empty() {
        return Err(Error::InvalidInput(format!(
            "{label}: missing column(s) {} (columns found: {})",
            absent
                .iter()
                .map(|a| format!("'{a}'"))
                .collect::<Vec<_>>()
                .join(", "),
            header.join(", ")
        )));
    }
    let mut cols = if parquet {
        guarded(&label, || {
            read_parquet(path, &label, &wanted, 0, map.time.unit)
        })?
    } else {
        read_csv(path, &label, delim, &wanted, 0, map.time.unit)?
    };
    let rows = cols[0].len();
    let row_name = move |k: usize| {
        if parquet {
            format!("data row {}", k + 1)
        } else {
            format!("row {}", k + 2)
        }
    };
    if rows < 2 {
        return Err(Error::InvalidInput(format!(
            "{label}: {rows} data rows; a log needs at least 2"
        )));
    }
    // Missing cells: refuse (naming the first) or drop the rows.
    let bad_rows: Vec<usize> = (0..rows)
        .filter(|&k| cols.iter().any(|c| c[k].is_nan()))
        .collect();
    if let Some(&k) = bad_rows.first()
        && !map.clean.drop_missing
    {
        let c = cols.iter().position(|c| c[k].is_nan()).unwrap_or(0);
        return Err(Error::InvalidInput(format!(
            "{label}: {}: column '{}' is empty or NaN ({} rows have missing cells; set [clean] drop_missing = true in a column map to drop them)",
            row_name(k),
            wanted[c],
            bad_rows.len()
        )));
    }
    let mut file_rows: Vec<usize> = (0..rows).collect();
    if !bad_rows.is_empty() {
        let keep: Vec<bool> = (0..rows)
            .map(|k| bad_rows.binary_search(&k).is_err())
            .collect();
        for c in &mut cols {
            *c = c
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(v, _)| *v)
                .collect();
        }
        file_rows.retain(|&k| keep[k]);
        if file_rows.len() < 2 {
            return Err(Error::InvalidInput(format!(
                "{label}: {} of {rows} data rows have missing cells; dropping them leaves {}, and a log needs at least 2",
                bad_rows.len(),
                file_rows.len()
            )));
        }
    }
    // Units to SI.
    let deg = std::f64::consts::PI / 180.0;
    let q_scale = match map.joints.position_unit {
        AngleUnit::Rad => 1.0,
        AngleUnit::Deg => deg,
    };
    let dq_scale = match map.joints.velocity_unit {
        RateUnit::RadS => 1.0,
        RateUnit::DegS => deg,
    };
    let p_scale = match map.power.unit {
        PowerUnit::W => 1.0,
        PowerUnit::KW => 1e3,
    };
    let scaled = |c: &Vec<f64>, s: f64| c.iter().map(|v| v * s).collect::<Vec<f64>>();
    let t0 = cols[0][0];
    let motors: Option<Vec<Vec<f64>>> = map.power.motors.as_ref().map(|_| {
        (0..n)
            .map(|i| scaled(&cols[motors_at + i], p_scale))
            .collect()
    });
    let power_w = match &source {
        PowerSource::Column { scale, .. } => scaled(&cols[p_at], *scale),
        PowerSource::VoltageCurrent { .. } => cols[p_at]
            .iter()
            .zip(&cols[p_at + 1])
            .map(|(u, i)| u * i)
            .collect(),
        PowerSource::MotorSum => {
            let m = motors.as_ref().ok_or_else(|| {
                Error::InvalidInput(format!("{label}: no motor power columns to sum"))
            })?;
            (0..file_rows.len())
                .map(|k| m.iter().map(|p| p[k]).sum())
                .collect()
        }
    };
    let mut frame = Frame {
        t_s: cols[0].iter().map(|t| t - t0).collect(),
        row: file_rows,
        q_rad: (0..n).map(|i| scaled(&cols[1 + i], q_scale)).collect(),
        dq_rad_s: map
            .joints
            .velocity
            .as_ref()
            .map(|_| (0..n).map(|i| scaled(&cols[dq_at + i], dq_scale)).collect()),
        power_w,
        motor_power_w: motors,
    };
    drop(cols);
    let missing_rows_dropped = bad_rows.len();
    let duplicates_merged = clean::merge_duplicates(&mut frame, &label, &row_name)?;
    let wrapped: Vec<usize> = map.joints.wrapped.iter().map(|j| j - 1).collect();
    let unwrapped_jumps = clean::unwrap(&mut frame, &wrapped);
    let suspect_jumps = clean::suspect_jumps(&frame, &wrapped);
    let median = median_period(&frame.t_s);
    if median <= 0.0 {
        return Err(Error::InvalidInput(format!(
            "{label}: fewer than two distinct time stamps"
        )));
    }
    let steps: Vec<f64> = frame
        .t_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d <= map.clean.max_gap_periods * median)
        .collect();
    let period_jitter_s = (steps.iter().map(|d| (d - median).powi(2)).sum::<f64>()
        / steps.len().max(1) as f64)
        .sqrt();
    let split = clean::split_gaps(frame, &map.clean, &label, &row_name)?;
    if split.pieces.is_empty() {
        return Err(Error::InvalidInput(format!(
            "{label}: every gap-free piece has fewer than {} samples ({} gaps)",
            map.clean.min_piece_samples, split.gaps
        )));
    }
    let mut pieces = split.pieces;
    let (mut regularized_pieces, mut regularized_max_dev_s) = (0, 0.0_f64);
    if map.clean.regularize_jitter {
        for p in &mut pieces {
            if let Some(dev) = clean::regularize(p, map.clean.max_jitter_periods) {
                regularized_pieces += 1;
                regularized_max_dev_s = regularized_max_dev_s.max(dev);
            }
        }
    }
    let mut decimation = 1;
    for p in &mut pieces {
        decimation = clean::decimate(p, map.clean.working_rate_hz);
    }
    let working_rate_hz = 1.0 / median_period(&pieces[0].t_s);
    // The lag, estimated on the longest piece.
    let (mut lag, mut lag_note) = (None, None);
    if !matches!(opts.lag, LagOption::Fixed(_)) {
        let longest = pieces.iter().max_by_key(|p| p.len()).unwrap_or(&pieces[0]);
        let max_lag = map
            .clean
            .max_lag_s
            .min(0.25 * longest.t_s.last().unwrap_or(&0.0));
        match lag::estimate_lag(
            &longest.t_s,
            &longest.q_rad,
            longest.dq_rad_s.as_deref(),
            &longest.power_w,
            max_lag,
        ) {
            Ok(l) => lag = Some(l),
            Err(e) => lag_note = Some(e.to_string()),
        }
    }
    let lag_applied_s = match opts.lag {
        LagOption::Report => 0.0,
        LagOption::Fixed(v) => v,
        LagOption::Auto => lag.map(|l| l.lag_s).ok_or_else(|| {
            Error::InvalidInput(format!(
                "{label}: --power-lag auto: {}",
                lag_note.clone().unwrap_or_default()
            ))
        })?,
    };
    let mut lag_trimmed = 0;
    if lag_applied_s != 0.0 {
        for p in &mut pieces {
            let others = p.motor_power_w.clone().unwrap_or_default();
            let (range, power, motors) = lag::shift(&p.t_s, &p.power_w, &others, lag_applied_s);
            lag_trimmed += p.len() - range.len();
            let mut s = p.slice(range);
            s.power_w = power;
            if s.motor_power_w.is_some() {
                s.motor_power_w = Some(motors);
            }
            *p = s;
        }
        pieces.retain(|p| p.len() >= 2);
        if pieces.is_empty() {
            return Err(Error::InvalidInput(format!(
                "{label}: a power lag of {lag_applied_s} s leaves no two samples whose shifted time lies inside the log"
            )));
        }
    }
    let split_source = pieces.len() > 1;
    let logs: Vec<Log> = pieces
        .into_iter()
        .map(|p| {
            let source = if split_source {
                format!("{label} [{:.3}-{:.3} s]", p.t_s[0], p.t_s[p.len() - 1])
            } else {
                label.clone()
            };
            Log {
                source,
                robot: None,
                t_s: p.t_s,
                q_rad: p.q_rad,
                dq_rad_s: p.dq_rad_s,
                power_w: p.power_w,
                signal: kind.signal(),
                motor_power_w: p.motor_power_w,
                power_averaged: false,
                payloads: Vec::new(),
            }
        })
        .collect();
    let (mut long_rests, mut long_rest_total_s) = (0, 0.0);
    for l in &logs {
        l.validate()?;
        for r in segments::rests(l, map.clean.rest_speed_rad_s, map.clean.long_rest_s) {
            long_rests += 1;
            long_rest_total_s += l.t_s[r.end - 1] - l.t_s[r.start];
        }
    }
    let report = ReadReport {
        source: label,
        rows,
        t0_s: t0,
        median_period_s: median,
        period_jitter_s,
        missing_rows_dropped,
        duplicates_merged,
        unwrapped_jumps,
        suspect_jumps,
        gaps: split.gaps,
        short_piece_samples_dropped: split.dropped_samples,
        decimation,
        regularized_pieces,
        regularized_max_dev_s,
        working_rate_hz,
        long_rests,
        long_rest_total_s,
        lag,
        lag_note,
        lag_applied_s,
        lag_trimmed,
        pieces: logs
            .iter()
            .map(|l| (l.t_s[0], l.t_s[l.len() - 1], l.len()))
            .collect(),
    };
    Ok((logs, report))
}
