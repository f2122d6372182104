//! The robot as a Rapier reduced-coordinate multibody (`rapier3d-f64`).
//!
//! Every link is a dynamic body whose frame is the model's MDH link frame, carrying the link's
//! mass properties (no colliders, self-contacts off, no sleeping). Joint `i` is a multibody
//! revolute joint whose free axis is the link frame's z, so Rapier's joint coordinate is the
//! model's `q_i` (rad), kept half a substep ahead of the velocities ([`RapierRobot::state`]).
//! Drive effects are injected into the physics per degree of freedom: the rotor inertia
//! reflected to the link side as armature (added to the mass matrix), viscous friction as a
//! torque at the predicted mid-step speed (Rapier's implicit damping only where the rotor
//! inertia is too small for that to be stable), and Coulomb friction in two ways (see
//! [`RapierRobot::step`]). Rapier's default joint damping is removed.
//!
//! **Accuracy per substep.** Both choices make the step second order where Rapier's own
//! reading is first order: at 1 substep the worst joint's torque residual against exact
//! inverse dynamics is about 0.011 % instead of 0.097 % (implicit damping, positions read at
//! the start of the kick), so one substep per 1 ms step suffices (docs/design/twin-profile.md).
//!
//! **Coulomb friction.** A joint that slides through the whole step (its speed keeps its sign
//! over it, judged from the speed now and the acceleration of the last step) feels its dry
//! friction as an exact torque `-fc sign(dq)` held over the step, beside the motor torque. Any
//! other joint (at rest, creeping, or reversing within the step) keeps Rapier's friction-loss
//! constraint, which holds it with true stiction. The constraint alone, sliding or not, leaves
//! a smooth first-order error in the joint torques, which the exact sliding torque removes
//! (see docs/experiments.md#exact-sliding-friction). Fewer constraint rows also converge
//! better: a joint held by stiction while others move stays put, where the coupled rows (one
//! Gauss-Seidel sweep per substep) let it creep.
//!
//! Joint torques are applied exactly as equal and opposite body torques about the joint axis
//! on the child and parent links, re-set every step: Rapier maps body wrenches through the
//! body Jacobians, so the pair acts on that joint's degree of freedom only
//! (`docs/design/rapier-multibody.md`, section 2).
//!
//! Units: SI (m, rad, kg, kg m^2, N m, s); gravity -9.81 m/s^2 along the base z.

use nalgebra::{Isometry3, Vector3};
use rapier3d_f64::math::{Matrix, Pose, Rotation, Vector};
use rapier3d_f64::prelude::{
    GenericJointBuilder, JointAxesMask, MassProperties, Multibody, MultibodyIndex, PhysicsWorld,
    RigidBodyBuilder, RigidBodyHandle,
};

use crate::dynamics::{DriveTerms, GRAVITY};
use crate::error::{Error, Result};
use crate::model::{RigidInertia, Robot};

/// Integration settings of the physics.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhysicsSettings {
    /// Step of the simulation (controller period; torques are held over it), s.
    #[serde(rename = "dt_s")]
    pub dt: f64,
    /// Rapier substeps per step (`num_solver_iterations`): the integration step is `dt / substeps`.
    pub substeps: usize,
}

impl Default for PhysicsSettings {
    fn default() -> Self {
        PhysicsSettings {
            dt: 1e-3,
            substeps: 1,
        }
    }
}

impl PhysicsSettings {
    /// Check the settings: positive finite `dt` up to 0.1 s, 1..=64 substeps.
    pub fn validate(&self) -> Result<()> {
        if !(self.dt.is_finite() && self.dt > 0.0 && self.dt <= 0.1) {
            return Err(Error::InvalidInput(format!(
                "physics step dt = {} s must be in (0, 0.1]",
                self.dt
            )));
        }
        if !(1..=64).contains(&self.substeps) {
            return Err(Error::InvalidInput(format!(
                "substeps = {} must be in 1..=64",
                self.substeps
            )));
        }
        Ok(())
    }
}

/// Speed (rad/s) at or below which a joint never counts as sliding: its dry friction stays
/// Rapier's friction-loss constraint (stiction). Far below any speed a drive moves at, far
/// above the creep of a joint the constraint holds (about 1e-5 rad/s).
const SLIDING_SPEED: f64 = 1e-3;

/// Gauss-Seidel sweeps per step (at least) over the friction-loss rows of the joints held by
/// stiction: `num_internal_pgs_iterations = ceil(STICTION_SWEEPS / substeps)`. One sweep per
/// substep lets a held joint creep (docs/design/rapier-multibody.md, section 3); six sweeps
/// per step is what the former default of 6 substeps gave. Only those rows pay for it.
const STICTION_SWEEPS: usize = 6;

