//! The cheapest timing of a whole task within a cycle time: one candidate per segment
//! ([`super::segment`]) and one wait that fills the cycle, held by the servos or, where the
//! drive file gives a brakes-applied mode ([`Brakes`]), by the brakes.
//!
//! # Method
//! An exact dynamic programme over the candidates (a multiple-choice knapsack): durations are
//! rounded up to [`SLOT_S`], and for every total duration the least motion energy over all
//! combinations of candidates is kept. A cycle-time bound `T` then costs the least motion
//! energy at total duration `tau` plus the cheapest wait of `T - tau`, minimised over `tau`.
//! The search needs neither smoothness nor convexity: the energy of a segment against its
//! speed has kinks where the planner starts slowing it for a joint limit, and the dynamic
//! programme is exact over the sampled candidates whatever their shape. What it cannot see is
//! a timing between grid points; the grid is dense where it matters (12 speeds, 3
//! accelerations per segment).

use serde::Serialize;

use crate::error::{Error, Result};
use crate::model::Robot;
use crate::model::drive::{BrakeWindow, Brakes};
use crate::model::payload::PayloadEvent;
use crate::trajectory::linear_move::SegmentTiming;
use crate::trajectory::sampled::Sampled;

use super::segment::{Candidate, PREDICTION_STEP_S, Task};

/// Time resolution of the dynamic programme, s; durations are rounded up to it, so a chosen
/// timing never exceeds its bound.
pub const SLOT_S: f64 = 0.001;

/// How the arm waits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WaitMode {
    /// The servos hold the arm (standby power and the copper loss of holding it).
    Hold,
    /// The brakes hold it after engaging, servos off ([`Brakes`]); the servos hold while the
    /// brakes engage and release.
    Brakes,
}

/// The wait that fills the cycle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Wait {
    /// The wait follows the arrival at the end of this segment (0-based).
    pub after_segment: usize,
    /// Duration, s.
    pub duration_s: f64,
    /// How the arm waits.
    pub mode: WaitMode,
    /// Predicted energy of the wait, J.
    #[serde(rename = "energy_J")]
    pub energy_j: f64,
}

/// A timed task.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Schedule {
    /// The chosen candidate of every segment.
    pub segments: Vec<Candidate>,
    /// The wait (duration 0 when the motion fills the cycle).
    pub wait: Wait,
    /// Cycle time, s: the segments' durations plus the wait.
    pub cycle_time_s: f64,
    /// Predicted energy per cycle, J: the segments' plus the wait's.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
}

impl Schedule {
    /// The segment timings to plan the task with ([`crate::trajectory::task::Scenario::plan_timed`]),
    /// the wait as the dwell of its segment.
    pub fn timings(&self) -> Vec<SegmentTiming> {
        self.segments
            .iter()
            .enumerate()
            .map(|(k, c)| {
                c.timing(if k == self.wait.after_segment {
                    self.wait.duration_s
                } else {
                    0.0
                })
            })
            .collect()
    }

    /// The brake windows of the plan, given the arrival times of its via points (s, the first
    /// at 0): the wait minus the engage and release times, when the brakes hold.
    pub fn brake_windows(&self, arrivals_s: &[f64], brakes: Option<&Brakes>) -> Vec<BrakeWindow> {
        match (self.wait.mode, brakes) {
            (WaitMode::Brakes, Some(b)) => {
                let arrive = arrivals_s[self.wait.after_segment + 1];
                vec![BrakeWindow {
                    start_s: arrive + b.engage_s,
                    end_s: arrive + self.wait.duration_s - b.release_s,
                }]
            }
            _ => Vec::new(),
        }
    }
}

/// The price of waiting at every via point reached (after each segment).
#[derive(Debug, Clone, PartialEq)]
pub struct WaitPrices {
    /// Predicted power of holding the arm at the end of each segment with what it carries
    /// there, W.
    pub hold_w: Vec<f64>,
    /// The brakes-applied mode, when the drive file gives one.
    pub brakes: Option<Brakes>,
}

