//! Timing and sampling of one straight segment, slowed down for the joint limits.

use nalgebra::{Isometry3, Matrix6xX, Translation3, UnitQuaternion, Vector3, Vector6};

use crate::error::{Error, Result};
use crate::kinematics::jacobian::{bias_acceleration, geometric_into};
use crate::model::Robot;

use super::checks::located;
use super::solver::{Solver, square};
use super::{
    LinearMoveOptions, MIN_SPEED_FRACTION, MotionLimits, SegmentTiming, SlowReason, SlowedSegment,
    ViaPose,
};
use crate::trajectory::s_curve::SCurve;

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

/// What every segment needs: the robot, its IK, the TCP and the bounds.
pub(super) struct Context<'a> {
    pub(super) robot: &'a Robot,
    pub(super) solver: Solver,
    pub(super) tcp: &'a Isometry3<f64>,
    pub(super) limits: &'a MotionLimits,
    /// Longest time between samples, s.
    pub(super) period: f64,
    /// Joint velocity bounds (URDF), rad/s.
    pub(super) vmax: Vec<f64>,
    /// Joint acceleration bounds, rad/s^2.
    pub(super) amax: Vec<f64>,
    /// Joint names.
    pub(super) names: Vec<&'a str>,
}

impl<'a> Context<'a> {
    pub(super) fn new(
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
            amax: options.limits.joint_accel_for(robot),
            names: joints.iter().map(|j| j.name.as_str()).collect(),
        }
    }
}

/// One straight segment between two via poses.
pub(super) struct Segment<'a> {
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
pub(super) struct JointSample {
    pub(super) t: f64,
    pub(super) q: Vec<f64>,
    pub(super) dq: Vec<f64>,
    pub(super) ddq: Vec<f64>,
}

/// A timed segment: samples after its start (the last at the end), its duration and whether
/// it was slowed.
pub(super) struct PlannedSegment {
    pub(super) samples: Vec<JointSample>,
    pub(super) duration: f64,
    pub(super) slowed: Option<SlowedSegment>,
}

/// The largest ratio of a joint's |dq| or |ddq| to its bound over a segment's samples.
#[derive(Clone, Copy)]
struct Peak {
    /// Ratio to the bound (with [`LIMIT_USE`]); above 1 is a violation.
    ratio: f64,
    /// Joint, 0-based.
    joint: usize,
}

/// Peak ratios of joint velocity and acceleration to their bounds.
struct Peaks {
    velocity: Peak,
    acceleration: Peak,
}

