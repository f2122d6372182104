//! Ordinary least squares with the statistics identification reports.
//!
//! Columns are scaled to unit norm before solving, so the condition number and the rank
//! decision do not depend on parameter units. A regressor whose scaled condition number
//! exceeds [`MAX_COND`] is rank deficient: the error names the parameters involved (the
//! columns that pivoted QR leaves without a significant pivot).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::identification::fit::Param;

/// Largest accepted condition number of the column-scaled regressor.
pub const MAX_COND: f64 = 1e10;

/// A least-squares estimate.
#[derive(Debug, Clone, Serialize)]
pub struct Estimate {
    /// Parameter names, in column order.
    pub names: Vec<String>,
    /// Estimated values.
    pub values: Vec<f64>,
    /// Standard deviations `sigma_k = sqrt(s^2 (A^T A)^-1_kk)` with `s^2 = |r|^2 / (m - p)`.
    pub std: Vec<f64>,
    /// Relative standard deviations `sigma_k / |value_k|` (infinite for a zero value).
    pub rel_std: Vec<f64>,
    /// Condition number of the regressor (columns scaled to unit norm).
    pub cond: f64,
    /// RMS of the residual, in the units of the observations (W for power, J for energy).
    pub residual_rms: f64,
    /// Number of observations.
    pub rows: usize,
    /// Covariance `s^2 (A^T A)^-1` of the values, in their units squared (not serialised).
    #[serde(skip)]
    pub covariance: DMatrix<f64>,
    /// What each value is in the power model's parameter vector, in column order, when the
    /// estimate comes from [`crate::identification::fit`] (empty otherwise; not serialised).
    #[serde(skip)]
    pub params: Vec<Param>,
}

/// Solve `a x = y` in the least-squares sense. `names` label the columns.
pub fn solve(a: &DMatrix<f64>, y: &DVector<f64>, names: &[String]) -> Result<Estimate> {
    let norms = checked_norms(a, y, names)?;
    let (r, qty) = reduce_system(a, y);
    reduced_solution(a, y, names, &norms, (&r, &qty))
}

/// [`solve`] from `A`'s reduction `(R, Q^T y)` by [`reduce_system`], computed once where the
/// covariance needs `R` too.
pub(crate) fn solve_reduced(
    a: &DMatrix<f64>,
    y: &DVector<f64>,
    names: &[String],
    reduced: (&DMatrix<f64>, &DVector<f64>),
) -> Result<Estimate> {
    let norms = checked_norms(a, y, names)?;
    reduced_solution(a, y, names, &norms, reduced)
}

/// The column norms of `a` after checking the problem: shapes, more rows than columns,
/// finite values, no zero column (named).
fn checked_norms(a: &DMatrix<f64>, y: &DVector<f64>, names: &[String]) -> Result<Vec<f64>> {
    let (m, p) = a.shape();
    if names.len() != p || y.len() != m {
        return Err(Error::InvalidInput(format!(
            "regressor {m}x{p}, {} observations, {} names",
            y.len(),
            names.len()
        )));
    }
    if m <= p {
        return Err(Error::InvalidInput(format!(
            "{m} observations for {p} parameters: need more data"
        )));
    }
    if a.iter().chain(y.iter()).any(|v| !v.is_finite()) {
        return Err(Error::InvalidInput(
            "regressor or observations contain NaN or infinite values".into(),
        ));
    }
    let norms: Vec<f64> = a.column_iter().map(|c| c.norm()).collect();
    let zero: Vec<&str> = names
        .iter()
        .zip(&norms)
        .filter(|(_, n)| **n == 0.0)
        .map(|(s, _)| s.as_str())
        .collect();
    if !zero.is_empty() {
        return Err(Error::RankDeficient {
            rank: p - zero.len(),
            cols: p,
            unidentifiable: format!("{} (not excited at all)", zero.join(", ")),
        });
    }
    Ok(norms)
}

