//! One bounded Levenberg–Marquardt loop for every nonlinear least-squares problem of the
//! crate: the power fit ([`crate::identification::fit`]), the consistent projection
//! ([`crate::identification::consistent`]) and the damped least-squares inverse kinematics
//! ([`crate::kinematics::dls`]).
//!
//! The loop owns what the three share: the damping schedule (multiplied by 10 after a
//! rejected or unsolvable trial, shrunk after an accepted one, within bounds), the tries per
//! iteration, and the stopping rules (iteration limit, a converged problem, a small fall of
//! the cost, a stalled cost, no accepted step). The problem ([`Problem`]) owns its residual,
//! its Jacobian and how the damping enters its step (Marquardt's scaled diagonal, natural
//! units, a plain `lambda I`), and with them its bounds: held parameters and an active set
//! ([`hold`]), projection onto bounds, a step cap ([`cap_step`]). Each caller so performs the
//! floating-point operations of its own method in its own order.

use std::collections::VecDeque;

use nalgebra::{DMatrix, DVector};

/// A nonlinear least-squares problem at its current point.
pub trait Problem {
    /// A trial point with whatever the problem keeps of its evaluation.
    type Trial;

    /// Cost (the squared residual norm) at the current point.
    fn cost(&self) -> f64;

    /// Whether the current point already meets the problem's own tolerances (checked before
    /// every iteration).
    fn converged(&self) -> bool {
        false
    }

    /// Linearise at the current point: called once per iteration, before its tries.
    fn linearise(&mut self) {}

    /// The trial point of the step damped by `damping`, with its cost; `None` when the damped
    /// system cannot be solved or the trial is not finite (the damping then grows).
    fn trial(&mut self, damping: f64) -> Option<(Self::Trial, f64)>;

    /// Move to `trial`, whose cost is `cost`.
    fn accept(&mut self, trial: Self::Trial, cost: f64);
}

/// How the damping shrinks after an accepted step (before its floor).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shrink {
    /// `damping / d`.
    Divide(f64),
    /// `damping * f`.
    Multiply(f64),
}

/// Stop when an accepted step lowers the cost by a small fall:
/// `(before - after) * scale / max(before, 1e-300) <= threshold`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fall {
    /// Factor of the relative fall (e.g. the residual's degrees of freedom, for a fall in
    /// units of the residual variance).
    pub scale: f64,
    /// Largest fall that counts as converged.
    pub threshold: f64,
}

/// Stop when the cost fell by at most `fraction` of itself over the last `window` iterations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stall {
    /// Iterations over which the fall is measured.
    pub window: usize,
    /// Largest relative fall over the window that counts as stalled.
    pub fraction: f64,
}

/// Settings of [`minimise`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Iteration limit (an iteration linearises once and makes up to `max_tries` trials).
    pub max_iterations: usize,
    /// Trials per iteration, each with ten times the damping of the one before.
    pub max_tries: usize,
    /// Damping of the first trial.
    pub initial_damping: f64,
    /// Least damping after an accepted step.
    pub min_damping: f64,
    /// Damping beyond which no iteration starts: no step lowers the cost any more.
    pub max_damping: f64,
    /// How the damping shrinks after an accepted step.
    pub shrink: Shrink,
    /// Stop after an accepted step that lowers the cost this little (`None`: never).
    pub fall: Option<Fall>,
    /// Stop when the cost stalls (`None`: never).
    pub stall: Option<Stall>,
    /// Stop after an iteration in which no trial lowered the cost (else go on with the
    /// damping grown, until `max_damping`).
    pub stop_when_stuck: bool,
}

/// What [`minimise`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Report {
    /// Iterations started.
    pub iterations: usize,
    /// Damping at the end.
    pub damping: f64,
}

