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
//! arm's power only, every copper coefficient free) fitted on the pooled samples; the lag
//! with the least residual wins: a walk down a grid of [`GRID`] points over `+-max` on every
//! sample, from lag 0 to the grid's least residual, then at most [`REFINE`] vertices of the
//! parabola through the best so far and its neighbours, on the samples that move
//! ([`find_lag`]; each trial lag fitted once, a grid point's neighbours and the bracket side
//! by side). The linear estimator without copper loss would not do:
//! with loads its residual is dominated by the copper loss it lacks and the lag it finds is a
//! third of the true one (docs/experiments.md#power-lag-in-the-fit).

use super::estimate::fit_free_from;
use super::samples::{Samples, fitted};
use super::{Estimator, FitOptions, Weighting};
use crate::error::Result;
use crate::identification::data::{Prepared, Route, prepare_lagged};
use crate::identification::model::PowerModel;
use crate::measurement::Log;
use crate::model::Robot;

/// Trial lags of the coarse grid (odd, so 0 is one of them).
const GRID: usize = 7;

/// Most steps of successive parabolic interpolation after the coarse grid.
const REFINE: usize = 6;

/// The refinement stops when its next lag is this close (s) to the best so far: a tenth of
/// the twin's 1 ms physics step; slow held-out moves are sensitive to a millisecond
/// (docs/experiments.md#the-lag-search-and-velocity-reversals).
const LAG_TOLERANCE_S: f64 = 1e-4;

/// The 99 % point of chi-square with one degree of freedom: the evidence a lag needs.
const LAG_EVIDENCE: f64 = 6.63;

/// The lag (s) of the logged power behind the joints in `logs` that the PMSM power model
/// fits best, searched within `+-opts.max_power_lag_s`; 0 when the search is off, when the
/// logs do not fit at all, or when the data cannot tell the lag from none.
///
/// The coarse grid fits every sample at the trial lags its downhill walk from lag 0 reaches
/// (`Trials::downhill`). The refinement and the evidence fit
/// every trial lag on the same samples: those at which every excited joint moves at
/// `opts.min_speed` or faster in the states at the grid's best lag (every sample again where
/// those do not bracket a least residual). Around a velocity reversal the model's Coulomb
/// sign flips where the route's velocity crosses zero, while the arm sticks or slips there;
/// that misfit shifts with the trial lag and pulls the least residual off the true lag
/// (docs/experiments.md#the-lag-search-and-velocity-reversals). A speed threshold taken at
/// each trial lag instead would fit other samples at each and make the residual jump between
/// them. The coarse grid keeps every sample: a short, slow log leaves too few moving samples
/// for a grid whose fits can be compared.
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
    let mut trials = Trials {
        robot,
        template,
        logs,
        routes,
        opts,
        keep: None,
        tried: Vec::new(),
        rows: 0,
        with_prior: false,
    };
    // Logs too short or too poor for a fit of their own (with the prior, if any) leave the
    // lag at zero; the identification proper then says what they lack.
    if trials.cost(0.0).is_err() {
        return Ok(0.0);
    }
    let step = 2.0 * max / (GRID - 1) as f64;
    let grid: Vec<f64> = (0..GRID).map(|k| -max + k as f64 * step).collect();
    let k = trials.downhill(&grid)?;
    // A least cost on the range's edge brackets no minimum: the residual falls on past the
    // range (a lag beyond it) or is flat and its least value the fits' scatter (a slow,
    // averaged log whose power hardly depends on the lag). Either way no lag in the range
    // is told from the others: none is kept.
    if k == 0 || k == GRID - 1 {
        return Ok(0.0);
    }
    // A least cost at lag 0 itself keeps none, without the evidence's fits.
    let Some(lag) = trials.refine_around(k, &grid)?.filter(|&l| l != 0.0) else {
        return Ok(0.0);
    };
    // Keep the lag only where the data tell it from none: the likelihood ratio of the fits
    // at that lag and at zero, `N ln(RSS_0 / RSS_L)`, above the 99 % point of chi-square
    // with one degree of freedom. A gentle motion's power hardly depends on the lag; its
    // residual is flat and the least of it noise.
    let (none, at_lag) = trials.on_one_branch(0.0, lag)?;
    let ratio = trials.rows as f64 * 2.0 * (none / at_lag).ln();
    Ok(if ratio > LAG_EVIDENCE { lag } else { 0.0 })
}

