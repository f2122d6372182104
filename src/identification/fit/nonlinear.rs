//! The nonlinear stage of the fit: Levenberg–Marquardt on the weighted residuals of the
//! power model (evaluated in parallel) and the statistics of its final linearisation.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::covariance::covariance;
use super::samples::{Instant, Samples};
use crate::error::Result;
use crate::identification::lsq::{
    ColumnPrior, Estimate, reduce_system, solve_reduced, solve_with_prior_reduced,
};
use crate::identification::model::PowerModel;
use crate::identification::tuning::CONVERGED_CHI2;
use crate::numerics::lm;

/// Iteration limit of Levenberg–Marquardt.
const MAX_ITERATIONS: usize = 100;

/// Damping increases tried per iteration of Levenberg–Marquardt.
const MAX_TRIES: usize = 20;

/// Fewest samples a thread evaluates at a time in Levenberg–Marquardt.
const PARALLEL_SAMPLES: usize = 512;

/// Row blocks of `J^T J` that [`gram`] computes from the diagonal on: `(1 + 3/4 + 1/2 +
/// 1/4) / 4`, five eighths of the full product's flops.
const GRAM_BLOCKS: usize = 4;

/// `J^T J` from the transposed Jacobian `J^T` (`p x m`, a column per sample) by the blocked
/// matrix product, through a transposed view (not a copy): the costliest product of an
/// iteration. Only the block upper triangle is multiplied (row block `b` of `J^T` times the
/// columns of `J` from `b`'s first on), the rest mirrored: the blocked product computes each
/// entry alone (its sum over the samples in the same order, wherever the entry lies), so the
/// result is the full product's, bit for bit (`gram_is_the_full_product`).
fn gram(jac_t: &DMatrix<f64>) -> DMatrix<f64> {
    let (p, m) = jac_t.shape();
    let jac = nalgebra::DMatrixView::from_slice_with_strides(jac_t.as_slice(), m, p, p, 1);
    // nalgebra hands a product to the blocked one only above 5 rows and columns a factor.
    if p < 8 * GRAM_BLOCKS || m <= 5 {
        return jac_t * jac;
    }
    let mut out = DMatrix::zeros(p, p);
    for b in 0..GRAM_BLOCKS {
        let (r0, r1) = (b * p / GRAM_BLOCKS, (b + 1) * p / GRAM_BLOCKS);
        let block = jac_t.rows(r0, r1 - r0) * jac.columns(r0, p - r0);
        out.view_mut((r0, r0), (r1 - r0, p - r0)).copy_from(&block);
    }
    for c in 0..p {
        for r in c + 1..p {
            out[(r, c)] = out[(c, r)];
        }
    }
    out
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
/// The shared loop ([`crate::numerics::lm`]) with Marquardt's damping (the diagonal of
/// `J^T J` scaled), loss coefficients (copper, gear friction) kept >= 0 by an active set and
/// projection, and a
/// stop when a step lowers the cost by less than [`CONVERGED_CHI2`] residual variances.
///
/// With a `prior` (on `z`, with the rows' noise variance `s^2`), its rows `s root (z - mean)`
/// join the residuals: the minimum is the posterior mode.
pub(super) fn levenberg_marquardt(
    s: &Samples,
    rows: &[usize],
    weights: &[f64],
    free: Option<&[bool]>,
    prior: Option<(&ColumnPrior, f64)>,
    z: &mut DVector<f64>,
) -> Result<()> {
    let np = s.params();
    let sw: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
    let mut jac_t = DMatrix::zeros(np, rows.len());
    let r = weighted_residuals(s, rows, &sw, z, Some(&mut jac_t));
    let prior = prior.map(|(pr, s2)| PriorRows {
        root: &pr.root * s2.sqrt(),
        target: &pr.root * &pr.mean * s2.sqrt(),
    });
    let cost = r.norm_squared() + prior.as_ref().map_or(0.0, |p| p.cost(z));
    let mut problem = PowerFit {
        s,
        rows,
        sw,
        free,
        prior,
        z,
        jac_t,
        r,
        cost,
        jtj: DMatrix::zeros(np, np),
        g: DVector::zeros(np),
        trial_r: DVector::zeros(rows.len()),
        trial_jac_t: DMatrix::zeros(np, rows.len()),
    };
    lm::minimise(
        &mut problem,
        &lm::Options {
            max_iterations: MAX_ITERATIONS,
            max_tries: MAX_TRIES,
            initial_damping: 1e-3,
            min_damping: 1e-12,
            max_damping: f64::INFINITY,
            shrink: lm::Shrink::Divide(10.0),
            // The fall in units of the residual variance (chi-square): below CONVERGED_CHI2
            // the parameters are within 0.01 standard deviations of the least cost.
            fall: Some(lm::Fall {
                scale: (rows.len().saturating_sub(np)).max(1) as f64,
                threshold: CONVERGED_CHI2,
            }),
            stall: None,
            stop_when_stuck: true,
        },
    );
    Ok(())
}

/// The weighted residual variance of the samples `rows` (weights `weights`) at `z` with
/// `moved` parameters fitted: `sum w r^2 / (rows - moved)`, the noise variance that weighs a
/// prior against them. Summed in parallel over fixed blocks of [`PARALLEL_SAMPLES`] and the
/// blocks' sums in order, so the result does not depend on the threads (a parallel `sum`
/// splits where the work is stolen, and floating-point addition is not associative).
pub(super) fn residual_variance(
    s: &Samples,
    rows: &[usize],
    weights: &[f64],
    z: &DVector<f64>,
    moved: usize,
) -> f64 {
    let blocks: Vec<f64> = rows
        .par_chunks(PARALLEL_SAMPLES)
        .zip(weights.par_chunks(PARALLEL_SAMPLES))
        .map(|(rows, weights)| {
            rows.iter()
                .zip(weights)
                .map(|(&m, w)| w * (s.power(m, z, None) - s.y[m]).powi(2))
                .sum::<f64>()
        })
        .collect();
    let r2: f64 = blocks.iter().sum();
    r2 / rows.len().saturating_sub(moved).max(1) as f64
}

/// The prior's rows in a fit: residuals `root z - target`.
struct PriorRows {
    /// `s root`.
    root: DMatrix<f64>,
    /// `s root mean`.
    target: DVector<f64>,
}

impl PriorRows {
    /// The prior rows' residuals at `z`.
    fn residuals(&self, z: &DVector<f64>) -> DVector<f64> {
        &self.root * z - &self.target
    }

    /// Their sum of squares at `z`.
    fn cost(&self, z: &DVector<f64>) -> f64 {
        self.residuals(z).norm_squared()
    }
}

/// The power fit as a problem of [`lm::minimise`]: the weighted residuals of the samples
/// `rows` at `z`, their transposed Jacobian, and this iteration's normal equations.
struct PowerFit<'a> {
    s: &'a Samples,
    rows: &'a [usize],
    /// Square roots of the weights, one per row.
    sw: Vec<f64>,
    /// The parameters that may move (all when `None`).
    free: Option<&'a [bool]>,
    /// The prior's rows, if any.
    prior: Option<PriorRows>,
    /// The current parameters.
    z: &'a mut DVector<f64>,
    /// Transposed weighted Jacobian at `z`, a column per row.
    jac_t: DMatrix<f64>,
    /// Weighted residuals at `z`.
    r: DVector<f64>,
    /// `|r|^2` (of the trial that became `z`).
    cost: f64,
    /// `J^T J` with the held parameters decoupled.
    jtj: DMatrix<f64>,
    /// `J^T r` with the held parameters' entries zero.
    g: DVector<f64>,
    /// The last trial's weighted residuals and transposed Jacobian: evaluated with its cost,
    /// they become `r` and `jac_t` when it is accepted (one pass over the samples per trial).
    trial_r: DVector<f64>,
    trial_jac_t: DMatrix<f64>,
}