/// Minimise `problem`'s cost from its current point by Levenberg–Marquardt under `opts`; the
/// problem is left at the last accepted point.
pub fn minimise<P: Problem>(problem: &mut P, opts: &Options) -> Report {
    let mut damping = opts.initial_damping;
    let mut iterations = 0;
    let mut history = VecDeque::new();
    if opts.stall.is_some() {
        history.push_back(problem.cost());
    }
    while iterations < opts.max_iterations && damping <= opts.max_damping && !problem.converged() {
        iterations += 1;
        problem.linearise();
        let mut improved = false;
        for _ in 0..opts.max_tries {
            let before = problem.cost();
            match problem.trial(damping) {
                Some((trial, after)) if after < before => {
                    improved = opts.fall.is_none_or(|f| {
                        (before - after) * f.scale / before.max(1e-300) > f.threshold
                    });
                    problem.accept(trial, after);
                    damping = match opts.shrink {
                        Shrink::Divide(d) => damping / d,
                        Shrink::Multiply(f) => damping * f,
                    }
                    .max(opts.min_damping);
                    break;
                }
                _ => damping *= 10.0,
            }
        }
        if let Some(stall) = opts.stall {
            let cost = problem.cost();
            history.push_back(cost);
            if history.len() > stall.window {
                let before = history.pop_front().unwrap_or(cost);
                if before - cost <= stall.fraction * before {
                    break;
                }
            }
        }
        if !improved && opts.stop_when_stuck {
            break;
        }
    }
    Report {
        iterations,
        damping,
    }
}

/// Hold the parameters `held` marks in the normal equations `jtj step = -g`: their rows and
/// columns of `jtj` zeroed with a unit diagonal and their gradient zeroed, so their step is
/// zero and nothing couples to them (an active set: held this iteration only).
pub fn hold(jtj: &mut DMatrix<f64>, g: &mut DVector<f64>, held: &[bool]) {
    for k in (0..held.len()).filter(|&k| held[k]) {
        jtj.row_mut(k).fill(0.0);
        jtj.column_mut(k).fill(0.0);
        jtj[(k, k)] = 1.0;
        g[k] = 0.0;
    }
}

/// Scale `step` down so that no coordinate moves more than `max` in its natural units
/// (`|step_k unit_k| <= max`).
pub fn cap_step(step: &mut DVector<f64>, unit: &[f64], max: f64) {
    let longest = step
        .iter()
        .zip(unit)
        .fold(0.0_f64, |m, (d, u)| m.max((d * u).abs()));
    if longest > max {
        *step *= max / longest;
    }
}