/// Largest `dt fv / Ia` (step times viscous friction over rotor inertia) at which a joint's
/// viscous friction is an explicit torque at the predicted mid-step speed: far inside the
/// explicit scheme's stability bound (2, with the link inertia only adding margin). Above it
/// Rapier's implicit damping carries it (unconditionally stable, first-order error).
const EXPLICIT_DAMPING: f64 = 0.5;

/// The Rapier world holding one robot.
pub struct RapierRobot {
    world: PhysicsWorld,
    links: Vec<RigidBodyHandle>,
    multibody: MultibodyIndex,
    /// Multibody link id of each joint's child body.
    link_ids: Vec<usize>,
    /// Index of each joint in Rapier's generalized coordinates.
    dofs: Vec<usize>,
    /// Step, s.
    dt: f64,
    /// How far Rapier's positions run ahead of its velocities, s: half a substep (see
    /// [`RapierRobot::state`]).
    lead: f64,
    /// Dry friction of each joint, N m (>= 0).
    coulomb: Vec<f64>,
    /// Viscous friction applied as an explicit torque at the predicted mid-step speed,
    /// N m s/rad, per joint; 0 where Rapier's implicit damping carries it instead.
    viscous: Vec<f64>,
    /// Joint speeds at the start of the last step (rad/s), for the acceleration that decides
    /// whether a joint slides through the next; `None` right after a teleport.
    last_dq: Option<Vec<f64>>,
    /// Scratch: positions, speeds and the torques handed to Rapier.
    scratch: [Vec<f64>; 3],
}

fn vec(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

fn pose(iso: &Isometry3<f64>) -> Pose {
    let q = iso.rotation.coords;
    Pose::from_parts(
        vec(&iso.translation.vector),
        Rotation::from_xyzw(q.x, q.y, q.z, q.w),
    )
}

fn mass_properties(i: &RigidInertia) -> MassProperties {
    let m = &i.inertia_com;
    let inertia = Matrix::from_cols(
        Vector::new(m[(0, 0)], m[(1, 0)], m[(2, 0)]),
        Vector::new(m[(0, 1)], m[(1, 1)], m[(2, 1)]),
        Vector::new(m[(0, 2)], m[(1, 2)], m[(2, 2)]),
    );
    MassProperties::with_inertia_matrix(vec(&i.com), i.mass, inertia)
}

/// Check that `drive` has `n` finite non-negative values of each term.
fn check_drive(drive: &DriveTerms, n: usize) -> Result<()> {
    for (name, v) in [
        ("rotor_inertia", &drive.rotor_inertia),
        ("viscous", &drive.viscous),
        ("coulomb", &drive.coulomb),
    ] {
        if v.len() != n || v.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(Error::InvalidInput(format!(
                "drive {name} must have {n} finite non-negative values"
            )));
        }
    }
    Ok(())
}

/// Put the drive terms into the multibody's per-DoF data (`dofs[i]`: joint `i`'s index):
/// rotor inertia as armature, dry friction as the friction-loss bound, viscous friction as
/// Rapier damping only where `dt fv > EXPLICIT_DAMPING Ia` (`dt` in s); Rapier's default
/// damping removed. Returns the viscous friction (N m s/rad) the step applies as a torque
/// instead, 0 where Rapier's damping carries it.
fn inject_drive(mb: &mut Multibody, dofs: &[usize], drive: &DriveTerms, dt: f64) -> Vec<f64> {
    mb.damping_mut().fill(0.0);
    let mut viscous = vec![0.0; dofs.len()];
    for (i, &d) in dofs.iter().enumerate() {
        if drive.viscous[i] * dt <= EXPLICIT_DAMPING * drive.rotor_inertia[i] {
            viscous[i] = drive.viscous[i];
        } else {
            mb.damping_mut()[d] = drive.viscous[i];
        }
        mb.frictions_mut()[d] = drive.coulomb[i];
        mb.armature_mut()[d] = drive.rotor_inertia[i];
    }
    viscous
}

/// A world without bodies, stepping by `settings`, gravity along -z.
fn empty_world(settings: &PhysicsSettings) -> PhysicsWorld {
    let mut world = PhysicsWorld::new();
    world.gravity = vec(&GRAVITY);
    let params = &mut world.integration_parameters;
    params.dt = settings.dt;
    params.num_solver_iterations = settings.substeps;
    // No colliders, so nothing for continuous collision detection to do: skip its per-step
    // motion test.
    params.max_ccd_substeps = 0;
    params.num_internal_pgs_iterations = STICTION_SWEEPS.div_ceil(settings.substeps);
    world
}

