//! What a real robot cell forbids a designed motion: a floor or table plane, joint ranges
//! narrower than the URDF's, and a speed and acceleration scaling.
//!
//! # Frames and units
//! The plane is horizontal in the **robot base frame** (the URDF's root link): `floor_z_m`
//! is its height there, m. Joint ranges are in rad, in the URDF's joint coordinates.
//! Scalings are fractions of the URDF velocity limits and of the acceleration limits the
//! design is given, in (0, 1].
//!
//! # File format (TOML)
//! ```toml
//! floor_z_m = -0.02          # the table top, 2 cm below the base frame's origin
//! floor_margin_m = 0.05      # the flange and the wrist stay 5 cm above it
//! base_radius_m = 0.15       # and 15 cm from the base's z axis
//! speed_scaling = 0.5        # half of each URDF velocity limit
//! accel_scaling = 0.5        # half of each acceleration limit
//!
//! [[joint]]                  # one per joint to narrow; others keep the URDF's range
//! name = "shoulder_lift_joint"
//! lower_rad = -2.5
//! upper_rad = -0.6
//! ```
//! Every key is optional; the defaults ([`Cell::default`]) are the workspace `excite` uses
//! without a cell: the floor at the base frame's origin, 0.05 m of margin, 0.15 m around the
//! base axis, full speed and acceleration.

use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::kinematics::fk::link_poses;
use crate::model::{JointLimits, Robot};

use super::Trajectory;
use super::limits::check_limits;

/// A joint range narrower than the URDF's.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointRange {
    /// URDF joint name.
    pub name: String,
    /// Lowest position the cell allows, rad.
    pub lower_rad: f64,
    /// Highest position the cell allows, rad.
    pub upper_rad: f64,
}

/// What a robot cell forbids (see the module docs for the file format).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Cell {
    /// Height of the floor or table plane, z in the robot base frame, m.
    pub floor_z_m: f64,
    /// Clearance the flange and the wrist centre keep above the plane, m (>= 0).
    pub floor_margin_m: f64,
    /// Radius of the keep-out cylinder around the base z axis, m (>= 0).
    pub base_radius_m: f64,
    /// Fraction of each URDF velocity limit a motion may use, in (0, 1].
    pub speed_scaling: f64,
    /// Fraction of each acceleration limit a motion may use, in (0, 1].
    pub accel_scaling: f64,
    /// Joint ranges narrower than the URDF's (`[[joint]]` tables).
    #[serde(rename = "joint")]
    pub joints: Vec<JointRange>,
}

impl Default for Cell {
    /// The workspace `excite` keeps without a cell file.
    fn default() -> Self {
        Cell {
            floor_z_m: 0.0,
            floor_margin_m: 0.05,
            base_radius_m: 0.15,
            speed_scaling: 1.0,
            accel_scaling: 1.0,
            joints: Vec::new(),
        }
    }
}

impl Cell {
    /// Parse and range-check a cell file's text; `label` names the file in messages.
    ///
    /// Errors ([`Error::Toml`], naming the file and the key): malformed TOML, unknown or
    /// mistyped keys, a non-finite value, a negative margin or radius, a scaling outside
    /// (0, 1], an empty joint range, a joint named twice.
    pub fn from_toml_str(text: &str, label: &str) -> Result<Cell> {
        let err = |message: String| Error::Toml {
            file: label.to_string(),
            message,
        };
        let cell: Cell =
            toml::from_str(text).map_err(|e| err(e.to_string().trim_end().to_string()))?;
        if !cell.floor_z_m.is_finite() {
            return Err(err(format!(
                "floor_z_m = {} must be finite (m)",
                cell.floor_z_m
            )));
        }
        for (key, v) in [
            ("floor_margin_m", cell.floor_margin_m),
            ("base_radius_m", cell.base_radius_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(err(format!("{key} = {v} must be finite and >= 0 (m)")));
            }
        }
        for (key, v) in [
            ("speed_scaling", cell.speed_scaling),
            ("accel_scaling", cell.accel_scaling),
        ] {
            if !(v > 0.0 && v <= 1.0) {
                return Err(err(format!(
                    "{key} = {v} must be in (0, 1]: a fraction of the robot's limits"
                )));
            }
        }
        for (k, j) in cell.joints.iter().enumerate() {
            if !(j.lower_rad.is_finite() && j.upper_rad.is_finite() && j.lower_rad < j.upper_rad) {
                return Err(err(format!(
                    "joint '{}': range [lower_rad, upper_rad] = [{}, {}] rad is empty or not finite",
                    j.name, j.lower_rad, j.upper_rad
                )));
            }
            if cell.joints[..k].iter().any(|o| o.name == j.name) {
                return Err(err(format!("joint '{}' is given twice", j.name)));
            }
        }
        Ok(cell)
    }

