//! The nonlinear stage of the fit: Levenberg–Marquardt on the weighted residuals of the
//! power model (evaluated in parallel) and the statistics of its final linearisation.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::covariance::covariance;
use super::samples::{Instant, Samples};
use crate::error::Result;
use crate::identification::lsq::{Estimate, solve};
use crate::identification::model::PowerModel;
use crate::identification::tuning::CONVERGED_CHI2;

/// Iteration limit of Levenberg–Marquardt.
const MAX_ITERATIONS: usize = 100;

/// Fewest samples a thread evaluates at a time in Levenberg–Marquardt.
const PARALLEL_SAMPLES: usize = 512;

/// `J^T J` from the transposed Jacobian `J^T` (`p x m`, a column per sample) by the blocked
/// matrix product, through a transposed view (not a copy): the costliest product of an
/// iteration.
fn gram(jac_t: &DMatrix<f64>) -> DMatrix<f64> {
    let (p, m) = jac_t.shape();
    let jac = nalgebra::DMatrixView::from_slice_with_strides(jac_t.as_slice(), m, p, p, 1);
    jac_t * jac
}

/// Residuals of the observations `rows` at `z`, each times `sw` (the square roots of the
/// weights), and with `jac_t` the transposed Jacobian likewise weighted, a column per
/// observation. The observations are evaluated in parallel into disjoint slices (no
/// reduction, so the result does not depend on the threads).
fn weighted_residuals(
    s: &Samples,
    rows: &[usize],
    sw: &[f64],
    z: &DVector<f64>,
    jac_t: Option<&mut DMatrix<f64>>,
) -> DVector<f64> {
    let mut r = DVector::zeros(rows.len());
    let samples = r.as_mut_slice().par_iter_mut().zip(rows).zip(sw);
    match jac_t {
        Some(j) => samples
            .zip(j.as_mut_slice().par_chunks_mut(s.params()))
            .with_min_len(PARALLEL_SAMPLES)
            .for_each(|(((rk, &m), &w), col)| {
                *rk = w * (s.power(m, z, Some(col)) - s.y[m]);
                col.iter_mut().for_each(|g| *g *= w);
            }),
        None => samples
            .with_min_len(PARALLEL_SAMPLES)
            .for_each(|((rk, &m), &w)| *rk = w * (s.power(m, z, None) - s.y[m])),
    }
    r
}

/// Levenberg–Marquardt on the samples `rows` with `weights` (one per row) from `z` (the
/// linear solution), in place; only the parameters marked in `free` move (all when `None`).
pub(super) fn levenberg_marquardt(
    s: &Samples,
    rows: &[usize],
    weights: &[f64],
    free: Option<&[bool]>,
    z: &mut DVector<f64>,
) -> Result<()> {
    let np = s.params();
    let sw: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
    let eval = |z: &DVector<f64>, jac_t: Option<&mut DMatrix<f64>>| {
        weighted_residuals(s, rows, &sw, z, jac_t)
    };
    let mut jac_t = DMatrix::zeros(np, rows.len());
    let mut r = eval(z, Some(&mut jac_t));
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    for _ in 0..MAX_ITERATIONS {
        let mut jtj = gram(&jac_t);
        let mut g = &jac_t * &r;
        // Held this iteration: the fixed parameters, and the copper coefficients on their
        // bound (0) that the gradient pushes below it (the active set). Projecting a full
        // Gauss-Newton step instead spoils it for every parameter correlated with the bound
        // one, and the iteration crawls.
        let held: Vec<bool> = (0..np)
            .map(|k| {
                let fixed = free.is_some_and(|f| !f[k]);
                let copper = (s.nb..s.nb + s.n).contains(&k);
                fixed || (copper && z[k] <= 0.0 && g[k] > 0.0)
            })
            .collect();
        for k in (0..np).filter(|&k| held[k]) {
            // No coupling, no gradient, so the step is zero.
            jtj.row_mut(k).fill(0.0);
            jtj.column_mut(k).fill(0.0);
            jtj[(k, k)] = 1.0;
            g[k] = 0.0;
        }
        let mut improved = false;
        for _ in 0..20 {
            let mut a = jtj.clone();
            for k in 0..np {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(chol) = a.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let step = chol.solve(&(-&g));
            let mut trial = &*z + &step;
            // Copper-loss coefficients are resistances: kept >= 0 (projected).
            for i in 0..s.n {
                trial[s.nb + i] = trial[s.nb + i].max(0.0);
            }
            let c = eval(&trial, None).norm_squared();
            if c < cost {
                // The fall in units of the residual variance (chi-square): below
                // CONVERGED_CHI2 the parameters are within 0.01 standard deviations of the
                // least cost.
                let chi2 =
                    (cost - c) * (rows.len().saturating_sub(np)).max(1) as f64 / cost.max(1e-300);
                *z = trial;
                r = eval(z, Some(&mut jac_t));
                cost = c;
                lambda = (lambda / 10.0).max(1e-12);
                improved = chi2 > CONVERGED_CHI2;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    Ok(())
}

/// Statistics of the fit at `z` on the samples `rows` with `weights`: its estimate and the
/// covariance of `z` (HAC, [`covariance`]) from the linearisation there over the parameters
/// `free` marks (all when `None`); a held parameter gets zero rows and columns.
pub(super) fn lm_statistics(
    template: &PowerModel,
    s: &Samples,
    rows: &[usize],
    weights: &[f64],
    free: Option<&[bool]>,
    z: &DVector<f64>,
) -> Result<(Estimate, DMatrix<f64>)> {
    let np = s.params();
    let sw: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
    let mut jac_t = DMatrix::zeros(np, rows.len());
    let r = weighted_residuals(s, rows, &sw, z, Some(&mut jac_t));
    let layout = s.layout();
    let names = layout.names(&template.names);
    // Statistics of the final linearisation over the parameters it moves (`J z - r` are its
    // observations); a held parameter gets zero rows and columns in the covariance.
    let moved: Vec<usize> = (0..np).filter(|&k| free.is_none_or(|f| f[k])).collect();
    let jac = DMatrix::from_fn(rows.len(), moved.len(), |m, c| jac_t[(moved[c], m)]);
    let y = &jac * DVector::from_iterator(moved.len(), moved.iter().map(|&k| z[k])) - &r;
    let moved_names: Vec<String> = moved.iter().map(|&k| names[k].clone()).collect();
    let mut est = solve(&jac, &y, &moved_names)?;
    est.params = moved.iter().map(|&k| layout.param(k)).collect();
    let series: Vec<usize> = rows.iter().map(|&m| s.series[m]).collect();
    let at: Vec<Instant> = rows.iter().map(|&m| s.instant(m)).collect();
    let moved_cov = covariance(&jac, &r, &series, &at)?;
    let mut cov = DMatrix::zeros(np, np);
    for (a, &ka) in moved.iter().enumerate() {
        for (b, &kb) in moved.iter().enumerate() {
            cov[(ka, kb)] = moved_cov[(a, b)];
        }
    }
    Ok((est, cov))
}
