//! Figure 14: the pick-and-place task over a speed x load grid on the twin, against the
//! energy an identified model predicts from the plan alone; the energy-optimal speed per load
//! and the energy / cycle-time trade-off. [`TwinChoice`] says which twin checks the cells:
//! the one of the input URDF and drive file ([`run`]), the identified model's own
//! ([`crate::identification::consistent::IdentifiedTwin::from_model`], also [`run`]), or none
//! ([`predict`]: the model's predictions alone).

use rayon::prelude::*;
use serde::Serialize;

use crate::dataset::Dataset;
use crate::error::{Error, Result};
use crate::identification::consistent::IdentifiedTwin;
use crate::identification::model::PowerModel;
use crate::identification::plan::PLAN_DT_S;
use crate::model::Robot;
use crate::optimize::segment::Task;
use crate::optimize::speed::{self, SpeedOptimum};
use crate::trajectory::linear_move::{LinearMotion, SlowedSegment};
use crate::trajectory::task::{Scenario, TaskRun};
use crate::twin::TorqueLimitHit;
use crate::validation::rig::{Progress, Rig};

/// Largest tracking error, rad, at which a twin run still counts as the planned task: beyond
/// what both the structure-matched and the realistic twin track on the built-in sweep (see
/// docs/experiments.md#tracking-error-bound), so only a run the drives cannot follow
/// (saturated torques, a payload far above the rating) exceeds it. 0.05 rad is about 3.5 cm
/// at the IRB 1200's 0.7 m reach. A real controller tracks far better: the realistic twin's PD
/// controller without integral action is an honest worst case, not a model of ABB's.
pub const TRACKING_ERROR_BOUND_RAD: f64 = 0.05;

/// Whether a twin run is flagged: a joint torque saturated, or the tracking error exceeded
/// [`TRACKING_ERROR_BOUND_RAD`] (or is not a number).
pub fn run_flagged(report: &crate::twin::RunReport) -> bool {
    !report.torque_limit_hits.is_empty()
        || report.max_tracking_error_rad.is_nan()
        || report.max_tracking_error_rad > TRACKING_ERROR_BOUND_RAD
}

/// Which twin checks a plan's energy (`sweep --twin`, `optimize --twin`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TwinChoice {
    /// The Rapier twin of the input URDF and drive file.
    #[default]
    Urdf,
    /// No twin: every plan is priced by the model alone ([`NO_PHYSICS_CHECK`]).
    None,
    /// The Rapier twin of the identified model's exported URDF and drive file
    /// ([`crate::identification::consistent::IdentifiedTwin::from_model`]).
    Identified,
}

/// What a result without a twin run says of itself.
pub const NO_PHYSICS_CHECK: &str = "no physics check ran (--twin none): energies are the model's predictions with their 95 % intervals";

impl TwinChoice {
    /// The name of the choice (`urdf`, `none`, `identified`), as in the results files.
    pub fn name(self) -> &'static str {
        match self {
            TwinChoice::Urdf => "urdf",
            TwinChoice::None => "none",
            TwinChoice::Identified => "identified",
        }
    }

    /// One line that says which twin ran: the input's, the identified model's, or
    /// [`NO_PHYSICS_CHECK`].
    pub fn statement(self) -> &'static str {
        match self {
            TwinChoice::Urdf => {
                "twin: the Rapier twin of the input URDF and drive file (--twin urdf)"
            }
            TwinChoice::None => NO_PHYSICS_CHECK,
            TwinChoice::Identified => {
                "twin: the Rapier twin of the identified model's consistent URDF and drive file (--twin identified)"
            }
        }
    }
}

impl std::str::FromStr for TwinChoice {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "urdf" => Ok(TwinChoice::Urdf),
            "none" => Ok(TwinChoice::None),
            "identified" => Ok(TwinChoice::Identified),
            other => Err(Error::InvalidInput(format!(
                "unknown twin '{other}' (expected urdf, none or identified)"
            ))),
        }
    }
}

