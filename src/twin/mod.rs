//! The digital twin: a Rapier reduced-coordinate multibody of the robot model
//! ([`physics`]) with drive friction and rotor inertia injected into the physics, tracked by
//! a computed-torque controller ([`controller`]). Motor power comes from the torque applied
//! to Rapier and the motion Rapier produced, through a motor model ([`motor`]); never from
//! the inverse-dynamics model evaluated on the reference. [`sensor`] turns the truth into a
//! logged, noisy measurement stream.
//!
//! # Start
//! A run that starts at rest begins as a real log does: the arm has stood servoed at the first
//! pose for [`TwinConfig::settle_s`] before the first row, so its controller's tracking error
//! has balanced the true gravity (or stiction holds the joint where the controller's torque
//! left it), rather than starting from zero tracking error with the nominal model's torque.
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

use crate::dynamics::{DriveTerms, REST_SPEED_EPS};
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
    /// How long the arm stands servoed at its first pose before a run that starts at rest
    /// records, s: as a robot stands before its log begins, so the holding torque it records
    /// first is the true gravity's (where stiction does not hold the joint), not the
    /// controller's nominal model's. The default, 0.5 s, is ten time constants of the default
    /// gains (critically damped at 20 rad/s) and more of a family robot's stiffer ones.
    #[serde(rename = "settle_s", default = "default_settle_s")]
    pub settle_s: f64,
}

