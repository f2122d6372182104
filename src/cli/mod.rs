//! Command definitions and dispatch.

/// `outln!(buf, fmt, args..)`: append a formatted line to a `String` buffer.
macro_rules! outln {
    ($o:expr) => {
        $o.push('\n')
    };
    ($o:expr, $($arg:tt)*) => {{
        $o.push_str(&format!($($arg)*));
        $o.push('\n');
    }};
}

/// `out!(buf, fmt, args..)`: append formatted text to a `String` buffer.
macro_rules! out {
    ($o:expr, $($arg:tt)*) => {
        $o.push_str(&format!($($arg)*))
    };
}

mod base_params;
mod dataset;
mod dynamics;
mod excite;
mod export;
mod identify;
mod log;
mod model;
mod optimize;
mod predict;
mod progress;
mod reproduce;
mod simulate;
mod sweep;
mod truth;
mod validate;
#[cfg(feature = "viz")]
mod viz;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use powertwin::Robot;
use powertwin::dataset::meta::Urdf;
use powertwin::dataset::{Dataset, Format};
use powertwin::identification::model::{PowerModel, check_schema_version};
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::payload::Payload;
use powertwin::model::urdf::{LoadOptions, load_file, load_str};
use powertwin::twin::TwinConfig;
use powertwin::twin::family::Plant;
use powertwin::twin::motor::MotorModel;
use powertwin::twin::physics::PhysicsSettings;
use powertwin::twin::sensor::{NoiseSettings, SensorSettings};
use powertwin::validation::sweep::Cell;
use rayon::prelude::*;
pub use truth::TruthArgs;

/// Energy digital twin of an industrial robot: identify dynamic and drive parameters from
/// motor power and predict the energy of a task (Liu et al. 2018).
///
/// Without --robot every command uses the built-in ABB IRB 1200-7/0.7 model.
/// Units are SI: m, rad, kg, s, N m, W, J.
#[derive(Debug, Parser)]
#[command(name = "powertwin", version, about, long_about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the held-out benchmark and the paper's experiments end to end (identification set,
    /// held-out motions, excitation, tool/load cases, speed/load sweep) and write a report.
    ///
    /// Runs, on the built-in ABB IRB 1200-7/0.7 twin: the identification a user would run
    /// (eight excitations designed together, three 10 s stretches each, known loads of 0-7 kg,
    /// the estimator chosen by cross-validation; written to model.json) and the held-out
    /// benchmark that leads the report (30 motions no identification saw, predicted from their
    /// 10 Hz logs and from their plans, with 95 % intervals, against a baseline without
    /// identification); six optimised excitations and the paper's step-by-step identification
    /// from total power (Table 3); the paper's method against all-at-once and PMSM estimators
    /// on the same data, with identified against true base parameters (Table 2); the tool and
    /// load cases (Table 4); and the pick-and-place task over speeds and loads (Figure 14).
    /// Writes report.md, results.json, model.json, charts (SVG and PNG), every twin dataset and
    /// (with the `viz` feature) the Rerun recording powertwin.rrd under --out.
    Reproduce(reproduce::ReproduceArgs),
    /// Show the robot model: joints, limits, masses, MDH table, standard and base parameters.
    Model(model::ModelArgs),
    /// Inverse dynamics of a table of states: joint torques from q, dq, ddq.
    Dynamics(dynamics::DynamicsArgs),
    /// Base (minimal) parameters: count, independent set, regrouping relations and values.
    BaseParams(base_params::BaseParamsArgs),
    /// Design an optimised Fourier excitation trajectory for identification, or (--set N) a
    /// whole identification set for any arm in its cell, with its runs manifest.
    Excite(excite::ExciteArgs),
    /// Identify base parameters (and motor losses) from the power in datasets.
    Identify(identify::IdentifyArgs),
    /// Predict the energy of a logged motion, or of a planned trajectory or scenario task, with
    /// an identified model (95 % interval).
    Predict(predict::PredictArgs),
    /// Judge an identified model on held-out motions run on the twin (out of sample).
    Validate(validate::ValidateArgs),
    /// Run the Rapier twin along a trajectory and write a ground-truth dataset.
    Simulate(simulate::SimulateArgs),
    /// Run a task scenario (default: the paper's pick and place) over speeds and loads on the
    /// twin, with the energy an identified model predicts.
    Sweep(sweep::SweepArgs),
    /// Generate many randomised ground-truth datasets in parallel (shardable).
    Dataset(dataset::DatasetArgs),
    /// The cheapest timing (per-segment speed and acceleration, waits with servos or brakes)
    /// and placement of a task in the same cycle time, predicted by a model and checked on the
    /// twin.
    Optimize(optimize::OptimizeArgs),
}

