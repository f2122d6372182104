//! `powertwin predict`: the energy of logged motions by an identified model, with its 95 %
//! interval; the power at the logged samples against the measured one (`--power-out`); the
//! logs with the model's power in Rerun. With `--trajectory` or `--scenario`, the energy and
//! power of a planned motion nobody has run ([`powertwin::identification::plan`]).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::Args;
use powertwin::Robot;
use powertwin::dataset::Dataset;
use powertwin::identification::data::Prepared;
use powertwin::identification::model::{DATASHEET_EFFICIENCY, PowerModel};
use powertwin::identification::plan::{price, price_scenario, read_plan, scenario_cell};
use powertwin::io::write_atomic;
use powertwin::model::payload::PayloadEvent;
use powertwin::trajectory::task::Scenario;
use powertwin::validation::log_price::{LogPrice, price_measured};
use serde_json::json;

use super::identify::{PayloadArgs, RouteArgs, gather};
use super::log::LogArgs;
use super::{RobotArgs, read_model};

/// Arguments of `predict`.
#[derive(Debug, Args)]
pub struct PredictArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Model file written by `identify` (or `reproduce`'s model.json).
    #[arg(long, value_name = "MODEL.json")]
    model: PathBuf,
    /// Dataset to predict (a twin run; its truth over the logged span, first to last sample, is
    /// shown for scoring).
    #[arg(
        long,
        value_name = "DIR",
        required_unless_present_any = ["log_input", "trajectory", "scenario"],
        conflicts_with = "log_input"
    )]
    data: Option<PathBuf>,
    /// A planned joint trajectory to price, no power needed: CSV with t_s (s), q1_rad..qn_rad
    /// and optionally dq1_rad_s.. and ddq1_rad_s2.. (as `simulate --trajectory` and `excite`
    /// write; names without units also read). Interpolated as `simulate` does: quintic Hermite
    /// through positions, velocities and accelerations, cubic Hermite through positions and
    /// velocities, a C2 cubic spline through positions alone (clamped to zero velocity at an
    /// end where a joint stands still). Refused outside the joint position or velocity
    /// limits. Payloads: --payload from before the start, or --payload-events on the file's
    /// t_s clock.
    #[arg(long, value_name = "PLAN.csv", conflicts_with_all = ["data", "log_input", "scenario"])]
    trajectory: Option<PathBuf>,
    /// A task scenario TOML to price as planned at --speed and --load (as `sweep` plans a
    /// cell: the scenario's tool from the start, each load from its pick to its release).
    #[arg(long, value_name = "S.toml", conflicts_with_all = ["data", "log_input", "payload", "payload_events"])]
    scenario: Option<PathBuf>,
    /// Commanded TCP speed of --scenario, m/s [default: the scenario's sweep speed nearest
    /// 0.5 m/s].
    #[arg(long, value_name = "M_S", requires = "scenario")]
    speed: Option<f64>,
    /// Load level L of --scenario, kg (load 1 = L/2, the heavier load = L for the built-in
    /// scenario) [default: the scenario's heaviest sweep load level].
    #[arg(long, value_name = "KG", requires = "scenario")]
    load: Option<f64>,
    #[command(flatten)]
    logs: LogArgs,
    #[command(flatten)]
    route: RouteArgs,
    #[command(flatten)]
    payloads: PayloadArgs,
    /// Write the power at the logged samples as CSV, to see where the model misses:
    /// `log` (1-based, in the order printed), `t_s` (the log's clock; for a logger that
    /// averages power, the middle of each sample period), `measured_{signal}_W` and
    /// `predicted_{signal}_W` (the modelled signal as the meter reads it: total, bus or grid;
    /// for a logger that averages power, the mean over each period; a bus or grid prediction
    /// never goes below its floor). For --trajectory or --scenario: `t_s` (the plan
    /// file's clock, or from the scenario's start) and `P_predicted_W` at the plan's samples.
    #[arg(long, value_name = "FILE.csv")]
    power_out: Option<PathBuf>,
    /// Machine-readable JSON instead of text.
    #[arg(long)]
    json: bool,
    #[cfg(feature = "viz")]
    #[command(flatten)]
    viz: super::viz::VizArgs,
}

