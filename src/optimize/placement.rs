//! Where the same task costs least: the whole task moved within a box around the user's
//! placement (via points translated, and rotated about the base z axis), each placement priced
//! by the model as the uniform plan at the reference speed, with the servos holding the arm
//! for the rest of the cycle-time bound.
//!
//! # Method
//! A coarse grid over the box (3 values per searched axis, in parallel), then a compass
//! search from the best grid point: each axis is stepped by half the grid spacing both ways,
//! the step halves when no neighbour improves, down to 1/32 of the box. Placements where a
//! via point is out of reach, a segment cannot follow or the cycle time exceeds the bound are
//! infeasible and skipped. Like any local search it finds a good placement, not provably the
//! best; the grid start keeps it from the nearest local minimum only.

use nalgebra::Vector3;
use rayon::prelude::*;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::trajectory::task::Scenario;

use super::schedule::WaitPrices;
use super::segment::Task;

/// Half-widths of the searched box around the user's placement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchBox {
    /// Translation half-widths along base x, y, z, m (>= 0).
    pub half_m: [f64; 3],
    /// Rotation half-width about the base z axis, rad (>= 0).
    pub half_yaw_rad: f64,
}

impl SearchBox {
    fn check(&self) -> Result<()> {
        let all = [
            self.half_m[0],
            self.half_m[1],
            self.half_m[2],
            self.half_yaw_rad,
        ];
        if all.iter().any(|v| !(v.is_finite() && *v >= 0.0)) || all.iter().all(|v| *v == 0.0) {
            return Err(Error::InvalidInput(format!(
                "search box {:?} m, {} rad: half-widths must be finite, >= 0 and not all 0",
                self.half_m, self.half_yaw_rad
            )));
        }
        Ok(())
    }

    fn half(&self) -> [f64; 4] {
        [
            self.half_m[0],
            self.half_m[1],
            self.half_m[2],
            self.half_yaw_rad,
        ]
    }
}

/// A placement of the task and its price.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Placement {
    /// Translation of the task in the base frame, m.
    pub offset_m: [f64; 3],
    /// Rotation of the task about the base z axis, deg.
    pub yaw_deg: f64,
    /// Cycle time of the uniform plan there, s.
    pub cycle_time_s: f64,
    /// Predicted energy per cycle (uniform plan, then holding until the bound), J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
}

/// Result of a placement search.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlacementSearch {
    /// The user's placement (no offset).
    pub user: Placement,
    /// The cheapest placement found.
    pub best: Placement,
    /// Placements priced.
    pub evaluated: usize,
    /// Of which infeasible (unreachable, too slow, or beyond the bound).
    pub infeasible: usize,
}

impl PlacementSearch {
    /// The task moved to the best placement.
    pub fn moved(&self, scenario: &Scenario) -> Scenario {
        moved(scenario, &self.best)
    }
}

fn moved(scenario: &Scenario, p: &Placement) -> Scenario {
    scenario.moved(&Vector3::from(p.offset_m), p.yaw_deg.to_radians())
}

/// Search `area` around the user's placement of `task` for the least predicted energy of the
/// uniform plan at `speed_m_s` (m/s) within `bound_s` (s). Errors: a bad box; the user's own
/// placement infeasible.
pub fn search(
    task: &Task,
    speed_m_s: f64,
    bound_s: f64,
    area: &SearchBox,
) -> Result<PlacementSearch> {
    area.check()?;
    let half = area.half();
    let pricer = Pricer {
        task,
        speed_m_s,
        bound_s,
    };
    let user = pricer.price([0.0; 4]).ok_or_else(|| {
        Error::InvalidInput(format!(
            "the task at the user's placement does not plan at {speed_m_s} m/s within \
             {bound_s:.3} s"
        ))
    })?;
    let found = grid_search(&pricer, &half, user);
    let found = compass_search(&pricer, &half, found);
    Ok(PlacementSearch {
        user,
        best: found.best,
        evaluated: found.evaluated,
        infeasible: found.infeasible,
    })
}

/// Prices placements of a task: the uniform plan at `speed_m_s` (m/s), then holding until
/// `bound_s` (s).
struct Pricer<'a> {
    /// The task at the user's placement.
    task: &'a Task<'a>,
    /// TCP speed of the uniform plan, m/s.
    speed_m_s: f64,
    /// Cycle-time bound, s.
    bound_s: f64,
}

