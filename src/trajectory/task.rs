//! A task scenario: linear TCP moves through named via points with a tool, loads picked and
//! released on the way, and the speed/load sweep to run it at. The built-in scenario is the
//! pick-and-place task of Liu et al. 2018, Figure 12 ([`Scenario::builtin`]).
//!
//! # File format (TOML)
//! `scenarios/pick_and_place.toml` documents every key with its unit. In short: `name`,
//! `tool` (a built-in payload name, a `*.payload.toml` path relative to the scenario file, or
//! `"none"` when the robot model already carries its end effector, e.g. the Panda's hand; then
//! `tcp_m` gives the TCP in the flange frame, m), `seed_deg` (IK start configuration, deg),
//! `path` (via point names in order), `[orientation]` (`x_base`, `z_base`: the TCP axes in
//! the base frame, shared by all via points), `[points]` (name = TCP position in the base frame, m), `[[loads]]` (`name`, `pick_at`, `release_at`:
//! 1-based steps of `path`; `mass_fraction` of the load level), `[motion]` (optional,
//! [`LinearMoveOptions`] with `[motion.limits]` = [`MotionLimits`](super::linear_move::MotionLimits))
//! and `[sweep]` (`speeds_m_s`, `loads_kg`). Unknown keys are errors.
//!
//! # Loads
//! A load is a steel cube ([`Payload::cube`]) with its centre of mass at the tool's TCP. For a
//! load level `L` (kg) it weighs `mass_fraction * L`; it is picked when the TCP arrives at step
//! `pick_at` and released when it arrives at step `release_at`. `L = 0` leaves the tool alone
//! on the flange throughout.

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;

use crate::error::{Error, Result};
use crate::model::Robot;
use crate::model::builtin;
use crate::model::payload::Payload;
use crate::model::payload::PayloadEvent;

use super::linear_move::{self, LinearMotion, LinearMoveOptions, SegmentTiming, ViaPose};

/// The `tool` of a scenario whose robot model already carries its end effector.
pub const NO_TOOL: &str = "none";

/// Tolerance on the unit length and orthogonality of the orientation axes.
const AXIS_TOL: f64 = 1e-6;

/// The speeds and load levels to run a scenario at.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    /// Commanded TCP speeds, m/s (finite, > 0).
    pub speeds_m_s: Vec<f64>,
    /// Load levels `L`, kg (finite, >= 0).
    pub loads_kg: Vec<f64>,
}

/// A load carried between two steps of the path.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Load {
    /// Display name.
    pub name: String,
    /// Step of the path (1-based) at whose arrival the load is picked.
    pub pick_at: usize,
    /// Step of the path (1-based) at whose arrival it is released (> `pick_at`).
    pub release_at: usize,
    /// Mass as a fraction of the load level `L` (finite, > 0).
    pub mass_fraction: f64,
}

/// A task scenario (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Display name.
    pub name: String,
    /// The tool (flange frame), or `None` when the robot model already carries its end
    /// effector (`tool = "none"`).
    pub tool: Option<Payload>,
    /// Joint configuration the inverse kinematics starts from, rad.
    pub seed_rad: Vec<f64>,
    /// Timing options and motion bounds of the linear moves.
    pub motion: LinearMoveOptions,
    /// Speeds and load levels to run the task at.
    pub sweep: Sweep,
    /// Via point names in order.
    path: Vec<String>,
    /// TCP positions by name, base frame, m.
    points: BTreeMap<String, Vector3<f64>>,
    /// TCP orientation at every via point, base frame.
    orientation: UnitQuaternion<f64>,
    /// TCP position in the flange frame, m (the tool's, or `tcp_m` without a tool).
    tcp_m: Vector3<f64>,
    /// Loads, sorted by `pick_at`, not overlapping.
    loads: Vec<Load>,
}

/// A via point reached during a run.
#[derive(Debug, Clone, PartialEq)]
pub struct ViaArrival {
    /// Via point name.
    pub name: String,
    /// Arrival time, s.
    pub arrival_s: f64,
    /// TCP position, base frame, m.
    pub tcp_m: Vector3<f64>,
}

