//! `powertwin identify` and `powertwin predict`: parameters from motor power, and the energy
//! the identified model predicts.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use powertwin::dataset::Dataset;
use powertwin::dynamics::ParamLayout;
use powertwin::identification::data::{Prepared, Route, prepare};
use powertwin::identification::energy::{self, Windows, window_energies};
use powertwin::identification::linear::{self, Observation};
use powertwin::identification::lsq::Estimate;
use powertwin::identification::model::PowerModel;
use powertwin::identification::pmsm;
use powertwin::identification::states::States;
use powertwin::identification::steps::{self, StepData, hold_still};
use powertwin::io::write_atomic;
use powertwin::validation::params::consistency;
use serde_json::json;

use super::{RobotArgs, read_model};

/// Identification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// The paper: step by step from total power, datasets in step order (joint 6, 5-6, ...).
    PaperSteps,
    /// All base parameters at once from total power.
    Total,
    /// From the power of each motor (eq. 13).
    PerJoint,
    /// From the energy of the windows between samples (no accelerations).
    Energy,
    /// PMSM losses too (copper and standby, nonlinear least squares).
    Pmsm,
    /// Classic torque least squares (reference; uses the logged joint torques).
    Torque,
}

/// How the logged positions are differentiated.
#[derive(Debug, Args)]
pub struct RouteArgs {
    /// Base frequency of a periodic excitation, Hz: fit the Fourier series (the paper's route).
    /// Without it, positions are smoothed with a local polynomial.
    #[arg(long)]
    base_freq: Option<f64>,
    /// Harmonics of the Fourier fit.
    #[arg(long, default_value_t = 5)]
    harmonics: usize,
}

impl RouteArgs {
    fn route(&self) -> Route {
        match self.base_freq {
            Some(f) => Route::Fourier {
                base_freq_hz: f,
                harmonics: self.harmonics,
            },
            None => Route::Smoothing {
                window: 9,
                degree: 4,
            },
        }
    }
}

/// Arguments of `identify`.
#[derive(Debug, Args)]
pub struct IdentifyArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Dataset directories (for paper-steps: one per step, joint 6 first).
    #[arg(long, value_name = "DIR", num_args = 1.., required = true)]
    data: Vec<PathBuf>,
    /// Identification method.
    #[arg(long, value_enum, default_value = "total")]
    method: Method,
    #[command(flatten)]
    route: RouteArgs,
    /// Drop samples at which an excited joint moves slower than this, rad/s (around velocity
    /// reversals the Coulomb sign is uncertain and stiction holds the joint). 0 keeps all.
    #[arg(long, default_value_t = 0.0, value_name = "RAD_S")]
    min_speed: f64,
    /// Output model file (JSON: base parameters, losses, statistics).
    #[arg(long, value_name = "MODEL.json")]
    out: PathBuf,
}

/// Concatenate the states of several datasets.
fn concat(prepared: &[Prepared]) -> States {
    let n = prepared[0].states.q.len();
    let mut s = States {
        t: Vec::new(),
        q: vec![Vec::new(); n],
        dq: vec![Vec::new(); n],
        ddq: vec![Vec::new(); n],
    };
    for p in prepared {
        s.t.extend_from_slice(&p.states.t);
        for i in 0..n {
            s.q[i].extend_from_slice(&p.states.q[i]);
            s.dq[i].extend_from_slice(&p.states.dq[i]);
            s.ddq[i].extend_from_slice(&p.states.ddq[i]);
        }
    }
    s
}

