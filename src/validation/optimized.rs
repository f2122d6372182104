//! The twin's check of an optimised task: the user's uniform plan and the optimised plan
//! (and the optimised plan at the best placement, when one was searched) run on the twin,
//! with predicted and simulated energies and savings side by side (errors scored by
//! [`crate::validation::score`]).

use rayon::prelude::*;
use serde::Serialize;

use crate::dataset::Dataset;
use crate::error::{Error, Result};
use crate::model::drive::{BrakeWindow, Brakes};
use crate::optimize::schedule::{Schedule, WaitPrices};
use crate::optimize::segment::Task;
use crate::optimize::{Optimized, PlannedSchedule, plan_schedule, predict_run};
use crate::trajectory::task::TaskRun;
use crate::twin::TorqueLimitHit;
use crate::validation::rig::{Progress, Rig};
use crate::validation::score::energy_error_pct;
use crate::validation::sweep::run_flagged;

/// One plan on the twin.
#[derive(Debug, Clone, Serialize)]
pub struct PlanCheck {
    /// Which plan ("uniform", "optimized", "optimized, best placement").
    pub name: String,
    /// Cycle time, s.
    pub cycle_time_s: f64,
    /// Predicted energy per cycle (the model's signal), J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// Half-width of its 95 % interval, J.
    #[serde(rename = "interval_95_J")]
    pub interval_j: f64,
    /// Energy of the same signal on the twin, J.
    #[serde(rename = "simulated_J")]
    pub simulated_j: f64,
    /// `100 (predicted - simulated) / simulated`, %.
    pub error_pct: f64,
    /// Time the brakes held the arm, s.
    pub braked_s: f64,
    /// Largest |q_ref - q| of the twin run, rad.
    pub max_tracking_error_rad: f64,
    /// Joints whose torque the twin clipped.
    pub torque_limit_hits: Vec<TorqueLimitHit>,
    /// Whether the twin did not perform the plan as planned (saturated torque or tracking
    /// error above [`TRACKING_ERROR_BOUND_RAD`](crate::validation::sweep::TRACKING_ERROR_BOUND_RAD)).
    pub flagged: bool,
}

/// A saving of one plan against the uniform one.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Saving {
    /// `100 (1 - E_plan / E_uniform)` from the model, %.
    pub predicted_saving_pct: f64,
    /// Half-width of its 95 % interval, percentage points (the two plans' intervals added: an
    /// upper bound whatever their correlation).
    pub interval_95_pct: f64,
    /// The same on the twin, %.
    pub simulated_saving_pct: f64,
    /// Whether the simulated saving lies within the predicted one's interval.
    pub within_interval: bool,
}

impl Saving {
    fn of(plan: &PlanCheck, uniform: &PlanCheck) -> Saving {
        let predicted = 100.0 * (1.0 - plan.predicted_j / uniform.predicted_j);
        let simulated = 100.0 * (1.0 - plan.simulated_j / uniform.simulated_j);
        let interval = 100.0 * (plan.interval_j + uniform.interval_j) / uniform.predicted_j;
        Saving {
            predicted_saving_pct: predicted,
            interval_95_pct: interval,
            simulated_saving_pct: simulated,
            within_interval: (predicted - simulated).abs() <= interval,
        }
    }
}

/// A plan to check: its task, schedule and name.
pub struct Candidate<'a> {
    /// Display name.
    pub name: &'a str,
    /// The task (possibly moved to another placement).
    pub task: Task<'a>,
    /// Its schedule.
    pub schedule: &'a Schedule,
}

/// An optimised plan on the twin and its saving against the uniform plan.
#[derive(Debug, Clone)]
pub struct CheckedPlan {
    /// The plan's twin run and prediction.
    pub check: PlanCheck,
    /// Its saving against the uniform plan.
    pub saving: Saving,
}

/// What the twin says of the plans.
pub struct Checked {
    /// The user's uniform plan.
    pub uniform: PlanCheck,
    /// The optimised plans, in the order given, with their savings against `uniform`.
    pub plans: Vec<CheckedPlan>,
    /// The twin runs: the uniform plan first, then the optimised ones.
    pub datasets: Vec<Dataset>,
    /// The planned runs, in the same order.
    pub runs: Vec<TaskRun>,
    /// The brake windows of each run, s.
    pub brakes: Vec<Vec<BrakeWindow>>,
}

/// One plan to run on the twin: its display name, its task and its planned schedule.
struct Job<'a> {
    /// Display name.
    name: String,
    /// The task (possibly moved to another placement).
    task: Task<'a>,
    /// The planned and priced run.
    plan: PlannedSchedule,
}

