//! Checks of the options and timings, and error messages that name a via point.

use crate::error::{Error, Result};
use crate::model::Robot;

use super::{LinearMoveOptions, MotionLimits, SegmentTiming, ViaPose};

/// Check the options against the robot.
pub(super) fn validate(robot: &Robot, options: &LinearMoveOptions) -> Result<()> {
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
    if !l.joint_accel_rad_s2.is_empty() {
        robot.check_len(&l.joint_accel_rad_s2, "joint_accel_rad_s2")?;
    }
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
pub(super) fn check_timing(k: usize, s: &SegmentTiming, limits: &MotionLimits) -> Result<()> {
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
pub(super) fn describe_via(k: usize, v: &ViaPose) -> String {
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
pub(super) fn located(e: Error, place: &str) -> Error {
    match e {
        Error::InvalidInput(m) => Error::InvalidInput(format!("{place}: {m}")),
        Error::Unreachable(m) => Error::Unreachable(format!("{place}: {m}")),
        Error::JointLimit(m) => Error::JointLimit(format!("{place}: {m}")),
        other => other,
    }
}
