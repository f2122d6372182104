//! Per-joint drive data that a URDF cannot hold: reflected rotor inertia, motor efficiency,
//! copper and standby losses, and friction overrides.
//!
//! # Units and sides
//! Every quantity is referred to the **link side** of the gearbox (joint torque `tau` in N m,
//! joint speed `dq` in rad/s):
//! - rotor inertia: kg m^2 (motor rotor inertia times the squared gear ratio),
//! - efficiency `eta`: dimensionless, in (0, 1] (Liu et al. 2018, eq. 9: `P = tau dq / eta`),
//! - copper loss coefficient `c`: W/(N m)^2, so that `P_copper = c tau^2`,
//! - standby power `P0`: W, drawn while the servo is on, even at rest,
//! - friction: Coulomb torque in N m and viscous coefficient in N m s/rad.
//!
//! # File format (TOML)
//! ```toml
//! robot = "abb_irb1200_7_70"          # optional; must equal the robot name when present
//! rated_payload_kg = 7.0              # optional; the maker's rated payload (tool + load)
//! [brakes]                            # optional; a waiting mode with brakes applied
//! power_W = 5.0                       # whole arm's drive power with servos off, brakes holding
//! engage_s = 0.2                      # from standstill until the brakes hold (servo on)
//! release_s = 0.2                     # from the release command until the servo holds
//! [[joint]]                           # one entry per robot joint, any order
//! name = "joint_1"
//! rotor_inertia_kgm2 = 0.36
//! efficiency = 0.87
//! copper_loss_W_per_Nm2 = 0.0045
//! standby_W = 4.0
//! coulomb_Nm = 10.0                   # optional; default: the URDF <dynamics friction>
//! viscous_Nms_per_rad = 8.0           # optional; default: the URDF <dynamics damping>
//! # Optional effects beyond the power model's structure ([`Unmodelled`]; default 0 / none;
//! # identify --method gear fits gear friction alike in both directions), applied only by a
//! # twin run with realistic fidelity:
//! iron_hysteresis_W_per_rad_s = 0.9   # iron loss k_h |dq|
//! iron_eddy_W_s2_per_rad2 = 0.36      # iron loss k_e dq^2
//! stribeck_static_Nm = 12.5           # static friction (>= coulomb_Nm) at rest
//! stribeck_speed_rad_s = 0.05         # Stribeck velocity
//! gear_friction_per_Nm = 0.02         # extra Coulomb friction per N m of transmitted torque
//! gear_friction_braking_per_Nm = 0.03 # the same while the load drives the motor (power
//!                                     # flowing back through the gear); default: as above
//! ```
//! Unknown keys, missing or repeated joints and out-of-range values are errors that name the
//! file, the joint and the key.

use std::collections::HashMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::model::{Friction, Joint, Robot};

/// Drive data of one joint, link side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointDrive {
    /// Motor rotor inertia reflected to the link side, kg m^2 (adds to the joint's diagonal
    /// mass-matrix entry).
    pub rotor_inertia: f64,
    /// Motor efficiency `eta` in (0, 1] (Liu et al. 2018, eq. 9).
    pub efficiency: f64,
    /// Copper loss coefficient, W/(N m)^2: `P_copper = copper_loss * tau^2` with the link-side
    /// torque `tau` in N m.
    pub copper_loss: f64,
    /// Constant power while the servo is on, W.
    pub standby_power: f64,
    /// Coulomb (N m) and viscous (N m s/rad) friction at the link side.
    pub friction: Friction,
    /// Effects beyond the identified model's structure (a realistic twin applies them).
    pub unmodelled: Unmodelled,
}

/// Drive effects beyond the identified power model's structure, so that a twin using them is
/// richer than any model identified from it (as a real robot is); the `gear` estimator
/// ([`crate::identification::fit::Estimator::Gear`]) represents gear friction alike in both
/// directions of the power flow. Link side.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Unmodelled {
    /// Hysteresis iron loss `k_h |dq|`, W/(rad/s).
    pub iron_hysteresis: f64,
    /// Eddy-current iron loss `k_e dq^2`, W/(rad/s)^2.
    pub iron_eddy: f64,
    /// Static friction at rest, N m (Stribeck: `fc + (fs - fc) exp(-(dq/vs)^2)`); `None`:
    /// no Stribeck effect.
    pub stribeck_static: Option<f64>,
    /// Stribeck velocity `vs`, rad/s.
    pub stribeck_speed: f64,
    /// Load-dependent gear friction: extra Coulomb friction `mu |tau|` per N m of
    /// transmitted torque, dimensionless, while the motor drives the load (`tau dq >= 0`).
    pub gear_friction: f64,
    /// The same while the load drives the motor (`tau dq < 0`, braking: power flows back
    /// through the gear), dimensionless. Harmonic and cycloidal drives differ in the two
    /// directions.
    pub gear_friction_braking: f64,
}