/// The fits of trial lags on one set of samples, each lag fitted once.
struct Trials<'a> {
    robot: &'a Robot,
    template: &'a PowerModel,
    logs: &'a [Log],
    routes: &'a [Route],
    opts: &'a FitOptions,
    /// Observations fitted on (the logs' samples one after another); `None`: all of them.
    keep: Option<Vec<bool>>,
    /// The lags fitted on `keep` from the linear solution, in order, and their fits.
    tried: Vec<(f64, Fitted)>,
    /// Observations the last fit used.
    rows: usize,
    /// Whether the fits add the prior: decided at the first fit on `keep`, since the
    /// regressor's rank does not depend on the lag.
    with_prior: bool,
}

/// What [`Trials::fit`] found at one lag.
struct Fitted {
    /// Residual RMS of the arm's power, W.
    cost: f64,
    /// Observations fitted on.
    rows: usize,
    /// Whether the fit took the prior.
    with_prior: bool,
    /// The fit's values (empty where it could not fit): a start on its branch for another
    /// lag's fit.
    values: Vec<f64>,
}

impl Trials<'_> {
    /// The logs prepared with the states `lag` s earlier than the power.
    fn prepare(&self, lag: f64) -> Result<Vec<Prepared>> {
        self.logs
            .iter()
            .enumerate()
            .map(|(k, l)| prepare_lagged(l, self.routes[k.min(self.routes.len() - 1)], lag))
            .collect()
    }

    /// Fit every trial lag from now on on the samples that move at lag `lag`.
    fn refer_to(&mut self, lag: f64) -> Result<()> {
        self.keep = Some(
            self.prepare(lag)?
                .iter()
                .flat_map(|p| fitted(p, self.opts.min_speed, 0.0))
                .collect(),
        );
        self.tried.clear();
        self.rows = 0;
        self.with_prior = false;
        Ok(())
    }

    /// The least-cost lag between the grid's neighbours of its best point `grid[k]`, refined
    /// on the samples that move at `grid[k]`. Where those fail to fit, or no longer bracket
    /// a least residual, on every sample as the grid was: a gentle unloaded motion's power is
    /// mostly friction, whose lag shows at the reversals. `None`: no bracket either way.
    fn refine_around(&mut self, k: usize, grid: &[f64]) -> Result<Option<f64>> {
        let bracket = [grid[k - 1], grid[k], grid[k + 1]];
        let every = (std::mem::take(&mut self.tried), self.rows, self.with_prior);
        if self.refer_to(grid[k]).is_ok()
            && self.costs(&bracket).is_ok()
            && let Ok(Some(lag)) = refine(bracket, &mut |l| self.cost(l))
        {
            return Ok(Some(lag));
        }
        self.keep = None;
        (self.tried, self.rows, self.with_prior) = every;
        refine(bracket, &mut |l| self.cost(l))
    }

    /// The grid point of a least cost, found by walking downhill from the middle (lag 0)
    /// to the lower neighbour until neither neighbour is lower; each point's neighbours
    /// fitted side by side. Where the cost over the grid has one minimum (a lag the data
    /// show) that is the grid's least cost, without fitting the far lags, whose fits are
    /// the slowest (a misfit that large converges in tens of iterations).
    fn downhill(&mut self, grid: &[f64]) -> Result<usize> {
        let mut k = grid.len() / 2;
        loop {
            let around = &grid[k.saturating_sub(1)..(k + 2).min(grid.len())];
            let costs = self.costs(around)?;
            let here = self.cost(grid[k])?;
            let lower = (0..around.len())
                .filter(|&i| costs[i] < here)
                .min_by(|&a, &b| costs[a].total_cmp(&costs[b]));
            match lower {
                Some(i) => k = k + i - usize::from(k > 0),
                None => return Ok(k),
            }
        }
    }

    /// Residual RMS (W) of the PMSM fit at `lag` (s).
    fn cost(&mut self, lag: f64) -> Result<f64> {
        if let Some((_, f)) = self.tried.iter().find(|(l, _)| *l == lag) {
            return Ok(f.cost);
        }
        let fitted = self.fit(lag, None)?;
        Ok(self.record(lag, fitted))
    }

    /// The costs at lags `a` and `b` on one branch of the fit's least cost each: each lag
    /// fitted again from the other's solution, the lesser of its two costs kept. The PMSM
    /// fit is not convex (the copper coefficients' bound, parameters the logs barely see), and
    /// fits of the same samples a millisecond apart can land from the linear solution on
    /// branches whose costs differ by more than the lag explains: the cost jumps between them
    /// (docs/experiments.md#a-spurious-power-lag). Compared across a jump, a lag the data do
    /// not show passes for evidence.
    fn on_one_branch(&mut self, a: f64, b: f64) -> Result<(f64, f64)> {
        let (ca, cb) = (self.cost(a)?, self.cost(b)?);
        let values = |l: f64| {
            self.tried
                .iter()
                .find(|(k, f)| *k == l && !f.values.is_empty())
                .map(|(_, f)| f.values.as_slice())
        };
        let (va, vb) = (values(a), values(b));
        let (a_from_b, b_from_a) = rayon::join(|| self.fit(a, vb), || self.fit(b, va));
        // A start the fit cannot continue from leaves the cost from the linear solution.
        let least = |c: f64, other: Result<Fitted>| other.map_or(c, |f| c.min(f.cost));
        Ok((least(ca, a_from_b), least(cb, b_from_a)))
    }

    /// [`Trials::cost`] of each of `lags`, in order. The first lag not yet fitted is fitted
    /// first (it decides whether the fits need the prior, as in a sequential search), the
    /// others side by side; each is recorded in order, so the search is the sequential one.
    fn costs(&mut self, lags: &[f64]) -> Result<Vec<f64>> {
        use rayon::prelude::*;
        let untried = |t: &Trials, l: &f64| !t.tried.iter().any(|(k, _)| k == l);
        if let Some(&first) = lags.iter().find(|l| untried(self, l)) {
            self.cost(first)?;
        }
        let rest: Vec<f64> = lags.iter().copied().filter(|l| untried(self, l)).collect();
        let this = &*self;
        let fits = rest
            .par_iter()
            .map(|&l| this.fit(l, None))
            .collect::<Result<Vec<_>>>()?;
        for (l, fitted) in rest.into_iter().zip(fits) {
            self.record(l, fitted);
        }
        lags.iter().map(|&l| self.cost(l)).collect()
    }

    /// Record the fit of `lag` ([`Trials::fit`]); returns its cost.
    fn record(&mut self, lag: f64, fitted: Fitted) -> f64 {
        self.rows = fitted.rows;
        self.with_prior = fitted.with_prior;
        let cost = fitted.cost;
        self.tried.push((lag, fitted));
        cost
    }

    /// The PMSM fit at `lag` from `start` (`None`: the linear solution): its residual RMS (W),
    /// the observations it used, whether it took the prior (the first fit on `keep` takes it
    /// only where the logs cannot be fitted without it; the later fits follow that first
    /// one), and its values.
    fn fit(&self, lag: f64, start: Option<&[f64]>) -> Result<Fitted> {
        let prepared = self.prepare(lag)?;
        let mut samples = Samples::new(
            self.robot,
            self.template,
            &prepared,
            0.0,
            self.opts.max_fit_rate_hz,
            self.opts.folds,
            false,
        )?;
        if let Some(keep) = &self.keep {
            samples.keep_only(keep)?;
        }
        let rows = (0..samples.len()).filter(|&m| samples.fit[m]).count();
        let fitted = |samples: &Samples, with_prior: bool| -> Result<Fitted> {
            let f = fit_free_from(
                self.template,
                samples,
                Estimator::Pmsm,
                Weighting::None,
                start,
            )?;
            Ok(Fitted {
                cost: f.estimate.residual_rms,
                rows,
                with_prior,
                values: f.estimate.values,
            })
        };
        // The prior only where the logs cannot be fitted without it: a prior centred on
        // files that are wrong (a copper coefficient off by half) tilts every trial lag's
        // residual, and the least of them moves (a third of a sample period on the family of
        // truths, docs/experiments.md#the-drive-files-copper-as-a-prior).
        if !self.with_prior {
            match (fitted(&samples, false), &self.opts.prior) {
                (Ok(f), _) => return Ok(f),
                (Err(_), Some(_)) if self.rows == 0 => {}
                (Err(e), _) => return Err(e),
            }
        }
        // Here only with a prior: already taken, or needed by the first fit.
        match &self.opts.prior {
            Some(prior) => fitted(&samples.with_prior(prior.clone())?, true),
            None => Ok(Fitted {
                cost: f64::INFINITY,
                rows,
                with_prior: true,
                values: Vec::new(),
            }),
        }
    }
}

