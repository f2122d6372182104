//! `powertwin reproduce`: the main job, with built-in defaults.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use powertwin::Robot;
use powertwin::dataset::Format;
use powertwin::dataset::meta::Urdf;
use powertwin::identification::model::DATASHEET_EFFICIENCY;
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::urdf::{LoadOptions, load_str};
use powertwin::report::figures::figures;
use powertwin::report::markdown::render;
use powertwin::report::plot::write_chart;
use powertwin::report::results::{Results, Settings};
use powertwin::report::summary::{DEFAULT_RUN, results_markdown};
use powertwin::trajectory::task::Scenario;
use powertwin::twin::TwinConfig;
use powertwin::twin::motor::MotorModel;
use powertwin::twin::physics::PhysicsSettings;
use powertwin::twin::sensor::{NoiseSettings, SensorSettings};
use powertwin::validation::reproduce::{Outcome, Plan, StageTime, run as run_plan};
use powertwin::validation::rig::Rig;

use crate::cli::progress::Bars;
use crate::cli::truth::Truth;
use crate::cli::{TruthArgs, emit, noise_settings, sweep_name, write_all};

/// Rapier substeps per physics step unless `--substeps` says otherwise.
const DEFAULT_SUBSTEPS: usize = 1;

/// Chart size, px.
const CHART_SIZE: (u32, u32) = (960, 600);

/// Arguments of `reproduce` (what it runs: the command's help, `Command::Reproduce`).
#[derive(Debug, Args)]
pub struct ReproduceArgs {
    /// Output directory (created; existing files in it are replaced).
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// A short run: smaller excitation designs (four identification excitations of two 10 s
    /// stretches), 12 held-out motions and a 3 x 2 sweep (0.1, 0.5, 1 m/s; 0, 4 kg).
    #[arg(long)]
    quick: bool,
    /// Scenario TOML of the pick-and-place task and its sweep [default: built-in
    /// scenarios/pick_and_place.toml].
    #[arg(long, value_name = "PATH")]
    scenario: Option<PathBuf>,
    /// Motor model of the twin: pmsm (P_mech + c tau^2 + P0) or efficiency (P_mech / eta, the
    /// paper's eq. 9, under which a payload does not change the energy of a closed cycle).
    #[arg(long, default_value = "pmsm")]
    motor: MotorModel,
    #[command(flatten)]
    truth: TruthArgs,
    /// Sensor noise: a noise TOML file, or `none` [default: encoder 6e-6 rad steps + 1e-5 rad
    /// noise, 0.5 W per motor, 1 W on the total power].
    #[arg(long, value_name = "PATH|none")]
    noise: Option<String>,
    /// Seed of the sensor noise and of the controller's nominal-model error, added to each
    /// run's own seed. Another seed is another draw of every log and so another identified
    /// model: the way to see how the held-out errors and the coverage of the 95 % intervals
    /// vary between identifications (one run scores one model).
    #[arg(long, default_value_t = 0)]
    noise_seed: u64,
    /// Rapier substeps per 1 ms physics step, as `simulate`. The default keeps the twin's
    /// torque residual against exact inverse dynamics within the 0.02 % fidelity target
    /// (tests/twin.rs); fewer substeps run faster and less exactly (docs/experiments.md).
    #[arg(long, default_value_t = DEFAULT_SUBSTEPS)]
    substeps: usize,
    /// Table format of the datasets.
    #[arg(long, default_value = "parquet")]
    format: Format,
    #[command(flatten)]
    overload: crate::cli::OverloadArgs,
    /// Also send the recording that is always saved to <out>/powertwin.rrd elsewhere.
    #[cfg(feature = "viz")]
    #[command(flatten)]
    viz: crate::cli::viz::VizArgs,
}

/// File name of the Rerun recording `reproduce` always writes under --out.
#[cfg(feature = "viz")]
const RECORDING_FILE: &str = "powertwin.rrd";

