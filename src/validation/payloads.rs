//! Table 4: the last step's trajectory run with no payload, the tool, and the tool with loads.
//! Each case's energy is predicted two ways: by identifying the last link again from that
//! case's data, as the paper does, and by adding the payload's known mass properties to the
//! no-payload model (no new data; an efficiency-scaled model uses the drives' nominal
//! efficiency for it).

use rayon::prelude::*;
use serde::Serialize;

use crate::dataset::Dataset;
use crate::error::{Error, Result};
use crate::identification::data::{Route, prepare};
use crate::identification::last_link::reidentify;
use crate::identification::lsq::Estimate;
use crate::identification::model::PowerModel;
use crate::model::payload::Payload;
use crate::model::payload::PayloadEvent;
use crate::trajectory::Trajectory;
use crate::validation::rig::{Progress, Rig};
use crate::validation::score::energy_error_pct;

/// One row of Table 4.
#[derive(Debug, Clone, Serialize)]
pub struct CaseRow {
    /// Case name (e.g. "tool + 2 kg").
    pub case: String,
    /// Payload mass, kg.
    pub payload_kg: f64,
    /// Energy the twin's motors used, J.
    #[serde(rename = "simulated_J")]
    pub simulated_j: f64,
    /// Predicted after re-identifying the last link from this case's data, J.
    #[serde(rename = "reidentified_J")]
    pub reidentified_j: f64,
    /// Its error, %.
    pub reidentified_error_pct: f64,
    /// The re-identification's estimate.
    pub estimate: Estimate,
    /// Predicted from the payload's known mass properties, J.
    #[serde(rename = "known_payload_J")]
    pub known_payload_j: f64,
    /// Its error, %.
    pub known_payload_error_pct: f64,
}

/// Outcome of the cases.
pub struct Cases {
    /// Table 4, one row per case.
    pub rows: Vec<CaseRow>,
    /// The twin's dataset of each case.
    pub datasets: Vec<Dataset>,
}

/// Run `cases` (name and payload, `None` for none) along `traj` (its measured data go through
/// `route`), and predict each: by re-identifying the last link of `linear` (a linear model
/// identified without payload, as the paper), and by adding the known payload to `known`
/// (any model identified without payload). `efficiency` is the drives' nominal efficiency
/// used to add a known payload to an efficiency-scaled model.
#[allow(clippy::too_many_arguments)]
pub fn run(
    rig: &Rig,
    linear: &PowerModel,
    known: &PowerModel,
    traj: &dyn Trajectory,
    route: Route,
    cases: &[(String, Option<Payload>)],
    efficiency: f64,
    progress: &dyn Progress,
) -> Result<Cases> {
    let robot = rig.robot;
    progress.stage("Table 4: tool and load cases", cases.len());
    let rows: Vec<(CaseRow, Dataset)> = cases
        .par_iter()
        .enumerate()
        .map(|(c, (name, payload))| {
            let events: Vec<PayloadEvent> = payload
                .iter()
                .map(|p| PayloadEvent {
                    t_s: 0.0,
                    payload: Some(p.clone()),
                })
                .collect();
            let description = serde_json::json!({
                "kind": "fourier excitation",
                "table": 4,
                "case": name,
            });
            let ds = rig.run(traj, &events, 100 + c as u64, description)?;
            let prepared = prepare(&ds.log("twin run")?, route)?;
            let (reidentified, estimate) =
                reidentify(robot, linear, &prepared.states, &prepared.p_total)
                    .map_err(|e| Error::InvalidInput(format!("case '{name}': {e}")))?;
            let dt = rig.twin.physics.dt;
            let simulated_j = ds.meta.summary.energy_total_j;
            let reidentified_j = reidentified.energy(robot, traj, dt)?;
            let known_payload_j = known
                .energy_with_payloads(robot, traj, &events, efficiency, dt)?
                .motor_j;
            progress.advance();
            Ok((
                CaseRow {
                    case: name.clone(),
                    payload_kg: payload.as_ref().map_or(0.0, |p| p.inertia.mass),
                    simulated_j,
                    reidentified_j,
                    reidentified_error_pct: energy_error_pct(reidentified_j, simulated_j),
                    estimate,
                    known_payload_j,
                    known_payload_error_pct: energy_error_pct(known_payload_j, simulated_j),
                },
                ds,
            ))
        })
        .collect::<Result<_>>()?;
    let (rows, datasets) = rows.into_iter().unzip();
    Ok(Cases { rows, datasets })
}