/// The least-squares step `min |R s - b|^2 + |D s|^2` of a damped linearisation in its QR
/// form: `R` (`q x q`, upper triangular: the Jacobian's `J = Q R`), `b` (`q`: `-Q^T r`, the
/// residual's first `q` rotated entries) and the diagonal `D` (`d`, `q` long). The rows of
/// `D` are rotated into `R` one at a time by Givens rotations (Moré 1978, MINPACK's
/// `qrsolv`), about `q^3` flops against the `10 q^3 / 3` of a Householder QR of the stacked
/// `2q x q` system, then `R' s = b'` is solved by back substitution. `None`: a singular
/// system (a zero on the rotated diagonal) or a step that is not finite.
pub fn damped_triangular_solve(
    r: &DMatrix<f64>,
    b: &DVector<f64>,
    d: &[f64],
) -> Option<DVector<f64>> {
    let q = r.ncols();
    // R transposed: column k of `rt` is row k of R, one contiguous slice for the rotations.
    let mut rt = r.transpose();
    let rows = rt.as_mut_slice();
    let mut b = b.clone();
    let mut row = vec![0.0; q];
    for (j, &dj) in d.iter().enumerate() {
        if dj == 0.0 {
            continue;
        }
        row.fill(0.0);
        row[j] = dj;
        let mut extra = 0.0;
        for k in j..q {
            if row[k] == 0.0 {
                continue;
            }
            // The rotation of rows (k of R, the diagonal row) that zeroes `row[k]` (entries of
            // a scaled Jacobian: the squares do not overflow).
            let rk = &mut rows[k * q + k..(k + 1) * q];
            let (a, e) = (rk[0], row[k]);
            let h = (a * a + e * e).sqrt();
            let (c, s) = (a / h, e / h);
            for (x, y) in rk.iter_mut().zip(&mut row[k..]) {
                let (u, v) = (*x, *y);
                *x = c * u + s * v;
                *y = c * v - s * u;
            }
            let (u, v) = (b[k], extra);
            b[k] = c * u + s * v;
            extra = c * v - s * u;
        }
    }
    let step = rt.transpose().solve_upper_triangular(&b)?;
    step.iter().all(|v| v.is_finite()).then_some(step)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `r(x) = [10 (x1 - x0^2), 1 - x0]` (Rosenbrock), damped by `damping (J^T J)_kk`.
    struct Rosenbrock {
        x: [f64; 2],
    }

    impl Rosenbrock {
        fn residual(x: &[f64; 2]) -> [f64; 2] {
            [10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]
        }
    }

    impl Problem for Rosenbrock {
        type Trial = [f64; 2];

        fn cost(&self) -> f64 {
            Self::residual(&self.x).iter().map(|v| v * v).sum()
        }

        fn trial(&mut self, damping: f64) -> Option<([f64; 2], f64)> {
            let r = Self::residual(&self.x);
            let j = DMatrix::from_row_slice(2, 2, &[-20.0 * self.x[0], 10.0, -1.0, 0.0]);
            let mut a = j.transpose() * &j;
            for k in 0..2 {
                a[(k, k)] += damping * a[(k, k)].max(1e-12);
            }
            let g = j.transpose() * DVector::from_column_slice(&r);
            let step = a.cholesky()?.solve(&(-g));
            let trial = [self.x[0] + step[0], self.x[1] + step[1]];
            let cost = Self::residual(&trial).iter().map(|v| v * v).sum();
            Some((trial, cost))
        }

        fn accept(&mut self, trial: [f64; 2], _cost: f64) {
            self.x = trial;
        }
    }

    #[test]
    fn the_loop_finds_the_minimum_of_rosenbrock() {
        let mut p = Rosenbrock { x: [-1.2, 1.0] };
        let report = minimise(
            &mut p,
            &Options {
                max_iterations: 200,
                max_tries: 30,
                initial_damping: 1e-3,
                min_damping: 1e-15,
                max_damping: f64::INFINITY,
                shrink: Shrink::Divide(10.0),
                fall: Some(Fall {
                    scale: 1.0,
                    threshold: 1e-15,
                }),
                stall: None,
                stop_when_stuck: true,
            },
        );
        assert!(
            (p.x[0] - 1.0).abs() < 1e-6 && (p.x[1] - 1.0).abs() < 1e-6,
            "{:?} after {report:?}",
            p.x
        );
    }

    #[test]
    fn the_damped_triangular_solve_is_the_stacked_least_squares_step() {
        // A 5 x 5 upper-triangular R, some diagonal damping (one zero), against the
        // least-squares solution of the stacked system [R; D] by SVD.
        let q = 5;
        let r = DMatrix::from_fn(q, q, |i, j| {
            if j >= i {
                1.0 + ((3 * i + 7 * j) % 5) as f64 * 0.7 - 0.2 * j as f64
            } else {
                0.0
            }
        });
        let b = DVector::from_fn(q, |i, _| (i as f64 * 1.3).sin());
        let d = [0.5, 0.0, 2.0, 0.1, 1.0];
        let mut a = DMatrix::zeros(2 * q, q);
        a.rows_mut(0, q).copy_from(&r);
        let mut rhs = DVector::zeros(2 * q);
        rhs.rows_mut(0, q).copy_from(&b);
        for (c, v) in d.iter().enumerate() {
            a[(q + c, c)] = *v;
        }
        let stacked = a.svd(true, true).solve(&rhs, 1e-14).unwrap();
        let givens = damped_triangular_solve(&r, &b, &d).unwrap();
        assert!(
            (givens - &stacked).norm() < 1e-12 * stacked.norm(),
            "{stacked}"
        );
        // Singular and undamped: no step.
        let mut singular = r.clone();
        singular[(3, 3)] = 0.0;
        assert!(damped_triangular_solve(&singular, &b, &[0.0; 5]).is_none());
    }

    #[test]
    fn a_step_is_capped_in_natural_units() {
        let mut step = DVector::from_vec(vec![4.0, -1.0]);
        cap_step(&mut step, &[0.5, 1.0], 1.0);
        assert_eq!(step.as_slice(), &[2.0, -0.5]);
        let mut g = DVector::from_vec(vec![1.0, 2.0]);
        let mut jtj = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 3.0]);
        hold(&mut jtj, &mut g, &[false, true]);
        assert_eq!(jtj.as_slice(), &[2.0, 0.0, 0.0, 1.0]);
        assert_eq!(g.as_slice(), &[1.0, 0.0]);
    }
}
