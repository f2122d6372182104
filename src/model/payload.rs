//! Tools and loads carried at the tool flange.
//!
//! # Frame and units
//! A payload is described in the **flange frame** `tool0` (ROS-Industrial convention: origin at
//! the centre of the mounting face, z along the flange normal pointing away from the robot).
//! Mass in kg, centre of mass and tool centre point in m, inertia tensor about the COM in
//! kg m^2 with flange-frame axes; products of inertia are tensor elements (`Ixy = -∫ x y dm`,
//! as in URDF).
//!
//! # File format (TOML)
//! ```toml
//! name = "tool 1.32 kg"
//! frame = "tool0"                     # the only supported frame
//! mass_kg = 1.32
//! com_m = [0.0, 0.0, 0.060]
//! inertia_kgm2 = [2.112e-3, 2.112e-3, 1.056e-3, 0.0, 0.0, 0.0]   # ixx iyy izz ixy ixz iyz
//! tcp_m = [0.0, 0.0, 0.120]           # optional tool centre point
//! ```
//! Following Liu et al. 2018, a payload is treated as part of the last link ([`attach`]).

use std::path::Path;

use nalgebra::Vector3;
use serde::Deserialize;

use crate::error::{Error, Result};
use crate::model::{RigidInertia, Robot};

/// The only frame a payload file may be written in: the tool flange.
const FLANGE_FRAME: &str = "tool0";

/// Density of the steel of [`Payload::cube`], kg/m^3.
pub const STEEL_DENSITY_KG_M3: f64 = 7850.0;

/// A rigid payload (tool, load, or both) fixed to the tool flange.
#[derive(Debug, Clone, PartialEq)]
pub struct Payload {
    /// Display name.
    pub name: String,
    /// Mass properties in the flange frame `tool0` (kg, m, kg m^2 about the COM).
    pub inertia: RigidInertia,
    /// Tool centre point in the flange frame, m, when the payload defines one.
    pub tcp: Option<Vector3<f64>>,
}

/// A payload change at a time: from `t_s` on, the flange carries `payload` (`None` = bare).
#[derive(Debug, Clone, PartialEq)]
pub struct PayloadEvent {
    /// Event time, s.
    pub t_s: f64,
    /// What the flange carries from then on (tool and load combined).
    pub payload: Option<Payload>,
}

/// The timeline `events` (sorted by time) with what the flange carries at `start_s` (s) in
/// force from `-inf`: a robot holds the payload it starts a log or a motion with before that
/// too, and the power lag and an averaging meter's first period reach back there. Events
/// after `start_s` are kept as they are; with none at or before it, the flange is bare
/// before the first.
pub fn carried_from_before(events: &[PayloadEvent], start_s: f64) -> Vec<PayloadEvent> {
    let after = events.partition_point(|e| e.t_s <= start_s);
    let mut out = Vec::with_capacity(events.len() - after + 1);
    if after > 0 {
        out.push(PayloadEvent {
            t_s: f64::NEG_INFINITY,
            payload: events[after - 1].payload.clone(),
        });
    }
    out.extend_from_slice(&events[after..]);
    out
}

/// Refuse a payload above the robot's rated payload: `mass_kg` (tool and load at the flange,
/// kg) against `rated_kg` (kg, from the drive file; `None` = no rating, nothing to check).
/// `what` names the payload in the message.
///
/// Errors ([`Error::InvalidInput`]): `mass_kg` is not finite, or exceeds `rated_kg`.
pub fn check_rated(mass_kg: f64, rated_kg: Option<f64>, what: &str) -> Result<()> {
    if !mass_kg.is_finite() {
        return Err(Error::InvalidInput(format!(
            "{what}: payload mass {mass_kg} kg must be finite"
        )));
    }
    match rated_kg {
        Some(rated) if mass_kg > rated => Err(Error::InvalidInput(format!(
            "{what}: payload of {mass_kg} kg (tool and load) exceeds the robot's rated payload \
             of {rated} kg (rated_payload_kg in the drive file)"
        ))),
        _ => Ok(()),
    }
}

/// The TOML file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PayloadFile {
    name: String,
    frame: String,
    mass_kg: f64,
    com_m: [f64; 3],
    inertia_kgm2: [f64; 6],
    tcp_m: Option<[f64; 3]>,
}

