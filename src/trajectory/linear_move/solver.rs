//! The inverse kinematics of a plan: closed form for the OPW class, else damped least squares.

use nalgebra::{Isometry3, Matrix6, Matrix6xX};

use crate::error::{Error, Result};
use crate::kinematics::dls::{self, DlsOptions};
use crate::kinematics::ik::Opw;
use crate::kinematics::jacobian::geometric_into;
use crate::model::Robot;

use super::checks::{describe_via, located};
use super::{LinearMoveOptions, ViaPose};

/// Initial damping of the numerical IK between samples, where the start is within
/// micrometres of the solution and Gauss-Newton steps converge at once (see [`DlsOptions`]).
const TRACKING_DAMPING: f64 = 1e-9;

/// The inverse kinematics of a plan.
pub(super) enum Solver {
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
    pub(super) fn new(
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

    pub(super) fn numeric(n: usize, held: Vec<usize>) -> Solver {
        let free = (0..n).filter(|j| !held.contains(j)).collect();
        Solver::Numeric { held, free }
    }

    /// Joint angles (rad) putting the TCP at `pose`, nearest `seed` (closed form) or found
    /// from `seed` (numerical; `tracking`: the seed is within micrometres, so start with
    /// Gauss-Newton steps).
    pub(super) fn solve(
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
    pub(super) fn via_points(
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
    pub(super) fn free(&self) -> &[usize] {
        const ALL: [usize; 6] = [0, 1, 2, 3, 4, 5];
        match self {
            Solver::Opw(_) => &ALL,
            Solver::Numeric { free, .. } => free,
        }
    }

    /// Smallest singular value of the square Jacobian of the free joints at `q`.
    pub(super) fn smallest_singular_value(
        &self,
        robot: &Robot,
        q: &[f64],
        tcp: &Isometry3<f64>,
    ) -> f64 {
        let mut jac = Matrix6xX::zeros(robot.dof());
        geometric_into(robot, q, tcp, &mut jac);
        square(&jac, self.free()).singular_values().min()
    }
}

/// The 6 x 6 matrix of the columns `free` of `jac`.
pub(super) fn square(jac: &Matrix6xX<f64>, free: &[usize]) -> Matrix6<f64> {
    Matrix6::from_fn(|r, c| jac[(r, free[c])])
}
