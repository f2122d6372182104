//! `meta.json`: everything needed to interpret, reproduce and check a dataset.
//!
//! # Schema, version 1 ([`SCHEMA_VERSION`])
//! One JSON object; every key below is required (`null` only where marked optional) and
//! unknown keys are rejected. Keys carry their units (`_s`, `_hz`, `_kg`, `_m`, `_kgm2`,
//! `_W`, `_J`, ...); joint vectors are in robot joint order (root to tip).
//!
//! | key | content |
//! | --- | --- |
//! | `schema_version` | `1` |
//! | `program` | `{name, version}` of the writer |
//! | `robot` | `{name, dof, joint_names, urdf: {source: {text} or {path}, sha256}}` |
//! | `drives` | per joint: `{joint, rotor_inertia_kgm2, coulomb_Nm, viscous_Nms_per_rad, efficiency, copper_loss_W_per_Nm2, standby_W}` (link side, as in the drive file) |
//! | `payloads` | timeline: `[{t_s, name, mass_kg, com_m, inertia_kgm2, tcp_m}]`, flange frame `tool0` |
//! | `standard_params` | true standard parameters: `{friction, armature, names, values}` |
//! | `base_params` | true base parameters: `{names, values, relations}` |
//! | `twin` | physics, controller and motor settings ([`TwinConfig`]): `{physics: {dt_s, substeps}, gains: {kp_per_s2, kd_per_s}, motor, nominal_error_rel, nominal_seed}`, `fidelity`, optionally `cabinet_power_W` (absent: 0) |
//! | `measurement` | logger settings ([`SensorSettings`]): `{rate_hz, power_averaging, noise: {encoder_resolution_rad, encoder_sigma_rad, joint_power_sigma_W, power_sigma_W, power_offset_W}, seed}`, optionally `power_lag_s` and `stamp_jitter_s` (absent: 0) |
//! | `trajectory_seed` | seed of a randomly generated trajectory (optional) |
//! | `trajectory` | free-form description written by the trajectory's owner |
//! | `summary` | `{duration_s, energy_total_J, energy_grid_J, truth_rows, measured_rows}` |
//! | `family` | optional: what was drawn for a robot of the family of truths ([`Draw`]: the family seed, link mass errors, per-joint friction laws and losses, cabinet, controller, logger) |
//!
//! Nothing run-dependent but the data is stored (no wall time, no host), so the same inputs
//! give byte-identical datasets.
//!
//! A reader first checks `schema_version` and refuses versions it does not know. Any change
//! to keys or meanings increments it.

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::dynamics::ParamLayout;
use crate::dynamics::base_params::{BaseParams, Relation};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::model::drive::Drive;
use crate::model::inertia::tensor_elements;
use crate::model::payload::Payload;
use crate::twin::TwinConfig;
use crate::twin::family::Draw;
use crate::twin::record::{Measured, Recording};
use crate::twin::sensor::SensorSettings;

/// Version of the `meta.json` schema this build writes and reads.
pub const SCHEMA_VERSION: u32 = 1;

/// The content of `meta.json` (see the module documentation for the schema).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Meta {
    /// Schema version; [`SCHEMA_VERSION`] for everything this build writes.
    pub schema_version: u32,
    /// The program that wrote the dataset.
    pub program: Program,
    /// The simulated robot.
    pub robot: RobotInfo,
    /// True drive parameters per joint, robot joint order.
    pub drives: Vec<DriveInfo>,
    /// Payloads attached to the flange, in time order; each applies from its `t_s` until the
    /// next one (an empty list means no payload throughout).
    pub payloads: Vec<PayloadRecord>,
    /// True standard parameters of the robot links (without payload) and drives.
    pub standard_params: StandardParams,
    /// True base parameters derived from [`Meta::standard_params`].
    pub base_params: BaseParamsInfo,
    /// Physics, controller and motor-model settings.
    pub twin: TwinConfig,
    /// Logger settings of the measured stream (rate, noise, noise seed).
    pub measurement: SensorSettings,
    /// Seed of a randomly generated trajectory (`None` for a given one).
    pub trajectory_seed: Option<u64>,
    /// Free-form description of the reference trajectory (kind, parameters, duration, ...).
    pub trajectory: serde_json::Value,
    /// Figures computed from the recorded data ([`Summary::of`]).
    pub summary: Summary,
    /// What was drawn when the twin ran a robot of the family (`--truth family:SEED`);
    /// truth, for scoring only. Absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub family: Option<Draw>,
}

/// Writer name and version.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Program {
    /// Program name (`powertwin`).
    pub name: String,
    /// Program version (Cargo package version).
    pub version: String,
}

