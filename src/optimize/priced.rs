//! What an optimisation reports of its plans: the chosen timing per segment, the model's
//! price of each plan, and the twin's energy when a twin checked it ([`crate::validation::optimized::check`]); with no twin
//! (`optimize --twin none`) the plans are priced by the model alone, as the twin check prices
//! them.

use serde::Serialize;

use crate::error::Result;
use crate::model::drive::Brakes;
use crate::optimize::schedule::{Schedule, WaitMode, WaitPrices};
use crate::optimize::segment::Task;
use crate::optimize::{Optimized, plan_schedule, predict_run};
use crate::validation::optimized::{Candidate, Checked, PlanCheck};

/// One plan: the model's price, and the twin's energy when a twin ran.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanEnergy {
    /// Which plan ("uniform", "optimized", ...).
    pub name: String,
    /// Cycle time, s.
    pub cycle_time_s: f64,
    /// Predicted energy per cycle (the model's signal), J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// Half-width of its 95 % interval, J.
    #[serde(rename = "interval_95_J")]
    pub interval_j: f64,
    /// Energy of the same signal on the twin, J; `None` (absent) when no twin ran.
    #[serde(rename = "simulated_J", skip_serializing_if = "Option::is_none")]
    pub simulated_j: Option<f64>,
    /// Time the brakes hold the arm, s.
    pub braked_s: f64,
}

/// The saving of one plan against the uniform one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlanSaving {
    /// `100 (1 - E_plan / E_uniform)` from the model, %.
    pub predicted_saving_pct: f64,
    /// Half-width of its 95 % interval, percentage points (the two plans' intervals added).
    pub interval_95_pct: f64,
    /// The same on the twin, %; `None` (absent) when no twin ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub simulated_saving_pct: Option<f64>,
    /// Whether the simulated saving lies within the predicted one's interval; `None` (absent)
    /// when no twin ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub within_interval: Option<bool>,
}

/// The uniform plan and the optimised ones, each with its saving against the uniform one.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanEnergies {
    /// The user's uniform plan.
    pub uniform: PlanEnergy,
    /// The optimised plans, in the order given, with their savings.
    pub plans: Vec<(PlanEnergy, PlanSaving)>,
}

impl PlanEnergy {
    fn of_check(c: &PlanCheck) -> PlanEnergy {
        PlanEnergy {
            name: c.name.clone(),
            cycle_time_s: c.cycle_time_s,
            predicted_j: c.predicted_j,
            interval_j: c.interval_j,
            simulated_j: Some(c.simulated_j),
            braked_s: c.braked_s,
        }
    }
}

impl PlanEnergies {
    /// The plans as the twin checked them (the numbers of `checked`, unchanged).
    pub fn from_twin(checked: &Checked) -> PlanEnergies {
        PlanEnergies {
            uniform: PlanEnergy::of_check(&checked.uniform),
            plans: checked
                .plans
                .iter()
                .map(|p| {
                    let s = &p.saving;
                    (
                        PlanEnergy::of_check(&p.check),
                        PlanSaving {
                            predicted_saving_pct: s.predicted_saving_pct,
                            interval_95_pct: s.interval_95_pct,
                            simulated_saving_pct: Some(s.simulated_saving_pct),
                            within_interval: Some(s.within_interval),
                        },
                    )
                })
                .collect(),
        }
    }

    /// Price the uniform plan of `optimized` (on `task`) and every candidate with the model
    /// alone, as [`crate::validation::optimized::check`] prices them (no twin runs); `brakes`
    /// is the drive's brakes-applied mode.
    ///
    /// Errors: planning or prediction errors.
    pub fn priced(
        task: &Task,
        optimized: &Optimized,
        candidates: &[Candidate],
        brakes: Option<&Brakes>,
    ) -> Result<PlanEnergies> {
        let run = task
            .scenario
            .plan(task.robot, optimized.uniform.speed_m_s, task.load_kg)?;
        let p = predict_run(task, &run)?;
        let uniform = PlanEnergy {
            name: "uniform".into(),
            cycle_time_s: run.motion.duration_s,
            predicted_j: p.energy_j,
            interval_j: p.interval_j,
            simulated_j: None,
            braked_s: 0.0,
        };
        let plans = candidates
            .iter()
            .map(|c| {
                let prices = WaitPrices::new(&c.task, brakes)?;
                let planned = plan_schedule(&c.task, c.schedule, &prices)?;
                let plan = PlanEnergy {
                    name: c.name.to_string(),
                    cycle_time_s: planned.run.motion.duration_s,
                    predicted_j: planned.predicted_j,
                    interval_j: planned.interval_j,
                    simulated_j: None,
                    braked_s: planned
                        .brakes
                        .iter()
                        .map(|w| w.end_s - w.start_s)
                        .sum::<f64>()
                        .max(0.0),
                };
                let saving = PlanSaving {
                    predicted_saving_pct: 100.0 * (1.0 - plan.predicted_j / uniform.predicted_j),
                    interval_95_pct: 100.0 * (plan.interval_j + uniform.interval_j)
                        / uniform.predicted_j,
                    simulated_saving_pct: None,
                    within_interval: None,
                };
                Ok((plan, saving))
            })
            .collect::<Result<_>>()?;
        Ok(PlanEnergies { uniform, plans })
    }
}

/// One segment of a schedule, named by its via points.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScheduledSegment {
    /// Via point the segment starts at.
    pub from: String,
    /// Via point it ends at.
    pub to: String,
    /// Commanded TCP speed, m/s.
    pub speed_m_s: f64,
    /// TCP acceleration bound, m/s^2.
    pub accel_m_s2: f64,
    /// Duration of the move, s.
    pub duration_s: f64,
    /// Predicted energy of the move, J (the model's signal).
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// Whether the planner slowed the move for a joint limit.
    pub slowed_for_joint_limit: bool,
    /// The wait at its end, s (0 but at the schedule's wait).
    pub dwell_s: f64,
    /// How the arm waits there: `none`, `hold` (servos) or `brakes`.
    pub dwell_mode: &'static str,
}

/// The segments of `schedule` with the via points of `path` (the scenario's path: one more
/// name than segments) and the wait at the end of its segment.
pub fn scheduled_segments(path: &[String], schedule: &Schedule) -> Vec<ScheduledSegment> {
    let wait = &schedule.wait;
    schedule
        .segments
        .iter()
        .zip(path.windows(2))
        .enumerate()
        .map(|(k, (c, ends))| {
            let waits = k == wait.after_segment && wait.duration_s > 0.0;
            ScheduledSegment {
                from: ends[0].clone(),
                to: ends[1].clone(),
                speed_m_s: c.speed_m_s,
                accel_m_s2: c.accel_m_s2,
                duration_s: c.duration_s,
                predicted_j: c.energy_j,
                slowed_for_joint_limit: c.slowed,
                dwell_s: if waits { wait.duration_s } else { 0.0 },
                dwell_mode: match (waits, wait.mode) {
                    (false, _) => "none",
                    (true, WaitMode::Hold) => "hold",
                    (true, WaitMode::Brakes) => "brakes",
                },
            }
        })
        .collect()
}