/// Run `identify`.
pub fn run_identify(args: &IdentifyArgs) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let mut datasets = Vec::new();
    for d in &args.data {
        let ds = Dataset::read(d).with_context(|| format!("reading dataset {}", d.display()))?;
        if ds.meta.robot.name != robot.name() || ds.meta.robot.dof != robot.dof() {
            bail!(
                "dataset {} is from robot '{}' ({} joints), not '{}' ({} joints)",
                d.display(),
                ds.meta.robot.name,
                ds.meta.robot.dof,
                robot.name(),
                robot.dof()
            );
        }
        datasets.push(ds);
    }
    if args.min_speed > 0.0 && args.method == Method::Energy {
        bail!(
            "--min-speed does not apply to the energy method (its windows join consecutive samples)"
        );
    }
    let prepared: Vec<Prepared> = datasets
        .iter()
        .zip(&args.data)
        .map(|(ds, d)| {
            let mut p = prepare(&ds.log(&d.display().to_string())?, args.route.route())
                .with_context(|| format!("preparing {}", d.display()))?;
            if args.min_speed > 0.0 {
                let dropped = p.drop_slow_samples(args.min_speed)?;
                eprintln!(
                    "{}: {dropped} samples with an excited joint below {} rad/s dropped",
                    d.display(),
                    args.min_speed
                );
            }
            Ok(p)
        })
        .collect::<Result<_>>()?;
    let layout = ParamLayout::new(&robot, true, true);
    let scaled = !matches!(args.method, Method::Pmsm | Method::Torque);
    let mut model = PowerModel::new(&robot, layout, scaled)?;
    let estimates: Vec<Estimate> = match args.method {
        Method::Total | Method::PerJoint | Method::Torque => {
            let states = concat(&prepared);
            let (kind, y): (Observation, Vec<f64>) = match args.method {
                Method::Total => (
                    Observation::TotalPower,
                    prepared.iter().flat_map(|p| p.p_total.clone()).collect(),
                ),
                Method::PerJoint => (
                    Observation::JointPower,
                    prepared.iter().flat_map(|p| p.p_joint.clone()).collect(),
                ),
                _ => {
                    let n = robot.dof();
                    let mut tau = Vec::new();
                    for ds in &datasets {
                        let stride = ds.meta.measurement.stride(ds.truth.dt)?;
                        for k in 0..ds.measured.t.len() {
                            tau.extend((0..n).map(|i| ds.truth.tau[i][k * stride]));
                        }
                    }
                    (Observation::Torque, tau)
                }
            };
            vec![linear::identify(&robot, &mut model, &states, kind, &y)?]
        }
        Method::Pmsm => {
            let states = concat(&prepared);
            let y: Vec<f64> = prepared.iter().flat_map(|p| p.p_total.clone()).collect();
            vec![pmsm::identify(&robot, &mut model, &states, &y)?]
        }
        Method::Energy => {
            let energies: Vec<Vec<f64>> = prepared
                .iter()
                .map(|p| window_energies(&p.states.t, &p.p_total, p.power_averaged))
                .collect();
            let windows: Vec<Windows> = prepared
                .iter()
                .zip(&energies)
                .map(|(p, e)| Windows {
                    motion: p.motion.as_ref(),
                    t: &p.states.t,
                    energy: e,
                })
                .collect();
            vec![energy::identify(&robot, &mut model, &windows)?]
        }
        Method::PaperSteps => {
            let data: Vec<StepData> = prepared
                .into_iter()
                .map(|p| {
                    let mut states = p.states;
                    hold_still(&mut states, &p.excited);
                    StepData {
                        joints: p.excited,
                        states,
                        p_total: p.p_total,
                    }
                })
                .collect();
            steps::identify(&robot, &mut model, &data)?
                .into_iter()
                .map(|r| r.estimate)
                .collect()
        }
    };
    // Positive definiteness does not depend on the 1/eta scale: check in model units.
    let consistency = consistency(&robot, &model, 1.0, 200, 1)?;
    let out = json!({
        "method": format!("{:?}", args.method),
        "model": model,
        "estimates": estimates,
        "consistency": consistency,
    });
    write_atomic(&args.out, serde_json::to_string_pretty(&out)?.as_bytes())
        .with_context(|| format!("writing {}", args.out.display()))?;
    if let Some(e) = estimates.last() {
        eprintln!(
            "{} base parameters identified ({:?}), condition number {:.1}, residual RMS {:.4}, {} observations -> {}",
            model.theta.iter().filter(|v| **v != 0.0).count(),
            args.method,
            e.cond,
            e.residual_rms,
            e.rows,
            args.out.display()
        );
    }
    eprintln!(
        "physical consistency: {} (mass matrix at 200 random poses: smallest eigenvalue {:.4} kg m^2{}; negative friction or rotor inertia: {})",
        if consistency.consistent { "yes" } else { "NO" },
        consistency.min_eigenvalue,
        if model.efficiency_scaled {
            " / eta"
        } else {
            ""
        },
        if consistency.negative_drive_terms.is_empty() {
            "none".to_string()
        } else {
            consistency.negative_drive_terms.join(", ")
        }
    );
    Ok(ExitCode::SUCCESS)
}

/// Arguments of `predict`.
#[derive(Debug, Args)]
pub struct PredictArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Model file written by `identify`.
    #[arg(long, value_name = "MODEL.json")]
    model: PathBuf,
    /// Dataset to predict.
    #[arg(long, value_name = "DIR")]
    data: PathBuf,
    #[command(flatten)]
    route: RouteArgs,
    /// Machine-readable JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// Run `predict`.
pub fn run_predict(args: &PredictArgs) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let model = read_model(&args.model, &robot)?;
    let ds = Dataset::read(&args.data)
        .with_context(|| format!("reading dataset {}", args.data.display()))?;
    let p = prepare(
        &ds.log(&args.data.display().to_string())?,
        args.route.route(),
    )?;
    let predicted = model.energy(&robot, p.motion.as_ref(), 1e-3)?;
    let measured: f64 = window_energies(&p.states.t, &p.p_total, p.power_averaged)
        .iter()
        .sum();
    let simulated = ds.meta.summary.energy_total_j;
    let mut ws = powertwin::dynamics::Workspace::new(&robot);
    let mut w = nalgebra::DMatrix::zeros(robot.dof(), model.layout.len());
    let n = robot.dof();
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut se = 0.0;
    for m in 0..p.states.len() {
        p.states.at(m, &mut q, &mut dq, &mut ddq);
        let pp = model.power(&robot, &mut ws, &mut w, &q, &dq, &ddq);
        se += (pp - p.p_total[m]).powi(2);
    }
    let rmse = (se / p.states.len() as f64).sqrt();
    let pct = |a: f64, b: f64| 100.0 * (a - b) / b;
    if args.json {
        super::emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(&json!({
                "predicted_J": predicted, "simulated_J": simulated, "measured_J": measured,
                "error_vs_simulated_pct": pct(predicted, simulated), "error_vs_measured_pct": pct(predicted, measured),
                "power_rmse_W": rmse,
            }))?
        ))?;
    } else {
        super::emit(&format!(
            "predicted {predicted:.2} J, simulated {simulated:.2} J ({:+.3} %), measured {measured:.2} J ({:+.3} %), power RMSE {rmse:.3} W\n",
            pct(predicted, simulated),
            pct(predicted, measured)
        ))?;
    }
    Ok(ExitCode::SUCCESS)
}