/// A scenario planned at one speed and load level.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskRun {
    /// The joint motion (implements [`super::Trajectory`]) with arrival times and slowed
    /// segments.
    pub motion: LinearMotion,
    /// What the flange carries: the tool from `t = 0`, tool and load from each pick, the tool
    /// again from each release (sorted by time).
    pub events: Vec<PayloadEvent>,
    /// Every step of the path with its arrival time.
    pub via: Vec<ViaArrival>,
}

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioFile {
    name: String,
    tool: String,
    tcp_m: Option<[f64; 3]>,
    seed_deg: Vec<f64>,
    path: Vec<String>,
    orientation: OrientationFile,
    points: BTreeMap<String, [f64; 3]>,
    #[serde(default)]
    loads: Vec<Load>,
    #[serde(default)]
    motion: LinearMoveOptions,
    sweep: Sweep,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OrientationFile {
    x_base: [f64; 3],
    z_base: [f64; 3],
}

impl Scenario {
    /// Parse a scenario's text; `label` names it in messages. A tool given as a file path is
    /// read relative to the current directory.
    ///
    /// Errors: [`Error::Toml`] for malformed TOML, unknown or missing keys (with line and
    /// column), an unknown via point name in `path`, non-finite or out-of-range values, axes
    /// that are not unit and orthogonal, a tool without TCP, overlapping loads; the errors of
    /// [`Payload::from_file`] for a tool file.
    pub fn from_toml_str(text: &str, label: &str) -> Result<Scenario> {
        parse(text, label, Path::new(""))
    }

    /// Read and parse a scenario file (see [`Scenario::from_toml_str`]); a tool file path is
    /// relative to the scenario's directory. I/O failures give [`Error::Io`].
    pub fn from_file(path: &Path) -> Result<Scenario> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let dir = path.parent().unwrap_or(Path::new(""));
        parse(&text, &path.display().to_string(), dir)
    }

    /// The built-in pick-and-place scenario ([`builtin::PICK_AND_PLACE`]).
    pub fn builtin() -> Result<Scenario> {
        Scenario::from_toml_str(
            builtin::PICK_AND_PLACE,
            "built-in scenario 'pick_and_place'",
        )
    }

    /// Via point names in order (the first is the start).
    pub fn path(&self) -> &[String] {
        &self.path
    }

    /// TCP position of a named via point, base frame, m.
    pub fn point(&self, name: &str) -> Option<Vector3<f64>> {
        self.points.get(name).copied()
    }

    /// TCP orientation at every via point, base frame.
    pub fn orientation(&self) -> UnitQuaternion<f64> {
        self.orientation
    }

    /// The loads, sorted by pick step.
    pub fn loads(&self) -> &[Load] {
        &self.loads
    }

    /// TCP pose in the flange frame, m: the tool's TCP (or the scenario's `tcp_m` when the
    /// robot carries its own end effector), with the flange orientation.
    pub fn tcp(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.tcp_m), UnitQuaternion::identity())
    }

    /// The heaviest payload (tool and load) the flange carries at load level `load_kg` (kg):
    /// the tool's mass plus the heaviest load's share of `load_kg` (loads never overlap), kg.
    pub fn max_payload_kg(&self, load_kg: f64) -> f64 {
        let heaviest = self
            .loads
            .iter()
            .map(|l| l.mass_fraction)
            .fold(0.0, f64::max);
        self.tool.as_ref().map_or(0.0, |t| t.inertia.mass) + heaviest * load_kg
    }

    /// Number of segments of the path (via points minus one); segment `k` runs from step
    /// `k + 1` to step `k + 2` of `path` (1-based steps).
    pub fn segments(&self) -> usize {
        self.path.len() - 1
    }

    /// The via poses of the path in order: TCP poses in the base frame, m.
    pub fn via_poses(&self) -> Vec<ViaPose> {
        self.path
            .iter()
            .map(|name| ViaPose {
                name: name.clone(),
                tcp: Isometry3::from_parts(Translation3::from(self.points[name]), self.orientation),
            })
            .collect()
    }

    /// The same task moved in the robot's base frame: every via point (and the TCP
    /// orientation) rotated by `yaw_rad` about the base z axis, then translated by
    /// `offset_m` (m). The loads, tool and timing are unchanged.
    pub fn moved(&self, offset_m: &Vector3<f64>, yaw_rad: f64) -> Scenario {
        let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_rad);
        let mut out = self.clone();
        for p in out.points.values_mut() {
            *p = rot * *p + offset_m;
        }
        out.orientation = rot * self.orientation;
        out
    }

    /// Plan the task on `robot` (bare, without payload) at the commanded TCP speed
    /// `speed_m_s` (m/s) and load level `load_kg` (kg, see the [module docs](self)), with
    /// the scenario's acceleration bound and dwell on every segment.
    ///
    /// Errors: [`Error::InvalidInput`] for a load level that is not finite and non-negative;
    /// the errors of [`linear_move::plan`] (unreachable via points and joint-limit problems
    /// name the via point or the segment).
    pub fn plan(&self, robot: &Robot, speed_m_s: f64, load_kg: f64) -> Result<TaskRun> {
        self.run_of(self.plan_speed(robot, speed_m_s)?, load_kg)
    }

    /// The joint motion of [`Scenario::plan`] at `speed_m_s` (m/s), which does not depend on
    /// the load: plan it once for every load level ([`Scenario::run_of`]).
    pub fn plan_speed(&self, robot: &Robot, speed_m_s: f64) -> Result<LinearMotion> {
        if !(speed_m_s.is_finite() && speed_m_s > 0.0) {
            return Err(Error::InvalidInput(format!(
                "TCP speed {speed_m_s} m/s must be finite and positive"
            )));
        }
        self.plan_motion(robot, &self.uniform(speed_m_s))
    }

    /// The timing of [`Scenario::plan`]: `speed_m_s` (m/s), the scenario's acceleration bound
    /// and dwell on every segment.
    pub fn uniform(&self, speed_m_s: f64) -> Vec<SegmentTiming> {
        vec![
            SegmentTiming {
                speed_m_s,
                accel_m_s2: self.motion.limits.accel_m_s2,
                dwell_s: self.motion.dwell_s,
            };
            self.segments()
        ]
    }

    /// Plan the task with one timing per segment ([`linear_move::plan_timed`]); otherwise as
    /// [`Scenario::plan`].
    pub fn plan_timed(
        &self,
        robot: &Robot,
        timing: &[SegmentTiming],
        load_kg: f64,
    ) -> Result<TaskRun> {
        self.run_of(self.plan_motion(robot, timing)?, load_kg)
    }

    /// The task run of `motion` (a joint motion of this task, [`Scenario::plan_motion`]) at
    /// load level `load_kg` (kg): its payload events and via-point arrivals.
    pub fn run_of(&self, motion: LinearMotion, load_kg: f64) -> Result<TaskRun> {
        let events = self.payload_events(&motion.arrivals_s, load_kg)?;
        let via = self
            .via_poses()
            .into_iter()
            .zip(&motion.arrivals_s)
            .map(|(v, &t)| ViaArrival {
                name: v.name,
                arrival_s: t,
                tcp_m: v.tcp.translation.vector,
            })
            .collect();
        Ok(TaskRun {
            motion,
            events,
            via,
        })
    }

    /// The joint motion of the task with one timing per segment, which does not depend on
    /// the load: [`Scenario::plan_timed`] without its payloads.
    pub fn plan_motion(&self, robot: &Robot, timing: &[SegmentTiming]) -> Result<LinearMotion> {
        linear_move::plan_timed(
            robot,
            &self.tcp(),
            &self.seed_rad,
            &self.via_poses(),
            timing,
            &self.motion,
        )
    }

    /// What the flange carries at load level `load_kg` (kg) along a motion of the task whose
    /// steps are reached at `arrivals_s` (s, one per step): the tool from `t = 0`, tool and
    /// load from each pick, the tool again from each release (sorted by time).
    pub fn payload_events(&self, arrivals_s: &[f64], load_kg: f64) -> Result<Vec<PayloadEvent>> {
        let payloads = self.segment_payloads(load_kg)?;
        if arrivals_s.len() != payloads.len() + 1 {
            return Err(Error::InvalidInput(format!(
                "{} arrival times for a task of {} segments",
                arrivals_s.len(),
                payloads.len()
            )));
        }
        // What the flange carries changes on arrival at a pick or release step.
        let mut events = vec![PayloadEvent {
            t_s: 0.0,
            payload: self.tool.clone(),
        }];
        for k in 1..payloads.len() {
            if payloads[k] != payloads[k - 1] {
                events.push(PayloadEvent {
                    t_s: arrivals_s[k],
                    payload: payloads[k].clone(),
                });
            }
        }
        if let Some(last) = payloads.last()
            && *last != self.tool
        {
            events.push(PayloadEvent {
                t_s: arrivals_s[payloads.len()],
                payload: self.tool.clone(),
            });
        }
        Ok(events)
    }

    /// What the flange carries on each segment at load level `load_kg` (kg): the tool, or the
    /// tool with the load picked at the segment's start step or before and released at its
    /// end step or after. Errors: a load level that is not finite and non-negative.
    pub fn segment_payloads(&self, load_kg: f64) -> Result<Vec<Option<Payload>>> {
        if !(load_kg.is_finite() && load_kg >= 0.0) {
            return Err(Error::InvalidInput(format!(
                "load level {load_kg} kg must be finite and non-negative"
            )));
        }
        let tcp = self.tcp();
        let mut out = vec![self.tool.clone(); self.segments()];
        if load_kg > 0.0 {
            for load in &self.loads {
                let mass = load.mass_fraction * load_kg;
                let cube = Payload::cube(
                    &format!("{} ({mass} kg)", load.name),
                    mass,
                    tcp.translation.vector,
                )?;
                let carried = match &self.tool {
                    Some(tool) => tool.combined(&cube),
                    None => cube,
                };
                // Segment k starts at step k + 1 and ends at step k + 2 (1-based).
                for (k, p) in out.iter_mut().enumerate() {
                    if load.pick_at <= k + 1 && k + 2 <= load.release_at {
                        *p = Some(carried.clone());
                    }
                }
            }
        }
        Ok(out)
    }
}

