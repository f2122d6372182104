//! The lag of the logged power behind the logged joints, found by the power model's own fit.
//!
//! A power meter on its own clock, or with a filter, logs the power late: the sample stamped
//! `t` is the power at `t - L`. Left unmodelled, a lag of a fraction of a sample period
//! already biases the inertial and friction parameters (the power moves fast where the arm
//! accelerates). The model-free estimate of [`crate::measurement::lag`] is good to about a
//! sample period; the power model explains the power far better, so its residual finds `L`
//! to a few milliseconds at any rate, averaging meters included.
//!
//! For each trial lag the logs are prepared with the states that much earlier
//! ([`crate::identification::data::prepare_lagged`]) and the PMSM estimator (unweighted, the
//! arm's power only, every sample) fitted on the pooled samples; the lag with the least
//! residual wins: a grid of [`GRID`] points over `+-max`, a grid of [`FINE`] across one coarse
//! step around its best, and the vertex of the parabola through the fine best and its
//! neighbours. The linear estimator without copper loss would not do: with
//! loads its residual is dominated by the copper loss it lacks and the lag it finds is a
//! third of the true one (docs/experiments.md#power-lag-in-the-fit).

use super::samples::Samples;
use super::{Estimator, FitOptions, Weighting, fit};
use crate::error::Result;
use crate::identification::data::{Route, prepare_lagged};
use crate::identification::model::PowerModel;
use crate::measurement::Log;
use crate::model::Robot;

/// Trial lags of the coarse grid (odd, so 0 is one of them).
const GRID: usize = 7;

/// Trial lags of the fine grid across one coarse step around the coarse best.
const FINE: usize = 5;

/// The 99 % point of chi-square with one degree of freedom: the evidence a lag needs.
const LAG_EVIDENCE: f64 = 6.63;

/// The lag (s) of the logged power behind the joints in `logs` that the PMSM power model
/// fits best, searched within `+-opts.max_power_lag_s`; 0 when the search is off, when the
/// logs do not fit at all, or when the data cannot tell the lag from none.
pub(super) fn find_lag(
    robot: &Robot,
    template: &PowerModel,
    logs: &[Log],
    routes: &[Route],
    opts: &FitOptions,
) -> Result<f64> {
    let max = opts.max_power_lag_s;
    if max <= 0.0 {
        return Ok(0.0);
    }
    let rows = std::cell::Cell::new(0usize);
    let cost = |lag: f64| -> Result<f64> {
        let prepared = logs
            .iter()
            .enumerate()
            .map(|(k, l)| prepare_lagged(l, routes[k.min(routes.len() - 1)], lag))
            .collect::<Result<Vec<_>>>()?;
        let samples = Samples::new(
            robot,
            template,
            &prepared,
            // Every sample: a speed threshold would pick other samples at every trial lag
            // and make the residual jump between them.
            0.0,
            opts.max_fit_rate_hz,
            opts.folds,
            false,
        )?;
        let samples = match &opts.prior {
            Some(prior) => samples.with_prior(prior.clone())?,
            None => samples,
        };
        let f = fit(
            template,
            &samples,
            Estimator::Pmsm,
            Weighting::None,
            &|_| true,
        )?;
        rows.set(f.estimate.rows);
        Ok(f.estimate.residual_rms)
    };
    // Logs too short or too poor for a fit of their own (with the prior, if any) leave the
    // lag at zero; the identification proper then says what they lack.
    let Ok(at_zero) = cost(0.0) else {
        return Ok(0.0);
    };
    let lag = search(max, &cost)?;
    // Keep the lag only where the data tell it from none: the likelihood ratio of the fits
    // at that lag and at zero, `N ln(RSS_0 / RSS_L)`, above the 99 % point of chi-square
    // with one degree of freedom. A gentle motion's power hardly depends on the lag; its
    // residual is flat and the least of it noise.
    let ratio = rows.get() as f64 * 2.0 * (at_zero / cost(lag)?).ln();
    Ok(if ratio > LAG_EVIDENCE { lag } else { 0.0 })
}

/// The least-cost lag within `+-max`.
fn search(max: f64, cost: &dyn Fn(f64) -> Result<f64>) -> Result<f64> {
    // The coarse grid, then a fine one around its best; the vertex of the parabola through
    // the fine best and its neighbours (kept inside them).
    let step = 2.0 * max / (GRID - 1) as f64;
    let coarse = best_of((0..GRID).map(|k| -max + k as f64 * step), cost)?;
    let fine_step = step / (FINE - 1) as f64;
    let fine: Vec<f64> = (0..FINE)
        .map(|k| coarse - 0.5 * step + k as f64 * fine_step)
        .collect();
    let costs = fine.iter().map(|&l| cost(l)).collect::<Result<Vec<_>>>()?;
    let k = (0..FINE)
        .min_by(|&a, &b| costs[a].total_cmp(&costs[b]))
        .unwrap_or(FINE / 2);
    if k == 0 || k == FINE - 1 {
        return Ok(fine[k]);
    }
    let (a, b, c) = (costs[k - 1], costs[k], costs[k + 1]);
    let curvature = a - 2.0 * b + c;
    let shift = if curvature > 0.0 {
        (0.5 * (a - c) / curvature).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    Ok(fine[k] + shift * fine_step)
}

/// The argument of the least cost among `lags`.
fn best_of(lags: impl Iterator<Item = f64>, cost: &dyn Fn(f64) -> Result<f64>) -> Result<f64> {
    let mut best = (0.0, f64::INFINITY);
    for lag in lags {
        let c = cost(lag)?;
        if c < best.1 {
            best = (lag, c);
        }
    }
    Ok(best.0)
}
