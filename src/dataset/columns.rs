//! Column names of the two tables, and the mapping between columns and records.
//!
//! This is the only place that knows how a [`Recording`] or a [`Measured`] becomes a list of
//! named `f64` columns and back: writing takes the columns in [`TRUTH`] / [`MEASURED`] order,
//! reading looks the same generated names up in the file header. A name is
//! `{stem}_{unit}` for a scalar series (`t_s`, `p_total_W`) and `{stem}{i}_{unit}` for joint
//! `i = 1..n` of a per-joint series (`q1_rad`, `ddq_ref6_rad_s2`).

use std::collections::{HashMap, HashSet};
use std::path::Path;

use crate::error::{Error, Result};
use crate::twin::record::{Measured, Recording};

/// Where a series lives in its record.
enum Field<R> {
    /// One column.
    Scalar(fn(&R) -> &Vec<f64>, fn(&mut R) -> &mut Vec<f64>),
    /// One column per joint (joint-major vectors).
    Joint(fn(&R) -> &Vec<Vec<f64>>, fn(&mut R) -> &mut Vec<Vec<f64>>),
}

/// One named quantity of a record: its name stem, its unit suffix and where it is stored.
pub(crate) struct Series<R: 'static> {
    stem: &'static str,
    unit: &'static str,
    field: Field<R>,
}

/// The columns of `truth.*`, in file order.
pub(crate) const TRUTH: &[Series<Recording>] = &[
    scalar("t", "s", |r| &r.t, |r| &mut r.t),
    joint("q", "rad", |r| &r.q, |r| &mut r.q),
    joint("dq", "rad_s", |r| &r.dq, |r| &mut r.dq),
    joint("q_ref", "rad", |r| &r.q_ref, |r| &mut r.q_ref),
    joint("dq_ref", "rad_s", |r| &r.dq_ref, |r| &mut r.dq_ref),
    joint("ddq_ref", "rad_s2", |r| &r.ddq_ref, |r| &mut r.ddq_ref),
    joint("tau", "Nm", |r| &r.tau, |r| &mut r.tau),
    joint("p_mech", "W", |r| &r.p_mech, |r| &mut r.p_mech),
    joint("p_elec", "W", |r| &r.p_elec, |r| &mut r.p_elec),
    scalar("p_total", "W", |r| &r.p_total, |r| &mut r.p_total),
    scalar("p_grid", "W", |r| &r.p_grid, |r| &mut r.p_grid),
    scalar(
        "payload",
        "kg",
        |r| &r.payload_mass,
        |r| &mut r.payload_mass,
    ),
];

/// The columns of `measured.*`, in file order.
pub(crate) const MEASURED: &[Series<Measured>] = &[
    scalar("t", "s", |m| &m.t, |m| &mut m.t),
    joint("q", "rad", |m| &m.q, |m| &mut m.q),
    joint("p_elec", "W", |m| &m.p_joint, |m| &mut m.p_joint),
    scalar("p_total", "W", |m| &m.p_total, |m| &mut m.p_total),
];

const fn scalar<R>(
    stem: &'static str,
    unit: &'static str,
    get: fn(&R) -> &Vec<f64>,
    get_mut: fn(&mut R) -> &mut Vec<f64>,
) -> Series<R> {
    Series {
        stem,
        unit,
        field: Field::Scalar(get, get_mut),
    }
}

const fn joint<R>(
    stem: &'static str,
    unit: &'static str,
    get: fn(&R) -> &Vec<Vec<f64>>,
    get_mut: fn(&mut R) -> &mut Vec<Vec<f64>>,
) -> Series<R> {
    Series {
        stem,
        unit,
        field: Field::Joint(get, get_mut),
    }
}