/// Parse and check a scenario; `dir` resolves a tool file path.
fn parse(text: &str, label: &str, dir: &Path) -> Result<Scenario> {
    let err = |message: String| Error::Toml {
        file: label.to_string(),
        message,
    };
    let file: ScenarioFile =
        toml::from_str(text).map_err(|e| err(e.to_string().trim_end().to_string()))?;

    let (tool, tcp_m) = tool_and_tcp(&file, dir, err)?;
    if let Some(i) = file.seed_deg.iter().position(|v| !v.is_finite()) {
        return Err(err(format!("seed_deg[{}] must be finite", i + 1)));
    }
    let points = via_points(&file.points, &file.path).map_err(err)?;
    let orientation = orientation(&file.orientation).map_err(err)?;
    let loads = sorted_loads(file.loads, file.path.len()).map_err(err)?;
    let sweep = file.sweep;
    check_sweep(&sweep).map_err(err)?;

    Ok(Scenario {
        name: file.name,
        tool,
        seed_rad: file.seed_deg.iter().map(|d| d.to_radians()).collect(),
        motion: file.motion,
        sweep,
        path: file.path,
        points,
        orientation,
        tcp_m,
        loads,
    })
}

/// The scenario's tool (`None` for [`NO_TOOL`]) and the TCP in the flange frame (m): the
/// file's `tcp_m` without a tool, else the tool's own. `err` makes a file error; a tool file
/// that cannot be read or parsed gives its own error.
fn tool_and_tcp(
    file: &ScenarioFile,
    dir: &Path,
    err: impl Fn(String) -> Error,
) -> Result<(Option<Payload>, Vector3<f64>)> {
    if file.tool == NO_TOOL {
        let Some(tcp) = file.tcp_m else {
            return Err(err(format!(
                "tool = \"{NO_TOOL}\" needs tcp_m, the TCP in the flange frame (m)"
            )));
        };
        if !tcp.iter().all(|v| v.is_finite()) {
            return Err(err(format!("tcp_m = {tcp:?} must be finite")));
        }
        return Ok((None, Vector3::from(tcp)));
    }
    if file.tcp_m.is_some() {
        return Err(err(format!(
            "tcp_m applies only to tool = \"{NO_TOOL}\"; tool '{}' defines its own TCP",
            file.tool
        )));
    }
    let tool = if builtin::is_payload_name(&file.tool) {
        builtin::payload(&file.tool)?
    } else {
        Payload::from_file(&dir.join(&file.tool))?
    };
    let Some(tcp) = tool.tcp else {
        return Err(err(format!(
            "tool '{}' defines no TCP (tcp_m); linear moves need one",
            file.tool
        )));
    };
    Ok((Some(tool), tcp))
}

