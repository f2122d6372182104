//! The paper's step-by-step identification from total power (Liu et al. 2018, Table 3).
//!
//! Step `s` uses data in which only the joints `J_s` move (the paper: step k excites joints
//! 7-k..6). Its total-power regressor has columns for every base parameter and a constant;
//! the parameters identified in earlier steps are known and move to the right-hand side.
//! Among the still unknown parameters of links `>= min J_s`, the ones this step's data can
//! determine are chosen greedily in link order (a column is kept when its distance from the
//! span of the kept ones, column-scaled, exceeds [`KEEP_TOL`]) and identified by least
//! squares, together with the constant power. Errors of early steps propagate into later
//! ones, as in the paper. Parameters no step determines stay zero: they do not act on any of
//! the recorded motions.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::identification::linear::{Observation, rows};
use crate::identification::lsq::{Estimate, solve};
use crate::identification::model::PowerModel;
use crate::identification::states::States;
use crate::model::Robot;

/// Relative pivot below which a column is not identified in a step.
pub const KEEP_TOL: f64 = 1e-3;
/// Columns smaller than this fraction of the largest candidate column are not excited.
const NEGLIGIBLE: f64 = 1e-6;

/// Hold the joints that are not in `joints` exactly still at their mean position: the paper's
/// premise for a step, and what the fitted states of a joint at rest should be.
pub fn hold_still(states: &mut States, joints: &[usize]) {
    for i in (0..states.q.len()).filter(|i| !joints.contains(i)) {
        let mean = states.q[i].iter().sum::<f64>() / states.q[i].len().max(1) as f64;
        states.q[i].fill(mean);
        states.dq[i].fill(0.0);
        states.ddq[i].fill(0.0);
    }
}

/// The data of one step.
#[derive(Debug, Clone)]
pub struct StepData {
    /// Joints that move in this step (0-based).
    pub joints: Vec<usize>,
    /// States at the power samples.
    pub states: States,
    /// Total motor power, W.
    pub p_total: Vec<f64>,
}

/// What one step identified.
#[derive(Debug, Clone, Serialize)]
pub struct StepResult {
    /// 1-based step number.
    pub step: usize,
    /// Excited joints, 1-based.
    pub joints: Vec<usize>,
    /// The estimate of this step's parameters (and `P0_W`).
    pub estimate: Estimate,
}

/// Identify `model` (filled in place) step by step.
pub fn identify(
    robot: &Robot,
    model: &mut PowerModel,
    steps: &[StepData],
) -> Result<Vec<StepResult>> {
    model.check_robot(robot)?;
    let nb = model.columns.len();
    let per_link = model.layout.per_link();
    let mut known = vec![false; nb];
    model.theta.fill(0.0);
    model.copper.fill(0.0);
    model.constant.fill(0.0);
    let mut results = Vec::with_capacity(steps.len());
    for (s, data) in steps.iter().enumerate() {
        if data.p_total.len() != data.states.len() {
            return Err(Error::InvalidInput(format!(
                "step {}: power and states differ in length",
                s + 1
            )));
        }
        let first = *data
            .joints
            .iter()
            .min()
            .ok_or_else(|| Error::InvalidInput(format!("step {} excites no joint", s + 1)))?;
        let (a, _) = rows(robot, model, &data.states, Observation::TotalPower);
        // Right-hand side without the known parameters.
        let mut y = DVector::from_column_slice(&data.p_total);
        for k in (0..nb).filter(|&k| known[k]) {
            y -= a.column(k) * model.theta[k];
        }
        let candidates: Vec<usize> = (0..nb)
            .filter(|&k| !known[k] && model.columns[k] / per_link >= first)
            .collect();
        let largest = candidates
            .iter()
            .map(|&k| a.column(k).norm())
            .fold(0.0, f64::max);
        let mut scaled = DMatrix::zeros(a.nrows(), candidates.len());
        for (j, &k) in candidates.iter().enumerate() {
            let norm = a.column(k).norm();
            if norm > NEGLIGIBLE * largest {
                scaled.set_column(j, &(a.column(k) / norm));
            }
        }
        let r = scaled.qr().unpack_r();
        let chosen: Vec<usize> = candidates
            .iter()
            .enumerate()
            .filter(|(j, _)| *j < r.nrows() && r[(*j, *j)].abs() > KEEP_TOL)
            .map(|(_, &k)| k)
            .collect();
        let mut sub = DMatrix::zeros(a.nrows(), chosen.len() + 1);
        for (j, &k) in chosen.iter().enumerate() {
            sub.set_column(j, &a.column(k));
        }
        sub.column_mut(chosen.len()).fill(1.0);
        let names: Vec<String> = chosen
            .iter()
            .map(|&k| model.names[k].clone())
            .chain(["P0_W".to_string()])
            .collect();
        let est = solve(&sub, &y, &names)
            .map_err(|e| Error::InvalidInput(format!("step {}: {e}", s + 1)))?;
        for (j, &k) in chosen.iter().enumerate() {
            model.theta[k] = est.values[j];
            known[k] = true;
        }
        model.constant[0] = est.values[chosen.len()];
        results.push(StepResult {
            step: s + 1,
            joints: data.joints.iter().map(|j| j + 1).collect(),
            estimate: est,
        });
    }
    Ok(results)
}
