//! `sweep`: a task scenario over speeds and loads, as `powertwin sweep` runs it.

use std::path::PathBuf;

use powertwin::dataset::{Dataset, Format};
use powertwin::identification::consistent::{IdentifiedTwin, Options};
use powertwin::identification::model::{DATASHEET_EFFICIENCY, PowerModel};
use powertwin::measurement::PowerSignal;
use powertwin::report::figures::energy_chart;
use powertwin::report::plot::write_chart;
use powertwin::trajectory::task::Scenario;
use powertwin::validation::rig::Silent;
use powertwin::validation::sweep::{self as lib_sweep, NO_PHYSICS_CHECK, TwinChoice};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use serde::Serialize;

use crate::cells::cell_from_json;
use crate::model::{PyModel, inner};
use crate::robot::PyRobot;
use crate::runs::twin_options;
use crate::{ctx, parse, value_error};

/// `sweep.json` (the CLI's).
#[derive(Serialize)]
struct SweepFile<'a> {
    scenario: &'a str,
    twin: &'static str,
    twin_note: &'static str,
    cells: &'a [lib_sweep::Cell],
    optima: &'a [lib_sweep::Optimum],
    pareto: &'a [usize],
}

/// `sweep.json` of `twin="none"`.
#[derive(Serialize)]
struct PredictedFile<'a> {
    scenario: &'a str,
    twin: &'static str,
    twin_note: &'static str,
    power_signal: PowerSignal,
    cells: &'a [lib_sweep::PredictedCell],
    optima: &'a [lib_sweep::PredictedOptimum],
    pareto: &'a [usize],
}

/// The scenario (a file or the built-in pick and place) with `speeds` and `loads` (m/s, kg)
/// replacing its grid when given.
fn scenario(path: Option<PathBuf>, speeds: Vec<f64>, loads: Vec<f64>) -> PyResult<Scenario> {
    let mut s = match &path {
        Some(p) => Scenario::from_file(p).map_err(ctx(""))?,
        None => Scenario::builtin().map_err(ctx(""))?,
    };
    if !speeds.is_empty() {
        s.sweep.speeds_m_s = speeds;
    }
    if !loads.is_empty() {
        s.sweep.loads_kg = loads;
    }
    Ok(s)
}

/// Write the cells' datasets in parallel (each atomically), as the CLI's `write_all`.
fn write_datasets(
    items: &[(String, &Dataset)],
    dir: &std::path::Path,
    format: Format,
) -> PyResult<()> {
    std::fs::create_dir_all(dir).map_err(|e| crate::os_error("creating", dir, &e))?;
    items
        .par_iter()
        .map(|(name, ds)| {
            let path = dir.join(name);
            ds.write(&path, format)
                .map_err(ctx(format!("writing {}", path.display())))
        })
        .collect()
}

/// Run a task scenario over speeds and loads on the twin (or, with `twin="none"`, price the
/// plans with the model alone), as `powertwin sweep` does: returns `(sweep_json, flagged)`,
/// the text of sweep.json and the message listing the flagged cells (torque saturated,
/// tracking lost; `None` when none is flagged or `allow_overload`). With `out`, writes each
/// cell's dataset, sweep.json and the chart there, as the CLI.
#[pyfunction]
#[pyo3(signature = (robot, model, scenario_path, speeds, loads, twin, opts, out, format, allow_overload))]
#[allow(clippy::too_many_arguments)]
pub fn sweep(
    py: Python<'_>,
    robot: &PyRobot,
    model: Option<PyRef<'_, PyModel>>,
    scenario_path: Option<PathBuf>,
    speeds: Vec<f64>,
    loads: Vec<f64>,
    twin: &str,
    opts: &Bound<'_, PyDict>,
    out: Option<PathBuf>,
    format: &str,
    allow_overload: bool,
) -> PyResult<(String, Option<String>)> {
    let setup = twin_options(opts)?.setup(robot, &[])?;
    let scenario = scenario(scenario_path, speeds, loads)?;
    let choice: TwinChoice = parse("twin", twin)?;
    let format: Format = parse("format", format)?;
    if !allow_overload {
        for &load in &scenario.sweep.loads_kg {
            powertwin::model::payload::check_rated(
                scenario.max_payload_kg(load),
                setup.drive.rated_payload_kg(),
                &format!("scenario '{}' at load level {load} kg", scenario.name),
            )
            .map_err(|e| value_error(format!("{e}; pass --allow-overload to run it anyway")))?;
        }
    }
    let model: Option<&PowerModel> = model.as_deref().map(inner);
    let r = &robot.robot;
    py.detach(|| -> PyResult<(String, Option<String>)> {
        let planned = lib_sweep::plan(r, &scenario).map_err(ctx(""))?;
        let needs_model =
            || model.ok_or_else(|| value_error(format!("--twin {} needs --model", choice.name())));
        if choice == TwinChoice::None {
            let m = needs_model()?;
            return Ok((
                predicted_json(r, &scenario, planned, m, out.as_deref())?,
                None,
            ));
        }
        with_rig(robot, &setup, choice, model, |rig| {
            let flags = (choice, format, allow_overload);
            twin_json(rig, &scenario, planned, model, out.as_deref(), flags)
        })
    })
}