impl WaitPrices {
    /// Hold powers from the model at the via points (with the payload carried during the
    /// wait: the one picked there, or the tool after a release).
    pub fn new(task: &Task, brakes: Option<&Brakes>) -> Result<WaitPrices> {
        let sc = task.scenario;
        let tcp = sc.tcp();
        let via = sc.via_poses();
        let configs = crate::trajectory::linear_move::via_configurations(
            task.robot,
            &tcp,
            &sc.seed_rad,
            &via,
            &sc.motion,
        )?;
        let payloads = task.payloads()?;
        let segments = sc.segments();
        let hold_w = (0..segments)
            .map(|k| {
                // At the arrival at step k + 2: the next segment's payload (a pick happens on
                // arrival), or the tool after the last segment.
                let payload = if k + 1 < segments {
                    payloads[k + 1].clone()
                } else {
                    sc.tool.clone()
                };
                hold_power(task, task.robot, &configs.q[k + 1], payload)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(WaitPrices {
            hold_w,
            brakes: brakes.copied(),
        })
    }

    /// The cheapest wait of `duration_s` (s): where and how, with its energy.
    pub fn cheapest(&self, duration_s: f64) -> Wait {
        let mut best: Option<Wait> = None;
        for (k, &p) in self.hold_w.iter().enumerate() {
            let mut options = vec![(WaitMode::Hold, p * duration_s)];
            if let Some(b) = &self.brakes
                && duration_s >= b.min_wait_s()
                && duration_s > 0.0
            {
                let braked = duration_s - b.min_wait_s();
                options.push((WaitMode::Brakes, p * b.min_wait_s() + b.power_w * braked));
            }
            for (mode, e) in options {
                if best.is_none_or(|w| e < w.energy_j) {
                    best = Some(Wait {
                        after_segment: k,
                        duration_s,
                        mode,
                        energy_j: e,
                    });
                }
            }
        }
        best.unwrap_or(Wait {
            after_segment: 0,
            duration_s,
            mode: WaitMode::Hold,
            energy_j: 0.0,
        })
    }
}

/// The model's power (W) holding the arm still at `q` (rad) with `payload`.
fn hold_power(
    task: &Task,
    robot: &Robot,
    q: &[f64],
    payload: Option<crate::model::payload::Payload>,
) -> Result<f64> {
    let n = robot.dof();
    let still = Sampled::new(
        vec![0.0, 1.0],
        q.iter().map(|&v| vec![v, v]).collect(),
        Some(vec![vec![0.0; 2]; n]),
        Some(vec![vec![0.0; 2]; n]),
    )?;
    let events = [PayloadEvent { t_s: 0.0, payload }];
    let p = task
        .model
        .predict(robot, &still, &events, task.efficiency, PREDICTION_STEP_S)?;
    Ok(p.energy_j)
}

/// The dynamic programme over the candidates of every segment.
pub struct Scheduler<'a> {
    candidates: &'a [Vec<Candidate>],
    prices: &'a WaitPrices,
    /// `best[k][tau]`: least energy of segments `0..k` taking `tau` slots in all.
    best: Vec<Vec<f64>>,
    /// The candidate of segment `k - 1` on that optimum.
    choice: Vec<Vec<u16>>,
}

impl<'a> Scheduler<'a> {
    /// Tabulate every total duration up to `horizon_s` (s). Errors: no segment, a segment
    /// without candidates, more than 65 535 candidates, or a horizon shorter than the
    /// fastest motion.
    pub fn new(
        candidates: &'a [Vec<Candidate>],
        prices: &'a WaitPrices,
        horizon_s: f64,
    ) -> Result<Scheduler<'a>> {
        if candidates.is_empty() || candidates.iter().any(|c| c.is_empty()) {
            return Err(Error::InvalidInput(
                "every segment needs at least one timing candidate".into(),
            ));
        }
        if candidates.iter().any(|c| c.len() > u16::MAX as usize) {
            return Err(Error::InvalidInput("too many timing candidates".into()));
        }
        let fastest: f64 = candidates.iter().map(|c| c[0].duration_s).sum();
        if !(horizon_s.is_finite() && horizon_s >= fastest) {
            return Err(Error::InvalidInput(format!(
                "cycle time {horizon_s} s is shorter than the fastest timing of the task \
                 ({fastest:.3} s)"
            )));
        }
        let slots = slots(horizon_s) + candidates.len();
        let mut best = vec![vec![f64::INFINITY; slots + 1]];
        best[0][0] = 0.0;
        let mut choice = vec![Vec::new()];
        for list in candidates {
            let prev = best.last().expect("one row");
            let mut row = vec![f64::INFINITY; slots + 1];
            let mut pick = vec![0u16; slots + 1];
            for (i, c) in list.iter().enumerate() {
                let s = slots_of(c.duration_s);
                for tau in 0..=slots.saturating_sub(s) {
                    let e = prev[tau] + c.energy_j;
                    if e < row[tau + s] {
                        row[tau + s] = e;
                        pick[tau + s] = i as u16;
                    }
                }
            }
            best.push(row);
            choice.push(pick);
        }
        Ok(Scheduler {
            candidates,
            prices,
            best,
            choice,
        })
    }

    /// The shortest cycle time the candidates allow, s.
    pub fn fastest_s(&self) -> f64 {
        self.candidates.iter().map(|c| c[0].duration_s).sum()
    }

