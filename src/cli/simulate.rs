//! `powertwin simulate`: one twin run of a given trajectory to a dataset.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use powertwin::dataset::generate::{RunSpec, simulate};
use powertwin::io::table::Table;
use powertwin::model::payload::PayloadEvent;
use powertwin::trajectory::sampled::Sampled;
use serde_json::json;

use super::TwinArgs;

/// Arguments of `simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    twin: TwinArgs,
    /// Reference trajectory CSV: columns t (s), q1..qn (rad), optionally dq1..dqn (rad/s) and
    /// ddq1..ddqn (rad/s^2) (names may carry units: t_s, q1_rad, ...). Missing derivatives are
    /// interpolated smoothly. Position or velocity limit violations are refused.
    #[arg(long, value_name = "TRAJ.csv")]
    trajectory: PathBuf,
    /// Output dataset directory (written atomically; an existing dataset there is replaced).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    overload: super::OverloadArgs,
    #[cfg(feature = "viz")]
    #[command(flatten)]
    viz: super::viz::VizArgs,
}

/// Run `simulate`.
pub fn run(args: &SimulateArgs) -> Result<ExitCode> {
    let setup = args.twin.setup()?;
    if let Some(p) = &setup.payload {
        args.overload.check_payload(
            p.inertia.mass,
            &setup.drive,
            &format!("payload '{}'", p.name),
        )?;
    }
    let table = Table::read(&args.trajectory)?;
    #[cfg(feature = "viz")]
    let viz = args.viz.open(None)?;
    let traj = Sampled::from_table(&table, setup.robot.dof())?;
    let events: Vec<PayloadEvent> = setup
        .payload
        .clone()
        .map(|p| PayloadEvent {
            t_s: 0.0,
            payload: Some(p),
        })
        .into_iter()
        .collect();
    let start = Instant::now();
    let rig = setup.rig();
    let (dataset, report) = simulate(&RunSpec {
        robot: rig.true_robot(),
        urdf: setup.urdf.clone(),
        drive: rig.true_drive(),
        events: &events,
        brakes: &[],
        twin: setup.plant.as_ref().map_or(&setup.twin, |p| &p.twin).clone(),
        sensor: *rig.logger(),
        trajectory: &traj,
        trajectory_description: json!({"kind": "sampled", "file": args.trajectory.display().to_string(),
            "interpolation": format!("{:?}", traj.interpolation()), "start_time_s": traj.start_time()}),
        trajectory_seed: None,
        family: setup.plant.as_ref().map(|p| &p.draw),
    })
    .with_context(|| format!("simulating {}", args.trajectory.display()))?;
    let sim_wall = start.elapsed().as_secs_f64();
    dataset
        .write(&args.out, args.twin.format)
        .with_context(|| format!("writing {}", args.out.display()))?;
    let s = &dataset.meta.summary;
    eprintln!(
        "{}: {:.1} s simulated in {:.2} s ({:.0}x real time), energy {:.1} J (grid {:.1} J), max tracking error {:.2e} rad",
        args.out.display(),
        s.duration_s,
        sim_wall,
        s.duration_s / sim_wall,
        s.energy_total_j,
        s.energy_grid_j,
        report.max_tracking_error_rad
    );
    for hit in &report.torque_limit_hits {
        eprintln!(
            "warning: joint '{}' hit its torque limit first at t = {:.3} s ({} steps clipped)",
            hit.joint, hit.first_t_s, hit.steps
        );
    }
    #[cfg(feature = "viz")]
    if let Some(viz) = &viz {
        use powertwin::viz::{DEFAULT_DISPLAY_HZ, Tab};
        let prefix = "run";
        viz.send_blueprint(&[Tab::Run {
            title: format!("simulate {}", args.trajectory.display()),
            prefix: prefix.into(),
            joints: setup.robot.dof(),
        }])?;
        viz.log_run(&setup.robot, &dataset, None, prefix, DEFAULT_DISPLAY_HZ)?;
        viz.log_payload_events(&events, prefix)?;
        viz.flush()?;
    }
    Ok(ExitCode::SUCCESS)
}