/// Run everything and write the report.
pub fn run(args: &ReproduceArgs) -> Result<ExitCode> {
    let start = Instant::now();
    let (robot, drive) = builtin_robot()?;
    let (twin, sensor) = twin_and_sensor(args)?;
    let plant = args.truth.plant(&robot, &drive, &twin, &sensor)?;
    let rig = Rig {
        plant: plant.as_ref(),
        robot: &robot,
        urdf: Urdf::inline(builtin::IRB1200_URDF),
        drive: &drive,
        twin,
        sensor,
    };
    let plan = experiment_plan(args, &drive)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    #[cfg(feature = "viz")]
    let viz = args.viz.open(Some(&args.out.join(RECORDING_FILE)))?;

    let bars = Bars::new();
    let mut outcome = run_plan(&rig, &plan, &bars)?;
    bars.finish();

    let writing = Instant::now();
    write_datasets(&outcome, &args.out.join("datasets"), args.format)?;
    write_model(&outcome, &args.out)?;
    let plots = write_charts(&robot, &outcome, &args.out)?;
    outcome.timings.push(StageTime {
        stage: "datasets and charts written".into(),
        wall_s: writing.elapsed().as_secs_f64(),
    });
    #[cfg(feature = "viz")]
    if let Some(viz) = &viz {
        log_recording(viz, &robot, &plan, &mut outcome)?;
    }
    let results = Results::new(
        &outcome,
        settings(args, &rig),
        start.elapsed().as_secs_f64(),
    );
    write_results(args, &results, &plots)?;
    emit(&summary(&results, &args.out))?;
    Ok(args.overload.exit_for(&results.sweep.cells).into())
}

/// The built-in IRB 1200 robot and its drive data.
fn builtin_robot() -> Result<(Robot, Drive)> {
    let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default())
        .context("loading the built-in IRB 1200 model")?;
    let drive = Drive::from_toml_str(
        builtin::IRB1200_DRIVE,
        "built-in irb1200_7_70.drive.toml",
        &robot,
    )?;
    Ok((robot, drive))
}

/// The twin's physics, motor and controller settings and the logger's, from the options.
fn twin_and_sensor(args: &ReproduceArgs) -> Result<(TwinConfig, SensorSettings)> {
    let noise = noise_settings(args.noise.as_deref())?;
    let twin = TwinConfig {
        physics: PhysicsSettings {
            substeps: args.substeps,
            ..PhysicsSettings::default()
        },
        motor: args.motor,
        nominal_error: args.truth.nominal_error(),
        nominal_seed: args.noise_seed,
        fidelity: args.truth.fidelity(),
        ..TwinConfig::default()
    };
    twin.physics.validate()?;
    let sensor = SensorSettings {
        noise,
        power_signal: args.truth.power_signal(),
        seed: args.noise_seed,
        ..SensorSettings::default()
    };
    Ok((twin, sensor))
}

/// The experiment plan with the chosen scenario, its payload at every load level (kg)
/// checked against the drive's rating.
fn experiment_plan(args: &ReproduceArgs, drive: &Drive) -> Result<Plan> {
    let mut plan = Plan::irb1200(args.quick)?;
    if let Some(path) = &args.scenario {
        plan.scenario = Scenario::from_file(path)?;
    }
    for &load in &plan.scenario.sweep.loads_kg {
        args.overload.check_payload(
            plan.scenario.max_payload_kg(load),
            drive,
            &format!("scenario '{}' at load level {load} kg", plan.scenario.name),
        )?;
    }
    Ok(plan)
}

/// Write `<out>/model.json`: the identified model with its method, estimate and
/// cross-validation scores.
fn write_model(outcome: &Outcome, out: &Path) -> Result<()> {
    let model_json = serde_json::json!({
        "method": outcome.model_name(),
        "model": &outcome.model,
        "estimates": [outcome.idset.selection.fit.free_estimate()],
        "cross_validation": &outcome.idset.selection.scores,
    });
    powertwin::io::write_atomic(
        &out.join("model.json"),
        serde_json::to_string_pretty(&model_json)?.as_bytes(),
    )?;
    Ok(())
}

/// Write the report's charts under `<out>/plots`; returns each chart's path relative to
/// `out` (without extension) and its caption.
fn write_charts(robot: &Robot, outcome: &Outcome, out: &Path) -> Result<Vec<(String, String)>> {
    let figs = figures(robot, outcome, DATASHEET_EFFICIENCY)?;
    let plots_dir = out.join("plots");
    std::fs::create_dir_all(&plots_dir)
        .with_context(|| format!("creating {}", plots_dir.display()))?;
    let mut plots = Vec::with_capacity(figs.len());
    for f in &figs {
        write_chart(&f.chart, &plots_dir, &f.stem, CHART_SIZE.0, CHART_SIZE.1)
            .with_context(|| format!("writing chart {}", f.stem))?;
        plots.push((format!("plots/{}", f.stem), f.caption.clone()));
    }
    Ok(plots)
}

/// Log the run to the Rerun recording and add the time it took to the outcome's timings.
#[cfg(feature = "viz")]
fn log_recording(
    viz: &powertwin::viz::Viz,
    robot: &Robot,
    plan: &Plan,
    outcome: &mut Outcome,
) -> Result<()> {
    let logging = Instant::now();
    viz.log_reproduce(
        robot,
        plan,
        outcome,
        DATASHEET_EFFICIENCY,
        powertwin::viz::DEFAULT_DISPLAY_HZ,
    )?;
    viz.flush()?;
    outcome.timings.push(StageTime {
        stage: format!("Rerun recording written ({RECORDING_FILE})"),
        wall_s: logging.elapsed().as_secs_f64(),
    });
    Ok(())
}

