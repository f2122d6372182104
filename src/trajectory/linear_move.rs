//! Linear TCP moves that stop at every via point (ABB `MoveL` to fine points).
//!
//! # Path
//! Segment `k` (0-based) runs from via pose `k` to via pose `k + 1` (TCP poses in the base
//! frame, m). One parameter `u` in `[0, 1]` drives both the position, interpolated linearly,
//! `p(u) = p_k + u (p_{k+1} - p_k)`, and the orientation, interpolated by slerp: a rotation by
//! `u theta` about the fixed base-frame axis `n` of the relative rotation `R_{k+1} R_k^T`
//! (`theta` in `[0, pi]`).
//!
//! # Timing
//! `u(t)` is a jerk-limited rest-to-rest [`SCurve`] whose bounds are the tighter of the
//! translational ones divided by the segment length `L` (m) and the rotational ones divided by
//! `theta` (rad): the TCP cruises at the commanded speed when the segment is long enough,
//! unless turning the tool needs longer (like ABB's orientation speed `v_ori`). Every segment
//! starts and ends at rest.
//!
//! # Joint motion
//! At every sample the joint angles come from the inverse kinematics seeded with the previous
//! sample, so the arm keeps its configuration along the path; the start uses the caller's
//! seed. Robots of the OPW class use the closed form ([`Opw::solve_nearest`]); any other arm
//! with 6 or more joints uses damped least squares ([`dls::solve_held`]) started at the
//! previous sample extrapolated by its velocity and acceleration (one or two Gauss-Newton steps
//! reach 1e-10 m and 1e-10 rad), and an error names the via point, or the segment, time and
//! fraction of the way, where it does not converge. Joint velocities and accelerations are the
//! exact derivatives: `dq = J^-1 [v; w]` and `ddq = J^-1 ([a; alpha] - Jdot dq)` with the
//! geometric Jacobian `J` of the TCP (its columns of the moving joints, a 6 x 6 matrix) and
//! [`bias_acceleration`].
//!
//! # Redundant arms
//! An arm with `n > 6` joints (the 7-joint Franka Panda) holds `n - 6` joints at the seed's
//! values for the whole motion ([`LinearMoveOptions::hold_joints`]), so the other six solve a
//! square problem: the IK solution near the previous sample is locally unique (no drift along
//! the self-motion), and `dq`, `ddq` are exact as above with zeros for the held joints. This
//! is how analytic solutions of the Panda parametrise its redundancy (He and Liu 2021 hold
//! `q7`); the seed's value of the held joint chooses the arm's "elbow" posture. Without
//! `hold_joints`, a 7-joint arm holds the joint that leaves the best-conditioned Jacobian: the
//! one whose smallest singular value of the remaining 6 x 6 Jacobian, minimised over the via
//! points (solved in order from the seed), is largest; a joint whose choice leaves a via point
//! unreachable is not taken. More than 7 joints need `hold_joints`.
//!
//! The samples (at most `sample_period_s` apart, with a sample at every
//! via point) are joined by quintic Hermite pieces ([`Sampled`]), which reproduce the line to
//! well below a micrometre between samples.
//!
//! # Joint limits
//! Position limits are enforced by the inverse kinematics. If a segment would exceed a joint
//! velocity limit (URDF) or an acceleration limit ([`MotionLimits::joint_accel_rad_s2`]), it
//! is slowed down: a velocity violation lowers the segment's speed bound, an acceleration
//! violation (or a velocity violation that lowering the speed does not cure) stretches the
//! whole segment in time, which scales joint velocities by `1/k` and accelerations by `1/k^2`.
//! Each slowed segment is reported in [`LinearMotion::slowed`]. A segment that would need less
//! than [`MIN_SPEED_FRACTION`] of its planned speed is an error.

