//! Optimised excitation (paper eqs. 7–8): choose the Fourier coefficients of the excited
//! joints so that the regressor of the parameters being identified is well conditioned,
//! subject to the robot's limits and workspace.
//!
//! - Parametrisation: [`Fourier::rest_constrained`] (rest at start and end); joints that are
//!   not excited hold `rest_pose`.
//! - Identified parameters: the base columns the excited joints can reveal from the chosen
//!   observation, found numerically (greedy QR in link order) on random states in which only
//!   those joints move.
//! - Objective: `ln cond(A)` of that regressor `A` sampled over one period, columns scaled
//!   to unit norm (unit-free), optionally `+ 1/sigma_min(A)` (as BIRDy offers), plus
//!   quadratic penalties for position (with margin), velocity and acceleration limits, and
//!   for the workspace: the flange and the wrist centre stay above a floor plane and outside
//!   a cylinder around the base column.
//! - Optimiser: CMA-ES (crate `cmaes`), several seeded starts; the best result is kept and
//!   then checked against the limits at 1 ms.

use std::time::Instant;

use nalgebra::{DMatrix, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::dynamics::base_params::BaseParams;
use crate::dynamics::regressor::regressor;
use crate::dynamics::rnea::rnea;
use crate::dynamics::{ParamLayout, Workspace};
use crate::error::{Error, Result};
use crate::kinematics::fk::link_poses;
use crate::model::Robot;
use crate::model::sampling::StateSampler;
use crate::trajectory::Trajectory;
use crate::trajectory::fourier::Fourier;
use crate::trajectory::limits::check_limits;

/// Which regressor the condition number is taken of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Observation {
    /// Total motor power: one row per sample (what the paper measures).
    TotalPower,
    /// Joint torques: one row per joint and sample.
    Torque,
}

/// Objective of the optimisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Criterion {
    /// `ln cond(A)`.
    Cond,
    /// `ln cond(A) + 1/sigma_min(A)`.
    CondPlusInverseSigmaMin,
}

/// Settings of the excitation design.
#[derive(Debug, Clone, PartialEq)]
pub struct ExcitationOptions {
    /// Excited joints (0-based).
    pub joints: Vec<usize>,
    /// Base frequency, Hz.
    pub base_freq_hz: f64,
    /// Harmonics per joint (>= 2).
    pub harmonics: usize,
    /// Whole periods to run.
    pub periods: usize,
    /// Pose of the joints that are not excited, and start guess of the offsets, rad.
    pub rest_pose: Vec<f64>,
    /// Parameter layout (friction and rotor-inertia columns).
    pub layout: ParamLayout,
    /// Observation whose regressor is conditioned.
    pub observation: Observation,
    /// Objective.
    pub criterion: Criterion,
    /// Samples per period for the objective.
    pub samples: usize,
    /// Distance kept from position limits, rad.
    pub position_margin: f64,
    /// Fraction of the velocity and acceleration limits that may be used.
    pub limit_fraction: f64,
    /// Acceleration limits per joint, rad/s^2.
    pub accel_limits: Vec<f64>,
    /// Floor plane height (base frame z) the flange and wrist centre stay above, m.
    pub floor_z: f64,
    /// Radius of the keep-out cylinder around the base z axis, m.
    pub base_radius: f64,
    /// Independent CMA-ES starts.
    pub starts: usize,
    /// Function evaluations per start.
    pub max_evals: usize,
    /// Seed of the starts.
    pub seed: u64,
}

