//! A measured log priced by an identified model, as `powertwin predict --log` prices it: the
//! log's motion priced as a plan is ([`crate::identification::plan::price`]: same step, same
//! clipping of the power), against the energy and power the log measured. Needs no truth, so
//! it scores a model on a user's own logs.

use crate::error::Result;
use crate::identification::data::{Prepared, Route, power_sample_nodes, power_times, prepare};
use crate::identification::energy::window_energies;
use crate::identification::model::{DATASHEET_EFFICIENCY, PowerModel, Prediction};
use crate::identification::plan::price;
use crate::measurement::Log;
use crate::model::Robot;

/// A log's prediction against its measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct LogPrice {
    /// Where the log came from.
    pub source: String,
    /// Predicted energy of the modelled signal with its 95 % interval, J.
    pub prediction: Prediction,
    /// Energy of the measured signal over the log (trapezoids between samples), J.
    pub measured_j: f64,
    /// Times the logged power belongs to, s (log clock; for a logger that averages power,
    /// the middle of each sample period).
    pub t_s: Vec<f64>,
    /// Measured power at those times, W.
    pub measured_w: Vec<f64>,
    /// Predicted power of the measured signal at those times, W, as the meter reads it: for
    /// a logger that averages power, the mean over each sample period; never below the floor
    /// of a bus or grid signal ([`crate::identification::model::PowerModel::reading`]).
    pub predicted_w: Vec<f64>,
}

impl LogPrice {
    /// RMS of predicted minus measured power, W.
    pub fn rmse_w(&self) -> f64 {
        let se: f64 = self
            .predicted_w
            .iter()
            .zip(&self.measured_w)
            .map(|(p, y)| (p - y).powi(2))
            .sum();
        (se / self.measured_w.len().max(1) as f64).sqrt()
    }

    /// Predicted minus measured energy, % of the measured.
    pub fn error_pct(&self) -> f64 {
        100.0 * (self.prediction.energy_j - self.measured_j) / self.measured_j
    }
}

/// Price a user's `log` with `model` on `robot`, as `powertwin predict --log` does: errors
/// unless the log is of `robot` ([`Log::check_robot`]: joint count, positions it can reach,
/// power it can draw), then prepares it along `route` and prices it ([`price_log`]). Returns
/// the prepared log too (for plots of the model along it).
pub fn price_measured(
    model: &PowerModel,
    robot: &Robot,
    log: &Log,
    route: Route,
) -> Result<(Prepared, LogPrice)> {
    log.check_robot(robot)?;
    let p = prepare(log, route)?;
    let price = price_log(model, robot, &p, &log.source)?;
    Ok((p, price))
}

/// Price the prepared log `p` (named `source`) with `model` on `robot`, the known payloads of
/// the log included (added to an efficiency-scaled model at [`DATASHEET_EFFICIENCY`]).
/// Errors: a model of another robot, a payload that cannot be attached.
pub fn price_log(
    model: &PowerModel,
    robot: &Robot,
    p: &Prepared,
    source: &str,
) -> Result<LogPrice> {
    let measured_j: f64 = window_energies(&p.states.t, &p.p_total, p.power_averaged)
        .iter()
        .sum();
    let t_s = power_times(&p.states.t, p.power_averaged);
    // The logged power belongs to the motion `power_lag_s` earlier (0 for most models), at
    // each sample's time or averaged over its period.
    let (nodes, per_sample) = power_sample_nodes(&p.states.t, p.power_averaged);
    let t: Vec<f64> = nodes
        .iter()
        .map(|t| t - p.motion_t0_s - model.power_lag_s)
        .collect();
    let priced = price(
        model,
        robot,
        p.motion.as_ref(),
        &p.motion_events(),
        DATASHEET_EFFICIENCY,
        &t,
    )?;
    let predicted_w = priced
        .power_w
        .chunks(per_sample)
        .map(|c| c.iter().sum::<f64>() / per_sample as f64)
        .collect();
    Ok(LogPrice {
        source: source.to_string(),
        prediction: priced.prediction,
        measured_j,
        t_s,
        measured_w: p.p_total.clone(),
        predicted_w,
    })
}
