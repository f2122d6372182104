//! `powertwin excite`: optimised Fourier excitation for identification (paper eqs. 7-8), one
//! trajectory or (`--set N`) an identification set designed together.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use powertwin::identification::excitation::{ExcitationOptions, design, rest_pose, standby_pose};
use powertwin::identification::excitation_set::arm::{ArmSet, design as design_arm_set};
use powertwin::identification::excitation_set::export::{SetFiles, write_set};
use powertwin::identification::excitation_set::{SetDesign, SetOptions};
use powertwin::io::write_atomic;
use powertwin::model::payload::{Payload, check_rated, resolve};
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::cell::Cell;
use powertwin::trajectory::limits::default_accel_limits;
use powertwin::trajectory::table::trajectory_csv;
use serde_json::json;

use super::{Exit, RobotArgs};

/// Arguments of `excite`.
#[derive(Debug, Args)]
pub struct ExciteArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Joints to excite, 1-based: a range like 4-6 or a list like 1,3,5 (others hold the rest
    /// pose) [default: all].
    #[arg(long, conflicts_with = "set")]
    joints: Option<String>,
    /// Base frequency, Hz (with --set: of the 1st, 3rd, ... excitation; the others run at
    /// twice it).
    #[arg(long, default_value_t = 0.1)]
    base_freq: f64,
    /// Harmonics per joint.
    #[arg(long, default_value_t = 5)]
    harmonics: usize,
    /// Whole periods of the trajectory.
    #[arg(long, default_value_t = 1, conflicts_with = "set")]
    periods: usize,
    /// Rest pose (rad, comma-separated): offsets start there and joints that are not
    /// excited hold it [default: 0,0.2,0.2,0,0.8,0 for the IRB 1200, else derived from the
    /// URDF: zeros clamped into the limits, or the nearest pose that keeps the flange and
    /// wrist above the floor and away from the base].
    #[arg(
        long,
        value_delimiter = ',',
        allow_hyphen_values = true,
        conflicts_with = "set"
    )]
    rest_pose: Vec<f64>,
    /// Acceleration limits, rad/s^2, comma-separated [default: the IRB 1200 estimates
    /// 15,15,20,30,30,40 for the IRB 1200, else each URDF velocity limit / 0.3 s]; a cell's
    /// accel_scaling multiplies them.
    #[arg(long, value_delimiter = ',')]
    accel_limits: Vec<f64>,
    /// Independent optimiser starts.
    #[arg(long, default_value_t = 2, conflicts_with = "set")]
    starts: usize,
    /// Objective evaluations per start (with --set: per excitation and round) [default: 3000;
    /// with --set 2000].
    #[arg(long)]
    evals: Option<usize>,
    /// Seed of the optimiser (with --set: also of the centres).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Design N excitations together, each about its own centre spread over the workspace
    /// and at its own load, for the condition of their stacked regressor; --out is then a
    /// directory: excitation_01.csv .., runs.toml (the manifest of the logs to record, for
    /// identify --runs).
    #[arg(long, value_name = "N")]
    set: Option<usize>,
    /// With --set: the load of each excitation, comma-separated, N entries or one for all:
    /// none, a built-in payload name, a payload TOML file, or several joined by '+'
    /// [default: none].
    #[arg(long, value_name = "SPEC,...", value_delimiter = ',', requires = "set")]
    loads: Vec<String>,
    /// With --set: drive file, whose rated payload (rated_payload_kg) each load must not
    /// exceed [default: the built-in IRB 1200 drive for the built-in robot, else no check].
    #[arg(long, value_name = "PATH", requires = "set")]
    drive: Option<PathBuf>,
    /// With --set: the robot cell (TOML: floor_z_m, floor_margin_m, base_radius_m,
    /// speed_scaling, accel_scaling, [[joint]] name, lower_rad, upper_rad; see
    /// docs/guide/cli.md) [default: floor at z = 0 m with 0.05 m margin, 0.15 m around
    /// the base, the URDF's ranges, full speed].
    #[arg(long, value_name = "CELL.toml", requires = "set")]
    cell: Option<PathBuf>,
    /// With --set: length of each excitation, s (rounded to whole periods).
    #[arg(long, value_name = "S", default_value_t = 30.0, requires = "set")]
    duration: f64,
    /// With --set: block-coordinate rounds of the joint design.
    #[arg(long, default_value_t = 2, requires = "set")]
    rounds: usize,
    /// With --set: csv writes the trajectory CSVs; urscript also a URScript program per
    /// excitation (excitation_01.script: movej to the start, servoj every controller period,
    /// stopj) for a Universal Robots controller.
    #[arg(long, value_enum, default_value_t = Format::Csv, requires = "set")]
    format: Format,
    /// With --set: the controller's rate, Hz: of the CSV rows and the servoj steps (500 for
    /// an e-Series, 125 for a CB3) [default: 100 for csv, 500 for urscript].
    #[arg(long, value_name = "HZ", requires = "set")]
    control_rate: Option<f64>,
    /// Output trajectory CSV (t_s, q_rad, dq_rad_s, ddq_rad_s2 at 100 Hz) for `simulate`;
    /// with --set the output directory.
    #[arg(long, value_name = "TRAJ.csv|DIR")]
    out: PathBuf,
    /// Print the report (condition numbers, parameters, Fourier coefficients) as JSON.
    #[arg(long)]
    json: bool,
}

