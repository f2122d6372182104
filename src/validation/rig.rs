//! The twin set-up an experiment runs on, and progress reporting.

use crate::dataset::Dataset;
use crate::dataset::generate::{RunSpec, simulate};
use crate::dataset::meta::Urdf;
use crate::error::Result;
use crate::model::Robot;
use crate::model::drive::{BrakeWindow, Drive};
use crate::model::payload::PayloadEvent;
use crate::trajectory::Trajectory;
use crate::twin::family::Plant;
use crate::twin::sensor::SensorSettings;
use crate::twin::{RunReport, TwinConfig};

/// Robot, drives, twin and logger settings of an experiment.
#[derive(Debug, Clone)]
pub struct Rig<'a> {
    /// The robot as the user's URDF describes it (no payload): what identification sees, and
    /// what the twin simulates unless `plant` is given.
    pub robot: &'a Robot,
    /// Where the robot came from (recorded in the datasets).
    pub urdf: Urdf,
    /// The drives as the user's drive file gives them (the truth unless `plant` is given).
    pub drive: &'a Drive,
    /// Physics, controller and motor model.
    pub twin: TwinConfig,
    /// Logger; run `k` of an experiment uses noise seed `sensor.seed + k`.
    pub sensor: SensorSettings,
    /// The robot the twin simulates when it is not the one the files describe: a robot of
    /// the family of truths ([`Plant`]). Its robot, drives, twin and logger settings replace
    /// `robot`, `drive`, `twin` and `sensor` in the twin runs and in scoring; identification
    /// and the baseline keep seeing `robot` and `drive`, the user's files. `None`: the files
    /// are the truth.
    pub plant: Option<&'a Plant>,
}

impl Rig<'_> {
    /// The robot the twin simulates (truth: for twin runs and scoring only).
    pub fn true_robot(&self) -> &Robot {
        self.plant.map_or(self.robot, |p| &p.robot)
    }

    /// The drives the twin simulates (truth: for twin runs and scoring only).
    pub fn true_drive(&self) -> &Drive {
        self.plant.map_or(self.drive, |p| &p.drive)
    }

    /// The logger of the twin runs.
    pub fn logger(&self) -> &SensorSettings {
        self.plant.map_or(&self.sensor, |p| &p.sensor)
    }

    /// Run the twin along `traj` with the payload timeline `events` and log it as a dataset.
    /// `run` numbers the run within the experiment (noise seed offset); `description` goes
    /// into `meta.json`.
    pub fn run(
        &self,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        run: u64,
        description: serde_json::Value,
    ) -> Result<Dataset> {
        Ok(self.run_reported(traj, events, &[], run, description)?.0)
    }

    /// [`Rig::run`] with the brakes holding the arm during `brakes`, also returning the twin's
    /// [`RunReport`] (tracking error, torque saturation).
    pub fn run_reported(
        &self,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        brakes: &[BrakeWindow],
        run: u64,
        description: serde_json::Value,
    ) -> Result<(Dataset, RunReport)> {
        let sensor = self.plant.map_or(&self.sensor, |p| &p.sensor);
        let spec = RunSpec {
            robot: self.true_robot(),
            urdf: self.urdf.clone(),
            drive: self.true_drive(),
            events,
            brakes,
            twin: self.plant.map_or(&self.twin, |p| &p.twin).clone(),
            sensor: SensorSettings {
                seed: sensor.seed.wrapping_add(run),
                ..*sensor
            },
            trajectory: traj,
            trajectory_description: description,
            trajectory_seed: None,
            family: self.plant.map(|p| &p.draw),
        };
        simulate(&spec)
    }
}

/// Receives progress of a long experiment (a progress bar in the CLI).
pub trait Progress: Sync {
    /// A stage of `items` units of work begins.
    fn stage(&self, name: &str, items: usize);
    /// `items` more units join the current stage (work that runs alongside it).
    fn extend(&self, items: usize) {
        let _ = items;
    }
    /// One unit of the current stage is done.
    fn advance(&self);
}

/// Stages that run side by side under one stage of the wrapped progress: each stage begun
/// through it adds its units to that stage.
pub struct Together<'a>(pub &'a dyn Progress);

impl Progress for Together<'_> {
    fn stage(&self, _: &str, items: usize) {
        self.0.extend(items);
    }
    fn advance(&self) {
        self.0.advance();
    }
}

/// Progress that goes nowhere.
pub struct Silent;

impl Progress for Silent {
    fn stage(&self, _: &str, _: usize) {}
    fn advance(&self) {}
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// Stages begun and units counted: `(name, items, done)` per stage.
    struct Count(Mutex<Vec<(String, usize, usize)>>);

    impl Progress for Count {
        fn stage(&self, name: &str, items: usize) {
            self.0.lock().unwrap().push((name.into(), items, 0));
        }
        fn extend(&self, items: usize) {
            self.0.lock().unwrap().last_mut().unwrap().1 += items;
        }
        fn advance(&self) {
            self.0.lock().unwrap().last_mut().unwrap().2 += 1;
        }
    }

    /// Two stages run side by side through `Together` fill one stage of the outer progress.
    #[test]
    fn side_by_side_stages_join_one_stage() {
        let count = Count(Mutex::new(Vec::new()));
        count.stage("both", 0);
        let together = Together(&count);
        rayon::join(
            || {
                together.stage("a", 3);
                (0..3).for_each(|_| together.advance());
            },
            || {
                together.stage("b", 2);
                (0..2).for_each(|_| together.advance());
            },
        );
        assert_eq!(*count.0.lock().unwrap(), vec![("both".to_string(), 5, 5)]);
    }
}