impl ExcitationOptions {
    /// Paper defaults for `robot` exciting `joints`: 0.1 Hz, 5 harmonics, 1 period, total
    /// power, friction and rotor-inertia columns, the robot's limits and `accel_limits`,
    /// floor at z = 0.05 m, a 0.15 m keep-out radius around the base, 2 starts of 3000
    /// evaluations.
    pub fn new(
        robot: &Robot,
        joints: Vec<usize>,
        rest_pose: Vec<f64>,
        accel_limits: Vec<f64>,
    ) -> Self {
        ExcitationOptions {
            joints,
            base_freq_hz: 0.1,
            harmonics: crate::identification::tuning::HARMONICS,
            periods: 1,
            rest_pose,
            layout: ParamLayout::new(robot, true, true),
            observation: Observation::TotalPower,
            criterion: Criterion::Cond,
            samples: 150,
            position_margin: 0.05,
            limit_fraction: 0.9,
            accel_limits,
            floor_z: 0.05,
            base_radius: 0.15,
            starts: 2,
            max_evals: 3000,
            seed: 1,
        }
    }
}

/// Outcome of a design.
#[derive(Debug, Clone)]
pub struct Excitation {
    /// The optimised trajectory.
    pub trajectory: Fourier,
    /// Names of the parameters the design conditions for.
    pub parameters: Vec<String>,
    /// Condition number of the start guess of the best start.
    pub cond_initial: f64,
    /// Condition number of the result.
    pub cond_final: f64,
    /// Objective evaluations in all starts.
    pub evaluations: usize,
    /// Wall time, s.
    pub wall_s: f64,
}

/// The optimiser sees limits shrunk by this factor (and the workspace grown by 0.02 m), so
/// the quadratic penalties, which tolerate tiny violations, leave the result strictly inside
/// the real limits.
const OPTIMISATION_TIGHTENING: f64 = 0.98;

/// Joint and workspace limits of an excitation, as quadratic penalties.
pub(crate) struct Bounds {
    /// Position limits less the margin, rad.
    lower: Vec<f64>,
    upper: Vec<f64>,
    /// Usable speed and acceleration per joint, rad/s and rad/s^2.
    vmax: Vec<f64>,
    amax: Vec<f64>,
    /// Floor plane height, m, and keep-out radius around the base axis, m.
    floor_z: f64,
    base_radius: f64,
}

impl Bounds {
    /// The limits of `robot` less `position_margin` (rad), `limit_fraction` of its speed
    /// limits (at most 10 rad/s) and of `accel_limits` (rad/s^2), the floor at `floor_z` (m)
    /// and the keep-out cylinder of radius `base_radius` (m).
    pub(crate) fn new(
        robot: &Robot,
        position_margin: f64,
        limit_fraction: f64,
        accel_limits: &[f64],
        floor_z: f64,
        base_radius: f64,
    ) -> Bounds {
        let joints = robot.joints();
        Bounds {
            lower: joints
                .iter()
                .map(|j| j.limits.lower + position_margin)
                .collect(),
            upper: joints
                .iter()
                .map(|j| j.limits.upper - position_margin)
                .collect(),
            vmax: joints
                .iter()
                .map(|j| j.limits.velocity.min(10.0) * limit_fraction)
                .collect(),
            amax: accel_limits.iter().map(|a| a * limit_fraction).collect(),
            floor_z,
            base_radius,
        }
    }

    /// Penalty of one state (0 inside every limit), with the limits shrunk by the factor
    /// `tighten` (<= 1) and the workspace grown by `(1 - tighten)` m. `poses` is scratch of
    /// `robot.dof()` link poses.
    pub(crate) fn penalty(
        &self,
        robot: &Robot,
        q: &[f64],
        dq: &[f64],
        ddq: &[f64],
        poses: &mut [nalgebra::Isometry3<f64>],
        tighten: f64,
    ) -> f64 {
        let n = robot.dof();
        let extra = 1.0 - tighten;
        let mut penalty = 0.0;
        for i in 0..n {
            let (lo, hi) = (self.lower[i] + extra, self.upper[i] - extra);
            let (vmax, amax) = (self.vmax[i] * tighten, self.amax[i] * tighten);
            penalty += (lo - q[i]).max(0.0).powi(2) + (q[i] - hi).max(0.0).powi(2);
            penalty += ((dq[i].abs() - vmax) / vmax).max(0.0).powi(2);
            penalty += ((ddq[i].abs() - amax) / amax).max(0.0).powi(2);
        }
        link_poses(robot, q, poses);
        let flange = poses[n - 1] * robot.flange();
        let points = [
            poses[n.saturating_sub(2)].translation.vector,
            flange.translation.vector,
        ];
        for p in points {
            penalty += (self.floor_z + extra - p.z).max(0.0).powi(2) * 100.0;
            let r = Vector3::new(p.x, p.y, 0.0).norm();
            penalty += (self.base_radius + extra - r).max(0.0).powi(2) * 100.0;
        }
        penalty
    }
}

