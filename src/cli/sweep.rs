//! `powertwin sweep`: a task scenario over speeds and loads on the twin.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::Args;
use powertwin::identification::model::{DATASHEET_EFFICIENCY, PowerModel};
use powertwin::measurement::PowerSignal;
use powertwin::report::figures::energy_chart;
use powertwin::report::plot::{Chart, Series, Style, XAxis, write_chart};
use powertwin::trajectory::task::Scenario;
use powertwin::validation::sweep::{self, NO_PHYSICS_CHECK, PredictedSweep, Sweep, TwinChoice};
use serde::Serialize;

use crate::cli::export::identified_twin;
use crate::cli::progress::Bars;
use crate::cli::{OverloadArgs, Setup, TwinArgs, emit, read_model, sweep_name, write_all};

/// Arguments of `sweep`.
///
/// Plans the scenario's linear moves for every speed and load level (load 1 = L/2, heavier
/// load = L), runs the twin on each in parallel and writes one dataset per cell, sweep.json
/// (cells, energy-optimal speed per load, Pareto front) and energy_vs_speed.svg/.png under
/// --out. With --model, the identified model (from `identify`) predicts every cell from the
/// plan and the known tool and loads. --twin chooses the twin (see below); with --twin none
/// no twin runs: sweep.json has no simulated columns and no dataset is written.
///
/// Exits 3 (after writing every output) when a cell is flagged: a torque saturated or the
/// tracking error exceeded 0.05 rad, so its energy is not the task's; --allow-overload
/// accepts such cells (exit 0, still flagged in the outputs).
#[derive(Debug, Args)]
pub struct SweepArgs {
    #[command(flatten)]
    twin: TwinArgs,
    /// Which twin runs the cells: `urdf` (the twin of --robot and --drive), `identified` (the
    /// twin of --model's consistent URDF and drive file, as `identify --export-urdf
    /// --export-drive` writes them) or `none` (no physics: the model's predictions with their
    /// 95 % intervals). `none` and `identified` need --model; for a robot that is not our twin
    /// they are the honest choice.
    #[arg(
        long = "twin",
        value_name = "urdf|none|identified",
        default_value = "urdf"
    )]
    twin_choice: TwinChoice,
    /// Scenario TOML [default: built-in scenarios/pick_and_place.toml].
    #[arg(long, value_name = "PATH")]
    scenario: Option<PathBuf>,
    /// Identified model (`identify --out`) to predict each cell with.
    #[arg(
        long,
        value_name = "MODEL.json",
        required_if_eq_any([("twin_choice", "none"), ("twin_choice", "identified")])
    )]
    model: Option<PathBuf>,
    /// TCP speeds, m/s, replacing the scenario's (comma-separated).
    #[arg(long, value_name = "M_S,...", value_delimiter = ',')]
    speeds: Vec<f64>,
    /// Load levels L, kg, replacing the scenario's (comma-separated).
    #[arg(long, value_name = "KG,...", value_delimiter = ',')]
    loads: Vec<f64>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Print sweep.json to stdout instead of a table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    overload: OverloadArgs,
    #[cfg(feature = "viz")]
    #[command(flatten)]
    viz: crate::cli::viz::VizArgs,
}

/// `sweep.json`.
#[derive(Serialize)]
struct SweepFile<'a> {
    scenario: &'a str,
    twin: &'static str,
    twin_note: &'static str,
    cells: &'a [sweep::Cell],
    optima: &'a [sweep::Optimum],
    pareto: &'a [usize],
}

/// `sweep.json` of `--twin none`: the model's predictions only.
#[derive(Serialize)]
struct PredictedFile<'a> {
    scenario: &'a str,
    twin: &'static str,
    twin_note: &'static str,
    power_signal: PowerSignal,
    cells: &'a [sweep::PredictedCell],
    optima: &'a [sweep::PredictedOptimum],
    pareto: &'a [usize],
}

