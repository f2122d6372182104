//! The model evaluated along a motion, state by state: the payload model in force, the
//! Coulomb friction's expected signs and law, and the power of each motor, the mean of the
//! two friction structures' where the model carries an alternative.

use nalgebra::DMatrix;

use super::PowerModel;
use crate::dynamics::base_params::BaseParams;
use crate::dynamics::regressor::regressor;
use crate::dynamics::{Workspace, sign};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::model::payload::{PayloadEvent, carried_from_before};
use crate::trajectory::Trajectory;

impl PowerModel {
    /// Call `f` with each state's evaluation at the times `t`, with the payload model in
    /// force then. Where the model has a [`PowerModel::alternative`] (the other friction
    /// structure, fitted on the same logs), each motor's predicted power is the mean of the
    /// two structures': the logs do not tell them apart, so each is taken as likely as the
    /// other. The Coulomb friction takes the trajectory's expected signs
    /// ([`Trajectory::coulomb_signs`]; for a motion estimated from a log, weighed down where
    /// a joint is not seen to move), and an unsure sign adds its variance to the copper loss.
    pub(super) fn each_state(
        &self,
        robot: &Robot,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        efficiency: f64,
        t: &[f64],
        mut f: impl FnMut(&StateEval),
    ) -> Result<()> {
        self.check_robot(robot)?;
        let alternative = self.alternative.as_deref();
        if alternative.is_some_and(|alt| alt.columns != self.columns) {
            return Err(Error::InvalidInput(
                "the alternative model's base parameters are not this model's".into(),
            ));
        }
        let base = (!events.is_empty())
            .then(|| self.base_params(robot))
            .transpose()?;
        let models = self.payload_models(robot, events, efficiency, base.as_ref())?;
        let alt_models = alternative
            .map(|alt| alt.payload_models(robot, events, efficiency, base.as_ref()))
            .transpose()?;
        let n = robot.dof();
        let mut ws = Workspace::new(robot);
        let mut w = DMatrix::zeros(n, self.layout.len());
        let mut j = Joints::new(n);
        let coulomb = self.coulomb_params();
        for &t in t {
            let (model, payload_kg) = in_force(&models, t);
            traj.sample(t, &mut j.q, &mut j.dq, &mut j.ddq);
            traj.coulomb_signs(t, &j.dq, &mut j.signs);
            regressor(robot, &mut ws, &self.layout, &j.q, &j.dq, &j.ddq, &mut w);
            model.coulomb_law(&coulomb, &mut w, &mut j);
            model.own_power(&w, &mut j);
            let stribeck_rise = model.stribeck_rise(&coulomb, &j);
            let alternative_p = alt_models
                .as_ref()
                .map(|models| in_force(models, t).0.mix_into(&coulomb, &w, &mut j));
            if alternative_p.is_none() {
                j.p.copy_from_slice(&j.own);
            }
            let stribeck_p = stribeck_rise.map(|rise| j.p.iter().sum::<f64>() + rise);
            f(&StateEval {
                p: &j.p,
                tau: &j.tau,
                dp_dtau: &j.dp_dtau,
                w: &w,
                dq: &j.dq,
                unsure: &j.unsure,
                model,
                payload_kg,
                alternative_p,
                stribeck_p,
            });
        }
        Ok(())
    }

    /// The Coulomb columns of the regressor `w` at the state of `j`: the expected sign times
    /// the model's friction law ([`PowerModel::coulomb_factor`]), and the variance an unsure
    /// sign adds to the squared torque (`j.unsure`). `coulomb` as
    /// [`PowerModel::coulomb_params`] gives.
    fn coulomb_law(
        &self,
        coulomb: &[Option<(usize, usize)>],
        w: &mut DMatrix<f64>,
        j: &mut Joints,
    ) {
        for (i, c) in coulomb.iter().enumerate() {
            j.unsure[i] = 0.0;
            j.factor[i] = self.coulomb_factor(i, j.dq[i]);
            if let Some((c, k)) = *c {
                w[(i, c)] = j.signs[i] * j.factor[i];
                j.unsure[i] = self.unsure_sign(k, j.signs[i], j.dq[i]) * j.factor[i].powi(2);
            }
        }
    }

