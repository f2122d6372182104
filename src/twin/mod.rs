//! The digital twin: a Rapier reduced-coordinate multibody of the robot model
//! ([`physics`]) with drive friction and rotor inertia injected into the physics, tracked by
//! a computed-torque controller ([`controller`]). Motor power comes from the torque applied
//! to Rapier and the motion Rapier produced, through a motor model ([`motor`]); never from
//! the inverse-dynamics model evaluated on the reference. [`sensor`] turns the truth into a
//! logged, noisy measurement stream.
//!
//! # Brakes
//! A run may hold the arm with its brakes during [`BrakeWindow`]s (only while the reference
//! stands still, and only with a drive file that gives the brakes-applied mode, [`Brakes`]).
//! The motors then draw no current: every joint records `power_W / n` of the brakes-applied
//! power and no copper, standby or iron loss. The joints do not move either way; the physics
//! keeps applying the controller's holding torque, which stands in for the brakes' torque.
//!
//! Energy is integrated consistently with how torque is applied: torque is held over each
//! step (zero-order hold), so joint work over step `k` is `tau_k (q_{k+1} - q_k)` exactly,
//! and the recorded power is that work divided by `dt`.

pub mod controller;
pub mod family;
pub mod motor;
pub mod physics;
pub mod record;
pub mod sensor;

use serde::{Deserialize, Serialize};

use crate::dynamics::DriveTerms;
use crate::error::{Error, Result};
use crate::model::drive::{BrakeWindow, Brakes, Drive};
use crate::model::payload::{Payload, PayloadEvent};
use crate::model::{RigidInertia, Robot};
use crate::trajectory::Trajectory;
use controller::{Controller, Gains, perturbed};
use motor::MotorModel;
use physics::{PhysicsSettings, RapierRobot};
use record::Recording;

/// How much of the real robot the twin simulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Fidelity {
    /// The structure an identified model has: rigid bodies, Coulomb and viscous friction,
    /// rotor inertia, and the motor model.
    #[default]
    Exact,
    /// Also the drives' [`crate::model::drive::Unmodelled`] effects: Stribeck and
    /// load-dependent gear friction in the physics, iron loss in the motors.
    Realistic,
}

impl std::str::FromStr for Fidelity {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "exact" => Ok(Fidelity::Exact),
            "realistic" => Ok(Fidelity::Realistic),
            other => Err(Error::InvalidInput(format!(
                "unknown twin fidelity '{other}' (expected exact or realistic)"
            ))),
        }
    }
}

/// Settings of a twin run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwinConfig {
    /// Physics step and substeps.
    pub physics: PhysicsSettings,
    /// Controller gains.
    pub gains: Gains,
    /// Motor model for electrical power.
    pub motor: MotorModel,
    /// Relative error of the controller's nominal model (0 = the true model).
    #[serde(rename = "nominal_error_rel")]
    pub nominal_error: f64,
    /// Seed of the nominal-model perturbation.
    pub nominal_seed: u64,
    /// Which effects the twin simulates.
    #[serde(default)]
    pub fidelity: Fidelity,
    /// Power of the controller cabinet (fans, computer, the drives' logic supply) that the
    /// power meter also measures, W: added to the logged signal after the DC bus's clip. 0
    /// when the meter does not see it (a meter on the DC bus).
    #[serde(
        rename = "cabinet_power_W",
        default,
        skip_serializing_if = "sensor::is_zero"
    )]
    pub cabinet_power_w: f64,
}

impl Default for TwinConfig {
    fn default() -> Self {
        TwinConfig {
            physics: PhysicsSettings::default(),
            gains: Gains::default(),
            motor: MotorModel::Pmsm,
            nominal_error: 0.0,
            nominal_seed: 0,
            fidelity: Fidelity::Exact,
            cabinet_power_w: 0.0,
        }
    }
}

/// Joints whose torque command hit the effort limit during a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TorqueLimitHit {
    /// Joint name.
    pub joint: String,
    /// First time the limit was hit, s.
    pub first_t_s: f64,
    /// Number of steps clipped.
    pub steps: usize,
}

/// Summary of a run besides the recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunReport {
    /// Largest |q_ref - q| over the run and joints, rad.
    pub max_tracking_error_rad: f64,
    /// Joints that hit their torque limit.
    pub torque_limit_hits: Vec<TorqueLimitHit>,
}