/// The run's settings as the results record them.
fn settings(args: &ReproduceArgs, rig: &Rig) -> Settings {
    Settings {
        robot: rig.robot.name().to_string(),
        motor_model: args.motor.name().to_string(),
        truth: args.truth.truth.to_string(),
        power_signal: rig.logger().power_signal.name().to_string(),
        dt_s: rig.twin.physics.dt,
        substeps: rig.twin.physics.substeps,
        sample_rate_hz: rig.logger().rate_hz,
        noise: rig.logger().noise != NoiseSettings::NONE,
        noise_seed: args.noise_seed,
        quick: args.quick,
    }
}

/// Write `results.json`, `report.md` (with the charts `plots`) and `results.md` under
/// `--out`.
fn write_results(
    args: &ReproduceArgs,
    results: &Results,
    plots: &[(String, String)],
) -> Result<()> {
    let json = serde_json::to_string_pretty(results).context("serialising results.json")?;
    powertwin::io::write_atomic(&args.out.join("results.json"), json.as_bytes())?;
    powertwin::io::write_atomic(
        &args.out.join("report.md"),
        render(results, plots).as_bytes(),
    )?;
    let value = serde_json::to_value(results).context("serialising results.md's input")?;
    powertwin::io::write_atomic(
        &args.out.join("results.md"),
        results_markdown(&value, &command_line(args)).as_bytes(),
    )?;
    Ok(())
}

/// The command line that gives this run's figures: `powertwin reproduce` and every option that
/// changes a number (not `--out`, `--format`, the Rerun sinks or `--allow-overload`).
fn command_line(args: &ReproduceArgs) -> String {
    let mut line = DEFAULT_RUN.to_string();
    if args.quick {
        line.push_str(" --quick");
    }
    if let Some(path) = &args.scenario {
        line.push_str(&format!(" --scenario {}", path.display()));
    }
    if args.motor != MotorModel::Pmsm {
        line.push_str(&format!(" --motor {}", args.motor.name()));
    }
    if args.truth.truth != Truth::Realistic {
        line.push_str(&format!(" --truth {}", args.truth.truth));
    }
    if let Some(p) = &args.truth.family_table {
        line.push_str(&format!(" --family-table {}", p.display()));
    }
    if let Some(e) = args.truth.nominal_error {
        line.push_str(&format!(" --nominal-error {e}"));
    }
    if let Some(p) = args.truth.power_signal {
        line.push_str(&format!(" --power-signal {}", p.name()));
    }
    if let Some(noise) = &args.noise {
        line.push_str(&format!(" --noise {noise}"));
    }
    if args.noise_seed != 0 {
        line.push_str(&format!(" --noise-seed {}", args.noise_seed));
    }
    if args.substeps != DEFAULT_SUBSTEPS {
        line.push_str(&format!(" --substeps {}", args.substeps));
    }
    line
}

/// Every twin dataset, named by experiment.
fn write_datasets(outcome: &Outcome, dir: &Path, format: Format) -> Result<()> {
    let mut all = Vec::new();
    for (k, ds) in outcome.steps.datasets.iter().enumerate() {
        all.push((format!("table3_step{}", k + 1), ds));
    }
    for (k, ds) in outcome.idset.datasets.iter().enumerate() {
        all.push((format!("identification_{}", k + 1), ds));
    }
    for (m, ds) in outcome
        .heldout
        .motions
        .iter()
        .zip(&outcome.heldout_datasets)
    {
        all.push((format!("heldout_{:02}_{}", m.index, m.kind), ds));
    }
    for (row, ds) in outcome.cases.rows.iter().zip(&outcome.cases.datasets) {
        all.push((format!("table4_{}", powertwin::io::slug(&row.case)), ds));
    }
    for (cell, ds) in outcome.sweep.cells.iter().zip(&outcome.sweep.datasets) {
        all.push((sweep_name(cell), ds));
    }
    write_all(&all, dir, format)
}

/// What the terminal shows at the end.
fn summary(r: &Results, out: &Path) -> String {
    let mut o = heldout_summary(r);
    o.push_str(&family_summary(r));
    o.push_str(&in_sample_summary(r));
    o.push_str(&sweep_summary(r));
    let recording = if cfg!(feature = "viz") {
        ", powertwin.rrd"
    } else {
        ""
    };
    outln!(
        o,
        "Wrote {}/report.md, results.md, results.json, model.json{recording}, plots/ and datasets/ in {:.1} s.",
        out.display(),
        r.total_wall_s
    );
    o
}