fn default_settle_s() -> f64 {
    0.5
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
            settle_s: default_settle_s(),
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
    /// settings, a nominal-model error that is not finite and in [0, 1), a cabinet power or a
    /// settling time that is not finite and >= 0, or drives of another joint count.
    pub fn new(robot: &'a Robot, drive: &'a Drive, config: TwinConfig) -> Result<Self> {
        config.physics.validate()?;
        if !(config.cabinet_power_w.is_finite() && config.cabinet_power_w >= 0.0) {
            return Err(Error::InvalidInput(format!(
                "cabinet power {} W must be finite and >= 0",
                config.cabinet_power_w
            )));
        }
        if !(config.settle_s.is_finite() && config.settle_s >= 0.0) {
            return Err(Error::InvalidInput(format!(
                "settling time {} s before a run must be finite and >= 0",
                config.settle_s
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

    /// Simulate tracking `traj` from rest at its start (where the arm first stands servoed at
    /// the start pose for [`TwinConfig::settle_s`]), with payload changes `events`
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
        let brakes_mode = self.check_run(traj, events, brakes)?;
        let n = self.robot.dof();
        let cfg = &self.config;
        let dt = cfg.physics.dt;
        let truth_terms = DriveTerms::from(self.drive);
        let sim = RapierRobot::new(self.robot, &truth_terms, &cfg.physics)?;
        let (nominal, nominal_terms) = perturbed(
            self.robot,
            &truth_terms,
            cfg.nominal_error,
            cfg.nominal_seed,
        )?;
        let mut payloads = Payloads::new(nominal.links()[n - 1].inertia);
        let ctrl = Controller::new(nominal, nominal_terms, cfg.gains);
        let mut arm = Arm::new(sim, ctrl, self.drive, cfg.fidelity == Fidelity::Realistic);
        let steps = (traj.duration() / dt).floor() as usize;
        let mut rec = Recording::with_capacity(n, steps, dt);
        let (mut q, mut dq, mut q_next, mut dq_next) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let (mut qr, mut dqr, mut ddqr, mut tau) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        traj.sample(0.0, &mut qr, &mut dqr, &mut ddqr);
        arm.sim.set_state(&qr, &dqr);
        payloads.apply(self, &mut arm, events, 0.0, dt)?;
        if dqr.iter().all(|v| v.abs() <= REST_SPEED_EPS) {
            arm.settle(&qr, cfg.settle_s, dt)?;
        }
        let mut hits: Vec<Option<TorqueLimitHit>> = vec![None; n];
        let mut max_err: f64 = 0.0;
        arm.sim.state(&mut q, &mut dq);
        for k in 0..steps {
            let t = k as f64 * dt;
            payloads.apply(self, &mut arm, events, t, dt)?;
            traj.sample(t, &mut qr, &mut dqr, &mut ddqr);
            let next = [q_next.as_mut_slice(), dq_next.as_mut_slice()];
            let clipped = arm.step(t, [&q, &dq], [&qr, &dqr, &ddqr], &mut tau, next)?;
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
                let p_elec = self.electrical_power(i, tau[i], speed, braked);
                p_total += p_elec;
                rec.q[i].push(q[i]);
                rec.dq[i].push(dq[i]);
                rec.q_ref[i].push(qr[i]);
                rec.dq_ref[i].push(dqr[i]);
                rec.ddq_ref[i].push(ddqr[i]);
                rec.tau[i].push(tau[i]);
                rec.p_mech[i].push(tau[i] * speed);
                rec.p_elec[i].push(p_elec);
            }
            rec.t.push(t);
            rec.p_total.push(p_total + cfg.cabinet_power_w);
            rec.p_grid.push(p_total.max(0.0) + cfg.cabinet_power_w);
            rec.payload_mass.push(payloads.mass);
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

    /// The checks of [`Twin::run`]'s inputs; the drive's brakes-applied mode when the run
    /// holds the arm with its brakes.
    fn check_run(
        &self,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        brakes: &[BrakeWindow],
    ) -> Result<Option<&'a Brakes>> {
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
        match (brakes.is_empty(), self.drive.brakes()) {
            (true, _) => Ok(None),
            (false, Some(b)) => Ok(Some(b)),
            (false, None) => Err(Error::InvalidInput(
                "the run holds the arm with its brakes, but the drive file gives no \
                 brakes-applied mode ([brakes])"
                    .into(),
            )),
        }
    }

    /// Electrical power (W) of motor `i` applying `tau` (N m) at joint speed `speed` (rad/s)
    /// over a step: the motor model (plus iron loss at realistic fidelity), or its share of
    /// the brakes-applied power while `braked`.
    fn electrical_power(&self, i: usize, tau: f64, speed: f64, braked: Option<&Brakes>) -> f64 {
        let cfg = &self.config;
        let joint = &self.drive.joints()[i];
        match braked {
            Some(b) => b.power_w / self.robot.dof() as f64,
            None => {
                let mut p = cfg.motor.electrical_power(joint, tau, tau * speed);
                if cfg.fidelity == Fidelity::Realistic {
                    p += joint.unmodelled.iron_loss(speed);
                }
                p
            }
        }
    }
}

/// The payload timeline of a run as it plays: the next event and the mass on the flange.
struct Payloads {
    /// Index of the next event to apply.
    next: usize,
    /// Payload mass on the flange, kg.
    mass: f64,
    /// The controller's nominal last link without a payload.
    nominal_last: RigidInertia,
}

impl Payloads {
    fn new(nominal_last: RigidInertia) -> Self {
        Payloads {
            next: 0,
            mass: 0.0,
            nominal_last,
        }
    }

    /// Apply the `events` due by time `t` (s; within half a step `dt`) to the physics and to
    /// the controller's nominal model (the controller is told the payload).
    fn apply(
        &mut self,
        twin: &Twin,
        arm: &mut Arm,
        events: &[PayloadEvent],
        t: f64,
        dt: f64,
    ) -> Result<()> {
        while self.next < events.len() && events[self.next].t_s <= t + 0.5 * dt {
            let p = events[self.next].payload.as_ref();
            arm.sim.set_last_link_inertia(&twin.last_link(p));
            let nominal_with = match p {
                Some(p) => self
                    .nominal_last
                    .combined(&p.in_last_link_frame(twin.robot)),
                None => self.nominal_last,
            };
            arm.ctrl.set_last_link_inertia(nominal_with)?;
            self.mass = p.map_or(0.0, |p| p.inertia.mass);
            self.next += 1;
        }
        Ok(())
    }
}

/// The simulated arm under its controller: one control step at a time.
struct Arm<'d> {
    sim: RapierRobot,
    ctrl: Controller,
    drive: &'d Drive,
    /// Whether the drives' unmodelled effects act ([`Fidelity::Realistic`]).
    realistic: bool,
}

impl<'d> Arm<'d> {
    fn new(sim: RapierRobot, ctrl: Controller, drive: &'d Drive, realistic: bool) -> Self {
        Arm {
            sim,
            ctrl,
            drive,
            realistic,
        }
    }

    /// One control step at time `t` (s) from the state `[q, dq]` (rad, rad/s) toward the
    /// reference `[q_ref, dq_ref, ddq_ref]`: the controller's torque (N m) into `tau`, held
    /// over the step, and the state after it into `next`. Returns the controller's clip mask.
    /// Errors: a non-finite torque or a diverging simulation.
    fn step(
        &mut self,
        t: f64,
        state: [&[f64]; 2],
        refs: [&[f64]; 3],
        tau: &mut [f64],
        next: [&mut [f64]; 2],
    ) -> Result<u64> {
        let [q, dq] = state;
        let [qr, dqr, ddqr] = refs;
        let clipped = self.ctrl.torque(q, dq, qr, dqr, ddqr, tau);
        if tau.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical(format!(
                "the controller produced a non-finite torque at t = {t:.4} s"
            )));
        }
        if self.realistic {
            for (i, d) in self.drive.joints().iter().enumerate() {
                self.sim
                    .set_coulomb(i, d.unmodelled.friction(d.friction.coulomb, dq[i], tau[i]));
            }
        }
        self.sim.step(tau);
        let [q_next, dq_next] = next;
        self.sim.state(q_next, dq_next);
        if q_next.iter().chain(dq_next.iter()).any(|v| !v.is_finite()) {
            return Err(Error::Numerical(format!(
                "the simulation diverged at t = {t:.4} s"
            )));
        }
        Ok(clipped)
    }

    /// Hold the reference `q_ref` (rad) at rest for `duration` (s) in steps of `dt` (s), so
    /// the controller's tracking error balances the true gravity before the recording starts.
    fn settle(&mut self, q_ref: &[f64], duration: f64, dt: f64) -> Result<()> {
        let n = q_ref.len();
        let zero = vec![0.0; n];
        let (mut q, mut dq, mut tau) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let (mut q_next, mut dq_next) = (vec![0.0; n], vec![0.0; n]);
        self.sim.state(&mut q, &mut dq);
        let steps = (duration / dt).round() as usize;
        for k in 0..steps {
            let t = (k as f64 - steps as f64) * dt;
            let next = [q_next.as_mut_slice(), dq_next.as_mut_slice()];
            self.step(t, [&q, &dq], [q_ref, &zero, &zero], &mut tau, next)?;
            std::mem::swap(&mut q, &mut q_next);
            std::mem::swap(&mut dq, &mut dq_next);
        }
        Ok(())
    }
}
