//! `powertwin identify`: parameters from motor power (datasets or measured logs), and the
//! arguments it shares with `predict` (route, payloads).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use powertwin::Robot;
use powertwin::dataset::Dataset;
use powertwin::dynamics::ParamLayout;
use powertwin::identification::consistency::{Consistency, consistency};
use powertwin::identification::data::{Prepared, Route, ensure_motion, prepare};
use powertwin::identification::energy::{self, Windows, window_energies};
use powertwin::identification::fit::{CvScore, Estimator, FitOptions, Weighting, identify_logs};
use powertwin::identification::linear::{self, Observation};
use powertwin::identification::lsq::Estimate;
use powertwin::identification::model::PowerModel;
use powertwin::identification::prior::{Determination, Prior, PriorWidths};
use powertwin::identification::steps::{self, StepData, hold_still};
use powertwin::io::write_atomic;
use powertwin::measurement::Log;
use powertwin::measurement::segments::MoveOptions;
use powertwin::model::payload::{PayloadEvent, resolve, timeline_from_file};
use powertwin::validation::estimators::MIN_SPEED;
use powertwin::validation::heldout::LOG_ROUTE;
use powertwin::validation::holdout::{Holdout, default_every, holdout};
use serde_json::json;

use super::RobotArgs;

mod report;
use super::log::{LogArgs, load_logs};
use report::{report_determination, report_friction, report_lowest_seen};

/// Identification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// The estimator chosen by cross-validation (leave one log out, or time blocks) between
    /// `total` and `pmsm`; known payloads enter through the base relations.
    Auto,
    /// The paper: step by step from total power, datasets in step order (joint 6, 5-6, ...).
    PaperSteps,
    /// All base parameters at once from total power (linear, no copper loss).
    Total,
    /// From the power of each motor (eq. 13).
    PerJoint,
    /// From the energy of the windows between samples (no accelerations).
    Energy,
    /// PMSM losses too (copper and standby, nonlinear least squares).
    Pmsm,
    /// PMSM losses and load-dependent gear friction `g |tau dq|` per joint (nonlinear),
    /// chosen by cross-validation against `pmsm`; the interval adds the two models'
    /// disagreement.
    Gear,
}

impl Method {
    /// The estimators cross-validation chooses from for a fitted method (`auto`, `total`,
    /// `pmsm`, `gear`); `None` for the paper's methods, which fit no candidates.
    pub(super) fn candidates(self) -> Option<Vec<Estimator>> {
        match self {
            Method::Auto => Some(Estimator::auto()),
            Method::Total => Some(vec![Estimator::Total]),
            Method::Pmsm => Some(vec![Estimator::Pmsm]),
            Method::Gear => Some(vec![Estimator::Pmsm, Estimator::Gear]),
            Method::PaperSteps | Method::PerJoint | Method::Energy => None,
        }
    }
}

/// Weighting of the samples (see `identify --weighting`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum WeightingArg {
    /// Ordinary least squares.
    None,
    /// Each log by the inverse of its residual variance.
    PerLog,
    /// Each sample by the inverse of a variance growing with the active power.
    PowerLevel,
}

impl From<WeightingArg> for Weighting {
    fn from(w: WeightingArg) -> Weighting {
        match w {
            WeightingArg::None => Weighting::None,
            WeightingArg::PerLog => Weighting::PerLog,
            WeightingArg::PowerLevel => Weighting::PowerLevel,
        }
    }
}

/// How the logged positions are differentiated.
#[derive(Debug, Args)]
pub struct RouteArgs {
    /// Base frequency of a periodic excitation, Hz: fit the Fourier series (the paper's route).
    /// Without it, any motion takes the spline route: rests held exactly still and the
    /// least-jerk quintic spline between them, smoothed for the log's own encoder noise.
    #[arg(long)]
    base_freq: Option<f64>,
    /// Harmonics of the Fourier fit.
    #[arg(long, default_value_t = 5)]
    harmonics: usize,
    /// Instead of the spline route, a local quartic through this many samples (odd, at least
    /// 5: the route before the spline; 5 suits 10 Hz logs, 9 suits 100 Hz, see
    /// docs/experiments.md#smoothing-window).
    #[arg(long, value_name = "SAMPLES", conflicts_with = "base_freq")]
    smoothing_window: Option<usize>,
}

