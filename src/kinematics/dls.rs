//! Numerical inverse kinematics for any serial chain: damped least squares
//! (Levenberg–Marquardt with adaptive damping).
//!
//! The residual is the 6-vector `e = [p_target - p; log(R_target R^T)]` of the TCP in the base
//! frame (frame 0 of the model): position error in m, orientation error as a rotation vector
//! in rad. A step solves `(J^T J + lambda I) dq = J^T e` with the geometric Jacobian `J`
//! ([`crate::kinematics::jacobian`]), clamps `q + dq` into the position limits and is kept
//! only if it lowers `|e|^2`; `lambda` is divided by 10 after an accepted step and multiplied
//! by 10 after a rejected one. Joint angles are in rad.
//!
//! [`solve_held`] keeps some joints at their seed values (their Jacobian columns are left out),
//! which turns a redundant arm into a square problem with a locally unique solution.

use nalgebra::{Isometry3, Matrix6xX, UnitQuaternion, Vector3, Vector6};

use crate::error::{Error, Result};
use crate::kinematics::fk::tcp_pose;
use crate::kinematics::jacobian::geometric_into;
use crate::model::Robot;
use crate::numerics::lm;

/// Smallest damping used (Gauss–Newton steps in practice).
const MIN_DAMPING: f64 = 1e-12;
/// Damping beyond which no step lowers the error any more: the solver is stuck.
const MAX_DAMPING: f64 = 1e12;

/// Settings of [`solve`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DlsOptions {
    /// Maximum number of steps tried (accepted or rejected); each costs one FK evaluation.
    pub max_iterations: usize,
    /// Converged when the TCP position error is below this, m.
    pub position_tolerance: f64,
    /// ... and the TCP orientation error is below this, rad.
    pub orientation_tolerance: f64,
    /// Initial damping `lambda` (units of `J^T J`: m^2 per rad^2 for the position rows,
    /// dimensionless for the orientation rows).
    pub initial_damping: f64,
}

impl Default for DlsOptions {
    /// 500 steps, 1e-10 m, 1e-10 rad, initial damping 1e-3.
    fn default() -> Self {
        DlsOptions {
            max_iterations: 500,
            position_tolerance: 1e-10,
            orientation_tolerance: 1e-10,
            initial_damping: 1e-3,
        }
    }
}

/// Joint angles (rad, within the position limits) that put the TCP at `target_tcp`, found by
/// damped least squares started at `seed` (rad; clamped into the limits first). `target_tcp`
/// is the TCP pose in the base frame, `tcp` the TCP pose in the flange frame (m).
///
/// The result is a local solution, usually the one nearest the seed.
///
/// # Errors
/// [`Error::InvalidInput`] for a seed of the wrong length or non-finite inputs;
/// [`Error::Unreachable`] when the error does not reach the tolerances within
/// `opts.max_iterations` steps or no step lowers it any more (pose out of reach, blocked by a
/// joint limit, or a seed in another basin); the message gives the final errors.
pub fn solve(
    robot: &Robot,
    target_tcp: &Isometry3<f64>,
    tcp: &Isometry3<f64>,
    seed: &[f64],
    opts: &DlsOptions,
) -> Result<Vec<f64>> {
    solve_held(robot, target_tcp, tcp, seed, opts, &[])
}

/// [`solve`] with the joints `held` (0-based) kept at their seed values (clamped into their
/// limits): only the other joints move. With `n - 6` joints held on an `n`-joint arm the
/// problem is square, so the solution near the seed is locally unique.
///
/// # Errors
/// Those of [`solve`], and [`Error::InvalidInput`] for a held joint index out of range.
pub fn solve_held(
    robot: &Robot,
    target_tcp: &Isometry3<f64>,
    tcp: &Isometry3<f64>,
    seed: &[f64],
    opts: &DlsOptions,
    held: &[usize],
) -> Result<Vec<f64>> {
    robot.check_len(seed, "seed")?;
    if let Some(j) = held.iter().find(|&&j| j >= robot.dof()) {
        return Err(Error::InvalidInput(format!(
            "held joint index {j} is out of range for {} joints",
            robot.dof()
        )));
    }
    ensure_pose_finite(target_tcp, "target TCP pose")?;
    ensure_pose_finite(tcp, "TCP offset")?;
    let n = robot.dof();
    let limits: Vec<(f64, f64)> = robot
        .joints()
        .iter()
        .map(|j| (j.limits.lower, j.limits.upper))
        .collect();
    let q: Vec<f64> = seed
        .iter()
        .zip(&limits)
        .map(|(&s, &(lo, hi))| s.clamp(lo, hi))
        .collect();
    let mut jac = Matrix6xX::zeros(n);
    let err = pose_error(target_tcp, &geometric_into(robot, &q, tcp, &mut jac));
    hold_columns(&mut jac, held);
    let mut problem = Ik {
        robot,
        target_tcp,
        tcp,
        held,
        limits: &limits,
        opts,
        trial: q.clone(),
        q,
        jac,
        err,
    };
    let report = lm::minimise(
        &mut problem,
        &lm::Options {
            max_iterations: opts.max_iterations,
            max_tries: 1,
            initial_damping: opts.initial_damping,
            min_damping: MIN_DAMPING,
            max_damping: MAX_DAMPING,
            shrink: lm::Shrink::Multiply(0.1),
            fall: None,
            stall: None,
            stop_when_stuck: false,
        },
    );
    let (q, err, steps) = (problem.q, problem.err, report.iterations);
    if converged(&err, opts) {
        return Ok(q);
    }
    Err(Error::Unreachable(format!(
        "damped least squares did not converge from the seed in {steps} steps: position error \
         {:.3e} m, orientation error {:.3e} rad (tolerances {:.1e} m, {:.1e} rad); the pose may \
         be out of reach or blocked by a joint limit, or the seed too far from a solution",
        err.fixed_rows::<3>(0).norm(),
        err.fixed_rows::<3>(3).norm(),
        opts.position_tolerance,
        opts.orientation_tolerance
    )))
}