impl Program {
    /// This build of powertwin.
    pub fn current() -> Self {
        Program {
            name: env!("CARGO_PKG_NAME").to_string(),
            version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }
}

/// The robot model.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotInfo {
    /// Robot name from the URDF.
    pub name: String,
    /// Number of joints; the tables have this many per-joint columns of each series.
    pub dof: usize,
    /// URDF joint names, root to tip (joint `i` of a column name is `joint_names[i - 1]`).
    pub joint_names: Vec<String>,
    /// The URDF the robot was loaded from.
    pub urdf: Urdf,
}

impl RobotInfo {
    /// Name, dof and joint names of `robot`, loaded from `urdf`.
    pub fn new(robot: &Robot, urdf: Urdf) -> Self {
        RobotInfo {
            name: robot.name().to_string(),
            dof: robot.dof(),
            joint_names: robot.joints().iter().map(|j| j.name.clone()).collect(),
            urdf,
        }
    }
}

/// A URDF by value or by path, with the SHA-256 of its text.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Urdf {
    /// The text itself, or the path it was read from.
    pub source: UrdfSource,
    /// SHA-256 of the URDF text (UTF-8 bytes), lowercase hex (what `sha256sum` prints).
    pub sha256: String,
}

/// Where the URDF text is.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UrdfSource {
    /// The full URDF text (for built-in models).
    Text(String),
    /// The path the URDF was read from, as given by the user.
    Path(String),
}

impl Urdf {
    /// Store the URDF text itself.
    pub fn inline(text: &str) -> Self {
        Urdf {
            sha256: sha256_hex(text.as_bytes()),
            source: UrdfSource::Text(text.to_string()),
        }
    }

    /// Refer to the file at `path` whose content is `text`.
    pub fn file(path: &str, text: &str) -> Self {
        Urdf {
            sha256: sha256_hex(text.as_bytes()),
            source: UrdfSource::Path(path.to_string()),
        }
    }
}

/// Lowercase hex SHA-256 of `bytes`.
fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Drive parameters of one joint, link side (see [`crate::model::drive`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveInfo {
    /// URDF joint name.
    pub joint: String,
    /// Reflected rotor inertia, kg m^2.
    pub rotor_inertia_kgm2: f64,
    /// Coulomb friction torque, N m.
    #[serde(rename = "coulomb_Nm")]
    pub coulomb_nm: f64,
    /// Viscous friction coefficient, N m s/rad.
    #[serde(rename = "viscous_Nms_per_rad")]
    pub viscous_nms_per_rad: f64,
    /// Motor efficiency in (0, 1].
    pub efficiency: f64,
    /// Copper loss coefficient, W/(N m)^2.
    #[serde(rename = "copper_loss_W_per_Nm2")]
    pub copper_loss_w_per_nm2: f64,
    /// Standby power while the servo is on, W.
    #[serde(rename = "standby_W")]
    pub standby_w: f64,
}

impl DriveInfo {
    /// One entry per joint of `robot` from `drive` (robot joint order).
    pub fn per_joint(robot: &Robot, drive: &Drive) -> Vec<DriveInfo> {
        robot
            .joints()
            .iter()
            .zip(drive.joints())
            .map(|(j, d)| DriveInfo {
                joint: j.name.clone(),
                rotor_inertia_kgm2: d.rotor_inertia,
                coulomb_nm: d.friction.coulomb,
                viscous_nms_per_rad: d.friction.viscous,
                efficiency: d.efficiency,
                copper_loss_w_per_nm2: d.copper_loss,
                standby_w: d.standby_power,
            })
            .collect()
    }
}

/// A payload attached from time `t_s` on, in the flange frame `tool0`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PayloadRecord {
    /// Time from which the payload is attached, s.
    pub t_s: f64,
    /// Display name.
    pub name: String,
    /// Mass, kg (0 for "no payload from here on").
    pub mass_kg: f64,
    /// Centre of mass in the flange frame, m.
    pub com_m: [f64; 3],
    /// Inertia tensor about the COM, flange axes, `[ixx iyy izz ixy ixz iyz]`, kg m^2.
    pub inertia_kgm2: [f64; 6],
    /// Tool centre point in the flange frame, m, when the payload defines one.
    pub tcp_m: Option<[f64; 3]>,
}

impl PayloadRecord {
    /// The twin's event: `payload` attached from `t_s` (s) on, or nothing (`None`, mass 0).
    pub fn of(event: &crate::model::payload::PayloadEvent) -> Self {
        match &event.payload {
            Some(p) => Self::new(event.t_s, p),
            None => PayloadRecord {
                t_s: event.t_s,
                name: "none".into(),
                mass_kg: 0.0,
                com_m: [0.0; 3],
                inertia_kgm2: [0.0; 6],
                tcp_m: None,
            },
        }
    }

    /// The event this record describes (mass 0: nothing on the flange). Errors
    /// ([`Error::InvalidInput`]): a negative or non-finite mass or time, or mass properties
    /// that are not physically consistent.
    pub fn event(&self) -> Result<crate::model::payload::PayloadEvent> {
        use crate::model::RigidInertia;
        use nalgebra::Vector3;
        if !(self.t_s.is_finite() && self.mass_kg.is_finite() && self.mass_kg >= 0.0) {
            return Err(Error::InvalidInput(format!(
                "payload '{}': t_s = {} s and mass_kg = {} kg must be finite, the mass >= 0",
                self.name, self.t_s, self.mass_kg
            )));
        }
        let payload = if self.mass_kg == 0.0 {
            None
        } else {
            let inertia =
                RigidInertia::new(self.mass_kg, Vector3::from(self.com_m), self.inertia_kgm2);
            inertia
                .validate(&format!("payload '{}'", self.name))
                .map_err(|e| Error::InvalidInput(e.to_string()))?;
            Some(Payload {
                name: self.name.clone(),
                inertia,
                tcp: self.tcp_m.map(Vector3::from),
            })
        };
        Ok(crate::model::payload::PayloadEvent {
            t_s: self.t_s,
            payload,
        })
    }

    /// `payload` attached from `t_s` (s) on.
    pub fn new(t_s: f64, payload: &Payload) -> Self {
        let b = &payload.inertia;
        let i = &b.inertia_com;
        PayloadRecord {
            t_s,
            name: payload.name.clone(),
            mass_kg: b.mass,
            com_m: [b.com.x, b.com.y, b.com.z],
            inertia_kgm2: tensor_elements(i),
            tcp_m: payload.tcp.map(|p| [p.x, p.y, p.z]),
        }
    }
}

/// A standard parameter vector with its layout (see [`ParamLayout`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StandardParams {
    /// Coulomb and viscous friction columns `fc{j}`, `fv{j}` are present.
    pub friction: bool,
    /// Rotor-inertia columns `Ia{j}` are present.
    pub armature: bool,
    /// Parameter names in layout order (`XX1` ... `M1`, `fc1`, `fv1`, `Ia1`, `XX2`, ...).
    pub names: Vec<String>,
    /// Values: kg m^2 (`XX`..`YZ`, `Ia`), kg m (`MX`..`MZ`), kg (`M`), N m (`fc`),
    /// N m s/rad (`fv`).
    pub values: Vec<f64>,
}

