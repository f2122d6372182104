//! `powertwin dynamics`: inverse dynamics of a CSV table of states.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use powertwin::dynamics::rnea::rnea;
use powertwin::dynamics::{DriveTerms, Workspace};
use powertwin::io::table::{Table, to_csv};
use powertwin::io::write_atomic;

use super::RobotArgs;

/// Arguments of `dynamics`.
#[derive(Debug, Args)]
pub struct DynamicsArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// CSV with columns q1..qn (rad), dq1..dqn (rad/s), ddq1..ddqn (rad/s^2); the names may
    /// carry units (q1_rad, dq1_rad_s, ddq1_rad_s2); other columns are ignored.
    #[arg(long, value_name = "STATES.csv")]
    input: PathBuf,
    /// Output CSV with columns tau1_Nm..taun_Nm (written atomically).
    #[arg(long, value_name = "TORQUES.csv")]
    output: PathBuf,
    /// Add rotor inertia and Coulomb/viscous friction from this drive file (default: rigid
    /// body only).
    #[arg(long, value_name = "PATH")]
    drive: Option<PathBuf>,
}

/// Run `dynamics`.
pub fn run(args: &DynamicsArgs) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let n = robot.dof();
    let terms = match &args.drive {
        Some(p) => args
            .robot
            .drive(&robot, Some(p))?
            .map(|d| DriveTerms::from(&d)),
        None => None,
    };
    let table = Table::read(&args.input)?;
    let q = table.joint_columns("q", "rad", n)?;
    let dq = table.joint_columns("dq", "rad_s", n)?;
    let ddq = table.joint_columns("ddq", "rad_s2", n)?;
    let rows = table.rows();
    let mut ws = Workspace::new(&robot);
    let mut out = vec![Vec::with_capacity(rows); n];
    let (mut qs, mut dqs, mut ddqs, mut tau) =
        (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for r in 0..rows {
        for i in 0..n {
            qs[i] = q[i][r];
            dqs[i] = dq[i][r];
            ddqs[i] = ddq[i][r];
        }
        rnea(&robot, &mut ws, &qs, &dqs, &ddqs, terms.as_ref(), &mut tau);
        for i in 0..n {
            out[i].push(tau[i]);
        }
    }
    let headers: Vec<String> = (1..=n).map(|i| format!("tau{i}_Nm")).collect();
    write_atomic(&args.output, to_csv(&headers, &out).as_bytes())
        .with_context(|| format!("writing {}", args.output.display()))?;
    eprintln!("{rows} rows -> {}", args.output.display());
    Ok(ExitCode::SUCCESS)
}