/// [`solve`] after its checks, from `A`'s reduction `(R, Q^T y)`: the p x p factor has A's
/// singular values and right singular vectors, and `(Q^T y)[..p]` the same least-squares
/// solution, at a fraction of an SVD of all rows.
fn reduced_solution(
    a: &DMatrix<f64>,
    y: &DVector<f64>,
    names: &[String],
    norms: &[f64],
    (r, qty): (&DMatrix<f64>, &DVector<f64>),
) -> Result<Estimate> {
    let (m, p) = a.shape();
    let scaled = DMatrix::from_fn(r.nrows(), p, |i, c| r[(i, c)] / norms[c]);
    let svd = scaled.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    let cond = smax / smin;
    if cond.is_nan() || cond > MAX_COND {
        let qr = scaled.clone().col_piv_qr();
        // Columns in pivot order: the permutation applied to the column indices.
        let mut idx = DMatrix::from_fn(1, p, |_, c| c as f64);
        qr.p().permute_columns(&mut idx);
        let diag = qr.unpack_r().diagonal();
        let order: Vec<usize> = idx.iter().map(|v| *v as usize).collect();
        let rank = diag.iter().filter(|d| d.abs() > smax / MAX_COND).count();
        let bad: Vec<&str> = order[rank..].iter().map(|&c| names[c].as_str()).collect();
        return Err(Error::RankDeficient {
            rank,
            cols: p,
            unidentifiable: format!("{} (condition number {cond:.3e})", bad.join(", ")),
        });
    }
    let x_scaled = svd
        .solve(
            &DMatrix::from_column_slice(qty.len(), 1, qty.as_slice()),
            0.0,
        )
        .map_err(|e| Error::Numerical(format!("least squares failed: {e}")))?;
    let values: Vec<f64> = (0..p).map(|c| x_scaled[(c, 0)] / norms[c]).collect();
    let resid = a * DVector::from_column_slice(&values) - y;
    let s2 = resid.norm_squared() / (m - p) as f64;
    // (A^T A)^-1 = S^-1 (As^T As)^-1 S^-1 with As = A S^-1; (As^T As)^-1 = V diag(1/s^2) V^T.
    let v_t = svd
        .v_t
        .as_ref()
        .ok_or_else(|| Error::Numerical("SVD without V".into()))?;
    let std: Vec<f64> = (0..p)
        .map(|c| {
            let var: f64 = (0..p)
                .map(|k| (v_t[(k, c)] / svd.singular_values[k]).powi(2))
                .sum();
            (s2 * var).sqrt() / norms[c]
        })
        .collect();
    let inv_s = DMatrix::from_fn(p, p, |k, c| v_t[(k, c)] / svd.singular_values[k]);
    let covariance = DMatrix::from_fn(p, p, |a, b| {
        s2 * inv_s.column(a).dot(&inv_s.column(b)) / (norms[a] * norms[b])
    });
    let rel_std = rel_std(&values, &std);
    Ok(Estimate {
        names: names.to_vec(),
        values,
        std,
        rel_std,
        cond,
        residual_rms: (resid.norm_squared() / m as f64).sqrt(),
        rows: m,
        covariance,
        params: Vec::new(),
    })
}

/// A Gaussian prior on the columns of a least-squares problem: `root (x - mean)` is
/// standard normal (`root^T root` the prior's precision, in the columns' units; zero columns
/// for values without a prior).
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnPrior {
    /// Root of the precision, `k x p`.
    pub root: DMatrix<f64>,
    /// Mean, `p` values (ignored where `root`'s column is zero).
    pub mean: DVector<f64>,
}

impl ColumnPrior {
    /// The prior of the columns `cols` only (others held at their values).
    pub fn columns(&self, cols: &[usize]) -> ColumnPrior {
        ColumnPrior {
            root: DMatrix::from_fn(self.root.nrows(), cols.len(), |r, c| {
                self.root[(r, cols[c])]
            }),
            mean: DVector::from_fn(cols.len(), |c, _| self.mean[cols[c]]),
        }
    }
}

/// The posterior of `a x = y` (rows with a common noise variance `s^2`) under the Gaussian
/// `prior`: the mean `(A^T A + s^2 P)^-1 (A^T y + s^2 P mean)` with `P = root^T root`, and
/// its covariance `s^2 (A^T A + s^2 P)^-1`. `s^2` is the residual variance of the data alone
/// (their least squares over the directions they determine, `|r|^2 / (m - rank)`), so the
/// prior weighs as much as it should against the data whatever the rows' units. Unlike
/// [`solve`], a rank-deficient `a` is no error where the prior covers the directions the
/// data miss: they come from the prior. `cond` is the data's condition number (infinite when
/// rank deficient). Returns the estimate and `s^2`.
pub fn solve_with_prior(
    a: &DMatrix<f64>,
    y: &DVector<f64>,
    names: &[String],
    prior: &ColumnPrior,
) -> Result<(Estimate, f64)> {
    check_with_prior(a, y, names, prior)?;
    let (r, qty) = reduce_system(a, y);
    reduced_posterior(a, y, names, prior, (&r, &qty))
}