/// Which robot to load.
#[derive(Debug, Args)]
pub struct RobotArgs {
    /// URDF of a fixed-base serial robot with revolute joints [default: built-in IRB 1200-7/0.7].
    #[arg(long, value_name = "PATH")]
    robot: Option<PathBuf>,
    /// Joints to freeze at position 0, e.g. gripper fingers (comma-separated names).
    #[arg(long, value_name = "NAME,...", value_delimiter = ',')]
    lock: Vec<String>,
}

impl RobotArgs {
    /// Load the chosen robot.
    pub fn load(&self) -> Result<Robot> {
        let opts = LoadOptions {
            lock: self.lock.clone(),
        };
        match &self.robot {
            Some(p) => {
                load_file(p, &opts).with_context(|| format!("loading robot {}", p.display()))
            }
            None => load_str(builtin::IRB1200_URDF, &opts)
                .context("loading the built-in IRB 1200 model"),
        }
    }

    /// Load a drive file, or the built-in IRB 1200 drive when the built-in robot is used and
    /// no file is given; `None` for another robot without a drive file.
    pub fn drive(&self, robot: &Robot, path: Option<&PathBuf>) -> Result<Option<Drive>> {
        match (path, &self.robot) {
            (Some(p), _) => {
                Ok(Some(Drive::from_file(p, robot).with_context(|| {
                    format!("loading drive {}", p.display())
                })?))
            }
            (None, None) => Ok(Some(Drive::from_toml_str(
                builtin::IRB1200_DRIVE,
                "built-in irb1200_7_70.drive.toml",
                robot,
            )?)),
            (None, Some(_)) => Ok(None),
        }
    }
}

/// Robot, drives, payload, physics, controller, motor model, logger and output format of a
/// twin run.
#[derive(Debug, Args)]
pub struct TwinArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Drive file (rotor inertia, friction, efficiency, losses) [default: the built-in IRB 1200
    /// drive for the built-in robot, else the URDF friction with ideal motors].
    #[arg(long, value_name = "PATH")]
    drive: Option<PathBuf>,
    /// Payload attached to the flange throughout: a built-in name (liu2018_tool,
    /// liu2018_load_1kg, liu2018_load_2kg, liu2018_load_4kg: the IRB 1200's, Liu et al. 2018;
    /// the old names tool, load_1kg, ... are accepted) or a payload TOML file; repeat or join
    /// with '+' to combine (e.g. --payload liu2018_tool+liu2018_load_2kg).
    #[arg(long, value_name = "NAME|PATH")]
    payload: Vec<String>,
    /// Physics step (torque held over it), s.
    #[arg(long, default_value_t = 0.001)]
    dt: f64,
    /// Rapier substeps per physics step.
    #[arg(long, default_value_t = 1)]
    substeps: usize,
    /// Motor model: pmsm (P_mech + c tau^2 + P0) or efficiency (P_mech / eta, the paper's eq. 9).
    #[arg(long, default_value = "pmsm")]
    motor: MotorModel,
    #[command(flatten)]
    truth: TruthArgs,
    /// Sample rate of the measured stream, Hz (a whole number of physics steps per sample).
    #[arg(long, default_value_t = 10.0)]
    sample_rate: f64,
    /// Sensor noise: a noise TOML file, or `none` [default: encoder 6e-6 rad steps + 1e-5 rad
    /// noise, 0.5 W per motor, 1 W on the total power].
    #[arg(long, value_name = "PATH|none")]
    noise: Option<String>,
    /// Average power over each sample period instead of sampling it.
    #[arg(long)]
    power_averaging: bool,
    /// Seed of the sensor noise and the nominal-model error (`dataset` draws one per item).
    #[arg(long, default_value_t = 0)]
    noise_seed: u64,
    /// Table format of the dataset.
    #[arg(long, default_value = "parquet")]
    format: Format,
}

/// A loaded twin setup.
pub struct Setup {
    /// The robot.
    pub robot: Robot,
    /// Where it came from.
    pub urdf: Urdf,
    /// True drives.
    pub drive: Drive,
    /// Payload attached throughout.
    pub payload: Option<Payload>,
    /// Twin settings.
    pub twin: TwinConfig,
    /// Logger settings.
    pub sensor: SensorSettings,
    /// The robot of the family the twin simulates instead of the files (`--truth
    /// family:SEED`).
    pub plant: Option<Plant>,
}

