//! The twin set-up an experiment runs on, and progress reporting.

use crate::dataset::Dataset;
use crate::dataset::generate::{RunSpec, simulate};
use crate::dataset::meta::Urdf;
use crate::error::Result;
use crate::model::Robot;
use crate::model::drive::{BrakeWindow, Drive};
use crate::model::payload::PayloadEvent;
use crate::trajectory::Trajectory;
use crate::twin::sensor::SensorSettings;
use crate::twin::{RunReport, TwinConfig};

/// Robot, true drives, twin and logger settings of an experiment.
#[derive(Debug, Clone)]
pub struct Rig<'a> {
    /// The simulated robot (no payload).
    pub robot: &'a Robot,
    /// Where the robot came from (recorded in the datasets).
    pub urdf: Urdf,
    /// True drive parameters.
    pub drive: &'a Drive,
    /// Physics, controller and motor model.
    pub twin: TwinConfig,
    /// Logger; run `k` of an experiment uses noise seed `sensor.seed + k`.
    pub sensor: SensorSettings,
}

impl Rig<'_> {
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
        let spec = RunSpec {
            robot: self.robot,
            urdf: self.urdf.clone(),
            drive: self.drive,
            events,
            brakes,
            twin: self.twin.clone(),
            sensor: SensorSettings {
                seed: self.sensor.seed.wrapping_add(run),
                ..self.sensor
            },
            trajectory: traj,
            trajectory_description: description,
            trajectory_seed: None,
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