/// [`solve_with_prior`] from `A`'s reduction `(R, Q^T y)` by [`reduce_system`], computed once where
/// the covariance needs `R` too.
pub(crate) fn solve_with_prior_reduced(
    a: &DMatrix<f64>,
    y: &DVector<f64>,
    names: &[String],
    prior: &ColumnPrior,
    reduced: (&DMatrix<f64>, &DVector<f64>),
) -> Result<(Estimate, f64)> {
    check_with_prior(a, y, names, prior)?;
    reduced_posterior(a, y, names, prior, reduced)
}

/// [`solve_with_prior`]'s checks: shapes and finite values.
fn check_with_prior(
    a: &DMatrix<f64>,
    y: &DVector<f64>,
    names: &[String],
    prior: &ColumnPrior,
) -> Result<()> {
    let (m, p) = a.shape();
    if names.len() != p || y.len() != m || prior.root.ncols() != p || prior.mean.len() != p {
        return Err(Error::InvalidInput(format!(
            "regressor {m}x{p}, {} observations, {} names, prior of {} columns",
            y.len(),
            names.len(),
            prior.root.ncols()
        )));
    }
    if a.iter().chain(y.iter()).any(|v| !v.is_finite()) {
        return Err(Error::InvalidInput(
            "regressor or observations contain NaN or infinite values".into(),
        ));
    }
    Ok(())
}

/// [`solve_with_prior`] after its checks, from `A`'s reduction `(R, Q^T y)`.
fn reduced_posterior(
    a: &DMatrix<f64>,
    y: &DVector<f64>,
    names: &[String],
    prior: &ColumnPrior,
    (r, qty): (&DMatrix<f64>, &DVector<f64>),
) -> Result<(Estimate, f64)> {
    let (m, p) = a.shape();
    let (cond, rank, s2) = data_noise(a, y, r, qty)?;
    // The stacked system [R; s root] x = [Q^T y; s root mean] has the posterior's normal
    // equations (|A x - y|^2 = |R x - Q^T y|^2 + const).
    let s = s2.sqrt();
    let k = prior.root.nrows();
    let stacked = DMatrix::from_fn(r.nrows() + k, p, |i, c| {
        if i < r.nrows() {
            r[(i, c)]
        } else {
            s * prior.root[(i - r.nrows(), c)]
        }
    });
    let prior_rhs = &prior.root * &prior.mean * s;
    let rhs = DVector::from_fn(r.nrows() + k, |i, _| {
        if i < r.nrows() {
            qty[i]
        } else {
            prior_rhs[i - r.nrows()]
        }
    });
    let (values, covariance) = stacked_solution(&stacked, &rhs, s2, names, rank)?;
    let std: Vec<f64> = (0..p).map(|c| covariance[(c, c)].max(0.0).sqrt()).collect();
    let resid = a * DVector::from_column_slice(&values) - y;
    let estimate = Estimate {
        names: names.to_vec(),
        rel_std: rel_std(&values, &std),
        values,
        std,
        cond,
        residual_rms: (resid.norm_squared() / m as f64).sqrt(),
        rows: m,
        covariance,
        params: Vec::new(),
    };
    Ok((estimate, s2))
}