impl StandardParams {
    /// Names from `layout` with the values `theta`; errors ([`Error::InvalidInput`]) when
    /// the lengths differ.
    pub fn new(layout: &ParamLayout, theta: Vec<f64>) -> Result<Self> {
        if theta.len() != layout.len() {
            return Err(Error::InvalidInput(format!(
                "standard parameter vector has {} entries, the layout has {}",
                theta.len(),
                layout.len()
            )));
        }
        Ok(StandardParams {
            friction: layout.friction,
            armature: layout.armature,
            names: layout.names(),
            values: theta,
        })
    }
}

/// Base parameters with their regrouping relations (see [`BaseParams`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseParamsInfo {
    /// Base parameter names (`R` appended where parameters are regrouped).
    pub names: Vec<String>,
    /// Values, in the unit of the kept standard parameter.
    pub values: Vec<f64>,
    /// `base = standard + sum coef * dropped`, one relation per base parameter.
    pub relations: Vec<Relation>,
}

impl BaseParamsInfo {
    /// The base parameters of `base` for the standard vector `theta` (layout of
    /// `base.layout()`); errors when `theta` has the wrong length.
    pub fn new(base: &BaseParams, theta: &[f64]) -> Result<Self> {
        Ok(BaseParamsInfo {
            names: base.base_names(),
            values: base.base_values(theta)?,
            relations: base.relations(),
        })
    }
}

/// Summary figures of the recorded data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Summary {
    /// Simulated time, `rows * dt`, s.
    pub duration_s: f64,
    /// Total motor energy, J ([`Recording::energy_total`]).
    #[serde(rename = "energy_total_J")]
    pub energy_total_j: f64,
    /// Grid-side energy, J ([`Recording::energy_grid`]).
    #[serde(rename = "energy_grid_J")]
    pub energy_grid_j: f64,
    /// Rows of the truth table.
    pub truth_rows: usize,
    /// Rows of the measured table.
    pub measured_rows: usize,
}

impl Summary {
    /// The figures of `truth` and `measured`.
    pub fn of(truth: &Recording, measured: &Measured) -> Self {
        Summary {
            duration_s: truth.len() as f64 * truth.dt,
            energy_total_j: truth.energy_total(),
            energy_grid_j: truth.energy_grid(),
            truth_rows: truth.len(),
            measured_rows: measured.t.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urdf_hash_is_sha256() {
        let u = Urdf::inline("abc");
        assert_eq!(
            u.sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(Urdf::file("r.urdf", "abc").sha256, u.sha256);
    }
}