/// Run `predict`.
pub fn run_predict(args: &PredictArgs) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let model = read_model(&args.model, &robot)?;
    if args.scenario.is_none() && (args.speed.is_some() || args.load.is_some()) {
        bail!("--speed and --load apply to --scenario only");
    }
    if args.trajectory.is_some() || args.scenario.is_some() {
        return run_plan(args, &robot, &model);
    }
    #[cfg(feature = "viz")]
    let viz = args.viz.open(None)?;
    let data: Vec<PathBuf> = args.data.iter().cloned().collect();
    let logs = gather(&data, &args.logs, &robot, &args.payloads)?;
    // The twin's truth, for scoring only: the energy of the logged signal over the span the
    // log covers (the prediction's), not the whole run, which goes on up to a sample period
    // after the last logged sample.
    let simulated = match (&args.data, logs.first()) {
        (Some(d), Some(log)) if !log.t_s.is_empty() => {
            let ds = Dataset::read(d)?;
            let (t0, t1) = (log.t_s[0], log.t_s[log.len() - 1]);
            Some(ds.truth.energy_between(t0, t1, model.signal.clipped()))
        }
        _ => None,
    };
    let mut rows: Vec<LogPrice> = Vec::new();
    let mut prepared: Vec<Prepared> = Vec::new();
    for log in &logs {
        let (p, row) = price_measured(&model, &robot, log, args.route.route())?;
        rows.push(row);
        prepared.push(p);
    }
    if let Some(path) = &args.power_out {
        write_power_csv(path, &model, &rows)?;
    }
    #[cfg(feature = "viz")]
    if let Some(viz) = &viz {
        show_predictions(viz, &robot, &model, &logs, &prepared, &rows)?;
    }
    emit_log_prices(args.json, &model, &rows, simulated)?;
    Ok(ExitCode::SUCCESS)
}

/// `predict --power-out`: the logged and predicted power at every logged sample of each log.
fn write_power_csv(path: &std::path::Path, model: &PowerModel, rows: &[LogPrice]) -> Result<()> {
    let signal = model.signal.name();
    let mut csv = format!("log,t_s,measured_{signal}_W,predicted_{signal}_W\n");
    for (k, r) in rows.iter().enumerate() {
        for ((t, y), p) in r.t_s.iter().zip(&r.measured_w).zip(&r.predicted_w) {
            let _ = writeln!(csv, "{},{t},{y},{p}", k + 1);
        }
    }
    write_atomic(path, csv.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// `predict --viz`: each log's measurement and the model's power along its route (between
/// the samples too), one tab a log.
#[cfg(feature = "viz")]
fn show_predictions(
    viz: &powertwin::viz::Viz,
    robot: &Robot,
    model: &PowerModel,
    logs: &[powertwin::measurement::Log],
    prepared: &[Prepared],
    rows: &[LogPrice],
) -> Result<()> {
    use powertwin::viz::{DEFAULT_DISPLAY_HZ, Tab};
    let prefix = |k: usize| format!("predict/log{}", k + 1);
    let tabs: Vec<Tab> = rows
        .iter()
        .enumerate()
        .map(|(k, r)| Tab::Run {
            title: r.source.clone(),
            prefix: prefix(k),
            joints: robot.dof(),
        })
        .collect();
    viz.send_blueprint(&tabs)?;
    for (k, (log, p)) in logs.iter().zip(prepared).enumerate() {
        viz.log_measurement(robot, log, &prefix(k))?;
        // The model's power along the route, between the samples too.
        let steps = (p.motion.duration() * DEFAULT_DISPLAY_HZ).ceil().max(1.0) as usize;
        let t: Vec<f64> = (0..=steps)
            .map(|j| p.motion.duration() * j as f64 / steps as f64)
            .collect();
        let joints = model.joint_powers_with_payloads(
            robot,
            p.motion.as_ref(),
            &p.motion_events(),
            DATASHEET_EFFICIENCY,
            &t,
        )?;
        let t_log: Vec<f64> = t.iter().map(|t| t + p.motion_t0_s).collect();
        viz.log_prediction(&t_log, &joints, &prefix(k))?;
    }
    viz.flush()?;
    Ok(())
}

/// The predictions of the logs (`rows`) as text or JSON; `simulated`: the twin's energy over
/// the logged span, for scoring, when one dataset was predicted.
fn emit_log_prices(
    json_out: bool,
    model: &PowerModel,
    rows: &[LogPrice],
    simulated: Option<f64>,
) -> Result<()> {
    let pct = |a: f64, b: f64| 100.0 * (a - b) / b;
    let json_rows: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let pred = &r.prediction;
            let mut v = json!({
                "source": r.source,
                "predicted_J": pred.energy_j, "interval_95_J": pred.interval_j,
                "measured_J": r.measured_j, "error_vs_measured_pct": r.error_pct(),
                "power_rmse_W": r.rmse_w(), "power_signal": model.signal.name(),
                "below_seen_J": pred.below_seen_j,
                "unseen_load_J": pred.unseen_load_j,
                "alternative_J": pred.alternative_j,
                "stribeck_J": pred.stribeck_j,
                "rest_s": pred.rest_s,
            });
            if let (Some(sim), 1) = (simulated, rows.len()) {
                v["simulated_J"] = json!(sim);
                v["error_vs_simulated_pct"] = json!(pct(pred.energy_j, sim));
            }
            v
        })
        .collect();
    if json_out {
        let out = if json_rows.len() == 1 {
            json_rows[0].clone()
        } else {
            json!(json_rows)
        };
        super::emit(&format!("{}\n", serde_json::to_string_pretty(&out)?))?;
    } else {
        let mut o = String::new();
        for r in rows {
            let pred = &r.prediction;
            let sim = match (simulated, rows.len()) {
                (Some(s), 1) => format!(", simulated {s:.2} J ({:+.3} %)", pct(pred.energy_j, s)),
                _ => String::new(),
            };
            let _ = writeln!(
                o,
                "{}: predicted {:.2} ± {:.2} J (95 %){sim}, measured {:.2} J ({:+.3} %), power RMSE {:.3} W{}",
                r.source,
                pred.energy_j,
                pred.interval_j,
                r.measured_j,
                r.error_pct(),
                r.rmse_w(),
                unseen(pred)
            );
        }
        super::emit(&o)?;
    }
    Ok(())
}