/// The least-squares solution of the stacked data-and-prior system `stacked x = rhs` and
/// its covariance `s2 (stacked^T stacked)^-1`, columns scaled to unit norm. Errors: a column
/// neither excited nor with a prior, or directions neither determines (`rank`: the data's).
fn stacked_solution(
    stacked: &DMatrix<f64>,
    rhs: &DVector<f64>,
    s2: f64,
    names: &[String],
    rank: usize,
) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let p = stacked.ncols();
    let norms: Vec<f64> = stacked.column_iter().map(|c| c.norm()).collect();
    if let Some(c) = norms.iter().position(|n| *n == 0.0) {
        return Err(Error::RankDeficient {
            rank,
            cols: p,
            unidentifiable: format!("{} (not excited and without a prior)", names[c]),
        });
    }
    let scaled = DMatrix::from_fn(stacked.nrows(), p, |i, c| stacked[(i, c)] / norms[c]);
    let svd = scaled.svd(true, true);
    let cond = svd.singular_values.max() / svd.singular_values.min();
    if cond.is_nan() || cond > MAX_COND {
        return Err(Error::RankDeficient {
            rank,
            cols: p,
            unidentifiable: format!(
                "directions neither the data nor the prior determine (condition number {cond:.3e})"
            ),
        });
    }
    let x_scaled = svd
        .solve(
            &DMatrix::from_column_slice(rhs.len(), 1, rhs.as_slice()),
            0.0,
        )
        .map_err(|e| Error::Numerical(format!("least squares failed: {e}")))?;
    let values: Vec<f64> = (0..p).map(|c| x_scaled[(c, 0)] / norms[c]).collect();
    let v_t = svd
        .v_t
        .as_ref()
        .ok_or_else(|| Error::Numerical("SVD without V".into()))?;
    let inv_s = DMatrix::from_fn(p, p, |k, c| v_t[(k, c)] / svd.singular_values[k]);
    let covariance = DMatrix::from_fn(p, p, |i, j| {
        s2 * inv_s.column(i).dot(&inv_s.column(j)) / (norms[i] * norms[j])
    });
    Ok((values, covariance))
}

/// The data's own condition number, numerical rank and residual variance `s^2` (of their
/// least squares over the directions they determine, truncated at [`MAX_COND`]) from `A`'s
/// triangular factor `r` and `Q^T y`. Errors: no more observations than that rank.
fn data_noise(
    a: &DMatrix<f64>,
    y: &DVector<f64>,
    r: &DMatrix<f64>,
    qty: &DVector<f64>,
) -> Result<(f64, usize, f64)> {
    let (m, p) = a.shape();
    if m == 0 || r.nrows() == 0 {
        return Err(Error::InvalidInput(
            "no samples left to fit: a fit leaves out the samples at rest, and one of a DC-bus \
             or grid signal those within 2 W of the meter's floor (where the reading may be the \
             clip's); check the power's unit and signal (--power)"
                .into(),
        ));
    }
    let norms: Vec<f64> = a
        .column_iter()
        .map(|c| {
            let n = c.norm();
            if n > 0.0 { n } else { 1.0 }
        })
        .collect();
    let scaled = DMatrix::from_fn(r.nrows(), p, |i, c| r[(i, c)] / norms[c]);
    let svd = scaled.svd(true, true);
    let smax = svd.singular_values.max();
    let tol = smax / MAX_COND;
    let rank = svd.singular_values.iter().filter(|v| **v > tol).count();
    let cond = if rank < p {
        f64::INFINITY
    } else {
        smax / svd.singular_values.min()
    };
    if m <= rank {
        return Err(Error::InvalidInput(format!(
            "{m} observations for {rank} directions the data determine: need more data"
        )));
    }
    let x_scaled = svd
        .solve(
            &DMatrix::from_column_slice(qty.len(), 1, qty.as_slice()),
            tol,
        )
        .map_err(|e| Error::Numerical(format!("least squares failed: {e}")))?;
    let x = DVector::from_fn(p, |c, _| x_scaled[(c, 0)] / norms[c]);
    let rss = (a * x - y).norm_squared();
    // A floor for data the model fits exactly (synthetic tests): the prior then only fills
    // the directions the data miss.
    let floor = 1e-12 * y.norm_squared() / m as f64;
    Ok((
        cond,
        rank,
        (rss / (m - rank) as f64).max(floor).max(f64::MIN_POSITIVE),
    ))
}

/// Rows per block of the blocked QR decomposition in [`reduce`] (at least four times the
/// columns).
const QR_BLOCK_ROWS: usize = 1024;