use nalgebra::{Isometry3, Matrix6, Matrix6xX, Translation3, UnitQuaternion, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::kinematics::dls::{self, DlsOptions};
use crate::kinematics::ik::Opw;
use crate::kinematics::jacobian::{bias_acceleration, geometric_into};
use crate::model::Robot;

use super::Trajectory;
use super::limits::IRB1200_ACCEL_LIMITS;
use super::s_curve::SCurve;
use super::sampled::Sampled;

/// A segment may be slowed until its peak TCP speed is this fraction of the unslowed one;
/// needing less is reported as an error ([`Error::JointLimit`]).
pub const MIN_SPEED_FRACTION: f64 = 0.01;

/// Safety factor on the limits when slowing a segment.
const SLOWDOWN_MARGIN: f64 = 1e-3;
/// Fraction of the joint velocity and acceleration limits the samples may reach: between the
/// samples (at most `sample_period_s` apart) the interpolated motion may peak a little higher.
const LIMIT_USE: f64 = 0.995;
/// Slowing attempts that lower only the speed bound before stretching the segment in time.
const SPEED_ONLY_ATTEMPTS: usize = 8;
/// Slowing attempts in all.
const MAX_ATTEMPTS: usize = 24;
/// Lengths (m) and angles (rad) below this count as zero.
const ZERO_MOTION: f64 = 1e-9;
/// Largest deviation (rad) of a joint step from the trapezoidal integral of its velocities
/// before the step counts as a jump of the inverse kinematics to another configuration.
const JUMP_TOL: f64 = 1e-2;
/// Initial damping of the numerical IK between samples, where the start is within
/// micrometres of the solution and Gauss-Newton steps converge at once (see [`DlsOptions`]).
const TRACKING_DAMPING: f64 = 1e-9;

/// Cartesian and joint bounds of a linear move. Defaults: the Cartesian limits that the
/// MoveIt Setup Assistant writes for the Pilz planner, as configured for the IRB 1200 in
/// PickNikRobotics/abb_ros2 (`pilz_cartesian_limits.yaml`: `max_trans_acc` 2.25 m/s^2,
/// `max_rot_vel` 1.57 rad/s; `shared/reference/irb1200.md`, section 6), plus estimates where
/// no source gives a value (ABB publishes none).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotionLimits {
    /// TCP acceleration and deceleration bound, m/s^2. Default 2.25 (Pilz `max_trans_acc`).
    pub accel_m_s2: f64,
    /// TCP jerk bound, m/s^3. Default 20 (estimate: full acceleration in about 0.11 s).
    pub jerk_m_s3: f64,
    /// Tool angular speed bound, rad/s. Default 1.57 (Pilz `max_rot_vel`).
    pub angular_speed_rad_s: f64,
    /// Tool angular acceleration bound, rad/s^2. Default 3.5325 = 2.25 * 1.57 / 1.0
    /// (estimate: the translational acceleration scaled by Pilz's `max_rot_vel` /
    /// `max_trans_vel`, so rotation ramps up as fast as translation).
    pub angular_accel_rad_s2: f64,
    /// Tool angular jerk bound, rad/s^3. Default 31.4 = 20 * 1.57 / 1.0 (estimate, same
    /// scaling).
    pub angular_jerk_rad_s3: f64,
    /// Joint acceleration bounds, rad/s^2, one per joint. Default
    /// [`IRB1200_ACCEL_LIMITS`] (estimates for the IRB 1200; give your robot's for another
    /// arm). Joint velocity bounds are the robot model's (URDF).
    pub joint_accel_rad_s2: Vec<f64>,
}

impl Default for MotionLimits {
    fn default() -> Self {
        MotionLimits {
            accel_m_s2: 2.25,
            jerk_m_s3: 20.0,
            angular_speed_rad_s: 1.57,
            angular_accel_rad_s2: 2.25 * 1.57,
            angular_jerk_rad_s3: 20.0 * 1.57,
            joint_accel_rad_s2: IRB1200_ACCEL_LIMITS.to_vec(),
        }
    }
}

/// Options of [`plan`].
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LinearMoveOptions {
    /// Longest time between two samples of the output, s, in `(0, 0.1]`. Default 0.002: the
    /// quintic Hermite pieces between samples then stay within nanometres of the line.
    pub sample_period_s: f64,
    /// Time spent standing at every via point reached (not at the start), s (>= 0).
    /// Default 0.
    pub dwell_s: f64,
    /// Cartesian and joint bounds.
    pub limits: MotionLimits,
    /// Joints (1-based) held at the seed's values on an arm with more than 6 joints, `n - 6`
    /// of them (see the [module docs](self)). Default empty: chosen automatically for a
    /// 7-joint arm; must stay empty for an arm with 6 joints.
    pub hold_joints: Vec<usize>,
}

impl Default for LinearMoveOptions {
    fn default() -> Self {
        LinearMoveOptions {
            sample_period_s: 0.002,
            dwell_s: 0.0,
            limits: MotionLimits::default(),
            hold_joints: Vec::new(),
        }
    }
}

/// A via point: a TCP pose in the base frame (m) with a name for messages.
#[derive(Debug, Clone, PartialEq)]
pub struct ViaPose {
    /// Name used in messages (may be empty).
    pub name: String,
    /// TCP pose in the base frame, m.
    pub tcp: Isometry3<f64>,
}

/// How one segment is timed: its TCP speed and acceleration bounds and the time spent standing
/// at its end. [`plan`] uses one speed for every segment; [`plan_timed`] takes one of these
/// per segment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmentTiming {
    /// Commanded TCP speed, m/s (finite, > 0).
    pub speed_m_s: f64,
    /// TCP acceleration and deceleration bound, m/s^2, in `(0, limits.accel_m_s2]`. The other
    /// bounds of the segment scale with it: the jerk bound by the same ratio (the jerk ramps
    /// keep their duration), and the tool's angular acceleration and jerk bounds too.
    pub accel_m_s2: f64,
    /// Time standing at the segment's end, s (>= 0).
    pub dwell_s: f64,
}

/// Which joint limit made a segment slow down.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SlowReason {
    /// A joint velocity limit (robot model).
    JointVelocity,
    /// A joint acceleration limit ([`MotionLimits::joint_accel_rad_s2`]).
    JointAcceleration,
}