/// The rig of the identified model's twin ([`TwinChoice::Identified`]): `twin`'s robot and
/// drives (its URDF text recorded in the datasets) with the physics, controller and logger
/// settings of `rig`.
pub fn identified_rig<'a>(twin: &'a IdentifiedTwin, rig: &Rig) -> Rig<'a> {
    Rig {
        plant: None,
        robot: &twin.robot,
        urdf: crate::dataset::meta::Urdf::inline(&twin.urdf()),
        drive: &twin.drive,
        twin: rig.twin.clone(),
        sensor: rig.sensor,
    }
}

/// One cell of the grid.
#[derive(Debug, Clone, Serialize)]
pub struct Cell {
    /// Commanded TCP speed, m/s.
    pub speed_m_s: f64,
    /// Load level L, kg (load 1 = L/2, the heavier load = L).
    pub load_kg: f64,
    /// Duration of the whole path, s.
    pub cycle_time_s: f64,
    /// Motor energy of the twin (regenerated energy counted negative), J.
    #[serde(rename = "simulated_J")]
    pub simulated_j: f64,
    /// Grid-side energy of the twin (`max(P, 0)`), J.
    #[serde(rename = "simulated_grid_J")]
    pub simulated_grid_j: f64,
    /// Motor energy the model predicts from the plan and the known payloads, J (`null`
    /// without a model).
    #[serde(rename = "predicted_J")]
    pub predicted_j: Option<f64>,
    /// Grid-side energy the model predicts, J.
    #[serde(rename = "predicted_grid_J")]
    pub predicted_grid_j: Option<f64>,
    /// `100 (predicted - simulated) / simulated`, motor energy, %.
    pub error_pct: Option<f64>,
    /// Segments the planner slowed down to respect joint limits.
    pub slowed: Vec<SlowedSegment>,
    /// Largest |q_ref - q| of the twin run over time and joints, rad.
    pub max_tracking_error_rad: f64,
    /// Joints whose torque command the twin clipped at the effort limit.
    pub torque_limit_hits: Vec<TorqueLimitHit>,
    /// Whether the twin did not perform the task as planned: a torque saturated or the
    /// tracking error exceeded [`TRACKING_ERROR_BOUND_RAD`]. Its energies are those of another
    /// motion.
    pub flagged: bool,
}

impl Cell {
    /// Why the cell is flagged (saturated joints, tracking error), `None` when it is not.
    pub fn flag_reason(&self) -> Option<String> {
        if !self.flagged {
            return None;
        }
        let mut why = Vec::new();
        if !self.torque_limit_hits.is_empty() {
            let joints: Vec<&str> = self
                .torque_limit_hits
                .iter()
                .map(|h| h.joint.as_str())
                .collect();
            why.push(format!("torque saturated on {}", joints.join(", ")));
        }
        if self.max_tracking_error_rad.is_nan()
            || self.max_tracking_error_rad > TRACKING_ERROR_BOUND_RAD
        {
            why.push(format!(
                "tracking error {:.3} rad > {TRACKING_ERROR_BOUND_RAD} rad",
                self.max_tracking_error_rad
            ));
        }
        Some(why.join("; "))
    }
}

/// The energy-optimal speed of one load level.
#[derive(Debug, Clone, Serialize)]
pub struct Optimum {
    /// Load level, kg.
    pub load_kg: f64,
    /// Speed of the grid cell with the least simulated energy, m/s.
    pub simulated_cell_m_s: f64,
    /// Minimum of a parabola in log speed through that cell and its neighbours, m/s, when the
    /// three cells have the same slowed segments (a smooth piece of the curve); else the
    /// cell's speed (a parabola across a planner kink would be fiction).
    pub simulated_interpolated_m_s: f64,
    /// Whether the neighbours of the least simulated cell have other slowed segments than it
    /// (the grid optimum sits at or near a planner limit).
    pub simulated_near_planner_limit: bool,
    /// The model's least-energy speed on its actual curve ([`crate::optimize::speed`];
    /// `null` without a model), with whether it sits on a planner limit.
    pub predicted: Option<SpeedOptimum>,
    /// Speed of least predicted energy, m/s (`predicted.speed_m_s`).
    pub predicted_m_s: Option<f64>,
    /// Predicted energy there, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: Option<f64>,
    /// Whether the simulated optimum lies strictly inside the speed range.
    pub interior: bool,
}

