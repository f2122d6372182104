//! Identification from the energy of time windows: no accelerations needed.
//!
//! Between two sample times the energy the motors delivered equals the change of kinetic
//! plus potential energy plus the friction work (plus constant power times the window):
//! `E_w = [h(t1) - h(t0)] theta + [fc int|dq| dt, fv int dq^2 dt] + P0 (t1 - t0)`,
//! with `h` the energy regressor ([`crate::dynamics::energy_regressor`]). Positions and
//! velocities at the window ends come from the fitted motion; the friction integrals are
//! taken over it at [`SUBSTEPS`] points per window: `int |dq| dt` as the total variation
//! `sum |q(t_k+1) - q(t_k)|` (exact except in the substep where the velocity reverses, which
//! Simpson's rule would not be: `|dq|` has a kink there), `int dq^2 dt` by Simpson's rule. Window energies come from an averaging power meter
//! exactly, or from instantaneous samples by the trapezoidal rule (approximate).

use nalgebra::{DMatrix, DVector};

use crate::dynamics::GRAVITY;
use crate::dynamics::energy_regressor::energy_regressor;
use crate::error::{Error, Result};
use crate::identification::lsq::{Estimate, solve};
use crate::identification::model::PowerModel;
use crate::model::Robot;
use crate::trajectory::Trajectory;

/// Subintervals per window for the friction integrals (even).
pub const SUBSTEPS: usize = 100;

/// Window energies (J) from power samples `p` (W) taken at times `t` (s): with `averaged`
/// samples (sample `m` is the mean over `[t_{m-1}, t_m)`) exactly `p_m (t_m - t_{m-1})`,
/// otherwise by the trapezoidal rule.
pub fn window_energies(t: &[f64], p: &[f64], averaged: bool) -> Vec<f64> {
    (1..t.len())
        .map(|m| {
            let dt = t[m] - t[m - 1];
            if averaged {
                p[m] * dt
            } else {
                0.5 * (p[m] + p[m - 1]) * dt
            }
        })
        .collect()
}

/// Regressor rows of the windows `[t_{m-1}, t_m]` along the motion `traj`, with the model's
/// base columns plus a last column for constant power (s).
pub fn rows(robot: &Robot, model: &PowerModel, traj: &dyn Trajectory, t: &[f64]) -> DMatrix<f64> {
    let n = robot.dof();
    let layout = &model.layout;
    let nb = model.columns.len();
    let mut a = DMatrix::zeros(t.len().saturating_sub(1), nb + 1);
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut h0 = vec![0.0; layout.len()];
    let mut h1 = vec![0.0; layout.len()];
    let mut full = vec![0.0; layout.len()];
    let (mut q_prev, mut dq_prev, mut ddq_prev) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    traj.sample(t[0], &mut q, &mut dq, &mut ddq);
    energy_regressor(robot, layout, &GRAVITY, &q, &dq, &mut h0);
    for m in 1..t.len() {
        traj.sample(t[m], &mut q, &mut dq, &mut ddq);
        energy_regressor(robot, layout, &GRAVITY, &q, &dq, &mut h1);
        for c in 0..layout.len() {
            full[c] = h1[c] - h0[c];
        }
        if layout.friction {
            let step = (t[m] - t[m - 1]) / SUBSTEPS as f64;
            for k in 0..=SUBSTEPS {
                let w = if k == 0 || k == SUBSTEPS {
                    1.0
                } else if k % 2 == 1 {
                    4.0
                } else {
                    2.0
                } * step
                    / 3.0;
                traj.sample(t[m - 1] + k as f64 * step, &mut q, &mut dq, &mut ddq);
                for i in 0..n {
                    if let (Some(cc), Some(cv)) = (layout.coulomb_col(i), layout.viscous_col(i)) {
                        if k > 0 {
                            full[cc] += variation(q_prev[i], dq_prev[i], ddq_prev[i], q[i], dq[i]);
                        }
                        full[cv] += w * dq[i] * dq[i];
                    }
                }
                q_prev.copy_from_slice(&q);
                dq_prev.copy_from_slice(&dq);
                ddq_prev.copy_from_slice(&ddq);
            }
        }
        for (k, &c) in model.columns.iter().enumerate() {
            a[(m - 1, k)] = full[c];
        }
        a[(m - 1, nb)] = t[m] - t[m - 1];
        std::mem::swap(&mut h0, &mut h1);
    }
    a
}

/// `int |dq| dt` over one substep from `q0` (velocity `v0`, acceleration `a0`) to `q1`
/// (velocity `v1`): `|q1 - q0|`, or, when the velocity reverses inside, the path out to the
/// turning point `q0 - v0^2 / (2 a0)` and back.
fn variation(q0: f64, v0: f64, a0: f64, q1: f64, v1: f64) -> f64 {
    if v0 * v1 < 0.0 && a0 != 0.0 {
        let turn = q0 - v0 * v0 / (2.0 * a0);
        (turn - q0).abs() + (q1 - turn).abs()
    } else {
        (q1 - q0).abs()
    }
}

/// One dataset's windows: the motion, the sample times (s) and the energies (J) of the
/// windows between consecutive samples.
pub struct Windows<'a> {
    /// Continuous motion through the samples.
    pub motion: &'a dyn Trajectory,
    /// Sample times, s.
    pub t: &'a [f64],
    /// Energy of each window `[t_m, t_m+1]`, J (one fewer than `t`).
    pub energy: &'a [f64],
}

/// Identify `model` (filled in place, constant power on joint 1) from the window energies of
/// one or more datasets.
pub fn identify(robot: &Robot, model: &mut PowerModel, data: &[Windows]) -> Result<Estimate> {
    model.check_robot(robot)?;
    let nb = model.columns.len();
    let mut blocks = Vec::with_capacity(data.len());
    let mut y = Vec::new();
    for (d, w) in data.iter().enumerate() {
        if w.t.len() < 2 || w.energy.len() + 1 != w.t.len() {
            return Err(Error::InvalidInput(format!(
                "dataset {}: {} window energies for {} sample times (need one fewer)",
                d + 1,
                w.energy.len(),
                w.t.len()
            )));
        }
        blocks.push(rows(robot, model, w.motion, w.t));
        y.extend_from_slice(w.energy);
    }
    let mut a = DMatrix::zeros(y.len(), nb + 1);
    let mut r0 = 0;
    for b in &blocks {
        a.view_mut((r0, 0), b.shape()).copy_from(b);
        r0 += b.nrows();
    }
    let names: Vec<String> = model
        .names
        .iter()
        .cloned()
        .chain(["P0_W".to_string()])
        .collect();
    let est = solve(&a, &DVector::from_column_slice(&y), &names)?;
    model.theta.copy_from_slice(&est.values[..nb]);
    model.constant.fill(0.0);
    model.constant[0] = est.values[nb];
    model.copper.fill(0.0);
    Ok(est)
}