    /// This structure's torque, power and `d p / d tau` of each motor at the state of `j`
    /// (regressor `w` with its Coulomb law).
    fn own_power(&self, w: &DMatrix<f64>, j: &mut Joints) {
        for i in 0..j.dq.len() {
            let (dq, tau) = (j.dq[i], self.torque(w, i));
            j.tau[i] = tau;
            j.own[i] = self.joint_power(tau, i, dq) + self.copper[i] * j.unsure[i];
            let mech = dq * tau;
            j.dp_dtau[i] = dq + 2.0 * self.copper[i] * tau + self.gear(i) * mech.signum() * dq;
        }
    }

    /// The power (W) the whole of the drive file's Stribeck rise adds at the state of `j`
    /// beyond the model's share of it, under this structure; `None` without a Stribeck law.
    fn stribeck_rise(&self, coulomb: &[Option<(usize, usize)>], j: &Joints) -> Option<f64> {
        (!self.stribeck.is_empty()).then(|| {
            (0..j.dq.len())
                .map(|i| match (coulomb[i], self.stribeck[i]) {
                    (Some((_, k)), Some(law)) => {
                        let (f, whole) = (j.factor[i], law.factor(j.dq[i], 1.0));
                        let tau = j.tau[i] + self.theta[k] * j.signs[i] * (whole - f);
                        let unsure = j.unsure[i] * (whole / f).powi(2);
                        self.joint_power(tau, i, j.dq[i]) + self.copper[i] * unsure - j.own[i]
                    }
                    _ => 0.0,
                })
                .sum()
        })
    }

    /// As the alternative structure (`self`), each motor's power at the state of `j` with the
    /// same regressor `w`: the prediction `j.p` becomes the mean of it and `j.own`. Returns
    /// the alternative's total power, W.
    fn mix_into(
        &self,
        coulomb: &[Option<(usize, usize)>],
        w: &DMatrix<f64>,
        j: &mut Joints,
    ) -> f64 {
        let mut total = 0.0;
        for (i, c) in coulomb.iter().enumerate() {
            let unsure = c.map_or(0.0, |(_, k)| {
                self.unsure_sign(k, j.signs[i], j.dq[i]) * j.factor[i].powi(2)
            });
            let other = self.joint_power(self.torque(w, i), i, j.dq[i]) + self.copper[i] * unsure;
            j.p[i] = 0.5 * (j.own[i] + other);
            total += other;
        }
        total
    }

    /// This model carrying the payloads of `events`, each from its time on (this model before
    /// the first; the one in force at time 0 from `-inf`), with each payload's mass, kg;
    /// `base` the base-parameter set (needed only with events).
    fn payload_models(
        &self,
        robot: &Robot,
        events: &[PayloadEvent],
        efficiency: f64,
        base: Option<&BaseParams>,
    ) -> Result<Vec<(f64, PowerModel, f64)>> {
        let mut models = vec![(f64::NEG_INFINITY, self.clone(), 0.0)];
        // What the motion starts with, it carried before its time 0 too.
        for e in &carried_from_before(events, 0.0) {
            let model = match (&e.payload, base) {
                (Some(p), Some(base)) => self.with_payload_on(base, robot, p, efficiency)?,
                _ => self.clone(),
            };
            let mass = e.payload.as_ref().map_or(0.0, |p| p.inertia.mass);
            models.push((e.t_s, model, mass));
        }
        Ok(models)
    }

