//! One twin run to one dataset: simulate, log, and describe everything in `meta.json`.

use crate::dataset::Dataset;
use crate::dataset::meta::{
    BaseParamsInfo, DriveInfo, Meta, PayloadRecord, Program, RobotInfo, SCHEMA_VERSION,
    StandardParams, Summary, Urdf,
};
use crate::dynamics::base_params::{BaseParams, SamplingOptions};
use crate::dynamics::{DriveTerms, ParamLayout};
use crate::error::Result;
use crate::model::Robot;
use crate::model::drive::Drive;
use crate::trajectory::Trajectory;
use crate::trajectory::limits::check_limits;
use crate::twin::family::Draw;
use crate::twin::sensor::{SensorSettings, measure};
use crate::twin::{RunReport, Twin, TwinConfig};

/// Everything a run needs.
pub struct RunSpec<'a> {
    /// The simulated robot.
    pub robot: &'a Robot,
    /// Where the robot came from (stored in `meta.json`).
    pub urdf: Urdf,
    /// True drive parameters.
    pub drive: &'a Drive,
    /// Payload timeline (sorted by time).
    pub events: &'a [crate::model::payload::PayloadEvent],
    /// Windows in which the brakes hold the arm (sorted; usually empty).
    pub brakes: &'a [crate::model::drive::BrakeWindow],
    /// Physics, controller and motor settings.
    pub twin: TwinConfig,
    /// Logger settings.
    pub sensor: SensorSettings,
    /// The reference trajectory.
    pub trajectory: &'a dyn Trajectory,
    /// Description of the trajectory for `meta.json`.
    pub trajectory_description: serde_json::Value,
    /// Seed of a randomly generated trajectory.
    pub trajectory_seed: Option<u64>,
    /// What was drawn when `robot`, `drive`, `twin` and `sensor` are a robot of the family
    /// of truths (recorded in `meta.json`).
    pub family: Option<&'a Draw>,
}

/// Check the trajectory against the robot's position and velocity limits, run the twin, log
/// the measured stream and assemble the dataset with its metadata (true standard and base
/// parameters with friction and rotor-inertia columns).
pub fn simulate(spec: &RunSpec) -> Result<(Dataset, RunReport)> {
    let robot = spec.robot;
    spec.sensor.stride(spec.twin.physics.dt)?;
    check_limits(robot, spec.trajectory, spec.twin.physics.dt, None)?;
    let (truth, report) = Twin::new(robot, spec.drive, spec.twin.clone())?.run(
        spec.trajectory,
        spec.events,
        spec.brakes,
    )?;
    let measured = measure(&truth, &spec.sensor)?;
    let layout = ParamLayout::new(robot, true, true);
    let theta = layout.theta(robot, &DriveTerms::from(spec.drive));
    let base = BaseParams::compute(robot, layout, &SamplingOptions::default())?;
    let meta = Meta {
        schema_version: SCHEMA_VERSION,
        program: Program::current(),
        robot: RobotInfo::new(robot, spec.urdf.clone()),
        drives: DriveInfo::per_joint(robot, spec.drive),
        payloads: spec.events.iter().map(PayloadRecord::of).collect(),
        base_params: BaseParamsInfo::new(&base, &theta)?,
        standard_params: StandardParams::new(&layout, theta)?,
        twin: spec.twin.clone(),
        measurement: spec.sensor,
        trajectory_seed: spec.trajectory_seed,
        trajectory: spec.trajectory_description.clone(),
        summary: Summary::of(&truth, &measured),
        family: spec.family.cloned(),
    };
    Ok((
        Dataset {
            meta,
            truth,
            measured,
        },
        report,
    ))
}