impl RouteArgs {
    pub(super) fn route(&self) -> Route {
        match (self.base_freq, self.smoothing_window) {
            (Some(f), _) => Route::Fourier {
                base_freq_hz: f,
                harmonics: self.harmonics,
            },
            (None, Some(window)) => Route::Smoothing { window, degree: 4 },
            (None, None) => LOG_ROUTE,
        }
    }
}

/// Known payloads of the logs (override what a dataset records).
#[derive(Debug, Args)]
pub struct PayloadArgs {
    /// Payload at the flange throughout: a built-in name (liu2018_tool, liu2018_load_1kg,
    /// liu2018_load_2kg, liu2018_load_4kg: the IRB 1200's of Liu et al. 2018) or a payload TOML
    /// file; repeat or join with '+' to combine (--payload liu2018_tool+liu2018_load_2kg).
    #[arg(long, value_name = "NAME|PATH")]
    payload: Vec<String>,
    /// Payload timeline TOML (`[[event]] t_s = .., payload = "tool+load_2kg"` or "none"),
    /// times on the log's clock.
    #[arg(long, value_name = "FILE", conflicts_with = "payload")]
    payload_events: Option<PathBuf>,
}

impl PayloadArgs {
    /// Warn on stderr for each built-in payload of `--payload` used on a robot that is not
    /// the IRB 1200 (a payload file gives no warning).
    pub(super) fn warn_foreign(&self, robot: &Robot) {
        for name in self.payload.iter().flat_map(|p| p.split('+')) {
            if !Path::new(name).exists() {
                crate::cli::warn_foreign_payload(name.trim(), robot);
            }
        }
    }

    /// The timeline the arguments give, or `None` to keep the log's own.
    pub(super) fn events(&self) -> Result<Option<Vec<PayloadEvent>>> {
        if let Some(path) = &self.payload_events {
            return Ok(Some(timeline_from_file(path)?));
        }
        if self.payload.is_empty() {
            return Ok(None);
        }
        let spec = self.payload.join("+");
        Ok(Some(vec![PayloadEvent {
            t_s: f64::NEG_INFINITY,
            payload: Some(resolve(&spec, Path::new("."))?),
        }]))
    }
}