/// Decision vector -> rest-constrained series about `rest_pose`: per excited joint
/// `[q0, a_1..a_{N-1}, b_1..b_{N-1}]` (rad) for `harmonics` = N; the other joints hold
/// `rest_pose`.
pub(crate) fn series(
    rest_pose: &[f64],
    joints: &[usize],
    harmonics: usize,
    base_freq_hz: f64,
    periods: usize,
    x: &[f64],
) -> Result<Fourier> {
    let n = rest_pose.len();
    let free = harmonics - 1;
    let per = 1 + 2 * free;
    let mut q0 = rest_pose.to_vec();
    let mut a = vec![vec![0.0; free]; n];
    let mut b = vec![vec![0.0; free]; n];
    for (k, &j) in joints.iter().enumerate() {
        let xs = &x[k * per..(k + 1) * per];
        q0[j] = xs[0];
        a[j].copy_from_slice(&xs[1..1 + free]);
        b[j].copy_from_slice(&xs[1 + free..]);
    }
    Fourier::rest_constrained(base_freq_hz, q0, a, b, periods as f64)
}

/// A start point of the design of [`series`]: offsets at the rest pose, small random
/// coefficients falling off as `1/h^2` (0.3 rad for the first harmonic).
pub(crate) fn start_point(
    rest_pose: &[f64],
    joints: &[usize],
    harmonics: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<f64> {
    let free = harmonics - 1;
    let per = 1 + 2 * free;
    let mut x0 = vec![0.0; per * joints.len()];
    for (k, &j) in joints.iter().enumerate() {
        x0[k * per] = rest_pose[j];
        for h in 0..free {
            let scale = 0.3 / ((h + 1) * (h + 1)) as f64;
            x0[k * per + 1 + h] = rng.random_range(-scale..scale);
            x0[k * per + 1 + free + h] = rng.random_range(-scale..scale);
        }
    }
    x0
}

/// The problem: fixed data shared by all objective evaluations.
struct Problem<'a> {
    robot: &'a Robot,
    opts: &'a ExcitationOptions,
    columns: Vec<usize>,
    bounds: Bounds,
}

