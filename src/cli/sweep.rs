//! `powertwin sweep`: a task scenario over speeds and loads on the twin.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::Args;
use powertwin::report::figures::energy_chart;
use powertwin::report::plot::write_chart;
use powertwin::trajectory::task::Scenario;
use powertwin::validation::sweep::{self, Sweep};
use serde::Serialize;

use crate::cli::progress::Bars;
use crate::cli::{OverloadArgs, TwinArgs, emit, read_model, sweep_name, write_all};

/// Arguments of `sweep`.
///
/// Plans the scenario's linear moves for every speed and load level (load 1 = L/2, heavier
/// load = L), runs the twin on each in parallel and writes one dataset per cell, sweep.json
/// (cells, energy-optimal speed per load, Pareto front) and energy_vs_speed.svg/.png under
/// --out. With --model, the identified model (from `identify`) predicts every cell from the
/// plan and the known tool and loads.
///
/// Exits 3 (after writing every output) when a cell is flagged: a torque saturated or the
/// tracking error exceeded 0.05 rad, so its energy is not the task's; --allow-overload
/// accepts such cells (exit 0, still flagged in the outputs).
#[derive(Debug, Args)]
pub struct SweepArgs {
    #[command(flatten)]
    twin: TwinArgs,
    /// Scenario TOML [default: built-in scenarios/pick_and_place.toml].
    #[arg(long, value_name = "PATH")]
    scenario: Option<PathBuf>,
    /// Identified model (`identify --out`) to predict each cell with.
    #[arg(long, value_name = "MODEL.json")]
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
    cells: &'a [sweep::Cell],
    optima: &'a [sweep::Optimum],
    pareto: &'a [usize],
}

/// Run the sweep.
pub fn run(args: &SweepArgs) -> Result<ExitCode> {
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
    let rig = setup.rig();
    let planned = sweep::plan(&setup.robot, &scenario)?;
    #[cfg(feature = "viz")]
    let viz = args.viz.open(None)?;
    let bars = Bars::new();
    let efficiency = powertwin::identification::model::DATASHEET_EFFICIENCY;
    let result = sweep::run(
        &rig,
        &scenario,
        planned,
        model.as_ref().map(|m| (m, efficiency)),
        &bars,
    )?;
    bars.finish();
    let names: Vec<(String, &powertwin::dataset::Dataset)> = result
        .cells
        .iter()
        .zip(&result.datasets)
        .map(|(c, d)| (sweep_name(c), d))
        .collect();
    write_all(&names, &args.out, args.twin.format)?;
    let file = SweepFile {
        scenario: &scenario.name,
        cells: &result.cells,
        optima: &result.optima,
        pareto: &result.pareto,
    };
    let json = serde_json::to_string_pretty(&file).context("serialising sweep.json")?;
    powertwin::io::write_atomic(&args.out.join("sweep.json"), json.as_bytes())?;
    write_chart(
        &energy_chart(&result),
        &args.out,
        "energy_vs_speed",
        960,
        600,
    )?;
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
    emit(&if args.json {
        json + "\n"
    } else {
        table(&result)
    })?;
    Ok(args.overload.exit_for(&result.cells).into())
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