impl Setup {
    /// The experiment rig of this setup.
    pub fn rig(&self) -> powertwin::validation::rig::Rig<'_> {
        powertwin::validation::rig::Rig {
            robot: &self.robot,
            urdf: self.urdf.clone(),
            drive: &self.drive,
            twin: self.twin.clone(),
            sensor: self.sensor,
            plant: self.plant.as_ref(),
        }
    }
}

impl TwinArgs {
    /// The truth options.
    pub fn truth_args(&self) -> &TruthArgs {
        &self.truth
    }

    /// Table format of the datasets.
    pub fn format(&self) -> Format {
        self.format
    }

    /// Load and validate everything.
    pub fn setup(&self) -> Result<Setup> {
        let robot = self.robot.load()?;
        let urdf = match &self.robot.robot {
            None => Urdf::inline(builtin::IRB1200_URDF),
            Some(p) => {
                let text = std::fs::read_to_string(p)
                    .with_context(|| format!("reading {}", p.display()))?;
                Urdf::file(&p.display().to_string(), &text)
            }
        };
        let drive = match self.robot.drive(&robot, self.drive.as_ref())? {
            Some(d) => d,
            None => Drive::from_urdf(&robot),
        };
        let mut payload: Option<Payload> = None;
        for p in &self.payload {
            for part in p.split('+').map(str::trim) {
                if !std::path::Path::new(part).exists() {
                    warn_foreign_payload(part, &robot);
                }
            }
            let one = powertwin::model::payload::resolve(p, std::path::Path::new("."))?;
            payload = Some(match payload {
                Some(acc) => acc.combined(&one),
                None => one,
            });
        }
        let noise = noise_settings(self.noise.as_deref())?;
        let twin = TwinConfig {
            physics: PhysicsSettings {
                dt: self.dt,
                substeps: self.substeps,
            },
            motor: self.motor,
            nominal_error: self.truth.nominal_error(),
            nominal_seed: self.noise_seed,
            fidelity: self.truth.fidelity(),
            ..TwinConfig::default()
        };
        twin.physics.validate()?;
        let sensor = SensorSettings {
            rate_hz: self.sample_rate,
            power_averaging: self.power_averaging,
            power_signal: self.truth.power_signal(),
            noise,
            seed: self.noise_seed,
            ..SensorSettings::default()
        };
        let plant = self.truth.plant(&robot, &drive, &twin, &sensor)?;
        Ok(Setup {
            robot,
            urdf,
            drive,
            payload,
            twin,
            sensor,
            plant,
        })
    }
}

/// Print a warning to stderr when the built-in payload `name` (the IRB 1200's) is used on
/// another robot; nothing for the IRB 1200 or a payload file.
pub fn warn_foreign_payload(name: &str, robot: &Robot) {
    if let Some(warning) = builtin::foreign_payload_warning(name, robot.name()) {
        eprintln!("warning: {warning}");
    }
}

/// Write command output to stdout. A closed pipe (e.g. `powertwin model | head`) is not an
/// error: the reader has all it wanted.
pub fn emit(text: &str) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e).context("writing to stdout"),
        _ => Ok(()),
    }
}

/// Read a model file written by `identify` (or a bare model) for `robot`: its
/// `schema_version` is checked first (see docs/design/model-schema.md).
pub fn read_model(path: &Path, robot: &Robot) -> Result<PowerModel> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not valid JSON", path.display()))?;
    let v = v.get("model").cloned().unwrap_or(v);
    check_schema_version(&v).with_context(|| format!("reading {}", path.display()))?;
    let model: PowerModel = serde_json::from_value(v)
        .with_context(|| format!("{}: not a powertwin model", path.display()))?;
    model
        .validate(robot)
        .with_context(|| format!("checking {}", path.display()))?;
    Ok(model)
}

/// The sensor noise of a `--noise` argument: `None` for the defaults, `none`, or a noise TOML
/// file.
pub fn noise_settings(arg: Option<&str>) -> Result<NoiseSettings> {
    Ok(match arg {
        None => NoiseSettings::default(),
        Some("none") => NoiseSettings::NONE,
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("reading {path}"))?;
            NoiseSettings::from_toml_str(&text, path)?
        }
    })
}

/// Write datasets `(name, dataset)` under `dir` in parallel (each atomically).
pub fn write_all(items: &[(String, &Dataset)], dir: &Path, format: Format) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    items
        .par_iter()
        .map(|(name, ds)| {
            let path = dir.join(name);
            ds.write(&path, format)
                .with_context(|| format!("writing {}", path.display()))
        })
        .collect()
}

