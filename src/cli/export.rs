//! `identify --export-urdf OUT.urdf --export-drive OUT.drive.toml`: the identified robot as a
//! twin (physically consistent URDF and drive file); the same twin in memory for `sweep` and
//! `optimize --twin identified`.

use std::path::Path;

use anyhow::{Context, Result};
use powertwin::Robot;
use powertwin::dynamics::DriveTerms;
use powertwin::identification::consistent::{IdentifiedTwin, Options};
use powertwin::identification::lsq::Estimate;
use powertwin::identification::model::PowerModel;
use powertwin::io::write_atomic;
use powertwin::model::drive::Brakes;

/// Write the identified robot's URDF and/or drive file (atomically) when a path is given.
/// The prior for what the data cannot reveal is `robot` itself (its URDF mass properties and
/// `<dynamics>` friction, no rotor inertia). Prints the projection's residual to stderr.
pub fn export(
    robot: &Robot,
    model: &PowerModel,
    estimate: Option<&Estimate>,
    urdf: Option<&Path>,
    drive: Option<&Path>,
) -> Result<()> {
    if urdf.is_none() && drive.is_none() {
        return Ok(());
    }
    let estimate = estimate.context("export: the identification produced no estimate")?;
    let prior = model.layout.theta(robot, &DriveTerms::from_urdf(robot));
    let twin = IdentifiedTwin::new(robot, model, estimate, &prior, &Options::default())
        .context("export: physically consistent parameters")?;
    report(&twin, "export");
    if let Some(path) = urdf {
        write_atomic(path, twin.urdf().as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("export: URDF -> {}", path.display());
    }
    if let Some(path) = drive {
        write_atomic(path, twin.drive_toml().as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("export: drive -> {}", path.display());
    }
    Ok(())
}

/// The twin of a model read from a file (`--twin identified`), in memory: the robot and drive
/// `identify --export-urdf --export-drive` writes, built from the model's own values and
/// covariance ([`IdentifiedTwin::from_model`]) with `robot` as the prior, and the input
/// drive's brakes-applied mode `brakes` (not identified). Prints the projection's residual to
/// stderr.
pub fn identified_twin(
    robot: &Robot,
    model: &PowerModel,
    brakes: Option<&Brakes>,
) -> Result<IdentifiedTwin> {
    let twin = IdentifiedTwin::from_model(robot, model, &Options::default())
        .and_then(|t| t.with_brakes(brakes))
        .context("--twin identified: the identified model's twin")?;
    report(&twin, "identified twin");
    Ok(twin)
}

/// Print how closely the twin's consistent parameters reproduce the model, and the values
/// written as 0, to stderr; `what` starts each line.
fn report(twin: &IdentifiedTwin, what: &str) {
    let c = &twin.consistent;
    eprintln!(
        "{what}: consistent parameters reproduce the identified base parameters within {:.3e} (Mahalanobis), largest change {:.3e} sigma; {} of {} standard parameters set by the prior",
        c.mahalanobis,
        c.max_change_sigma,
        c.from_prior.len(),
        c.names.len()
    );
    for v in &twin.clamped {
        eprintln!("{what}: negative identified {v} written as 0");
    }
}
