//! Any arm end to end: the Universal Robots UR5 (6 joints, not of the OPW class) and the Franka
//! Emika Panda (7 joints, fingers locked) through excite -> simulate -> identify -> predict ->
//! sweep, with the models, drive files and scenarios of `models/` and `scenarios/`. The library
//! chain is checked with numbers; one CLI run per robot checks that every command takes
//! `--robot`, `--drive` (and `--lock`).

use crate::common;

use std::path::{Path, PathBuf};

use common::{run as powertwin, tmp};
use nalgebra::{Isometry3, Translation3, Vector3};
use powertwin::dataset::Dataset;
use powertwin::dataset::generate::{RunSpec, simulate};
use powertwin::dataset::meta::Urdf;
use powertwin::dynamics::ParamLayout;
use powertwin::identification::consistency::consistency;
use powertwin::identification::data::{Route, prepare};
use powertwin::identification::excitation::{ExcitationOptions, design, rest_pose};
use powertwin::identification::model::PowerModel;
use powertwin::identification::pmsm;
use powertwin::identification::states::States;
use powertwin::kinematics::dls::{self, DlsOptions};
use powertwin::kinematics::fk::tcp_pose;
use powertwin::model::drive::Drive;
use powertwin::model::urdf::{LoadOptions, load_file};
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::limits::check_limits;
use powertwin::trajectory::linear_move::{LinearMoveOptions, ViaPose, plan};
use powertwin::trajectory::random::{RandomFourierOptions, random_fourier};
use powertwin::trajectory::s_curve::SCurve;
use powertwin::trajectory::task::Scenario;
use powertwin::twin::TwinConfig;
use powertwin::twin::physics::PhysicsSettings;
use powertwin::twin::sensor::SensorSettings;
use powertwin::validation::heldout::{self, HeldoutOptions};
use powertwin::validation::idset::IdSetOptions;
use powertwin::validation::rig::{Rig, Silent};
use powertwin::validation::sweep;
use powertwin::{Error, Robot};

/// Panda finger joints, locked (closed) for every command.
const PANDA_LOCK: [&str; 2] = ["panda_finger_joint1", "panda_finger_joint2"];

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// One arm's files.
struct Arm {
    urdf: &'static str,
    lock: &'static [&'static str],
    drive: &'static str,
    scenario: &'static str,
    /// Load level of the sweep, kg.
    load_kg: f64,
}

const UR5: Arm = Arm {
    urdf: "models/ur5.urdf",
    lock: &[],
    drive: "models/ur5.drive.toml",
    scenario: "scenarios/ur5_pick_and_place.toml",
    load_kg: 4.0,
};

const PANDA: Arm = Arm {
    urdf: "models/panda.urdf",
    lock: &PANDA_LOCK,
    drive: "models/panda.drive.toml",
    scenario: "scenarios/panda_pick_and_place.toml",
    load_kg: 2.0,
};

fn load(arm: &Arm) -> (Robot, Drive, Urdf) {
    let path = repo(arm.urdf);
    let opts = LoadOptions {
        lock: arm.lock.iter().map(|s| s.to_string()).collect(),
    };
    let robot = load_file(&path, &opts).expect("the model loads");
    let drive = Drive::from_file(&repo(arm.drive), &robot).expect("the drive file loads");
    let text = std::fs::read_to_string(&path).unwrap();
    (robot, drive, Urdf::file(arm.urdf, &text))
}

/// Excitations designed per arm, and 10 s periods of each.
const EXCITATIONS: usize = 3;
const PERIODS: usize = 4;
/// Seeds of the held-out random motions.
const HELDOUT_SEEDS: [u64; 3] = [11, 12, 13];
/// Rapier substeps per physics step.
const SUBSTEPS: usize = 3;

mod chain;
mod commands;
mod motions;