impl Unmodelled {
    /// Iron loss (W) at link speed `dq` (rad/s).
    #[inline]
    pub fn iron_loss(&self, dq: f64) -> f64 {
        self.iron_hysteresis * dq.abs() + self.iron_eddy * dq * dq
    }

    /// Dry friction torque (N m) at speed `dq` (rad/s) with transmitted torque `tau` (N m),
    /// for Coulomb friction `coulomb` (N m): Stribeck plus gear friction of the direction the
    /// power flows (the twin's sliding torque, or its stiction bound at rest).
    #[inline]
    pub fn friction(&self, coulomb: f64, dq: f64, tau: f64) -> f64 {
        let stribeck = match self.stribeck_static {
            Some(fs) if self.stribeck_speed > 0.0 => {
                (fs - coulomb) * (-(dq / self.stribeck_speed).powi(2)).exp()
            }
            _ => 0.0,
        };
        let mu = if tau * dq < 0.0 {
            self.gear_friction_braking
        } else {
            self.gear_friction
        };
        coulomb + stribeck + mu * tau.abs()
    }

    /// Whether any effect is present.
    pub fn any(&self) -> bool {
        *self != Unmodelled::default()
    }
}

impl JointDrive {
    /// The lossless, inertia-free drive with the given friction.
    fn lossless(friction: Friction) -> Self {
        JointDrive {
            rotor_inertia: 0.0,
            efficiency: 1.0,
            copper_loss: 0.0,
            standby_power: 0.0,
            friction,
            unmodelled: Unmodelled::default(),
        }
    }
}

/// The arm's standstill mode with brakes applied and servos off (a data-sheet value of the
/// controller, e.g. an energy-saving mode). While the brakes hold, the motors draw no current:
/// no copper loss and no servo standby power, only `power_w` for the whole arm.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Brakes {
    /// Power of the whole arm's drives while all brakes hold, W.
    #[serde(rename = "power_W")]
    pub power_w: f64,
    /// Time from standstill until the brakes hold, s; the servo holds the arm meanwhile.
    pub engage_s: f64,
    /// Time from the release command until the servo holds the arm again, s (servo on).
    pub release_s: f64,
}

impl Brakes {
    /// The shortest wait (s) in which the brakes can hold at all: engage plus release.
    pub fn min_wait_s(&self) -> f64 {
        self.engage_s + self.release_s
    }
}

/// A time interval of a run during which the brakes hold the arm, s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BrakeWindow {
    /// Start (brakes holding), s.
    pub start_s: f64,
    /// End (release begins; the servo holds from here), s.
    pub end_s: f64,
}

impl BrakeWindow {
    /// Check a sorted, non-overlapping list of finite windows with `start_s < end_s`.
    pub fn check_all(windows: &[BrakeWindow]) -> Result<()> {
        for (k, w) in windows.iter().enumerate() {
            if !(w.start_s.is_finite() && w.end_s.is_finite() && w.start_s < w.end_s) {
                return Err(Error::InvalidInput(format!(
                    "brake window {} [{}, {}] s must be finite with start < end",
                    k + 1,
                    w.start_s,
                    w.end_s
                )));
            }
            if k > 0 && w.start_s < windows[k - 1].end_s {
                return Err(Error::InvalidInput(format!(
                    "brake window {} starts at {} s before window {} ends at {} s",
                    k + 1,
                    w.start_s,
                    k,
                    windows[k - 1].end_s
                )));
            }
        }
        Ok(())
    }

    /// Whether time `t` (s) lies in one of `windows` (`start <= t < end`).
    pub fn holds(windows: &[BrakeWindow], t: f64) -> bool {
        windows.iter().any(|w| w.start_s <= t && t < w.end_s)
    }
}