impl Problem<'_> {
    /// Decision vector -> trajectory (see [`series`]).
    fn trajectory(&self, x: &[f64]) -> Result<Fourier> {
        let o = self.opts;
        series(
            &o.rest_pose,
            &o.joints,
            o.harmonics,
            o.base_freq_hz,
            o.periods,
            x,
        )
    }

    /// Regressor of the identified columns over one period (columns unit-norm scaled) and
    /// the constraint penalty, with the limits shrunk by the factor `tighten` (<= 1) and the
    /// workspace grown by `(1 - tighten)` m, so that the optimiser keeps a safety distance.
    fn evaluate(&self, traj: &Fourier, tighten: f64) -> (DMatrix<f64>, f64) {
        let o = self.opts;
        let robot = self.robot;
        let n = robot.dof();
        let rows_per = match o.observation {
            Observation::TotalPower => 1,
            Observation::Torque => n,
        };
        let mut a = DMatrix::zeros(o.samples * rows_per, self.columns.len());
        let mut ws = Workspace::new(robot);
        let mut w = DMatrix::zeros(n, o.layout.len());
        let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut poses = vec![nalgebra::Isometry3::identity(); n];
        let mut penalty = 0.0;
        let period = 1.0 / o.base_freq_hz;
        for s in 0..o.samples {
            let t = period * s as f64 / o.samples as f64;
            traj.sample(t, &mut q, &mut dq, &mut ddq);
            penalty += self
                .bounds
                .penalty(robot, &q, &dq, &ddq, &mut poses, tighten);
            regressor(robot, &mut ws, &o.layout, &q, &dq, &ddq, &mut w);
            for (k, &c) in self.columns.iter().enumerate() {
                match o.observation {
                    Observation::TotalPower => a[(s, k)] = (0..n).map(|i| dq[i] * w[(i, c)]).sum(),
                    Observation::Torque => {
                        for i in 0..n {
                            a[(s * n + i, k)] = w[(i, c)];
                        }
                    }
                }
            }
        }
        for mut col in a.column_iter_mut() {
            let norm = col.norm();
            if norm > 0.0 {
                col.unscale_mut(norm);
            }
        }
        (a, penalty)
    }

    /// Condition number and smallest singular value of a scaled regressor (from the
    /// eigenvalues of A^T A).
    fn conditioning(a: &DMatrix<f64>) -> (f64, f64) {
        let eig = (a.transpose() * a).symmetric_eigenvalues();
        let (lo, hi) = (eig.min().max(0.0), eig.max());
        if lo <= 0.0 {
            return (f64::INFINITY, 0.0);
        }
        ((hi / lo).sqrt(), lo.sqrt())
    }

    fn objective(&self, x: &[f64]) -> f64 {
        let Ok(traj) = self.trajectory(x) else {
            return 1e6;
        };
        let (a, penalty) = self.evaluate(&traj, OPTIMISATION_TIGHTENING);
        let (cond, smin) = Self::conditioning(&a);
        let base = if cond.is_finite() { cond.ln() } else { 50.0 };
        let extra = match self.opts.criterion {
            Criterion::Cond => 0.0,
            Criterion::CondPlusInverseSigmaMin => 1.0 / smin.max(1e-12),
        };
        base + extra + 1e3 * penalty
    }
}

/// Largest joint speed of the identifiability scan's random states, rad/s (and at most each
/// joint's limit).
const SCAN_VELOCITY: f64 = 2.0;
/// Largest joint acceleration of the identifiability scan's random states, rad/s^2.
const SCAN_ACCELERATION: f64 = 5.0;

/// The base columns of `layout` that motions of `joints` alone reveal through `observation`:
/// greedy QR in link order on random states with the other joints at `rest_pose`.
pub fn identifiable_columns(
    robot: &Robot,
    layout: ParamLayout,
    joints: &[usize],
    rest_pose: &[f64],
    observation: Observation,
    seed: u64,
) -> Result<Vec<usize>> {
    let n = robot.dof();
    let mut sampler = StateSampler::new(robot, SCAN_VELOCITY, SCAN_ACCELERATION, seed)?;
    let mut ws = Workspace::new(robot);
    let mut w = DMatrix::zeros(n, layout.len());
    let samples = 400;
    let rows_per = if observation == Observation::TotalPower {
        1
    } else {
        n
    };
    let mut stack = DMatrix::zeros(samples * rows_per, layout.len());
    let (mut q, mut dq, mut ddq) = (rest_pose.to_vec(), vec![0.0; n], vec![0.0; n]);
    for s in 0..samples {
        for &j in joints {
            sampler.joint(j, &mut q, &mut dq, &mut ddq);
        }
        regressor(robot, &mut ws, &layout, &q, &dq, &ddq, &mut w);
        for c in 0..layout.len() {
            match observation {
                Observation::TotalPower => stack[(s, c)] = (0..n).map(|i| dq[i] * w[(i, c)]).sum(),
                Observation::Torque => {
                    for i in 0..n {
                        stack[(s * n + i, c)] = w[(i, c)];
                    }
                }
            }
        }
    }
    let base = BaseParams::from_stack(&stack, layout)?;
    Ok(base.independent().to_vec())
}