/// The robot setup, the scenario with the command line's speeds and loads, and the model.
fn load(args: &SweepArgs) -> Result<(Setup, Scenario, Option<PowerModel>)> {
    let setup = args.twin.setup()?;
    if setup.payload.is_some() {
        bail!("--payload does not apply to a sweep: the scenario defines the tool and loads");
    }
    let mut scenario = match &args.scenario {
        Some(p) => Scenario::from_file(p)?,
        None => Scenario::builtin()?,
    };
    if !args.speeds.is_empty() {
        scenario.sweep.speeds_m_s = args.speeds.clone();
    }
    if !args.loads.is_empty() {
        scenario.sweep.loads_kg = args.loads.clone();
    }
    for &load in &scenario.sweep.loads_kg {
        args.overload.check_payload(
            scenario.max_payload_kg(load),
            &setup.drive,
            &format!("scenario '{}' at load level {load} kg", scenario.name),
        )?;
    }
    let model = args
        .model
        .as_deref()
        .map(|p| read_model(p, &setup.robot))
        .transpose()?;
    Ok((setup, scenario, model))
}

/// Run the sweep.
pub fn run(args: &SweepArgs) -> Result<ExitCode> {
    let (setup, scenario, model) = load(args)?;
    let planned = sweep::plan(&setup.robot, &scenario)?;
    let needs_model = || {
        model
            .as_ref()
            .with_context(|| format!("--twin {} needs --model", args.twin_choice.name()))
    };
    let identified = match args.twin_choice {
        TwinChoice::None => {
            return run_predicted(args, &setup.robot, &scenario, planned, needs_model()?);
        }
        TwinChoice::Identified => Some(identified_twin(
            &setup.robot,
            needs_model()?,
            setup.drive.brakes(),
        )?),
        TwinChoice::Urdf => None,
    };
    let input = setup.rig();
    let rig = match &identified {
        Some(t) => sweep::identified_rig(t, &input),
        None => input,
    };
    #[cfg(feature = "viz")]
    let viz = args.viz.open(None)?;
    let bars = Bars::new();
    let efficiency = DATASHEET_EFFICIENCY;
    let result = sweep::run(
        &rig,
        &scenario,
        planned,
        model.as_ref().map(|m| (m, efficiency)),
        &bars,
    )?;
    bars.finish();
    let json = write_outputs(args, &scenario, &result)?;
    #[cfg(feature = "viz")]
    if let Some(viz) = &viz {
        viz.log_sweep(
            &setup.robot,
            &result,
            &scenario.tcp(),
            model.as_ref().map(|m| (m, efficiency)),
            "sweep",
            powertwin::viz::DEFAULT_DISPLAY_HZ,
        )?;
        viz.flush()?;
    }
    let mut text = String::new();
    if args.twin_choice != TwinChoice::Urdf {
        outln!(text, "{}", args.twin_choice.statement());
    }
    emit(&if args.json {
        json + "\n"
    } else {
        text + &table(&result)
    })?;
    Ok(args.overload.exit_for(&result.cells).into())
}

/// Write the cells' datasets, sweep.json and the chart under `--out`; returns sweep.json's
/// text.
fn write_outputs(args: &SweepArgs, scenario: &Scenario, result: &Sweep) -> Result<String> {
    let names: Vec<(String, &powertwin::dataset::Dataset)> = result
        .cells
        .iter()
        .zip(&result.datasets)
        .map(|(c, d)| (sweep_name(c), d))
        .collect();
    write_all(&names, &args.out, args.twin.format)?;
    let file = SweepFile {
        scenario: &scenario.name,
        twin: args.twin_choice.name(),
        twin_note: args.twin_choice.statement(),
        cells: &result.cells,
        optima: &result.optima,
        pareto: &result.pareto,
    };
    let json = serde_json::to_string_pretty(&file).context("serialising sweep.json")?;
    powertwin::io::write_atomic(&args.out.join("sweep.json"), json.as_bytes())?;
    write_chart(
        &energy_chart(result),
        &args.out,
        "energy_vs_speed",
        960,
        600,
    )?;
    Ok(json)
}

/// `--twin none`: price every planned cell with `model` alone; write sweep.json and the
/// chart of the predicted energies (no datasets).
fn run_predicted(
    args: &SweepArgs,
    robot: &powertwin::Robot,
    scenario: &Scenario,
    planned: Vec<sweep::Planned>,
    model: &PowerModel,
) -> Result<ExitCode> {
    #[cfg(feature = "viz")]
    if args.viz.open(None)?.is_some() {
        bail!("--twin none runs no twin: there is nothing to show in Rerun");
    }
    let result = sweep::predict(robot, scenario, planned, (model, DATASHEET_EFFICIENCY))?;
    let file = PredictedFile {
        scenario: &scenario.name,
        twin: TwinChoice::None.name(),
        twin_note: NO_PHYSICS_CHECK,
        power_signal: model.signal,
        cells: &result.cells,
        optima: &result.optima,
        pareto: &result.pareto,
    };
    let json = serde_json::to_string_pretty(&file).context("serialising sweep.json")?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    powertwin::io::write_atomic(&args.out.join("sweep.json"), json.as_bytes())?;
    write_chart(
        &predicted_chart(&result),
        &args.out,
        "energy_vs_speed",
        960,
        600,
    )?;
    emit(&if args.json {
        json + "\n"
    } else {
        predicted_table(&result)
    })?;
    Ok(ExitCode::SUCCESS)
}