    /// The cheapest schedule within `cycle_time_s` (s; the wait fills the rest). Errors: a
    /// bound shorter than the fastest timing or beyond the tabulated horizon.
    pub fn within(&self, cycle_time_s: f64) -> Result<Schedule> {
        let last = self.best.last().expect("rows");
        if !(cycle_time_s.is_finite() && cycle_time_s >= self.fastest_s()) {
            return Err(Error::InvalidInput(format!(
                "cycle time {cycle_time_s:.3} s is shorter than the fastest timing of the task \
                 ({:.3} s)",
                self.fastest_s()
            )));
        }
        let top = slots(cycle_time_s).min(last.len() - 1);
        let mut best: Option<(f64, usize)> = None;
        for (tau, &e) in last.iter().enumerate().take(top + 1) {
            if !e.is_finite() {
                continue;
            }
            let wait = (cycle_time_s - tau as f64 * SLOT_S).max(0.0);
            let total = e + self.prices.cheapest(wait).energy_j;
            if best.is_none_or(|(b, _)| total < b) {
                best = Some((total, tau));
            }
        }
        let (_, mut tau) = best.ok_or_else(|| {
            Error::InvalidInput(format!("no timing of the task fits in {cycle_time_s:.3} s"))
        })?;
        let mut segments = Vec::with_capacity(self.candidates.len());
        for k in (0..self.candidates.len()).rev() {
            let c = self.candidates[k][self.choice[k + 1][tau] as usize];
            tau -= slots_of(c.duration_s);
            segments.push(c);
        }
        segments.reverse();
        let motion_s: f64 = segments.iter().map(|c| c.duration_s).sum();
        let wait = self.prices.cheapest((cycle_time_s - motion_s).max(0.0));
        let predicted_j = segments.iter().map(|c| c.energy_j).sum::<f64>() + wait.energy_j;
        Ok(Schedule {
            segments,
            wait,
            cycle_time_s: motion_s + wait.duration_s,
            predicted_j,
        })
    }
}

/// Slots (of [`SLOT_S`]) that fit in `t` (s).
fn slots(t: f64) -> usize {
    (t / SLOT_S + 1e-9).floor() as usize
}

/// Slots a duration `d` (s) takes, rounded up.
fn slots_of(d: f64) -> usize {
    (d / SLOT_S - 1e-9).ceil().max(0.0) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(d: f64, e: f64) -> Candidate {
        Candidate {
            speed_m_s: 1.0 / d,
            accel_m_s2: 1.0,
            duration_s: d,
            energy_j: e,
            slowed: false,
        }
    }

    fn prices(hold_w: Vec<f64>, brakes: Option<Brakes>) -> WaitPrices {
        WaitPrices { hold_w, brakes }
    }

    #[test]
    fn the_programme_finds_the_cheapest_combination_within_the_bound() {
        // Two segments; a brute force over all 9 combinations with a 10 W hold.
        let cands = vec![
            vec![c(1.0, 30.0), c(1.5, 20.0), c(2.5, 16.0)],
            vec![c(0.5, 50.0), c(1.0, 25.0), c(2.0, 12.0)],
        ];
        let p = prices(vec![10.0, 10.0], None);
        let s = Scheduler::new(&cands, &p, 6.0).unwrap();
        for bound in [1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 6.0] {
            let got = s.within(bound).unwrap();
            let mut want = f64::INFINITY;
            for a in &cands[0] {
                for b in &cands[1] {
                    let d = a.duration_s + b.duration_s;
                    if d <= bound + 1e-12 {
                        want = want.min(a.energy_j + b.energy_j + 10.0 * (bound - d));
                    }
                }
            }
            assert!(
                (got.predicted_j - want).abs() < 1e-9,
                "{bound}: {got:?} vs {want}"
            );
            assert!((got.cycle_time_s - bound).abs() < 1e-9);
        }
        assert!(s.within(1.4).is_err());
    }

    #[test]
    fn waits_take_the_brakes_when_they_pay_and_the_cheapest_place() {
        let b = Brakes {
            power_w: 2.0,
            engage_s: 0.2,
            release_s: 0.2,
        };
        let p = prices(vec![30.0, 20.0], Some(b));
        let w = p.cheapest(1.0);
        assert_eq!((w.after_segment, w.mode), (1, WaitMode::Brakes));
        assert!((w.energy_j - (20.0 * 0.4 + 2.0 * 0.6)).abs() < 1e-12);
        // Too short to engage the brakes: the servos hold.
        let w = p.cheapest(0.3);
        assert_eq!((w.after_segment, w.mode), (1, WaitMode::Hold));
        assert!((w.energy_j - 6.0).abs() < 1e-12);
    }
}
