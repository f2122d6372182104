//! Energy predictions of a [`PowerModel`] with their 95 % intervals: the parameter covariance
//! propagated through the energy, the cross-validated structure error, and what the
//! identification logs left undetermined (a clipped meter below the lowest level seen, a
//! payload heavier than the logs carried, the friction structure).

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
    /// (at least `structure_active_W` times the duration) and `structure_fold_W` times the
    /// duration for a motion that rests (its variance in proportion to the time every joint
    /// is slower than the least fitted speed, whole at [`tuning::FOLD_ERROR_REST_SHARE`] of
    /// the duration), plus half the energy a clipped
    /// signal spends below `lowest_seen_W` (what the meter reads there is undetermined), plus
    /// [`tuning::UNSEEN_LOAD_LOSS`] of the mechanical energy a payload heavier than
    /// `payload_seen_kg` moves through the joints beyond that mass (`unseen_load_J`), plus
    /// half its difference from the model of the other friction structure
    /// ([`PowerModel::alternative`], `alternative_J`). Where the model has that alternative,
    /// the energy is the mean of the two structures' (their power averaged state by state).
    /// `dt`: integration step, s.
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
        let sums = self.integrate(robot, traj, events, efficiency, dt)?;
        let duration = traj.duration();
        let energy_j = if self.signal.clipped() {
            sums.grid
        } else {
            sums.motor
        };
        let alternative_j = self.alternative.as_ref().map(|_| sums.alternative);
        let stribeck_j = (!self.stribeck.is_empty()).then_some(sums.stribeck);
        let sigma = self.sigma(&sums, energy_j, alternative_j, stribeck_j, duration);
        Ok(Prediction {
            energy_j,
            interval_j: 1.96 * sigma,
            motor_j: sums.motor,
            grid_j: sums.grid,
            duration_s: duration,
            below_seen_j: sums.unseen,
            unseen_load_j: sums.unseen_load,
            alternative_j,
            stribeck_j,
            rest_s: sums.rest,
        })
    }

    /// The first stage of [`PowerModel::predict`]: the trapezoid integrals along `traj` at
    /// steps of at most `dt` (s) that the prediction and its interval need.
    fn integrate(
        &self,
        robot: &Robot,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        efficiency: f64,
        dt: f64,
    ) -> Result<Integrals> {
        let steps = (traj.duration() / dt).ceil().max(1.0) as usize;
        let h = traj.duration() / steps as f64;
        let t: Vec<f64> = (0..=steps).map(|k| k as f64 * h).collect();
        let clipped = self.signal.clipped();
        let alternative = self.alternative.as_deref();
        let lowest_seen = if clipped { self.lowest_seen } else { None };
        let floor = if clipped {
            self.bus_floor.unwrap_or(0.0)
        } else {
            0.0
        };
        let standby: f64 = self.constant.iter().sum();
        let mut sums = Integrals {
            gradient: vec![0.0; self.params()],
            ..Integrals::default()
        };
        let coulomb = self.coulomb_params();
        let mut k = 0usize;
        let rest_below = self.min_speed.unwrap_or(0.0);
        self.each_state(robot, traj, events, efficiency, &t, |e| {
            let weight = h * if k == 0 || k == steps { 0.5 } else { 1.0 };
            k += 1;
            if e.dq.iter().all(|v| v.abs() < rest_below) {
                sums.rest += weight;
            }
            let total: f64 = e.p.iter().sum();
            sums.motor += weight * total;
            sums.grid += weight * total.max(floor);
            let signal = self.reading(total);
            sums.active += weight * (signal - standby).abs();
            if let Some(low) = lowest_seen {
                // The reading below `low` lies between the power clipped at 0 and `low`.
                sums.unseen += weight * (low - total.max(0.0)).max(0.0);
            }
            sums.unseen_load += weight * self.unseen_load_power(e);
            if let (Some(alt), Some(p)) = (alternative, e.alternative_p) {
                // What the alternative's own `predict` integrates: its own meter's reading.
                sums.alternative += weight * alt.reading(p);
            }
            if let Some(p) = e.stribeck_p {
                sums.stribeck += weight * self.reading(p);
            }
            if !(clipped && total < floor) {
                self.add_power_gradient(e, &coulomb, weight, &mut sums.gradient);
            }
        })?;
        Ok(sums)
    }

    /// The second stage of [`PowerModel::predict`]: the standard deviation (J) of a predicted
    /// `energy_j` (J) over `duration` (s), from its integrals `sums` and the energies of the
    /// other friction structure and of the whole Stribeck rise, where the model has them.
    fn sigma(
        &self,
        sums: &Integrals,
        energy_j: f64,
        alternative_j: Option<f64>,
        stribeck_j: Option<f64>,
        duration: f64,
    ) -> f64 {
        let np = self.params();
        // The chosen structure's parameter variance, taken whole where the prediction is the
        // mean of the two structures: both were fitted on the same logs, so their parameter
        // errors move together and the mean's variance is about either's (the chosen one's
        // gradient halved would leave out the other's half).
        let param_var = if self.covariance.len() == np * np {
            let cov = DMatrix::from_row_slice(np, np, &self.covariance);
            let g = nalgebra::DVector::from_column_slice(&sums.gradient);
            (g.transpose() * cov * &g)[(0, 0)].max(0.0)
        } else {
            0.0
        };
        let active = sums.active.max(self.structure_active * duration);
        let disagreement = alternative_j.map_or(0.0, |e| energy_j - e);
        let stribeck_rest = stribeck_j.map_or(0.0, |e| e - energy_j);
        let rest_share = (sums.rest / (tuning::FOLD_ERROR_REST_SHARE * duration)).min(1.0);
        (param_var
            + (self.structure_sigma * duration).powi(2)
            + (self.structure_rel * active).powi(2)
            + rest_share * (self.structure_fold * duration).powi(2)
            + (0.5 * sums.unseen).powi(2)
            + (tuning::UNSEEN_LOAD_LOSS * sums.unseen_load).powi(2)
            + disagreement.powi(2)
            + stribeck_rest.powi(2))
        .sqrt()
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

/// The integrals along a motion that [`PowerModel::predict`] needs (J unless noted).
#[derive(Debug, Default)]
struct Integrals {
    /// The predicted motor sum.
    motor: f64,
    /// `max(P, F)`, `F` the floor of a clipped signal (0 for an unclipped one).
    grid: f64,
    /// The active energy `integral |reading - P0| dt`.
    active: f64,
    /// What a clipped signal spends below the lowest level the logs show.
    unseen: f64,
    /// The mechanical energy a payload heavier than the logs carried moves beyond their load.
    unseen_load: f64,
    /// The other friction structure's reading.
    alternative: f64,
    /// The reading with the whole of the drive file's Stribeck rise.
    stribeck: f64,
    /// Time at rest, s: every joint slower than the least speed the fit saw.
    rest: f64,
    /// The gradient of the energy in the covariance's parameters.
    gradient: Vec<f64>,
}

/// An energy prediction with its uncertainty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Prediction {
    /// Predicted energy of the modelled signal (the motor sum, or the DC bus / grid power
    /// clipped at its floor, [`PowerModel::reading`]), J: the mean of the two friction
    /// structures' where the model has an alternative.
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
    /// The energy the model of the other friction structure predicts (with load-dependent
    /// gear friction if this model has none, without it if it has;
    /// [`PowerModel::alternative`]), J: `energy_J` is the mean of it and the model's own,
    /// and half their difference is in the interval's standard deviation. `None` without an
    /// alternative.
    #[serde(rename = "alternative_J", skip_serializing_if = "Option::is_none")]
    pub alternative_j: Option<f64>,
    /// The energy the model predicts with the whole of the drive file's Stribeck rise at slow
    /// joint speeds ([`PowerModel::stribeck`]; the model takes
    /// [`tuning::STRIBECK_SHARE`] of it), J: the difference is in the interval's standard
    /// deviation. `None` without a Stribeck law.
    #[serde(rename = "stribeck_J", skip_serializing_if = "Option::is_none")]
    pub stribeck_j: Option<f64>,
    /// Time the motion rests, s: every joint slower than the least speed the identification
    /// fitted (`min_speed_rad_s`; none for a model without one). The interval takes the error
    /// the cross-validation pieces of a left-out log share (`structure_fold_W`) in proportion
    /// to it, whole from [`tuning::FOLD_ERROR_REST_SHARE`] of the duration on.
    pub rest_s: f64,
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
    use crate::model::builtin;
    use crate::model::urdf::{LoadOptions, load_str};
    use crate::trajectory::sampled::Sampled;

    #[test]
    fn the_prediction_is_the_mean_of_the_two_friction_structures() {
        let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).unwrap();
        let mut model =
            PowerModel::new(&robot, ParamLayout::new(&robot, true, true), false).unwrap();
        let coulomb = model.coulomb_params();
        for (_, kc) in coulomb.iter().flatten() {
            model.theta[*kc] = 10.0;
        }
        model.constant[0] = 100.0;
        // The same friction with 5 % of the transmitted power lost in the gear besides.
        let mut alt = model.clone();
        alt.gear_friction = vec![0.05; robot.dof()];
        model.alternative = Some(Box::new(alt.clone()));
        // Joint 1 turning at 0.5 rad/s for 10 s, the others at rest.
        let t: Vec<f64> = (0..=100).map(|k| 0.1 * k as f64).collect();
        let rest = [0.0, 0.2, 0.2, 0.0, 0.8, 0.0];
        let q = (0..6)
            .map(|j| {
                t.iter()
                    .map(|&t| if j == 0 { 0.5 * t } else { rest[j] })
                    .collect()
            })
            .collect();
        let dq = (0..6)
            .map(|j| vec![if j == 0 { 0.5 } else { 0.0 }; t.len()])
            .collect();
        let traj = Sampled::new(t, q, Some(dq), None).unwrap();
        let p = model.predict(&robot, &traj, &[], 1.0, 0.01).unwrap();
        let other = alt.predict(&robot, &traj, &[], 1.0, 0.01).unwrap();
        // Standby 1000 J and friction work 10 N m x 0.5 rad/s x 10 s = 50 J; the gear loses
        // 5 % of that besides. The model predicts the mean of the two.
        assert!((p.energy_j - 1051.25).abs() < 1e-6, "{} J", p.energy_j);
        assert!(
            (other.energy_j - 1052.5).abs() < 1e-6,
            "{} J",
            other.energy_j
        );
        assert_eq!(p.alternative_j, Some(other.energy_j));
        // Nothing else is uncertain in this model: the interval is half the two structures'
        // difference (the standard deviation of an even mixture of the two).
        assert!(
            (p.interval_j - 1.96 * 1.25).abs() < 1e-6,
            "{} J",
            p.interval_j
        );
        // Its power, motor by motor, is the mean too.
        let times = [0.0, 5.0];
        let mean = model
            .power_with_payloads(&robot, &traj, &[], 1.0, &times)
            .unwrap();
        let gear = alt
            .power_with_payloads(&robot, &traj, &[], 1.0, &times)
            .unwrap();
        assert!((mean[1] - 105.125).abs() < 1e-9, "{} W", mean[1]);
        assert!((gear[1] - 105.25).abs() < 1e-9, "{} W", gear[1]);
        // Without an alternative there is no such term.
        model.alternative = None;
        let p = model.predict(&robot, &traj, &[], 1.0, 0.01).unwrap();
        assert_eq!((p.alternative_j, p.interval_j), (None, 0.0));
    }

    #[test]
    fn a_slow_joint_takes_a_share_of_the_stribeck_rise_and_the_rest_is_the_interval() {
        use crate::identification::model::Stribeck;
        use crate::identification::tuning::STRIBECK_SHARE;
        let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).unwrap();
        let mut model =
            PowerModel::new(&robot, ParamLayout::new(&robot, true, true), false).unwrap();
        for (_, kc) in model.coulomb_params().iter().flatten() {
            model.theta[*kc] = 10.0;
        }
        model.constant[0] = 100.0;
        // Joint 1 turning at its Stribeck velocity for 10 s, the others at rest.
        let (v, rise) = (0.05, 0.4);
        let t: Vec<f64> = (0..=100).map(|k| 0.1 * k as f64).collect();
        let rest = [0.0, 0.2, 0.2, 0.0, 0.8, 0.0];
        let q = (0..6)
            .map(|j| {
                t.iter()
                    .map(|&t| if j == 0 { v * t } else { rest[j] })
                    .collect()
            })
            .collect();
        let dq = (0..6)
            .map(|j| vec![if j == 0 { v } else { 0.0 }; t.len()])
            .collect();
        let traj = Sampled::new(t, q, Some(dq), None).unwrap();
        let plain = model.predict(&robot, &traj, &[], 1.0, 0.01).unwrap();
        assert_eq!(plain.stribeck_j, None);
        // Friction work 10 N m x 0.05 rad/s x 10 s = 5 J at the Coulomb friction.
        assert!(
            (plain.energy_j - 1005.0).abs() < 1e-6,
            "{} J",
            plain.energy_j
        );
        model.stribeck = vec![Some(Stribeck { rise, speed: v }); robot.dof()];
        let p = model.predict(&robot, &traj, &[], 1.0, 0.01).unwrap();
        let raised = |share: f64| 1000.0 + 5.0 * (1.0 + share * rise * (-1.0f64).exp());
        assert!(
            (p.energy_j - raised(STRIBECK_SHARE)).abs() < 1e-6,
            "{} J",
            p.energy_j
        );
        let whole = p.stribeck_j.expect("the whole rise's energy");
        assert!((whole - raised(1.0)).abs() < 1e-6, "{whole} J");
        // Nothing else is uncertain in this model: the interval is the rest of the rise.
        assert!(
            (p.interval_j - 1.96 * (whole - p.energy_j)).abs() < 1e-6,
            "{} J",
            p.interval_j
        );
    }
}