/// Run the uniform plan of `optimized` (on `task`) and every candidate plan on `rig` in
/// parallel. Errors: planning or twin errors; a flagged run is reported, not an error.
pub fn check(
    rig: &Rig,
    task: &Task,
    optimized: &Optimized,
    candidates: &[Candidate],
    progress: &dyn Progress,
) -> Result<Checked> {
    let brakes = rig.drive.brakes();
    progress.stage("optimised plans on the twin", candidates.len() + 1);
    let jobs = plan_jobs(task, optimized, candidates, brakes)?;
    let clipped = task.model.signal.clipped();
    let out: Vec<(PlanCheck, Dataset)> = jobs
        .par_iter()
        .enumerate()
        .map(|(k, job)| run_job(rig, k, job, clipped, progress))
        .collect::<Result<_>>()?;
    let (uniform, plans, datasets) = with_savings(out)?;
    let (runs, brakes): (Vec<TaskRun>, Vec<Vec<BrakeWindow>>) = jobs
        .into_iter()
        .map(|j| (j.plan.run, j.plan.brakes))
        .unzip();
    Ok(Checked {
        uniform,
        plans,
        datasets,
        runs,
        brakes,
    })
}

/// Plan and price the jobs: the user's uniform plan on `task` (servos on throughout) first,
/// then each candidate's schedule with the holding prices of `brakes`.
fn plan_jobs<'a>(
    task: &Task<'a>,
    optimized: &Optimized,
    candidates: &[Candidate<'a>],
    brakes: Option<&Brakes>,
) -> Result<Vec<Job<'a>>> {
    let uniform_run = task
        .scenario
        .plan(task.robot, optimized.uniform.speed_m_s, task.load_kg)?;
    let uniform_p = predict_run(task, &uniform_run)?;
    let mut jobs = vec![Job {
        name: "uniform".to_string(),
        task: *task,
        plan: PlannedSchedule {
            run: uniform_run,
            brakes: Vec::new(),
            predicted_j: uniform_p.energy_j,
            interval_j: uniform_p.interval_j,
        },
    }];
    for c in candidates {
        let prices = WaitPrices::new(&c.task, brakes)?;
        jobs.push(Job {
            name: c.name.to_string(),
            task: c.task,
            plan: plan_schedule(&c.task, c.schedule, &prices)?,
        });
    }
    Ok(jobs)
}

/// Run job `k` on the twin (its own noise seed) and compare its predicted energy with the
/// twin's: the grid-side energy when the model's signal is `clipped`, else the motor sum, J.
fn run_job(
    rig: &Rig,
    k: usize,
    job: &Job,
    clipped: bool,
    progress: &dyn Progress,
) -> Result<(PlanCheck, Dataset)> {
    let Job {
        name,
        task: t,
        plan,
    } = job;
    let description = serde_json::json!({
        "kind": "optimised task check",
        "plan": name,
        "scenario": t.scenario.name,
        "load_kg": t.load_kg,
    });
    let run = &plan.run;
    let windows = &plan.brakes;
    let (ds, report) = rig.run_reported(
        &run.motion.trajectory,
        &run.events,
        windows,
        300 + k as u64,
        description,
    )?;
    let braked_s: f64 = windows.iter().map(|w| w.end_s - w.start_s).sum();
    let predicted_j = plan.predicted_j;
    let sim = &ds.meta.summary;
    let simulated_j = if clipped {
        sim.energy_grid_j
    } else {
        sim.energy_total_j
    };
    progress.advance();
    Ok((
        PlanCheck {
            name: name.clone(),
            cycle_time_s: run.motion.duration_s,
            predicted_j,
            interval_j: plan.interval_j,
            simulated_j,
            error_pct: energy_error_pct(predicted_j, simulated_j),
            braked_s,
            flagged: run_flagged(&report),
            max_tracking_error_rad: report.max_tracking_error_rad,
            torque_limit_hits: report.torque_limit_hits,
        },
        ds,
    ))
}

/// Split the twin's checks, uniform plan first, into the uniform plan, the other plans with
/// their savings against it, and the datasets in the same order.
fn with_savings(
    out: Vec<(PlanCheck, Dataset)>,
) -> Result<(PlanCheck, Vec<CheckedPlan>, Vec<Dataset>)> {
    let mut checks = Vec::with_capacity(out.len());
    let mut datasets = Vec::with_capacity(out.len());
    for (c, d) in out {
        checks.push(c);
        datasets.push(d);
    }
    let mut it = checks.into_iter();
    let uniform = it
        .next()
        .ok_or_else(|| Error::Numerical("no plan checked".into()))?;
    let plans = it
        .map(|c| {
            let saving = Saving::of(&c, &uniform);
            CheckedPlan { check: c, saving }
        })
        .collect();
    Ok((uniform, plans, datasets))
}