/// Drive data of every joint of a robot, in robot joint order.
#[derive(Debug, Clone, PartialEq)]
pub struct Drive {
    joints: Vec<JointDrive>,
    rated_payload_kg: Option<f64>,
    brakes: Option<Brakes>,
}

/// The TOML file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DriveFile {
    robot: Option<String>,
    rated_payload_kg: Option<f64>,
    brakes: Option<Brakes>,
    joint: Vec<JointEntry>,
}

/// One `[[joint]]` table.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct JointEntry {
    name: String,
    rotor_inertia_kgm2: f64,
    efficiency: f64,
    #[serde(rename = "copper_loss_W_per_Nm2")]
    copper_loss: f64,
    #[serde(rename = "standby_W")]
    standby: f64,
    #[serde(rename = "coulomb_Nm")]
    coulomb: Option<f64>,
    #[serde(rename = "viscous_Nms_per_rad")]
    viscous: Option<f64>,
    #[serde(rename = "iron_hysteresis_W_per_rad_s", default)]
    iron_hysteresis: f64,
    #[serde(rename = "iron_eddy_W_s2_per_rad2", default)]
    iron_eddy: f64,
    #[serde(rename = "stribeck_static_Nm")]
    stribeck_static: Option<f64>,
    #[serde(rename = "stribeck_speed_rad_s", default)]
    stribeck_speed: f64,
    #[serde(rename = "gear_friction_per_Nm", default)]
    gear_friction: f64,
    #[serde(rename = "gear_friction_braking_per_Nm")]
    gear_friction_braking: Option<f64>,
}

impl JointEntry {
    /// The entry's drive data for `joint` (link side), with the URDF friction of `joint` where
    /// the entry gives none and the braking gear friction equal to the driving one where it
    /// gives none.
    fn drive(&self, joint: &Joint) -> JointDrive {
        JointDrive {
            rotor_inertia: self.rotor_inertia_kgm2,
            efficiency: self.efficiency,
            copper_loss: self.copper_loss,
            standby_power: self.standby,
            friction: Friction {
                coulomb: self.coulomb.unwrap_or(joint.friction.coulomb),
                viscous: self.viscous.unwrap_or(joint.friction.viscous),
            },
            unmodelled: Unmodelled {
                iron_hysteresis: self.iron_hysteresis,
                iron_eddy: self.iron_eddy,
                stribeck_static: self.stribeck_static,
                stribeck_speed: self.stribeck_speed,
                gear_friction: self.gear_friction,
                gear_friction_braking: self.gear_friction_braking.unwrap_or(self.gear_friction),
            },
        }
    }
}

impl Drive {
    /// Parse a drive file's text for `robot`. `label` names the file in error messages.
    ///
    /// Errors ([`Error::Toml`]): malformed TOML or unknown/missing keys (with the parser's line
    /// and column), a `robot` name that differs from `robot.name()`, joints that are missing,
    /// repeated or not in the robot, non-finite values, an efficiency outside (0, 1] or a
    /// negative inertia, loss or friction value.
    pub fn from_toml_str(text: &str, label: &str, robot: &Robot) -> Result<Drive> {
        let err = |message: String| Error::Toml {
            file: label.to_string(),
            message,
        };
        let file: DriveFile =
            toml::from_str(text).map_err(|e| err(e.to_string().trim_end().to_string()))?;
        check_file_level(&file, robot).map_err(err)?;
        let entries = entries_in_joint_order(&file.joint, robot).map_err(err)?;
        let joints = robot
            .joints()
            .iter()
            .zip(entries)
            .map(|(joint, e)| {
                let drive = e.drive(joint);
                check_joint(&drive).map_err(|m| err(format!("joint '{}': {m}", joint.name)))?;
                Ok(drive)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Drive {
            joints,
            rated_payload_kg: file.rated_payload_kg,
            brakes: file.brakes,
        })
    }

    /// Read and parse a drive file for `robot` (see [`Drive::from_toml_str`]); I/O failures
    /// give [`Error::Io`].
    pub fn from_file(path: &Path, robot: &Robot) -> Result<Drive> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Drive::from_toml_str(&text, &path.display().to_string(), robot)
    }