/// A segment that was slowed down to respect the joint limits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SlowedSegment {
    /// Segment index, 0-based: from via point `segment` to via point `segment + 1`.
    pub segment: usize,
    /// TCP speed bound before slowing, m/s: the commanded speed, or less when the tool's
    /// angular speed bound governs the segment (0 for a pure reorientation).
    pub commanded_m_s: f64,
    /// TCP speed bound after slowing, m/s (the segment cruises at it when long enough).
    pub used_m_s: f64,
    /// Joint (0-based) whose limit was exceeded most at the commanded speed.
    pub limiting_joint: usize,
    /// Which of its limits.
    pub reason: SlowReason,
}

/// A planned sequence of linear moves.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearMotion {
    /// The joint trajectory (quintic Hermite through the samples).
    pub trajectory: Sampled,
    /// Time at which each via point is reached, s (the first is 0).
    pub arrivals_s: Vec<f64>,
    /// Total duration, s (the last arrival plus its dwell).
    pub duration_s: f64,
    /// Segments slowed down for the joint limits, in order.
    pub slowed: Vec<SlowedSegment>,
}

impl Trajectory for LinearMotion {
    fn dof(&self) -> usize {
        self.trajectory.dof()
    }

    fn duration(&self) -> f64 {
        self.trajectory.duration()
    }

    fn sample(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        self.trajectory.sample(t, q, dq, ddq);
    }
}

/// Plan linear TCP moves through `via` (at least 2 poses, the first being the start) at the
/// commanded TCP speed `speed_m_s` (m/s), stopping at each via point (see the
/// [module docs](self)). `tcp` is the TCP pose in the flange frame (m); `seed` (rad) selects
/// the arm configuration at the start (the inverse-kinematics solution nearest to it).
///
/// # Errors
/// - [`Error::InvalidInput`]: a speed that is not finite and positive, fewer than 2 via
///   points, a seed of the wrong length, non-finite poses, bad options (non-positive or
///   non-finite bounds, joint bounds of the wrong length, sample period outside `(0, 0.1]`,
///   negative dwell), or all via points equal without dwell.
/// - [`Error::Model`]: the robot has fewer than 6 joints (it cannot follow a TCP pose), or
///   more than 7 without [`LinearMoveOptions::hold_joints`].
/// - [`Error::Unreachable`]: a via point or a pose on a segment is out of reach, the numerical
///   inverse kinematics does not converge there, or the inverse kinematics has to change
///   configuration on a segment (a singularity on the line).
/// - [`Error::JointLimit`]: a via point or a pose on a segment is outside the position limits
///   in every configuration, or a segment would need less than [`MIN_SPEED_FRACTION`] of its
///   speed to respect the joint velocity and acceleration limits.
///
/// Messages name the via point (1-based, with its name and position) or the segment.
pub fn plan(
    robot: &Robot,
    tcp: &Isometry3<f64>,
    seed: &[f64],
    via: &[ViaPose],
    speed_m_s: f64,
    options: &LinearMoveOptions,
) -> Result<LinearMotion> {
    if !(speed_m_s.is_finite() && speed_m_s > 0.0) {
        return Err(Error::InvalidInput(format!(
            "TCP speed {speed_m_s} m/s must be finite and positive"
        )));
    }
    let timing = SegmentTiming {
        speed_m_s,
        accel_m_s2: options.limits.accel_m_s2,
        dwell_s: options.dwell_s,
    };
    let timings = vec![timing; via.len().saturating_sub(1)];
    plan_timed(robot, tcp, seed, via, &timings, options)
}

