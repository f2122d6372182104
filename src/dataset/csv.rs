//! CSV tables: a header row of column names, then one line per row, every value in Rust's
//! shortest round-trip representation (reading gives back the same bits).

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use crate::dataset::columns;
use crate::error::{Error, Result};
use crate::io::table::{Table, write_csv};

/// Write a table (all columns the same length, values finite) to `path` and sync it.
pub(crate) fn write(path: &Path, names: &[String], cols: &[&[f64]]) -> Result<()> {
    let io = |e| Error::io(path, e);
    let file = File::create(path).map_err(io)?;
    let mut out = BufWriter::with_capacity(1 << 20, file);
    write_csv(&mut out, names, cols).map_err(io)?;
    let file = out.into_inner().map_err(|e| io(e.into_error()))?;
    file.sync_all().map_err(io)
}

/// Read the `expected` columns, in that order. Errors name the file and the missing,
/// unexpected or repeated columns ([`Error::Dataset`]), or the row and column of a cell that
/// is not a finite number ([`Error::Table`], header = row 1).
pub(crate) fn read(path: &Path, expected: &[String]) -> Result<Vec<Vec<f64>>> {
    let table = Table::read(path)?;
    let index = columns::locate(path, table.headers(), expected)?;
    let mut cols: Vec<Option<Vec<f64>>> = table.into_columns().into_iter().map(Some).collect();
    Ok(index
        .iter()
        .map(|&i| cols[i].take().unwrap_or_default())
        .collect())
}
