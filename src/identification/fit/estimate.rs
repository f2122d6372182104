//! One estimator's fit: the linear solution, Levenberg–Marquardt from it for the copper
//! losses (and the gear friction), the rounds of iterated weighting, and the loss
//! coefficients the data cannot tell from zero held there.

use nalgebra::{DMatrix, DVector};

use super::covariance::covariance;
use super::floor::Floor;
use super::nonlinear::{levenberg_marquardt, lm_statistics, residual_variance};
use super::weighting::variance_weights;
use super::{Estimator, Fit, Param, Weighting, samples::Samples};
use crate::error::Result;
use crate::identification::lsq::{
    ColumnPrior, Estimate, reduce_system, solve_reduced, solve_with_prior_reduced,
};
use crate::identification::model::PowerModel;
use crate::identification::tuning;

/// Measured power (W) above the floor at or below which a sample of a clipped signal (DC bus,
/// grid) may be clipped, so the linear estimator leaves it out.
const CLIPPED_BELOW_W: f64 = 2.0;

/// Re-weightings of iterated weighted least squares (each from the previous fit's residuals).
const WLS_ITERATIONS: usize = 2;

/// Fit `estimator` on the samples for which `use_sample(m)` and the sample's fit flag hold,
/// weighted by `weighting` (iterated: each weighting from the previous fit's residuals).
/// `template` gives the robot's base-parameter set (its values are ignored). The covariance
/// is the weighted one (the model's, where a nonlinear estimator holds loss coefficients at
/// zero, linearised at the held fit with those coefficients free); `residual_rms` stays the
/// unweighted RMS in W of the arm's power (not the motors').
pub fn fit(
    template: &PowerModel,
    s: &Samples,
    estimator: Estimator,
    weighting: Weighting,
    use_sample: &dyn Fn(usize) -> bool,
) -> Result<Fit> {
    fit_inner(template, s, estimator, weighting, use_sample, true, None)
}

/// [`fit`] with every loss coefficient free (none held at zero for want of significance)
/// and without statistics (zero covariance): the least cost and its `residual_rms` alone, for
/// a search that only compares residuals.
pub(super) fn fit_free(
    template: &PowerModel,
    s: &Samples,
    estimator: Estimator,
    weighting: Weighting,
) -> Result<Fit> {
    fit_free_from(template, s, estimator, weighting, None)
}

/// [`fit_free`] whose Levenberg–Marquardt starts from `start` (values in the fit's layout, as
/// [`Fit::estimate`] holds them) instead of the linear solution: the least cost on the branch
/// of another fit of nearly the same samples.
pub(super) fn fit_free_from(
    template: &PowerModel,
    s: &Samples,
    estimator: Estimator,
    weighting: Weighting,
    start: Option<&[f64]>,
) -> Result<Fit> {
    fit_inner(template, s, estimator, weighting, &|_| true, false, start)
}