/// The predicted energy of the model's signal per cycle against speed, one line per load
/// (`--twin none`).
fn predicted_chart(result: &PredictedSweep) -> Chart {
    let mut chart = Chart::new(
        "Predicted energy per cycle against TCP speed (model only, no physics check)",
        "TCP speed (m/s)",
        "Predicted energy per cycle, the model's signal (J)",
    )
    .with_x_axis(XAxis::Log);
    for load in sweep::distinct(&result.cells, |c| c.load_kg) {
        let points = result
            .cells
            .iter()
            .filter(|c| c.load_kg == load)
            .map(|c| (c.speed_m_s, c.predicted_signal_j))
            .collect();
        chart = chart.with_series(Series::new(
            format!("model, load {load} kg"),
            points,
            Style::LineMarkers,
        ));
    }
    chart
}

/// The predicted cells as a text table, under [`NO_PHYSICS_CHECK`] (`--twin none`).
fn predicted_table(result: &PredictedSweep) -> String {
    let mut o = String::new();
    outln!(o, "{NO_PHYSICS_CHECK}");
    outln!(
        o,
        "speed_m_s  load_kg  cycle_time_s  predicted_J  predicted_grid_J  signal_J  interval_95_J  slowed_segments"
    );
    for c in &result.cells {
        outln!(
            o,
            "{:9}  {:7}  {:12.3}  {:11.2}  {:16.2}  {:8.2}  {:13.2}  {}",
            c.speed_m_s,
            c.load_kg,
            c.cycle_time_s,
            c.predicted_j,
            c.predicted_grid_j,
            c.predicted_signal_j,
            c.interval_j,
            c.slowed.len()
        );
    }
    for opt in &result.optima {
        let g = &opt.grid;
        outln!(
            o,
            "load {} kg: least predicted energy at {} m/s ({}); model optimum {:.3} m/s{}",
            opt.load_kg,
            g.cell_m_s,
            if g.interior {
                format!("interior; interpolated {:.3} m/s", g.interpolated_m_s)
            } else {
                "at the edge of the grid".into()
            },
            opt.predicted.speed_m_s,
            if opt.predicted.on_planner_limit {
                format!(
                    " (on a planner limit: {} segments slowed for joint limits)",
                    opt.predicted.slowed_segments
                )
            } else {
                String::new()
            }
        );
    }
    o
}

/// The cells as a text table.
fn table(result: &Sweep) -> String {
    let mut o = String::new();
    outln!(
        o,
        "speed_m_s  load_kg  cycle_time_s  simulated_J  grid_J  predicted_J  error_pct  slowed_segments  flag"
    );
    for c in &result.cells {
        outln!(
            o,
            "{:9}  {:7}  {:12.3}  {:11.2}  {:6.1}  {:>11}  {:>9}  {:15}  {}",
            c.speed_m_s,
            c.load_kg,
            c.cycle_time_s,
            c.simulated_j,
            c.simulated_grid_j,
            c.predicted_j.map_or("-".into(), |e| format!("{e:.2}")),
            c.error_pct.map_or("-".into(), |e| format!("{e:+.3}")),
            c.slowed.len(),
            c.flag_reason()
                .map_or("-".into(), |why| format!("FLAGGED: {why}"))
        );
    }
    for opt in &result.optima {
        outln!(
            o,
            "load {} kg: least simulated energy at {} m/s ({}){}",
            opt.load_kg,
            opt.simulated_cell_m_s,
            if opt.interior {
                format!(
                    "interior; interpolated {:.3} m/s",
                    opt.simulated_interpolated_m_s
                )
            } else {
                "at the edge of the grid".into()
            },
            opt.predicted_m_s.map_or(String::new(), |v| format!(
                "; model optimum {v:.3} m/s{}",
                crate::cli::reproduce::planner_limit(opt)
            ))
        );
    }
    o
}
