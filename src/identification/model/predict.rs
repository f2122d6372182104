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
    /// `payload_seen_kg` moves through the joints beyond that mass (`unseen_load_J`), plus
    /// [`tuning::SLOW_FRICTION_UNSURE`] of the Coulomb friction work at slow joint speeds
    /// (`slow_friction_J`), plus, for a model with gear
    /// friction, its disagreement with the model without it (`without_gear_J`). `dt`:
    /// integration step, s.
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
        let (mut unseen_load, mut slow_friction) = (0.0, 0.0);
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
            slow_friction += weight * self.slow_friction_power(e, &coulomb);
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
            + (tuning::SLOW_FRICTION_UNSURE * slow_friction).powi(2)
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
            slow_friction_j: slow_friction,
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

    /// Coulomb friction power (W) of state `e` at slow joint speeds, `sum_i |fc_i dq_i|
    /// exp(-(dq_i / (SLOW_FRICTION_SPAN min_speed))^2)` with `fc_i` the model's Coulomb
    /// parameter (`coulomb` as [`PowerModel::coulomb_params`] gives). Identification fitted
    /// only samples at which every excited joint moved at least `min_speed`, so how the
    /// friction changes at slower speeds is not in the model; 0 for a model without Coulomb
    /// friction or without a least fitted speed.
    fn slow_friction_power(&self, e: &StateEval, coulomb: &[Option<(usize, usize)>]) -> f64 {
        let Some(span) = self
            .min_speed
            .filter(|v| *v > 0.0)
            .map(|v| tuning::SLOW_FRICTION_SPAN * v)
        else {
            return 0.0;
        };
        coulomb
            .iter()
            .zip(e.dq)
            .filter_map(|(c, &v)| {
                let (_, kc) = (*c)?;
                let x = v / span;
                Some((e.model.theta[kc] * v).abs() * (-x * x).exp())
            })
            .sum()
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
    /// Coulomb friction work at slow joint speeds (`integral sum_i |fc_i dq_i| exp(-(dq_i /
    /// (2 min_speed))^2) dt`, with the model's least fitted speed `min_speed_rad_s`), J: the
    /// identification logs show the friction only at speeds above that;
    /// `SLOW_FRICTION_UNSURE` of it is in the interval's standard deviation (0 for a model
    /// without a least fitted speed).
    #[serde(rename = "slow_friction_J")]
    pub slow_friction_j: f64,
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

#[cfg(test)]
mod tests {
    use crate::dynamics::ParamLayout;
    use crate::identification::model::PowerModel;
    use crate::identification::tuning;
    use crate::model::builtin;
    use crate::model::urdf::{LoadOptions, load_str};
    use crate::trajectory::sampled::Sampled;

    /// A model of only Coulomb friction (10 N m per joint), fitted no slower than `min_speed`
    /// (rad/s), predicting joint 1 turning at `speed` (rad/s) for 10 s, the others at rest:
    /// the energy, its interval and its slow-friction work, J.
    fn coulomb_only(speed: f64, min_speed: Option<f64>) -> (f64, f64, f64) {
        let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).unwrap();
        let mut model =
            PowerModel::new(&robot, ParamLayout::new(&robot, true, true), false).unwrap();
        model.min_speed = min_speed;
        let coulomb = model.coulomb_params();
        for (_, kc) in coulomb.iter().flatten() {
            model.theta[*kc] = 10.0;
        }
        let t: Vec<f64> = (0..=100).map(|k| 0.1 * k as f64).collect();
        // Per joint, per sample.
        let rest = [0.0, 0.2, 0.2, 0.0, 0.8, 0.0];
        let q = (0..6)
            .map(|j| {
                t.iter()
                    .map(|&t| if j == 0 { speed * t } else { rest[j] })
                    .collect()
            })
            .collect();
        let dq = (0..6)
            .map(|j| vec![if j == 0 { speed } else { 0.0 }; t.len()])
            .collect();
        let traj = Sampled::new(t, q, Some(dq), None).unwrap();
        let p = model.predict(&robot, &traj, &[], 1.0, 0.01).unwrap();
        (p.energy_j, p.interval_j, p.slow_friction_j)
    }

    #[test]
    fn friction_at_slow_joint_speeds_widens_the_interval() {
        // At 0.05 rad/s the friction work is 10 N m x 0.05 rad/s x 10 s = 5 J, all of it at a
        // speed identification fitted no sample at (weight exp(-(0.05 / (2 x 0.05))^2)).
        let (energy, interval, slow) = coulomb_only(0.05, Some(tuning::MIN_SPEED));
        assert!((energy - 5.0).abs() < 1e-6, "{energy} J");
        let expected = 5.0 * (-0.25f64).exp();
        assert!((slow - expected).abs() < 1e-6, "{slow} J vs {expected} J");
        // Nothing else is uncertain in this model: the interval is the slow-friction term.
        let sigma = tuning::SLOW_FRICTION_UNSURE * slow;
        assert!((interval - 1.96 * sigma).abs() < 1e-9, "{interval} J");
        // At 0.5 rad/s the same friction is fitted: no slow-friction term to speak of.
        let (energy, interval, slow) = coulomb_only(0.5, Some(tuning::MIN_SPEED));
        assert!((energy - 50.0).abs() < 1e-6, "{energy} J");
        assert!(slow < 1e-9 && interval < 1e-9, "{slow} J, {interval} J");
        // A model without a least fitted speed (not fitted by speed, or an older file) has no
        // such term.
        let (energy, interval, slow) = coulomb_only(0.05, None);
        assert!((energy - 5.0).abs() < 1e-6, "{energy} J");
        assert_eq!((interval, slow), (0.0, 0.0));
    }
}