/// Candidate poses drawn by [`rest_pose`] when the centre pose violates the workspace, by
/// [`standby_pose`] and by [`crate::identification::excitation_set::centres::spread_centres`].
pub(crate) const REST_CANDIDATES: usize = 4000;

/// Each joint's range within its position limits less `margin` (rad), clipped to
/// [-pi, pi]. Errors when a range is not wider than `2 margin`.
pub(crate) fn rest_ranges(robot: &Robot, margin: f64) -> Result<Vec<(f64, f64)>> {
    robot
        .joints()
        .iter()
        .map(|j| {
            let lo = (j.limits.lower + margin).max(-std::f64::consts::PI);
            let hi = (j.limits.upper - margin).min(std::f64::consts::PI);
            if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
                return Err(Error::InvalidInput(format!(
                    "joint '{}': no rest pose {margin} rad inside its limits [{}, {}] rad",
                    j.name, j.limits.lower, j.limits.upper
                )));
            }
            Ok((lo, hi))
        })
        .collect()
}

/// A pose drawn uniformly within `ranges` (rad, one `(lo, hi)` per joint).
pub(crate) fn random_pose(rng: &mut ChaCha8Rng, ranges: &[(f64, f64)]) -> Vec<f64> {
    ranges
        .iter()
        .map(|&(lo, hi)| rng.random_range(lo..hi))
        .collect()
}

/// Whether pose `q` keeps the flange and the wrist (the origin of the second-to-last link
/// frame) above `floor_z` (m) and `base_radius` (m) from the base z axis, with 0.02 m to
/// spare. `poses`: scratch of one pose per link.
/// With `column_top` (m), the base column ends there: a point higher than that by
/// `base_radius` may be over the base axis (an arm held upright).
pub(crate) fn clear_of_workspace(
    robot: &Robot,
    q: &[f64],
    floor_z: f64,
    base_radius: f64,
    column_top: Option<f64>,
    poses: &mut [nalgebra::Isometry3<f64>],
) -> bool {
    let n = robot.dof();
    link_poses(robot, q, poses);
    let flange = poses[n - 1] * robot.flange();
    let above_column = |z: f64| column_top.is_some_and(|top| z >= top + base_radius);
    [
        poses[n.saturating_sub(2)].translation.vector,
        flange.translation.vector,
    ]
    .iter()
    .all(|p| {
        p.z >= floor_z + 0.02
            && (above_column(p.z) || Vector3::new(p.x, p.y, 0.0).norm() >= base_radius + 0.02)
    })
}