/// The twin of one robot with its drives.
pub struct Twin<'a> {
    robot: &'a Robot,
    drive: &'a Drive,
    config: TwinConfig,
}

impl<'a> Twin<'a> {
    /// A twin of `robot` with true drive parameters `drive`. Errors: invalid physics
    /// settings, a nominal-model error that is not finite and in [0, 1), a cabinet power that
    /// is not finite and >= 0, or drives of another joint count.
    pub fn new(robot: &'a Robot, drive: &'a Drive, config: TwinConfig) -> Result<Self> {
        config.physics.validate()?;
        if !(config.cabinet_power_w.is_finite() && config.cabinet_power_w >= 0.0) {
            return Err(Error::InvalidInput(format!(
                "cabinet power {} W must be finite and >= 0",
                config.cabinet_power_w
            )));
        }
        if !(config.nominal_error.is_finite() && (0.0..1.0).contains(&config.nominal_error)) {
            return Err(Error::InvalidInput(format!(
                "nominal model error {} must be finite and in [0, 1)",
                config.nominal_error
            )));
        }
        if drive.joints().len() != robot.dof() {
            return Err(Error::InvalidInput(format!(
                "drive has {} joints, robot {}",
                drive.joints().len(),
                robot.dof()
            )));
        }
        Ok(Twin {
            robot,
            drive,
            config,
        })
    }

    /// Last-link mass properties with `payload` attached.
    fn last_link(&self, payload: Option<&Payload>) -> RigidInertia {
        let last = &self.robot.links()[self.robot.dof() - 1].inertia;
        match payload {
            Some(p) => last.combined(&p.in_last_link_frame(self.robot)),
            None => *last,
        }
    }