/// [`fit`] when `full`, else [`fit_free`]; Levenberg–Marquardt from `start` (`None`: the
/// linear solution).
fn fit_inner(
    template: &PowerModel,
    s: &Samples,
    estimator: Estimator,
    weighting: Weighting,
    use_sample: &dyn Fn(usize) -> bool,
    full: bool,
    start: Option<&[f64]>,
) -> Result<Fit> {
    let s = &*s.for_estimator(estimator);
    let rows: Vec<usize> = (0..s.len())
        .filter(|&m| s.fit[m] && use_sample(m))
        .collect();
    // Each round's Levenberg–Marquardt starts from the round before (the weights move the
    // least cost a little) and solves no linear problem ([`warm_fit`]); the first starts
    // from the linear solution. From the linear solution every round, a bus signal's fit
    // (the clip makes its cost kinked) crawls tens of iterations back to where the last
    // round ended.
    let run = |zero_loss: &[bool], start: Option<&[f64]>| -> Result<(Fit, Vec<f64>)> {
        let mut weights = vec![1.0; rows.len()];
        let rounds = if weighting == Weighting::None {
            0
        } else {
            WLS_ITERATIONS
        };
        let one = |weights: &[f64], z: Option<&[f64]>, statistics: bool| {
            let start = Start { zero_loss, z };
            fit_weighted(template, s, estimator, &rows, weights, start, statistics)
        };
        let mut start = start.map(|z| z.to_vec());
        // Only the last round's statistics are kept: the earlier ones give only weights.
        for _ in 0..rounds {
            let f = one(&weights, start.as_deref(), false)?;
            let z = DVector::from_column_slice(&f.estimate.values);
            weights = variance_weights(s, &rows, &z, weighting);
            start = Some(f.estimate.values);
        }
        Ok((one(&weights, start.as_deref(), full)?, weights))
    };
    let layout = s.layout();
    let (f, _) = run(&vec![false; layout.len()], start)?;
    if estimator == Estimator::Total || !full {
        return Ok(f);
    }
    // Loss coefficients without a prior that the data cannot tell from zero (on the bound,
    // or within tuning::COPPER_SIGNIFICANCE standard deviations of it) are held at zero and
    // the rest refitted: left free, they trade against the standby power and each other along
    // directions the data barely see, and predict other motions far off
    // (docs/experiments.md#copper-coefficients-held-at-zero; tests/consistent.rs). A
    // coefficient with the drive file's value as a prior stays free: the prior holds it where
    // the data do not.
    let weak: Vec<bool> = (0..layout.len())
        .map(|k| {
            layout.is_loss(k)
                && f.covariance[(k, k)] > 0.0
                && !s.loss_has_prior(k)
                && f.estimate.values[k] <= tuning::COPPER_SIGNIFICANCE * f.covariance[(k, k)].sqrt()
        })
        .collect();
    if !weak.iter().any(|&w| w) {
        return Ok(f);
    }
    // From the free fit, the weak coefficients at zero.
    let (mut held, weights) = run(&weak, Some(&f.estimate.values))?;
    // Held at zero is an estimate, not knowledge: the model predicts with a covariance in
    // which a held coefficient keeps its spread and its trade against the standby and the
    // others, so a motion like the data gets about the interval it had, and one whose torques
    // on that joint go beyond the data's (a payload the data never carried) a wider one, not
    // a narrow one around the missing copper loss. That covariance is the model's own,
    // linearised at the parameters it predicts with, every loss coefficient free
    // ([`covariance_with_held_free`]). The free fit's, taken where a coefficient ran off along
    // a direction the data do not see (a wrist's growing while its fitted torque shrinks),
    // put millions of W/(N m)^2 of spread into every interval
    // (docs/experiments.md#copper-losses-without-a-drive-file). (The fit's own covariance
    // keeps zero rows there: they mark the parameters it held.)
    let covariance = covariance_with_held_free(template, s, estimator, &rows, &weights, &held)?;
    let z = DVector::from_column_slice(&held.estimate.values);
    held.model.covariance = fitted_model(template, s, estimator, &z, &covariance).covariance;
    Ok(held)
}

/// The covariance of `held`, a fit of `estimator` that held some loss coefficients at zero
/// on the samples `rows` with its last round's `weights`: linearised at its own parameters
/// with every loss coefficient the estimator fits free (a held one's column is its loss at
/// the model's torques, `tau_i^2` or `|dq_i tau_i|`), with the prior (if any) weighed by the
/// power model's residual variance there. A held coefficient keeps the spread the data leave
/// it and its trade against the others, taken at the model that predicts.
fn covariance_with_held_free(
    template: &PowerModel,
    s: &Samples,
    estimator: Estimator,
    rows: &[usize],
    weights: &[f64],
    held: &Fit,
) -> Result<DMatrix<f64>> {
    let z = DVector::from_column_slice(&held.estimate.values);
    let free = free_params(s, estimator, &vec![false; s.params()]);
    let moved = free.iter().filter(|f| **f).count();
    let z_prior = s.z_prior();
    let prior = (z_prior.as_ref()).map(|pr| (pr, residual_variance(s, rows, weights, &z, moved)));
    let (_, covariance) = lm_statistics(template, s, rows, weights, Some(&free), prior, &z)?;
    Ok(covariance)
}

