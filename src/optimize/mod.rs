//! Energy-optimal tasks: the cheapest way an identified model knows to do the same job in the
//! same cycle time.
//!
//! * [`segment`]: every segment of a task timed at a grid of TCP speeds and accelerations,
//!   planned and priced with the model.
//! * [`schedule`]: one timing per segment and one wait (servos or brakes) under a cycle-time
//!   bound, by an exact dynamic programme; the least energy at every cycle time.
//! * [`placement`]: where in the workspace the same task costs least.
//! * [`speed`]: the least energy on a uniform-speed sweep's actual (kinked) curve.
//! * [`priced`]: the plans' energies as reported, with the twin's or from the model alone.
//!
//! [`optimize`] runs the first two against the user's uniform-speed plan. Only the model and
//! data-sheet values price a plan; the twin checks the result
//! ([`crate::validation::optimized`]).

pub mod placement;
pub mod priced;
pub mod schedule;
pub mod segment;
pub mod speed;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::model::drive::{BrakeWindow, Brakes};
use crate::trajectory::task::TaskRun;

use schedule::{Schedule, Scheduler, WaitPrices};
use segment::{Candidate, Grid, PREDICTION_STEP_S, Task};

/// The cycle-time bound of an optimisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CycleBound {
    /// At most this cycle time, s.
    Seconds(f64),
    /// At most this many percent slower than the uniform reference plan (0: the same cycle
    /// time).
    SlowdownPct(f64),
}

/// A point of the least-energy curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrontPoint {
    /// Cycle time, s.
    pub cycle_time_s: f64,
    /// Least predicted energy per cycle at that cycle time, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
}

/// A uniform-speed plan of the task (every segment at one commanded speed).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct UniformPoint {
    /// Commanded TCP speed, m/s.
    pub speed_m_s: f64,
    /// Cycle time, s.
    pub cycle_time_s: f64,
    /// Predicted energy per cycle, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// Half-width of its 95 % interval, J.
    #[serde(rename = "interval_95_J")]
    pub interval_j: f64,
}

/// Options of [`optimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Speeds and accelerations every segment is tried at.
    pub grid: Grid,
    /// The least-energy curve spans cycle times from the fastest timing to this multiple of
    /// the bound.
    pub front_span: f64,
    /// Points on that curve.
    pub front_points: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            grid: Grid::standard(),
            front_span: 2.0,
            front_points: 40,
        }
    }
}

/// What [`optimize`] found.
#[derive(Debug, Clone)]
pub struct Optimized {
    /// The user's plan: every segment at the reference speed, no wait.
    pub uniform: UniformPoint,
    /// The cycle-time bound used, s.
    pub bound_s: f64,
    /// The cheapest schedule within the bound.
    pub schedule: Schedule,
    /// The candidates of every segment (undominated ones).
    pub candidates: Vec<Vec<Candidate>>,
    /// Least predicted energy against cycle time.
    pub front: Vec<FrontPoint>,
    /// Uniform-speed plans at the grid's speeds.
    pub uniform_curve: Vec<UniformPoint>,
}