/// Outcome of the sweep.
pub struct Sweep {
    /// Cells, load-major in the scenario's order.
    pub cells: Vec<Cell>,
    /// Optimum per load.
    pub optima: Vec<Optimum>,
    /// Indices into `cells` of the cells no other cell of the same load beats in both energy
    /// and cycle time (the Pareto front per load, by cycle time).
    pub pareto: Vec<usize>,
    /// The twin's dataset of each cell.
    pub datasets: Vec<Dataset>,
    /// Each cell's plan.
    pub plans: Vec<TaskRun>,
}

impl Sweep {
    /// Index of the cell that shows the task best: the heaviest load at the speed nearest
    /// 0.5 m/s (the speed of the paper's Figure 13); `None` without cells.
    pub fn representative(&self) -> Option<usize> {
        let key = |c: &Cell| ((c.speed_m_s - 0.5).abs(), -c.load_kg);
        (0..self.cells.len()).min_by(|&a, &b| {
            key(&self.cells[a])
                .partial_cmp(&key(&self.cells[b]))
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    }
}

/// One cell of the grid, planned.
pub struct Planned {
    /// Commanded TCP speed, m/s.
    pub speed: f64,
    /// Load level, kg.
    pub load: f64,
    /// The plan.
    pub plan: TaskRun,
}

/// Plan every cell of the scenario's grid (load-major), so that an unreachable via point or
/// a speed the joints cannot follow is reported before anything runs. The joint motion does
/// not depend on the load: each speed is planned once (in parallel) and serves every load.
pub fn plan(robot: &Robot, scenario: &Scenario) -> Result<Vec<Planned>> {
    let (speeds, loads) = (&scenario.sweep.speeds_m_s, &scenario.sweep.loads_kg);
    if speeds.is_empty() || loads.is_empty() {
        return Err(Error::InvalidInput(
            "the sweep needs at least one speed and one load".into(),
        ));
    }
    let context = |speed: f64, load: Option<f64>| {
        let load = load.map_or(String::new(), |l| format!(" with load {l} kg"));
        format!("scenario '{}' at {speed} m/s{load}", scenario.name)
    };
    let motions: Vec<LinearMotion> = speeds
        .par_iter()
        .map(|&speed| {
            scenario
                .plan_speed(robot, speed)
                .map_err(|e| e.context(&context(speed, None)))
        })
        .collect::<Result<_>>()?;
    let mut grid = Vec::with_capacity(loads.len() * speeds.len());
    for &load in loads {
        for (&speed, motion) in speeds.iter().zip(&motions) {
            let plan = scenario
                .run_of(motion.clone(), load)
                .map_err(|e| e.context(&context(speed, Some(load))))?;
            grid.push(Planned { speed, load, plan });
        }
    }
    Ok(grid)
}

/// A model to predict with: identified without payload; the tool and loads are added from
/// their known mass properties, with the drives' nominal efficiency (the second field) for an
/// efficiency-scaled model.
pub type Predictor<'a> = (&'a PowerModel, f64);

/// Run the planned cells on `rig` in parallel, and predict every cell when a model is given;
/// with a model, each load's least-energy speed is searched at the same time (it needs only
/// the plans). The twin runs start longest first, so that no long run is left alone on one
/// core at the end.
pub fn run(
    rig: &Rig,
    scenario: &Scenario,
    plans: Vec<Planned>,
    predictor: Option<Predictor>,
    progress: &dyn Progress,
) -> Result<Sweep> {
    let robot = rig.robot;
    progress.stage("Figure 14: speed x load sweep", plans.len());
    let (lo, hi) = speed_range(&plans);
    let loads = distinct(&plans, |p| p.load);
    let mut order: Vec<(usize, Planned)> = plans.into_iter().enumerate().collect();
    order.sort_by(|a, b| {
        b.1.plan
            .motion
            .duration_s
            .total_cmp(&a.1.plan.motion.duration_s)
    });
    let run_cell = |(k, planned): (usize, Planned)| {
        let (cell, ds, plan) = run_cell(rig, scenario, k, planned, predictor)?;
        progress.advance();
        Ok((k, cell, ds, plan))
    };
    // The model's least-energy speed of every load, searched while the twin runs.
    let least = || match predictor {
        Some(p) => least_energy(robot, scenario, &loads, p, (lo, hi))
            .map(|v| v.into_iter().map(Some).collect()),
        None => Ok(vec![None; loads.len()]),
    };
    // `par_bridge` hands the runs out in the order given: longest first.
    let (out, predicted): (_, Result<Vec<Option<SpeedOptimum>>>) = rayon::join(
        || {
            order
                .into_iter()
                .par_bridge()
                .map(run_cell)
                .collect::<Result<Vec<_>>>()
        },
        least,
    );
    let mut out = out?;
    let predicted = predicted?;
    out.sort_by_key(|o| o.0);
    let mut cells = Vec::with_capacity(out.len());
    let mut datasets = Vec::with_capacity(out.len());
    let mut plans = Vec::with_capacity(out.len());
    for (_, c, d, p) in out {
        cells.push(c);
        datasets.push(d);
        plans.push(p);
    }
    let optima = loads
        .iter()
        .zip(predicted)
        .map(|(&load, predicted)| optimum(&cells, load, predicted))
        .collect::<Result<_>>()?;
    let pareto = pareto_front(&cells);
    Ok(Sweep {
        cells,
        optima,
        pareto,
        datasets,
        plans,
    })
}

/// Run cell `k` (its index in [`plan`]'s load-major order) of a planned grid on `rig`: the
/// twin run (noise seed `200 + k`) and the prediction [`run`] makes for that cell, for
/// running the cells of one sweep in separate processes; [`assemble`] joins them as [`run`]
/// does. Returns the cell, its dataset and its plan.
pub fn run_cell(
    rig: &Rig,
    scenario: &Scenario,
    k: usize,
    Planned { speed, load, plan }: Planned,
    predictor: Option<Predictor>,
) -> Result<(Cell, Dataset, TaskRun)> {
    let robot = rig.robot;
    let dt = rig.twin.physics.dt;
    let description = serde_json::json!({
        "kind": "pick and place",
        "scenario": scenario.name,
        "speed_m_s": speed,
        "load_kg": load,
    });
    let (ds, report) = rig.run_reported(
        &plan.motion.trajectory,
        &plan.events,
        &[],
        200 + k as u64,
        description,
    )?;
    let pred = predictor
        .map(|(model, efficiency)| {
            model.energy_with_payloads(robot, &plan.motion.trajectory, &plan.events, efficiency, dt)
        })
        .transpose()?;
    let sim = &ds.meta.summary;
    Ok((
        Cell {
            speed_m_s: speed,
            load_kg: load,
            cycle_time_s: plan.motion.duration_s,
            simulated_j: sim.energy_total_j,
            simulated_grid_j: sim.energy_grid_j,
            predicted_j: pred.map(|p| p.motor_j),
            predicted_grid_j: pred.map(|p| p.grid_j),
            error_pct: pred.map(|p| 100.0 * (p.motor_j - sim.energy_total_j) / sim.energy_total_j),
            slowed: plan.motion.slowed.clone(),
            flagged: run_flagged(&report),
            max_tracking_error_rad: report.max_tracking_error_rad,
            torque_limit_hits: report.torque_limit_hits,
        },
        ds,
        plan,
    ))
}

/// The optima per load and the Pareto front of a sweep's `cells` (in [`plan`]'s load-major
/// order) that ran separately ([`run_cell`]), as [`run`] computes them: with `predictor`,
/// the model's least-energy speed of every load is searched over the cells' speed range.
pub fn assemble(
    robot: &Robot,
    scenario: &Scenario,
    cells: &[Cell],
    predictor: Option<Predictor>,
) -> Result<(Vec<Optimum>, Vec<usize>)> {
    let speeds = cells.iter().map(|c| c.speed_m_s);
    let range = (
        speeds.clone().fold(f64::INFINITY, f64::min),
        speeds.fold(f64::NEG_INFINITY, f64::max),
    );
    let loads = distinct(cells, |c| c.load_kg);
    let predicted: Vec<Option<SpeedOptimum>> = match predictor {
        Some(p) => least_energy(robot, scenario, &loads, p, range)?
            .into_iter()
            .map(Some)
            .collect(),
        None => vec![None; loads.len()],
    };
    let optima = loads
        .iter()
        .zip(predicted)
        .map(|(&load, predicted)| optimum(cells, load, predicted))
        .collect::<Result<_>>()?;
    Ok((optima, pareto_front(cells)))
}

/// The least and the greatest speed of the planned cells, m/s.
fn speed_range(plans: &[Planned]) -> (f64, f64) {
    let speeds = plans.iter().map(|p| p.speed);
    (
        speeds.clone().fold(f64::INFINITY, f64::min),
        speeds.fold(f64::NEG_INFINITY, f64::max),
    )
}

/// The model's least-energy speed in `range` (m/s) of every load level of `loads` (kg).
fn least_energy(
    robot: &Robot,
    scenario: &Scenario,
    loads: &[f64],
    (model, efficiency): Predictor,
    (lo, hi): (f64, f64),
) -> Result<Vec<SpeedOptimum>> {
    let tasks: Vec<Task> = loads
        .iter()
        .map(|&load_kg| Task {
            robot,
            scenario,
            load_kg,
            model,
            efficiency,
        })
        .collect();
    speed::least_energy(&tasks, lo, hi)
}

/// One cell of a sweep that no twin ran (`--twin none`): the model's prediction alone.
#[derive(Debug, Clone, Serialize)]
pub struct PredictedCell {
    /// Commanded TCP speed, m/s.
    pub speed_m_s: f64,
    /// Load level L, kg.
    pub load_kg: f64,
    /// Duration of the whole path, s.
    pub cycle_time_s: f64,
    /// Motor energy the model predicts (regenerated energy counted negative), J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// Grid-side energy the model predicts (`max(P, 0)`), J.
    #[serde(rename = "predicted_grid_J")]
    pub predicted_grid_j: f64,
    /// Energy of the model's own signal, J: `predicted_J` for a model of the motor sum,
    /// `predicted_grid_J` for one of the DC bus (clipped at zero); what `predict --scenario`
    /// prices for the same cell.
    #[serde(rename = "predicted_signal_J")]
    pub predicted_signal_j: f64,
    /// Half-width of the 95 % interval of `predicted_signal_J`, J.
    #[serde(rename = "interval_95_J")]
    pub interval_j: f64,
    /// Segments the planner slowed down to respect joint limits.
    pub slowed: Vec<SlowedSegment>,
}

/// The energy-optimal speed of one load level of a sweep that no twin ran.
#[derive(Debug, Clone, Serialize)]
pub struct PredictedOptimum {
    /// Load level, kg.
    pub load_kg: f64,
    /// The grid cell of least predicted energy of the model's signal (`predicted_signal_J`,
    /// the energy the model is identified for and the optimiser minimises).
    pub grid: RowOptimum,
    /// The model's least-energy speed on its actual curve ([`crate::optimize::speed`]).
    pub predicted: SpeedOptimum,
}

/// Outcome of a sweep that no twin ran ([`predict`]).
pub struct PredictedSweep {
    /// Cells, load-major in the scenario's order.
    pub cells: Vec<PredictedCell>,
    /// Optimum per load.
    pub optima: Vec<PredictedOptimum>,
    /// Indices into `cells` of the per-load Pareto front of (cycle time, predicted energy of
    /// the model's signal).
    pub pareto: Vec<usize>,
    /// Each cell's plan.
    pub plans: Vec<TaskRun>,
}

/// Price the planned cells with the model alone, in parallel (no twin runs: `--twin none`):
/// each cell as [`PowerModel::predict`] prices it at the step [`PLAN_DT_S`] (the energy
/// `predict --scenario` gives for the same cell, with its 95 % interval), and each load's
/// least-energy speed searched as [`run`] does.
///
/// Errors: a prediction or a speed search that fails.
pub fn predict(
    robot: &Robot,
    scenario: &Scenario,
    plans: Vec<Planned>,
    predictor: Predictor,
) -> Result<PredictedSweep> {
    let (model, efficiency) = predictor;
    let range = speed_range(&plans);
    let loads = distinct(&plans, |p| p.load);
    let (cells, least) = rayon::join(
        || {
            plans
                .par_iter()
                .map(|Planned { speed, load, plan }| {
                    let traj = &plan.motion.trajectory;
                    let p = model.predict(robot, traj, &plan.events, efficiency, PLAN_DT_S)?;
                    Ok(PredictedCell {
                        speed_m_s: *speed,
                        load_kg: *load,
                        cycle_time_s: plan.motion.duration_s,
                        predicted_j: p.motor_j,
                        predicted_grid_j: p.grid_j,
                        predicted_signal_j: p.energy_j,
                        interval_j: p.interval_j,
                        slowed: plan.motion.slowed.clone(),
                    })
                })
                .collect::<Result<Vec<_>>>()
        },
        || least_energy(robot, scenario, &loads, predictor, range),
    );
    let cells = cells?;
    let optima = loads
        .iter()
        .zip(least?)
        .map(|(&load_kg, predicted)| {
            let row = cells
                .iter()
                .filter(|c| c.load_kg == load_kg)
                .map(|c| (c.speed_m_s, c.predicted_signal_j, &c.slowed[..]))
                .collect();
            let grid = row_optimum(row)
                .ok_or_else(|| Error::InvalidInput(format!("no cell with load {load_kg} kg")))?;
            Ok(PredictedOptimum {
                load_kg,
                grid,
                predicted,
            })
        })
        .collect::<Result<_>>()?;
    let pareto = pareto_of(
        &cells
            .iter()
            .map(|c| (c.load_kg, c.cycle_time_s, c.predicted_signal_j))
            .collect::<Vec<_>>(),
    );
    Ok(PredictedSweep {
        cells,
        optima,
        pareto,
        plans: plans.into_iter().map(|p| p.plan).collect(),
    })
}

/// The distinct values of `key` over `items` (e.g. the load levels of the cells), in order of
/// first appearance.
pub fn distinct<T>(items: &[T], key: impl Fn(&T) -> f64) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::new();
    for c in items {
        if !out.contains(&key(c)) {
            out.push(key(c));
        }
    }
    out
}

