//! `powertwin excite`: optimised Fourier excitation for identification (paper eqs. 7-8).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::Args;
use powertwin::identification::excitation::{ExcitationOptions, design, rest_pose, standby_pose};
use powertwin::io::table::to_csv;
use powertwin::io::write_atomic;
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::limits::default_accel_limits;
use serde_json::json;

use super::RobotArgs;

/// Arguments of `excite`.
#[derive(Debug, Args)]
pub struct ExciteArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Joints to excite, 1-based: a range like 4-6 or a list like 1,3,5 (others hold the rest
    /// pose) [default: all].
    #[arg(long)]
    joints: Option<String>,
    /// Base frequency, Hz.
    #[arg(long, default_value_t = 0.1)]
    base_freq: f64,
    /// Harmonics per joint.
    #[arg(long, default_value_t = 5)]
    harmonics: usize,
    /// Whole periods of the trajectory.
    #[arg(long, default_value_t = 1)]
    periods: usize,
    /// Rest pose (rad, comma-separated): offsets start there and joints that are not
    /// excited hold it [default: 0,0.2,0.2,0,0.8,0 for the IRB 1200, else derived from the
    /// URDF: zeros clamped into the limits, or the nearest pose that keeps the flange and
    /// wrist above the floor and away from the base].
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    rest_pose: Vec<f64>,
    /// Acceleration limits, rad/s^2, comma-separated [default: the IRB 1200 estimates
    /// 15,15,20,30,30,40 for the IRB 1200, else each URDF velocity limit / 0.3 s].
    #[arg(long, value_delimiter = ',')]
    accel_limits: Vec<f64>,
    /// Independent optimiser starts.
    #[arg(long, default_value_t = 2)]
    starts: usize,
    /// Objective evaluations per start.
    #[arg(long, default_value_t = 3000)]
    evals: usize,
    /// Seed of the optimiser.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output trajectory CSV (t_s, q_rad, dq_rad_s, ddq_rad_s2 at 100 Hz) for `simulate`.
    #[arg(long, value_name = "TRAJ.csv")]
    out: PathBuf,
    /// Print the report (condition numbers, parameters, Fourier coefficients) as JSON.
    #[arg(long)]
    json: bool,
}

/// Parse `4-6` or `1,3,5` into 0-based joint indices.
fn parse_joints(s: &str, dof: usize) -> Result<Vec<usize>> {
    let one = |t: &str| -> Result<usize> {
        let j: usize = t
            .trim()
            .parse()
            .with_context(|| format!("joint '{t}' is not a number"))?;
        if j == 0 || j > dof {
            bail!("joint {j} is not in 1..={dof}");
        }
        Ok(j - 1)
    };
    let joints: Vec<usize> = if let Some((a, b)) = s.split_once('-') {
        let (a, b) = (one(a)?, one(b)?);
        if a > b {
            bail!("joint range '{s}' is empty");
        }
        (a..=b).collect()
    } else {
        s.split(',').map(one).collect::<Result<_>>()?
    };
    Ok(joints)
}

/// Run `excite`.
pub fn run(args: &ExciteArgs) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let n = robot.dof();
    let joints = match &args.joints {
        Some(s) => parse_joints(s, n)?,
        None => (0..n).collect(),
    };
    let accel = if args.accel_limits.is_empty() {
        default_accel_limits(&robot)
    } else {
        args.accel_limits.clone()
    };
    let mut opts = ExcitationOptions::new(&robot, joints.clone(), vec![0.0; n], accel);
    opts.rest_pose = if !args.rest_pose.is_empty() {
        args.rest_pose.clone()
    } else if robot.name() == powertwin::model::builtin::IRB1200_NAME {
        vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0]
    } else {
        rest_pose(
            &robot,
            opts.position_margin + 0.05,
            opts.floor_z,
            opts.base_radius,
        )?
    };
    opts.base_freq_hz = args.base_freq;
    opts.harmonics = args.harmonics;
    opts.periods = args.periods;
    opts.starts = args.starts;
    opts.max_evals = args.evals;
    opts.seed = args.seed;
    let ex = design(&robot, &opts)?;
    let traj = &ex.trajectory;
    let rows = (traj.duration() * 100.0).round() as usize + 1;
    let mut cols = vec![Vec::with_capacity(rows); 1 + 3 * n];
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..rows {
        let t = k as f64 / 100.0;
        traj.sample(t, &mut q, &mut dq, &mut ddq);
        cols[0].push(t);
        for i in 0..n {
            cols[1 + i].push(q[i]);
            cols[1 + n + i].push(dq[i]);
            cols[1 + 2 * n + i].push(ddq[i]);
        }
    }
    let headers: Vec<String> = std::iter::once("t_s".to_string())
        .chain((1..=n).map(|i| format!("q{i}_rad")))
        .chain((1..=n).map(|i| format!("dq{i}_rad_s")))
        .chain((1..=n).map(|i| format!("ddq{i}_rad_s2")))
        .collect();
    write_atomic(&args.out, to_csv(&headers, &cols).as_bytes())
        .with_context(|| format!("writing {}", args.out.display()))?;
    // Where a rest pins the standby power (not part of the trajectory).
    let standby = standby_pose(
        &robot,
        opts.position_margin + 0.05,
        opts.floor_z,
        opts.base_radius,
    )
    .ok();
    if args.json {
        let report = json!({
            "standby_pose_rad": standby.as_ref().map(|s| &s.0),
            "standby_gravity_torque_Nm": standby.as_ref().map(|s| &s.1),
            "joints": joints.iter().map(|j| j + 1).collect::<Vec<_>>(),
            "cond_initial": ex.cond_initial, "cond_final": ex.cond_final,
            "parameters": ex.parameters, "evaluations": ex.evaluations, "wall_s": ex.wall_s,
            "base_freq_hz": traj.base_freq_hz(), "harmonics": traj.harmonics(), "periods": traj.periods(),
            "q0_rad": traj.q0(), "a_rad": traj.a(), "b_rad": traj.b(),
        });
        super::emit(&format!("{}\n", serde_json::to_string_pretty(&report)?))?;
    } else {
        super::emit(&format!(
            "excited joints {:?}: condition number {:.4e} -> {:.2} over {} parameters ({} evaluations, {:.1} s); {} s trajectory written to {}\n",
            joints.iter().map(|j| j + 1).collect::<Vec<_>>(),
            ex.cond_initial,
            ex.cond_final,
            ex.parameters.len(),
            ex.evaluations,
            ex.wall_s,
            traj.duration(),
            args.out.display()
        ))?;
        if let Some((q, tau)) = &standby {
            super::emit(&format!(
                "also log the robot held still for 20 s or more at q = [{}] rad (gravity torques at most {:.2} N m by the URDF): that rest pins the identified standby power\n",
                q.iter()
                    .map(|v| format!("{v:.3}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                tau.iter().fold(0.0_f64, |m, t| m.max(t.abs()))
            ))?;
        }
    }
    Ok(ExitCode::SUCCESS)
}
