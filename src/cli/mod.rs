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
mod dynamics;
mod model;
mod reproduce;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use powertwin::Robot;
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::urdf::{LoadOptions, load_file, load_str};

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
    /// Run the paper's experiments end to end (excitation, identification, tool/load cases,
    /// speed/load sweep) and write a report.
    Reproduce(reproduce::ReproduceArgs),
    /// Show the robot model: joints, limits, masses, MDH table, standard and base parameters.
    Model(model::ModelArgs),
    /// Inverse dynamics of a table of states: joint torques from q, dq, ddq.
    Dynamics(dynamics::DynamicsArgs),
    /// Base (minimal) parameters: count, independent set, regrouping relations and values.
    BaseParams(base_params::BaseParamsArgs),
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

/// Run a parsed command line.
pub fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Reproduce(a) => reproduce::run(&a),
        Command::Model(a) => model::run(&a),
        Command::Dynamics(a) => dynamics::run(&a),
        Command::BaseParams(a) => base_params::run(&a),
    }
}
