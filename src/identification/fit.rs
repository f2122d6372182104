//! Power-model fitting on pooled logs, with what a user knows and nothing else: the fitted
//! states, the measured power of a stated [`PowerSignal`](crate::measurement::PowerSignal), and the known payload timeline.
//!
//! The model (paper eqs. 9–13 with PMSM losses) is, per sample,
//! `P = sum_i [dq_i tau_i + c_i tau_i^2] + P0` with `tau = W_base (theta + delta(t))`, where
//! `delta(t)` is the base-parameter change of the payload known to be at the flange then (so
//! data recorded with tools and loads identify the bare robot). A DC-bus or grid signal
//! cannot go negative (braking energy is burnt in the brake resistor), so the model of such a
//! signal is `max(P, 0)`. Estimators:
//! - [`Estimator::Total`]: `c = 0`, linear least squares (clipped samples left out);
//! - [`Estimator::Pmsm`]: copper loss too, Levenberg–Marquardt from the linear solution.
//!
//! [`select`] chooses between them by K-fold cross-validation on contiguous time blocks of
//! the identification logs (never against a twin's truth) and measures the model-structure
//! error that the parameter covariance does not explain, which widens the prediction
//! intervals ([`crate::identification::model::PowerModel::predict`]).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::dynamics::Workspace;
use crate::dynamics::regressor::regressor;
use crate::error::{Error, Result};
use crate::identification::data::Prepared;
use crate::identification::lsq::{Estimate, solve};
use crate::identification::model::PowerModel;
use crate::model::Robot;

/// Iteration limit of Levenberg–Marquardt.
const MAX_ITERATIONS: usize = 100;

/// Measured power (W) at or below which a sample of a clipped signal (DC bus, grid) may be
/// clipped, so the linear estimator leaves it out.
const CLIPPED_BELOW_W: f64 = 2.0;

/// The estimators [`select`] compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Estimator {
    /// Base parameters and a constant from total power, linear (no copper loss).
    Total,
    /// Base parameters, copper-loss coefficients and a constant, nonlinear.
    Pmsm,
}

impl Estimator {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Total => "total",
            Estimator::Pmsm => "pmsm",
        }
    }
}

/// Pooled identification samples: regressor rows, speeds, known payload torques and the
/// measured power, with the cross-validation block of each.
pub struct Samples {
    n: usize,
    nb: usize,
    /// Base regressor rows per sample, `n x nb`.
    wb: Vec<DMatrix<f64>>,
    /// Joint speeds per sample, rad/s.
    dq: Vec<Vec<f64>>,
    /// Torque of the known payload per sample, N m (zero without payload).
    tau_known: Vec<Vec<f64>>,
    /// Measured power, W.
    y: Vec<f64>,
    /// Whether the sample is used for fitting (every excited joint moves fast enough).
    fit: Vec<bool>,
    /// Cross-validation piece: `(log index, block)`.
    piece: Vec<(usize, usize)>,
    /// Cross-validation fold of each sample.
    fold: Vec<usize>,
    /// Number of folds.
    folds: usize,
    /// The signal cannot go negative.
    clipped: bool,
}