/// The linear problem without copper loss and gear friction on the samples `rows` (weights
/// `weights`): `y - dq . tau_known = (dq^T W_b) theta + P0` for the arm, `y - dq_i tau_known,i =
/// (dq_i W_b,i) theta + P0_i` for motor `i`, rows times the square roots of the weights, the
/// arm's samples that may sit on the floor left out.
fn linear_design(s: &Samples, rows: &[usize], weights: &[f64]) -> LinearDesign {
    let (n, nb, np) = (s.n, s.nb, s.params());
    // A floor read from the logs is known here; one the standby gives is not yet.
    let floor = match s.floor {
        Some(Floor::Fixed(f)) => f.max(0.0),
        _ => 0.0,
    };
    let lin: Vec<(usize, f64)> = rows
        .iter()
        .zip(weights)
        .filter(|(m, _)| !s.clipped || s.motor[**m].is_some() || s.y[**m] > floor + CLIPPED_BELOW_W)
        .map(|(m, w)| (*m, w.sqrt()))
        .collect();
    let to_z: Vec<usize> = (0..nb).chain(s.layout().losses().end..np).collect();
    let mut a = DMatrix::zeros(lin.len(), to_z.len());
    let mut y = DVector::zeros(lin.len());
    for (r, &(m, sw)) in lin.iter().enumerate() {
        let joints = match s.motor[m] {
            Some(i) => i..i + 1,
            None => 0..n,
        };
        // The mean over the states the observation averages (one for an instantaneous
        // meter).
        let span = s.span[m];
        let w = sw / span as f64;
        let mut known_power = 0.0;
        for st in s.state[m]..s.state[m] + span {
            let v = &s.dq[st * n..(st + 1) * n];
            let wb = &s.wb[st * n * nb..(st + 1) * n * nb];
            let known = &s.tau_known[st * n..(st + 1) * n];
            for k in 0..nb {
                a[(r, k)] += w * joints.clone().map(|i| v[i] * wb[i * nb + k]).sum::<f64>();
            }
            known_power += joints.clone().map(|i| v[i] * known[i]).sum::<f64>() / span as f64;
        }
        let standby = to_z.binary_search(&s.constant(m));
        a[(r, standby.expect("every standby power is a column"))] = sw;
        y[r] = sw * (s.y[m] - known_power);
    }
    LinearDesign { lin, to_z, a, y }
}

/// The linear problem of [`linear_design`].
struct LinearDesign {
    /// The rows used: sample and square root of its weight.
    lin: Vec<(usize, f64)>,
    /// Each column's index in `z` (all but the loss coefficients).
    to_z: Vec<usize>,
    /// The weighted design.
    a: DMatrix<f64>,
    /// The weighted observations.
    y: DVector<f64>,
}

/// Where a weighted fit's Levenberg–Marquardt starts and what it holds.
#[derive(Clone, Copy)]
struct Start<'a> {
    /// The loss coefficients held at zero (by index in `z`).
    zero_loss: &'a [bool],
    /// The `z` to start from (held loss coefficients set to zero); `None`: the linear
    /// solution.
    z: Option<&'a [f64]>,
}

/// One weighted fit of `estimator` on the samples `rows` with weights `weights` (one per
/// row), Levenberg–Marquardt (the nonlinear estimators) from `start`. Without `statistics` the
/// fit's covariance is left zero and its estimate holds only the values (for a round of
/// iterated weighting, which needs only the residuals).
fn fit_weighted(
    template: &PowerModel,
    s: &Samples,
    estimator: Estimator,
    rows: &[usize],
    weights: &[f64],
    start: Start,
    statistics: bool,
) -> Result<Fit> {
    let (estimate, covariance, z) = match start.z {
        Some(z0) if estimator != Estimator::Total => {
            let free = free_params(s, estimator, start.zero_loss);
            warm_fit(template, s, rows, weights, (&free, z0), statistics)?
        }
        _ => cold_fit(
            template,
            s,
            estimator,
            rows,
            weights,
            start.zero_loss,
            statistics,
        )?,
    };
    let model = fitted_model(template, s, estimator, &z, &covariance);
    // The residual in W (unweighted) of the arm's power over the fitted samples.
    let arm: Vec<usize> = rows
        .iter()
        .copied()
        .filter(|&m| s.motor[m].is_none())
        .collect();
    let residual_rms = (arm
        .iter()
        .map(|&m| (s.power(m, &z, None) - s.y[m]).powi(2))
        .sum::<f64>()
        / arm.len().max(1) as f64)
        .sqrt();
    Ok(Fit {
        model,
        estimate: Estimate {
            values: z.as_slice().to_vec(),
            residual_rms,
            ..estimate
        },
        covariance,
        layout: s.layout(),
    })
}

/// The parameters a nonlinear `estimator` moves: all but the loss coefficients held at zero
/// (`zero_loss`) and those it does not fit.
fn free_params(s: &Samples, estimator: Estimator, zero_loss: &[bool]) -> Vec<bool> {
    let layout = s.layout();
    (0..layout.len())
        .map(|k| match layout.param(k) {
            Param::Copper(_) => !zero_loss[k],
            Param::Gear(_) => estimator.fits_gear() && !zero_loss[k],
            _ => true,
        })
        .collect()
}