/// [`plan`] with its own speed, acceleration and dwell for every segment (`timing[k]` times
/// the move from `via[k]` to `via[k + 1]`); `options.dwell_s` is not used. The errors of
/// [`plan`], and [`Error::InvalidInput`] for a timing list of another length than the
/// segments, a speed that is not finite and positive, an acceleration outside
/// `(0, limits.accel_m_s2]` or a negative dwell.
pub fn plan_timed(
    robot: &Robot,
    tcp: &Isometry3<f64>,
    seed: &[f64],
    via: &[ViaPose],
    timing: &[SegmentTiming],
    options: &LinearMoveOptions,
) -> Result<LinearMotion> {
    for (k, s) in timing.iter().enumerate() {
        check_timing(k, s, &options.limits)?;
    }
    if via.len() < 2 {
        return Err(Error::InvalidInput(format!(
            "linear moves need at least 2 via points (the start and a target), got {}",
            via.len()
        )));
    }
    if robot.dof() < 6 {
        return Err(Error::Model(format!(
            "robot '{}' has {} joints; linear TCP moves need at least 6",
            robot.name(),
            robot.dof()
        )));
    }
    robot.check_len(seed, "seed")?;
    crate::error::ensure_finite(seed, "seed")?;
    validate(robot, options)?;
    let solver = Solver::new(robot, tcp, seed, via, options)?;
    let n = robot.dof();
    let ctx = Context::new(robot, solver, tcp, options);
    // Every via point on its own, seeded with the previous one, for errors that name it.
    let q_start = ctx.solver.via_points(robot, tcp, seed, via)?.swap_remove(0);

    let zero = vec![0.0; n];
    let mut out = Output::new(n);
    out.push(0.0, &q_start, &zero, &zero);
    let mut arrivals = vec![0.0];
    let mut slowed = Vec::new();
    let mut t = 0.0;
    let mut q = q_start;
    if timing.len() != via.len() - 1 {
        return Err(Error::InvalidInput(format!(
            "{} segment timings for {} via points ({} segments)",
            timing.len(),
            via.len(),
            via.len() - 1
        )));
    }
    for (k, timing) in timing.iter().enumerate() {
        let seg = Segment::new(k, &via[k], &via[k + 1]);
        if let Some(planned) = seg.plan(&ctx, &q, timing)? {
            for s in &planned.samples {
                out.push(t + s.t, &s.q, &s.dq, &s.ddq);
            }
            t += planned.duration;
            if let Some(s) = planned.samples.last() {
                q.clone_from(&s.q);
            }
            slowed.extend(planned.slowed);
        }
        arrivals.push(t);
        if timing.dwell_s > 0.0 {
            t += timing.dwell_s;
            out.push(t, &q, &zero, &zero);
        }
    }
    if out.t.len() < 2 {
        return Err(Error::InvalidInput(
            "all via points coincide and there is no dwell: the motion has zero duration".into(),
        ));
    }
    let trajectory = Sampled::new(out.t, out.q, Some(out.dq), Some(out.ddq))?;
    Ok(LinearMotion {
        trajectory,
        arrivals_s: arrivals,
        duration_s: t,
        slowed,
    })
}

/// The arm's configuration at the via points of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct ViaConfigurations {
    /// Joint angles at every via point, rad.
    pub q: Vec<Vec<f64>>,
    /// Joints (1-based) held at the seed's values (empty for a 6-joint arm): plan parts of
    /// the path with these as [`LinearMoveOptions::hold_joints`] to move as the whole plan.
    pub hold_joints: Vec<usize>,
}

/// Joint angles (rad) at every via point as [`plan`] reaches them: the first nearest `seed`,
/// each next one from the previous, so the arm keeps its configuration. Errors as [`plan`]'s
/// for the via points.
pub fn via_configurations(
    robot: &Robot,
    tcp: &Isometry3<f64>,
    seed: &[f64],
    via: &[ViaPose],
    options: &LinearMoveOptions,
) -> Result<ViaConfigurations> {
    if robot.dof() < 6 {
        return Err(Error::Model(format!(
            "robot '{}' has {} joints; linear TCP moves need at least 6",
            robot.name(),
            robot.dof()
        )));
    }
    robot.check_len(seed, "seed")?;
    crate::error::ensure_finite(seed, "seed")?;
    let solver = Solver::new(robot, tcp, seed, via, options)?;
    Ok(ViaConfigurations {
        q: solver.via_points(robot, tcp, seed, via)?,
        hold_joints: match &solver {
            Solver::Opw(_) => Vec::new(),
            Solver::Numeric { held, .. } => held.iter().map(|j| j + 1).collect(),
        },
    })
}

/// The inverse kinematics of a plan.
enum Solver {
    /// Closed form (OPW class).
    Opw(Box<Opw>),
    /// Damped least squares with `held` joints (0-based) kept at the seed's values; `free`
    /// are the others (6 of them), whose Jacobian columns are inverted.
    Numeric { held: Vec<usize>, free: Vec<usize> },
}

impl Solver {
    /// The solver for `robot`: closed form when it is of the OPW class, else numerical with
    /// the held joints of `options` (or, for 7 joints, chosen on the via points). `robot` has
    /// at least 6 joints.
    fn new(
        robot: &Robot,
        tcp: &Isometry3<f64>,
        seed: &[f64],
        via: &[ViaPose],
        options: &LinearMoveOptions,
    ) -> Result<Solver> {
        let n = robot.dof();
        let given = &options.hold_joints;
        if !given.is_empty() && given.len() != n - 6 {
            return Err(Error::InvalidInput(format!(
                "hold_joints = {given:?}: a {n}-joint arm holds {} joints during linear moves",
                n - 6
            )));
        }
        for (k, &j) in given.iter().enumerate() {
            if j == 0 || j > n || given[..k].contains(&j) {
                return Err(Error::InvalidInput(format!(
                    "hold_joints = {given:?}: joint numbers must be distinct and in 1..={n}"
                )));
            }
        }
        if n == 6 {
            return Ok(match Opw::from_robot(robot) {
                Some(opw) => Solver::Opw(Box::new(opw)),
                None => Solver::numeric(n, Vec::new()),
            });
        }
        if !given.is_empty() {
            return Ok(Solver::numeric(n, given.iter().map(|j| j - 1).collect()));
        }
        if n > 7 {
            return Err(Error::Model(format!(
                "robot '{}' has {n} joints: give the {} joints to hold during linear moves \
                 (motion.hold_joints)",
                robot.name(),
                n - 6
            )));
        }
        // Hold the joint that leaves the best-conditioned Jacobian over the via points.
        let mut best: Option<(f64, usize)> = None;
        let mut why = Vec::new();
        for j in 0..n {
            let solver = Solver::numeric(n, vec![j]);
            match solver.via_points(robot, tcp, seed, via) {
                Ok(qs) => {
                    let score = qs
                        .iter()
                        .map(|q| solver.smallest_singular_value(robot, q, tcp))
                        .fold(f64::INFINITY, f64::min);
                    if best.is_none_or(|(b, _)| score > b) {
                        best = Some((score, j));
                    }
                }
                Err(e) => why.push(format!("holding joint {}: {e}", j + 1)),
            }
        }
        match best {
            Some((_, j)) => Ok(Solver::numeric(n, vec![j])),
            None => Err(Error::Unreachable(format!(
                "no joint of the {n}-joint arm can be held so that every via point is reached: \
                 {}",
                why.join("; ")
            ))),
        }
    }