    /// A moving joint's expected squared torque beyond its expected torque squared for a
    /// Coulomb sign `s` in (-1, 1) the motion is unsure of (N^2 m^2): the expected torque has
    /// `fc s`, and its expected square is `fc^2 (1 - s^2)` more. `k`: the Coulomb
    /// parameter's index in `theta`; 0 at rest.
    fn unsure_sign(&self, k: usize, s: f64, dq: f64) -> f64 {
        if sign(dq) != 0.0 {
            self.theta[k].powi(2) * (1.0 - s * s)
        } else {
            0.0
        }
    }
}

/// One state's joint quantities in [`PowerModel::each_state`], one entry per joint.
struct Joints {
    /// Positions, rad.
    q: Vec<f64>,
    /// Speeds, rad/s.
    dq: Vec<f64>,
    /// Accelerations, rad/s^2.
    ddq: Vec<f64>,
    /// Expected Coulomb signs.
    signs: Vec<f64>,
    /// Factors of the model's Coulomb law ([`PowerModel::coulomb_factor`]).
    factor: Vec<f64>,
    /// Variance an unsure Coulomb sign adds to the squared torque, N^2 m^2.
    unsure: Vec<f64>,
    /// Torques of the model in force (N m, or N m / eta when efficiency-scaled).
    tau: Vec<f64>,
    /// `d p / d tau` of each motor under the model in force, rad/s.
    dp_dtau: Vec<f64>,
    /// Each motor's power under the model in force, W.
    own: Vec<f64>,
    /// Each motor's predicted power, W: `own`, or its mean with the alternative's.
    p: Vec<f64>,
}

impl Joints {
    fn new(n: usize) -> Joints {
        let zeros = vec![0.0; n];
        Joints {
            q: zeros.clone(),
            dq: zeros.clone(),
            ddq: zeros.clone(),
            signs: zeros.clone(),
            factor: vec![1.0; n],
            unsure: zeros.clone(),
            tau: zeros.clone(),
            dp_dtau: zeros.clone(),
            own: zeros.clone(),
            p: zeros,
        }
    }
}

/// One state evaluated by [`PowerModel::each_state`].
pub(super) struct StateEval<'a> {
    /// Predicted power of each motor, W (the mean of the two friction structures' where the
    /// model has an alternative).
    pub(super) p: &'a [f64],
    /// Each motor's torque under the model in force (N m, or N m / eta when
    /// efficiency-scaled).
    pub(super) tau: &'a [f64],
    /// Each motor's `d p / d tau` (rad/s): the speed, the copper loss's `2 c tau` and the
    /// gear friction's `g sign(dq tau) dq`.
    pub(super) dp_dtau: &'a [f64],
    /// Each motor's expected squared torque beyond its expected torque squared (N^2 m^2):
    /// `fc^2 (1 - s^2)` for a Coulomb sign `s` the motion is unsure of.
    pub(super) unsure: &'a [f64],
    /// Full regressor at the state.
    pub(super) w: &'a DMatrix<f64>,
    /// Joint speeds, rad/s.
    pub(super) dq: &'a [f64],
    /// The model in force (with the payload then attached).
    pub(super) model: &'a PowerModel,
    /// Mass of the payload then attached, kg (0 without one).
    pub(super) payload_kg: f64,
    /// Total power of the alternative model at the state (with the same payload), W; `None`
    /// without one.
    pub(super) alternative_p: Option<f64>,
    /// Total power of the model in force at the state with the whole of the drive file's
    /// Stribeck rise ([`PowerModel::stribeck`]), W; `None` without one.
    pub(super) stribeck_p: Option<f64>,
}

/// The model in force at time `t` (s) of a list from [`PowerModel::payload_models`], with its
/// payload's mass, kg.
fn in_force(models: &[(f64, PowerModel, f64)], t: f64) -> (&PowerModel, f64) {
    models
        .iter()
        .rev()
        .find(|(from, _, _)| *from <= t)
        .map_or((&models[0].1, 0.0), |(_, m, kg)| (m, *kg))
}