impl Samples {
    /// Build the samples of `logs` for `model`'s base parameters. Samples at which an
    /// excited joint moves slower than `min_speed` (rad/s) are kept for cross-validated
    /// energies but not fitted on, unless every joint's velocity and acceleration is exactly
    /// zero (a rest held still by the route). Each log is cut into `folds` contiguous time
    /// blocks (the energy pieces); with three logs or more, each fold holds out a whole log (a
    /// motion, centre and payload the fit did not see, as a prediction meets), else one block
    /// of every log.
    ///
    /// Errors: logs of different power signals, a model of another robot, a payload that is
    /// not physical.
    pub fn new(
        robot: &Robot,
        model: &PowerModel,
        logs: &[Prepared],
        min_speed: f64,
        folds: usize,
    ) -> Result<Samples> {
        model.check_robot(robot)?;
        let first = logs
            .first()
            .ok_or_else(|| Error::InvalidInput("no logs to identify from".into()))?;
        if logs
            .iter()
            .any(|p| p.signal.clipped() != first.signal.clipped())
        {
            return Err(Error::InvalidInput(
                "the logs mix power signals that can and cannot go negative (total vs bus/grid)"
                    .into(),
            ));
        }
        let n = robot.dof();
        let nb = model.columns.len();
        let needs_base = logs
            .iter()
            .any(|p| p.payloads.iter().any(|e| e.payload.is_some()));
        let base = needs_base.then(|| model.base_params(robot)).transpose()?;
        let mut s = Samples {
            n,
            nb,
            wb: Vec::new(),
            dq: Vec::new(),
            tau_known: Vec::new(),
            y: Vec::new(),
            fit: Vec::new(),
            piece: Vec::new(),
            fold: Vec::new(),
            folds: if logs.len() >= 3 {
                logs.len()
            } else {
                folds.max(2)
            },
            clipped: first.signal.clipped(),
        };
        let mut ws = Workspace::new(robot);
        let mut w = DMatrix::zeros(n, model.layout.len());
        let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for (l, p) in logs.iter().enumerate() {
            if p.p_total.len() != p.states.len() {
                return Err(Error::InvalidInput(format!(
                    "log {}: {} power samples for {} states",
                    l + 1,
                    p.p_total.len(),
                    p.states.len()
                )));
            }
            // Base-parameter change of each known payload (model units, not scaled).
            let deltas: Vec<(f64, Option<Vec<f64>>)> = p
                .payloads
                .iter()
                .map(|e| {
                    let d = match (&e.payload, &base) {
                        (Some(pl), Some(b)) => Some(model.payload_delta(b, robot, pl)?),
                        _ => None,
                    };
                    Ok((e.t_s, d))
                })
                .collect::<Result<_>>()?;
            let len = p.states.len();
            let moving = p.states.moving(&p.excited, min_speed);
            let mut fit = vec![false; len];
            for m in moving {
                fit[m] = true;
            }
            // A robot held exactly still (the spline route's rests) has no Coulomb sign to
            // doubt: its power is the standby plus the copper loss of holding the pose, which
            // pins the constant.
            for (m, f) in fit.iter_mut().enumerate() {
                *f |= p.states.dq.iter().all(|v| v[m] == 0.0)
                    && p.states.ddq.iter().all(|a| a[m] == 0.0);
            }
            for (m, &fit_m) in fit.iter().enumerate() {
                p.states.at(m, &mut q, &mut dq, &mut ddq);
                regressor(robot, &mut ws, &model.layout, &q, &dq, &ddq, &mut w);
                let wb = DMatrix::from_fn(n, nb, |i, k| w[(i, model.columns[k])]);
                let t = p.states.t[m];
                let active = deltas.iter().rev().find(|(from, _)| *from <= t);
                let tau_known = match active {
                    Some((_, Some(d))) => (&wb * DVector::from_column_slice(d)).as_slice().to_vec(),
                    _ => vec![0.0; n],
                };
                s.wb.push(wb);
                s.dq.push(dq.clone());
                s.tau_known.push(tau_known);
                s.y.push(p.p_total[m]);
                s.fit.push(fit_m);
                let block = (m * folds.max(1)) / len;
                s.piece.push((l, block));
                s.fold.push(if logs.len() >= 3 { l } else { block });
            }
        }
        Ok(s)
    }

