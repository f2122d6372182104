//! The files of a designed identification set, for the user to run on the robot: per
//! excitation `excitation_01.csv` .. (the trajectory table of
//! [`crate::trajectory::table`]) and, for a Universal Robots controller,
//! `excitation_01.script` .. ([`crate::trajectory::urscript`]); and the manifest `runs.toml`
//! ([`super::runs`]) with the log paths to fill and each run's payload.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::io::write_atomic;
use crate::trajectory::Trajectory;
use crate::trajectory::table::trajectory_csv;
use crate::trajectory::urscript::{UrScriptOptions, urscript};

use super::runs::{PlannedRun, log_path, manifest_toml, portable_payload};

/// Where and how to write a set.
#[derive(Debug, Clone)]
pub struct SetFiles<'a> {
    /// Output directory (created if missing).
    pub dir: &'a Path,
    /// Rate of the CSV rows and of the URScript `servoj` steps, Hz (the controller's rate).
    pub rate_hz: f64,
    /// Also write a URScript program per excitation.
    pub urscript: bool,
    /// The payload of each excitation as the user gave it (see [`portable_payload`]).
    pub payloads: &'a [String],
    /// Directory relative payload paths in `payloads` are resolved from.
    pub payload_dir: &'a Path,
    /// Name of the robot, for the manifest's header.
    pub robot: &'a str,
}

/// Write the excitations `trajectories` (one per entry of `files.payloads`) and the
/// manifest; returns the paths written, the manifest last.
///
/// Errors: as many payloads as trajectories are needed; the directory, a file or a payload
/// cannot be written or resolved; a rate that is not finite and positive.
pub fn write_set(trajectories: &[&dyn Trajectory], files: &SetFiles) -> Result<Vec<PathBuf>> {
    if trajectories.len() != files.payloads.len() {
        return Err(Error::InvalidInput(format!(
            "{} excitations but {} payloads",
            trajectories.len(),
            files.payloads.len()
        )));
    }
    std::fs::create_dir_all(files.dir).map_err(|e| Error::io(files.dir, e))?;
    let mut written = Vec::new();
    let mut runs = Vec::with_capacity(trajectories.len());
    let mut copied = Vec::new();
    for (k, (traj, spec)) in trajectories.iter().zip(files.payloads).enumerate() {
        let name = format!("excitation_{:02}", k + 1);
        let csv = files.dir.join(format!("{name}.csv"));
        write_atomic(&csv, trajectory_csv(*traj, files.rate_hz)?.as_bytes())?;
        written.push(csv);
        let mut excitation = format!("{name}.csv");
        if files.urscript {
            let script = files.dir.join(format!("{name}.script"));
            let opts = UrScriptOptions::new(&name, 1.0 / files.rate_hz);
            write_atomic(&script, urscript(*traj, &opts)?.as_bytes())?;
            written.push(script);
            excitation = format!("{name}.script ({name}.csv)");
        }
        runs.push(PlannedRun {
            excitation: format!("{excitation}, {:.1} s", traj.duration()),
            log: log_path(k + 1),
            payload: portable_payload(spec, files.payload_dir, files.dir, &mut copied)?,
        });
    }
    let manifest = files.dir.join("runs.toml");
    write_atomic(
        &manifest,
        manifest_toml(&header(files.robot, runs.len()), &runs).as_bytes(),
    )?;
    written.push(manifest);
    Ok(written)
}

/// What the manifest's header tells the user to record.
fn header(robot: &str, count: usize) -> Vec<String> {
    vec![
        format!(
            "Identification runs of {robot}: {count} excitations designed together by `powertwin excite --set`."
        ),
        "For each run: mount its payload, play its excitation on the robot (the CSV's q*_rad at"
            .into(),
        "its t_s, or the .script on a UR controller), and record a log of the time, the joint"
            .into(),
        "positions (rad; velocities if the controller gives them) and the motor power (the DC bus,"
            .into(),
        "the mains or each motor's) from a few seconds before the motion starts to a few seconds"
            .into(),
        "after it ends, at the controller's rate (10 Hz at least). Save it at `log` (relative to"
            .into(),
        "this file), then: powertwin identify --robot URDF --runs runs.toml".into(),
    ]
}