    fn numeric(n: usize, held: Vec<usize>) -> Solver {
        let free = (0..n).filter(|j| !held.contains(j)).collect();
        Solver::Numeric { held, free }
    }

    /// Joint angles (rad) putting the TCP at `pose`, nearest `seed` (closed form) or found
    /// from `seed` (numerical; `tracking`: the seed is within micrometres, so start with
    /// Gauss-Newton steps).
    fn solve(
        &self,
        robot: &Robot,
        pose: &Isometry3<f64>,
        tcp: &Isometry3<f64>,
        seed: &[f64],
        tracking: bool,
    ) -> Result<Vec<f64>> {
        match self {
            Solver::Opw(opw) => opw.solve_nearest(pose, tcp, seed).map(|q| q.to_vec()),
            Solver::Numeric { held, .. } => {
                let mut opts = DlsOptions::default();
                if tracking {
                    opts.initial_damping = TRACKING_DAMPING;
                }
                dls::solve_held(robot, pose, tcp, seed, &opts, held)
            }
        }
    }

    /// Every via point solved in order, the first from `seed`, each next one from the
    /// previous; errors name the via point.
    fn via_points(
        &self,
        robot: &Robot,
        tcp: &Isometry3<f64>,
        seed: &[f64],
        via: &[ViaPose],
    ) -> Result<Vec<Vec<f64>>> {
        let mut out: Vec<Vec<f64>> = Vec::with_capacity(via.len());
        for (k, v) in via.iter().enumerate() {
            let from = out.last().map_or(seed, Vec::as_slice);
            let q = self
                .solve(robot, &v.tcp, tcp, from, false)
                .map_err(|e| located(e, &describe_via(k, v)))?;
            out.push(q);
        }
        Ok(out)
    }

    /// The joints whose Jacobian columns form the square matrix that maps joint rates to the
    /// TCP twist.
    fn free(&self) -> &[usize] {
        const ALL: [usize; 6] = [0, 1, 2, 3, 4, 5];
        match self {
            Solver::Opw(_) => &ALL,
            Solver::Numeric { free, .. } => free,
        }
    }

    /// Smallest singular value of the square Jacobian of the free joints at `q`.
    fn smallest_singular_value(&self, robot: &Robot, q: &[f64], tcp: &Isometry3<f64>) -> f64 {
        let mut jac = Matrix6xX::zeros(robot.dof());
        geometric_into(robot, q, tcp, &mut jac);
        square(&jac, self.free()).singular_values().min()
    }
}

/// The 6 x 6 matrix of the columns `free` of `jac`.
fn square(jac: &Matrix6xX<f64>, free: &[usize]) -> Matrix6<f64> {
    Matrix6::from_fn(|r, c| jac[(r, free[c])])
}

/// Check the options against the robot.
fn validate(robot: &Robot, options: &LinearMoveOptions) -> Result<()> {
    let l = &options.limits;
    for (name, value) in [
        ("accel_m_s2", l.accel_m_s2),
        ("jerk_m_s3", l.jerk_m_s3),
        ("angular_speed_rad_s", l.angular_speed_rad_s),
        ("angular_accel_rad_s2", l.angular_accel_rad_s2),
        ("angular_jerk_rad_s3", l.angular_jerk_rad_s3),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(Error::InvalidInput(format!(
                "motion limit {name} = {value} must be finite and positive"
            )));
        }
    }
    robot.check_len(&l.joint_accel_rad_s2, "joint_accel_rad_s2")?;
    if let Some(i) = l.joint_accel_rad_s2.iter().position(|v| *v <= 0.0) {
        return Err(Error::InvalidInput(format!(
            "joint_accel_rad_s2[{}] = {} rad/s^2 must be positive",
            i + 1,
            l.joint_accel_rad_s2[i]
        )));
    }
    let dt = options.sample_period_s;
    if !(dt.is_finite() && dt > 0.0 && dt <= 0.1) {
        return Err(Error::InvalidInput(format!(
            "sample_period_s = {dt} s must be in (0, 0.1]"
        )));
    }
    let dwell = options.dwell_s;
    if !(dwell.is_finite() && dwell >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "dwell_s = {dwell} s must be finite and non-negative"
        )));
    }
    Ok(())
}