/// [`fit_weighted`] from the linear solution: its estimate, covariance and parameters `z`.
fn cold_fit(
    template: &PowerModel,
    s: &Samples,
    estimator: Estimator,
    rows: &[usize],
    weights: &[f64],
    zero_loss: &[bool],
    statistics: bool,
) -> Result<(Estimate, DMatrix<f64>, DVector<f64>)> {
    let np = s.params();
    let LinearDesign { lin, to_z, a, y } = linear_design(s, rows, weights);
    let layout = s.layout();
    let names = layout.names(&template.names);
    let names_lin: Vec<String> = to_z.iter().map(|&k| names[k].clone()).collect();
    // With a prior, the posterior: the data decide what they determine, the prior the rest;
    // `s2` is the weighted rows' noise variance that weighs the prior against them.
    let z_prior = s.z_prior();
    // One reduction of the design for the solution and (the linear estimator's) covariance.
    let (rf, qty) = reduce_system(&a, &y);
    let (mut est, s2) = match &z_prior {
        Some(pr) => solve_with_prior_reduced(&a, &y, &names_lin, &pr.columns(&to_z), (&rf, &qty))?,
        None => (solve_reduced(&a, &y, &names_lin, (&rf, &qty))?, 0.0),
    };
    let prior = z_prior.as_ref().map(|pr| (pr, s2));
    est.params = to_z.iter().map(|&k| layout.param(k)).collect();
    let mut z = DVector::zeros(np);
    for (c, &k) in to_z.iter().enumerate() {
        z[k] = est.values[c];
    }
    let (estimate, covariance) = match estimator {
        _ if !statistics && estimator == Estimator::Total => (est, DMatrix::zeros(np, np)),
        Estimator::Total => {
            let x = DVector::from_column_slice(&est.values);
            let series: Vec<usize> = lin.iter().map(|&(m, _)| s.series[m]).collect();
            let at: Vec<_> = lin.iter().map(|&(m, _)| s.instant(m)).collect();
            let lin_prior = prior.map(|(pr, s2)| (pr.columns(&to_z), s2));
            let cov_lin = covariance(
                (&a, &rf),
                &(&y - &a * x),
                &series,
                &at,
                lin_prior.as_ref().map(|(pr, s2)| (pr, *s2)),
            )?;
            let mut cov = DMatrix::zeros(np, np);
            for (r, &kr) in to_z.iter().enumerate() {
                for (c, &kc) in to_z.iter().enumerate() {
                    cov[(kr, kc)] = cov_lin[(r, c)];
                }
            }
            (est, cov)
        }
        Estimator::Pmsm | Estimator::Gear => {
            let free = free_params(s, estimator, zero_loss);
            let prior = posterior_mode(s, rows, weights, &free, prior, &mut z)?;
            if statistics {
                lm_statistics(template, s, rows, weights, Some(&free), prior, &z)?
            } else {
                (est, DMatrix::zeros(np, np))
            }
        }
    };
    Ok((estimate, covariance, z))
}

/// [`fit_weighted`] of a nonlinear estimator from `z0`, the round before's parameters
/// (`free` marks those that move; the others start and stay at zero): its estimate,
/// covariance and parameters. No linear solution, which the start would replace; with a
/// prior, one Levenberg–Marquardt weighed by the power model's residual variance at `z0`
/// under these weights ([`posterior_mode`]'s second fit, from a start that is already the
/// power model's posterior mode under the round before's weights). Without `statistics` the
/// estimate holds no statistics (empty standard deviations, condition number 0).
fn warm_fit(
    template: &PowerModel,
    s: &Samples,
    rows: &[usize],
    weights: &[f64],
    (free, z0): (&[bool], &[f64]),
    statistics: bool,
) -> Result<(Estimate, DMatrix<f64>, DVector<f64>)> {
    let np = s.params();
    let mut z = DVector::from_fn(np, |k, _| if free[k] { z0[k] } else { 0.0 });
    let z_prior = s.z_prior();
    let moved = free.iter().filter(|f| **f).count();
    let prior = z_prior
        .as_ref()
        .map(|pr| (pr, residual_variance(s, rows, weights, &z, moved)));
    levenberg_marquardt(s, rows, weights, Some(free), prior, &mut z)?;
    if statistics {
        let (est, cov) = lm_statistics(template, s, rows, weights, Some(free), prior, &z)?;
        return Ok((est, cov, z));
    }
    let layout = s.layout();
    let est = Estimate {
        names: layout.names(&template.names),
        values: z.as_slice().to_vec(),
        std: Vec::new(),
        rel_std: Vec::new(),
        cond: 0.0,
        residual_rms: 0.0,
        rows: rows.len(),
        covariance: DMatrix::zeros(np, np),
        params: (0..np).map(|k| layout.param(k)).collect(),
    };
    Ok((est, DMatrix::zeros(np, np), z))
}