impl lm::Problem for PowerFit<'_> {
    type Trial = DVector<f64>;

    fn cost(&self) -> f64 {
        self.cost
    }

    fn linearise(&mut self) {
        let (s, np) = (self.s, self.s.params());
        self.jtj = gram(&self.jac_t);
        self.g = &self.jac_t * &self.r;
        if let Some(p) = &self.prior {
            self.jtj += p.root.transpose() * &p.root;
            self.g += p.root.transpose() * p.residuals(self.z);
        }
        // Held this iteration: the fixed parameters, and the loss coefficients on their
        // bound (0) that the gradient pushes below it (the active set). Projecting a full
        // Gauss-Newton step instead spoils it for every parameter correlated with the bound
        // one, and the iteration crawls.
        let held: Vec<bool> = (0..np)
            .map(|k| {
                let fixed = self.free.is_some_and(|f| !f[k]);
                let loss = s.layout().is_loss(k);
                fixed || (loss && self.z[k] <= 0.0 && self.g[k] > 0.0)
            })
            .collect();
        lm::hold(&mut self.jtj, &mut self.g, &held);
    }

    fn trial(&mut self, damping: f64) -> Option<(DVector<f64>, f64)> {
        let s = self.s;
        let mut a = self.jtj.clone();
        for k in 0..s.params() {
            a[(k, k)] += damping * self.jtj[(k, k)].max(1e-12);
        }
        let chol = a.cholesky()?;
        let step = chol.solve(&(-&self.g));
        let mut trial = &*self.z + &step;
        // Copper-loss coefficients are resistances and gear friction dissipates: both kept
        // >= 0 (projected).
        for k in s.layout().losses() {
            trial[k] = trial[k].max(0.0);
        }
        self.trial_r =
            weighted_residuals(s, self.rows, &self.sw, &trial, Some(&mut self.trial_jac_t));
        let c = self.trial_r.norm_squared() + self.prior.as_ref().map_or(0.0, |p| p.cost(&trial));
        Some((trial, c))
    }

    fn accept(&mut self, trial: DVector<f64>, cost: f64) {
        *self.z = trial;
        std::mem::swap(&mut self.r, &mut self.trial_r);
        std::mem::swap(&mut self.jac_t, &mut self.trial_jac_t);
        self.cost = cost;
    }
}

