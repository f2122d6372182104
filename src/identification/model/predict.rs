//! Energy predictions of a [`PowerModel`] with their 95 % intervals: the parameter covariance
//! propagated through the energy, the cross-validated structure error, and what the
//! identification logs left undetermined (a clipped meter below the lowest level seen, a
//! payload heavier than the logs carried, the gear term's disagreement).

use nalgebra::DMatrix;
use serde::Serialize;

use super::{PowerModel, StateEval};
use crate::error::{Error, Result};
use crate::identification::tuning;
use crate::model::Robot;
use crate::model::payload::PayloadEvent;
use crate::trajectory::Trajectory;

impl PowerModel {
    /// Predicted energy of the modelled signal (J) along `traj` with the payloads of
    /// `events` (as in [`PowerModel::energy_with_payloads`]), with its 95 % interval: the
    /// parameter covariance propagated through the energy (which is linear in the base
    /// parameters) plus the cross-validated structure error, `structure_sigma_W` times the
    /// motion's duration and `structure_rel` times its active energy `integral |P - P0| dt`
    /// (at least `structure_active_W` times the duration), plus half the energy a clipped
    /// signal spends below `lowest_seen_W` (what the meter reads there is undetermined), plus
    /// [`tuning::UNSEEN_LOAD_LOSS`] of the mechanical energy a payload heavier than
    /// `payload_seen_kg` moves through the joints beyond that mass (`unseen_load_J`), plus,
    /// for a model with gear friction, its disagreement with the model without it
    /// (`without_gear_J`). `dt`: integration step, s.
    pub fn predict(
        &self,
        robot: &Robot,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        efficiency: f64,
        dt: f64,
    ) -> Result<Prediction> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::InvalidInput(format!(
                "integration step {dt} s must be positive"
            )));
        }
        let np = self.params();
        let steps = (traj.duration() / dt).ceil().max(1.0) as usize;
        let h = traj.duration() / steps as f64;
        let t: Vec<f64> = (0..=steps).map(|k| k as f64 * h).collect();
        let clipped = self.signal.clipped();
        let without_gear_j = match &self.without_gear {
            Some(alt) => Some(alt.predict(robot, traj, events, efficiency, dt)?.energy_j),
            None => None,
        };
        let (mut motor, mut grid, mut active, mut unseen) = (0.0, 0.0, 0.0, 0.0);
        let mut unseen_load = 0.0;
        let lowest_seen = if clipped { self.lowest_seen } else { None };
        let floor = if clipped {
            self.bus_floor.unwrap_or(0.0)
        } else {
            0.0
        };
        let standby: f64 = self.constant.iter().sum();
        let mut g = vec![0.0; np];
        let coulomb = self.coulomb_params();
        let mut k = 0usize;
        self.each_state(robot, traj, events, efficiency, &t, |e| {
            let weight = h * if k == 0 || k == steps { 0.5 } else { 1.0 };
            k += 1;
            let total: f64 = e.p.iter().sum();
            motor += weight * total;
            grid += weight * total.max(floor);
            let signal = self.reading(total);
            active += weight * (signal - standby).abs();
            if let Some(low) = lowest_seen {
                // The reading below `low` lies between the power clipped at 0 and `low`.
                unseen += weight * (low - total.max(0.0)).max(0.0);
            }
            unseen_load += weight * self.unseen_load_power(e);
            if !(clipped && total < floor) {
                self.add_power_gradient(e, &coulomb, weight, &mut g);
            }
        })?;
        let param_var = if self.covariance.len() == np * np {
            let cov = DMatrix::from_row_slice(np, np, &self.covariance);
            let g = nalgebra::DVector::from_column_slice(&g);
            (g.transpose() * cov * &g)[(0, 0)].max(0.0)
        } else {
            0.0
        };
        let duration = traj.duration();
        let active = active.max(self.structure_active * duration);
        let energy_j = if clipped { grid } else { motor };
        let disagreement = without_gear_j.map_or(0.0, |e| energy_j - e);
        let sigma = (param_var
            + (self.structure_sigma * duration).powi(2)
            + (self.structure_rel * active).powi(2)
            + (0.5 * unseen).powi(2)
            + (tuning::UNSEEN_LOAD_LOSS * unseen_load).powi(2)
            + disagreement.powi(2))
        .sqrt();
        Ok(Prediction {
            energy_j,
            interval_j: 1.96 * sigma,
            motor_j: motor,
            grid_j: grid,
            duration_s: duration,
            below_seen_j: unseen,
            unseen_load_j: unseen_load,
            without_gear_j,
        })
    }

    /// Add `weight` times the gradient of state `e`'s predicted power in `z = [theta, copper,
    /// gear_friction, P0]` (the covariance's parameters) to `g`; `coulomb` as
    /// [`PowerModel::coulomb_params`] gives.
    fn add_power_gradient(
        &self,
        e: &StateEval,
        coulomb: &[Option<(usize, usize)>],
        weight: f64,
        g: &mut [f64],
    ) {
        let (n, nb) = (self.copper.len(), self.columns.len());
        // d p / d theta = W^T d p / d tau, one regressor column (contiguous) at a time.
        let w = e.w.as_slice();
        for (gk, &c) in g.iter_mut().zip(&self.columns) {
            let col = &w[c * n..(c + 1) * n];
            let dot: f64 = col.iter().zip(e.dp_dtau).map(|(a, b)| a * b).sum();
            *gk += weight * dot;
        }
        for i in 0..n {
            let tau = e.tau[i];
            let mech = e.dq[i] * tau;
            g[nb + i] += weight * (tau * tau + e.unsure[i]);
            if !self.gear_friction.is_empty() {
                g[nb + n + i] += weight * mech.abs();
            }
            // `unsure` is `fc^2 (1 - s^2)`, quadratic in the Coulomb parameter.
            if let Some((_, kc)) = coulomb[i]
                && e.model.theta[kc] != 0.0
            {
                g[kc] += weight * 2.0 * e.model.copper[i] * e.unsure[i] / e.model.theta[kc];
            }
        }
        let last = g.len() - 1;
        g[last] += weight;
    }

    /// Mechanical power (W) the payload attached at state `e` moves through the joints,
    /// `sum_i |dtau_i dq_i|` with `dtau` its torque, times the fraction of its mass beyond the
    /// heaviest load the identification logs carried (`payload_seen_kg`); 0 within it.
    fn unseen_load_power(&self, e: &StateEval) -> f64 {
        match self.payload_seen {
            Some(seen) if e.payload_kg > seen => {
                let beyond = 1.0 - seen / e.payload_kg;
                (0..e.dq.len())
                    .map(|i| {
                        let added = e.tau[i] - self.torque(e.w, i);
                        beyond * (added * e.dq[i]).abs()
                    })
                    .sum()
            }
            _ => 0.0,
        }
    }
}