    /// Simulate tracking `traj` from rest at its start, with payload changes `events`
    /// (sorted by time; an event at 0 sets the initial payload) and the brakes holding the arm
    /// during `brakes` (sorted, not overlapping; see the [module docs](self)).
    ///
    /// Errors: a trajectory of another joint count, unsorted or non-finite events or brake
    /// windows, brake windows without a brakes-applied mode in the drive file or while the
    /// reference moves ([`Error::InvalidInput`]); a non-finite torque or a diverging
    /// simulation ([`Error::Numerical`]).
    pub fn run(
        &self,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        brakes: &[BrakeWindow],
    ) -> Result<(Recording, RunReport)> {
        let n = self.robot.dof();
        if traj.dof() != n {
            return Err(Error::InvalidInput(format!(
                "trajectory has {} joints, robot {n}",
                traj.dof()
            )));
        }
        if events.windows(2).any(|w| w[1].t_s < w[0].t_s)
            || events.iter().any(|e| !e.t_s.is_finite())
        {
            return Err(Error::InvalidInput(
                "payload events must be finite and sorted by time".into(),
            ));
        }
        BrakeWindow::check_all(brakes)?;
        let brakes_mode: Option<&Brakes> = match (brakes.is_empty(), self.drive.brakes()) {
            (true, _) => None,
            (false, Some(b)) => Some(b),
            (false, None) => {
                return Err(Error::InvalidInput(
                    "the run holds the arm with its brakes, but the drive file gives no \
                     brakes-applied mode ([brakes])"
                        .into(),
                ));
            }
        };
        let cfg = &self.config;
        let dt = cfg.physics.dt;
        let truth_terms = DriveTerms::from(self.drive);
        let mut sim = RapierRobot::new(self.robot, &truth_terms, &cfg.physics)?;
        let (nominal, nominal_terms) = perturbed(
            self.robot,
            &truth_terms,
            cfg.nominal_error,
            cfg.nominal_seed,
        )?;
        let nominal_last = nominal.links()[n - 1].inertia;
        let mut ctrl = Controller::new(nominal, nominal_terms, cfg.gains);
        let steps = (traj.duration() / dt).floor() as usize;
        let mut rec = Recording {
            dt,
            ..Recording::default()
        };
        let per_joint = || vec![Vec::with_capacity(steps); n];
        rec.q = per_joint();
        rec.dq = per_joint();
        rec.q_ref = per_joint();
        rec.dq_ref = per_joint();
        rec.ddq_ref = per_joint();
        rec.tau = per_joint();
        rec.p_mech = per_joint();
        rec.p_elec = per_joint();
        let (mut q, mut dq, mut q_next, mut dq_next) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let (mut qr, mut dqr, mut ddqr, mut tau) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        traj.sample(0.0, &mut qr, &mut dqr, &mut ddqr);
        sim.set_state(&qr, &dqr);
        let mut next_event = 0;
        let mut payload_mass = 0.0;
        let mut hits: Vec<Option<TorqueLimitHit>> = vec![None; n];
        let mut max_err: f64 = 0.0;
        let realistic = cfg.fidelity == Fidelity::Realistic;
        let joints = self.drive.joints();
        sim.state(&mut q, &mut dq);
        for k in 0..steps {
            let t = k as f64 * dt;
            while next_event < events.len() && events[next_event].t_s <= t + 0.5 * dt {
                let p = events[next_event].payload.as_ref();
                sim.set_last_link_inertia(&self.last_link(p));
                let nominal_with = match p {
                    Some(p) => nominal_last.combined(&p.in_last_link_frame(self.robot)),
                    None => nominal_last,
                };
                ctrl.set_last_link_inertia(nominal_with)?;
                payload_mass = p.map_or(0.0, |p| p.inertia.mass);
                next_event += 1;
            }
            traj.sample(t, &mut qr, &mut dqr, &mut ddqr);
            let clipped = ctrl.torque(&q, &dq, &qr, &dqr, &ddqr, &mut tau);
            if tau.iter().any(|v| !v.is_finite()) {
                return Err(Error::Numerical(format!(
                    "the controller produced a non-finite torque at t = {t:.4} s"
                )));
            }
            if realistic {
                for (i, d) in joints.iter().enumerate() {
                    sim.set_coulomb(i, d.unmodelled.friction(d.friction.coulomb, dq[i], tau[i]));
                }
            }
            sim.step(&tau);
            sim.state(&mut q_next, &mut dq_next);
            if q_next.iter().chain(&dq_next).any(|v| !v.is_finite()) {
                return Err(Error::Numerical(format!(
                    "the simulation diverged at t = {t:.4} s"
                )));
            }
            let braked = brakes_mode.filter(|_| BrakeWindow::holds(brakes, t));
            if braked.is_some() && dqr.iter().chain(&ddqr).any(|v| v.abs() > 1e-9) {
                return Err(Error::InvalidInput(format!(
                    "the brakes hold at t = {t:.4} s while the reference moves"
                )));
            }
            let mut p_total = 0.0;
            for i in 0..n {
                max_err = max_err.max((qr[i] - q[i]).abs());
                if clipped & (1 << i) != 0 {
                    let h = hits[i].get_or_insert(TorqueLimitHit {
                        joint: self.robot.joints()[i].name.clone(),
                        first_t_s: t,
                        steps: 0,
                    });
                    h.steps += 1;
                }
                let speed = (q_next[i] - q[i]) / dt;
                let p_mech = tau[i] * speed;
                let p_elec = match braked {
                    Some(b) => b.power_w / n as f64,
                    None => {
                        let mut p = cfg.motor.electrical_power(&joints[i], tau[i], p_mech);
                        if realistic {
                            p += joints[i].unmodelled.iron_loss(speed);
                        }
                        p
                    }
                };
                p_total += p_elec;
                rec.q[i].push(q[i]);
                rec.dq[i].push(dq[i]);
                rec.q_ref[i].push(qr[i]);
                rec.dq_ref[i].push(dqr[i]);
                rec.ddq_ref[i].push(ddqr[i]);
                rec.tau[i].push(tau[i]);
                rec.p_mech[i].push(p_mech);
                rec.p_elec[i].push(p_elec);
            }
            rec.t.push(t);
            rec.p_total.push(p_total + cfg.cabinet_power_w);
            rec.p_grid.push(p_total.max(0.0) + cfg.cabinet_power_w);
            rec.payload_mass.push(payload_mass);
            std::mem::swap(&mut q, &mut q_next);
            std::mem::swap(&mut dq, &mut dq_next);
        }
        Ok((
            rec,
            RunReport {
                max_tracking_error_rad: max_err,
                torque_limit_hits: hits.into_iter().flatten().collect(),
            },
        ))
    }
}
