//! The robot model: a fixed-base serial chain of revolute joints with link mass properties,
//! limits, friction estimates and display geometry.
//!
//! # Frames
//! Frame 0 is the URDF root link frame (the robot base). Link frame `i` (1-based, moved by
//! joint `i`) has its z axis along joint `i`'s axis, positive in the URDF axis direction, and
//! is placed by modified Denavit–Hartenberg rules (x along the common normal to the next axis,
//! see [`frames`]). For the IRB 1200 these are exactly the paper's MDH frames (Table 1).
//! The pose of frame `i` in frame `i-1` is `origin_i * Rz(q_i)`. Joint coordinates are the
//! URDF's (rad), so `q = 0` is the URDF zero pose. The URDF's own link frames are kept
//! (`Link::urdf_pose`) for display and export.
//!
//! # Units
//! SI throughout: m, rad, kg, kg m^2, N m, s.

pub mod builtin;
pub mod drive;
pub mod export;
pub mod frames;
pub mod inertia;
pub mod payload;
pub mod sampling;
pub mod urdf;

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

use crate::error::{Error, Result};
pub use inertia::RigidInertia;

/// Position, velocity and effort limits of a joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimits {
    /// Lower position limit, rad (`-inf` for a continuous joint).
    pub lower: f64,
    /// Upper position limit, rad (`+inf` for a continuous joint).
    pub upper: f64,
    /// Velocity limit, rad/s (`+inf` when the URDF gives none).
    pub velocity: f64,
    /// Effort limit, N m, when the URDF gives a positive one.
    pub effort: Option<f64>,
}

impl JointLimits {
    /// True when `q` (rad) lies within the position limits widened by `margin` rad on each
    /// side (false for NaN).
    pub fn admits(&self, q: f64, margin: f64) -> bool {
        q >= self.lower - margin && q <= self.upper + margin
    }
}

/// Joint friction as written in the URDF `<dynamics>` element (estimates; the drive file may
/// override them).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Friction {
    /// Coulomb friction torque, N m.
    pub coulomb: f64,
    /// Viscous friction coefficient, N m s/rad.
    pub viscous: f64,
}

/// A revolute joint.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// URDF joint name.
    pub name: String,
    /// Pose of link frame `i` in link frame `i-1` at `q_i = 0`.
    pub origin: Isometry3<f64>,
    /// Limits (continuous joints have infinite position limits).
    pub limits: JointLimits,
    /// Friction from the URDF `<dynamics>` element.
    pub friction: Friction,
}

/// Display/collision primitive.
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    /// Box with full side lengths, m.
    Box {
        /// Side lengths along x, y, z, m.
        size: [f64; 3],
    },
    /// Cylinder along the shape's z axis, centred on its origin.
    Cylinder {
        /// Radius, m.
        radius: f64,
        /// Length, m.
        length: f64,
    },
    /// Capsule along the shape's z axis.
    Capsule {
        /// Radius, m.
        radius: f64,
        /// Length of the cylindrical part, m.
        length: f64,
    },
    /// Sphere.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// Mesh file as named in the URDF (not loaded by powertwin).
    Mesh {
        /// File name or `package://` URI.
        filename: String,
        /// Scale factors.
        scale: [f64; 3],
    },
}

/// A shape placed in a link frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    /// Pose of the shape in the link frame.
    pub pose: Isometry3<f64>,
    /// The primitive.
    pub geometry: Geometry,
    /// Colour (RGBA, 0..1) when the URDF gives one.
    pub rgba: Option<[f32; 4]>,
}

/// A rigid link (the base or the body moved by one joint), after merging fixed children.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// URDF link name.
    pub name: String,
    /// Mass properties in the link frame.
    pub inertia: RigidInertia,
    /// Pose of the URDF link frame in the (MDH) link frame.
    pub urdf_pose: Isometry3<f64>,
    /// Visual shapes in the link frame.
    pub visuals: Vec<Shape>,
    /// Collision shapes in the link frame.
    pub collisions: Vec<Shape>,
}

/// Joint transform and link mass data cached for the hot paths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ChainJoint {
    /// Rotation of frame i (at q = 0) in frame i-1.
    pub rot: Matrix3<f64>,
    /// Origin of frame i in frame i-1, m.
    pub pos: Vector3<f64>,
    /// Link inertia about the frame origin, frame i, kg m^2.
    pub inertia_o: Matrix3<f64>,
    /// First moment m c, frame i, kg m.
    pub mc: Vector3<f64>,
    /// Mass, kg.
    pub mass: f64,
}

impl ChainJoint {
    fn new(joint: &Joint, link: &Link) -> Self {
        ChainJoint {
            rot: *joint.origin.rotation.to_rotation_matrix().matrix(),
            pos: joint.origin.translation.vector,
            inertia_o: link.inertia.inertia_origin(),
            mc: link.inertia.com * link.inertia.mass,
            mass: link.inertia.mass,
        }
    }
}

/// A fixed-base serial robot with `n` revolute joints, ordered root to tip.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    name: String,
    base: Link,
    joints: Vec<Joint>,
    links: Vec<Link>,
    flange: Isometry3<f64>,
    flange_name: String,
    chain: Vec<ChainJoint>,
}

