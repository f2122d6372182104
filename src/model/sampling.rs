//! Seeded random joint states within a robot's limits: the one sampler behind the base-
//! parameter stack ([`crate::dynamics::base_params`]), the identifiability scan of excitation
//! design ([`crate::identification::excitation`]) and the consistency check's random poses
//! ([`crate::identification::consistency`]).
//!
//! Positions are uniform in the joint's position window ([`position_window`]): the limits,
//! narrowed to a 2 pi wide window when they are wider (a revolute joint shows every pose
//! within 2 pi), so continuous joints and limits such as `[-10, 10]` rad or `[4, 6]` rad all
//! give a non-empty range. Velocities are uniform in `±min(velocity limit, max_velocity)`
//! (rad/s) and accelerations in `±max_acceleration` (rad/s^2).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{Error, Result};
use crate::model::{JointLimits, Robot};

/// Width of the widest position window, rad: one full turn.
const FULL_TURN: f64 = 2.0 * std::f64::consts::PI;

/// The position window of a joint, rad: `[lower, upper]` when it is at most 2 pi wide,
/// otherwise the 2 pi wide window inside the limits closest to being centred on 0 (so
/// `[-pi, pi]` for limits that contain it, e.g. continuous joints or `[-10, 10]` rad).
///
/// Errors ([`Error::InvalidInput`]): a NaN limit, or `lower >= upper` (an empty range).
pub fn position_window(limits: &JointLimits) -> Result<(f64, f64)> {
    let (lower, upper) = (limits.lower, limits.upper);
    if lower.is_nan() || upper.is_nan() || lower >= upper {
        return Err(Error::InvalidInput(format!(
            "position limits [{lower}, {upper}] rad are empty or not numbers"
        )));
    }
    if upper - lower <= FULL_TURN {
        return Ok((lower, upper));
    }
    let half = 0.5 * FULL_TURN;
    let centre = 0.0_f64.clamp(lower + half, upper - half);
    Ok((centre - half, centre + half))
}

/// Seeded sampler of joint states `(q, dq, ddq)` (rad, rad/s, rad/s^2) within a robot's limits.
#[derive(Debug, Clone)]
pub struct StateSampler {
    /// Position window per joint, rad.
    windows: Vec<(f64, f64)>,
    /// Velocity bound per joint, rad/s.
    velocity: Vec<f64>,
    /// Acceleration bound, rad/s^2.
    acceleration: f64,
    rng: ChaCha8Rng,
}

impl StateSampler {
    /// A sampler for `robot` with velocities bounded by `max_velocity` (rad/s, and by each
    /// joint's limit) and accelerations by `max_acceleration` (rad/s^2), seeded with `seed`.
    ///
    /// Errors ([`Error::InvalidInput`], naming the joint): an empty or NaN position range, or a
    /// bound that is not finite and positive.
    pub fn new(
        robot: &Robot,
        max_velocity: f64,
        max_acceleration: f64,
        seed: u64,
    ) -> Result<StateSampler> {
        for (what, v) in [
            ("max_velocity (rad/s)", max_velocity),
            ("max_acceleration (rad/s^2)", max_acceleration),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::InvalidInput(format!(
                    "state sampler: {what} is {v}; it must be finite and positive"
                )));
            }
        }
        let mut windows = Vec::with_capacity(robot.dof());
        let mut velocity = Vec::with_capacity(robot.dof());
        for j in robot.joints() {
            windows.push(
                position_window(&j.limits)
                    .map_err(|e| e.context(&format!("joint '{}'", j.name)))?,
            );
            let v = j.limits.velocity.min(max_velocity);
            if v.is_nan() || v <= 0.0 {
                return Err(Error::InvalidInput(format!(
                    "joint '{}': velocity limit {} rad/s must be positive",
                    j.name, j.limits.velocity
                )));
            }
            velocity.push(v);
        }
        Ok(StateSampler {
            windows,
            velocity,
            acceleration: max_acceleration,
            rng: ChaCha8Rng::seed_from_u64(seed),
        })
    }

    /// A random position of joint `j` (0-based), rad, uniform in its [`position_window`].
    /// Panics if `j` is not a joint index of the robot (a programming error).
    pub fn position(&mut self, j: usize) -> f64 {
        let (lo, hi) = self.windows[j];
        self.rng.random_range(lo..hi)
    }

    /// Draw position, velocity and acceleration of joint `j` (0-based) into `q[j]`, `dq[j]`,
    /// `ddq[j]` (rad, rad/s, rad/s^2), in that order.
    pub fn joint(&mut self, j: usize, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        q[j] = self.position(j);
        let v = self.velocity[j];
        dq[j] = self.rng.random_range(-v..v);
        let a = self.acceleration;
        ddq[j] = self.rng.random_range(-a..a);
    }

    /// Draw a whole state, joint by joint (see [`StateSampler::joint`]). The slices have the
    /// robot's joint count.
    pub fn state(&mut self, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        for j in 0..self.windows.len() {
            self.joint(j, q, dq, ddq);
        }
    }

    /// A random pose (rad per joint).
    pub fn pose(&mut self) -> Vec<f64> {
        (0..self.windows.len()).map(|j| self.position(j)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(lower: f64, upper: f64) -> JointLimits {
        JointLimits {
            lower,
            upper,
            velocity: 1.0,
            effort: None,
        }
    }

    #[test]
    fn windows_are_the_limits_or_a_full_turn() {
        let pi = std::f64::consts::PI;
        assert_eq!(position_window(&limits(-1.0, 2.0)).unwrap(), (-1.0, 2.0));
        assert_eq!(position_window(&limits(4.0, 6.0)).unwrap(), (4.0, 6.0));
        assert_eq!(position_window(&limits(-10.0, 10.0)).unwrap(), (-pi, pi));
        let (lo, hi) = position_window(&limits(3.0, 20.0)).unwrap();
        assert_eq!(lo, 3.0);
        assert!((hi - (3.0 + 2.0 * pi)).abs() < 1e-12);
        let inf = f64::INFINITY;
        assert_eq!(position_window(&limits(-inf, inf)).unwrap(), (-pi, pi));
        assert!(position_window(&limits(1.0, -1.0)).is_err());
        assert!(position_window(&limits(1.0, 1.0)).is_err());
        assert!(position_window(&limits(f64::NAN, 1.0)).is_err());
    }
}