/// Column names of a table with the given series for an `dof`-joint robot, in file order.
pub(crate) fn names<R>(series: &[Series<R>], dof: usize) -> Vec<String> {
    let mut names = Vec::new();
    for s in series {
        match s.field {
            Field::Scalar(..) => names.push(format!("{}_{}", s.stem, s.unit)),
            Field::Joint(..) => {
                names.extend((1..=dof).map(|i| format!("{}{i}_{}", s.stem, s.unit)));
            }
        }
    }
    names
}

/// Column names of `truth.parquet` / `truth.csv` for an `dof`-joint robot, in file order:
/// `t_s`, `q{i}_rad`, `dq{i}_rad_s`, `q_ref{i}_rad`, `dq_ref{i}_rad_s`, `ddq_ref{i}_rad_s2`,
/// `tau{i}_Nm`, `p_mech{i}_W`, `p_elec{i}_W`, `p_total_W`, `p_grid_W`, `payload_kg`
/// (`i = 1..dof`).
pub fn truth_columns(dof: usize) -> Vec<String> {
    names(TRUTH, dof)
}

/// Column names of `measured.parquet` / `measured.csv` for an `dof`-joint robot, in file
/// order: `t_s`, `q{i}_rad`, `p_elec{i}_W`, `p_total_W` (`i = 1..dof`).
pub fn measured_columns(dof: usize) -> Vec<String> {
    names(MEASURED, dof)
}

/// The columns of `record` in [`names`] order. Errors ([`Error::InvalidInput`], naming
/// `table` and the column) when a per-joint series does not have `dof` joints or a column's
/// length differs from the first column's.
pub(crate) fn columns<'a, R>(
    series: &[Series<R>],
    record: &'a R,
    dof: usize,
    table: &str,
) -> Result<Vec<&'a [f64]>> {
    let mut cols: Vec<&'a [f64]> = Vec::new();
    for s in series {
        match s.field {
            Field::Scalar(get, _) => cols.push(get(record)),
            Field::Joint(get, _) => {
                let joints = get(record);
                if joints.len() != dof {
                    return Err(Error::InvalidInput(format!(
                        "{table}: series '{}' has {} joints, the robot has {dof}",
                        s.stem,
                        joints.len()
                    )));
                }
                cols.extend(joints.iter().map(Vec::as_slice));
            }
        }
    }
    let rows = cols.first().map_or(0, |c| c.len());
    if let Some(k) = cols.iter().position(|c| c.len() != rows) {
        let names = names(series, dof);
        return Err(Error::InvalidInput(format!(
            "{table}: column '{}' has {} values, '{}' has {rows}",
            names[k],
            cols[k].len(),
            names[0]
        )));
    }
    Ok(cols)
}

/// Rebuild a record from columns in [`names`] order (the inverse of [`columns`]); fields
/// that are not columns keep their `Default` value.
pub(crate) fn record<R: Default>(series: &[Series<R>], dof: usize, cols: Vec<Vec<f64>>) -> R {
    let mut record = R::default();
    let mut cols = cols.into_iter();
    for s in series {
        match s.field {
            Field::Scalar(_, get_mut) => *get_mut(&mut record) = cols.next().unwrap_or_default(),
            Field::Joint(_, get_mut) => {
                *get_mut(&mut record) = cols.by_ref().take(dof).collect();
            }
        }
    }
    record
}

/// For each expected column name, its position among the file's `found` names. Errors name
/// the file and list every missing, unexpected or repeated column.
pub(crate) fn locate(path: &Path, found: &[String], expected: &[String]) -> Result<Vec<usize>> {
    let mut index: HashMap<&str, usize> = HashMap::with_capacity(found.len());
    let mut repeated = Vec::new();
    for (i, name) in found.iter().enumerate() {
        if index.insert(name, i).is_some() {
            repeated.push(name);
        }
    }
    let expected_set: HashSet<&str> = expected.iter().map(String::as_str).collect();
    let missing: Vec<&String> = expected
        .iter()
        .filter(|n| !index.contains_key(n.as_str()))
        .collect();
    let unexpected: Vec<&String> = found
        .iter()
        .filter(|n| !expected_set.contains(n.as_str()))
        .collect();
    let problems: Vec<String> = [
        ("missing", missing),
        ("unexpected", unexpected),
        ("repeated", repeated),
    ]
    .into_iter()
    .filter(|(_, names)| !names.is_empty())
    .map(|(what, names)| format!("{what} column(s) {}", quoted_list(&names)))
    .collect();
    if !problems.is_empty() {
        return Err(Error::Dataset {
            path: path.to_path_buf(),
            message: problems.join("; "),
        });
    }
    Ok(expected.iter().map(|n| index[n.as_str()]).collect())
}