/// A rest pose for an excitation of `robot`, derived from its URDF: every joint at 0 clamped
/// into its position limits less `margin` (rad), or, when the flange or the wrist (the origin
/// of the second-to-last link frame) is then below `floor_z` (m) or within `base_radius` (m) of
/// the base z axis (with 0.02 m to spare), the seeded random pose within those limits
/// (each joint within [-pi, pi]) that satisfies the workspace and lies nearest that pose.
///
/// Errors: [`Error::InvalidInput`] when a joint's range is not wider than `2 margin`, or no
/// drawn pose satisfies the workspace.
pub fn rest_pose(robot: &Robot, margin: f64, floor_z: f64, base_radius: f64) -> Result<Vec<f64>> {
    let n = robot.dof();
    let ranges = rest_ranges(robot, margin)?;
    let centre: Vec<f64> = ranges
        .iter()
        .map(|&(lo, hi)| 0.0_f64.clamp(lo, hi))
        .collect();
    let mut poses = vec![nalgebra::Isometry3::identity(); n];
    if clear_of_workspace(robot, &centre, floor_z, base_radius, None, &mut poses) {
        return Ok(centre);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut best: Option<(f64, Vec<f64>)> = None;
    for _ in 0..REST_CANDIDATES {
        let q = random_pose(&mut rng, &ranges);
        let d: f64 = q.iter().zip(&centre).map(|(a, b)| (a - b).powi(2)).sum();
        if best.as_ref().is_none_or(|(bd, _)| d < *bd)
            && clear_of_workspace(robot, &q, floor_z, base_radius, None, &mut poses)
        {
            best = Some((d, q));
        }
    }
    best.map(|(_, q)| q).ok_or_else(|| {
        Error::InvalidInput(format!(
            "no pose of {REST_CANDIDATES} drawn keeps the flange and wrist above z = {floor_z} m \
             and {base_radius} m from the base axis; give a rest pose"
        ))
    })
}

/// Coordinate-search passes of [`standby_pose`] after the random draw.
const STANDBY_PASSES: usize = 40;

/// The pose at which a robot at rest draws its standby power and next to no holding current:
/// within the position limits less `margin` (rad) and the workspace of [`rest_pose`]
/// (`floor_z`, `base_radius`, m; the wrist and flange may be over the base axis when
/// `base_radius` above the shoulder, the origin of the second link's frame: an arm held
/// upright), the pose that minimises the URDF's gravity torques relative
/// to each joint's effort limit (1 N m for all when the URDF lacks one),
/// `sum_i (tau_g,i / effort_i)^2` (the holding copper loss
/// `c_i tau_i^2` when, as usual, `c_i` falls with the square of the motor's torque rating).
/// Seeded random draws, then a coordinate search (steps halved from 0.2 rad to 1e-4 rad).
/// Returns the pose (rad) and its gravity torques (N m).
///
/// A log of the robot held there pins the identified standby power, which the copper loss of
/// moving otherwise trades against ([`crate::validation::idset`]).
///
/// Errors: those of [`rest_pose`]'s ranges, or no drawn pose clear of the workspace.
pub fn standby_pose(
    robot: &Robot,
    margin: f64,
    floor_z: f64,
    base_radius: f64,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let n = robot.dof();
    let ranges = rest_ranges(robot, margin)?;
    // Without effort limits in the URDF, every joint alike.
    let effort: Vec<f64> = if robot.joints().iter().all(|j| j.limits.effort.is_some()) {
        robot
            .joints()
            .iter()
            .map(|j| j.limits.effort.unwrap_or(1.0).max(1e-9))
            .collect()
    } else {
        vec![1.0; n]
    };
    let mut ws = Workspace::new(robot);
    let mut poses = vec![nalgebra::Isometry3::identity(); n];
    let zero = vec![0.0; n];
    let mut tau = vec![0.0; n];
    // The base column ends at the shoulder: the origin of the second link's frame.
    link_poses(robot, &vec![0.0; n], &mut poses);
    let shoulder = poses[1.min(n - 1)].translation.vector.z;
    let mut cost = |q: &[f64], tau: &mut [f64]| -> f64 {
        if !clear_of_workspace(robot, q, floor_z, base_radius, Some(shoulder), &mut poses) {
            return f64::INFINITY;
        }
        rnea(robot, &mut ws, q, &zero, &zero, None, tau);
        tau.iter().zip(&effort).map(|(t, e)| (t / e).powi(2)).sum()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut best: Option<(f64, Vec<f64>)> = None;
    for _ in 0..REST_CANDIDATES {
        let q = random_pose(&mut rng, &ranges);
        let c = cost(&q, &mut tau);
        if c.is_finite() && best.as_ref().is_none_or(|(bc, _)| c < *bc) {
            best = Some((c, q));
        }
    }
    let (mut best_cost, mut q) = best.ok_or_else(|| {
        Error::InvalidInput(format!(
            "no pose of {REST_CANDIDATES} drawn keeps the flange and wrist above z = {floor_z} m \
             and {base_radius} m from the base axis"
        ))
    })?;
    let mut step = 0.2;
    for _ in 0..STANDBY_PASSES {
        let mut improved = false;
        for i in 0..n {
            for dir in [-1.0, 1.0] {
                let mut trial = q.clone();
                trial[i] = (q[i] + dir * step).clamp(ranges[i].0, ranges[i].1);
                let c = cost(&trial, &mut tau);
                if c < best_cost {
                    (best_cost, q, improved) = (c, trial, true);
                }
            }
        }
        if !improved {
            step *= 0.5;
            if step < 1e-4 {
                break;
            }
        }
    }
    cost(&q, &mut tau);
    Ok((q, tau))
}

/// Design an excitation trajectory for `robot`.
pub fn design(robot: &Robot, opts: &ExcitationOptions) -> Result<Excitation> {
    let start = Instant::now();
    let n = robot.dof();
    robot.check_len(&opts.rest_pose, "rest pose")?;
    robot.check_position_limits(&opts.rest_pose)?;
    if opts.joints.is_empty() || opts.joints.iter().any(|&j| j >= n) {
        return Err(Error::InvalidInput(format!(
            "excited joints must be in 1..={n}"
        )));
    }
    if opts.harmonics < 2 || opts.periods == 0 || opts.samples < 10 || opts.starts == 0 {
        return Err(Error::InvalidInput(
            "excitation needs >= 2 harmonics, >= 1 period, >= 10 samples and >= 1 start".into(),
        ));
    }
    if opts.accel_limits.len() != n || !(opts.limit_fraction > 0.0 && opts.limit_fraction <= 1.0) {
        return Err(Error::InvalidInput(format!(
            "need {n} acceleration limits and a limit fraction in (0, 1]"
        )));
    }
    let columns = identifiable_columns(
        robot,
        opts.layout,
        &opts.joints,
        &opts.rest_pose,
        opts.observation,
        opts.seed,
    )?;
    let names = opts.layout.names();
    let problem = Problem {
        robot,
        opts,
        columns: columns.clone(),
        bounds: Bounds::new(
            robot,
            opts.position_margin,
            opts.limit_fraction,
            &opts.accel_limits,
            opts.floor_z,
            opts.base_radius,
        ),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let mut best: Option<(f64, Vec<f64>, f64)> = None;
    let mut evaluations = 0;
    for s in 0..opts.starts {
        let x0 = start_point(&opts.rest_pose, &opts.joints, opts.harmonics, &mut rng);
        let cond0 = problem
            .trajectory(&x0)
            .map(|t| Problem::conditioning(&problem.evaluate(&t, 1.0).0).0)
            .unwrap_or(f64::INFINITY);
        let objective = |x: &cmaes::DVector<f64>| problem.objective(x.as_slice());
        let mut state = cmaes::CMAESOptions::new(x0, 0.1)
            .max_function_evals(opts.max_evals)
            .seed(opts.seed.wrapping_add(s as u64))
            .build(objective)
            .map_err(|e| Error::Numerical(format!("CMA-ES options: {e:?}")))?;
        let result = state.run();
        evaluations += state.function_evals();
        if let Some(b) = result.overall_best
            && best.as_ref().is_none_or(|(v, _, _)| b.value < *v)
        {
            best = Some((b.value, b.point.as_slice().to_vec(), cond0));
        }
    }
    let (_, x, cond_initial) =
        best.ok_or_else(|| Error::Numerical("CMA-ES found no point".into()))?;
    let trajectory = problem.trajectory(&x)?;
    let (a, penalty) = problem.evaluate(&trajectory, 1.0);
    if penalty > 0.0 {
        return Err(Error::JointLimit(format!(
            "the optimised excitation still violates limits or the workspace (penalty {penalty:.3e}); widen the limits or reduce the harmonics"
        )));
    }
    check_limits(robot, &trajectory, 1e-3, Some(&opts.accel_limits))?;
    Ok(Excitation {
        trajectory,
        parameters: columns.iter().map(|&c| names[c].clone()).collect(),
        cond_initial,
        cond_final: Problem::conditioning(&a).0,
        evaluations,
        wall_s: start.elapsed().as_secs_f64(),
    })
}