/// The via points by name (TCP positions, base frame, m), checked finite, and a `path` of at
/// least two steps that names only them; or why not.
fn via_points(
    points: &BTreeMap<String, [f64; 3]>,
    path: &[String],
) -> std::result::Result<BTreeMap<String, Vector3<f64>>, String> {
    let mut out = BTreeMap::new();
    for (name, p) in points {
        if !p.iter().all(|v| v.is_finite()) {
            return Err(format!("points.{name} = {p:?} must be finite"));
        }
        out.insert(name.clone(), Vector3::from(*p));
    }
    if path.len() < 2 {
        return Err(format!(
            "path has {} via points; it needs at least 2 (the start and a target)",
            path.len()
        ));
    }
    for (k, name) in path.iter().enumerate() {
        if !out.contains_key(name) {
            let known: Vec<&str> = out.keys().map(String::as_str).collect();
            return Err(format!(
                "path[{}] = '{name}' is not a via point (defined in [points]: {})",
                k + 1,
                known.join(", ")
            ));
        }
    }
    Ok(out)
}

/// The loads sorted by `pick_at`, each within the `steps` of the path with a positive mass
/// fraction and none picked before the previous one is released; or why not.
fn sorted_loads(mut loads: Vec<Load>, steps: usize) -> std::result::Result<Vec<Load>, String> {
    loads.sort_by_key(|l| l.pick_at);
    for (k, l) in loads.iter().enumerate() {
        if !(1 <= l.pick_at && l.pick_at < l.release_at && l.release_at <= steps) {
            return Err(format!(
                "load '{}': pick_at = {} and release_at = {} must satisfy \
                 1 <= pick_at < release_at <= {steps} (steps of path)",
                l.name, l.pick_at, l.release_at
            ));
        }
        if !(l.mass_fraction.is_finite() && l.mass_fraction > 0.0) {
            return Err(format!(
                "load '{}': mass_fraction = {} must be finite and positive",
                l.name, l.mass_fraction
            ));
        }
        if k > 0 && l.pick_at < loads[k - 1].release_at {
            return Err(format!(
                "load '{}' is picked at step {} before load '{}' is released at step {}",
                l.name,
                l.pick_at,
                loads[k - 1].name,
                loads[k - 1].release_at
            ));
        }
    }
    Ok(loads)
}