/// `'a', 'b', 'c'`, cut after [`LISTED`] names with a count of the rest.
fn quoted_list(names: &[&String]) -> String {
    let mut list: Vec<String> = names
        .iter()
        .take(LISTED)
        .map(|n| format!("'{n}'"))
        .collect();
    if names.len() > LISTED {
        list.push(format!("and {} more", names.len() - LISTED));
    }
    list.join(", ")
}

/// Column names listed in one error message at most.
const LISTED: usize = 8;

/// Check that every value is finite; the error ([`Error::InvalidInput`]) names the table,
/// the column and the 1-based data row.
pub(crate) fn ensure_finite(table: &str, names: &[String], cols: &[&[f64]]) -> Result<()> {
    match names
        .iter()
        .zip(cols)
        .find_map(|(n, c)| non_finite(n, c, 0))
    {
        Some(message) => Err(Error::InvalidInput(format!("{table}: {message}"))),
        None => Ok(()),
    }
}

/// The first value of `col` that is not finite, as a message naming the column and the
/// 1-based data row (`row0` rows of the table precede `col`).
pub(crate) fn non_finite(name: &str, col: &[f64], row0: usize) -> Option<String> {
    col.iter().position(|v| !v.is_finite()).map(|k| {
        format!(
            "column '{name}' is {} at data row {} (datasets hold finite values only)",
            col[k],
            row0 + k + 1
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_the_documented_order() {
        assert_eq!(
            measured_columns(2),
            [
                "t_s",
                "q1_rad",
                "q2_rad",
                "p_elec1_W",
                "p_elec2_W",
                "p_total_W"
            ]
        );
        let t = truth_columns(6);
        assert_eq!(t.len(), 1 + 8 * 6 + 3);
        assert_eq!(t[1], "q1_rad");
        assert_eq!(t[6 * 4 + 1], "ddq_ref1_rad_s2");
        assert_eq!(t[6 * 5 + 6], "tau6_Nm");
        assert_eq!(t[t.len() - 1], "payload_kg");
    }

    #[test]
    fn columns_and_record_are_inverse() {
        let m = Measured {
            rate_hz: 0.0,
            t: vec![0.0, 1.0],
            q: vec![vec![1.0, 2.0], vec![3.0, 4.0]],
            p_joint: vec![vec![5.0, 6.0], vec![7.0, 8.0]],
            p_total: vec![9.0, 10.0],
        };
        let cols = columns(MEASURED, &m, 2, "m").unwrap();
        assert_eq!(cols[2], &[3.0, 4.0]);
        let owned = cols.iter().map(|c| c.to_vec()).collect();
        assert_eq!(record::<Measured>(MEASURED, 2, owned), m);
        let e = columns(MEASURED, &m, 3, "m").unwrap_err();
        assert!(e.to_string().contains("'q' has 2 joints"), "{e}");
    }

    #[test]
    fn locate_lists_every_problem() {
        let found: Vec<String> = ["b", "x", "b"].map(String::from).to_vec();
        let expected: Vec<String> = ["a", "b"].map(String::from).to_vec();
        let e = locate(Path::new("f"), &found, &expected)
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing column(s) 'a'"), "{e}");
        assert!(e.contains("unexpected column(s) 'x'"), "{e}");
        assert!(e.contains("repeated column(s) 'b'"), "{e}");
    }
}