    /// Drive data from per-joint values in robot joint order, with the file's range checks
    /// (errors name the joint and the quantity).
    pub fn new(robot: &Robot, joints: Vec<JointDrive>) -> Result<Drive> {
        if joints.len() != robot.dof() {
            return Err(Error::InvalidInput(format!(
                "{} drive entries for a robot with {} joints",
                joints.len(),
                robot.dof()
            )));
        }
        for (j, d) in robot.joints().iter().zip(&joints) {
            check_joint(d)
                .map_err(|m| Error::InvalidInput(format!("drive of joint '{}': {m}", j.name)))?;
        }
        Ok(Drive {
            joints,
            rated_payload_kg: None,
            brakes: None,
        })
    }

    /// The same file-level data (rated payload, brakes) with other per-joint values, checked
    /// as [`Drive::new`] checks them.
    pub fn with_joints(&self, robot: &Robot, joints: Vec<JointDrive>) -> Result<Drive> {
        Ok(Drive {
            rated_payload_kg: self.rated_payload_kg,
            brakes: self.brakes,
            ..Drive::new(robot, joints)?
        })
    }

    /// Ideal drives: no friction, no rotor inertia, efficiency 1, no copper or standby loss.
    pub fn ideal(robot: &Robot) -> Drive {
        Drive {
            joints: vec![JointDrive::lossless(Friction::default()); robot.dof()],
            rated_payload_kg: None,
            brakes: None,
        }
    }

    /// The URDF's `<dynamics>` friction with otherwise ideal drives (no rotor inertia,
    /// efficiency 1, no copper or standby loss).
    pub fn from_urdf(robot: &Robot) -> Drive {
        Drive {
            joints: robot
                .joints()
                .iter()
                .map(|j| JointDrive::lossless(j.friction))
                .collect(),
            rated_payload_kg: None,
            brakes: None,
        }
    }

    /// The same drives without their [`Unmodelled`] effects (the structure an identified
    /// model has).
    pub fn exact(&self) -> Drive {
        Drive {
            joints: self
                .joints
                .iter()
                .map(|j| JointDrive {
                    unmodelled: Unmodelled::default(),
                    ..*j
                })
                .collect(),
            rated_payload_kg: self.rated_payload_kg,
            brakes: self.brakes,
        }
    }

    /// Drive data per joint, in robot joint order.
    pub fn joints(&self) -> &[JointDrive] {
        &self.joints
    }

    /// The robot's rated payload (tool and load at the flange), kg, when the drive file
    /// gives one (`rated_payload_kg`). Heavier payloads are refused unless the caller allows
    /// an overload ([`crate::model::payload::check_rated`]).
    pub fn rated_payload_kg(&self) -> Option<f64> {
        self.rated_payload_kg
    }

    /// The brakes-applied standstill mode, when the drive file gives it (`[brakes]`).
    pub fn brakes(&self) -> Option<&Brakes> {
        self.brakes.as_ref()
    }

    /// The drives' nominal efficiency: the mean of the joints' efficiencies. What the
    /// paper's single `1/eta` scale of the power model stands for.
    pub fn nominal_efficiency(&self) -> f64 {
        self.joints.iter().map(|j| j.efficiency).sum::<f64>() / self.joints.len().max(1) as f64
    }

    /// Reflected rotor inertias per joint, kg m^2 (link side).
    pub fn rotor_inertia(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.rotor_inertia).collect()
    }

    /// Coulomb friction torques per joint, N m (link side).
    pub fn coulomb(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.friction.coulomb).collect()
    }

    /// Viscous friction coefficients per joint, N m s/rad (link side).
    pub fn viscous(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.friction.viscous).collect()
    }

    /// Motor efficiencies per joint, in (0, 1].
    pub fn efficiency(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.efficiency).collect()
    }
}

/// Check the file-level keys against `robot`: the robot name when given, a finite positive
/// rated payload (kg) and finite non-negative brake power (W) and times (s); or why not.
fn check_file_level(file: &DriveFile, robot: &Robot) -> std::result::Result<(), String> {
    if let Some(name) = &file.robot
        && name != robot.name()
    {
        return Err(format!(
            "the drive file is for robot '{name}' but the model is '{}'",
            robot.name()
        ));
    }
    if let Some(m) = file.rated_payload_kg
        && !(m.is_finite() && m > 0.0)
    {
        return Err(format!(
            "rated_payload_kg = {m}; it must be finite and positive"
        ));
    }
    if let Some(b) = &file.brakes {
        for (key, v) in [
            ("power_W", b.power_w),
            ("engage_s", b.engage_s),
            ("release_s", b.release_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("brakes.{key} = {v} must be finite and >= 0"));
            }
        }
    }
    Ok(())
}