impl RapierRobot {
    /// Build the multibody of `robot` with the drive terms `drive` injected, at `q = 0`, at rest.
    pub fn new(robot: &Robot, drive: &DriveTerms, settings: &PhysicsSettings) -> Result<Self> {
        settings.validate()?;
        let n = robot.dof();
        check_drive(drive, n)?;
        let mut world = empty_world(settings);
        let base = world.insert_body(RigidBodyBuilder::fixed());
        // The free degree of freedom of a revolute multibody joint is the joint frame's x axis;
        // `r` turns it onto the link frame's z axis.
        let r = Rotation::from_rotation_arc(Vector::X, Vector::Z);
        let mut parent = base;
        let mut links = Vec::with_capacity(n);
        for (joint, link) in robot.joints().iter().zip(robot.links()) {
            let body = world.insert_body(
                RigidBodyBuilder::dynamic()
                    .additional_mass_properties(mass_properties(&link.inertia))
                    .can_sleep(false),
            );
            let frame1 = pose(&joint.origin);
            let rapier_joint = GenericJointBuilder::new(JointAxesMask::LOCKED_REVOLUTE_AXES)
                .local_frame1(Pose::from_parts(frame1.translation, frame1.rotation * r))
                .local_frame2(Pose::from_rotation(r))
                .contacts_enabled(false)
                .build();
            world
                .multibody_joints
                .insert(parent, body, rapier_joint, true)
                .ok_or_else(|| {
                    Error::Model(format!("Rapier refused the joint '{}'", joint.name))
                })?;
            links.push(body);
            parent = body;
        }
        let link_of = |h: RigidBodyHandle| {
            world
                .multibody_joints
                .rigid_body_link(h)
                .copied()
                .ok_or_else(|| Error::Model("a link is not part of the multibody".into()))
        };
        let multibody = link_of(links[0])?.multibody;
        let link_ids = links
            .iter()
            .map(|h| link_of(*h).map(|l| l.id))
            .collect::<Result<Vec<_>>>()?;
        let mb = world
            .multibody_joints
            .get_multibody_mut(multibody)
            .ok_or_else(|| Error::Model("multibody missing".into()))?;
        // Until the first forward kinematics the fixed root is a free 6-DoF body.
        mb.forward_kinematics(&world.bodies, true);
        mb.set_self_contacts_enabled(false);
        let dofs = link_ids
            .iter()
            .map(|id| mb.link(*id).map(|l| l.assembly_id()))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| Error::Model("multibody link missing".into()))?;
        if mb.ndofs() != n {
            return Err(Error::Model(format!(
                "Rapier multibody has {} degrees of freedom, the robot {n}",
                mb.ndofs()
            )));
        }
        let viscous = inject_drive(mb, &dofs, drive, settings.dt);
        Ok(RapierRobot {
            world,
            links,
            multibody,
            link_ids,
            dofs,
            dt: settings.dt,
            lead: 0.5 * settings.dt / settings.substeps as f64,
            coulomb: drive.coulomb.clone(),
            viscous,
            last_dq: None,
            scratch: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        })
    }

    fn mb(&self) -> &Multibody {
        self.world
            .multibody_joints
            .get_multibody(self.multibody)
            .expect("the multibody exists for the lifetime of RapierRobot")
    }

    /// Number of joints.
    pub fn dof(&self) -> usize {
        self.links.len()
    }

    /// Rapier's joint coordinates (rad) and velocities (rad/s) as it holds them.
    fn raw_state(&self, q: &mut [f64], dq: &mut [f64]) {
        let mb = self.mb();
        let v = mb.generalized_velocity();
        for i in 0..self.dof() {
            q[i] = mb
                .link(self.link_ids[i])
                .map_or(f64::NAN, |l| l.joint().coords()[3]);
            dq[i] = v[self.dofs[i]];
        }
    }

    /// Joint positions (rad) and velocities (rad/s) now.
    ///
    /// Rapier's substep is symplectic Euler: a kick `v += h a(q, v)` at the positions, then a
    /// drift `q += h v`. Read on a staggered grid, that is the second-order leapfrog: the
    /// velocity after a substep is the mean over it (the velocity at its middle), and each
    /// kick acts at the middle of the interval its torque is held over. So Rapier's positions
    /// are kept half a substep `h / 2` ahead of its velocities: the joint position at the
    /// step's time is Rapier's coordinate less `h / 2` times its velocity
    /// (see docs/experiments.md#leapfrog-reading).
    pub fn state(&self, q: &mut [f64], dq: &mut [f64]) {
        self.raw_state(q, dq);
        for (q, dq) in q.iter_mut().zip(dq.iter()) {
            *q -= self.lead * dq;
        }
    }

    /// Teleport the robot to `(q, dq)` (rad, rad/s).
    pub fn set_state(&mut self, q: &[f64], dq: &[f64]) {
        let n = self.dof();
        let mut cur_q = vec![0.0; n];
        let mut cur_dq = vec![0.0; n];
        self.raw_state(&mut cur_q, &mut cur_dq);
        let mut disp = vec![0.0; n];
        for i in 0..n {
            disp[self.dofs[i]] = q[i] + self.lead * dq[i] - cur_q[i];
        }
        let multibody = self.multibody;
        let world = &mut self.world;
        let mb = world
            .multibody_joints
            .get_multibody_mut(multibody)
            .expect("the multibody exists for the lifetime of RapierRobot");
        mb.apply_displacements(&disp);
        mb.forward_kinematics(&world.bodies, false);
        mb.update_rigid_bodies(&mut world.bodies, true);
        let mut v = mb.generalized_velocity_mut();
        for i in 0..n {
            v[self.dofs[i]] = dq[i];
        }
        self.last_dq = None;
    }

    /// Replace the mass properties of the last link (e.g. at a pick or release); `inertia`
    /// is in the last link frame. Takes effect at the next step.
    pub fn set_last_link_inertia(&mut self, inertia: &RigidInertia) {
        let h = self.links[self.links.len() - 1];
        if let Some(body) = self.world.bodies.get_mut(h) {
            body.set_additional_mass_properties(mass_properties(inertia), true);
        }
    }

    /// Set the dry friction of joint `i` (N m, >= 0) for the next steps: how a realistic twin
    /// makes friction depend on speed (Stribeck) and load (gear friction), still dissipated by
    /// the physics.
    pub fn set_coulomb(&mut self, i: usize, coulomb: f64) {
        self.coulomb[i] = coulomb.max(0.0);
    }

    /// Advance one step `dt` holding the motor torques `tau` (N m) against the joints' dry and
    /// viscous friction. The viscous torque is `-fv (v + a dt / 2)`, at the speed predicted for
    /// the step's middle (where the joint's `fv dt` is small against its rotor inertia). A joint whose speed `v` (rad/s) is above `SLIDING_SPEED` (1e-3) and keeps its
    /// sign two steps ahead at the last step's acceleration `a` (`v (v + 2 a dt) > 0`) slides:
    /// its friction is the torque `-fc sign(v)` added to `tau`. The others get the
    /// friction-loss constraint of bound `fc` (stiction; Rapier decides the torque).
    pub fn step(&mut self, tau: &[f64]) {
        let n = self.dof();
        let [mut q, mut v, mut applied] = std::mem::take(&mut self.scratch);
        self.state(&mut q, &mut v);
        let mb = self
            .world
            .multibody_joints
            .get_multibody_mut(self.multibody)
            .expect("the multibody exists for the lifetime of RapierRobot");
        for i in 0..n {
            let a = self
                .last_dq
                .as_ref()
                .map_or(0.0, |last| (v[i] - last[i]) / self.dt);
            let sliding = v[i].abs() > SLIDING_SPEED && v[i] * (v[i] + 2.0 * a * self.dt) > 0.0;
            let fc = self.coulomb[i];
            mb.frictions_mut()[self.dofs[i]] = if sliding { 0.0 } else { fc };
            applied[i] = if sliding {
                tau[i] - fc * v[i].signum()
            } else {
                tau[i]
            } - self.viscous[i] * (v[i] + 0.5 * a * self.dt);
        }
        match &mut self.last_dq {
            Some(last) => last.copy_from_slice(&v),
            None => self.last_dq = Some(v.clone()),
        }
        let bodies = &mut self.world.bodies;
        for h in &self.links {
            if let Some(b) = bodies.get_mut(*h) {
                b.reset_torques(false);
            }
        }
        for (i, &t) in applied.iter().enumerate() {
            let child = self.links[i];
            let Some(body) = bodies.get_mut(child) else {
                continue;
            };
            let axis = body.position().rotation * Vector::Z;
            body.add_torque(axis * t, true);
            if i > 0
                && let Some(parent) = bodies.get_mut(self.links[i - 1])
            {
                parent.add_torque(axis * -t, true);
            }
        }
        self.world.step();
        self.scratch = [q, v, applied];
    }
}
