//! The heteroscedasticity and autocorrelation consistent (HAC) covariance of a least-squares
//! estimate whose residuals are correlated in time within each log.

use nalgebra::{DMatrix, DVector};

use super::samples::Instant;
use crate::error::{Error, Result};
use crate::identification::lsq::ColumnPrior;

/// Covariance of the least-squares estimate from the (weighted) design `a` and its residuals
/// `r` (one per row), computed with the columns scaled to unit norm. Rows of one log
/// (`log[row]`, in time order) are neighbours in time: their residuals are correlated (the
/// 10 Hz route's differentiation error and any structure error change slowly), so the plain
/// `s^2 (A^T A)^-1` understates the spread of the estimate. This is the heteroscedasticity
/// and autocorrelation consistent (HAC) sandwich `B S B` with `B = (A^T A)^-1` and `S` the
/// Bartlett-weighted sum of the score products `g_t g_{t-l}^T` (`g_t = a_t r_t`) within each
/// log up to lag `L` (Newey and West 1987), `L` from the pooled lag-1 autocorrelation `rho` of
/// the residuals by Andrews' (1991) AR(1) plug-in `1.1447 (alpha T)^(1/3)`,
/// `alpha = 4 rho^2 / ((1 - rho)^2 (1 + rho)^2)`, `T` the mean rows per log; times
/// `m / (m - p)`. With white residuals (`rho` = 0) it is the plain sandwich.
///
/// Rows are the observations of the series `series[row]` (one signal of one log, in time
/// order; the lag comes from their residuals) taken at `at[row]` (its log and state; states
/// numbered in time order): the arm's power and each motor's at one instant share the
/// state's error (the route's, the structure's), so the scores of one instant are summed
/// before the kernel runs over the instants of each log. Series taken as independent,
/// duplicated observations would count as new information.
///
/// With a Gaussian `prior` on the columns and the rows' noise variance `s^2` (the estimate
/// then being the posterior mean `(A^T A + s^2 P)^-1 (A^T y + s^2 P mean)`, `P` the prior's
/// precision), the covariance is that of the estimate's error over both the noise and the
/// prior's spread of the truth: `B (S + s^4 P) B` with `B = (A^T A + s^2 P)^-1`. With white
/// residuals that is the posterior covariance `(A^T A / s^2 + P)^-1`; without a prior, the
/// sandwich above. The degrees of freedom use the effective number of parameters
/// `tr(B A^T A)`.
///
/// `rf` is `A`'s triangular factor by [`reduce`](crate::identification::lsq::reduce)
/// (shared with the estimate's own solution).
pub(super) fn covariance(
    (a, rf): (&DMatrix<f64>, &DMatrix<f64>),
    r: &DVector<f64>,
    series: &[usize],
    at: &[Instant],
    prior: Option<(&ColumnPrior, f64)>,
) -> Result<DMatrix<f64>> {
    let (m, p) = a.shape();
    debug_assert_eq!(r.len(), m);
    debug_assert_eq!((series.len(), at.len()), (m, m));
    // The triangular factor has A's singular values and right singular vectors; the prior's
    // rows `s root` below it make the factor of `A^T A + s^2 P`.
    let stacked = match prior {
        Some((pr, s2)) => {
            let k = pr.root.nrows();
            DMatrix::from_fn(rf.nrows() + k, p, |i, c| {
                if i < rf.nrows() {
                    rf[(i, c)]
                } else {
                    s2.sqrt() * pr.root[(i - rf.nrows(), c)]
                }
            })
        }
        None => rf.clone(),
    };
    let norms: Vec<f64> = match prior {
        Some(_) => stacked
            .column_iter()
            .map(|c| c.norm().max(1e-300))
            .collect(),
        None => a.column_iter().map(|c| c.norm().max(1e-300)).collect(),
    };
    let scaled = DMatrix::from_fn(stacked.nrows(), p, |i, c| stacked[(i, c)] / norms[c]);
    let svd = scaled.svd(false, true);
    let v_t = svd
        .v_t
        .ok_or_else(|| Error::Numerical("SVD without V".into()))?;
    // B = (A_s^T A_s + s^2 P_s)^-1 of the scaled columns.
    let bread = DMatrix::from_fn(p, p, |i, j| {
        (0..p)
            .map(|k| v_t[(k, i)] * v_t[(k, j)] / svd.singular_values[k].powi(2))
            .sum::<f64>()
    });
    let lag = hac_lag(r, series);
    // Scores of the scaled columns, summed per instant, a column per instant in time order.
    let instants: std::collections::BTreeMap<Instant, usize> = at
        .iter()
        .copied()
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .enumerate()
        .map(|(k, i)| (i, k))
        .collect();
    let mut g = DMatrix::zeros(p, instants.len());
    for (t, i) in at.iter().enumerate() {
        let k = instants[i];
        for c in 0..p {
            g[(c, k)] += a[(t, c)] / norms[c] * r[t];
        }
    }
    let logs: Vec<usize> = instants.keys().map(|i| i.log).collect();
    let mut meat = bartlett_meat(&g, &logs, lag);
    let mut p_eff = p as f64;
    if let Some((pr, s2)) = prior {
        // s^4 P in the scaled columns, and tr(B A^T A) = p - tr(B s^2 P).
        let root_s = DMatrix::from_fn(pr.root.nrows(), p, |i, c| pr.root[(i, c)] / norms[c]);
        let info = root_s.transpose() * &root_s * s2;
        meat += &info * s2;
        p_eff -= (&bread * &info).trace();
    }
    let dof = m as f64 / (m as f64 - p_eff).max(1.0);
    let cov_scaled = &bread * meat * &bread * dof;
    Ok(DMatrix::from_fn(p, p, |i, j| {
        cov_scaled[(i, j)] / (norms[i] * norms[j])
    }))
}