/// `predict --trajectory` or `--scenario`: price a plan nobody has run.
fn run_plan(args: &PredictArgs, robot: &Robot, model: &PowerModel) -> Result<ExitCode> {
    let (source, price, t0) = if let Some(path) = &args.trajectory {
        args.payloads.warn_foreign(robot);
        let traj = read_plan(robot, path)?;
        let t0 = traj.start_time();
        // A timeline's times are on the file's clock; the plan's run from its first sample.
        let events: Vec<PayloadEvent> = args
            .payloads
            .events()?
            .unwrap_or_default()
            .into_iter()
            .map(|e| PayloadEvent {
                t_s: e.t_s - t0,
                ..e
            })
            .collect();
        let price = price(
            model,
            robot,
            &traj,
            &events,
            DATASHEET_EFFICIENCY,
            traj.sample_times(),
        )
        .with_context(|| format!("predicting {}", path.display()))?;
        (path.display().to_string(), price, t0)
    } else {
        let path = args.scenario.as_ref().context("no plan given")?;
        let scenario = Scenario::from_file(path)?;
        let (speed, load) = scenario_cell(&scenario, args.speed, args.load)?;
        let price = price_scenario(model, robot, &scenario, speed, load, DATASHEET_EFFICIENCY)
            .with_context(|| format!("predicting {}", path.display()))?;
        let source = format!("{} at {speed} m/s, load {load} kg", path.display());
        (source, price, 0.0)
    };
    if let Some(path) = &args.power_out {
        let mut csv = String::from("t_s,P_predicted_W\n");
        for (t, p) in price.t_s.iter().zip(&price.power_w) {
            let _ = writeln!(csv, "{},{p}", t + t0);
        }
        write_atomic(path, csv.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let pred = &price.prediction;
    if args.json {
        let v = json!({
            "source": source,
            "energy_J": pred.energy_j,
            "interval_J": [pred.energy_j - pred.interval_j, pred.energy_j + pred.interval_j],
            "interval_95_J": pred.interval_j,
            "duration_s": pred.duration_s,
            "mean_power_W": price.mean_power_w(),
            "power_signal": model.signal.name(),
            "below_seen_J": pred.below_seen_j,
            "unseen_load_J": pred.unseen_load_j,
            "alternative_J": pred.alternative_j,
            "stribeck_J": pred.stribeck_j,
            "rest_s": pred.rest_s,
        });
        super::emit(&format!("{}\n", serde_json::to_string_pretty(&v)?))?;
    } else {
        super::emit(&format!(
            "{source}: predicted {:.2} ± {:.2} J (95 %), duration {:.3} s, mean power {:.2} W{}\n",
            pred.energy_j,
            pred.interval_j,
            pred.duration_s,
            price.mean_power_w(),
            unseen(pred)
        ))?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The notes a prediction carries when its power goes below the lowest level the
/// identification logs show the meter at, its payload is heavier than they carried, or the
/// model of the other friction structure, or the whole of the drive file's Stribeck rise,
/// differs from it by over half the interval's standard deviation (empty otherwise).
fn unseen(pred: &powertwin::identification::model::Prediction) -> String {
    let mut note = String::new();
    if pred.below_seen_j > 0.0 {
        note += &format!(
            "; {:.2} J of it below the lowest power identification saw the meter at (undetermined, in the interval)",
            pred.below_seen_j
        );
    }
    if pred.unseen_load_j > 0.0 {
        note += &format!(
            "; a payload heavier than identification carried moves {:.2} J more through the joints (its losses undetermined, in the interval)",
            pred.unseen_load_j
        );
    }
    if let Some(e) = pred.alternative_j
        && (pred.energy_j - e).abs() > 0.5 * pred.interval_j / 1.96
    {
        note += &format!(
            "; the mean of {:.2} J and {e:.2} J, the models with and without load-dependent gear friction (the logs do not tell them apart; half the difference is in the interval)",
            2.0 * pred.energy_j - e
        );
    }
    if let Some(e) = pred.stribeck_j
        && (e - pred.energy_j).abs() > 0.5 * pred.interval_j / 1.96
    {
        note += &format!(
            "; {e:.2} J with the whole of the drive file's Stribeck rise at slow joint speeds (the logs barely show it; the model takes part of it, the rest is in the interval)"
        );
    }
    note
}
