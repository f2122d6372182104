//! Table 3: step `k` excites the last `k` joints with an optimised Fourier trajectory, the
//! twin runs it, and the parameters of link `n+1-k` are identified from total power given the
//! earlier steps (Liu et al. 2018, Table 3). Each step's energy is then predicted with the
//! parameters known after that step, on that step's commanded trajectory, and compared with
//! the twin's simulated energy.

use rayon::prelude::*;
use serde::Serialize;

use crate::dataset::Dataset;
use crate::dynamics::ParamLayout;
use crate::error::Result;
use crate::identification::data::{Route, prepare};
use crate::identification::excitation::{ExcitationOptions, design};
use crate::identification::lsq::Estimate;
use crate::identification::model::PowerModel;
use crate::identification::steps::{StepData, hold_still, identify};
use crate::trajectory::fourier::Fourier;
use crate::validation::rig::{Progress, Rig};
use crate::validation::score::energy_error_pct;

/// Settings of the six steps.
#[derive(Debug, Clone, PartialEq)]
pub struct StepsOptions {
    /// Pose of the joints a step does not excite (and offsets' start guess), rad.
    pub rest_pose: Vec<f64>,
    /// Acceleration limits of the excitation, rad/s^2 per joint.
    pub accel_limits: Vec<f64>,
    /// Periods of 10 s (at 0.1 Hz) each step runs.
    pub periods: usize,
    /// CMA-ES starts per design.
    pub starts: usize,
    /// Objective evaluations per start.
    pub max_evals: usize,
    /// Seed of the designs (step `k` uses `seed + k`).
    pub seed: u64,
}

/// One row of Table 3.
#[derive(Debug, Clone, Serialize)]
pub struct StepRow {
    /// 1-based step.
    pub step: usize,
    /// Excited joints, 1-based.
    pub joints: Vec<usize>,
    /// Condition number of the excitation's regressor before and after the design.
    pub design_cond_initial: f64,
    /// After the design.
    pub design_cond_final: f64,
    /// Wall time of the design, s.
    pub design_s: f64,
    /// The step's least-squares estimate (base parameters identified in it and `P0_W`).
    pub estimate: Estimate,
    /// Energy the twin's motors used, J.
    #[serde(rename = "simulated_J")]
    pub simulated_j: f64,
    /// Energy predicted with the parameters known after this step, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// `100 (predicted - simulated) / simulated`, %.
    pub error_pct: f64,
}

/// Outcome of the six steps.
pub struct Steps {
    /// Table 3, one row per step.
    pub rows: Vec<StepRow>,
    /// The model after the last step.
    pub model: PowerModel,
    /// The commanded trajectory of each step (the last excites every joint).
    pub trajectories: Vec<Fourier>,
    /// The twin's dataset of each step.
    pub datasets: Vec<Dataset>,
    /// Each step's fitted states and measured total power.
    pub data: Vec<StepData>,
}

/// Run the steps on `rig` (one per joint, designs and twin runs in parallel) and identify
/// step by step with the paper's linear power model (`theta` scaled by 1/eta, as the
/// paper's eq. 12; it has no copper loss). Measured data go through the paper's route
/// (Fourier fit, 0.1 Hz, 5 harmonics); the joints a step does not excite are held still in the fitted states.
pub fn run(rig: &Rig, opts: &StepsOptions, progress: &dyn Progress) -> Result<Steps> {
    let robot = rig.robot;
    let n = robot.dof();
    progress.stage("Table 3: excitation and twin runs", n);
    let runs: Vec<_> = (1..=n)
        .into_par_iter()
        .map(|k| {
            let joints: Vec<usize> = (n - k..n).collect();
            let mut o = ExcitationOptions::new(
                robot,
                joints.clone(),
                opts.rest_pose.clone(),
                opts.accel_limits.clone(),
            );
            o.periods = opts.periods;
            o.starts = opts.starts;
            o.max_evals = opts.max_evals;
            o.seed = opts.seed.wrapping_add(k as u64);
            let ex = design(robot, &o)?;
            let description = serde_json::json!({
                "kind": "fourier excitation",
                "table": 3,
                "step": k,
                "joints": joints.iter().map(|j| j + 1).collect::<Vec<_>>(),
            });
            let ds = rig.run(&ex.trajectory, &[], k as u64, description)?;
            progress.advance();
            Ok((joints, ex, ds))
        })
        .collect::<Result<_>>()?;
    let route = Route::Fourier {
        base_freq_hz: 0.1,
        harmonics: 5,
    };
    let mut data = Vec::with_capacity(n);
    for (joints, _, ds) in &runs {
        let p = prepare(&ds.log("twin run")?, route)?;
        let mut states = p.states;
        hold_still(&mut states, joints);
        data.push(StepData {
            joints: joints.clone(),
            states,
            p_total: p.p_total,
        });
    }
    let layout = ParamLayout::new(robot, true, true);
    // The paper's model: base parameters divided by the (unknown) efficiency, whatever motors
    // the twin has (a user does not know them).
    let mut model = PowerModel::new(robot, layout, true)?;
    let mut rows = Vec::with_capacity(n);
    for (k, (joints, ex, ds)) in runs.iter().enumerate() {
        let estimate = identify(robot, &mut model, &data[..=k])?
            .pop()
            .expect("one result per step")
            .estimate;
        let predicted_j = model.energy(robot, &ex.trajectory, rig.twin.physics.dt)?;
        let simulated_j = ds.meta.summary.energy_total_j;
        rows.push(StepRow {
            step: k + 1,
            joints: joints.iter().map(|j| j + 1).collect(),
            design_cond_initial: ex.cond_initial,
            design_cond_final: ex.cond_final,
            design_s: ex.wall_s,
            estimate,
            simulated_j,
            predicted_j,
            error_pct: energy_error_pct(predicted_j, simulated_j),
        });
    }
    let (trajectories, datasets) = runs
        .into_iter()
        .map(|(_, ex, ds)| (ex.trajectory, ds))
        .unzip();
    Ok(Steps {
        rows,
        model,
        trajectories,
        datasets,
        data,
    })
}