/// `sum_{t,s} k(|t - s|) g_t g_s^T` over the columns `g_t` of `g` that belong to one log
/// (`log[t]`, each log's columns contiguous and in time order), with the Bartlett kernel
/// `k(d) = 1 - d / (lag + 1)` for `d <= lag`. The kernel is the overlap of two boxes of
/// `lag + 1` samples, so this is `sum_j h_j h_j^T / (lag + 1)` over the sums `h_j` of `g`
/// in every window of `lag + 1` samples that overlaps a log (partial windows at its ends
/// included): one matrix product, at the cost of lag 0 whatever the lag (a loop over lags
/// costs `lag` times that, and 1 kHz logs, their residuals correlated over many samples,
/// get long lags).
fn bartlett_meat(g: &DMatrix<f64>, log: &[usize], lag: usize) -> DMatrix<f64> {
    let p = g.nrows();
    let mut starts = vec![0];
    starts.extend((1..log.len()).filter(|&t| log[t] != log[t - 1]));
    starts.push(log.len());
    let windows: usize = starts.windows(2).map(|w| w[1] - w[0] + lag).sum();
    let mut h = DMatrix::zeros(p, windows);
    let mut col = 0;
    for seg in starts.windows(2) {
        let (s0, len) = (seg[0], seg[1] - seg[0]);
        // Prefix sums: column k holds the sum of the segment's first k scores.
        let mut prefix = DMatrix::zeros(p, len + 1);
        for k in 0..len {
            let next = prefix.column(k) + g.column(s0 + k);
            prefix.set_column(k + 1, &next);
        }
        for j in 0..len + lag {
            // Window [j - lag, j] of the segment, clipped to it.
            let (from, to) = (j.saturating_sub(lag), j.min(len - 1) + 1);
            h.set_column(col, &(prefix.column(to) - prefix.column(from)));
            col += 1;
        }
    }
    (&h * h.transpose()) / (lag + 1) as f64
}