/// The least-cost lag inside `bracket` (`a < b < c`; `None` unless the cost at `b` is no more
/// than at `a` and `c`): successive parabolic interpolation on the mean square residual,
/// which is quadratic in the lag near its least value (the residual is linear in a small
/// change of lag; its root mean square is V-shaped, and parabolas through it stop short). At
/// most [`REFINE`] steps; it stops when the vertex moves less than [`LAG_TOLERANCE_S`].
fn refine(bracket: [f64; 3], cost: &mut dyn FnMut(f64) -> Result<f64>) -> Result<Option<f64>> {
    let mut br = [
        (bracket[0], cost(bracket[0])?),
        (bracket[1], cost(bracket[1])?),
        (bracket[2], cost(bracket[2])?),
    ];
    if !(br[1].1 <= br[0].1 && br[1].1 <= br[2].1) {
        return Ok(None);
    }
    for _ in 0..REFINE {
        let [(a, fa), (b, fb), (c, fc)] = br;
        let (sa, sb, sc) = (fa * fa, fb * fb, fc * fc);
        let den = (b - a) * (sb - sc) - (b - c) * (sb - sa);
        let num = (b - a).powi(2) * (sb - sc) - (b - c).powi(2) * (sb - sa);
        let vertex = b - 0.5 * num / den;
        // A vertex outside the bracket (a flat or degenerate parabola): the larger half's
        // middle instead.
        let x = if vertex > a && vertex < c {
            vertex
        } else if b - a > c - b {
            0.5 * (a + b)
        } else {
            0.5 * (b + c)
        };
        if (x - b).abs() < LAG_TOLERANCE_S {
            break;
        }
        let fx = cost(x)?;
        br = match (x < b, fx <= fb) {
            (true, true) => [(a, fa), (x, fx), (b, fb)],
            (true, false) => [(x, fx), (b, fb), (c, fc)],
            (false, true) => [(b, fb), (x, fx), (c, fc)],
            (false, false) => [(a, fa), (b, fb), (x, fx)],
        };
    }
    Ok(Some(br[1].0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A residual whose mean square is quadratic in the lag (its root is not): the refinement
    /// lands on the least value from a coarse bracket, in few fits.
    #[test]
    fn refinement_finds_the_least_mean_square() {
        for truth in [0.0, 0.0123, 0.03, -0.021] {
            let mut fits = 0;
            let mut cost = |l: f64| -> Result<f64> {
                fits += 1;
                Ok((1.0 + 4.0e4 * (l - truth).powi(2)).sqrt())
            };
            let grid = 0.1 / 3.0;
            let b = (truth / grid).round() * grid;
            let lag = refine([b - grid, b, b + grid], &mut cost).unwrap().unwrap();
            assert!((lag - truth).abs() < LAG_TOLERANCE_S, "{truth}: {lag}");
            assert!(fits <= 5, "{truth}: {fits} fits");
        }
    }

    /// A middle point that is not the least of the three brackets nothing.
    #[test]
    fn a_bracket_without_a_least_middle_is_refused() {
        let mut cost = |l: f64| -> Result<f64> { Ok(1.0 + l) };
        assert_eq!(refine([-0.1, 0.0, 0.1], &mut cost).unwrap(), None);
    }
}