    /// Samples of pooled `states` (any order) with their total power `p` (W, a signal that
    /// can go negative), no payload, all fitted on, in one fold: for estimators that pool
    /// already-selected samples.
    pub fn from_states(
        robot: &Robot,
        model: &PowerModel,
        states: &crate::identification::states::States,
        p: &[f64],
    ) -> Result<Samples> {
        model.check_robot(robot)?;
        if p.len() != states.len() {
            return Err(Error::InvalidInput(format!(
                "{} power samples for {} states",
                p.len(),
                states.len()
            )));
        }
        let n = robot.dof();
        let nb = model.columns.len();
        let mut ws = Workspace::new(robot);
        let mut w = DMatrix::zeros(n, model.layout.len());
        let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut wbs = Vec::with_capacity(states.len());
        let mut dqs = Vec::with_capacity(states.len());
        for m in 0..states.len() {
            states.at(m, &mut q, &mut dq, &mut ddq);
            regressor(robot, &mut ws, &model.layout, &q, &dq, &ddq, &mut w);
            wbs.push(DMatrix::from_fn(n, nb, |i, k| w[(i, model.columns[k])]));
            dqs.push(dq.clone());
        }
        let len = states.len();
        Ok(Samples {
            n,
            nb,
            wb: wbs,
            dq: dqs,
            tau_known: vec![vec![0.0; n]; len],
            y: p.to_vec(),
            fit: vec![true; len],
            piece: vec![(0, 0); len],
            fold: vec![0; len],
            folds: 1,
            clipped: false,
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    /// Number of parameters `z = [theta, c_1..c_n, P0]`.
    fn params(&self) -> usize {
        self.nb + self.n + 1
    }

    /// Predicted power (W, clipped when the signal is) of sample `m` with parameters `z`,
    /// and optionally its gradient with respect to `z`.
    fn power(&self, m: usize, z: &DVector<f64>, grad: Option<&mut [f64]>) -> f64 {
        let (n, nb) = (self.n, self.nb);
        let theta = z.rows(0, nb);
        let wb = &self.wb[m];
        let tau = wb * theta + DVector::from_column_slice(&self.tau_known[m]);
        let v = &self.dq[m];
        let mut p = z[nb + n];
        for i in 0..n {
            p += v[i] * tau[i] + z[nb + i] * tau[i] * tau[i];
        }
        let off = self.clipped && p < 0.0;
        if let Some(g) = grad {
            if off {
                g.fill(0.0);
            } else {
                for (k, gk) in g.iter_mut().enumerate().take(nb) {
                    *gk = (0..n)
                        .map(|i| (v[i] + 2.0 * z[nb + i] * tau[i]) * wb[(i, k)])
                        .sum();
                }
                for i in 0..n {
                    g[nb + i] = tau[i] * tau[i];
                }
                g[nb + n] = 1.0;
            }
        }
        if off { 0.0 } else { p }
    }
}

/// A fitted model with its parameter covariance.
pub struct Fit {
    /// The model (filled in).
    pub model: PowerModel,
    /// Least-squares statistics of the fit.
    pub estimate: Estimate,
    /// Covariance of `z = [theta, c_1..c_n, P0]` (zero rows and columns for parameters the
    /// estimator holds fixed).
    pub covariance: DMatrix<f64>,
}

/// Fit `estimator` on the samples for which `use_sample(m)` and the sample's fit flag hold.
/// `template` gives the robot's base-parameter set (its values are ignored).
pub fn fit(
    template: &PowerModel,
    s: &Samples,
    estimator: Estimator,
    use_sample: &dyn Fn(usize) -> bool,
) -> Result<Fit> {
    let (n, nb, np) = (s.n, s.nb, s.params());
    let rows: Vec<usize> = (0..s.len())
        .filter(|&m| s.fit[m] && use_sample(m))
        .collect();
    // Linear solution: y - dq . tau_known = (dq^T W_b) theta + P0 (clipped samples out).
    let lin: Vec<usize> = rows
        .iter()
        .copied()
        .filter(|&m| !s.clipped || s.y[m] > CLIPPED_BELOW_W)
        .collect();
    let mut a = DMatrix::zeros(lin.len(), nb + 1);
    let mut y = DVector::zeros(lin.len());
    for (r, &m) in lin.iter().enumerate() {
        let v = &s.dq[m];
        for k in 0..nb {
            a[(r, k)] = (0..n).map(|i| v[i] * s.wb[m][(i, k)]).sum();
        }
        a[(r, nb)] = 1.0;
        y[r] = s.y[m] - (0..n).map(|i| v[i] * s.tau_known[m][i]).sum::<f64>();
    }
    let names_lin: Vec<String> = template
        .names
        .iter()
        .cloned()
        .chain(["P0_W".to_string()])
        .collect();
    let est = solve(&a, &y, &names_lin)?;
    let mut z = DVector::zeros(np);
    z.rows_mut(0, nb).copy_from_slice(&est.values[..nb]);
    z[np - 1] = est.values[nb];
    let (estimate, covariance) = match estimator {
        Estimator::Total => {
            let cov_lin = covariance(&a, est.residual_rms.powi(2) * lin.len() as f64, &est)?;
            let mut cov = DMatrix::zeros(np, np);
            let map = |k: usize| if k < nb { k } else { np - 1 };
            for r in 0..=nb {
                for c in 0..=nb {
                    cov[(map(r), map(c))] = cov_lin[(r, c)];
                }
            }
            (est, cov)
        }
        Estimator::Pmsm => levenberg_marquardt(template, s, &rows, &mut z)?,
    };
    let mut model = template.clone();
    model.efficiency_scaled = false;
    model.theta.copy_from_slice(z.rows(0, nb).as_slice());
    model.copper.copy_from_slice(z.rows(nb, n).as_slice());
    model.constant.fill(0.0);
    model.constant[0] = z[np - 1];
    model.signal = if s.clipped {
        crate::measurement::PowerSignal::Bus
    } else {
        crate::measurement::PowerSignal::Total
    };
    model.covariance = covariance.as_slice().to_vec();
    Ok(Fit {
        model,
        estimate: Estimate {
            values: z.as_slice().to_vec(),
            ..estimate
        },
        covariance,
    })
}

/// `s2_total / (m - p) * (A^T A)^-1`, with `s2_total` the residual sum of squares, computed
/// with the columns scaled to unit norm.
fn covariance(a: &DMatrix<f64>, rss: f64, est: &Estimate) -> Result<DMatrix<f64>> {
    let (m, p) = a.shape();
    let norms: Vec<f64> = a.column_iter().map(|c| c.norm().max(1e-300)).collect();
    let scaled = DMatrix::from_fn(m, p, |r, c| a[(r, c)] / norms[c]);
    let svd = scaled.svd(false, true);
    let v_t = svd
        .v_t
        .ok_or_else(|| Error::InvalidInput("SVD without V".into()))?;
    let s2 = rss / (m.saturating_sub(p)).max(1) as f64;
    let mut cov = DMatrix::zeros(p, p);
    for r in 0..p {
        for c in 0..p {
            let v: f64 = (0..p)
                .map(|k| v_t[(k, r)] * v_t[(k, c)] / svd.singular_values[k].powi(2))
                .sum();
            cov[(r, c)] = s2 * v / (norms[r] * norms[c]);
        }
    }
    debug_assert_eq!(est.values.len(), p);
    Ok(cov)
}

/// Levenberg–Marquardt on the samples `rows` from `z` (the linear solution), in place.
fn levenberg_marquardt(
    template: &PowerModel,
    s: &Samples,
    rows: &[usize],
    z: &mut DVector<f64>,
) -> Result<(Estimate, DMatrix<f64>)> {
    let np = s.params();
    let eval = |z: &DVector<f64>, jac: Option<&mut DMatrix<f64>>| -> DVector<f64> {
        let mut r = DVector::zeros(rows.len());
        let mut grad = vec![0.0; np];
        let mut jac = jac;
        for (k, &m) in rows.iter().enumerate() {
            let want = jac.is_some();
            let p = s.power(m, z, want.then_some(grad.as_mut_slice()));
            r[k] = p - s.y[m];
            if let Some(j) = jac.as_deref_mut() {
                for (c, g) in grad.iter().enumerate() {
                    j[(k, c)] = *g;
                }
            }
        }
        r
    };
    let mut jac = DMatrix::zeros(rows.len(), np);
    let mut r = eval(z, Some(&mut jac));
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    for _ in 0..MAX_ITERATIONS {
        let jtj = jac.transpose() * &jac;
        let g = jac.transpose() * &r;
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
                let rel = (cost - c) / cost.max(1e-300);
                *z = trial;
                r = eval(z, Some(&mut jac));
                cost = c;
                lambda = (lambda / 10.0).max(1e-12);
                improved = rel > 1e-12;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let n = s.n;
    let names: Vec<String> = template
        .names
        .iter()
        .cloned()
        .chain((1..=n).map(|i| format!("c{i}_W_per_Nm2")))
        .chain(["P0_W".to_string()])
        .collect();
    // Statistics of the final linearisation: J z - r are its observations.
    let y = &jac * &*z - &r;
    let est = solve(&jac, &y, &names)?;
    let cov = covariance(&jac, r.norm_squared(), &est)?;
    Ok((est, cov))
}

/// One estimator's cross-validation score.
#[derive(Debug, Clone, Serialize)]
pub struct CvScore {
    /// Estimator name.
    pub estimator: Estimator,
    /// RMS over held-out pieces (one log's time block) of the mean-power error, W: the
    /// energy error per second of a motion not fitted on.
    #[serde(rename = "mean_power_rms_W")]
    pub mean_power_rms_w: f64,
    /// RMS of the held-out sample power residuals, W.
    #[serde(rename = "power_rmse_W")]
    pub power_rmse_w: f64,
    /// Held-out pieces scored.
    pub pieces: usize,
}

/// The outcome of [`select`].
pub struct Selection {
    /// Scores of every candidate, in the order given.
    pub scores: Vec<CvScore>,
    /// The candidate with the smallest mean-power error.
    pub chosen: Estimator,
    /// The chosen estimator fitted on all samples, with `structure_sigma` set.
    pub fit: Fit,
}

/// Choose among `candidates` by cross-validation over the folds of the samples (see
/// [`Samples::new`]), then fit the chosen one on all samples. The spread of the held-out mean-power errors beyond what noise and the
/// parameter covariance explain is the model's structure error (`structure_sigma_W`), used
/// for prediction intervals.
///
/// Errors: no candidates, or a fit that fails on all data.
pub fn select(template: &PowerModel, s: &Samples, candidates: &[Estimator]) -> Result<Selection> {
    if candidates.is_empty() {
        return Err(Error::InvalidInput(
            "cross-validation needs at least one estimator".into(),
        ));
    }
    let folds = s.folds;
    let mut scores = Vec::new();
    let mut excess = Vec::new();
    for &est in candidates {
        let (mut se_mean, mut se_sample, mut samples, mut pieces) = (0.0, 0.0, 0usize, 0usize);
        let mut unexplained = 0.0;
        let mut ok = true;
        for k in 0..folds {
            let Ok(f) = fit(template, s, est, &|m| s.fold[m] != k) else {
                ok = false;
                break;
            };
            let z = DVector::from_column_slice(&f.estimate.values);
            let residual_var = f.estimate.residual_rms.powi(2);
            let mut by_piece: std::collections::BTreeMap<(usize, usize), (f64, usize)> =
                Default::default();
            for m in (0..s.len()).filter(|&m| s.fold[m] == k) {
                let e = s.power(m, &z, None) - s.y[m];
                se_sample += e * e;
                samples += 1;
                let entry = by_piece.entry(s.piece[m]).or_insert((0.0, 0));
                entry.0 += e;
                entry.1 += 1;
            }
            for (sum, count) in by_piece.values() {
                let c = *count as f64;
                let mean = sum / c;
                se_mean += mean * mean;
                unexplained += mean * mean - residual_var / c;
                pieces += 1;
            }
        }
        if !ok || pieces == 0 {
            continue;
        }
        scores.push(CvScore {
            estimator: est,
            mean_power_rms_w: (se_mean / pieces as f64).sqrt(),
            power_rmse_w: (se_sample / samples.max(1) as f64).sqrt(),
            pieces,
        });
        excess.push((unexplained / pieces as f64).max(0.0).sqrt());
    }
    let Some(best) = scores
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.mean_power_rms_w.total_cmp(&b.1.mean_power_rms_w))
        .map(|(i, _)| i)
    else {
        // No candidate fits every fold: the fit on all data says why (rank deficiency names
        // the parameters the data cannot reveal), or that the folds were too small.
        fit(template, s, candidates[0], &|_| true)?;
        return Err(Error::InvalidInput(
            "no estimator could be fitted with any one run left out: record more runs or longer ones"
                .into(),
        ));
    };
    let chosen = scores[best].estimator;
    let mut f = fit(template, s, chosen, &|_| true)?;
    f.model.structure_sigma = excess[best];
    Ok(Selection {
        scores,
        chosen,
        fit: f,
    })
}

/// Settings of [`identify_logs`].
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Samples at which an excited joint moves slower than this (rad/s) are not fitted on
    /// (Coulomb sign and stiction around velocity reversals), except where the robot is held
    /// exactly still; they still count in the cross-validated energies.
    pub min_speed: f64,
    /// Contiguous time blocks each log is cut into: the energy pieces of cross-validation,
    /// and its folds when there are fewer than three logs.
    pub folds: usize,
    /// Estimators to choose from.
    pub candidates: Vec<Estimator>,
}

impl Default for FitOptions {
    /// 0.05 rad/s, 5 folds, `total` and `pmsm`.
    fn default() -> Self {
        FitOptions {
            min_speed: 0.05,
            folds: 5,
            candidates: vec![Estimator::Total, Estimator::Pmsm],
        }
    }
}

/// Identify the power model of `robot` from measured logs: states along `routes` (one for
/// all logs, or one per log), known payloads through the base relations, the estimator
/// chosen by cross-validation. Reads nothing but the logs. Errors: logs of another robot or
/// joint count, rank-deficient data (naming the parameters), too little data.
pub fn identify_logs(
    robot: &Robot,
    logs: &[crate::measurement::Log],
    routes: &[crate::identification::data::Route],
    opts: &FitOptions,
) -> Result<Selection> {
    if routes.len() != 1 && routes.len() != logs.len() {
        return Err(Error::InvalidInput(format!(
            "{} routes for {} logs: give one for all or one per log",
            routes.len(),
            logs.len()
        )));
    }
    if !(opts.min_speed.is_finite() && opts.min_speed >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "minimum speed {} rad/s must be finite and >= 0",
            opts.min_speed
        )));
    }
    for log in logs {
        if log.dof() != robot.dof() {
            return Err(Error::InvalidInput(format!(
                "{}: {} joints, robot '{}' has {}",
                log.source,
                log.dof(),
                robot.name(),
                robot.dof()
            )));
        }
        if let Some(name) = &log.robot
            && name != robot.name()
        {
            return Err(Error::InvalidInput(format!(
                "{} is a log of robot '{name}', not '{}'",
                log.source,
                robot.name()
            )));
        }
    }
    let prepared = logs
        .iter()
        .enumerate()
        .map(|(k, l)| crate::identification::data::prepare(l, routes[k.min(routes.len() - 1)]))
        .collect::<Result<Vec<_>>>()?;
    let layout = crate::dynamics::ParamLayout::new(robot, true, true);
    let template = PowerModel::new(robot, layout, false)?;
    let samples = Samples::new(robot, &template, &prepared, opts.min_speed, opts.folds)?;
    select(&template, &samples, &opts.candidates)
}
