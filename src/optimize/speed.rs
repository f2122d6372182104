//! The energy-optimal uniform speed of a task: the least predicted energy on the actual
//! energy-against-speed curve, which has kinks where the planner starts slowing a segment for
//! a joint limit (above such a speed the segment no longer gets faster, so energy can only
//! rise or stay). A search that assumes one smooth minimum lands on such a kink; this one
//! samples the curve densely, refines only inside the best sample's bracket, and says when the
//! optimum sits on a planner limit.

use rayon::prelude::*;
use serde::Serialize;

use crate::error::{Error, Result};

use super::segment::Task;
use crate::trajectory::linear_move::LinearMotion;

/// Speeds sampled across the range, evenly in log speed.
const SAMPLES: usize = 24;
/// Refinement stops when the bracket spans less than this ratio of speeds.
const REFINE_RATIO: f64 = 1.005;
/// Relative speed step used to tell whether the optimum sits on a planner limit.
const KINK_STEP: f64 = 0.01;

/// The least-energy uniform speed of one load level.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SpeedOptimum {
    /// Load level, kg.
    pub load_kg: f64,
    /// Commanded TCP speed of least predicted energy, m/s.
    pub speed_m_s: f64,
    /// Predicted energy there, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// Cycle time there, s.
    pub cycle_time_s: f64,
    /// Segments the planner slows for joint limits at that speed.
    pub slowed_segments: usize,
    /// Whether the optimum sits where the planner starts slowing another segment (1 % slower
    /// or faster changes the number of slowed segments): the minimum is a kink of the curve,
    /// set by a joint limit rather than by the energy trade-off.
    pub on_planner_limit: bool,
    /// Whether it lies at an end of the searched range.
    pub at_range_end: bool,
}

/// The least predicted energy of each of `tasks` (one task, robot and model at several load
/// levels) at uniform speeds in `[lo_m_s, hi_m_s]` (m/s), in the order given. The motion at a
/// speed does not depend on the load, so the sampled speeds are planned once for all loads.
/// Errors: a bad range, tasks of different robots or scenarios, or a load with no speed in
/// the range that plans.
pub fn least_energy(tasks: &[Task], lo_m_s: f64, hi_m_s: f64) -> Result<Vec<SpeedOptimum>> {
    if !(lo_m_s.is_finite() && lo_m_s > 0.0 && hi_m_s >= lo_m_s && hi_m_s.is_finite()) {
        return Err(Error::InvalidInput(format!(
            "speed range [{lo_m_s}, {hi_m_s}] m/s must be finite, positive and ordered"
        )));
    }
    let Some(first) = tasks.first() else {
        return Ok(Vec::new());
    };
    if tasks
        .iter()
        .any(|t| t.robot != first.robot || t.scenario != first.scenario)
    {
        return Err(Error::InvalidInput(
            "the speed search takes the tasks of one robot and one scenario".into(),
        ));
    }
    let (a, b) = (lo_m_s.ln(), hi_m_s.ln());
    let xs: Vec<f64> = (0..SAMPLES)
        .map(|k| a + (b - a) * k as f64 / (SAMPLES - 1) as f64)
        .collect();
    let (robot, scenario) = (first.robot, first.scenario);
    let plan = |ln_v: f64| scenario.plan_motion(robot, &scenario.uniform(ln_v.exp()));
    let motions: Vec<Option<LinearMotion>> = xs.par_iter().map(|&x| plan(x).ok()).collect();
    tasks
        .par_iter()
        .map(|task| {
            let energy_of = |motion: &LinearMotion| -> Result<(f64, f64, usize)> {
                let events = scenario.payload_events(&motion.arrivals_s, task.load_kg)?;
                let p = super::predict_motion(task, motion, &events)?;
                Ok((p.energy_j, motion.duration_s, motion.slowed.len()))
            };
            let ys: Vec<Option<(f64, f64, usize)>> = motions
                .par_iter()
                .map(|m| m.as_ref().and_then(|m| energy_of(m).ok()))
                .collect();
            search(
                task,
                &xs,
                &ys,
                |x| energy_of(&plan(x)?),
                (a, b),
                (lo_m_s, hi_m_s),
            )
        })
        .collect()
}

/// The optimum of `task` from its energies `ys` (J, with cycle time, s, and slowed segments)
/// sampled at the log speeds `xs`, refined with `energy` (the same of a log speed) inside the
/// best sample's bracket; `(a, b)` is the searched range in log speed, `(lo_m_s, hi_m_s)` in
/// m/s.
fn search(
    task: &Task,
    xs: &[f64],
    ys: &[Option<(f64, f64, usize)>],
    energy: impl Fn(f64) -> Result<(f64, f64, usize)>,
    (a, b): (f64, f64),
    (lo_m_s, hi_m_s): (f64, f64),
) -> Result<SpeedOptimum> {
    let best = (0..SAMPLES)
        .filter(|&k| ys[k].is_some())
        .min_by(|&i, &j| {
            let e = |k: usize| ys[k].map_or(f64::INFINITY, |y| y.0);
            e(i).total_cmp(&e(j))
        })
        .ok_or_else(|| {
            Error::InvalidInput(format!(
                "no speed in [{lo_m_s}, {hi_m_s}] m/s plans for load {} kg",
                task.load_kg
            ))
        })?;
    // Golden-section search inside the best sample's bracket; kinks elsewhere cannot mislead
    // it, and inside the bracket the best of all evaluated points is kept.
    let (mut lo, mut hi) = (xs[best.saturating_sub(1)], xs[(best + 1).min(SAMPLES - 1)]);
    let mut top = (xs[best], ys[best].expect("filtered"));
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let eval = |x: f64, top: &mut (f64, (f64, f64, usize))| -> f64 {
        match energy(x) {
            Ok(y) => {
                if y.0 < top.1.0 {
                    *top = (x, y);
                }
                y.0
            }
            Err(_) => f64::INFINITY,
        }
    };
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (eval(x1, &mut top), eval(x2, &mut top));
    while hi - lo > REFINE_RATIO.ln() {
        if f1 <= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = eval(x1, &mut top);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = eval(x2, &mut top);
        }
    }
    let (x, (e, cycle, slowed)) = top;
    let count = |x: f64| energy(x).ok().map(|y| y.2);
    let on_planner_limit = [x - KINK_STEP, x + KINK_STEP]
        .iter()
        .any(|&y| count(y).is_some_and(|c| c != slowed));
    Ok(SpeedOptimum {
        load_kg: task.load_kg,
        speed_m_s: x.exp(),
        predicted_j: e,
        cycle_time_s: cycle,
        slowed_segments: slowed,
        on_planner_limit,
        at_range_end: (x - a).abs() < 1e-12 || (x - b).abs() < 1e-12,
    })
}