/// Directory name of a sweep cell's dataset.
pub fn sweep_name(cell: &Cell) -> String {
    format!("sweep_{}mps_{}kg", cell.speed_m_s, cell.load_kg)
}

/// `--allow-overload`: what `simulate`, `sweep`, `optimize` and `reproduce` do with a payload
/// above the robot's rating and with twin runs the drives cannot follow.
#[derive(Debug, Args)]
pub struct OverloadArgs {
    /// Run payloads above the robot's rated payload (rated_payload_kg in the drive file); for
    /// sweep, optimize and reproduce also exit 0 although twin runs (sweep cells, plans)
    /// saturate a torque or track worse than 0.05 rad: they are still flagged in every
    /// output, and without this option those commands exit 3 after writing them.
    #[arg(long)]
    allow_overload: bool,
}

impl OverloadArgs {
    /// Refuse a payload of `mass_kg` (kg, tool and load) above `drive`'s rated payload unless
    /// overloads are allowed; `what` names the payload.
    pub fn check_payload(&self, mass_kg: f64, drive: &Drive, what: &str) -> Result<()> {
        if self.allow_overload {
            return Ok(());
        }
        powertwin::model::payload::check_rated(mass_kg, drive.rated_payload_kg(), what)
            .map_err(|e| anyhow::anyhow!("{e}; pass --allow-overload to run it anyway"))
    }

    /// Whether flagged twin runs and overloads are accepted.
    pub fn allowed(&self) -> bool {
        self.allow_overload
    }

    /// The exit status of a command that ran the sweep's `cells` and wrote its outputs:
    /// [`Exit::Flagged`] (with the flagged cells listed on stderr) when a cell is flagged and
    /// overloads are not allowed, else [`Exit::Ok`].
    pub fn exit_for(&self, cells: &[Cell]) -> Exit {
        match self.flagged_cells(cells) {
            Some(message) => {
                eprintln!("flagged: {message}");
                Exit::Flagged
            }
            None => Exit::Ok,
        }
    }

    /// The message listing the sweep's flagged cells (torque saturated, tracking lost), each
    /// with its reason; `None` when no cell is flagged or overloads are allowed.
    pub fn flagged_cells(&self, cells: &[Cell]) -> Option<String> {
        let flagged: Vec<String> = cells
            .iter()
            .filter_map(|c| {
                c.flag_reason()
                    .map(|why| format!("{} m/s, {} kg: {why}", c.speed_m_s, c.load_kg))
            })
            .collect();
        if flagged.is_empty() || self.allow_overload {
            return None;
        }
        Some(format!(
            "{} of {} sweep cells are flagged: the twin did not perform the task as planned, so \
             their energies are not the task's ({}); pass --allow-overload to accept them",
            flagged.len(),
            cells.len(),
            flagged.join("; ")
        ))
    }
}

/// The exit status of `powertwin` (documented in docs/guide/cli.md, "Exit codes").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Exit {
    /// 0: the command succeeded.
    Ok,
    /// 1: the command failed (bad input, unreadable file, unsupported robot, numerical
    /// failure); the message is on stderr.
    Error,
    /// 2: the command line is wrong (unknown command or option, missing or malformed
    /// argument); clap prints the usage on stderr.
    Usage,
    /// 3: the command ran and wrote its outputs, but some results are flagged and should not
    /// be trusted as they are (e.g. a `sweep` cell whose torque saturated); the reasons are
    /// on stderr.
    Flagged,
}

impl Exit {
    /// The numeric status.
    pub const fn code(self) -> u8 {
        match self {
            Exit::Ok => 0,
            Exit::Error => 1,
            Exit::Usage => 2,
            Exit::Flagged => 3,
        }
    }
}

impl From<Exit> for ExitCode {
    fn from(exit: Exit) -> Self {
        ExitCode::from(exit.code())
    }
}

/// Run a parsed command line.
pub fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Reproduce(a) => reproduce::run(&a),
        Command::Model(a) => model::run(&a),
        Command::Dynamics(a) => dynamics::run(&a),
        Command::BaseParams(a) => base_params::run(&a),
        Command::Excite(a) => excite::run(&a),
        Command::Identify(a) => identify::run_identify(&a),
        Command::Predict(a) => predict::run_predict(&a),
        Command::Validate(a) => validate::run(&a),
        Command::Simulate(a) => simulate::run(&a),
        Command::Sweep(a) => sweep::run(&a),
        Command::Dataset(a) => dataset::run(&a),
        Command::Optimize(a) => optimize::run(&a),
    }
}