impl Payload {
    /// Parse a payload file's text; `label` names the file in error messages.
    ///
    /// Errors ([`Error::Toml`]): malformed TOML or unknown/missing keys (with the parser's line
    /// and column), a frame other than `tool0`, a non-positive mass, non-finite values, or an
    /// inertia tensor that is not physically consistent ([`RigidInertia::validate`]).
    pub fn from_toml_str(text: &str, label: &str) -> Result<Payload> {
        let err = |message: String| Error::Toml {
            file: label.to_string(),
            message,
        };
        let file: PayloadFile =
            toml::from_str(text).map_err(|e| err(e.to_string().trim_end().to_string()))?;
        if file.frame != FLANGE_FRAME {
            return Err(err(format!(
                "frame = '{}' is not supported; payloads are given in the flange frame '{FLANGE_FRAME}'",
                file.frame
            )));
        }
        if let Some(tcp) = file.tcp_m
            && !tcp.iter().all(|v| v.is_finite())
        {
            return Err(err(format!("tcp_m = {tcp:?} must be finite")));
        }
        let inertia = RigidInertia::new(file.mass_kg, Vector3::from(file.com_m), file.inertia_kgm2);
        inertia
            .validate(&format!("payload '{}'", file.name))
            .map_err(|e| match e {
                Error::Model(m) => err(m),
                other => other,
            })?;
        Ok(Payload {
            name: file.name,
            inertia,
            tcp: file.tcp_m.map(Vector3::from),
        })
    }

    /// Read and parse a payload file (see [`Payload::from_toml_str`]); I/O failures give
    /// [`Error::Io`].
    pub fn from_file(path: &Path) -> Result<Payload> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Payload::from_toml_str(&text, &path.display().to_string())
    }

    /// A solid steel cube ([`STEEL_DENSITY_KG_M3`]) of `mass_kg` with its centre of mass at
    /// `com_m` (flange frame, m), edges along the flange axes, without a TCP: side
    /// `a = (m / rho)^(1/3)`, `Ixx = Iyy = Izz = m a^2 / 6` about the COM. The loads of
    /// `docs/design/irb1200-data.md`, section 5.4. Errors ([`Error::InvalidInput`]): a mass
    /// that is not finite and positive, a non-finite COM.
    pub fn cube(name: &str, mass_kg: f64, com_m: Vector3<f64>) -> Result<Payload> {
        if !(mass_kg.is_finite() && mass_kg > 0.0) {
            return Err(Error::InvalidInput(format!(
                "cube '{name}': mass {mass_kg} kg must be finite and positive"
            )));
        }
        crate::error::ensure_finite(com_m.as_slice(), &format!("cube '{name}' com_m"))?;
        let side = (mass_kg / STEEL_DENSITY_KG_M3).cbrt();
        let i = mass_kg * side * side / 6.0;
        Ok(Payload {
            name: name.to_string(),
            inertia: RigidInertia::new(mass_kg, com_m, [i, i, i, 0.0, 0.0, 0.0]),
            tcp: None,
        })
    }

    /// The rigid union of two payloads (both in the flange frame), e.g. tool + load. The TCP is
    /// `self`'s when it has one, else `other`'s.
    pub fn combined(&self, other: &Payload) -> Payload {
        Payload {
            name: format!("{} + {}", self.name, other.name),
            inertia: self.inertia.combined(&other.inertia),
            tcp: self.tcp.or(other.tcp),
        }
    }

    /// The payload's mass properties in the robot's last link frame (via [`Robot::flange`]).
    pub fn in_last_link_frame(&self, robot: &Robot) -> RigidInertia {
        self.inertia.transformed(robot.flange())
    }
}

/// A copy of `robot` whose last link carries `payload` (the paper's "load treated as part of
/// link 6"). Errors if the combined body fails [`RigidInertia::validate`].
pub fn attach(robot: &Robot, payload: &Payload) -> Result<Robot> {
    let last = robot.dof() - 1;
    let inertia = robot.links()[last]
        .inertia
        .combined(&payload.in_last_link_frame(robot));
    robot.with_link_inertia(last, inertia)
}