impl Pricer<'_> {
    /// The placement at `x` (offset along base x, y, z in m, yaw about base z in rad) and its
    /// predicted energy per cycle, J; `None` when infeasible (the plan fails, exceeds the
    /// bound or cannot be priced).
    fn price(&self, x: [f64; 4]) -> Option<Placement> {
        let task = self.task;
        let p = Placement {
            offset_m: [x[0], x[1], x[2]],
            yaw_deg: x[3].to_degrees(),
            cycle_time_s: 0.0,
            predicted_j: 0.0,
        };
        let sc = moved(task.scenario, &p);
        let t = Task {
            scenario: &sc,
            ..*task
        };
        let run = sc.plan(task.robot, self.speed_m_s, task.load_kg).ok()?;
        let cycle = run.motion.duration_s;
        if cycle > self.bound_s {
            return None;
        }
        let e = super::predict_run(&t, &run).ok()?.energy_j;
        let hold = WaitPrices::new(&t, None)
            .ok()?
            .cheapest(self.bound_s - cycle)
            .energy_j;
        Some(Placement {
            cycle_time_s: cycle,
            predicted_j: e + hold,
            ..p
        })
    }
}

/// The cheapest placement found so far and the placements priced to find it.
struct Found {
    /// The cheapest placement.
    best: Placement,
    /// Placements priced.
    evaluated: usize,
    /// Of which infeasible.
    infeasible: usize,
}

/// The coarse grid: `-h`, `0`, `+h` on every searched axis of the box `half` (m, m, m, rad),
/// priced in parallel; the cheapest of them and `user`.
fn grid_search(pricer: &Pricer, half: &[f64; 4], user: Placement) -> Found {
    let axes: Vec<Vec<f64>> = half
        .iter()
        .map(|&h| if h > 0.0 { vec![-h, 0.0, h] } else { vec![0.0] })
        .collect();
    let mut grid = vec![[0.0; 4]];
    for (i, values) in axes.iter().enumerate() {
        grid = grid
            .iter()
            .flat_map(|g| {
                values.iter().map(move |&v| {
                    let mut x = *g;
                    x[i] = v;
                    x
                })
            })
            .collect();
    }
    let priced: Vec<Option<Placement>> = grid.par_iter().map(|&x| pricer.price(x)).collect();
    let infeasible = priced.iter().filter(|p| p.is_none()).count();
    let best =
        priced.into_iter().flatten().fold(
            user,
            |b, p| if p.predicted_j < b.predicted_j { p } else { b },
        );
    Found {
        best,
        evaluated: grid.len(),
        infeasible,
    }
}

/// The compass search from `found`: each searched axis of the box `half` (m, m, m, rad)
/// stepped both ways by half the grid spacing, the step halved when no neighbour improves,
/// until every step is at most 1/32 of its half-width.
fn compass_search(pricer: &Pricer, half: &[f64; 4], found: Found) -> Found {
    let Found {
        mut best,
        mut evaluated,
        mut infeasible,
    } = found;
    let mut step: [f64; 4] = half.map(|h| 0.5 * h);
    while step
        .iter()
        .zip(half)
        .any(|(s, h)| *h > 0.0 && *s > h / 32.0)
    {
        let x0 = coords(&best);
        let moves: Vec<[f64; 4]> = (0..4)
            .filter(|&i| half[i] > 0.0)
            .flat_map(|i| {
                [-1.0, 1.0].into_iter().map(move |sgn| {
                    let mut x = x0;
                    x[i] = (x[i] + sgn * step[i]).clamp(-half[i], half[i]);
                    x
                })
            })
            .collect();
        let priced: Vec<Option<Placement>> = moves.par_iter().map(|&x| pricer.price(x)).collect();
        evaluated += moves.len();
        infeasible += priced.iter().filter(|p| p.is_none()).count();
        match priced
            .into_iter()
            .flatten()
            .filter(|p| p.predicted_j < best.predicted_j)
            .min_by(|a, b| a.predicted_j.total_cmp(&b.predicted_j))
        {
            Some(p) => best = p,
            None => step = step.map(|s| 0.5 * s),
        }
    }
    Found {
        best,
        evaluated,
        infeasible,
    }
}

/// The search coordinates of placement `p`: offset along base x, y, z in m, yaw about base z
/// in rad.
fn coords(p: &Placement) -> [f64; 4] {
    [
        p.offset_m[0],
        p.offset_m[1],
        p.offset_m[2],
        p.yaw_deg.to_radians(),
    ]
}