/// The model of `estimator`'s parameters `z` (with their `covariance`) on the samples `s`:
/// `[theta, c, g, P0]` (`g` only when the estimator fits it) and their covariance; the motors'
/// own standby powers only served the fit (their marginal is dropped).
fn fitted_model(
    template: &PowerModel,
    s: &Samples,
    estimator: Estimator,
    z: &DVector<f64>,
    covariance: &DMatrix<f64>,
) -> PowerModel {
    let (n, nb, np) = (s.n, s.nb, s.params());
    let mut model = template.clone();
    model.efficiency_scaled = false;
    model.theta.copy_from_slice(z.rows(0, nb).as_slice());
    model.copper.copy_from_slice(z.rows(nb, n).as_slice());
    model.gear_friction = if estimator.fits_gear() {
        z.rows(nb + n, n).as_slice().to_vec()
    } else {
        Vec::new()
    };
    model.constant.fill(0.0);
    model.constant[0] = z[np - 1];
    model.signal = if s.clipped {
        crate::measurement::PowerSignal::Bus
    } else {
        crate::measurement::PowerSignal::Total
    };
    let loss_end = nb + n + model.gear_friction.len();
    let kept: Vec<usize> = (0..loss_end).chain([np - 1]).collect();
    model.covariance = DMatrix::from_fn(kept.len(), kept.len(), |r, c| {
        covariance[(kept[r], kept[c])]
    })
    .as_slice()
    .to_vec();
    model
}

/// Levenberg-Marquardt of the PMSM fit from `z`, in place, moving the parameters `free`
/// marks; with a `prior`, refitted with the power model's own residual variance, which is
/// returned with the prior. The linear solution's variance (the `prior`'s on entry) holds the
/// copper loss it leaves out, tens of times the power model's on the family of truths, so it
/// weighs the prior that many times too heavily
/// (docs/experiments.md#the-drive-files-copper-as-a-prior).
fn posterior_mode<'a>(
    s: &Samples,
    rows: &[usize],
    weights: &[f64],
    free: &[bool],
    prior: Option<(&'a ColumnPrior, f64)>,
    z: &mut DVector<f64>,
) -> Result<Option<(&'a ColumnPrior, f64)>> {
    levenberg_marquardt(s, rows, weights, Some(free), prior, z)?;
    let Some((pr, _)) = prior else {
        return Ok(None);
    };
    let moved = free.iter().filter(|f| **f).count();
    let s2 = residual_variance(s, rows, weights, z, moved);
    levenberg_marquardt(s, rows, weights, Some(free), Some((pr, s2)), z)?;
    Ok(Some((pr, s2)))
}

impl Fit {
    /// The estimated values only (without the loss coefficients the estimator holds at
    /// zero), with their names and covariance.
    pub fn free_estimate(&self) -> Estimate {
        let layout = self.layout;
        let np = layout.len();
        let free: Vec<usize> = (0..np)
            .filter(|&k| !layout.is_loss(k) || self.covariance[(k, k)] > 0.0)
            .collect();
        let names = layout.names(&self.model.names);
        let pick = |v: &[f64]| free.iter().map(|&k| v[k]).collect::<Vec<f64>>();
        let std = pick(
            &(0..np)
                .map(|k| self.covariance[(k, k)].max(0.0).sqrt())
                .collect::<Vec<_>>(),
        );
        let values = pick(&self.estimate.values);
        Estimate {
            names: free.iter().map(|&k| names[k].clone()).collect(),
            params: free.iter().map(|&k| layout.param(k)).collect(),
            rel_std: crate::identification::lsq::rel_std(&values, &std),
            values,
            std,
            covariance: DMatrix::from_fn(free.len(), free.len(), |r, c| {
                self.covariance[(free[r], free[c])]
            }),
            ..self.estimate.clone()
        }
    }
}
