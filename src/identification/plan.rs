//! Pricing a planned motion that nobody has run: the energy an identified [`PowerModel`]
//! predicts for a joint trajectory (a CSV plan, or a scenario planned at a speed and load),
//! with its 95 % interval and the predicted power along the plan. No power is measured: the
//! states come from the plan itself, through [`PowerModel::predict`], the same call as the
//! "from the plan" figures of the held-out benchmark.

use std::path::Path;

use crate::error::{Error, Result};
use crate::identification::model::{PowerModel, Prediction};
use crate::io::table::Table;
use crate::model::Robot;
use crate::model::payload::PayloadEvent;
use crate::trajectory::Trajectory;
use crate::trajectory::limits::check_limits;
use crate::trajectory::sampled::Sampled;
use crate::trajectory::task::Scenario;

/// Integration step of a priced motion's energy, s (a plan's, and a log's motion in
/// `predict`).
pub const PLAN_DT_S: f64 = 1e-3;

/// Step at which a plan read from a file is checked against the joint limits, s.
pub const LIMIT_CHECK_DT_S: f64 = 1e-3;

/// Read a joint trajectory CSV for `robot` ([`Sampled::from_table`]: `t_s`, `q1_rad..qn_rad`,
/// optionally `dq*_rad_s` and `ddq*_rad_s2`; positions alone are interpolated by a C2 cubic
/// spline) and check it against the robot's joint positions and velocities.
///
/// Errors name the file: [`Error::Table`] with the row for a missing column, a non-number or
/// non-finite cell, fewer than 2 rows or times that do not increase; [`Error::InvalidInput`]
/// for a position column beyond the robot's joints; [`Error::JointLimit`] for the first
/// sample (in time) outside a position or velocity limit.
pub fn read_plan(robot: &Robot, path: &Path) -> Result<Sampled> {
    let table = Table::read(path)?;
    let label = table.label().to_string();
    let extra = robot.dof() + 1;
    if table
        .column(&[&format!("q{extra}_rad"), &format!("q{extra}")])
        .is_ok()
    {
        return Err(Error::InvalidInput(format!(
            "{label}: has a position column q{extra}, but robot '{}' has {} joints",
            robot.name(),
            robot.dof()
        )));
    }
    let traj = Sampled::from_table(&table, robot.dof())?;
    check_limits(robot, &traj, LIMIT_CHECK_DT_S, None).map_err(|e| {
        e.context(&if traj.start_time() == 0.0 {
            label.clone()
        } else {
            format!(
                "{label} (t from its first sample, t_s = {} s)",
                traj.start_time()
            )
        })
    })?;
    Ok(traj)
}

/// A plan's predicted energy and power.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanPrice {
    /// The energy of the modelled signal with its 95 % interval
    /// ([`PowerModel::predict`]).
    pub prediction: Prediction,
    /// Times of the power samples, s (trajectory time, from 0).
    pub t_s: Vec<f64>,
    /// Predicted power of the modelled signal at those times, W (for a clipped signal, DC bus
    /// or grid, never below its floor: [`PowerModel::reading`]).
    pub power_w: Vec<f64>,
}

impl PlanPrice {
    /// Mean predicted power over the plan, W: the energy divided by the duration (0 for a
    /// plan of zero duration).
    pub fn mean_power_w(&self) -> f64 {
        let d = self.prediction.duration_s;
        if d > 0.0 {
            self.prediction.energy_j / d
        } else {
            0.0
        }
    }
}

/// Price `traj` with `model` on `robot` while the flange carries the payloads of `events`
/// (trajectory time; none before the first): the energy of [`PowerModel::predict`] at the
/// step [`PLAN_DT_S`], and the power at the trajectory times `t_s` (s, clamped to the plan).
/// `efficiency`: the drives' nominal efficiency, used to add a payload to an
/// efficiency-scaled model.
///
/// Errors: a model of another robot, a payload that cannot be attached, an efficiency
/// outside (0, 1].
pub fn price(
    model: &PowerModel,
    robot: &Robot,
    traj: &dyn Trajectory,
    events: &[PayloadEvent],
    efficiency: f64,
    t_s: &[f64],
) -> Result<PlanPrice> {
    let prediction = model.predict(robot, traj, events, efficiency, PLAN_DT_S)?;
    let mut power_w = model.power_with_payloads(robot, traj, events, efficiency, t_s)?;
    power_w.iter_mut().for_each(|p| *p = model.reading(*p));
    Ok(PlanPrice {
        prediction,
        t_s: t_s.to_vec(),
        power_w,
    })
}

/// The cell of a scenario's sweep that `predict --scenario` prices when no speed or load is
/// given: the sweep speed nearest 0.5 m/s and the heaviest load level (the cell the sweep
/// shows as its representative), each replaced by `speed_m_s` / `load_kg` when given.
///
/// Errors: a scenario whose sweep has no speed (or no load level) when that one is not given.
pub fn scenario_cell(
    scenario: &Scenario,
    speed_m_s: Option<f64>,
    load_kg: Option<f64>,
) -> Result<(f64, f64)> {
    let missing = |what: &str| {
        Error::InvalidInput(format!(
            "scenario '{}' lists no {what} in [sweep]: give one",
            scenario.name
        ))
    };
    let speed = match speed_m_s {
        Some(v) => v,
        None => scenario
            .sweep
            .speeds_m_s
            .iter()
            .copied()
            .min_by(|a, b| (a - 0.5).abs().total_cmp(&(b - 0.5).abs()))
            .ok_or_else(|| missing("speed"))?,
    };
    let load = match load_kg {
        Some(v) => v,
        None => scenario
            .sweep
            .loads_kg
            .iter()
            .copied()
            .max_by(f64::total_cmp)
            .ok_or_else(|| missing("load level"))?,
    };
    Ok((speed, load))
}

/// Plan `scenario` on `robot` at `speed_m_s` (m/s) and load level `load_kg` (kg) as
/// [`Scenario::plan`] does (the tool from `t = 0`, each load from its pick to its release) and
/// price the plan with `model` as [`price`] does, the power at the plan's samples. The energy
/// is the one `sweep --model` predicts for that cell (same plan, payloads and step).
///
/// Errors: those of [`Scenario::plan`] (named by scenario, speed and load) and of [`price`].
pub fn price_scenario(
    model: &PowerModel,
    robot: &Robot,
    scenario: &Scenario,
    speed_m_s: f64,
    load_kg: f64,
    efficiency: f64,
) -> Result<PlanPrice> {
    let plan = scenario.plan(robot, speed_m_s, load_kg).map_err(|e| {
        e.context(&format!(
            "scenario '{}' at {speed_m_s} m/s with load {load_kg} kg",
            scenario.name
        ))
    })?;
    let traj = &plan.motion.trajectory;
    price(
        model,
        robot,
        traj,
        &plan.events,
        efficiency,
        traj.sample_times(),
    )
}