/// `twin="none"`: sweep.json of the model's predictions alone (written under `out`).
fn predicted_json(
    r: &powertwin::Robot,
    scenario: &Scenario,
    planned: Vec<lib_sweep::Planned>,
    m: &PowerModel,
    out: Option<&std::path::Path>,
) -> PyResult<String> {
    let result =
        lib_sweep::predict(r, scenario, planned, (m, DATASHEET_EFFICIENCY)).map_err(ctx(""))?;
    let file = PredictedFile {
        scenario: &scenario.name,
        twin: TwinChoice::None.name(),
        twin_note: NO_PHYSICS_CHECK,
        power_signal: m.signal,
        cells: &result.cells,
        optima: &result.optima,
        pareto: &result.pareto,
    };
    let json = serde_json::to_string_pretty(&file)
        .map_err(|e| value_error(format!("serialising sweep.json: {e}")))?;
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).map_err(|e| crate::os_error("creating", dir, &e))?;
        powertwin::io::write_atomic(&dir.join("sweep.json"), json.as_bytes()).map_err(ctx(""))?;
    }
    Ok(json)
}

/// The cells run on `rig`: sweep.json and the flagged cells' message; the datasets,
/// sweep.json and the chart written under `out`.
fn twin_json(
    rig: &powertwin::validation::rig::Rig,
    scenario: &Scenario,
    planned: Vec<lib_sweep::Planned>,
    model: Option<&PowerModel>,
    out: Option<&std::path::Path>,
    (choice, format, allow_overload): (TwinChoice, Format, bool),
) -> PyResult<(String, Option<String>)> {
    let result = lib_sweep::run(
        rig,
        scenario,
        planned,
        model.map(|m| (m, DATASHEET_EFFICIENCY)),
        &Silent,
    )
    .map_err(ctx(""))?;
    let file = SweepFile {
        scenario: &scenario.name,
        twin: choice.name(),
        twin_note: choice.statement(),
        cells: &result.cells,
        optima: &result.optima,
        pareto: &result.pareto,
    };
    let json = serde_json::to_string_pretty(&file)
        .map_err(|e| value_error(format!("serialising sweep.json: {e}")))?;
    if let Some(dir) = out {
        let names: Vec<(String, &Dataset)> = result
            .cells
            .iter()
            .zip(&result.datasets)
            .map(|(c, d)| (format!("sweep_{}mps_{}kg", c.speed_m_s, c.load_kg), d))
            .collect();
        write_datasets(&names, dir, format)?;
        powertwin::io::write_atomic(&dir.join("sweep.json"), json.as_bytes()).map_err(ctx(""))?;
        write_chart(&energy_chart(&result), dir, "energy_vs_speed", 960, 600).map_err(ctx(""))?;
    }
    Ok((json, flagged(&result.cells, allow_overload)))
}

/// The CLI's message listing the flagged cells, or `None`.
fn flagged(cells: &[lib_sweep::Cell], allowed: bool) -> Option<String> {
    let flagged: Vec<String> = cells
        .iter()
        .filter_map(|c| {
            c.flag_reason()
                .map(|why| format!("{} m/s, {} kg: {why}", c.speed_m_s, c.load_kg))
        })
        .collect();
    if flagged.is_empty() || allowed {
        return None;
    }
    Some(format!(
        "{} of {} sweep cells are flagged: the twin did not perform the task as planned, so \
         their energies are not the task's ({}); pass allow_overload=True to accept them",
        flagged.len(),
        cells.len(),
        flagged.join("; ")
    ))
}

/// The rig of `choice` (the URDF's twin, or the identified model's) for `robot`.
fn with_rig<T>(
    robot: &PyRobot,
    setup: &crate::robot::Setup,
    choice: TwinChoice,
    model: Option<&PowerModel>,
    f: impl FnOnce(&powertwin::validation::rig::Rig) -> PyResult<T>,
) -> PyResult<T> {
    let identified = match choice {
        TwinChoice::Identified => Some(
            IdentifiedTwin::from_model(
                &robot.robot,
                model.ok_or_else(|| value_error("--twin identified needs --model"))?,
                &Options::default(),
            )
            .and_then(|t| t.with_brakes(setup.drive.brakes()))
            .map_err(ctx("--twin identified: the identified model's twin"))?,
        ),
        TwinChoice::Urdf => None,
        TwinChoice::None => return Err(value_error("twin='none' runs no cell on a twin")),
    };
    let input = powertwin::validation::rig::Rig {
        plant: None,
        robot: &robot.robot,
        urdf: robot.urdf.clone(),
        drive: &setup.drive,
        twin: setup.twin.clone(),
        sensor: setup.sensor,
    };
    match &identified {
        Some(t) => f(&lib_sweep::identified_rig(t, &input)),
        None => f(&input),
    }
}

