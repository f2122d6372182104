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
//! residual wins: a grid of [`GRID`] points over `+-max`, then a golden-section search within
//! one grid step of the best. The linear estimator without copper loss would not do: with
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
const GRID: usize = 9;

/// Golden-section steps after the grid (each narrows the bracket by 0.618).
const REFINE: usize = 8;

/// The lag (s) of the logged power behind the joints in `logs` that the linear power model
/// fits best, searched within `+-opts.max_power_lag_s`; 0 when the search is off.
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
        let f = fit(
            template,
            &samples,
            Estimator::Pmsm,
            Weighting::None,
            &|_| true,
        )?;
        Ok(f.estimate.residual_rms)
    };
    let step = 2.0 * max / (GRID - 1) as f64;
    let mut best = (0.0, f64::INFINITY);
    for k in 0..GRID {
        let lag = -max + k as f64 * step;
        let c = cost(lag)?;
        if c < best.1 {
            best = (lag, c);
        }
    }
    // Golden section on [best - step, best + step].
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (best.0 - step, best.0 + step);
    let mut x1 = b - ratio * (b - a);
    let mut x2 = a + ratio * (b - a);
    let (mut f1, mut f2) = (cost(x1)?, cost(x2)?);
    for _ in 0..REFINE {
        if f1 < f2 {
            b = x2;
            (x2, f2) = (x1, f1);
            x1 = b - ratio * (b - a);
            f1 = cost(x1)?;
        } else {
            a = x1;
            (x1, f1) = (x2, f2);
            x2 = a + ratio * (b - a);
            f2 = cost(x2)?;
        }
    }
    let (lag, c) = if f1 < f2 { (x1, f1) } else { (x2, f2) };
    Ok(if c < best.1 { lag } else { best.0 })
}