/// Arguments of `identify`.
#[derive(Debug, Args)]
pub struct IdentifyArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Dataset directories (for paper-steps: one per step, joint 6 first).
    #[arg(long, value_name = "DIR", num_args = 1.., required_unless_present = "log_input", conflicts_with = "log_input")]
    data: Vec<PathBuf>,
    #[command(flatten)]
    logs: LogArgs,
    /// Identification method.
    #[arg(long, value_enum, default_value = "auto")]
    method: Method,
    #[command(flatten)]
    route: RouteArgs,
    #[command(flatten)]
    payloads: PayloadArgs,
    /// Samples at which an excited joint moves slower than this (rad/s) are not fitted on
    /// (around velocity reversals the Coulomb sign is uncertain and stiction holds the joint)
    /// [default: 0.05 for auto, total, pmsm and gear; 0 for the others].
    #[arg(long, value_name = "RAD_S")]
    min_speed: Option<f64>,
    /// Fastest rate at which a log's states are fitted on, Hz: a faster log is fitted on every
    /// k-th state (all still count in the cross-validation's energies); 0 fits every state
    /// (slower, for --method auto, total, pmsm and gear).
    #[arg(long, value_name = "HZ", default_value_t = powertwin::identification::tuning::MAX_FIT_RATE_HZ)]
    fit_rate: f64,
    /// Weighted least squares for --method auto, total, pmsm and gear: `none` (ordinary),
    /// `per-log` weighs each log by the inverse of its residual variance, `power-level` each
    /// sample by the inverse of a variance growing with the predicted active power (both
    /// iterated from the residuals) [default: power-level].
    #[arg(long, value_enum)]
    weighting: Option<WeightingArg>,
    /// Keep the least-squares estimate as it is. By default (--method auto, total, pmsm and gear)
    /// the model is made physically consistent inside identification: positive-definite
    /// pseudo-inertias, non-negative friction, rotor inertia and losses, nearest to the
    /// estimate in its covariance (the input URDF decides what the data cannot see).
    #[arg(long)]
    unconstrained: bool,
    /// Fit the arm's power alone for --method auto, total, pmsm and gear. By default, when every
    /// log has the power of each motor, each motor's power is fitted too (its own standby
    /// power per motor): each joint's parameters are then seen in its own motor, not only
    /// under the larger joints' power.
    #[arg(long)]
    arm_power_only: bool,
    /// Before fitting on everything, check the identification out of sample on your own
    /// logs: leave out every K-th run (with fewer than 4 runs, every K-th rest-to-rest move;
    /// with --base-freq always runs), identify on the rest with the same options and report
    /// each held-out piece's measured and predicted energy, error, 95 % interval and power
    /// RMSE, then the median and worst error and the interval coverage (stderr). 0 skips it;
    /// with too few pieces it is skipped with a note. For --method auto, total, pmsm and gear
    /// [default: 4, or 3 with three pieces: the last left out]
    #[arg(long, value_name = "K")]
    holdout: Option<usize>,
    /// Output model file (JSON: base parameters, losses, covariance, statistics).
    #[arg(long, value_name = "MODEL.json")]
    out: PathBuf,
    /// Also write the identified robot as URDF: physically consistent link inertials and
    /// friction (needs --method auto, total, pmsm or gear); what the data cannot reveal keeps the input
    /// URDF's values.
    #[arg(long, value_name = "OUT.urdf")]
    export_urdf: Option<PathBuf>,
    /// Also write the identified drives (rotor inertia, friction, copper loss, standby power).
    #[arg(long, value_name = "OUT.drive.toml")]
    export_drive: Option<PathBuf>,
    #[command(flatten)]
    prior: PriorArgs,
    /// Print the report (model path, estimator, cross-validation, determined directions,
    /// each parameter's source) as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// The prior of identification: what the URDF and the drive file already say.
#[derive(Debug, Args)]
pub struct PriorArgs {
    /// Drive file whose data-sheet friction, rotor inertia, copper-loss coefficients and gear
    /// friction centre the prior [default: the built-in drive for the built-in robot, else the
    /// URDF's <dynamics> friction and no copper-loss or gear-friction prior].
    #[arg(long, value_name = "PATH")]
    drive: Option<PathBuf>,
    /// A prior width (one standard deviation), repeatable: mass=0.3 (relative), com=0.02 (m),
    /// inertia=0.5 (relative to the mean principal moment), friction=0.5, rotor=0.5,
    /// copper=0.5 and gear=1 (relative to the drive file's value). The defaults are those.
    #[arg(long, value_name = "KEY=VALUE")]
    prior_width: Vec<String>,
    /// Identify from the data alone, without the prior: a log that leaves directions of the
    /// base-parameter space undetermined is then refused (--method auto, total, pmsm and gear; the
    /// paper's methods never use the prior).
    #[arg(long, conflicts_with_all = ["drive", "prior_width"])]
    no_prior: bool,
}