/// Statistics of the fit at `z` on the samples `rows` with `weights`: its estimate and the
/// covariance of `z` (HAC, [`covariance`]) from the linearisation there over the parameters
/// `free` marks (all when `None`); a held parameter gets zero rows and columns. With a
/// `prior` (and the rows' noise variance), the posterior's statistics.
pub(super) fn lm_statistics(
    template: &PowerModel,
    s: &Samples,
    rows: &[usize],
    weights: &[f64],
    free: Option<&[bool]>,
    prior: Option<(&ColumnPrior, f64)>,
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
    let moved_prior = prior.map(|(pr, s2)| (pr.columns(&moved), s2));
    // One reduction of the linearisation for the estimate and its covariance.
    let (rf, qty) = reduce_system(&jac, &y);
    let mut est = match &moved_prior {
        Some((pr, _)) => solve_with_prior_reduced(&jac, &y, &moved_names, pr, (&rf, &qty))?.0,
        None => solve_reduced(&jac, &y, &moved_names, (&rf, &qty))?,
    };
    est.params = moved.iter().map(|&k| layout.param(k)).collect();
    let series: Vec<usize> = rows.iter().map(|&m| s.series[m]).collect();
    let at: Vec<Instant> = rows.iter().map(|&m| s.instant(m)).collect();
    let moved_cov = covariance(
        (&jac, &rf),
        &r,
        &series,
        &at,
        moved_prior.as_ref().map(|(pr, s2)| (pr, *s2)),
    )?;
    let mut cov = DMatrix::zeros(np, np);
    for (a, &ka) in moved.iter().enumerate() {
        for (b, &kb) in moved.iter().enumerate() {
            cov[(ka, kb)] = moved_cov[(a, b)];
        }
    }
    Ok((est, cov))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block-triangle Gram matrix equals the full blocked product bit for bit, for sample
    /// counts beyond the product's depth blocks and parameter counts not divisible by the
    /// row blocks.
    #[test]
    fn gram_is_the_full_product() {
        for (p, m) in [(70, 3001), (65, 16_800), (33, 257), (12, 40)] {
            let jac_t = DMatrix::from_fn(p, m, |r, c| {
                let x = ((r * 7919 + c * 104_729) % 1009) as f64 / 1009.0 - 0.5;
                x * 10f64.powi((r % 7) as i32 - 3)
            });
            let jac = nalgebra::DMatrixView::from_slice_with_strides(jac_t.as_slice(), m, p, p, 1);
            let full = &jac_t * jac;
            let fast = gram(&jac_t);
            assert!(
                full.iter()
                    .zip(fast.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "p {p}, m {m}"
            );
        }
    }
}
