//! Linear estimators: least squares on the base regressor.
//!
//! - [`Observation::TotalPower`]: one row per sample, `sum_i dq_i W_base,i` (paper eqs. 11–13
//!   with the total power of all motors, as RobotStudio reports it), plus a constant column
//!   for standby and auxiliary power;
//! - [`Observation::JointPower`]: one row per motor and sample, `dq_i W_base,i` (eq. 13 with
//!   per-motor power), plus a constant column per motor;
//! - [`Observation::Torque`]: the classic torque least squares, `W_base,i` (reference).
//!
//! With the efficiency motor model the power estimates are the base parameters divided by
//! eta (eq. 12).

use nalgebra::{DMatrix, DVector};

use crate::dynamics::Workspace;
use crate::dynamics::regressor::regressor;
use crate::error::{Error, Result};
use crate::identification::lsq::{Estimate, solve};
use crate::identification::model::PowerModel;
use crate::identification::states::States;
use crate::model::Robot;

/// What was measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observation {
    /// Total motor power, W.
    TotalPower,
    /// Power of each motor, W.
    JointPower,
    /// Joint torque, N m.
    Torque,
}

/// Regressor rows for the observation kind at every sample of `states`, with the model's
/// base columns, and the extra constant columns' names.
pub fn rows(
    robot: &Robot,
    model: &PowerModel,
    states: &States,
    kind: Observation,
) -> (DMatrix<f64>, Vec<String>) {
    let n = robot.dof();
    let nb = model.columns.len();
    let (per_sample, extra): (usize, Vec<String>) = match kind {
        Observation::TotalPower => (1, vec!["P0_W".into()]),
        Observation::JointPower => (n, (1..=n).map(|i| format!("P0_{i}_W")).collect()),
        Observation::Torque => (n, Vec::new()),
    };
    let mut a = DMatrix::zeros(per_sample * states.len(), nb + extra.len());
    let mut ws = Workspace::new(robot);
    let mut w = DMatrix::zeros(n, model.layout.len());
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for m in 0..states.len() {
        states.at(m, &mut q, &mut dq, &mut ddq);
        regressor(robot, &mut ws, &model.layout, &q, &dq, &ddq, &mut w);
        for (k, &c) in model.columns.iter().enumerate() {
            match kind {
                Observation::TotalPower => {
                    a[(m, k)] = (0..n).map(|i| dq[i] * w[(i, c)]).sum();
                }
                Observation::JointPower => {
                    for i in 0..n {
                        a[(m * n + i, k)] = dq[i] * w[(i, c)];
                    }
                }
                Observation::Torque => {
                    for i in 0..n {
                        a[(m * n + i, k)] = w[(i, c)];
                    }
                }
            }
        }
        match kind {
            Observation::TotalPower => a[(m, nb)] = 1.0,
            Observation::JointPower => {
                for i in 0..n {
                    a[(m * n + i, nb + i)] = 1.0;
                }
            }
            Observation::Torque => {}
        }
    }
    (a, extra)
}

/// Identify the base parameters of `model` (filled in place) from `states` and the matching
/// observations `y` (one per row of [`rows`]: samples for total power, sample-major
/// `[m * n + i]` for per-joint quantities).
pub fn identify(
    robot: &Robot,
    model: &mut PowerModel,
    states: &States,
    kind: Observation,
    y: &[f64],
) -> Result<Estimate> {
    model.check_robot(robot)?;
    let (a, extra) = rows(robot, model, states, kind);
    if y.len() != a.nrows() {
        return Err(Error::InvalidInput(format!(
            "{} observations for {} regressor rows",
            y.len(),
            a.nrows()
        )));
    }
    let names: Vec<String> = model.names.iter().cloned().chain(extra).collect();
    let est = solve(&a, &DVector::from_column_slice(y), &names)?;
    let nb = model.columns.len();
    model.theta.copy_from_slice(&est.values[..nb]);
    model.constant.fill(0.0);
    match kind {
        Observation::TotalPower => model.constant[0] = est.values[nb],
        Observation::JointPower => model.constant.copy_from_slice(&est.values[nb..]),
        Observation::Torque => {}
    }
    Ok(est)
}