/// The `[[joint]]` entries in robot joint order, one per joint; or every unknown, repeated
/// and missing joint name in one message.
fn entries_in_joint_order<'a>(
    entries: &'a [JointEntry],
    robot: &Robot,
) -> std::result::Result<Vec<&'a JointEntry>, String> {
    let index: HashMap<&str, usize> = robot
        .joints()
        .iter()
        .enumerate()
        .map(|(i, j)| (j.name.as_str(), i))
        .collect();
    let mut slots: Vec<Option<&JointEntry>> = vec![None; robot.dof()];
    let mut unknown = Vec::new();
    let mut repeated = Vec::new();
    for entry in entries {
        match index.get(entry.name.as_str()) {
            None => unknown.push(format!("'{}'", entry.name)),
            Some(&i) if slots[i].is_some() => repeated.push(format!("'{}'", entry.name)),
            Some(&i) => slots[i] = Some(entry),
        }
    }
    let missing: Vec<String> = robot
        .joints()
        .iter()
        .zip(&slots)
        .filter(|(_, s)| s.is_none())
        .map(|(j, _)| format!("'{}'", j.name))
        .collect();
    let mut problems = Vec::new();
    if !unknown.is_empty() {
        let names: Vec<&str> = robot.joints().iter().map(|j| j.name.as_str()).collect();
        problems.push(format!(
            "unknown joint(s) {} (robot '{}' has {})",
            unknown.join(", "),
            robot.name(),
            names.join(", ")
        ));
    }
    if !repeated.is_empty() {
        problems.push(format!(
            "joint(s) listed more than once: {}",
            repeated.join(", ")
        ));
    }
    if !missing.is_empty() {
        problems.push(format!("missing joint(s): {}", missing.join(", ")));
    }
    if !problems.is_empty() {
        return Err(problems.join("; "));
    }
    // No joint is missing (checked above), so the entries line up with the robot's joints.
    Ok(slots.into_iter().flatten().collect())
}

/// Range checks of one joint's values; the message names the TOML key.
fn check_joint(d: &JointDrive) -> std::result::Result<(), String> {
    let non_negative = [
        ("rotor_inertia_kgm2", d.rotor_inertia),
        ("copper_loss_W_per_Nm2", d.copper_loss),
        ("standby_W", d.standby_power),
        ("coulomb_Nm", d.friction.coulomb),
        ("viscous_Nms_per_rad", d.friction.viscous),
        ("iron_hysteresis_W_per_rad_s", d.unmodelled.iron_hysteresis),
        ("iron_eddy_W_s2_per_rad2", d.unmodelled.iron_eddy),
        ("stribeck_speed_rad_s", d.unmodelled.stribeck_speed),
        ("gear_friction_per_Nm", d.unmodelled.gear_friction),
        (
            "gear_friction_braking_per_Nm",
            d.unmodelled.gear_friction_braking,
        ),
    ];
    for (key, v) in non_negative {
        if !v.is_finite() || v < 0.0 {
            return Err(format!("{key} = {v} must be finite and >= 0"));
        }
    }
    if let Some(fs) = d.unmodelled.stribeck_static {
        if !(fs.is_finite() && fs >= d.friction.coulomb) {
            return Err(format!(
                "stribeck_static_Nm = {fs} must be finite and >= coulomb_Nm = {}",
                d.friction.coulomb
            ));
        }
        if d.unmodelled.stribeck_speed <= 0.0 {
            return Err("stribeck_static_Nm needs stribeck_speed_rad_s > 0".into());
        }
    }
    for (key, mu) in [
        ("gear_friction_per_Nm", d.unmodelled.gear_friction),
        (
            "gear_friction_braking_per_Nm",
            d.unmodelled.gear_friction_braking,
        ),
    ] {
        if mu >= 1.0 {
            return Err(format!("{key} = {mu} must be < 1"));
        }
    }
    if !(d.efficiency.is_finite() && d.efficiency > 0.0 && d.efficiency <= 1.0) {
        return Err(format!("efficiency = {} must be in (0, 1]", d.efficiency));
    }
    Ok(())
}
