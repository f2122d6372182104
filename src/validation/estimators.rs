//! The estimators compared on the same data: the six steps' fitted states and total power.
//!
//! * `paper-steps`: the paper's step-by-step method ([`super::steps`]).
//! * `total`: every base parameter at once from the pooled total power (linear model), without
//!   the samples near a velocity reversal ([`MIN_SPEED`]).
//! * `pmsm`: the same pooled samples with copper-loss terms, by Levenberg–Marquardt.
//!
//! Each model predicts the energy of every step's trajectory it was fitted on: an in-sample
//! comparison (a fit with a constant-power column predicts its own data's energy almost
//! whatever its parameters are). Which model to use is decided elsewhere, by
//! cross-validation ([`crate::identification::fit::select`]), never by these errors.

use serde::Serialize;

use crate::dynamics::ParamLayout;
use crate::error::{Error, Result};
use crate::identification::consistency::{Consistency, consistency};
use crate::identification::linear::{self, Observation};
use crate::identification::lsq::Estimate;
use crate::identification::model::{DATASHEET_EFFICIENCY, PowerModel};
use crate::identification::pmsm;
use crate::identification::states::States;
use crate::validation::rig::Rig;
use crate::validation::score::{ParamRow, energy_error_pct, table};
use crate::validation::steps::Steps;

/// Samples at which an excited joint moves slower than this (rad/s) are left out of the
/// all-at-once fits: around velocity reversals the Coulomb sign is uncertain and stiction
/// holds the joint. Measured on the twin: the PMSM residual falls tenfold and the copper-loss
/// coefficients of the wrist come out right.
pub const MIN_SPEED: f64 = 0.05;

/// Random poses of the consistency check.
const CONSISTENCY_POSES: usize = 200;

/// One estimator's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct EstimatorResult {
    /// Method name (`paper-steps`, `total`, `pmsm`).
    pub method: String,
    /// The identified model.
    pub model: PowerModel,
    /// Least-squares statistics (one per step for `paper-steps`).
    pub estimates: Vec<Estimate>,
    /// Predicted energy of each step's trajectory, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: Vec<f64>,
    /// Its error against the simulated energy, %.
    pub error_pct: Vec<f64>,
    /// Largest absolute error over the steps, %.
    pub max_abs_error_pct: f64,
    /// Identified against true base parameters (Table 2).
    pub parameters: Vec<ParamRow>,
    /// Physical-consistency check.
    pub consistency: Consistency,
}

/// Identify with every estimator and evaluate each on the steps' trajectories (in-sample).
/// The paper-steps model is taken from `steps`; the linear all-at-once model is the
/// paper's (scaled by 1/eta), the PMSM model is in SI units.
pub fn compare(rig: &Rig, steps: &Steps) -> Result<Vec<EstimatorResult>> {
    let robot = rig.robot;
    let mut pooled: Option<States> = None;
    let mut power = Vec::new();
    for d in &steps.data {
        let keep = d.states.moving(&d.joints, MIN_SPEED);
        let states = d.states.select(&keep);
        power.extend(keep.iter().map(|&m| d.p_total[m]));
        match &mut pooled {
            Some(p) => p.append(&states)?,
            None => pooled = Some(states),
        }
    }
    let pooled =
        pooled.ok_or_else(|| Error::InvalidInput("no step data to identify from".into()))?;
    let layout = ParamLayout::new(robot, true, true);
    let mut fits = vec![(
        "paper-steps",
        steps.model.clone(),
        steps.rows.iter().map(|r| r.estimate.clone()).collect(),
    )];
    let mut total = PowerModel::new(robot, layout, true)?;
    let est = linear::identify(robot, &mut total, &pooled, Observation::TotalPower, &power)?;
    fits.push(("total", total, vec![est]));
    let mut model = PowerModel::new(robot, layout, false)?;
    let est = pmsm::identify(robot, &mut model, &pooled, &power)?;
    fits.push(("pmsm", model, vec![est]));
    let efficiency = DATASHEET_EFFICIENCY;
    fits.into_iter()
        .map(|(method, model, estimates)| {
            let mut predicted_j = Vec::with_capacity(steps.rows.len());
            let mut error_pct = Vec::with_capacity(steps.rows.len());
            for (row, traj) in steps.rows.iter().zip(&steps.trajectories) {
                let e = model.energy(robot, traj, rig.twin.physics.dt)?;
                predicted_j.push(e);
                error_pct.push(energy_error_pct(e, row.simulated_j));
            }
            let refs: Vec<&Estimate> = estimates.iter().collect();
            let parameters = table(rig.true_robot(), rig.true_drive(), &model, &refs)?;
            let consistency = consistency(robot, &model, efficiency, CONSISTENCY_POSES, 1)?;
            Ok(EstimatorResult {
                method: method.to_string(),
                max_abs_error_pct: error_pct.iter().fold(0.0, |m: f64, e| m.max(e.abs())),
                model,
                estimates,
                predicted_j,
                error_pct,
                parameters,
                consistency,
            })
        })
        .collect()
}
