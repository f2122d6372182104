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
//! arm's power only, every sample, every copper coefficient free) fitted on the pooled samples; the lag with the least
//! residual wins: a grid of [`GRID`] points over `+-max`, then [`REFINE`] vertices of the
//! parabola through the best so far and its neighbours (each trial lag fitted once). The linear estimator without copper loss would not do: with
//! loads its residual is dominated by the copper loss it lacks and the lag it finds is a
//! third of the true one (docs/experiments.md#power-lag-in-the-fit).

use super::estimate::fit_free;
use super::samples::Samples;
use super::{Estimator, FitOptions, Weighting};
use crate::error::Result;
use crate::identification::data::{Route, prepare_lagged};
use crate::identification::model::PowerModel;
use crate::measurement::Log;
use crate::model::Robot;

/// Trial lags of the coarse grid (odd, so 0 is one of them).
const GRID: usize = 7;

/// Steps of successive parabolic interpolation after the coarse grid.
const REFINE: usize = 3;

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
    // The prior only where the logs cannot be fitted without it: a prior centred on files
    // that are wrong (a copper coefficient off by half) tilts every trial lag's residual, and
    // the least of them moves (a third of a sample period on the family of truths,
    // docs/experiments.md#the-drive-files-copper-as-a-prior).
    let with_prior = std::cell::Cell::new(false);
    let fit_at = |lag: f64| -> Result<f64> {
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
        let fitted = |samples: &Samples| -> Result<f64> {
            let f = fit_free(template, samples, Estimator::Pmsm, Weighting::None)?;
            rows.set((0..samples.len()).filter(|&m| samples.fit[m]).count());
            Ok(f.estimate.residual_rms)
        };
        if !with_prior.get() {
            match (fitted(&samples), &opts.prior) {
                (Ok(c), _) => return Ok(c),
                // Decided at the first trial lag: the regressor's rank does not depend on it.
                (Err(_), Some(_)) if rows.get() == 0 => with_prior.set(true),
                (Err(e), _) => return Err(e),
            }
        }
        // `with_prior` is set only when there is a prior.
        match &opts.prior {
            Some(prior) => fitted(&samples.with_prior(prior.clone())?),
            None => Ok(f64::INFINITY),
        }
    };
    // Each trial lag is fitted once: the search and the evidence share the fits.
    let tried = std::cell::RefCell::new(Vec::<(f64, f64)>::new());
    let cost = |lag: f64| -> Result<f64> {
        if let Some(&(_, c)) = tried.borrow().iter().find(|(l, _)| *l == lag) {
            return Ok(c);
        }
        let c = fit_at(lag)?;
        tried.borrow_mut().push((lag, c));
        Ok(c)
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

/// The least-cost lag within `+-max`: the best of a coarse grid, then [`REFINE`] steps of
/// successive parabolic interpolation inside the bracket of its neighbours; 0 when the grid's
/// best is on its edge.
fn search(max: f64, cost: &dyn Fn(f64) -> Result<f64>) -> Result<f64> {
    let step = 2.0 * max / (GRID - 1) as f64;
    let grid: Vec<f64> = (0..GRID).map(|k| -max + k as f64 * step).collect();
    let costs = grid.iter().map(|&l| cost(l)).collect::<Result<Vec<_>>>()?;
    let k = (0..GRID)
        .min_by(|&a, &b| costs[a].total_cmp(&costs[b]))
        .unwrap_or(GRID / 2);
    // A least cost on the range's edge brackets no minimum: the residual falls on past the
    // range (a lag beyond it) or is flat and its least value the fits' scatter (a slow,
    // averaged log whose power hardly depends on the lag). Either way no lag in the range
    // is told from the others: none is kept.
    if k == 0 || k == GRID - 1 {
        return Ok(0.0);
    }
    // The bracket (a, b, c): a < b < c, f(b) <= f(a), f(c).
    let mut br = [
        (grid[k - 1], costs[k - 1]),
        (grid[k], costs[k]),
        (grid[k + 1], costs[k + 1]),
    ];
    for _ in 0..REFINE {
        let [(a, fa), (b, fb), (c, fc)] = br;
        // The vertex of the parabola through the three, kept a tenth of the bracket away
        // from its ends and from b (a flat or degenerate parabola: the larger half's middle).
        let den = (b - a) * (fb - fc) - (b - c) * (fb - fa);
        let num = (b - a).powi(2) * (fb - fc) - (b - c).powi(2) * (fb - fa);
        let gap = 0.1 * (c - a);
        let mut x = if den.abs() > 0.0 {
            b - 0.5 * num / den
        } else {
            f64::NAN
        };
        if !(x > a + gap && x < c - gap) || (x - b).abs() < 0.5 * gap {
            x = if b - a > c - b {
                0.5 * (a + b)
            } else {
                0.5 * (b + c)
            };
        }
        let fx = cost(x)?;
        br = match (x < b, fx <= fb) {
            (true, true) => [(a, fa), (x, fx), (b, fb)],
            (true, false) => [(x, fx), (b, fb), (c, fc)],
            (false, true) => [(b, fb), (x, fx), (c, fc)],
            (false, false) => [(a, fa), (b, fb), (x, fx)],
        };
    }
    Ok(br[1].0)
}