/// The held-out benchmark's lines: energy errors (%) and interval coverage from the log,
/// from the plan and of the baseline, and the worst power RMSE (W).
fn heldout_summary(r: &Results) -> String {
    let mut o = String::new();
    let h = &r.heldout;
    outln!(
        o,
        "Held-out benchmark ({} motions no identification saw), model {}:",
        h.motions.len(),
        r.model.name
    );
    for (name, s) in [
        ("from the log ", &h.from_log),
        ("from the plan", &h.from_plan),
        ("baseline     ", &h.baseline),
    ] {
        outln!(
            o,
            "  {name}: energy error median {:.3} %, worst {:.3} %; above standby worst {:.3} %; 95 % interval coverage {:.0} %{}",
            s.energy_error_pct.median,
            s.energy_error_pct.worst,
            s.above_standby_error_pct.worst,
            s.coverage_pct,
            s.median_z.map_or(String::new(), |z| format!(
                " (median |error| {z:.2} sigma; calibrated 0.67)"
            ))
        );
    }
    outln!(
        o,
        "  power RMSE worst {:.2} W from the log, {:.2} W from the plan (baseline {:.1} W)",
        h.power_rmse_w.worst,
        h.plan_power_rmse_w.worst,
        h.baseline_power_rmse_w.worst
    );
    o
}

/// The robot family's lines: pooled energy errors (%) and interval coverage from the log
/// and from the plan.
fn family_summary(r: &Results) -> String {
    let mut o = String::new();
    let f = &r.family;
    outln!(
        o,
        "Across {} robots we did not build (family seed {}, each identified from its own logs), pooled:",
        f.robots.len(),
        f.seed
    );
    for (name, s) in [
        ("from the log ", &f.from_log),
        ("from the plan", &f.from_plan),
    ] {
        outln!(
            o,
            "  {name}: energy error median {:.3} %, p95 {:.3} %, worst {:.3} %; 95 % interval coverage {:.0} % (lowest robot {:.0} %)",
            s.energy_error_pct.median,
            s.energy_error_pct.p95,
            s.energy_error_pct.worst,
            s.coverage_pct,
            f.worst_robot_coverage_pct
        );
    }
    o
}

/// The in-sample lines: Table 3's step errors, each estimator's worst step and Table 4's
/// cases (energy errors, %).
fn in_sample_summary(r: &Results) -> String {
    let mut o = String::new();
    outln!(o, "In-sample (each predicted on its own fitting data):");
    outln!(
        o,
        "Table 3 (paper's six steps on the twin), energy error %:"
    );
    for row in &r.table3 {
        outln!(o, "  step {}: {:+.3}", row.step, row.error_pct);
    }
    for e in &r.estimators {
        outln!(
            o,
            "estimator {}: worst step error {:.3} %",
            e.method,
            e.max_abs_error_pct
        );
    }
    outln!(
        o,
        "Table 4, energy error % (re-identified / known payload):"
    );
    for c in &r.table4 {
        outln!(
            o,
            "  {}: {:+.3} / {:+.3}",
            c.case,
            c.reidentified_error_pct,
            c.known_payload_error_pct
        );
    }
    o
}

/// The sweep's lines: its worst energy error (%) and, per load level (kg), the speed (m/s)
/// of least energy on the twin's grid and the model's optimum.
fn sweep_summary(r: &Results) -> String {
    let mut o = String::new();
    let worst = r
        .sweep
        .cells
        .iter()
        .filter_map(|c| c.error_pct)
        .fold(0.0_f64, |m, e| m.max(e.abs()));
    outln!(
        o,
        "Sweep: {} cells, worst energy error {:.3} %",
        r.sweep.cells.len(),
        worst
    );
    for opt in &r.sweep.optima {
        outln!(
            o,
            "  load {} kg: least energy at {} m/s (twin grid{}), model optimum {:.3} m/s{}",
            opt.load_kg,
            opt.simulated_cell_m_s,
            if opt.interior {
                ", interior"
            } else {
                ", at the edge"
            },
            opt.predicted_m_s.unwrap_or(f64::NAN),
            planner_limit(opt)
        );
    }
    o
}

/// ", on a planner limit (N segments slowed)" when the model's optimum sits where the
/// planner starts slowing a segment, else nothing.
pub fn planner_limit(opt: &powertwin::validation::sweep::Optimum) -> String {
    match opt.predicted {
        Some(p) if p.on_planner_limit => format!(
            " (on a planner limit: {} segments slowed for joint limits)",
            p.slowed_segments
        ),
        _ => String::new(),
    }
}
