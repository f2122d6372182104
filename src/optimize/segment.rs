//! The timing candidates of each segment of a task: every (TCP speed, acceleration) pair of a
//! grid, planned alone (segments start and end at rest, so they can be) and predicted with an
//! identified model, reduced to the ones no other candidate beats in both duration and
//! energy.
//!
//! Energies of rest-to-rest segments add up: the model's power depends only on the state and
//! the payload at each instant, and the wait between segments is priced separately
//! ([`super::schedule`]).

use rayon::prelude::*;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::identification::model::PowerModel;
use crate::model::Robot;
use crate::model::payload::{Payload, PayloadEvent};
use crate::trajectory::linear_move::{self, LinearMoveOptions, SegmentTiming};
use crate::trajectory::task::Scenario;

/// Integration step of the predicted energies, s. The predicted power is smooth along a
/// planned segment (jerk-limited, ramps of 0.1 s and longer), so the trapezoidal rule at 5 ms
/// integrates it to well below the model's own accuracy.
pub const PREDICTION_STEP_S: f64 = 0.005;

/// Commanded speeds tried per segment and acceleration once the planner slows the segment.
const SLOWED_TRIES: usize = 3;

/// The TCP speeds and acceleration fractions every segment is tried at.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Commanded TCP speeds, m/s (finite, > 0).
    pub speeds_m_s: Vec<f64>,
    /// Accelerations as fractions of the scenario's bound `accel_m_s2`, in (0, 1].
    pub accel_fractions: Vec<f64>,
}

impl Grid {
    /// 12 speeds spaced evenly in log speed from 0.15 to 2 m/s (the fast end is cut by the
    /// joint limits, which the planner reports as slowed segments) and 3 accelerations: the
    /// full bound, a half and a quarter. Slower moves are not worth pricing: a slow move costs
    /// the servos' standby and holding power for longer, which a wait with the brakes
    /// applied does cheaper.
    pub fn standard() -> Grid {
        let (lo, hi, n) = (0.15f64, 2.0f64, 12);
        Grid {
            speeds_m_s: (0..n)
                .map(|k| (lo.ln() + (hi / lo).ln() * k as f64 / (n - 1) as f64).exp())
                .collect(),
            accel_fractions: vec![1.0, 0.5, 0.25],
        }
    }

    fn check(&self) -> Result<()> {
        if self.speeds_m_s.is_empty() || self.accel_fractions.is_empty() {
            return Err(Error::InvalidInput(
                "the timing grid needs at least one speed and one acceleration".into(),
            ));
        }
        if let Some(v) = self
            .speeds_m_s
            .iter()
            .find(|v| !(v.is_finite() && **v > 0.0))
        {
            return Err(Error::InvalidInput(format!(
                "grid speed {v} m/s must be finite and positive"
            )));
        }
        if let Some(a) = self
            .accel_fractions
            .iter()
            .find(|a| !(**a > 0.0 && **a <= 1.0))
        {
            return Err(Error::InvalidInput(format!(
                "grid acceleration fraction {a} must be in (0, 1]"
            )));
        }
        Ok(())
    }
}

/// One way to time a segment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Candidate {
    /// Commanded TCP speed, m/s.
    pub speed_m_s: f64,
    /// TCP acceleration bound, m/s^2.
    pub accel_m_s2: f64,
    /// Duration of the move, s (after any slowing for the joint limits).
    pub duration_s: f64,
    /// Predicted energy of the move, J (the model's signal).
    #[serde(rename = "energy_J")]
    pub energy_j: f64,
    /// Whether the planner slowed the move below the commanded speed for a joint limit.
    pub slowed: bool,
}

impl Candidate {
    /// The segment timing of this candidate with `dwell_s` (s) at its end.
    pub fn timing(&self, dwell_s: f64) -> SegmentTiming {
        SegmentTiming {
            speed_m_s: self.speed_m_s,
            accel_m_s2: self.accel_m_s2,
            dwell_s,
        }
    }
}

/// A task to time, with the model that prices it.
#[derive(Clone, Copy)]
pub struct Task<'a> {
    /// The robot (no payload).
    pub robot: &'a Robot,
    /// The task.
    pub scenario: &'a Scenario,
    /// Load level, kg.
    pub load_kg: f64,
    /// The identified model and the nominal efficiency its known payloads are scaled with
    /// (efficiency-scaled models only).
    pub model: &'a PowerModel,
    /// Nominal drive efficiency for payloads, in (0, 1].
    pub efficiency: f64,
}

impl Task<'_> {
    /// What the flange carries on each segment.
    pub fn payloads(&self) -> Result<Vec<Option<Payload>>> {
        self.scenario.segment_payloads(self.load_kg)
    }
}

/// The candidates of every segment: each list sorted by duration, with energies strictly
/// falling (the dominated ones removed). Segments are planned and predicted in parallel.
///
/// Errors: a bad grid; a via point out of reach; a segment with no candidate that plans (its
/// planner error is returned); the model's errors.
pub fn candidates(task: &Task, grid: &Grid) -> Result<Vec<Vec<Candidate>>> {
    grid.check()?;
    let accel_bound = task.scenario.motion.limits.accel_m_s2;
    let mut speeds = grid.speeds_m_s.clone();
    speeds.sort_by(f64::total_cmp);
    let chains: Vec<Chain> = (0..task.scenario.segments())
        .flat_map(|k| {
            let speeds = &speeds;
            grid.accel_fractions.iter().map(move |&a| Chain {
                segment: k,
                accel_m_s2: a * accel_bound,
                speeds_m_s: speeds.clone(),
            })
        })
        .collect();
    let mut out: Vec<Vec<Candidate>> = vec![Vec::new(); task.scenario.segments()];
    price(task, &chains, &mut out)?;
    Ok(out)
}

