//! Identification for the PMSM motor model: total power
//! `P = sum_i [dq_i tau_i + c_i tau_i^2] + P0` with `tau_i = W_base,i theta` is nonlinear in
//! the unknowns `(theta, c_1..c_n, P0)`. Levenberg–Marquardt from the linear total-power
//! solution (`c = 0`); standard deviations from the final linearisation. With copper loss in
//! the model the predicted energy rises again at low speed, as the twin's does.

use nalgebra::{DMatrix, DVector};

use crate::dynamics::Workspace;
use crate::dynamics::regressor::regressor;
use crate::error::{Error, Result};
use crate::identification::linear::{self, Observation};
use crate::identification::lsq::{Estimate, solve};
use crate::identification::model::PowerModel;
use crate::identification::states::States;
use crate::model::Robot;

/// Iteration limit of Levenberg–Marquardt.
const MAX_ITERATIONS: usize = 100;

/// Identify `model` (filled in place, not efficiency-scaled) from total power `p` (W) at the
/// samples of `states`.
pub fn identify(
    robot: &Robot,
    model: &mut PowerModel,
    states: &States,
    p: &[f64],
) -> Result<Estimate> {
    model.check_robot(robot)?;
    if p.len() != states.len() {
        return Err(Error::InvalidInput(format!(
            "{} power samples for {} states",
            p.len(),
            states.len()
        )));
    }
    model.efficiency_scaled = false;
    linear::identify(robot, model, states, Observation::TotalPower, p)?;
    let n = robot.dof();
    let nb = model.columns.len();
    // Base regressor rows per sample: wb[m] is n x nb.
    let mut ws = Workspace::new(robot);
    let mut w = DMatrix::zeros(n, model.layout.len());
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut wb = Vec::with_capacity(states.len());
    let mut speeds = Vec::with_capacity(states.len());
    for m in 0..states.len() {
        states.at(m, &mut q, &mut dq, &mut ddq);
        regressor(robot, &mut ws, &model.layout, &q, &dq, &ddq, &mut w);
        wb.push(DMatrix::from_fn(n, nb, |i, k| w[(i, model.columns[k])]));
        speeds.push(dq.clone());
    }
    let np = nb + n + 1;
    let mut z = DVector::zeros(np);
    z.rows_mut(0, nb).copy_from_slice(&model.theta);
    z[np - 1] = model.constant.iter().sum();
    let eval = |z: &DVector<f64>, jac: Option<&mut DMatrix<f64>>| -> DVector<f64> {
        let theta = z.rows(0, nb);
        let mut r = DVector::zeros(wb.len());
        let mut jac = jac;
        for (m, (wm, v)) in wb.iter().zip(&speeds).enumerate() {
            let tau = wm * theta;
            let mut pm = z[np - 1];
            for i in 0..n {
                pm += v[i] * tau[i] + z[nb + i] * tau[i] * tau[i];
            }
            r[m] = pm - p[m];
            if let Some(j) = jac.as_deref_mut() {
                for k in 0..nb {
                    j[(m, k)] = (0..n)
                        .map(|i| (v[i] + 2.0 * z[nb + i] * tau[i]) * wm[(i, k)])
                        .sum();
                }
                for i in 0..n {
                    j[(m, nb + i)] = tau[i] * tau[i];
                }
                j[(m, np - 1)] = 1.0;
            }
        }
        r
    };
    let mut jac = DMatrix::zeros(wb.len(), np);
    let mut r = eval(&z, Some(&mut jac));
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
            let trial = &z + &step;
            let r_trial = eval(&trial, None);
            let c = r_trial.norm_squared();
            if c < cost {
                let rel = (cost - c) / cost.max(1e-300);
                z = trial;
                r = eval(&z, Some(&mut jac));
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
    // Statistics from the final linearisation: J z - r are the observations of the
    // linearised model at z.
    let names: Vec<String> = model
        .names
        .iter()
        .cloned()
        .chain((1..=n).map(|i| format!("c{i}_W_per_Nm2")))
        .chain(["P0_W".to_string()])
        .collect();
    let y = &jac * &z - &r;
    let est = solve(&jac, &y, &names)?;
    model.theta.copy_from_slice(z.rows(0, nb).as_slice());
    model.copper.copy_from_slice(z.rows(nb, n).as_slice());
    model.constant.fill(0.0);
    model.constant[0] = z[np - 1];
    Ok(Estimate {
        values: z.as_slice().to_vec(),
        ..est
    })
}
