//! Re-identify the last link with a payload (the paper's Table 4: "tool and load are treated as
//! part of link 6, which is identified again").
//!
//! A payload changes only the last link's ten standard inertial parameters. In base-parameter
//! form these appear in every base parameter whose regrouping relation involves one of them
//! (for the IRB 1200 also parameters named after links 4 and 5, into which `M6` and `MZ6`
//! regroup). Those base parameters and the constant power are estimated by least squares from
//! total power; all other parameters keep the model's values.

use nalgebra::DVector;

use crate::error::{Error, Result};
use crate::identification::linear::{Observation, rows};
use crate::identification::lsq::{Estimate, solve};
use crate::identification::model::PowerModel;
use crate::identification::states::States;
use crate::model::Robot;
use crate::model::inertia::STANDARD_NAMES;

/// Indices (into `model.theta`) of the base parameters that carry the last link's standard
/// inertial parameters.
pub fn affected(robot: &Robot, model: &PowerModel) -> Result<Vec<usize>> {
    let base = model.base_params(robot)?;
    let last: Vec<String> = STANDARD_NAMES
        .iter()
        .map(|s| format!("{s}{}", robot.dof()))
        .collect();
    Ok(base
        .relations()
        .iter()
        .enumerate()
        .filter(|(_, r)| {
            last.contains(&r.standard) || r.terms.iter().any(|(name, _)| last.contains(name))
        })
        .map(|(k, _)| k)
        .collect())
}

/// A copy of `model` whose last-link base parameters ([`affected`]) and constant power are
/// identified again from total power `p` (W) at the samples of `states`, with the payload on.
/// Only for linear power models (no copper-loss terms).
pub fn reidentify(
    robot: &Robot,
    model: &PowerModel,
    states: &States,
    p: &[f64],
) -> Result<(PowerModel, Estimate)> {
    model.check_robot(robot)?;
    if model.copper.iter().any(|c| *c != 0.0) {
        return Err(Error::InvalidInput(
            "re-identifying the last link needs a linear power model (no copper-loss terms)".into(),
        ));
    }
    if p.len() != states.len() {
        return Err(Error::InvalidInput(format!(
            "{} power samples for {} states",
            p.len(),
            states.len()
        )));
    }
    let unknown = affected(robot, model)?;
    let (a, _) = rows(robot, model, states, Observation::TotalPower);
    let nb = model.columns.len();
    let mut y = DVector::from_column_slice(p);
    for k in (0..nb).filter(|k| !unknown.contains(k)) {
        y -= a.column(k) * model.theta[k];
    }
    let columns: Vec<usize> = unknown.iter().copied().chain([nb]).collect();
    let names: Vec<String> = unknown
        .iter()
        .map(|&k| model.names[k].clone())
        .chain(["P0_W".to_string()])
        .collect();
    let est = solve(&a.select_columns(columns.iter()), &y, &names)?;
    let mut out = model.clone();
    for (j, &k) in unknown.iter().enumerate() {
        out.theta[k] = est.values[j];
    }
    out.constant.fill(0.0);
    out.constant[0] = est.values[unknown.len()];
    Ok((out, est))
}
