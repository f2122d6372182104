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
//!
//! [`SCurve`]: super::s_curve::SCurve
//! [`Opw::solve_nearest`]: crate::kinematics::ik::Opw::solve_nearest
//! [`dls::solve_held`]: crate::kinematics::dls::solve_held
//! [`bias_acceleration`]: crate::kinematics::jacobian::bias_acceleration

mod checks;
mod segment;
mod solver;

use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::model::Robot;

use super::Trajectory;
use super::limits::{IRB1200_ACCEL_LIMITS, default_accel_limits};
use super::sampled::Sampled;

use checks::{check_timing, validate};
use segment::{Context, Segment};
use solver::Solver;

/// A segment may be slowed until its peak TCP speed is this fraction of the unslowed one;
/// needing less is reported as an error ([`Error::JointLimit`]).
pub const MIN_SPEED_FRACTION: f64 = 0.01;

/// Cartesian and joint bounds of a linear move.
///
/// Defaults ([`MotionLimits::default`]): the Cartesian limits that the MoveIt Setup Assistant
/// writes for the Pilz planner (`max_trans_acc` 2.25 m/s^2, `max_rot_vel` 1.57 rad/s), plus
/// estimates where it gives none, and joint acceleration bounds taken from the robot
/// ([`default_accel_limits`]: the robot's own where known, else its URDF velocity limits over
/// [`ACCEL_TIME_S`](super::limits::ACCEL_TIME_S)). [`MotionLimits::irb1200`] gives the
/// IRB 1200's bounds explicitly.
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
    /// Joint acceleration bounds, rad/s^2, one per joint, or empty (the default) for the
    /// robot's own: [`default_accel_limits`] of the planned robot. Joint velocity bounds are
    /// the robot model's (URDF).
    pub joint_accel_rad_s2: Vec<f64>,
}

impl Default for MotionLimits {
    /// The Pilz Cartesian defaults, joint acceleration bounds from the robot (empty).
    fn default() -> Self {
        MotionLimits {
            accel_m_s2: 2.25,
            jerk_m_s3: 20.0,
            angular_speed_rad_s: 1.57,
            angular_accel_rad_s2: 2.25 * 1.57,
            angular_jerk_rad_s3: 20.0 * 1.57,
            joint_accel_rad_s2: Vec::new(),
        }
    }
}

impl MotionLimits {
    /// The IRB 1200's bounds: the Pilz Cartesian limits as configured for it in
    /// PickNikRobotics/abb_ros2 (`pilz_cartesian_limits.yaml`), and its joint acceleration
    /// bounds [`IRB1200_ACCEL_LIMITS`] (estimates; ABB publishes none).
    pub fn irb1200() -> Self {
        MotionLimits {
            joint_accel_rad_s2: IRB1200_ACCEL_LIMITS.to_vec(),
            ..MotionLimits::default()
        }
    }

    /// The joint acceleration bounds for `robot`, rad/s^2: [`Self::joint_accel_rad_s2`] when
    /// given, else [`default_accel_limits`].
    pub fn joint_accel_for(&self, robot: &Robot) -> Vec<f64> {
        if self.joint_accel_rad_s2.is_empty() {
            default_accel_limits(robot)
        } else {
            self.joint_accel_rad_s2.clone()
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