/// Add candidates around each segment's timing in `chosen` (speeds 8 % and 16 % either side,
/// at its acceleration) to `lists`, which stay fronts. Grids are coarse; this refines the
/// optimum between their points.
pub fn refine(task: &Task, chosen: &[Candidate], lists: &mut [Vec<Candidate>]) -> Result<()> {
    let chains: Vec<Chain> = chosen
        .iter()
        .enumerate()
        .map(|(k, c)| Chain {
            segment: k,
            accel_m_s2: c.accel_m_s2,
            speeds_m_s: [0.84, 0.92, 1.08, 1.16]
                .iter()
                .map(|f| f * c.speed_m_s)
                .collect(),
        })
        .collect();
    price(task, &chains, lists)
}

/// Speeds (rising) to try one segment at, at one acceleration bound (m/s^2).
struct Chain {
    segment: usize,
    accel_m_s2: f64,
    speeds_m_s: Vec<f64>,
}

/// Plan and predict every chain in parallel and merge the candidates into `lists` (one per
/// segment), keeping each a front. A chain stops after [`SLOWED_TRIES`] slowed candidates:
/// once the planner slows the segment for a joint limit, higher commanded speeds give nearly
/// the same motion (the slowing depends a little on how far the commanded speed overshoots).
/// Errors: a segment that ends up without any candidate (its first planner error).
fn price(task: &Task, chains: &[Chain], lists: &mut [Vec<Candidate>]) -> Result<()> {
    let sc = task.scenario;
    let tcp = sc.tcp();
    let via = sc.via_poses();
    let configs =
        linear_move::via_configurations(task.robot, &tcp, &sc.seed_rad, &via, &sc.motion)?;
    let options = LinearMoveOptions {
        hold_joints: configs.hold_joints.clone(),
        ..sc.motion.clone()
    };
    let payloads = task.payloads()?;
    let one = |k: usize, speed: f64, accel: f64| -> Result<Candidate> {
        let timing = SegmentTiming {
            speed_m_s: speed,
            accel_m_s2: accel,
            dwell_s: 0.0,
        };
        let motion = linear_move::plan_timed(
            task.robot,
            &tcp,
            &configs.q[k],
            &via[k..=k + 1],
            &[timing],
            &options,
        )?;
        let events = [PayloadEvent {
            t_s: 0.0,
            payload: payloads[k].clone(),
        }];
        let p = task.model.predict(
            task.robot,
            &motion.trajectory,
            &events,
            task.efficiency,
            PREDICTION_STEP_S,
        )?;
        Ok(Candidate {
            speed_m_s: speed,
            accel_m_s2: accel,
            duration_s: motion.duration_s,
            energy_j: p.energy_j,
            slowed: !motion.slowed.is_empty(),
        })
    };
    let priced: Vec<(usize, Result<Candidate>)> = chains
        .par_iter()
        .flat_map_iter(|chain| {
            let mut out = Vec::new();
            let mut slowed = 0;
            for &v in &chain.speeds_m_s {
                let c = one(chain.segment, v, chain.accel_m_s2);
                slowed += usize::from(c.as_ref().is_ok_and(|c| c.slowed));
                out.push((chain.segment, c));
                if slowed == SLOWED_TRIES {
                    break;
                }
            }
            out
        })
        .collect();
    let mut first_error: Vec<Option<Error>> = (0..lists.len()).map(|_| None).collect();
    for (k, r) in priced {
        match r {
            Ok(c) => lists[k].push(c),
            Err(e) => {
                first_error[k].get_or_insert(e);
            }
        }
    }
    for (k, list) in lists.iter_mut().enumerate() {
        if list.is_empty() {
            return Err(first_error[k].take().unwrap_or_else(|| {
                Error::InvalidInput(format!("segment {} has no timing candidate", k + 1))
            }));
        }
        *list = front(std::mem::take(list));
    }
    Ok(())
}

/// The candidates no other one beats in both duration and energy, by rising duration.
fn front(mut list: Vec<Candidate>) -> Vec<Candidate> {
    list.sort_by(|a, b| {
        a.duration_s
            .total_cmp(&b.duration_s)
            .then(a.energy_j.total_cmp(&b.energy_j))
    });
    let mut out: Vec<Candidate> = Vec::new();
    for c in list {
        if out.last().is_none_or(|l| c.energy_j < l.energy_j) {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(d: f64, e: f64) -> Candidate {
        Candidate {
            speed_m_s: 1.0,
            accel_m_s2: 1.0,
            duration_s: d,
            energy_j: e,
            slowed: false,
        }
    }

    #[test]
    fn the_front_keeps_only_undominated_candidates() {
        let f = front(vec![
            c(2.0, 5.0),
            c(1.0, 9.0),
            c(1.5, 9.5),
            c(3.0, 6.0),
            c(2.5, 4.0),
        ]);
        let pts: Vec<(f64, f64)> = f.iter().map(|c| (c.duration_s, c.energy_j)).collect();
        assert_eq!(pts, vec![(1.0, 9.0), (2.0, 5.0), (2.5, 4.0)]);
    }
}