impl PriorArgs {
    /// The widths of `--prior-width` over the defaults.
    fn widths(&self) -> Result<PriorWidths> {
        let mut w = PriorWidths::default();
        for item in &self.prior_width {
            let (key, value) = item
                .split_once('=')
                .with_context(|| format!("--prior-width {item}: expected KEY=VALUE"))?;
            let v: f64 = value
                .trim()
                .parse()
                .with_context(|| format!("--prior-width {item}: '{value}' is not a number"))?;
            let slot = match key.trim() {
                "mass" => &mut w.mass_rel,
                "com" => &mut w.com_m,
                "inertia" => &mut w.inertia_rel,
                "friction" => &mut w.friction_rel,
                "rotor" => &mut w.rotor_rel,
                "copper" => &mut w.copper_rel,
                "gear" => &mut w.gear_rel,
                other => bail!(
                    "--prior-width {item}: unknown key '{other}' (mass, com, inertia, friction, rotor, copper, gear)"
                ),
            };
            *slot = v;
        }
        Ok(w)
    }

    /// The prior of `robot` from the URDF, the drive file and the widths (`None` with
    /// `--no-prior`).
    pub(super) fn prior(&self, robot: &Robot, robot_args: &RobotArgs) -> Result<Option<Prior>> {
        if self.no_prior {
            return Ok(None);
        }
        let drive = robot_args.drive(robot, self.drive.as_ref())?;
        Ok(Some(
            Prior::for_robot(robot, drive.as_ref(), &self.widths()?)
                .context("building the prior from the URDF and drive file")?,
        ))
    }
}

/// Read the datasets' logs for `robot`, with the payload timeline of `payloads` when given.
fn read_logs(data: &[PathBuf], robot: &Robot, payloads: &PayloadArgs) -> Result<Vec<Log>> {
    let events = payloads.events()?;
    data.iter()
        .map(|d| {
            let ds =
                Dataset::read(d).with_context(|| format!("reading dataset {}", d.display()))?;
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
            let mut log = ds.log(&d.display().to_string())?;
            if let Some(e) = &events {
                log.payloads = e.clone();
            }
            Ok(log)
        })
        .collect()
}

/// The logs of `--data` datasets, `--log` files or the runs of a `--runs` manifest, for
/// `robot`, with the payload timeline of `payloads` when given (a manifest gives each run's).
pub(super) fn gather(
    data: &[PathBuf],
    log_args: &LogArgs,
    robot: &Robot,
    payloads: &PayloadArgs,
) -> Result<Vec<Log>> {
    payloads.warn_foreign(robot);
    if data.is_empty() {
        let mut logs = load_logs(log_args)?;
        let events = payloads.events()?;
        if let Some(e) = &events {
            for log in &mut logs {
                log.payloads = e.clone();
            }
        }
        Ok(logs)
    } else {
        read_logs(data, robot, payloads)
    }
}

/// Run `identify`.
pub fn run_identify(args: &IdentifyArgs) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let logs = gather(&args.data, &args.logs, &robot, &args.payloads)?;
    // One error for every method, before the held-out check (the fitted methods' library
    // pipeline checks again, for its other callers).
    for log in &logs {
        log.check_robot(&robot)?;
    }
    let fitted = matches!(
        args.method,
        Method::Auto | Method::Total | Method::Pmsm | Method::Gear
    );
    let min_speed = args
        .min_speed
        .unwrap_or(if fitted { MIN_SPEED } else { 0.0 });
    check_method(args, &logs, fitted, min_speed)?;
    let route = args.route.route();
    let prior = if fitted {
        args.prior.prior(&robot, &args.robot)?
    } else {
        None
    };
    let held_out = report_holdout(args, &robot, &logs, (route, min_speed), fitted, &prior);
    let identified = if fitted {
        identify_fitted(args, &robot, &logs, route, min_speed, prior)?
    } else {
        identify_paper(args.method, &robot, &logs, route, min_speed)?
    };
    write_and_report(args, &robot, &identified, held_out.as_ref())?;
    Ok(ExitCode::SUCCESS)
}