/// Check that the sweep has speeds (m/s, finite and positive) and load levels (kg, finite
/// and non-negative), at least one of each.
fn check_sweep(sweep: &Sweep) -> std::result::Result<(), String> {
    if sweep.speeds_m_s.is_empty() || sweep.loads_kg.is_empty() {
        return Err("sweep.speeds_m_s and sweep.loads_kg need at least one value each".into());
    }
    if let Some(v) = sweep
        .speeds_m_s
        .iter()
        .find(|v| !(v.is_finite() && **v > 0.0))
    {
        return Err(format!(
            "sweep.speeds_m_s contains {v}; speeds must be finite and positive"
        ));
    }
    if let Some(v) = sweep
        .loads_kg
        .iter()
        .find(|v| !(v.is_finite() && **v >= 0.0))
    {
        return Err(format!(
            "sweep.loads_kg contains {v}; loads must be finite and non-negative"
        ));
    }
    Ok(())
}

/// The rotation whose x and z axes are `x_base` and `z_base` (unit within [`AXIS_TOL`] and
/// orthogonal), or why not.
fn orientation(o: &OrientationFile) -> std::result::Result<UnitQuaternion<f64>, String> {
    let x = Vector3::from(o.x_base);
    let z = Vector3::from(o.z_base);
    for (name, v) in [("x_base", &x), ("z_base", &z)] {
        if !(v.iter().all(|c| c.is_finite()) && (v.norm() - 1.0).abs() <= AXIS_TOL) {
            return Err(format!(
                "orientation.{name} = {:?} must be a unit vector",
                v.as_slice()
            ));
        }
    }
    if x.dot(&z).abs() > AXIS_TOL {
        return Err(format!(
            "orientation.x_base and z_base are not orthogonal (dot product {:.3e})",
            x.dot(&z)
        ));
    }
    let x = x.normalize();
    let z = (z - x * x.dot(&z)).normalize();
    let m = Matrix3::from_columns(&[x, z.cross(&x), z]);
    Ok(UnitQuaternion::from_rotation_matrix(
        &Rotation3::from_matrix_unchecked(m),
    ))
}