/// Cell `k` (load-major: load `k / len(speeds)`, speed `k % len(speeds)`) of the sweep
/// `sweep(...)` runs with the same arguments, run alone (same plan, same twin run, same
/// prediction): the cell's JSON (as in sweep.json), its dataset written under `out` when
/// given. For running a sweep's cells on many processes; `sweep_assemble` joins them.
#[pyfunction]
#[pyo3(signature = (robot, model, scenario_path, speeds, loads, k, twin, opts, out, format))]
#[allow(clippy::too_many_arguments)]
pub fn sweep_cell(
    py: Python<'_>,
    robot: &PyRobot,
    model: Option<PyRef<'_, PyModel>>,
    scenario_path: Option<PathBuf>,
    speeds: Vec<f64>,
    loads: Vec<f64>,
    k: usize,
    twin: &str,
    opts: &Bound<'_, PyDict>,
    out: Option<PathBuf>,
    format: &str,
) -> PyResult<String> {
    let setup = twin_options(opts)?.setup(robot, &[])?;
    let scenario = scenario(scenario_path, speeds, loads)?;
    let choice: TwinChoice = parse("twin", twin)?;
    let format: Format = parse("format", format)?;
    let (ns, nl) = (
        scenario.sweep.speeds_m_s.len(),
        scenario.sweep.loads_kg.len(),
    );
    if k >= ns * nl {
        return Err(value_error(format!(
            "k={k}: the grid has {} cells",
            ns * nl
        )));
    }
    let (speed, load) = (
        scenario.sweep.speeds_m_s[k % ns],
        scenario.sweep.loads_kg[k / ns],
    );
    let model: Option<&PowerModel> = model.as_deref().map(inner);
    py.detach(|| {
        let plan = scenario.plan(&robot.robot, speed, load).map_err(|e| {
            py_context(e.context(&format!(
                "scenario '{}' at {speed} m/s with load {load} kg",
                scenario.name
            )))
        })?;
        let planned = lib_sweep::Planned { speed, load, plan };
        let predictor = model.map(|m| (m, DATASHEET_EFFICIENCY));
        let (cell, ds, _) = with_rig(robot, &setup, choice, model, |rig| {
            lib_sweep::run_cell(rig, &scenario, k, planned, predictor).map_err(ctx(""))
        })?;
        if let Some(dir) = &out {
            let name = format!("sweep_{}mps_{}kg", cell.speed_m_s, cell.load_kg);
            write_datasets(&[(name, &ds)], dir, format)?;
        }
        serde_json::to_string(&cell).map_err(|e| value_error(e.to_string()))
    })
}

fn py_context(e: powertwin::Error) -> PyErr {
    crate::py_err("", &e)
}

/// sweep.json of cells run separately (`sweep_cell`, JSON texts in grid order) with the
/// same arguments: the optima and Pareto front as `sweep(...)` computes them. Returns
/// `(sweep_json, flagged)` as `sweep`.
#[pyfunction]
#[pyo3(signature = (robot, model, scenario_path, speeds, loads, twin, cells, allow_overload))]
#[allow(clippy::too_many_arguments)]
pub fn sweep_assemble(
    py: Python<'_>,
    robot: &PyRobot,
    model: Option<PyRef<'_, PyModel>>,
    scenario_path: Option<PathBuf>,
    speeds: Vec<f64>,
    loads: Vec<f64>,
    twin: &str,
    cells: Vec<String>,
    allow_overload: bool,
) -> PyResult<(String, Option<String>)> {
    let scenario = scenario(scenario_path, speeds, loads)?;
    let choice: TwinChoice = parse("twin", twin)?;
    let cells: Vec<lib_sweep::Cell> = cells
        .iter()
        .map(|c| cell_from_json(c))
        .collect::<PyResult<_>>()?;
    let model: Option<&PowerModel> = model.as_deref().map(inner);
    py.detach(|| {
        let predictor = model.map(|m| (m, DATASHEET_EFFICIENCY));
        let (optima, pareto) =
            lib_sweep::assemble(&robot.robot, &scenario, &cells, predictor).map_err(ctx(""))?;
        let file = SweepFile {
            scenario: &scenario.name,
            twin: choice.name(),
            twin_note: choice.statement(),
            cells: &cells,
            optima: &optima,
            pareto: &pareto,
        };
        let json = serde_json::to_string_pretty(&file)
            .map_err(|e| value_error(format!("serialising sweep.json: {e}")))?;
        Ok((json, flagged(&cells, allow_overload)))
    })
}
