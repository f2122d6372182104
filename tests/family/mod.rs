//! The family of truths: drawing robots we did not build, the effects they add to the twin
//! (direction-dependent gear friction, cabinet load, power lag, stamp jitter), the lag the
//! identification finds, and the CLI's errors.

use crate::common;

use powertwin::identification::data::Route;
use powertwin::identification::fit::{FitOptions, identify_logs};
use powertwin::identification::model::PowerModel;
use powertwin::model::drive::Drive;
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::fourier::Fourier;
use powertwin::twin::Fidelity;
use powertwin::twin::family::FamilyTable;
use powertwin::twin::sensor::{NoiseSettings, SensorSettings};
use powertwin::validation::rig::Rig;

/// Two runs of `traj` on `rig` (noise seeds 0 and 1), as logged.
fn two_logs(rig: &Rig, traj: &Fourier) -> Vec<powertwin::measurement::Log> {
    (0..2)
        .map(|k| {
            rig.run(traj, &[], k, serde_json::json!({}))
                .unwrap()
                .log("run")
                .unwrap()
        })
        .collect()
}

/// A 20 s excitation of the IRB 1200 (four periods of 0.2 Hz, 5 harmonics).
fn excitation(robot: &powertwin::Robot) -> Fourier {
    let n = robot.dof();
    let q0 = vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0];
    let a: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..5)
                .map(|k| 0.3 / (1.0 + k as f64) * if (i + k) % 2 == 0 { 1.0 } else { -0.7 })
                .collect()
        })
        .collect();
    let b: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..5)
                .map(|k| 0.25 / (1.0 + k as f64) * if (i + 2 * k) % 3 == 0 { -1.0 } else { 0.8 })
                .collect()
        })
        .collect();
    Fourier::new(0.2, q0, a, b, 4.0).unwrap()
}

mod commands;
mod draws;
mod effects;
mod predictions;