impl Robot {
    /// Assemble and validate a robot. `links[i]` is the body moved by `joints[i]`; `flange` is
    /// the pose of the tool flange (`tool0`) in the last link frame.
    pub fn new(
        name: impl Into<String>,
        base: Link,
        joints: Vec<Joint>,
        links: Vec<Link>,
        flange: Isometry3<f64>,
        flange_name: impl Into<String>,
    ) -> Result<Self> {
        if joints.is_empty() {
            return Err(Error::Model("the chain has no revolute joint".into()));
        }
        if joints.len() != links.len() {
            return Err(Error::Model(format!(
                "{} joints but {} moving links",
                joints.len(),
                links.len()
            )));
        }
        for (j, l) in joints.iter().zip(&links) {
            let lim = &j.limits;
            if lim.lower.is_nan() || lim.upper.is_nan() || lim.lower >= lim.upper {
                return Err(Error::Model(format!(
                    "joint '{}': position limits [{}, {}] rad are empty",
                    j.name, lim.lower, lim.upper
                )));
            }
            if lim.velocity.is_nan() || lim.velocity <= 0.0 {
                return Err(Error::Model(format!(
                    "joint '{}': velocity limit {} rad/s must be positive",
                    j.name, lim.velocity
                )));
            }
            let f = &j.friction;
            if !(f.coulomb.is_finite()
                && f.viscous.is_finite()
                && f.coulomb >= 0.0
                && f.viscous >= 0.0)
            {
                return Err(Error::Model(format!(
                    "joint '{}': friction must be finite and non-negative (coulomb {}, viscous {})",
                    j.name, f.coulomb, f.viscous
                )));
            }
            let iso_ok = j.origin.translation.vector.iter().all(|v| v.is_finite())
                && j.origin.rotation.coords.iter().all(|v| v.is_finite());
            if !iso_ok {
                return Err(Error::Model(format!(
                    "joint '{}': origin is not finite",
                    j.name
                )));
            }
            l.inertia
                .validate(&format!("link '{}' (moved by joint '{}')", l.name, j.name))?;
        }
        let chain = joints
            .iter()
            .zip(&links)
            .map(|(j, l)| ChainJoint::new(j, l))
            .collect();
        Ok(Robot {
            name: name.into(),
            base,
            joints,
            links,
            flange,
            flange_name: flange_name.into(),
            chain,
        })
    }

    /// Robot name from the URDF.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Number of joints (degrees of freedom).
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// Joints, root to tip.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Moving links; `links()[i]` is moved by `joints()[i]`.
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// The fixed base link (frame 0).
    pub fn base(&self) -> &Link {
        &self.base
    }

    /// Pose of the tool flange in the last link frame.
    pub fn flange(&self) -> &Isometry3<f64> {
        &self.flange
    }

    /// Name of the flange frame (`tool0` when the URDF has one).
    pub fn flange_name(&self) -> &str {
        &self.flange_name
    }

    pub(crate) fn chain(&self) -> &[ChainJoint] {
        &self.chain
    }

    /// Pose of link frame `i` (0-based joint index) in frame `i-1` at joint angle `q` (rad).
    pub fn joint_transform(&self, i: usize, q: f64) -> Isometry3<f64> {
        self.joints[i].origin * rot_z(q)
    }

    /// Standard inertial parameters of every link, `n x 10`, layout of [`inertia::STANDARD_NAMES`]
    /// in the link frames (kg m^2, kg m, kg).
    pub fn standard_params(&self) -> Vec<[f64; 10]> {
        self.links
            .iter()
            .map(|l| l.inertia.standard_params())
            .collect()
    }

    /// A copy with its joints replaced by `joints` (the same chain with other limits or
    /// friction, e.g. a cell's narrower ranges), validated as [`Robot::new`] validates.
    pub fn with_joints(&self, joints: Vec<Joint>) -> Result<Robot> {
        Robot::new(
            self.name(),
            self.base().clone(),
            joints,
            self.links().to_vec(),
            *self.flange(),
            self.flange_name(),
        )
    }

    /// A copy with link `i`'s mass properties replaced (e.g. link 6 plus a payload).
    pub fn with_link_inertia(&self, i: usize, inertia: RigidInertia) -> Result<Robot> {
        let mut r = self.clone();
        inertia.validate(&format!("link '{}'", r.links[i].name))?;
        r.links[i].inertia = inertia;
        r.chain[i] = ChainJoint::new(&r.joints[i], &r.links[i]);
        Ok(r)
    }

    /// Check a joint-space vector: right length and finite values. `what` names it (e.g. "q").
    pub fn check_len(&self, v: &[f64], what: &str) -> Result<()> {
        if v.len() != self.dof() {
            return Err(Error::InvalidInput(format!(
                "{what} has {} values, the robot has {} joints",
                v.len(),
                self.dof()
            )));
        }
        crate::error::ensure_finite(v, what)
    }

    /// Check positions against the position limits (names the first violating joint).
    pub fn check_position_limits(&self, q: &[f64]) -> Result<()> {
        self.check_len(q, "q")?;
        for (j, &qi) in self.joints.iter().zip(q) {
            if !j.limits.admits(qi, 0.0) {
                return Err(Error::JointLimit(format!(
                    "joint '{}' at {:.6} rad is outside [{:.6}, {:.6}] rad",
                    j.name, qi, j.limits.lower, j.limits.upper
                )));
            }
        }
        Ok(())
    }

    /// Check velocities against the velocity limits (names the first violating joint).
    pub fn check_velocity_limits(&self, dq: &[f64]) -> Result<()> {
        self.check_len(dq, "dq")?;
        for (j, &v) in self.joints.iter().zip(dq) {
            if v.abs() > j.limits.velocity {
                return Err(Error::JointLimit(format!(
                    "joint '{}' speed {:.6} rad/s exceeds its limit {:.6} rad/s",
                    j.name,
                    v.abs(),
                    j.limits.velocity
                )));
            }
        }
        Ok(())
    }
}

/// Rotation about z by `q` rad as an isometry.
pub fn rot_z(q: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), q),
    )
}
