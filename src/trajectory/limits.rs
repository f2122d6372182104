//! Checking a trajectory against the robot's joint limits.

use crate::Robot;
use crate::error::{Error, Result};

use super::Trajectory;

/// Acceleration bounds for excitation design on the IRB 1200, rad/s^2 per joint. ABB
/// publishes none; these are estimates (`docs/design/irb1200-data.md`, section 2).
pub const IRB1200_ACCEL_LIMITS: [f64; 6] = [15.0, 15.0, 20.0, 30.0, 30.0, 40.0];

/// Time, s, in which a joint of a robot without published acceleration bounds is assumed to
/// reach its URDF velocity limit from rest (estimate: the IRB 1200's bounds,
/// [`IRB1200_ACCEL_LIMITS`], give 0.11-0.29 s; the Franka Panda's published ones 0.13-0.29 s).
pub const ACCEL_TIME_S: f64 = 0.3;

/// Default joint acceleration bounds, rad/s^2: [`IRB1200_ACCEL_LIMITS`] for the IRB 1200
/// (robot name `abb_irb1200_7_70`), else each joint's URDF velocity limit divided by
/// [`ACCEL_TIME_S`] (an estimate; give the robot's own values where published).
pub fn default_accel_limits(robot: &Robot) -> Vec<f64> {
    if robot.name() == crate::model::builtin::IRB1200_NAME
        && robot.dof() == IRB1200_ACCEL_LIMITS.len()
    {
        return IRB1200_ACCEL_LIMITS.to_vec();
    }
    robot
        .joints()
        .iter()
        .map(|j| j.limits.velocity / ACCEL_TIME_S)
        .collect()
}

/// Sample `traj` every `dt` seconds from 0 (and at its end) and check position and velocity
/// against the robot's joint limits, and acceleration against `accel_limits` (rad/s^2, one
/// per joint) when given. A non-finite sample counts as a violation.
///
/// Errors: [`Error::JointLimit`] for the first violation in time, naming the joint, the time
/// (s), the value and the limit; [`Error::InvalidInput`] when the trajectory's dof differs
/// from the robot's, `dt` is not positive and finite, the duration is not finite and
/// non-negative, or `accel_limits` has the wrong length or a non-positive entry.
pub fn check_limits(
    robot: &Robot,
    traj: &dyn Trajectory,
    dt: f64,
    accel_limits: Option<&[f64]>,
) -> Result<()> {
    let n = robot.dof();
    if traj.dof() != n {
        return Err(Error::InvalidInput(format!(
            "the trajectory has {} joints, the robot {n}",
            traj.dof()
        )));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::InvalidInput(format!(
            "check step dt = {dt} s must be finite and positive"
        )));
    }
    let duration = traj.duration();
    if !(duration.is_finite() && duration >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "trajectory duration {duration} s must be finite and non-negative"
        )));
    }
    if let Some(acc) = accel_limits {
        robot.check_len(acc, "acceleration limits")?;
        if let Some(i) = acc.iter().position(|v| *v <= 0.0) {
            return Err(Error::InvalidInput(format!(
                "acceleration limit of joint {} is {} rad/s^2 (must be positive)",
                i + 1,
                acc[i]
            )));
        }
    }
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut k = 0u64;
    loop {
        let t = (k as f64 * dt).min(duration);
        traj.sample(t, &mut q, &mut dq, &mut ddq);
        for (i, joint) in robot.joints().iter().enumerate() {
            let lim = &joint.limits;
            let what = || format!("joint {} '{}' at t = {t:.6} s", i + 1, joint.name);
            if q[i].is_nan() || q[i] < lim.lower || q[i] > lim.upper {
                return Err(Error::JointLimit(format!(
                    "{}: position {:.6} rad is outside [{:.6}, {:.6}] rad",
                    what(),
                    q[i],
                    lim.lower,
                    lim.upper
                )));
            }
            if exceeds(dq[i], lim.velocity) {
                return Err(Error::JointLimit(format!(
                    "{}: velocity {:.6} rad/s exceeds the limit {:.6} rad/s",
                    what(),
                    dq[i],
                    lim.velocity
                )));
            }
            if let Some(acc) = accel_limits
                && exceeds(ddq[i], acc[i])
            {
                return Err(Error::JointLimit(format!(
                    "{}: acceleration {:.6} rad/s^2 exceeds the limit {:.6} rad/s^2",
                    what(),
                    ddq[i],
                    acc[i]
                )));
            }
        }
        if t >= duration {
            return Ok(());
        }
        k += 1;
    }
}

/// Whether `|value|` is above `limit` or not a number.
fn exceeds(value: f64, limit: f64) -> bool {
    value.is_nan() || value.abs() > limit
}
