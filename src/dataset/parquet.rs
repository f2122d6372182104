//! Parquet tables: one required `DOUBLE` (Arrow `Float64`) column per series, row groups of
//! [`ROW_GROUP_ROWS`] rows, `BYTE_STREAM_SPLIT` encoding with Snappy compression and no
//! dictionary. Simulated signals have full-precision mantissas that rarely repeat: on such
//! data a dictionary only costs time (it doubles the write time before falling back to plain
//! encoding), and splitting the bytes of each double into streams lets Snappy shrink the
//! files by about a fifth (signs, exponents and leading mantissa bytes repeat) where it
//! gains nothing on plain doubles. Constant columns compress to almost nothing.
//!
//! Output is deterministic: the footer's `created_by` is fixed to [`CREATED_BY`], no
//! key-value metadata is written (the Arrow schema is not embedded: plain `DOUBLE` columns
//! read back as `Float64` without it), and nothing else in the format depends on time.

use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use arrow_array::{Array, ArrayRef, Float64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::arrow_writer::ArrowWriterOptions;
use parquet::basic::{Compression, Encoding};
use parquet::file::properties::WriterProperties;

use crate::dataset::columns;
use crate::error::{Error, Result, catch_decoder_panic};

/// Rows per Arrow batch when writing and reading (bounds the per-batch copy).
const BATCH_ROWS: usize = 65_536;
/// Rows per Parquet row group (bounds the writer's buffered, encoded data).
const ROW_GROUP_ROWS: usize = 8 * BATCH_ROWS;
/// The `created_by` field of every file powertwin writes.
const CREATED_BY: &str = concat!("powertwin version ", env!("CARGO_PKG_VERSION"));

/// Write a table (all columns the same length) to `path` and sync it.
pub(crate) fn write(path: &Path, names: &[String], cols: &[&[f64]]) -> Result<()> {
    let err = |e: &dyn std::fmt::Display| Error::Dataset {
        path: path.to_path_buf(),
        message: format!("Parquet writer: {e}"),
    };
    let fields: Vec<Field> = names
        .iter()
        .map(|n| Field::new(n, DataType::Float64, false))
        .collect();
    let schema = Arc::new(Schema::new(fields));
    let props = WriterProperties::builder()
        .set_created_by(CREATED_BY.to_string())
        .set_compression(Compression::SNAPPY)
        .set_dictionary_enabled(false)
        .set_encoding(Encoding::BYTE_STREAM_SPLIT)
        .set_max_row_group_row_count(Some(ROW_GROUP_ROWS))
        .build();
    let options = ArrowWriterOptions::new()
        .with_properties(props)
        .with_skip_arrow_metadata(true);
    let file = File::create(path).map_err(|e| Error::io(path, e))?;
    let mut writer =
        ArrowWriter::try_new_with_options(file, schema.clone(), options).map_err(|e| err(&e))?;
    let rows = cols.first().map_or(0, |c| c.len());
    for start in (0..rows).step_by(BATCH_ROWS) {
        let end = (start + BATCH_ROWS).min(rows);
        let arrays: Vec<ArrayRef> = cols
            .iter()
            .map(|c| Arc::new(Float64Array::from(c[start..end].to_vec())) as ArrayRef)
            .collect();
        let batch = RecordBatch::try_new(schema.clone(), arrays).map_err(|e| err(&e))?;
        writer.write(&batch).map_err(|e| err(&e))?;
    }
    let file = writer.into_inner().map_err(|e| err(&e))?;
    file.sync_all().map_err(|e| Error::io(path, e))
}

/// Read the `expected` columns, in that order. Errors ([`Error::Dataset`]) name the file and
/// say what is wrong: not Parquet or truncated, missing/unexpected/repeated columns, a column
/// that is not `Float64`, or a null or non-finite cell (with column and 1-based data row).
///
/// The Parquet decoder can panic on some corrupted files (found by tests/fuzz.rs: 9 of
/// 30,000 mutated `measured.parquet` files); such a panic is caught and reported as an
/// [`Error::Dataset`] like any other unreadable file.
pub(crate) fn read(path: &Path, expected: &[String]) -> Result<Vec<Vec<f64>>> {
    catch_decoder_panic(|| read_unchecked(path, expected)).unwrap_or_else(|why| {
        Err(Error::Dataset {
            path: path.to_path_buf(),
            message: format!("corrupt Parquet file: the decoder failed ({why})"),
        })
    })
}

/// [`read`] without the guard against decoder panics.
fn read_unchecked(path: &Path, expected: &[String]) -> Result<Vec<Vec<f64>>> {
    let bad = |message: String| Error::Dataset {
        path: path.to_path_buf(),
        message,
    };
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file)
        .map_err(|e| bad(format!("not a readable Parquet file (truncated?): {e}")))?;
    let schema = builder.schema().clone();
    let found: Vec<String> = schema.fields().iter().map(|f| f.name().clone()).collect();
    let index = columns::locate(path, &found, expected)?;
    for (name, &i) in expected.iter().zip(&index) {
        let data_type = schema.field(i).data_type();
        if *data_type != DataType::Float64 {
            return Err(bad(format!(
                "column '{name}' has type {data_type}, expected Float64 (Parquet DOUBLE)"
            )));
        }
    }
    let reader = builder
        .with_batch_size(BATCH_ROWS)
        .build()
        .map_err(|e| bad(format!("cannot read: {e}")))?;
    let mut out = vec![Vec::new(); expected.len()];
    let mut row0 = 0;
    for batch in reader {
        let batch = batch.map_err(|e| {
            bad(format!(
                "cannot decode the rows after data row {row0} (corrupt or truncated?): {e}"
            ))
        })?;
        for ((name, &i), col) in expected.iter().zip(&index).zip(&mut out) {
            let array = batch
                .column(i)
                .as_any()
                .downcast_ref::<Float64Array>()
                .ok_or_else(|| bad(format!("column '{name}' is not Float64")))?;
            if array.null_count() > 0 {
                let k = (0..array.len()).find(|&k| array.is_null(k)).unwrap_or(0);
                return Err(bad(format!(
                    "column '{name}' is null at data row {}",
                    row0 + k + 1
                )));
            }
            let values = array.values();
            if let Some(message) = columns::non_finite(name, values, row0) {
                return Err(bad(message));
            }
            col.extend_from_slice(values);
        }
        row0 += batch.num_rows();
    }
    Ok(out)
}