/// The held-out check of `--holdout` (along `route`, at `min_speed` rad/s, with `prior`),
/// printed to stderr, or why it was skipped (then `None`): it never stops the identification
/// on everything.
fn report_holdout(
    args: &IdentifyArgs,
    robot: &Robot,
    logs: &[Log],
    (route, min_speed): (Route, f64),
    fitted: bool,
    prior: &Option<Prior>,
) -> Option<Holdout> {
    if args.holdout == Some(0) {
        return None;
    }
    if !fitted {
        if args.holdout.is_some() {
            eprintln!("holdout skipped: --holdout applies to --method auto, total, pmsm and gear");
        }
        return None;
    }
    let moves = MoveOptions::default();
    let every = args
        .holdout
        .unwrap_or_else(|| default_every(logs, route, &moves));
    let opts = fit_options(args, min_speed, prior.clone());
    match holdout(robot, logs, every, route, &opts, &moves) {
        Ok(h) => {
            eprintln!("{h}");
            Some(h)
        }
        Err(e) => {
            eprintln!("holdout skipped: {e}");
            None
        }
    }
}

/// Refuse options that do not apply to the method.
fn check_method(args: &IdentifyArgs, logs: &[Log], fitted: bool, min_speed: f64) -> Result<()> {
    if args.holdout == Some(1) {
        bail!("--holdout 1 would hold out every run: give 0 (no holdout) or at least 2");
    }
    if min_speed > 0.0 && args.method == Method::Energy {
        bail!(
            "--min-speed does not apply to the energy method (its windows join consecutive samples)"
        );
    }
    let prior_args = args.prior.drive.is_some() || !args.prior.prior_width.is_empty();
    if !fitted
        && (args.unconstrained
            || args.arm_power_only
            || args.weighting.is_some()
            || prior_args
            || args.prior.no_prior)
    {
        bail!(
            "--weighting, --unconstrained, --arm-power-only and the prior's options apply to --method auto, total, pmsm and gear, not {:?}",
            args.method
        );
    }
    if !fitted
        && logs
            .iter()
            .any(|l| l.payloads.iter().any(|e| e.payload.is_some()))
    {
        bail!(
            "method {:?} does not take known payloads; use --method auto, total, pmsm or gear for data recorded with a payload",
            args.method
        );
    }
    Ok(())
}

/// An identified model with its estimates and, for the fitted methods, the
/// cross-validation scores.
struct Identified {
    model: PowerModel,
    /// The parameter estimates, the last being the model's.
    estimates: Vec<Estimate>,
    /// Cross-validation score per candidate estimator (empty for the paper's methods).
    cross_validation: Vec<CvScore>,
    /// The estimator cross-validation chose (`None` for the paper's methods).
    estimator: Option<Estimator>,
    /// What the data determined against the prior (`None` without one).
    determination: Option<Determination>,
}

/// The options of `--method auto`, `total` or `pmsm`, with `prior`.
fn fit_options(args: &IdentifyArgs, min_speed: f64, prior: Option<Prior>) -> FitOptions {
    let candidates = args.method.candidates().unwrap_or_else(Estimator::auto);
    FitOptions {
        min_speed,
        candidates,
        weighting: args
            .weighting
            .map_or(FitOptions::default().weighting, Into::into),
        consistent: !args.unconstrained,
        motor_power: !args.arm_power_only,
        max_fit_rate_hz: args.fit_rate,
        prior,
        ..FitOptions::default()
    }
}