/// Check segment `k`'s timing against the bounds.
fn check_timing(k: usize, s: &SegmentTiming, limits: &MotionLimits) -> Result<()> {
    let place = || format!("segment {}", k + 1);
    if !(s.speed_m_s.is_finite() && s.speed_m_s > 0.0) {
        return Err(Error::InvalidInput(format!(
            "{}: TCP speed {} m/s must be finite and positive",
            place(),
            s.speed_m_s
        )));
    }
    if !(s.accel_m_s2 > 0.0 && s.accel_m_s2 <= limits.accel_m_s2) {
        return Err(Error::InvalidInput(format!(
            "{}: TCP acceleration {} m/s^2 must be in (0, {}] (the motion limit accel_m_s2)",
            place(),
            s.accel_m_s2,
            limits.accel_m_s2
        )));
    }
    if !(s.dwell_s.is_finite() && s.dwell_s >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "{}: dwell {} s must be finite and non-negative",
            place(),
            s.dwell_s
        )));
    }
    Ok(())
}

/// "via point 4 'B' at (0.300, 0.300, 0.300) m" (1-based).
fn describe_via(k: usize, v: &ViaPose) -> String {
    let p = v.tcp.translation.vector;
    let name = if v.name.is_empty() {
        String::new()
    } else {
        format!(" '{}'", v.name)
    };
    format!(
        "via point {}{name} at ({:.4}, {:.4}, {:.4}) m",
        k + 1,
        p.x,
        p.y,
        p.z
    )
}

/// The same error with `place` in front of its message.
fn located(e: Error, place: &str) -> Error {
    match e {
        Error::InvalidInput(m) => Error::InvalidInput(format!("{place}: {m}")),
        Error::Unreachable(m) => Error::Unreachable(format!("{place}: {m}")),
        Error::JointLimit(m) => Error::JointLimit(format!("{place}: {m}")),
        other => other,
    }
}

/// What every segment needs: the robot, its IK, the TCP and the bounds.
struct Context<'a> {
    robot: &'a Robot,
    solver: Solver,
    tcp: &'a Isometry3<f64>,
    limits: &'a MotionLimits,
    /// Longest time between samples, s.
    period: f64,
    /// Joint velocity bounds (URDF), rad/s.
    vmax: Vec<f64>,
    /// Joint acceleration bounds, rad/s^2.
    amax: Vec<f64>,
    /// Joint names.
    names: Vec<&'a str>,
}

impl<'a> Context<'a> {
    fn new(
        robot: &'a Robot,
        solver: Solver,
        tcp: &'a Isometry3<f64>,
        options: &'a LinearMoveOptions,
    ) -> Self {
        let joints = robot.joints();
        Context {
            robot,
            solver,
            tcp,
            limits: &options.limits,
            period: options.sample_period_s,
            vmax: joints.iter().map(|j| j.limits.velocity).collect(),
            amax: options.limits.joint_accel_rad_s2.clone(),
            names: joints.iter().map(|j| j.name.as_str()).collect(),
        }
    }
}

/// One straight segment between two via poses.
struct Segment<'a> {
    /// Index, 0-based.
    index: usize,
    from: &'a ViaPose,
    to: &'a ViaPose,
    /// Translation from start to end, m (zero below [`ZERO_MOTION`]).
    delta: Vector3<f64>,
    /// Length, m.
    length: f64,
    /// Rotation axis in the base frame (unit) times the angle, rad.
    turn: Vector3<f64>,
    /// Rotation angle, rad.
    angle: f64,
}

/// One joint sample of a segment; `t` from the segment's start, s.
#[derive(Clone)]
struct JointSample {
    t: f64,
    q: Vec<f64>,
    dq: Vec<f64>,
    ddq: Vec<f64>,
}

/// A timed segment: samples after its start (the last at the end), its duration and whether
/// it was slowed.
struct PlannedSegment {
    samples: Vec<JointSample>,
    duration: f64,
    slowed: Option<SlowedSegment>,
}

/// Peak ratios of joint velocity and acceleration to their bounds, with the joints.
struct Peaks {
    velocity: (f64, usize),
    acceleration: (f64, usize),
}

impl<'a> Segment<'a> {
    fn new(index: usize, from: &'a ViaPose, to: &'a ViaPose) -> Self {
        let mut delta = to.tcp.translation.vector - from.tcp.translation.vector;
        let mut length = delta.norm();
        if length < ZERO_MOTION {
            delta = Vector3::zeros();
            length = 0.0;
        }
        let rel = to.tcp.rotation * from.tcp.rotation.inverse();
        let (turn, angle) = match rel.axis_angle() {
            Some((axis, angle)) if angle >= ZERO_MOTION => (axis.into_inner() * angle, angle),
            _ => (Vector3::zeros(), 0.0),
        };
        Segment {
            index,
            from,
            to,
            delta,
            length,
            turn,
            angle,
        }
    }

