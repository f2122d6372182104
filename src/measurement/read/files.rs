//! Opening a log file (CSV or Parquet) and reading the wanted columns as numbers.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use arrow_array::cast::AsArray;
use arrow_array::types::{
    Float32Type, Float64Type, Int8Type, Int16Type, Int32Type, Int64Type, TimestampMicrosecondType,
    TimestampMillisecondType, TimestampNanosecondType, TimestampSecondType, UInt8Type, UInt16Type,
    UInt32Type, UInt64Type,
};
use arrow_array::{Array, ArrayRef};
use arrow_schema::DataType;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use crate::error::{Error, Result, catch_decoder_panic};
use crate::measurement::columns::TimeUnit;

/// A log file opened for reading: its format and column names.
pub(super) struct LogFile<'a> {
    path: &'a Path,
    /// The file's name in messages.
    label: &'a str,
    /// Parquet (else CSV).
    pub(super) parquet: bool,
    /// CSV delimiter (unused for Parquet).
    delim: u8,
    /// Column names of the file.
    pub(super) header: Vec<String>,
}

impl<'a> LogFile<'a> {
    /// Detect the format, the delimiter (`delimiter`: the column map's, else sniffed) and read
    /// the header.
    pub(super) fn open(path: &'a Path, label: &'a str, delimiter: Option<char>) -> Result<Self> {
        let parquet = is_parquet(path)?;
        let delim = sniff_delimiter(path, delimiter)?;
        let header = headers(path, label, parquet, delim)?;
        Ok(LogFile {
            path,
            label,
            parquet,
            delim,
            header,
        })
    }

    /// The columns `wanted` (by name; the first is the time, in `unit`) as numbers, one
    /// vector per column; missing cells are NaN.
    pub(super) fn read(&self, wanted: &[String], unit: TimeUnit) -> Result<Vec<Vec<f64>>> {
        let (path, label) = (self.path, self.label);
        if self.parquet {
            guarded(label, || read_parquet(path, label, wanted, 0, unit))
        } else {
            read_csv(path, label, self.delim, wanted, 0, unit)
        }
    }

    /// How a file row (0-based data row) is named in messages: as a spreadsheet shows it
    /// for CSV (the header is row 1), `data row N` (1-based) for Parquet.
    pub(super) fn row_name(&self, k: usize) -> String {
        if self.parquet {
            format!("data row {}", k + 1)
        } else {
            format!("row {}", k + 2)
        }
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
fn sniff_delimiter(path: &Path, given: Option<char>) -> Result<u8> {
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
