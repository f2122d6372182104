//! CSV tables of joint-space samples.
//!
//! Column names carry their units: `q1_rad`, `dq1_rad_s`, `ddq1_rad_s2`, `tau1_Nm`, `t_s`.
//! On input the bare names of the paper (`q1`, `dq1`, `ddq1`, `t`) are accepted as well;
//! other columns are ignored. Rows are numbered 1-based with the header as row 1, as a
//! spreadsheet shows them.

use std::fmt::Write as _;
use std::io::{Read, Write};
use std::path::Path;

use crate::error::{Error, Result};

/// A numeric CSV table held column-wise.
#[derive(Debug, Clone)]
pub struct Table {
    label: String,
    headers: Vec<String>,
    columns: Vec<Vec<f64>>,
}

impl Table {
    /// Parse CSV text; `label` names the source in errors. Every cell must be a finite number.
    pub fn parse(text: &str, label: &str) -> Result<Table> {
        Table::from_reader(text.as_bytes(), label)
    }

    /// Parse CSV from a reader (streamed, record by record); see [`Table::parse`].
    fn from_reader(input: impl Read, label: &str) -> Result<Table> {
        let err = |row: usize, message: String| Error::Table {
            file: label.to_string(),
            row,
            message,
        };
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(input);
        let headers: Vec<String> = reader
            .headers()
            .map_err(|e| err(1, e.to_string()))?
            .iter()
            .map(str::to_string)
            .collect();
        if headers.is_empty() || headers.iter().all(String::is_empty) {
            return Err(err(1, "no header row".into()));
        }
        let mut columns = vec![Vec::new(); headers.len()];
        for (k, record) in reader.records().enumerate() {
            let row = k + 2;
            let record = record.map_err(|e| err(row, e.to_string()))?;
            if record.len() != headers.len() {
                return Err(err(
                    row,
                    format!("{} fields, the header has {}", record.len(), headers.len()),
                ));
            }
            for (c, cell) in record.iter().enumerate() {
                let v: f64 = cell.parse().map_err(|_| {
                    err(
                        row,
                        format!("column '{}': '{cell}' is not a number", headers[c]),
                    )
                })?;
                if !v.is_finite() {
                    return Err(err(
                        row,
                        format!("column '{}' is {v} (must be finite)", headers[c]),
                    ));
                }
                columns[c].push(v);
            }
        }
        Ok(Table {
            label: label.to_string(),
            headers,
            columns,
        })
    }

    /// Read and parse a CSV file (streamed: memory holds the columns, not the text).
    pub fn read(path: &Path) -> Result<Table> {
        let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        Table::from_reader(file, &path.display().to_string())
    }

    /// The label naming the source in errors (usually the file path).
    pub fn label(&self) -> &str {
        &self.label
    }

    /// Number of data rows.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }

    /// Column names, in file order.
    pub fn headers(&self) -> &[String] {
        &self.headers
    }

    /// The columns, in the order of [`Table::headers`].
    pub fn into_columns(self) -> Vec<Vec<f64>> {
        self.columns
    }

    /// The column with one of the given names (first match), or an error naming them.
    pub fn column(&self, names: &[&str]) -> Result<&[f64]> {
        names
            .iter()
            .find_map(|n| self.headers.iter().position(|h| h == n))
            .map(|c| self.columns[c].as_slice())
            .ok_or_else(|| Error::Table {
                file: self.label.clone(),
                row: 1,
                message: format!("missing column '{}'", names.join("' or '")),
            })
    }

    /// Columns `{prefix}1..{prefix}n`, each also accepted with `_{unit}` appended.
    pub fn joint_columns(&self, prefix: &str, unit: &str, n: usize) -> Result<Vec<&[f64]>> {
        (1..=n)
            .map(|i| {
                let bare = format!("{prefix}{i}");
                let with_unit = format!("{prefix}{i}_{unit}");
                self.column(&[&with_unit, &bare])
            })
            .collect()
    }
}

/// Render columns as CSV text with the given headers (see [`write_csv`]).
pub fn to_csv(headers: &[String], columns: &[Vec<f64>]) -> String {
    let columns: Vec<&[f64]> = columns.iter().map(Vec::as_slice).collect();
    let mut out = Vec::new();
    write_csv(&mut out, headers, &columns).expect("writing to memory cannot fail");
    String::from_utf8(out).expect("the headers are UTF-8 and the numbers ASCII")
}

/// Write columns of equal length as CSV (`csv::Writer`: a header row, then one record per
/// row; a header with a comma or quote is quoted) with the given headers, each value in
/// Rust's shortest representation that parses back to the same `f64` (`{}`). `out` should be
/// buffered.
///
/// # Panics
/// If a column is shorter than the first one.
pub fn write_csv(
    out: &mut impl Write,
    headers: &[String],
    columns: &[&[f64]],
) -> std::io::Result<()> {
    let mut w = csv::WriterBuilder::new().from_writer(out);
    w.write_record(headers)?;
    let rows = columns.first().map_or(0, |c| c.len());
    let mut cell = String::with_capacity(32);
    for r in 0..rows {
        for column in columns {
            cell.clear();
            write!(cell, "{}", column[r]).expect("writing to a String cannot fail");
            w.write_field(&cell)?;
        }
        w.write_record(None::<&[u8]>)?;
    }
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_cells_name_the_row() {
        let e = Table::parse("q1,q2\n1,2\n3,x\n", "t.csv").unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.csv: row 3: column 'q2': 'x' is not a number"
        );
        let e = Table::parse("q1,q2\n1,NaN\n", "t.csv").unwrap_err();
        assert!(e.to_string().contains("row 2"), "{e}");
        let e = Table::parse("q1,q2\n1\n", "t.csv").unwrap_err();
        assert!(e.to_string().contains("row 2"), "{e}");
    }

    #[test]
    fn unit_suffixed_and_bare_names_are_accepted() {
        let t = Table::parse("q1_rad,q2,other\n1,2,3\n", "t").unwrap();
        let cols = t.joint_columns("q", "rad", 2).unwrap();
        assert_eq!(cols[0], &[1.0]);
        assert_eq!(cols[1], &[2.0]);
        let e = t.joint_columns("dq", "rad_s", 2).unwrap_err();
        assert!(
            e.to_string()
                .contains("missing column 'dq1_rad_s' or 'dq1'"),
            "{e}"
        );
    }

    #[test]
    fn csv_round_trip_is_exact() {
        let cols = vec![vec![0.1, 1.0 / 3.0], vec![-2.5e-17, 7.0]];
        let text = to_csv(&["a".into(), "b".into()], &cols);
        let t = Table::parse(&text, "x").unwrap();
        assert_eq!(t.column(&["a"]).unwrap(), cols[0].as_slice());
        assert_eq!(t.column(&["b"]).unwrap(), cols[1].as_slice());
    }
}