/// The triangular factor `R` (`p x p`) of the thin QR decomposition `A = Q R` of a tall
/// `m x p` matrix, and `Q^T y` cut to its first `p` rows when `y` is given. `R` has the
/// singular values and right singular vectors of `A` (so its condition number and
/// `(A^T A)^-1 = (R^T R)^-1`), and `R x = (Q^T y)[..p]` is the least-squares solution of
/// `A x = y`. A matrix with no more rows than columns is returned as it is (with `y`).
///
/// Tall-skinny QR: the `R` of each block of rows (in parallel), then the `R` of those
/// stacked, which is an `R` of `A` since every step is orthogonal. `y` rides along as a last
/// column, whose part of the final `R` is `Q^T y` with the signs of `R`'s rows. One
/// Householder QR of all rows streams the whole matrix once per column; for the tens of
/// thousands of rows of a fit with each motor's power that was a quarter of the time of
/// identification.
pub(crate) fn reduce(
    a: &DMatrix<f64>,
    y: Option<&DVector<f64>>,
) -> (DMatrix<f64>, Option<DVector<f64>>) {
    use rayon::prelude::*;
    let (m, p) = a.shape();
    if m <= p {
        return (a.clone(), y.cloned());
    }
    let cols = p + usize::from(y.is_some());
    let block = QR_BLOCK_ROWS.max(4 * cols);
    // Block starts; a short remainder joins the last block.
    let starts: Vec<usize> = (0..m)
        .step_by(block)
        .filter(|&s| s == 0 || m - s >= block)
        .collect();
    let augmented = |from: usize, to: usize| -> DMatrix<f64> {
        DMatrix::from_fn(to - from, cols, |i, c| match y {
            Some(y) if c == p => y[from + i],
            _ => a[(from + i, c)],
        })
    };
    let r = if starts.len() == 1 {
        augmented(0, m).qr().r()
    } else {
        let factors: Vec<DMatrix<f64>> = (0..starts.len())
            .into_par_iter()
            .map(|k| {
                let to = starts.get(k + 1).copied().unwrap_or(m);
                augmented(starts[k], to).qr().r()
            })
            .collect();
        let stacked = DMatrix::from_fn(factors.len() * cols, cols, |i, c| {
            factors[i / cols][(i % cols, c)]
        });
        stacked.qr().r()
    };
    let qty = y.map(|_| r.view((0, p), (p, 1)).column(0).into_owned());
    (r.view((0, 0), (p, p)).into_owned(), qty)
}

/// [`reduce`] of the system `a x = y`: `R` and `Q^T y` (`y` itself for a matrix with no more
/// rows than columns), the reduction [`solve_reduced`] and [`solve_with_prior_reduced`] take.
pub(crate) fn reduce_system(a: &DMatrix<f64>, y: &DVector<f64>) -> (DMatrix<f64>, DVector<f64>) {
    let (r, qty) = reduce(a, Some(y));
    (r, qty.unwrap_or_else(|| y.clone()))
}

/// Relative standard deviations `std / |value|` (infinite for a value of 0).
pub(crate) fn rel_std(values: &[f64], std: &[f64]) -> Vec<f64> {
    values
        .iter()
        .zip(std)
        .map(|(v, s)| {
            if *v == 0.0 {
                f64::INFINITY
            } else {
                s / v.abs()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tall matrix of rows of very different sizes (a badly scaled regressor) and its
    /// observations.
    fn tall(m: usize, p: usize) -> (DMatrix<f64>, DVector<f64>) {
        let a = DMatrix::from_fn(m, p, |i, c| {
            let x = ((i * 7919 + c * 104_729) % 1000) as f64 / 1000.0 - 0.5;
            x * 10f64.powi(c as i32 % 4 - 2) + if c == 0 { 1.0 } else { 0.0 }
        });
        let y = DVector::from_fn(m, |i, _| ((i * 31) % 17) as f64 - 8.0);
        (a, y)
    }

    #[test]
    fn the_blocked_qr_gives_the_least_squares_of_all_rows() {
        // One block, one block with a remainder, and many blocks.
        for m in [900, QR_BLOCK_ROWS + 7, 5 * QR_BLOCK_ROWS + 300] {
            let (a, y) = tall(m, 9);
            let (r, qty) = reduce(&a, Some(&y));
            let qty = qty.unwrap();
            assert_eq!((r.nrows(), r.ncols(), qty.len()), (9, 9, 9));
            // R^T R = A^T A, and R x = Q^T y solves the least squares of all rows.
            let gram = a.transpose() * &a;
            let rel = (r.transpose() * &r - &gram).norm() / gram.norm();
            assert!(rel < 1e-12, "{m} rows: {rel}");
            let x = r.clone().solve_upper_triangular(&qty).unwrap();
            let reference = a.clone().svd(true, true).solve(&y, 1e-14).unwrap();
            let err = (&x - &reference).norm() / reference.norm();
            assert!(err < 1e-9, "{m} rows: {err}");
            // Without observations the same factor (row signs aside).
            let (r_only, none) = reduce(&a, None);
            assert!(none.is_none());
            let rel = (r_only.transpose() * &r_only - &gram).norm() / gram.norm();
            assert!(rel < 1e-12, "{m} rows: {rel}");
        }
    }
}