    /// "segment 3 (C -> B)" (1-based via points).
    fn describe(&self) -> String {
        let name = |k: usize, v: &ViaPose| {
            if v.name.is_empty() {
                format!("via {}", k + 1)
            } else {
                v.name.clone()
            }
        };
        format!(
            "segment {} ({} -> {})",
            self.index + 1,
            name(self.index, self.from),
            name(self.index + 1, self.to)
        )
    }

    /// Time the segment from joint configuration `q0` at the commanded speed, slowing it down
    /// for the joint limits; `None` for a segment without motion.
    fn plan(
        &self,
        ctx: &Context,
        q0: &[f64],
        timing: &SegmentTiming,
    ) -> Result<Option<PlannedSegment>> {
        if self.length == 0.0 && self.angle == 0.0 {
            return Ok(None);
        }
        let l = ctx.limits;
        let scale = timing.accel_m_s2 / l.accel_m_s2;
        // Bounds on u (1/s, 1/s^2, 1/s^3): the tighter of translation and rotation.
        let bound = |lin: f64, ang: f64| (lin / self.length).min(ang / self.angle);
        let planned = [
            bound(timing.speed_m_s, l.angular_speed_rad_s),
            bound(timing.accel_m_s2, scale * l.angular_accel_rad_s2),
            bound(scale * l.jerk_m_s3, scale * l.angular_jerk_rad_s3),
        ];
        let mut b = planned;
        // Peak u speed of the unslowed profile; the first limit violation; the last one
        // (joint, what, ratio to the limit, TCP peak speed in m/s).
        let mut planned_peak = f64::INFINITY;
        let mut first: Option<(SlowReason, usize)> = None;
        let mut last: Option<(usize, &str, f64, f64)> = None;
        for attempt in 0..MAX_ATTEMPTS {
            let profile = SCurve::new(1.0, b[0], b[1], b[2])?;
            if attempt == 0 {
                planned_peak = profile.peak_speed();
            }
            if let Some((joint, what, ratio, at)) = last
                && profile.peak_speed() < MIN_SPEED_FRACTION * planned_peak
            {
                return Err(Error::JointLimit(format!(
                    "{}: joint '{}' reaches {ratio:.2} times its {what} limit at a peak TCP \
                     speed of {at:.4} m/s, and meeting it would take the segment below {:.0} % \
                     of its planned speed (a singularity near the line?)",
                    self.describe(),
                    ctx.names[joint],
                    MIN_SPEED_FRACTION * 100.0,
                )));
            }
            let samples = self.sample(ctx, q0, &profile)?;
            let peaks = peaks(ctx, &samples);
            let (rv, jv) = peaks.velocity;
            let (ra, ja) = peaks.acceleration;
            if rv <= 1.0 && ra <= 1.0 {
                let slowed = first.map(|(reason, joint)| SlowedSegment {
                    segment: self.index,
                    commanded_m_s: planned[0] * self.length,
                    used_m_s: b[0] * self.length,
                    limiting_joint: joint,
                    reason,
                });
                return Ok(Some(PlannedSegment {
                    samples,
                    duration: profile.duration(),
                    slowed,
                }));
            }
            let by_velocity = rv >= ra.sqrt();
            let violation = if by_velocity {
                (SlowReason::JointVelocity, jv)
            } else {
                (SlowReason::JointAcceleration, ja)
            };
            first.get_or_insert(violation);
            let at = profile.peak_speed() * self.length;
            last = Some(if by_velocity {
                (jv, "velocity", rv, at)
            } else {
                (ja, "acceleration", ra, at)
            });
            if by_velocity && attempt < SPEED_ONLY_ATTEMPTS {
                b[0] = b[0].min(profile.peak_speed()) / (rv * (1.0 + SLOWDOWN_MARGIN));
            } else {
                let k = rv.max(ra.sqrt()) * (1.0 + SLOWDOWN_MARGIN);
                b = [b[0] / k, b[1] / (k * k), b[2] / (k * k * k)];
            }
        }
        Err(Error::JointLimit(format!(
            "{}: slowing down did not bring the joints within their limits after {MAX_ATTEMPTS} \
             attempts",
            self.describe()
        )))
    }