/// `--method auto`, `total` or `pmsm`: the fitted estimators, chosen by cross-validation.
fn identify_fitted(
    args: &IdentifyArgs,
    robot: &Robot,
    logs: &[Log],
    route: Route,
    min_speed: f64,
    prior: Option<Prior>,
) -> Result<Identified> {
    let sel = identify_logs(
        robot,
        logs,
        &[route],
        &fit_options(args, min_speed, prior.clone()),
    )?;
    eprintln!(
        "fitted on {}",
        match (sel.motor_power, args.arm_power_only) {
            (true, _) => "the arm's power and each motor's",
            (false, true) => "the arm's power (--arm-power-only)",
            (false, false) => "the arm's power (the logs do not all have each motor's)",
        }
    );
    for c in &sel.scores {
        eprintln!(
            "cross-validation {}: mean-power error {:.3} W, power RMSE {:.3} W over {} held-out pieces",
            c.estimator.name(),
            c.mean_power_rms_w,
            c.power_rmse_w,
            c.pieces
        );
    }
    if sel.fit.model.power_lag_s != 0.0 {
        eprintln!(
            "power lag behind the joints found by the fit: {:+.1} ms (the states the power belongs to)",
            1e3 * sel.fit.model.power_lag_s
        );
    }
    if let Some(c) = &sel.consistent {
        eprintln!(
            "consistent: the model moved {:.3} (Mahalanobis) from the estimate, at most {:.3} standard deviations per value",
            c.mahalanobis, c.max_change_sigma
        );
    }
    let determination = prior.map(|p| p.determination(&sel.fit.model)).transpose()?;
    Ok(Identified {
        model: sel.fit.model.clone(),
        estimates: vec![sel.fit.free_estimate()],
        cross_validation: sel.scores,
        estimator: Some(sel.chosen),
        determination,
    })
}

/// `--method paper-steps`, `per-joint` or `energy`: the paper's linear estimators on the
/// prepared logs.
fn identify_paper(
    method: Method,
    robot: &Robot,
    logs: &[Log],
    route: Route,
    min_speed: f64,
) -> Result<Identified> {
    let layout = ParamLayout::new(robot, true, true);
    let prepared = prepare_logs(logs, route, min_speed)?;
    ensure_motion(&prepared)?;
    let mut model = PowerModel::new(robot, layout, true)?;
    let estimates = match method {
        Method::PerJoint => vec![identify_per_joint(robot, &mut model, &prepared)?],
        Method::Energy => vec![identify_energy(robot, &mut model, &prepared)?],
        _ => identify_steps(robot, &mut model, prepared)?,
    };
    model.signal = logs[0].signal;
    Ok(Identified {
        model,
        estimates,
        cross_validation: Vec::new(),
        estimator: None,
        determination: None,
    })
}

/// Prepare each log along `route`; with `min_speed` (rad/s) above 0, drop the samples at
/// which an excited joint moves slower, and say how many.
fn prepare_logs(logs: &[Log], route: Route, min_speed: f64) -> Result<Vec<Prepared>> {
    logs.iter()
        .map(|l| {
            let mut p = prepare(l, route).with_context(|| format!("preparing {}", l.source))?;
            if min_speed > 0.0 {
                let dropped = p.drop_slow_samples(min_speed)?;
                eprintln!(
                    "{}: {dropped} samples with an excited joint below {min_speed} rad/s dropped",
                    l.source
                );
            }
            Ok(p)
        })
        .collect()
}

/// `--method per-joint`: all base parameters at once from the power of each motor (eq. 13),
/// the logs' states stacked in order.
fn identify_per_joint(
    robot: &Robot,
    model: &mut PowerModel,
    prepared: &[Prepared],
) -> Result<Estimate> {
    let mut states = prepared[0].states.clone();
    for p in &prepared[1..] {
        states.append(&p.states)?;
    }
    let y: Vec<f64> = prepared.iter().flat_map(|p| p.p_joint.clone()).collect();
    if y.len() != states.len() * robot.dof() {
        bail!("per-joint identification needs the power of every motor in every log");
    }
    Ok(linear::identify(
        robot,
        model,
        &states,
        Observation::JointPower,
        &y,
    )?)
}

/// `--method energy`: the base parameters from the energy of the windows between samples of
/// each log's total power, J.
fn identify_energy(
    robot: &Robot,
    model: &mut PowerModel,
    prepared: &[Prepared],
) -> Result<Estimate> {
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
    Ok(energy::identify(robot, model, &windows)?)
}