impl<'a> Segment<'a> {
    pub(super) fn new(index: usize, from: &'a ViaPose, to: &'a ViaPose) -> Self {
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
    pub(super) fn plan(
        &self,
        ctx: &Context,
        q0: &[f64],
        timing: &SegmentTiming,
    ) -> Result<Option<PlannedSegment>> {
        if self.length == 0.0 && self.angle == 0.0 {
            return Ok(None);
        }
        let planned = self.u_bounds(ctx.limits, timing);
        let mut b = planned;
        // Peak u speed of the unslowed profile; the first limit violation (reason, joint);
        // the last one.
        let mut planned_peak = f64::INFINITY;
        let mut first: Option<(SlowReason, usize)> = None;
        let mut last: Option<Violation> = None;
        for attempt in 0..MAX_ATTEMPTS {
            let profile = SCurve::new(1.0, b[0], b[1], b[2])?;
            if attempt == 0 {
                planned_peak = profile.peak_speed();
            }
            if let Some(v) = last
                && profile.peak_speed() < MIN_SPEED_FRACTION * planned_peak
            {
                return Err(self.too_slow(ctx, &v));
            }
            let samples = self.sample(ctx, q0, &profile)?;
            let peaks = peaks(ctx, &samples);
            let (rv, ra) = (peaks.velocity.ratio, peaks.acceleration.ratio);
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
            let v = Violation::of(&peaks, profile.peak_speed() * self.length);
            first.get_or_insert((v.reason, v.joint));
            last = Some(v);
            let speed_only = v.by_velocity && attempt < SPEED_ONLY_ATTEMPTS;
            b = slower_bounds(b, profile.peak_speed(), rv, ra, speed_only);
        }
        Err(Error::JointLimit(format!(
            "{}: slowing down did not bring the joints within their limits after {MAX_ATTEMPTS} \
             attempts",
            self.describe()
        )))
    }

    /// Bounds on the path parameter `u` (speed 1/s, acceleration 1/s^2, jerk 1/s^3): the
    /// tighter of translation and rotation at the segment's commanded timing.
    fn u_bounds(&self, l: &MotionLimits, timing: &SegmentTiming) -> [f64; 3] {
        let scale = timing.accel_m_s2 / l.accel_m_s2;
        let bound = |lin: f64, ang: f64| (lin / self.length).min(ang / self.angle);
        [
            bound(timing.speed_m_s, l.angular_speed_rad_s),
            bound(timing.accel_m_s2, scale * l.angular_accel_rad_s2),
            bound(scale * l.jerk_m_s3, scale * l.angular_jerk_rad_s3),
        ]
    }

    /// The error when meeting the limit violation `v` would take the segment below the
    /// smallest allowed fraction of its planned speed.
    fn too_slow(&self, ctx: &Context, v: &Violation) -> Error {
        let Violation {
            joint,
            what,
            ratio,
            at,
            ..
        } = *v;
        Error::JointLimit(format!(
            "{}: joint '{}' reaches {ratio:.2} times its {what} limit at a peak TCP \
             speed of {at:.4} m/s, and meeting it would take the segment below {:.0} % \
             of its planned speed (a singularity near the line?)",
            self.describe(),
            ctx.names[joint],
            MIN_SPEED_FRACTION * 100.0,
        ))
    }

    /// Joint samples along the segment timed by `profile`, at most the sample period apart,
    /// after the start (which is `q0` at rest).
    fn sample(&self, ctx: &Context, q0: &[f64], profile: &SCurve) -> Result<Vec<JointSample>> {
        let duration = profile.duration();
        let period = ctx.period;
        let last = n_samples(duration, period);
        let h = duration / last as f64;
        let n = ctx.robot.dof();
        let mut jac = Matrix6xX::zeros(n);
        let mut out: Vec<JointSample> = Vec::with_capacity(last);
        let mut prev = JointSample {
            t: 0.0,
            q: q0.to_vec(),
            dq: vec![0.0; n],
            ddq: vec![0.0; n],
        };
        let mut guess = vec![0.0; n];
        for i in 1..=last {
            let t = if i == last { duration } else { i as f64 * h };
            let [u, du, ddu] = profile.sample(t);
            let pose = self.pose_at(u, i == last);
            let place = || {
                format!(
                    "{} at t = {t:.4} s ({:.1} % of the way)",
                    self.describe(),
                    u * 100.0
                )
            };
            let step = t - prev.t;
            extrapolate(ctx, &prev, step, &mut guess);
            let q = ctx
                .solver
                .solve(ctx.robot, &pose, ctx.tcp, &guess, true)
                .map_err(|e| located(e, &place()))?;
            let (dq, ddq) = self.joint_rates(ctx, &q, [du, ddu], &mut jac, &place)?;
            check_jumps(ctx, &prev, &q, &dq, step, &place)?;
            prev = JointSample { t, q, dq, ddq };
            out.push(prev.clone());
        }
        Ok(out)
    }

    /// TCP pose (base frame) at path parameter `u`; exactly the end pose when `end`.
    fn pose_at(&self, u: f64, end: bool) -> Isometry3<f64> {
        if end {
            self.to.tcp
        } else {
            let r0 = self.from.tcp.rotation;
            let p0 = self.from.tcp.translation.vector;
            Isometry3::from_parts(
                Translation3::from(p0 + self.delta * u),
                UnitQuaternion::from_scaled_axis(self.turn * u) * r0,
            )
        }
    }

    /// Joint velocities (rad/s) and accelerations (rad/s^2) at configuration `q` (rad) that
    /// move the TCP along the segment with path rates `[du, ddu]` (1/s, 1/s^2); `jac` is
    /// scratch space for the Jacobian and `place` names the sample in errors.
    fn joint_rates(
        &self,
        ctx: &Context,
        q: &[f64],
        [du, ddu]: [f64; 2],
        jac: &mut Matrix6xX<f64>,
        place: &dyn Fn() -> String,
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = ctx.robot.dof();
        let free = ctx.solver.free();
        geometric_into(ctx.robot, q, ctx.tcp, jac);
        let lu = square(jac, free).lu();
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
            - bias_acceleration(ctx.robot, q, &dq, ctx.tcp);
        let accel = lu.solve(&acc).filter(finite).ok_or_else(singular)?;
        let mut ddq = vec![0.0; n];
        for (k, &j) in free.iter().enumerate() {
            ddq[j] = accel[k];
        }
        Ok((dq, ddq))
    }
}

/// A joint limit violation of a segment's samples.
#[derive(Clone, Copy)]
struct Violation {
    /// Whether the velocity bound is the one to meet (else the acceleration bound).
    by_velocity: bool,
    reason: SlowReason,
    /// Joint, 0-based.
    joint: usize,
    /// "velocity" or "acceleration".
    what: &'static str,
    /// Ratio of the joint's peak to its bound.
    ratio: f64,
    /// Peak TCP speed of the profile, m/s.
    at: f64,
}

impl Violation {
    /// The violation to meet given the sample `peaks` of a profile with peak TCP speed `at`
    /// (m/s): the velocity bound unless the acceleration ratio's square root is larger.
    fn of(peaks: &Peaks, at: f64) -> Self {
        let (rv, jv) = (peaks.velocity.ratio, peaks.velocity.joint);
        let (ra, ja) = (peaks.acceleration.ratio, peaks.acceleration.joint);
        let by_velocity = rv >= ra.sqrt();
        let (reason, joint, what, ratio) = if by_velocity {
            (SlowReason::JointVelocity, jv, "velocity", rv)
        } else {
            (SlowReason::JointAcceleration, ja, "acceleration", ra)
        };
        Violation {
            by_velocity,
            reason,
            joint,
            what,
            ratio,
            at,
        }
    }
}

/// Bounds on `u` for the next attempt after peak ratios `rv` (velocity) and `ra`
/// (acceleration): with `speed_only` only the speed bound drops below the profile's peak
/// speed `peak` (1/s), else the whole profile is stretched in time.
fn slower_bounds(b: [f64; 3], peak: f64, rv: f64, ra: f64, speed_only: bool) -> [f64; 3] {
    if speed_only {
        [b[0].min(peak) / (rv * (1.0 + SLOWDOWN_MARGIN)), b[1], b[2]]
    } else {
        let k = rv.max(ra.sqrt()) * (1.0 + SLOWDOWN_MARGIN);
        [b[0] / k, b[1] / (k * k), b[2] / (k * k * k)]
    }
}

/// Fills `guess` with the IK starting point for a sample `step` (s) after `prev`: the previous
/// configuration, extrapolated for the numeric solver (the closed form only uses it to choose
/// the nearest of its solutions), rad.
fn extrapolate(ctx: &Context, prev: &JointSample, step: f64, guess: &mut [f64]) {
    for (j, g) in guess.iter_mut().enumerate() {
        *g = match ctx.solver {
            Solver::Opw(_) => prev.q[j],
            Solver::Numeric { .. } => prev.q[j] + step * (prev.dq[j] + 0.5 * step * prev.ddq[j]),
        };
    }
}

/// Fails when a joint's step from `prev` to `q` (rad) departs from the trapezoidal integral of
/// its velocities `prev.dq`, `dq` over `step` (s) by more than [`JUMP_TOL`]: the inverse
/// kinematics changed configuration.
fn check_jumps(
    ctx: &Context,
    prev: &JointSample,
    q: &[f64],
    dq: &[f64],
    step: f64,
    place: &dyn Fn() -> String,
) -> Result<()> {
    for j in 0..ctx.robot.dof() {
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
    Ok(())
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
    let none = Peak {
        ratio: 0.0,
        joint: 0,
    };
    let mut p = Peaks {
        velocity: none,
        acceleration: none,
    };
    for s in samples {
        for (j, (vmax, amax)) in ctx.vmax.iter().zip(&ctx.amax).enumerate() {
            let rv = s.dq[j].abs() / (LIMIT_USE * vmax);
            let ra = s.ddq[j].abs() / (LIMIT_USE * amax);
            if rv > p.velocity.ratio {
                p.velocity = Peak {
                    ratio: rv,
                    joint: j,
                };
            }
            if ra > p.acceleration.ratio {
                p.acceleration = Peak {
                    ratio: ra,
                    joint: j,
                };
            }
        }
    }
    p
}