    /// Read and check a cell file ([`Cell::from_toml_str`]).
    pub fn from_file(path: &Path) -> Result<Cell> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Cell::from_toml_str(&text, &path.display().to_string())
    }

    /// Height the flange and the wrist centre stay above, z in the base frame, m: the plane
    /// plus the margin.
    pub fn floor_z(&self) -> f64 {
        self.floor_z_m + self.floor_margin_m
    }

    /// `accel_limits` (rad/s^2 per joint) times the acceleration scaling.
    pub fn accel_limits(&self, accel_limits: &[f64]) -> Vec<f64> {
        accel_limits
            .iter()
            .map(|a| a * self.accel_scaling)
            .collect()
    }

    /// `robot` as the cell lets it move: each joint's position limits intersected with the
    /// cell's range, each velocity limit times the speed scaling. Whatever checks a motion
    /// against the returned robot's limits checks it against the cell's.
    ///
    /// Errors ([`Error::InvalidInput`]): a cell joint the robot does not have (the robot's
    /// joints are listed), a cell range that does not overlap the URDF's.
    pub fn limit(&self, robot: &Robot) -> Result<Robot> {
        let mut joints = robot.joints().to_vec();
        for range in &self.joints {
            let Some(joint) = joints.iter_mut().find(|j| j.name == range.name) else {
                return Err(Error::InvalidInput(format!(
                    "cell joint '{}' is not a joint of robot '{}' ({})",
                    range.name,
                    robot.name(),
                    robot
                        .joints()
                        .iter()
                        .map(|j| j.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            };
            let lim = joint.limits;
            let (lower, upper) = (
                lim.lower.max(range.lower_rad),
                lim.upper.min(range.upper_rad),
            );
            if lower >= upper {
                return Err(Error::InvalidInput(format!(
                    "cell joint '{}': range [{}, {}] rad lies outside the URDF's [{}, {}] rad",
                    range.name, range.lower_rad, range.upper_rad, lim.lower, lim.upper
                )));
            }
            joint.limits = JointLimits {
                lower,
                upper,
                ..lim
            };
        }
        for joint in &mut joints {
            joint.limits.velocity *= self.speed_scaling;
        }
        robot.with_joints(joints)
    }

    /// Check `traj` every `dt` s against the cell: the position and velocity limits of
    /// `limited` (the robot as [`Cell::limit`] returned it), `accel_limits` (rad/s^2, already
    /// scaled), and the flange and the wrist centre (the origin of the second-to-last link
    /// frame) above [`Cell::floor_z`] and `base_radius_m` from the base z axis.
    ///
    /// Errors: [`Error::JointLimit`] naming the first violation, its time (s) and the point;
    /// the input errors of [`check_limits`].
    pub fn check_motion(
        &self,
        limited: &Robot,
        traj: &dyn Trajectory,
        accel_limits: &[f64],
        dt: f64,
    ) -> Result<()> {
        check_limits(limited, traj, dt, Some(accel_limits))?;
        let n = limited.dof();
        let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut poses = vec![nalgebra::Isometry3::identity(); n];
        let steps = (traj.duration() / dt).ceil() as usize;
        for k in 0..=steps {
            let t = (k as f64 * dt).min(traj.duration());
            traj.sample(t, &mut q, &mut dq, &mut ddq);
            link_poses(limited, &q, &mut poses);
            let flange = poses[n - 1] * limited.flange();
            let points = [
                ("wrist", poses[n.saturating_sub(2)].translation.vector),
                ("flange", flange.translation.vector),
            ];
            for (what, p) in points {
                let radius = p.x.hypot(p.y);
                if p.z < self.floor_z() || radius < self.base_radius_m {
                    return Err(Error::JointLimit(format!(
                        "the {what} at t = {t:.3} s is at z = {:.4} m, {radius:.4} m from the \
                         base axis: the cell keeps it above z = {:.4} m (floor and margin) and \
                         {} m from the axis",
                        p.z,
                        self.floor_z(),
                        self.base_radius_m
                    )));
                }
            }
        }
        Ok(())
    }
}