/// A payload given on the command line or in a timeline: a built-in name
/// ([`crate::model::builtin::PAYLOAD_NAMES`]) or a payload TOML file (relative paths from
/// `dir`); several joined with `+` are combined (`tool+load_2kg`).
pub fn resolve(spec: &str, dir: &Path) -> Result<Payload> {
    let mut acc: Option<Payload> = None;
    for part in spec.split('+').map(str::trim) {
        if part.is_empty() {
            return Err(Error::InvalidInput(format!(
                "payload '{spec}': empty name between '+'"
            )));
        }
        let one = if crate::model::builtin::is_payload_name(part) {
            crate::model::builtin::payload(part)?
        } else {
            let path = dir.join(part);
            if !path.is_file() {
                return Err(Error::InvalidInput(format!(
                    "payload '{part}' is neither a built-in name ({}) nor a file",
                    crate::model::builtin::PAYLOAD_NAMES.join(", ")
                )));
            }
            Payload::from_file(&path)?
        };
        acc = Some(match acc {
            Some(a) => a.combined(&one),
            None => one,
        });
    }
    acc.ok_or_else(|| Error::InvalidInput("empty payload".into()))
}

/// One `[[event]]` of a payload timeline file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TimelineEntry {
    t_s: f64,
    payload: String,
}

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TimelineFile {
    event: Vec<TimelineEntry>,
}

/// Parse a payload timeline (TOML; `label` names the file in messages, `dir` resolves
/// payload files):
/// ```toml
/// [[event]]
/// t_s = 0.0
/// payload = "tool"            # a built-in name, a payload file, or several joined by '+'
/// [[event]]
/// t_s = 3.2
/// payload = "tool+load_2kg"
/// [[event]]
/// t_s = 7.5
/// payload = "none"            # nothing on the flange from here on
/// ```
/// Times in s on the log's clock; each payload applies until the next event, and the one in
/// force at the log's first sample was at the flange before it too ([`carried_from_before`]).
/// Errors ([`Error::Toml`]): malformed TOML, unknown keys, non-finite or decreasing times,
/// unknown payloads.
pub fn timeline_from_toml_str(text: &str, label: &str, dir: &Path) -> Result<Vec<PayloadEvent>> {
    let err = |message: String| Error::Toml {
        file: label.to_string(),
        message,
    };
    let file: TimelineFile =
        toml::from_str(text).map_err(|e| err(e.to_string().trim_end().to_string()))?;
    let mut out: Vec<PayloadEvent> = Vec::with_capacity(file.event.len());
    for (k, e) in file.event.iter().enumerate() {
        if !e.t_s.is_finite() || out.last().is_some_and(|p| e.t_s < p.t_s) {
            return Err(err(format!(
                "event {}: t_s = {} must be finite and not before the previous event",
                k + 1,
                e.t_s
            )));
        }
        let payload = if e.payload.trim() == "none" {
            None
        } else {
            Some(resolve(&e.payload, dir).map_err(|x| err(format!("event {}: {x}", k + 1)))?)
        };
        out.push(PayloadEvent {
            t_s: e.t_s,
            payload,
        });
    }
    Ok(out)
}

/// Read a payload timeline file (see [`timeline_from_toml_str`]).
pub fn timeline_from_file(path: &Path) -> Result<Vec<PayloadEvent>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    timeline_from_toml_str(&text, &path.display().to_string(), dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn event(t_s: f64, kg: Option<f64>) -> PayloadEvent {
        PayloadEvent {
            t_s,
            payload: kg.map(|m| Payload::cube("load", m, Vector3::zeros()).unwrap()),
        }
    }

    #[test]
    fn the_payload_a_log_starts_with_is_carried_before_it() {
        let mass = |e: &[PayloadEvent]| -> Vec<(f64, Option<f64>)> {
            e.iter()
                .map(|e| (e.t_s, e.payload.as_ref().map(|p| p.inertia.mass)))
                .collect()
        };
        let timeline = [event(0.0, Some(2.0)), event(5.0, None)];
        // In force at the start (0.002 s): from -inf; the later change as it was.
        assert_eq!(
            mass(&carried_from_before(&timeline, 0.002)),
            [(f64::NEG_INFINITY, Some(2.0)), (5.0, None)]
        );
        // Of two changes before the start, the later one is what the robot starts with.
        assert_eq!(
            mass(&carried_from_before(&timeline, 6.0)),
            [(f64::NEG_INFINITY, None)]
        );
        // A first change after the start leaves the flange bare before it.
        assert_eq!(mass(&carried_from_before(&timeline, -1.0)), mass(&timeline));
        assert!(carried_from_before(&[], 0.0).is_empty());
    }
}
