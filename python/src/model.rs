//! `identify`, its out-of-sample `holdout`, and the identified `Model` (predict, save, load,
//! export).

use std::path::PathBuf;

use numpy::{PyArray1, PyReadonlyArray2};
use powertwin::Robot;
use powertwin::dynamics::DriveTerms;
use powertwin::identification::consistency::consistency;
use powertwin::identification::consistent::{IdentifiedTwin, Options};
use powertwin::identification::data::Route;
use powertwin::identification::fit::{Estimator, FitOptions, Weighting, identify_logs};
use powertwin::identification::lsq::Estimate;
use powertwin::identification::model::{DATASHEET_EFFICIENCY, PowerModel, check_schema_version};
use powertwin::identification::plan::{LIMIT_CHECK_DT_S, PlanPrice, price, read_plan};
use powertwin::identification::prior::{Prior, PriorWidths};
use powertwin::io::write_atomic;
use powertwin::measurement::segments::MoveOptions;
use powertwin::model::payload::{PayloadEvent, resolve};
use powertwin::trajectory::limits::check_limits;
use powertwin::trajectory::sampled::Sampled;
use powertwin::validation::estimators::MIN_SPEED;
use powertwin::validation::heldout::LOG_ROUTE;
use powertwin::validation::holdout::{self as held_out, default_every};
use powertwin::validation::log_price::price_measured;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::json;

use crate::robot::PyRobot;
use crate::runs::PyLog;
use crate::{ctx, value_error};

/// An identified power model of a robot: base parameters, motor losses, covariance.
///
/// From `identify(...)` or `Model.load(path, robot)`. `save` writes what `powertwin identify
/// --out` writes; `predict` and `predict_trajectory` give what `powertwin predict` prints.
#[pyclass(name = "Model", module = "powertwin._powertwin", frozen)]
pub struct PyModel {
    robot: Robot,
    model: PowerModel,
    /// The free estimate (identify only; `None` for a loaded model).
    estimate: Option<Estimate>,
    /// The model file's document.
    doc: serde_json::Value,
}

/// How positions are differentiated (the CLI's `--base-freq`, `--harmonics`,
/// `--smoothing-window`).
fn route(base_freq: Option<f64>, harmonics: usize, smoothing_window: Option<usize>) -> Route {
    match (base_freq, smoothing_window) {
        (Some(f), _) => Route::Fourier {
            base_freq_hz: f,
            harmonics,
        },
        (None, Some(window)) => Route::Smoothing { window, degree: 4 },
        (None, None) => LOG_ROUTE,
    }
}

/// The payload timeline of a `--payload` spec (from before the start), or `None`.
fn payload_events(payload: Option<Vec<String>>) -> PyResult<Vec<PayloadEvent>> {
    match payload {
        Some(p) if !p.is_empty() => Ok(vec![PayloadEvent {
            t_s: f64::NEG_INFINITY,
            payload: Some(resolve(&p.join("+"), std::path::Path::new(".")).map_err(ctx(""))?),
        }]),
        _ => Ok(Vec::new()),
    }
}

/// The prior widths of a `{key: value}` dict over the defaults (the CLI's `--prior-width`).
fn widths(w: Option<std::collections::HashMap<String, f64>>) -> PyResult<PriorWidths> {
    let mut out = PriorWidths::default();
    for (key, v) in w.unwrap_or_default() {
        let slot = match key.as_str() {
            "mass" => &mut out.mass_rel,
            "com" => &mut out.com_m,
            "inertia" => &mut out.inertia_rel,
            "friction" => &mut out.friction_rel,
            "rotor" => &mut out.rotor_rel,
            "copper" => &mut out.copper_rel,
            "gear" => &mut out.gear_rel,
            other => {
                return Err(value_error(format!(
                    "prior_widths: unknown key '{other}' (mass, com, inertia, friction, rotor, copper, gear)"
                )));
            }
        };
        *slot = v;
    }
    Ok(out)
}