/// Bartlett lag of [`covariance`]: Andrews' AR(1) plug-in from the lag-1 autocorrelation of
/// the residuals `r` pooled within the logs `log`, capped at a quarter of the mean rows per
/// log.
fn hac_lag(r: &DVector<f64>, log: &[usize]) -> usize {
    let m = r.len();
    let (mut num, mut den) = (0.0, 0.0);
    for t in 0..m {
        den += r[t] * r[t];
        if t > 0 && log[t] == log[t - 1] {
            num += r[t] * r[t - 1];
        }
    }
    let rho = if den > 0.0 {
        (num / den).clamp(0.0, 0.97)
    } else {
        0.0
    };
    let logs = log.windows(2).filter(|w| w[0] != w[1]).count() + 1;
    let rows = m as f64 / logs as f64;
    let alpha = 4.0 * rho * rho / ((1.0 - rho).powi(2) * (1.0 + rho).powi(2));
    (1.1447 * (alpha * rows).cbrt()).min(rows / 4.0).floor() as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identification::lsq::reduce;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    /// Unbiased sample variance of `v` (the Monte Carlo spread of an estimate).
    fn sample_variance(v: &[f64]) -> f64 {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64
    }

    /// Least squares on slow regressors (a constant and a 0.05 Hz sine and cosine at 10 Hz,
    /// four logs of 30 s) with AR(1) residuals (rho 0.7): the plain `s^2 (A^T A)^-1` is
    /// several times too narrow, the HAC covariance matches the spread of the estimates over
    /// 400 draws.
    #[test]
    fn the_covariance_accounts_for_residuals_correlated_in_time() {
        let (logs, rows, rho): (usize, usize, f64) = (4, 300, 0.7);
        // Each row its own log: no lags, the plain sandwich.
        let unrelated: Vec<usize> = (0..logs * rows).collect();
        let log: Vec<usize> = (0..logs * rows).map(|m| m / rows).collect();
        let a = DMatrix::from_fn(logs * rows, 3, |m, c| {
            let t = (m % rows) as f64 * 0.1 + 7.0 * (m / rows) as f64;
            let w = 2.0 * std::f64::consts::PI * 0.05 * t;
            [1.0, w.sin(), w.cos()][c]
        });
        let at: Vec<Instant> = log
            .iter()
            .enumerate()
            .map(|(m, &l)| Instant { log: l, state: m })
            .collect();
        let apart: Vec<Instant> = (0..log.len())
            .map(|m| Instant { log: m, state: m })
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (draws, mut est, mut hac, mut plain) = (400, Vec::new(), 0.0, 0.0);
        for _ in 0..draws {
            let mut e = DVector::zeros(logs * rows);
            let mut prev = 0.0;
            for m in 0..logs * rows {
                let z: f64 = rng.sample(StandardNormal);
                prev = if m % rows == 0 {
                    z / (1.0 - rho * rho).sqrt()
                } else {
                    rho * prev + z
                };
                e[m] = prev;
            }
            let x = a.clone().svd(true, true).solve(&e, 0.0).unwrap();
            let r = &e - &a * &x;
            hac += covariance((&a, &reduce(&a, None).0), &r, &log, &at, None).unwrap()[(0, 0)]
                / draws as f64;
            plain += covariance((&a, &reduce(&a, None).0), &r, &unrelated, &apart, None).unwrap()
                [(0, 0)]
                / draws as f64;
            est.push(x[0]);
        }
        let spread = sample_variance(&est);
        assert!(
            (0.7..1.4).contains(&(hac / spread)),
            "HAC variance {hac:.3e} against the spread {spread:.3e}"
        );
        assert!(
            plain / spread < 0.4,
            "plain {plain:.3e}, spread {spread:.3e}"
        );
    }

    /// Two signals observed at the same instants share those instants' errors (as the arm's
    /// and a motor's power share the state's): the covariance that sums the scores of an
    /// instant matches the estimate's spread; taking the signals as independent halves it.
    #[test]
    fn observations_of_one_instant_are_not_independent_information() {
        let rows = 400;
        // Series 0 and 1 observe the same design at the same instants of one log.
        let a = DMatrix::from_fn(2 * rows, 2, |m, c| {
            let w = 0.37 * (m % rows) as f64;
            [1.0, w.sin()][c]
        });
        let series: Vec<usize> = (0..2 * rows).map(|m| m / rows).collect();
        let shared: Vec<Instant> = (0..2 * rows)
            .map(|m| Instant {
                log: 0,
                state: m % rows,
            })
            .collect();
        let apart: Vec<Instant> = (0..2 * rows)
            .map(|m| Instant { log: 0, state: m })
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (draws, mut est, mut together, mut independent) = (400, Vec::new(), 0.0, 0.0);
        for _ in 0..draws {
            let common: Vec<f64> = (0..rows).map(|_| rng.sample(StandardNormal)).collect();
            let e = DVector::from_fn(2 * rows, |m, _| {
                common[m % rows] + 0.1 * rng.sample::<f64, _>(StandardNormal)
            });
            let x = a.clone().svd(true, true).solve(&e, 0.0).unwrap();
            let r = &e - &a * &x;
            together += covariance((&a, &reduce(&a, None).0), &r, &series, &shared, None).unwrap()
                [(1, 1)]
                / draws as f64;
            independent += covariance((&a, &reduce(&a, None).0), &r, &series, &apart, None)
                .unwrap()[(1, 1)]
                / draws as f64;
            est.push(x[1]);
        }
        let spread = sample_variance(&est);
        assert!(
            (0.8..1.25).contains(&(together / spread)),
            "{together:.3e} against the spread {spread:.3e}"
        );
        assert!(
            independent / spread < 0.6,
            "{independent:.3e} against the spread {spread:.3e}"
        );
    }

    /// The window form of the Bartlett sum equals the sum over lags.
    #[test]
    fn the_bartlett_windows_equal_the_sum_over_lags() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let log: Vec<usize> = (0..23)
            .map(|t| usize::from(t >= 9) + usize::from(t >= 20))
            .collect();
        let g = DMatrix::from_fn(4, log.len(), |_, _| rng.sample::<f64, _>(StandardNormal));
        for lag in [0, 1, 2, 5, 12] {
            let mut direct = &g * g.transpose();
            for l in 1..=lag {
                let w = 1.0 - l as f64 / (lag + 1) as f64;
                for t in l..log.len() {
                    if log[t] == log[t - l] {
                        let c = g.column(t) * g.column(t - l).transpose();
                        direct += (&c + c.transpose()) * w;
                    }
                }
            }
            let windows = bartlett_meat(&g, &log, lag);
            assert!(
                (windows - &direct).abs().max() < 1e-12 * direct.abs().max(),
                "lag {lag}"
            );
        }
    }
}