    /// Joint samples along the segment timed by `profile`, at most the sample period apart,
    /// after the start (which is `q0` at rest).
    fn sample(&self, ctx: &Context, q0: &[f64], profile: &SCurve) -> Result<Vec<JointSample>> {
        let duration = profile.duration();
        let period = ctx.period;
        let last = n_samples(duration, period);
        let h = duration / last as f64;
        let n = ctx.robot.dof();
        let free = ctx.solver.free();
        let mut jac = Matrix6xX::zeros(n);
        let mut out: Vec<JointSample> = Vec::with_capacity(last);
        let mut prev = JointSample {
            t: 0.0,
            q: q0.to_vec(),
            dq: vec![0.0; n],
            ddq: vec![0.0; n],
        };
        let mut guess = vec![0.0; n];
        let r0 = self.from.tcp.rotation;
        let p0 = self.from.tcp.translation.vector;
        for i in 1..=last {
            let t = if i == last { duration } else { i as f64 * h };
            let [u, du, ddu] = profile.sample(t);
            let pose = if i == last {
                self.to.tcp
            } else {
                Isometry3::from_parts(
                    Translation3::from(p0 + self.delta * u),
                    UnitQuaternion::from_scaled_axis(self.turn * u) * r0,
                )
            };
            let place = || {
                format!(
                    "{} at t = {t:.4} s ({:.1} % of the way)",
                    self.describe(),
                    u * 100.0
                )
            };
            // The previous sample, extrapolated (the closed form only uses it to choose the
            // nearest of its solutions).
            let step = t - prev.t;
            for (j, g) in guess.iter_mut().enumerate() {
                *g = match ctx.solver {
                    Solver::Opw(_) => prev.q[j],
                    Solver::Numeric { .. } => {
                        prev.q[j] + step * (prev.dq[j] + 0.5 * step * prev.ddq[j])
                    }
                };
            }
            let q = ctx
                .solver
                .solve(ctx.robot, &pose, ctx.tcp, &guess, true)
                .map_err(|e| located(e, &place()))?;
            geometric_into(ctx.robot, &q, ctx.tcp, &mut jac);
            let lu = square(&jac, free).lu();
            let singular = || {
                Error::Unreachable(format!(
                    "{}: the Jacobian is singular at q = {q:.4?} rad",
                    place()
                ))
            };
            let finite = |v: &Vector6<f64>| v.iter().all(|x| x.is_finite());
            let twist = stack(&(self.delta * du), &(self.turn * du));
            let rates = lu.solve(&twist).filter(finite).ok_or_else(singular)?;
            let mut dq = vec![0.0; n];
            for (k, &j) in free.iter().enumerate() {
                dq[j] = rates[k];
            }
            let acc = stack(&(self.delta * ddu), &(self.turn * ddu))
                - bias_acceleration(ctx.robot, &q, &dq, ctx.tcp);
            let accel = lu.solve(&acc).filter(finite).ok_or_else(singular)?;
            let mut ddq = vec![0.0; n];
            for (k, &j) in free.iter().enumerate() {
                ddq[j] = accel[k];
            }
            for j in 0..n {
                let jump = (q[j] - prev.q[j] - 0.5 * (dq[j] + prev.dq[j]) * step).abs();
                if jump > JUMP_TOL {
                    return Err(Error::Unreachable(format!(
                        "{}: joint '{}' jumps by {:.4} rad between samples; the inverse \
                         kinematics changes configuration (a singularity on the line)",
                        place(),
                        ctx.names[j],
                        q[j] - prev.q[j]
                    )));
                }
            }
            prev = JointSample { t, q, dq, ddq };
            out.push(prev.clone());
        }
        Ok(out)
    }
}

/// Number of samples of a segment of `duration` (s) at most `period` (s) apart.
fn n_samples(duration: f64, period: f64) -> usize {
    ((duration / period).ceil() as usize).max(1)
}

/// `[a; b]`.
fn stack(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector6<f64> {
    Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

/// Largest ratios of |dq| and |ddq| to their bounds over the samples, with the joints.
fn peaks(ctx: &Context, samples: &[JointSample]) -> Peaks {
    let mut p = Peaks {
        velocity: (0.0, 0),
        acceleration: (0.0, 0),
    };
    for s in samples {
        for (j, (vmax, amax)) in ctx.vmax.iter().zip(&ctx.amax).enumerate() {
            let rv = s.dq[j].abs() / (LIMIT_USE * vmax);
            let ra = s.ddq[j].abs() / (LIMIT_USE * amax);
            if rv > p.velocity.0 {
                p.velocity = (rv, j);
            }
            if ra > p.acceleration.0 {
                p.acceleration = (ra, j);
            }
        }
    }
    p
}

/// Joint-major sample columns for [`Sampled::new`].
struct Output {
    t: Vec<f64>,
    q: Vec<Vec<f64>>,
    dq: Vec<Vec<f64>>,
    ddq: Vec<Vec<f64>>,
}

impl Output {
    fn new(dof: usize) -> Self {
        Output {
            t: Vec::new(),
            q: vec![Vec::new(); dof],
            dq: vec![Vec::new(); dof],
            ddq: vec![Vec::new(); dof],
        }
    }

    fn push(&mut self, t: f64, q: &[f64], dq: &[f64], ddq: &[f64]) {
        self.t.push(t);
        for j in 0..self.q.len() {
            self.q[j].push(q[j]);
            self.dq[j].push(dq[j]);
            self.ddq[j].push(ddq[j]);
        }
    }
}