/// The candidate estimators of `method` and the weighting (the CLI's `--method`,
/// `--weighting`).
fn estimators(method: &str, weighting: Option<&str>) -> PyResult<(Vec<Estimator>, Weighting)> {
    let candidates = match method {
        "auto" => Estimator::auto(),
        "total" => vec![Estimator::Total],
        "pmsm" => vec![Estimator::Pmsm],
        "gear" => vec![Estimator::Pmsm, Estimator::Gear],
        other => {
            return Err(value_error(format!(
                "method={other:?}: expected 'auto', 'total', 'pmsm' or 'gear'"
            )));
        }
    };
    let weighting = match weighting {
        None => FitOptions::default().weighting,
        Some("none") => Weighting::None,
        Some("per-log") => Weighting::PerLog,
        Some("power-level") => Weighting::PowerLevel,
        Some(w) => {
            return Err(value_error(format!(
                "weighting={w:?}: expected 'none', 'per-log' or 'power-level'"
            )));
        }
    };
    Ok((candidates, weighting))
}

/// Refuse logs whose joint count is not the robot's (the CLI's message).
fn check_dof(robot: &PyRobot, logs: &[powertwin::measurement::Log]) -> PyResult<()> {
    for log in logs {
        if log.dof() != robot.robot.dof() {
            return Err(value_error(format!(
                "{}: {} joint columns, robot '{}' has {} joints",
                log.source,
                log.dof(),
                robot.robot.name(),
                robot.robot.dof()
            )));
        }
    }
    Ok(())
}

/// `identify`'s and `holdout`'s options as the Python wrappers pass them: a dict with these
/// keys, the CLI's options of the same names.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct FitArgs {
    method: String,
    base_freq: Option<f64>,
    harmonics: usize,
    smoothing_window: Option<usize>,
    min_speed: Option<f64>,
    fit_rate: f64,
    weighting: Option<String>,
    unconstrained: bool,
    arm_power_only: bool,
    prior: bool,
    prior_widths: Option<std::collections::HashMap<String, f64>>,
}

/// What `identify` and `holdout` fit with: the logs, the fit's options, the route and the
/// prior of the URDF and drive file.
struct Setup {
    logs: Vec<powertwin::measurement::Log>,
    opts: FitOptions,
    route: Route,
    prior: Option<Prior>,
}

/// The [`Setup`] of `logs` and `args` on `robot`.
fn setup(robot: &PyRobot, logs: Vec<PyRef<'_, PyLog>>, args: FitArgs) -> PyResult<Setup> {
    let (candidates, weighting) = estimators(&args.method, args.weighting.as_deref())?;
    let logs: Vec<powertwin::measurement::Log> = logs.iter().map(|l| l.log.clone()).collect();
    check_dof(robot, &logs)?;
    let prior = if args.prior {
        let drive = robot.drive()?;
        Some(
            Prior::for_robot(&robot.robot, drive.as_ref(), &widths(args.prior_widths)?)
                .map_err(ctx("building the prior from the URDF and drive file"))?,
        )
    } else {
        None
    };
    let opts = FitOptions {
        min_speed: args.min_speed.unwrap_or(MIN_SPEED),
        candidates,
        weighting,
        consistent: !args.unconstrained,
        motor_power: !args.arm_power_only,
        max_fit_rate_hz: args.fit_rate,
        prior: prior.clone(),
        ..FitOptions::default()
    };
    Ok(Setup {
        logs,
        opts,
        route: route(args.base_freq, args.harmonics, args.smoothing_window),
        prior,
    })
}