/// An energy prediction with its uncertainty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Prediction {
    /// Predicted energy of the modelled signal (the motor sum, or the DC bus / grid power
    /// clipped at its floor, [`PowerModel::reading`]), J.
    #[serde(rename = "energy_J")]
    pub energy_j: f64,
    /// Half-width of the 95 % interval of `energy_j`, J.
    #[serde(rename = "interval_95_J")]
    pub interval_j: f64,
    /// Integral of the predicted motor sum, J (regenerated energy counts negative).
    #[serde(rename = "motor_J")]
    pub motor_j: f64,
    /// Integral of `max(P, F)` with `F` the floor of a clipped signal (0 for an unclipped
    /// one), J.
    #[serde(rename = "grid_J")]
    pub grid_j: f64,
    /// Duration of the motion, s.
    #[serde(rename = "duration_s")]
    pub duration_s: f64,
    /// Energy the predicted signal spends below the lowest level the identification logs show
    /// a clipped meter at (`integral max(lowest_seen - signal, 0) dt`), J: what the meter
    /// reads there is undetermined; half of it is in the interval's standard deviation.
    #[serde(rename = "below_seen_J")]
    pub below_seen_j: f64,
    /// Mechanical energy the payload moves through the joints beyond the heaviest load the
    /// identification logs carried (`integral sum_i |dtau_i dq_i| dt` of the payload's torque,
    /// times the fraction of its mass beyond that load), J; `UNSEEN_LOAD_LOSS` of it is in the
    /// interval's standard deviation.
    #[serde(rename = "unseen_load_J")]
    pub unseen_load_j: f64,
    /// For a model with gear friction, the energy its model without gear friction predicts
    /// ([`PowerModel::without_gear`]), J: the difference is in the interval's standard
    /// deviation. `None` without gear friction.
    #[serde(rename = "without_gear_J", skip_serializing_if = "Option::is_none")]
    pub without_gear_j: Option<f64>,
}

/// Predicted energy of a motion.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EnergyPrediction {
    /// Integral of the predicted total motor power, J (regenerated energy counts negative).
    #[serde(rename = "motor_J")]
    pub motor_j: f64,
    /// Integral of the predicted grid-side power `max(P, F)`, J (no energy fed back; `F` the
    /// floor of a clipped signal, 0 for an unclipped one).
    #[serde(rename = "grid_J")]
    pub grid_j: f64,
}