/// Stacked condition number above which `excite --set` flags its design (exit 3): designed
/// sets score 30-500 (docs/guide/your-robot.md), a set that learnt nothing 1e5 and more.
const FLAG_COND: f64 = 1e4;

/// What `excite --set` writes for the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    /// Trajectory CSVs only.
    Csv,
    /// Trajectory CSVs and a URScript program per excitation.
    Urscript,
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
    match args.set {
        Some(count) => run_set(args, count),
        None => run_single(args),
    }
}

/// One excitation of the chosen joints.
fn run_single(args: &ExciteArgs) -> Result<ExitCode> {
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
    opts.max_evals = args.evals.unwrap_or(3000);
    opts.seed = args.seed;
    let ex = design(&robot, &opts)?;
    let traj = &ex.trajectory;
    write_atomic(&args.out, trajectory_csv(traj, 100.0)?.as_bytes())
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

/// The load of each of `count` excitations from `--loads` (`None`: nothing on the flange),
/// with the specs as given.
fn set_loads(args: &ExciteArgs, count: usize) -> Result<(Vec<String>, Vec<Option<Payload>>)> {
    let specs: Vec<String> = match args.loads.len() {
        0 => vec!["none".into(); count],
        1 => vec![args.loads[0].trim().to_string(); count],
        n if n == count => args.loads.iter().map(|s| s.trim().to_string()).collect(),
        n => bail!(
            "--loads has {n} entries for {count} excitations: give one per excitation or one for all"
        ),
    };
    let payloads = specs
        .iter()
        .enumerate()
        .map(|(k, spec)| {
            (spec != "none")
                .then(|| resolve(spec, Path::new(".")))
                .transpose()
                .with_context(|| format!("--loads entry {} ('{spec}')", k + 1))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((specs, payloads))
}

/// `--set N`: the identification set of any arm in its cell, its files and its manifest.
fn run_set(args: &ExciteArgs, count: usize) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let (specs, payloads) = set_loads(args, count)?;
    let rated = args
        .robot
        .drive(&robot, args.drive.as_ref())?
        .and_then(|d| d.rated_payload_kg());
    for (spec, p) in specs.iter().zip(&payloads) {
        if let Some(p) = p {
            check_rated(p.inertia.mass, rated, &format!("--loads '{spec}'"))?;
        }
    }
    let cell = match &args.cell {
        Some(path) => Cell::from_file(path)?,
        None => Cell::default(),
    };
    let accel_limits = if args.accel_limits.is_empty() {
        default_accel_limits(&robot)
    } else {
        args.accel_limits.clone()
    };
    let set = ArmSet {
        payloads,
        duration_s: args.duration,
        base_freq_hz: args.base_freq,
        harmonics: args.harmonics,
        accel_limits,
        rounds: args.rounds,
        max_evals: args.evals.unwrap_or(2000),
        seed: args.seed,
    };
    let what = || match &args.cell {
        Some(path) => format!("cell {}", path.display()),
        None => "the default workspace".into(),
    };
    let (problem, design) = design_arm_set(&robot, &cell, &set)
        .with_context(|| format!("designing {count} excitations in {}", what()))?;
    let urscript = args.format == Format::Urscript;
    let rate_hz = args
        .control_rate
        .unwrap_or(if urscript { 500.0 } else { 100.0 });
    let trajectories: Vec<&dyn Trajectory> = design
        .trajectories
        .iter()
        .map(|t| t as &dyn Trajectory)
        .collect();
    let written = write_set(
        &trajectories,
        &SetFiles {
            dir: &args.out,
            rate_hz,
            urscript,
            payloads: &specs,
            payload_dir: Path::new("."),
            robot: robot.name(),
        },
    )
    .with_context(|| format!("writing the set into {}", args.out.display()))?;
    report_set(args, &problem.options, &design, &specs, &written)?;
    if design.cond_final > FLAG_COND {
        eprintln!(
            "flagged: the stacked condition number stays at {:.3e} (above {FLAG_COND:.0e}): \
             these runs will not separate the parameters; the cell leaves too little motion \
             (speed scaling, joint ranges, floor), the loads do not differ, or --evals is too \
             small",
            design.cond_final
        );
        return Ok(Exit::Flagged.into());
    }
    Ok(ExitCode::SUCCESS)
}

/// Print what `run_set` designed and wrote.
fn report_set(
    args: &ExciteArgs,
    options: &SetOptions,
    design: &SetDesign,
    specs: &[String],
    written: &[PathBuf],
) -> Result<()> {
    let members: Vec<_> = options
        .members
        .iter()
        .zip(&design.trajectories)
        .zip(specs)
        .zip(&design.member_conds)
        .map(|(((m, t), spec), cond)| {
            json!({
                "centre_rad": m.centre, "base_freq_hz": m.base_freq_hz, "periods": m.periods,
                "duration_s": t.duration(), "payload": spec, "cond": cond,
                "q0_rad": t.q0(), "a_rad": t.a(), "b_rad": t.b(),
            })
        })
        .collect();
    if args.json {
        let report = json!({
            "excitations": members, "cond_initial": design.cond_initial,
            "cond_final": design.cond_final, "criterion": options.criterion,
            "criterion_by_round": design.criterion_by_round,
            "evaluations": design.evaluations, "wall_s": design.wall_s,
            "files": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        });
        return super::emit(&format!("{}\n", serde_json::to_string_pretty(&report)?));
    }
    let mut text = format!(
        "{} excitations designed together ({}, {} evaluations, {:.1} s): stacked condition number {:.4e} -> {:.2}\n",
        members.len(),
        options.criterion.describe(),
        design.evaluations,
        design.wall_s,
        design.cond_initial,
        design.cond_final
    );
    for (k, ((m, t), spec)) in options
        .members
        .iter()
        .zip(&design.trajectories)
        .zip(specs)
        .enumerate()
    {
        text.push_str(&format!(
            "  excitation {:02}: {:.1} s at {} Hz, payload {spec}, own condition number {:.1}\n",
            k + 1,
            t.duration(),
            m.base_freq_hz,
            design.member_conds[k]
        ));
    }
    text.push_str(&format!(
        "wrote {} files into {}; record the logs runs.toml lists, then: powertwin identify --runs {}\n",
        written.len(),
        args.out.display(),
        args.out.join("runs.toml").display()
    ));
    super::emit(&text)
}