/// Optimise the timing of `task` under `bound`, against the uniform plan at
/// `reference_speed_m_s` (m/s). `brakes` is the drive file's brakes-applied mode (`None`: the
/// servos hold every wait).
///
/// Errors: a bad reference speed, bound or grid; an unplannable task; a bound shorter than the
/// fastest timing.
pub fn optimize(
    task: &Task,
    reference_speed_m_s: f64,
    bound: CycleBound,
    brakes: Option<&Brakes>,
    opts: &Options,
) -> Result<Optimized> {
    let uniform = uniform_point(task, reference_speed_m_s)?;
    let bound_s = match bound {
        CycleBound::Seconds(s) if s.is_finite() && s > 0.0 => s,
        CycleBound::SlowdownPct(p) if p.is_finite() && p >= 0.0 => {
            uniform.cycle_time_s * (1.0 + p / 100.0)
        }
        other => {
            return Err(Error::InvalidInput(format!(
                "cycle-time bound {other:?} must be finite and positive (a slowdown >= 0 %)"
            )));
        }
    };
    if !(opts.front_span.is_finite() && opts.front_span >= 1.0 && opts.front_points >= 2) {
        return Err(Error::InvalidInput(
            "the least-energy curve needs a span >= 1 and at least 2 points".into(),
        ));
    }
    let mut grid = opts.grid.clone();
    grid.speeds_m_s.push(reference_speed_m_s);
    let mut candidates = segment::candidates(task, &grid)?;
    let prices = WaitPrices::new(task, brakes)?;
    let horizon = bound_s * opts.front_span;
    // Refine around the grid's optimum once, then schedule over all candidates.
    if let Ok(first) = Scheduler::new(&candidates, &prices, horizon)?.within(bound_s) {
        segment::refine(task, &first.segments, &mut candidates)?;
    }
    let scheduler = Scheduler::new(&candidates, &prices, horizon)?;
    // The uniform plan itself, waiting for the rest of the bound: the optimum is never worse
    // (the dynamic programme rounds durations up to whole slots, which can exclude it). The
    // two are compared as the user gets them, planned as whole motions (their segments'
    // sums differ from that by up to 0.1 J on the built-in and the Panda's pick and place).
    let reference = reference_schedule(task, reference_speed_m_s, bound_s, &prices)?;
    let schedule = match (scheduler.within(bound_s), reference) {
        (Ok(s), Some(r)) => {
            let whole = |x: &Schedule| plan_schedule(task, x, &prices).map(|p| p.predicted_j);
            if whole(&s)? < whole(&r)? { s } else { r }
        }
        (Ok(s), None) => s,
        (Err(_), Some(r)) => r,
        (Err(e), None) => return Err(e),
    };
    // Durations are rounded up to whole slots, so the fastest combination needs a little
    // more than the sum of the fastest durations.
    let lo = scheduler.fastest_s() + schedule::SLOT_S * candidates.len() as f64;
    let front = (0..opts.front_points)
        .map(|i| {
            let t = lo + (horizon - lo) * i as f64 / (opts.front_points - 1) as f64;
            scheduler.within(t).map(|s| FrontPoint {
                cycle_time_s: t,
                predicted_j: s.predicted_j,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let uniform_curve = opts
        .grid
        .speeds_m_s
        .iter()
        .filter_map(|&v| uniform_point(task, v).ok())
        .filter(|u| u.cycle_time_s <= horizon)
        .collect();
    Ok(Optimized {
        uniform,
        bound_s,
        schedule,
        candidates,
        front,
        uniform_curve,
    })
}

/// The uniform plan at `speed_m_s` (m/s) as a schedule within `bound_s` (s): every segment
/// at that speed and the full acceleration, and the cheapest wait for the rest; `None` when it
/// takes longer than the bound.
fn reference_schedule(
    task: &Task,
    speed_m_s: f64,
    bound_s: f64,
    prices: &WaitPrices,
) -> Result<Option<Schedule>> {
    let grid = Grid {
        speeds_m_s: vec![speed_m_s],
        accel_fractions: vec![1.0],
    };
    let segments: Vec<Candidate> = segment::candidates(task, &grid)?
        .into_iter()
        .map(|c| c[0])
        .collect();
    let motion_s: f64 = segments.iter().map(|c| c.duration_s).sum();
    // The segments' durations, summed, can pass the plan's own by a rounding error (the
    // uniform plan at its own cycle time was excluded so, and a dearer schedule returned).
    if motion_s > bound_s * (1.0 + 1e-9) {
        return Ok(None);
    }
    let wait = prices.cheapest((bound_s - motion_s).max(0.0));
    let predicted_j = segments.iter().map(|c| c.energy_j).sum::<f64>() + wait.energy_j;
    Ok(Some(Schedule {
        segments,
        wait,
        cycle_time_s: motion_s + wait.duration_s,
        predicted_j,
    }))
}

/// A schedule planned as one motion ([`crate::trajectory::task::Scenario::plan_timed`]) and
/// priced by the model.
pub struct PlannedSchedule {
    /// The planned run.
    pub run: TaskRun,
    /// Where the brakes hold the arm, s.
    pub brakes: Vec<BrakeWindow>,
    /// Predicted energy per cycle, J: the motion with the servos on throughout, less the
    /// holding power the brakes save in their windows (at the brakes-applied power instead).
    pub predicted_j: f64,
    /// Half-width of its 95 % interval, J.
    pub interval_j: f64,
}

/// Plan `schedule` of `task` as one motion and price it; `prices` gives the holding power of
/// its wait and the brakes-applied mode.
///
/// Errors: an unplannable timing; a prediction that fails.
pub fn plan_schedule(
    task: &Task,
    schedule: &Schedule,
    prices: &WaitPrices,
) -> Result<PlannedSchedule> {
    let run = task
        .scenario
        .plan_timed(task.robot, &schedule.timings(), task.load_kg)?;
    let brakes = schedule.brake_windows(&run.motion.arrivals_s, prices.brakes.as_ref());
    let braked_s: f64 = brakes.iter().map(|w| w.end_s - w.start_s).sum();
    let saved_w = match &prices.brakes {
        Some(b) if braked_s > 0.0 => prices.hold_w[schedule.wait.after_segment] - b.power_w,
        _ => 0.0,
    };
    let p = predict_run(task, &run)?;
    Ok(PlannedSchedule {
        run,
        brakes,
        predicted_j: p.energy_j - saved_w * braked_s,
        interval_j: p.interval_j,
    })
}

/// The uniform plan at `speed_m_s` (m/s), predicted.
pub fn uniform_point(task: &Task, speed_m_s: f64) -> Result<UniformPoint> {
    let run = task.scenario.plan(task.robot, speed_m_s, task.load_kg)?;
    let p = predict_run(task, &run)?;
    Ok(UniformPoint {
        speed_m_s,
        cycle_time_s: run.motion.duration_s,
        predicted_j: p.energy_j,
        interval_j: p.interval_j,
    })
}

/// The model's prediction of a planned run (servos on throughout).
pub fn predict_run(task: &Task, run: &TaskRun) -> Result<crate::identification::model::Prediction> {
    predict_motion(task, &run.motion, &run.events)
}

/// The model's prediction of a planned `motion` with the payload timeline `events` (servos on
/// throughout).
pub fn predict_motion(
    task: &Task,
    motion: &crate::trajectory::linear_move::LinearMotion,
    events: &[crate::model::payload::PayloadEvent],
) -> Result<crate::identification::model::Prediction> {
    task.model.predict(
        task.robot,
        &motion.trajectory,
        events,
        task.efficiency,
        PREDICTION_STEP_S,
    )
}