/// `--method paper-steps`: step by step from total power, one log per step in step order,
/// the joints each step does not excite held still; one estimate per step.
fn identify_steps(
    robot: &Robot,
    model: &mut PowerModel,
    prepared: Vec<Prepared>,
) -> Result<Vec<Estimate>> {
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
    Ok(steps::identify(robot, model, &data)?
        .into_iter()
        .map(|r| r.estimate)
        .collect())
}

/// Check the model's physical consistency, export it if asked, write `--out` and print the
/// summary.
fn write_and_report(
    args: &IdentifyArgs,
    robot: &Robot,
    identified: &Identified,
    held_out: Option<&Holdout>,
) -> Result<()> {
    let consistency = write_model(args, robot, identified)?;
    report_summary(args, identified, &consistency);
    if args.json {
        print_json_report(args, identified, &consistency, held_out)?;
    }
    Ok(())
}

/// Check the model's physical consistency (mass matrix at random poses), export the
/// identified URDF and drive file if asked, and write `--out` with the estimates,
/// cross-validation, consistency and determination.
fn write_model(args: &IdentifyArgs, robot: &Robot, identified: &Identified) -> Result<Consistency> {
    let Identified {
        model,
        estimates,
        cross_validation: cv,
        determination,
        ..
    } = identified;
    // Positive definiteness does not depend on the 1/eta scale: check in model units.
    let consistency = consistency(robot, model, 1.0, 200, 1)?;
    super::export::export(
        robot,
        model,
        estimates.last(),
        args.export_urdf.as_deref(),
        args.export_drive.as_deref(),
    )?;
    let out = json!({
        "method": format!("{:?}", args.method).to_lowercase(),
        "model": model,
        "estimates": estimates,
        "cross_validation": cv,
        "consistency": consistency,
        "determination": determination,
    });
    write_atomic(&args.out, serde_json::to_string_pretty(&out)?.as_bytes())
        .with_context(|| format!("writing {}", args.out.display()))?;
    Ok(consistency)
}

/// Print the summary on stderr: the fit, physical consistency (the mass matrix's smallest
/// eigenvalue, kg m^2, over eta for an efficiency-scaled model), determined directions, the
/// lowest power and heaviest payload the logs show, and the friction.
fn report_summary(args: &IdentifyArgs, identified: &Identified, consistency: &Consistency) {
    let Identified {
        model,
        estimates,
        estimator,
        determination,
        ..
    } = identified;
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
    if let Some(d) = determination {
        report_determination(d);
    }
    if let Some(low) = model.lowest_seen {
        report_lowest_seen(
            low,
            model.bus_floor,
            estimates.last().map_or(0.0, |e| e.residual_rms),
        );
    }
    if let Some(kg) = model.payload_seen {
        eprintln!(
            "heaviest payload the logs carried: {kg:.2} kg; losses that grow with the torque of \
             a heavier one are undetermined: predictions' intervals hold {} % of the energy its \
             excess moves through the joints (to determine them: runs carrying it)",
            100.0 * powertwin::identification::tuning::UNSEEN_LOAD_LOSS
        );
    }
    report_friction(model, estimator.is_some());
}

/// `--json`: print the report (model path, estimator, cross-validation, determined
/// directions, what the logs show, the held-out check) on stdout.
fn print_json_report(
    args: &IdentifyArgs,
    identified: &Identified,
    consistency: &Consistency,
    held_out: Option<&Holdout>,
) -> Result<()> {
    let Identified {
        model,
        estimates,
        cross_validation: cv,
        estimator,
        determination,
    } = identified;
    let report = json!({
        "model_path": args.out,
        "method": format!("{:?}", args.method).to_lowercase(),
        "estimator": estimator,
        "cross_validation": cv,
        "condition_number": estimates.last().map(|e| e.cond),
        "physically_consistent": consistency.consistent,
        "determination": determination,
        "lowest_seen_W": model.lowest_seen,
        "bus_floor_W": model.bus_floor,
        "payload_seen_kg": model.payload_seen,
        "min_speed_rad_s": model.min_speed,
        "holdout": held_out,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
