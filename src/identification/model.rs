//! The identified power model (paper eqs. 9–14): base parameters plus motor-loss terms.
//!
//! Predicted total motor power at a state is
//! `P = sum_i [ dq_i tau_i + c_i tau_i^2 + P0_i ]` with `tau_i = W_base,i(q, dq, ddq) theta`.
//! For the paper's efficiency model `c = 0` and `theta` is the base-parameter vector divided
//! by the motor efficiency (eq. 12: the method cannot separate them); for the PMSM model
//! `theta` is in SI units and `c_i` (W/(N m)^2), `P0_i` (W) are identified too.
//! Energy over a trajectory (eq. 14) integrates that power in time.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::dynamics::base_params::{BaseParams, SamplingOptions};
use crate::dynamics::regressor::regressor;
use crate::dynamics::{ParamLayout, Workspace};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::trajectory::Trajectory;

/// Base-parameter power model of one robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PowerModel {
    /// Robot name (a model only applies to its robot).
    pub robot: String,
    /// Parameter layout of the underlying standard vector.
    pub layout: ParamLayout,
    /// Base-parameter names, in `theta` order.
    pub names: Vec<String>,
    /// Columns of the standard regressor that form the base regressor.
    pub columns: Vec<usize>,
    /// Base-parameter values (divided by the efficiency when `efficiency_scaled`).
    pub theta: Vec<f64>,
    /// Whether `theta` is scaled by 1/eta (efficiency motor model).
    pub efficiency_scaled: bool,
    /// Copper-loss coefficient per joint, W/(N m)^2 (0 for the efficiency model).
    #[serde(rename = "copper_W_per_Nm2")]
    pub copper: Vec<f64>,
    /// Constant power per joint, W (standby, auxiliaries, meter offset; only their sum is
    /// identifiable from total power, stored on joint 1).
    #[serde(rename = "constant_W")]
    pub constant: Vec<f64>,
}

impl PowerModel {
    /// A zero model over the base parameters of `robot` for `layout`.
    pub fn new(robot: &Robot, layout: ParamLayout, efficiency_scaled: bool) -> Result<PowerModel> {
        let base = BaseParams::compute(robot, layout, &SamplingOptions::default())?;
        Ok(PowerModel {
            robot: robot.name().to_string(),
            layout,
            names: base.base_names(),
            columns: base.independent().to_vec(),
            theta: vec![0.0; base.rank()],
            efficiency_scaled,
            copper: vec![0.0; robot.dof()],
            constant: vec![0.0; robot.dof()],
        })
    }

    /// Check that the model belongs to `robot`.
    pub fn check_robot(&self, robot: &Robot) -> Result<()> {
        if self.robot != robot.name() || self.layout.dof != robot.dof() {
            return Err(Error::InvalidInput(format!(
                "the model was identified for robot '{}' ({} joints), not '{}' ({} joints)",
                self.robot,
                self.layout.dof,
                robot.name(),
                robot.dof()
            )));
        }
        Ok(())
    }

    /// Joint torques `tau = W_base theta` (N m, or N m / eta when efficiency-scaled) and the
    /// total power (W) at one state. `w` is scratch of size `n x layout.len()`.
    pub fn power(
        &self,
        robot: &Robot,
        ws: &mut Workspace,
        w: &mut DMatrix<f64>,
        q: &[f64],
        dq: &[f64],
        ddq: &[f64],
    ) -> f64 {
        regressor(robot, ws, &self.layout, q, dq, ddq, w);
        let mut p = 0.0;
        for i in 0..robot.dof() {
            let tau: f64 = self
                .columns
                .iter()
                .zip(&self.theta)
                .map(|(&c, th)| w[(i, c)] * th)
                .sum();
            p += dq[i] * tau + self.copper[i] * tau * tau + self.constant[i];
        }
        p
    }

    /// Predicted energy (J) of following `traj`, integrating the power at step `dt` (s) with
    /// the trapezoidal rule (paper eq. 14).
    pub fn energy(&self, robot: &Robot, traj: &dyn Trajectory, dt: f64) -> Result<f64> {
        self.check_robot(robot)?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::InvalidInput(format!(
                "integration step {dt} s must be positive"
            )));
        }
        let n = robot.dof();
        let mut ws = Workspace::new(robot);
        let mut w = DMatrix::zeros(n, self.layout.len());
        let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let steps = (traj.duration() / dt).ceil().max(1.0) as usize;
        let h = traj.duration() / steps as f64;
        let mut e = 0.0;
        for k in 0..=steps {
            traj.sample(k as f64 * h, &mut q, &mut dq, &mut ddq);
            let p = self.power(robot, &mut ws, &mut w, &q, &dq, &ddq);
            e += if k == 0 || k == steps { 0.5 * p } else { p };
        }
        Ok(e * h)
    }
}