/// The optimum of one load level, with the model's least-energy speed when there is one.
fn optimum(cells: &[Cell], load: f64, predicted: Option<SpeedOptimum>) -> Result<Optimum> {
    let row: Vec<RowPoint> = cells
        .iter()
        .filter(|c| c.load_kg == load)
        .map(|c| (c.speed_m_s, c.simulated_j, &c.slowed[..]))
        .collect();
    let best = row_optimum(row)
        .ok_or_else(|| Error::InvalidInput(format!("no cell with load {load} kg")))?;
    Ok(Optimum {
        load_kg: load,
        simulated_cell_m_s: best.cell_m_s,
        simulated_interpolated_m_s: best.interpolated_m_s,
        simulated_near_planner_limit: best.near_planner_limit,
        predicted_m_s: predicted.map(|p| p.speed_m_s),
        predicted_j: predicted.map(|p| p.predicted_j),
        predicted,
        interior: best.interior,
    })
}

/// A cell of one load level: speed (m/s), energy (J) and slowed segments.
type RowPoint<'a> = (f64, f64, &'a [SlowedSegment]);

/// The least-energy cell of one load level's row.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RowOptimum {
    /// Speed of the grid cell with the least energy, m/s.
    pub cell_m_s: f64,
    /// Minimum of a parabola in log speed through that cell and its neighbours, m/s, when the
    /// three cells have the same slowed segments (a smooth piece of the curve); else the
    /// cell's speed (a parabola across a planner kink would be fiction).
    pub interpolated_m_s: f64,
    /// Whether the neighbours of the least cell have other slowed segments than it (the grid
    /// optimum sits at or near a planner limit).
    pub near_planner_limit: bool,
    /// Whether the least cell lies strictly inside the speed range.
    pub interior: bool,
}

