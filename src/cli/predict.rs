//! `powertwin predict`: the energy of logged motions by an identified model, with its 95 %
//! interval; the power at the logged samples against the measured one (`--power-out`); the
//! logs with the model's power in Rerun.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use powertwin::dataset::Dataset;
use powertwin::identification::data::{Prepared, power_times, prepare};
use powertwin::identification::energy::window_energies;
use powertwin::identification::model::{DATASHEET_EFFICIENCY, Prediction};
use powertwin::io::write_atomic;
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
        required_unless_present = "log",
        conflicts_with = "log"
    )]
    data: Option<PathBuf>,
    #[command(flatten)]
    logs: LogArgs,
    #[command(flatten)]
    route: RouteArgs,
    #[command(flatten)]
    payloads: PayloadArgs,
    /// Write the power at the logged samples as CSV, to see where the model misses:
    /// `log` (1-based, in the order printed), `t_s` (the log's clock; for a logger that
    /// averages power, the middle of each sample period), `measured_{signal}_W` and
    /// `predicted_{signal}_W` (the modelled signal: total, bus or grid; a bus or grid
    /// prediction never goes negative).
    #[arg(long, value_name = "FILE.csv")]
    power_out: Option<PathBuf>,
    /// Machine-readable JSON instead of text.
    #[arg(long)]
    json: bool,
    #[cfg(feature = "viz")]
    #[command(flatten)]
    viz: super::viz::VizArgs,
}

/// One log's prediction.
struct Row {
    /// Where the log came from.
    source: String,
    /// Predicted energy with its interval.
    prediction: Prediction,
    /// Energy of the measured signal over the log, J.
    measured_j: f64,
    /// Times the logged power belongs to, s (log clock).
    t_s: Vec<f64>,
    /// Measured power at those times, W.
    measured_w: Vec<f64>,
    /// Predicted power of the measured signal at those times, W.
    predicted_w: Vec<f64>,
}

impl Row {
    /// RMS of predicted minus measured power, W.
    fn rmse_w(&self) -> f64 {
        let se: f64 = self
            .predicted_w
            .iter()
            .zip(&self.measured_w)
            .map(|(p, y)| (p - y).powi(2))
            .sum();
        (se / self.measured_w.len().max(1) as f64).sqrt()
    }
}

/// Run `predict`.
pub fn run_predict(args: &PredictArgs) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let model = read_model(&args.model, &robot)?;
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
    let mut rows = Vec::new();
    let mut prepared: Vec<Prepared> = Vec::new();
    for log in &logs {
        let p = prepare(log, args.route.route())?;
        let events = p.motion_events();
        let prediction = model.predict(
            &robot,
            p.motion.as_ref(),
            &events,
            DATASHEET_EFFICIENCY,
            1e-3,
        )?;
        let measured_j: f64 = window_energies(&p.states.t, &p.p_total, p.power_averaged)
            .iter()
            .sum();
        let t_s = power_times(&p.states.t, p.power_averaged);
        let t: Vec<f64> = t_s.iter().map(|t| t - p.motion_t0_s).collect();
        let mut predicted_w = model.power_with_payloads(
            &robot,
            p.motion.as_ref(),
            &events,
            DATASHEET_EFFICIENCY,
            &t,
        )?;
        if model.signal.clipped() {
            predicted_w.iter_mut().for_each(|v| *v = v.max(0.0));
        }
        rows.push(Row {
            source: log.source.clone(),
            prediction,
            measured_j,
            t_s,
            measured_w: p.p_total.clone(),
            predicted_w,
        });
        prepared.push(p);
    }
    if let Some(path) = &args.power_out {
        let signal = model.signal.name();
        let mut csv = format!("log,t_s,measured_{signal}_W,predicted_{signal}_W\n");
        for (k, r) in rows.iter().enumerate() {
            for ((t, y), p) in r.t_s.iter().zip(&r.measured_w).zip(&r.predicted_w) {
                let _ = writeln!(csv, "{},{t},{y},{p}", k + 1);
            }
        }
        write_atomic(path, csv.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    #[cfg(feature = "viz")]
    if let Some(viz) = &viz {
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
        for (k, (log, p)) in logs.iter().zip(&prepared).enumerate() {
            viz.log_measurement(&robot, log, &prefix(k))?;
            // The model's power along the route, between the samples too.
            let steps = (p.motion.duration() * DEFAULT_DISPLAY_HZ).ceil().max(1.0) as usize;
            let t: Vec<f64> = (0..=steps)
                .map(|j| p.motion.duration() * j as f64 / steps as f64)
                .collect();
            let joints = model.joint_powers_with_payloads(
                &robot,
                p.motion.as_ref(),
                &p.motion_events(),
                DATASHEET_EFFICIENCY,
                &t,
            )?;
            let t_log: Vec<f64> = t.iter().map(|t| t + p.motion_t0_s).collect();
            viz.log_prediction(&t_log, &joints, &prefix(k))?;
        }
        viz.flush()?;
    }
    let pct = |a: f64, b: f64| 100.0 * (a - b) / b;
    let json_rows: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let pred = &r.prediction;
            let mut v = json!({
                "source": r.source,
                "predicted_J": pred.energy_j, "interval_95_J": pred.interval_j,
                "measured_J": r.measured_j, "error_vs_measured_pct": pct(pred.energy_j, r.measured_j),
                "power_rmse_W": r.rmse_w(), "power_signal": model.signal.name(),
            });
            if let (Some(sim), 1) = (simulated, rows.len()) {
                v["simulated_J"] = json!(sim);
                v["error_vs_simulated_pct"] = json!(pct(pred.energy_j, sim));
            }
            v
        })
        .collect();
    if args.json {
        let out = if json_rows.len() == 1 {
            json_rows[0].clone()
        } else {
            json!(json_rows)
        };
        super::emit(&format!("{}\n", serde_json::to_string_pretty(&out)?))?;
    } else {
        let mut o = String::new();
        for r in &rows {
            let pred = &r.prediction;
            let sim = match (simulated, rows.len()) {
                (Some(s), 1) => format!(", simulated {s:.2} J ({:+.3} %)", pct(pred.energy_j, s)),
                _ => String::new(),
            };
            let _ = writeln!(
                o,
                "{}: predicted {:.2} ± {:.2} J (95 %){sim}, measured {:.2} J ({:+.3} %), power RMSE {:.3} W",
                r.source,
                pred.energy_j,
                pred.interval_j,
                r.measured_j,
                pct(pred.energy_j, r.measured_j),
                r.rmse_w()
            );
        }
        super::emit(&o)?;
    }
    Ok(ExitCode::SUCCESS)
}