/// Damped least squares as a problem of [`lm::minimise`]: the pose error at `q`, a step
/// `(J^T J + lambda I) dq = J^T e` clamped into the position limits, one trial per iteration
/// (each costs one FK evaluation).
struct Ik<'a> {
    robot: &'a Robot,
    target_tcp: &'a Isometry3<f64>,
    tcp: &'a Isometry3<f64>,
    held: &'a [usize],
    /// Position limits `(lower, upper)` per joint, rad.
    limits: &'a [(f64, f64)],
    opts: &'a DlsOptions,
    /// Joint angles, rad.
    q: Vec<f64>,
    /// Storage of the trial angles, rad.
    trial: Vec<f64>,
    /// Geometric Jacobian at `q`, the held joints' columns zero.
    jac: Matrix6xX<f64>,
    /// Pose error at `q` (m, rad).
    err: Vector6<f64>,
}

impl lm::Problem for Ik<'_> {
    type Trial = Vector6<f64>;

    fn cost(&self) -> f64 {
        self.err.norm_squared()
    }

    fn converged(&self) -> bool {
        converged(&self.err, self.opts)
    }

    fn trial(&mut self, lambda: f64) -> Option<(Vector6<f64>, f64)> {
        let jt = self.jac.transpose();
        let mut a = &jt * &self.jac;
        for i in 0..self.q.len() {
            a[(i, i)] += lambda;
        }
        let chol = a.cholesky()?;
        let dq = chol.solve(&(&jt * self.err));
        for ((t, (&qi, &d)), &(lo, hi)) in self
            .trial
            .iter_mut()
            .zip(self.q.iter().zip(dq.iter()))
            .zip(self.limits)
        {
            *t = (qi + d).clamp(lo, hi);
        }
        let trial_err = pose_error(
            self.target_tcp,
            &tcp_pose(self.robot, &self.trial, self.tcp),
        );
        Some((trial_err, trial_err.norm_squared()))
    }

    fn accept(&mut self, _trial_err: Vector6<f64>, _cost: f64) {
        std::mem::swap(&mut self.q, &mut self.trial);
        self.err = pose_error(
            self.target_tcp,
            &geometric_into(self.robot, &self.q, self.tcp, &mut self.jac),
        );
        hold_columns(&mut self.jac, self.held);
    }
}

/// Zero the Jacobian columns of the held joints: the damped step then leaves them alone.
fn hold_columns(jac: &mut Matrix6xX<f64>, held: &[usize]) {
    for &j in held {
        jac.column_mut(j).fill(0.0);
    }
}

fn converged(err: &Vector6<f64>, opts: &DlsOptions) -> bool {
    err.fixed_rows::<3>(0).norm() < opts.position_tolerance
        && err.fixed_rows::<3>(3).norm() < opts.orientation_tolerance
}

/// `[p_target - p; log(R_target R^T)]` in the base frame (m, rad).
fn pose_error(target: &Isometry3<f64>, current: &Isometry3<f64>) -> Vector6<f64> {
    let dp = target.translation.vector - current.translation.vector;
    let dr = rotation_vector(&(target.rotation * current.rotation.inverse()));
    Vector6::new(dp.x, dp.y, dp.z, dr.x, dr.y, dr.z)
}

/// Rotation vector (axis times angle in [0, pi], rad) of a unit quaternion, accurate for tiny
/// angles (nalgebra's `scaled_axis` goes through `acos` and loses them below about 1e-8).
fn rotation_vector(r: &UnitQuaternion<f64>) -> Vector3<f64> {
    let (w, v) = if r.w < 0.0 {
        (-r.w, -r.imag())
    } else {
        (r.w, r.imag())
    };
    let s = v.norm();
    if s == 0.0 {
        return Vector3::zeros();
    }
    v * (2.0 * s.atan2(w) / s)
}

/// [`Error::InvalidInput`] unless every coordinate of `pose` is finite; `what` names it.
pub(crate) fn ensure_pose_finite(pose: &Isometry3<f64>, what: &str) -> Result<()> {
    let ok = pose.translation.vector.iter().all(|v| v.is_finite())
        && pose.rotation.coords.iter().all(|v| v.is_finite());
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidInput(format!("{what} is not finite: {pose}")))
    }
}
