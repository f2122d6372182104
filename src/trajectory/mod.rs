//! Joint trajectories: what the twin's controller tracks.
//!
//! A [`Trajectory`] gives the reference position, velocity and acceleration of every joint
//! (rad, rad/s, rad/s^2) at any time `t` in `[0, duration]` (s). Implementations: sampled
//! tables with smooth interpolation, finite Fourier series (paper eq. 7), rest-to-rest
//! point-to-point motions, seeded random generators for bulk datasets, and linear TCP moves
//! ([`linear_move`], timed by [`s_curve`]) for tasks such as the paper's pick and place
//! ([`task`]).
//! [`limits::check_limits`] samples any trajectory against the robot's joint limits, as
//! narrowed by a robot cell ([`cell`]). [`table`] and [`urscript`] export a trajectory for a
//! controller.

pub mod cell;
pub mod fourier;
pub mod limits;
pub mod linear_move;
pub mod point_to_point;
pub mod random;
pub mod s_curve;
pub mod sampled;
pub mod table;
pub mod task;
pub mod urscript;

/// A joint-space reference trajectory.
pub trait Trajectory: Send + Sync {
    /// Number of joints.
    fn dof(&self) -> usize;
    /// Duration, s. The trajectory is defined on `[0, duration]`.
    fn duration(&self) -> f64;
    /// Reference position (rad), velocity (rad/s) and acceleration (rad/s^2) at time `t` (s),
    /// written into slices of length [`Trajectory::dof`]. Times outside `[0, duration]` are
    /// clamped. Must not allocate.
    fn sample(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]);
    /// Expected sign of each joint's Coulomb friction at time `t` (s), given the speeds `dq`
    /// (rad/s) [`Trajectory::sample`] gave there, written into `s` (in `[-1, 1]`, length
    /// [`Trajectory::dof`]). The default, for a motion known exactly, is
    /// [`crate::dynamics::sign`]`(dq)`. A motion estimated from noisy positions weighs it
    /// down where the joint is not seen to move ([`sampled::Sampled::with_move_weights`]).
    /// Must not allocate.
    fn coulomb_signs(&self, _t: f64, dq: &[f64], s: &mut [f64]) {
        exact_coulomb_signs(dq, s);
    }
}

/// The Coulomb signs of a motion known exactly: [`crate::dynamics::sign`] of each speed in
/// `dq` (rad/s), written into `s`.
pub fn exact_coulomb_signs(dq: &[f64], s: &mut [f64]) {
    for (si, &v) in s.iter_mut().zip(dq) {
        *si = crate::dynamics::sign(v);
    }
}