/// Identify a power model from logs, as `powertwin identify --method auto|total|pmsm` does
/// (the estimator chosen by cross-validation; physically consistent unless `unconstrained`;
/// the prior from the URDF and the robot's drive file unless `prior=False`). The held-out
/// check of `identify --holdout` is [`holdout`] (it does not change the model).
#[pyfunction]
pub fn identify(
    py: Python<'_>,
    robot: &PyRobot,
    logs: Vec<PyRef<'_, PyLog>>,
    args: FitArgs,
) -> PyResult<PyModel> {
    let method = args.method.clone();
    let Setup {
        logs,
        opts,
        route,
        prior,
    } = setup(robot, logs, args)?;
    let r = &robot.robot;
    py.detach(|| -> PyResult<PyModel> {
        let sel = identify_logs(r, &logs, &[route], &opts).map_err(ctx(""))?;
        let determination = prior
            .map(|p| p.determination(&sel.fit.model))
            .transpose()
            .map_err(ctx(""))?;
        let model = sel.fit.model.clone();
        let estimates = vec![sel.fit.free_estimate()];
        let consistency = consistency(r, &model, 1.0, 200, 1).map_err(ctx(""))?;
        let doc = json!({
            "method": method,
            "model": model,
            "estimates": estimates,
            "cross_validation": sel.scores,
            "consistency": consistency,
            "determination": determination,
        });
        Ok(PyModel {
            robot: r.clone(),
            model,
            estimate: estimates.into_iter().next_back(),
            doc,
        })
    })
}

/// Check an identification out of sample on the user's own logs, as `powertwin identify
/// --holdout K` does before fitting on everything: leave out every K-th run (with fewer than
/// 4 runs, every K-th rest-to-rest move; along the Fourier route always runs), identify on the
/// rest with `identify`'s options and predict each piece left out. `every`: K (`None`: the
/// CLI's default). Returns the JSON of `identify --json`'s `holdout`. Errors: too few pieces,
/// and those of the identification and predictions.
#[pyfunction]
pub fn holdout(
    py: Python<'_>,
    robot: &PyRobot,
    logs: Vec<PyRef<'_, PyLog>>,
    every: Option<usize>,
    args: FitArgs,
) -> PyResult<String> {
    let s = setup(robot, logs, args)?;
    let moves = MoveOptions::default();
    let every = every.unwrap_or_else(|| default_every(&s.logs, s.route, &moves));
    let r = &robot.robot;
    py.detach(|| {
        let h = held_out::holdout(r, &s.logs, every, s.route, &s.opts, &moves)
            .map_err(ctx("holdout"))?;
        serde_json::to_string(&h).map_err(|e| value_error(e.to_string()))
    })
}

impl PyModel {
    /// Parse and check a model file's text, as the CLI's `read_model`.
    fn parse(text: &str, shown: &str, robot: &PyRobot) -> PyResult<PyModel> {
        let doc: serde_json::Value = serde_json::from_str(text)
            .map_err(|e| value_error(format!("{shown}: not valid JSON: {e}")))?;
        let v = doc.get("model").cloned().unwrap_or_else(|| doc.clone());
        check_schema_version(&v).map_err(ctx(format!("reading {shown}")))?;
        let model: PowerModel = serde_json::from_value(v)
            .map_err(|e| value_error(format!("{shown}: not a powertwin model: {e}")))?;
        model
            .validate(&robot.robot)
            .map_err(ctx(format!("checking {shown}")))?;
        Ok(PyModel {
            robot: robot.robot.clone(),
            model,
            estimate: None,
            doc,
        })
    }
}

/// A plan's price as a dict.
fn plan_dict<'py>(py: Python<'py>, p: &PlanPrice, t0: f64) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let pred = &p.prediction;
    d.set_item("energy_J", pred.energy_j)?;
    d.set_item("interval_J", pred.interval_j)?;
    d.set_item("duration_s", pred.duration_s)?;
    d.set_item("below_seen_J", pred.below_seen_j)?;
    d.set_item("unseen_load_J", pred.unseen_load_j)?;
    d.set_item("alternative_J", pred.alternative_j)?;
    d.set_item("stribeck_J", pred.stribeck_j)?;
    d.set_item("rest_s", pred.rest_s)?;
    d.set_item("mean_power_W", p.mean_power_w())?;
    let t: Vec<f64> = p.t_s.iter().map(|t| t + t0).collect();
    d.set_item("t_s", PyArray1::from_vec(py, t))?;
    d.set_item("power_W", PyArray1::from_slice(py, &p.power_w))?;
    Ok(d)
}