/// The least-energy cell of `row` (in any order); `None` for an empty row.
fn row_optimum(mut row: Vec<RowPoint>) -> Option<RowOptimum> {
    row.sort_by(|a, b| a.0.total_cmp(&b.0));
    let best = (0..row.len()).min_by(|&a, &b| row[a].1.total_cmp(&row[b].1))?;
    let interior = best > 0 && best + 1 < row.len();
    let slowed = |k: usize| row[k].2.iter().map(|s| s.segment).collect::<Vec<_>>();
    let smooth = interior && slowed(best - 1) == slowed(best) && slowed(best + 1) == slowed(best);
    let interpolated_m_s = if smooth {
        let x: Vec<f64> = (best - 1..=best + 1).map(|k| row[k].0.ln()).collect();
        let y: Vec<f64> = (best - 1..=best + 1).map(|k| row[k].1).collect();
        parabola_min(&x, &y).exp()
    } else {
        row[best].0
    };
    Some(RowOptimum {
        cell_m_s: row[best].0,
        interpolated_m_s,
        near_planner_limit: interior && !smooth,
        interior,
    })
}

/// The abscissa of the vertex of the parabola through three points (the middle one's when
/// they are collinear or the vertex falls outside them).
fn parabola_min(x: &[f64], y: &[f64]) -> f64 {
    let (d1, d2) = (x[1] - x[0], x[2] - x[1]);
    let (s1, s2) = ((y[1] - y[0]) / d1, (y[2] - y[1]) / d2);
    let curvature = (s2 - s1) / (x[2] - x[0]);
    if curvature <= 0.0 {
        return x[1];
    }
    let vertex = 0.5 * (x[0] + x[1]) - s1 / (2.0 * curvature);
    vertex.clamp(x[0], x[2])
}

/// Indices of the cells on the per-load Pareto front of (cycle time, simulated energy).
fn pareto_front(cells: &[Cell]) -> Vec<usize> {
    pareto_of(
        &cells
            .iter()
            .map(|c| (c.load_kg, c.cycle_time_s, c.simulated_j))
            .collect::<Vec<_>>(),
    )
}

/// Indices of the points `(load kg, cycle time s, energy J)` that no other point of the same
/// load beats in both cycle time and energy.
fn pareto_of(points: &[(f64, f64, f64)]) -> Vec<usize> {
    (0..points.len())
        .filter(|&i| {
            let (load, time, energy) = points[i];
            !points
                .iter()
                .any(|&(l, t, e)| l == load && t <= time && e <= energy && (t < time || e < energy))
        })
        .collect()
}