#[pymethods]
impl PyModel {
    /// Read a model file written by `identify` (or a bare model) for `robot`, as `powertwin
    /// predict --model` does (schema version checked, model checked against the robot).
    #[staticmethod]
    fn load(path: PathBuf, robot: &PyRobot) -> PyResult<PyModel> {
        let text =
            std::fs::read_to_string(&path).map_err(|e| crate::os_error("reading", &path, &e))?;
        PyModel::parse(&text, &path.display().to_string(), robot)
    }

    /// A model from the text of a model file (`shown` names it in errors; pickling).
    #[staticmethod]
    fn _from_json(text: &str, shown: &str, robot: &PyRobot) -> PyResult<PyModel> {
        PyModel::parse(text, shown, robot)
    }

    /// Write the model file (JSON; what `identify --out` writes for an identified model, the
    /// file read for a loaded one), atomically.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        let text = serde_json::to_string_pretty(&self.doc)
            .map_err(|e| value_error(format!("serialising the model: {e}")))?;
        write_atomic(&path, text.as_bytes()).map_err(ctx(format!("writing {}", path.display())))
    }

    /// The model file's JSON text.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.doc).map_err(|e| value_error(e.to_string()))
    }

    /// Write the identified robot as URDF (physically consistent link inertials and
    /// friction; what the data cannot reveal keeps the input URDF's values), as `identify
    /// --export-urdf`; `drive`: also the identified drive file (TOML), as `--export-drive`.
    #[pyo3(signature = (path, drive=None))]
    fn export_urdf(&self, py: Python<'_>, path: PathBuf, drive: Option<PathBuf>) -> PyResult<()> {
        let (robot, model) = (&self.robot, &self.model);
        py.detach(|| -> PyResult<()> {
            let twin = match &self.estimate {
                Some(est) => {
                    let prior = model.layout.theta(robot, &DriveTerms::from_urdf(robot));
                    IdentifiedTwin::new(robot, model, est, &prior, &Options::default())
                }
                None => IdentifiedTwin::from_model(robot, model, &Options::default()),
            }
            .map_err(ctx("export: physically consistent parameters"))?;
            write_atomic(&path, twin.urdf().as_bytes())
                .map_err(ctx(format!("writing {}", path.display())))?;
            if let Some(d) = &drive {
                write_atomic(d, twin.drive_toml().as_bytes())
                    .map_err(ctx(format!("writing {}", d.display())))?;
            }
            Ok(())
        })
    }

    /// The energy of a logged motion (as `powertwin predict --log/--data`): a dict with
    /// energy_J and interval_J (95 %, half width) of the modelled signal, measured_J, and the
    /// power at the logged samples: t_s (s), power_W (predicted), measured_W.
    #[pyo3(signature = (log, base_freq=None, harmonics=5, smoothing_window=None))]
    fn _predict<'py>(
        &self,
        py: Python<'py>,
        log: &PyLog,
        base_freq: Option<f64>,
        harmonics: usize,
        smoothing_window: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let route = route(base_freq, harmonics, smoothing_window);
        let (robot, model) = (&self.robot, &self.model);
        let lp = py.detach(|| price_measured(model, robot, &log.log, route).map(|(_, lp)| lp));
        let lp = lp.map_err(ctx(""))?;
        let d = PyDict::new(py);
        d.set_item("energy_J", lp.prediction.energy_j)?;
        d.set_item("interval_J", lp.prediction.interval_j)?;
        d.set_item("duration_s", lp.prediction.duration_s)?;
        d.set_item("below_seen_J", lp.prediction.below_seen_j)?;
        d.set_item("unseen_load_J", lp.prediction.unseen_load_j)?;
        d.set_item("alternative_J", lp.prediction.alternative_j)?;
        d.set_item("stribeck_J", lp.prediction.stribeck_j)?;
        d.set_item("rest_s", lp.prediction.rest_s)?;
        d.set_item("measured_J", lp.measured_j)?;
        d.set_item("error_pct", lp.error_pct())?;
        d.set_item("power_rmse_W", lp.rmse_w())?;
        d.set_item("t_s", PyArray1::from_slice(py, &lp.t_s))?;
        d.set_item("power_W", PyArray1::from_slice(py, &lp.predicted_w))?;
        d.set_item("measured_W", PyArray1::from_slice(py, &lp.measured_w))?;
        Ok(d)
    }

    /// The energy and power of a planned trajectory nobody has run (as `powertwin predict
    /// --trajectory`): from the CSV `path`, or arrays `t_s` (s), `q_rad` (n, dof) with
    /// optional `dq` (rad/s) and `ddq` (rad/s^2); `payload` at the flange from the start.
    #[pyo3(signature = (path, t_s, q_rad, dq, ddq, payload))]
    #[allow(clippy::too_many_arguments)]
    fn _predict_trajectory<'py>(
        &self,
        py: Python<'py>,
        path: Option<PathBuf>,
        t_s: Option<Vec<f64>>,
        q_rad: Option<PyReadonlyArray2<'py, f64>>,
        dq: Option<PyReadonlyArray2<'py, f64>>,
        ddq: Option<PyReadonlyArray2<'py, f64>>,
        payload: Option<Vec<String>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (robot, model) = (&self.robot, &self.model);
        let cols = |a: &PyReadonlyArray2<'py, f64>| -> Vec<Vec<f64>> {
            let v = a.as_array();
            (0..v.ncols()).map(|j| v.column(j).to_vec()).collect()
        };
        let (q, dq, ddq) = (
            q_rad.as_ref().map(cols),
            dq.as_ref().map(cols),
            ddq.as_ref().map(cols),
        );
        let events = payload_events(payload)?;
        let (price, t0) = py.detach(|| -> PyResult<(PlanPrice, f64)> {
            let (traj, label) = match (&path, t_s, q) {
                (Some(p), _, _) => (
                    read_plan(robot, p).map_err(ctx(""))?,
                    p.display().to_string(),
                ),
                (None, Some(t), Some(q)) => {
                    let traj = Sampled::new(t, q, dq, ddq).map_err(ctx("trajectory"))?;
                    check_limits(robot, &traj, LIMIT_CHECK_DT_S, None)
                        .map_err(ctx("trajectory"))?;
                    (traj, "trajectory".to_string())
                }
                _ => return Err(value_error("a trajectory file or t_s and q_rad is needed")),
            };
            let t0 = traj.start_time();
            let events: Vec<PayloadEvent> = events
                .into_iter()
                .map(|e| PayloadEvent {
                    t_s: e.t_s - t0,
                    ..e
                })
                .collect();
            let p = price(
                model,
                robot,
                &traj,
                &events,
                DATASHEET_EFFICIENCY,
                traj.sample_times(),
            )
            .map_err(ctx(format!("predicting {label}")))?;
            Ok((p, t0))
        })?;
        plan_dict(py, &price, t0)
    }

    /// The modelled power signal: "total", "bus" or "grid".
    #[getter]
    fn signal(&self) -> String {
        self.model.signal.name().to_string()
    }

    /// The identified base parameters (model units), shape (p,).
    #[getter]
    fn theta<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.model.theta)
    }

    /// The identification method of the model file ("auto", "total", "pmsm" or "gear"), if it
    /// says.
    #[getter]
    fn method(&self) -> Option<String> {
        self.doc
            .get("method")
            .and_then(|m| m.as_str())
            .map(str::to_string)
    }

    fn __repr__(&self) -> String {
        format!(
            "Model(robot='{}', signal='{}', {} base parameters)",
            self.robot.name(),
            self.model.signal.name(),
            self.model.theta.len()
        )
    }
}

/// The `PowerModel` of a Python model (for the sweep).
pub fn inner(m: &PyModel) -> &PowerModel {
    &m.model
}
