//! An identification set designed as a whole: several excitations of every joint, each about
//! its own centre of the workspace, at its own base frequency and carrying its own known
//! payload, optimised together so that the **stacked** regressor of all of them is well
//! conditioned (rather than each one on its own, [`crate::identification::excitation`]).
//!
//! - Regressor: the one [`crate::identification::fit`] fits, linearised at the nominal model,
//!   at the logging rate (e.g. 10 Hz) over each excitation's run: per sample the total-power
//!   row `sum_i dq_i W_base,i` of the base parameters, the copper-loss columns `tau_i^2`
//!   (torques of the URDF's nominal model with the excitation's known payload attached: the
//!   payload is what separates copper loss from the rest) and a constant (standby). Samples
//!   at which a joint moves slower than the fit's minimum speed are left out, as the fit
//!   leaves them out. Each excitation counts with its number of periods.
//! - Criterion ([`SetCriterion`]): `ln cond` or D-optimality (`-ln det / p`) of the stacked
//!   information matrix with columns scaled to unit norm (unit-free).
//! - Constraints: joint position (with margin), speed and acceleration limits, floor and base
//!   keep-out, as quadratic penalties ([`crate::identification::excitation`]); the result is
//!   checked at 1 ms.
//! - Optimiser: block coordinates. Round 1 designs the excitations one after the other, each
//!   for the set with those already designed; every further round re-optimises each
//!   excitation with all the others fixed. Each block is a CMA-ES run (crate `cmaes`) whose
//!   population is evaluated in parallel; the result depends only on the seed.
//!
//! For any arm in its cell, [`arm::plan`] derives the members and limits, and [`export`]
//! writes the designed set for the user to run ([`runs`]: the manifest `identify --runs`
//! reads).

pub mod arm;
pub mod centres;
pub mod export;
pub mod runs;

use std::time::Instant;

use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::dynamics::base_params::{BaseParams, SamplingOptions};
use crate::dynamics::regressor::regressor;
use crate::dynamics::{DriveTerms, ParamLayout, Workspace};
use crate::error::{Error, Result};
use crate::identification::excitation::{Bounds, series, start_point};
use crate::model::Robot;
use crate::model::payload::{Payload, attach};
use crate::trajectory::Trajectory;
use crate::trajectory::fourier::Fourier;
use crate::trajectory::limits::check_limits;

/// Objective of the set design.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SetCriterion {
    /// `ln cond(A)` of the stacked, column-scaled regressor.
    Cond,
    /// `-ln det(A^T A) / p` of the stacked, column-scaled regressor (D-optimality).
    DOptimal,
}

impl SetCriterion {
    /// What the criterion optimises, in words.
    pub fn describe(self) -> &'static str {
        match self {
            SetCriterion::Cond => "condition number",
            SetCriterion::DOptimal => "D-optimality",
        }
    }
}

/// One excitation of the set.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// Start guess of the centre pose, rad.
    pub centre: Vec<f64>,
    /// Base frequency, Hz.
    pub base_freq_hz: f64,
    /// Whole periods the excitation runs.
    pub periods: usize,
    /// Known payload at the flange during the run (`None`: nothing).
    pub payload: Option<Payload>,
}

/// Settings of [`design_set`].
#[derive(Debug, Clone, PartialEq)]
pub struct SetOptions {
    /// The excitations.
    pub members: Vec<Member>,
    /// Harmonics per joint (>= 2).
    pub harmonics: usize,
    /// Rate of the samples the design conditions, Hz ([`DESIGN_RATE_HZ`] for a set planned
    /// for logs of any rate).
    pub sample_rate_hz: f64,
    /// Samples at which a joint moves slower than this (rad/s) do not count (the fit leaves
    /// them out).
    pub min_speed: f64,
    /// Objective.
    pub criterion: SetCriterion,
    /// Acceleration limits per joint, rad/s^2.
    pub accel_limits: Vec<f64>,
    /// Distance kept from position limits, rad.
    pub position_margin: f64,
    /// Fraction of the speed and acceleration limits that may be used.
    pub limit_fraction: f64,
    /// Floor plane height the flange and wrist centre stay above, m.
    pub floor_z: f64,
    /// Radius of the keep-out cylinder around the base z axis, m.
    pub base_radius: f64,
    /// Rounds of block-coordinate optimisation (>= 1).
    pub rounds: usize,
    /// CMA-ES evaluations per excitation and round.
    pub max_evals: usize,
    /// Seed (excitation `k` in round `r` uses `seed + 1000 r + k`).
    pub seed: u64,
}

/// Outcome of [`design_set`].
#[derive(Debug, Clone)]
pub struct SetDesign {
    /// The optimised excitations, in the order of the members.
    pub trajectories: Vec<Fourier>,
    /// Condition number of the stacked, column-scaled regressor at the start guesses.
    pub cond_initial: f64,
    /// The same after the design.
    pub cond_final: f64,
    /// Condition number of each excitation's own regressor after the design.
    pub member_conds: Vec<f64>,
    /// Criterion value after each round.
    pub criterion_by_round: Vec<f64>,
    /// Objective evaluations in all.
    pub evaluations: usize,
    /// Wall time, s.
    pub wall_s: f64,
}

/// The optimiser sees limits shrunk by this factor (see the single design).
const OPTIMISATION_TIGHTENING: f64 = 0.98;
/// Rate of the samples a set's design conditions, Hz, whatever rate the logs will have: the
/// paper's logging rate. The design conditions the regressor's mean over each period; the
/// highest harmonic of a 0.2 Hz excitation is 1 Hz, and 10 samples of it per cycle measure
/// that mean as well as a faster log's would, at a fraction of the cost
/// (docs/experiments.md#one-design-rate).
pub const DESIGN_RATE_HZ: f64 = 10.0;
/// Samples per period at which the limits are checked during the optimisation.
const PENALTY_SAMPLES: usize = 100;
/// CMA-ES step size of the first round (rad) and of the refinement rounds.
const SIGMA_FIRST: f64 = 0.1;
const SIGMA_REFINE: f64 = 0.05;
/// Weights of the limits' penalty in the objective: the first always, the next ones in turn
/// while the last round leaves an excitation outside its limits (quadratic penalties let a
/// strong criterion pull the optimum slightly outside, most where a cell's limits bind).
const PENALTY_WEIGHTS: [f64; 3] = [1e3, 1e6, 1e9];
/// Most halvings of a start point's amplitudes ([`SetProblem::within_limits`]).
const START_HALVINGS: usize = 4;
/// Added to the diagonal of the scaled information matrix (of unit diagonal).
const RIDGE: f64 = 1e-9;

/// Fixed data of the set problem.
struct SetProblem<'a> {
    robot: &'a Robot,
    opts: &'a SetOptions,
    layout: ParamLayout,
    /// Base columns of the layout.
    columns: Vec<usize>,
    /// Nominal standard parameters of each member (URDF with its payload attached).
    nominal: Vec<Vec<f64>>,
    bounds: Bounds,
    joints: Vec<usize>,
}

impl<'a> SetProblem<'a> {
    /// The set problem of `opts` for `robot`: the base columns of its structure (position
    /// limits lifted), each member's nominal parameters (URDF with its payload attached) and
    /// the limits' bounds.
    fn new(robot: &'a Robot, opts: &'a SetOptions) -> Result<Self> {
        let n = robot.dof();
        let layout = ParamLayout::new(robot, true, true);
        let base = BaseParams::compute(&structural(robot)?, layout, &SamplingOptions::default())?;
        let drive = DriveTerms::from_urdf(robot);
        let nominal = opts
            .members
            .iter()
            .map(|m| {
                Ok(match &m.payload {
                    Some(p) => layout.theta(&attach(robot, p)?, &drive),
                    None => layout.theta(robot, &drive),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(SetProblem {
            robot,
            opts,
            layout,
            columns: base.independent().to_vec(),
            nominal,
            bounds: Bounds::new(
                robot,
                opts.position_margin,
                opts.limit_fraction,
                &opts.accel_limits,
                opts.floor_z,
                opts.base_radius,
            ),
            joints: (0..n).collect(),
        })
    }

    /// Unknowns of the fit: base parameters, copper coefficients, constant.
    fn params(&self) -> usize {
        self.columns.len() + self.robot.dof() + 1
    }

    fn trajectory(&self, k: usize, x: &[f64]) -> Result<Fourier> {
        let m = &self.opts.members[k];
        series(
            &m.centre,
            &self.joints,
            self.opts.harmonics,
            m.base_freq_hz,
            m.periods,
            x,
        )
    }

    /// Information `A^T A` of member `k`'s excitation over its whole run (unscaled) and the
    /// penalty of its limits with the tightening `tighten`.
    fn information(&self, k: usize, traj: &Fourier, tighten: f64) -> (DMatrix<f64>, f64) {
        let robot = self.robot;
        let n = robot.dof();
        let member = &self.opts.members[k];
        let period = 1.0 / member.base_freq_hz;
        let mut poses = vec![nalgebra::Isometry3::identity(); n];
        let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut penalty = 0.0;
        for s in 0..PENALTY_SAMPLES {
            traj.sample(
                period * s as f64 / PENALTY_SAMPLES as f64,
                &mut q,
                &mut dq,
                &mut ddq,
            );
            penalty += self
                .bounds
                .penalty(robot, &q, &dq, &ddq, &mut poses, tighten);
        }
        let rows = (period * self.opts.sample_rate_hz).round().max(1.0) as usize;
        let (nb, p) = (self.columns.len(), self.params());
        let mut a = DMatrix::zeros(rows, p);
        let mut ws = Workspace::new(robot);
        let mut w = DMatrix::zeros(n, self.layout.len());
        let nominal = &self.nominal[k];
        for r in 0..rows {
            traj.sample(
                r as f64 / self.opts.sample_rate_hz,
                &mut q,
                &mut dq,
                &mut ddq,
            );
            if dq.iter().any(|v| v.abs() < self.opts.min_speed) {
                continue;
            }
            regressor(robot, &mut ws, &self.layout, &q, &dq, &ddq, &mut w);
            for (c, &col) in self.columns.iter().enumerate() {
                a[(r, c)] = (0..n).map(|i| dq[i] * w[(i, col)]).sum();
            }
            for i in 0..n {
                let tau: f64 = (0..self.layout.len()).map(|c| w[(i, c)] * nominal[c]).sum();
                a[(r, nb + i)] = tau * tau;
            }
            a[(r, p - 1)] = 1.0;
        }
        (a.transpose() * &a * member.periods as f64, penalty)
    }

    /// The information matrix with its columns scaled to unit norm, plus a ridge that keeps
    /// the criterion finite while the first excitations alone cannot reveal every parameter.
    fn scaled(info: &DMatrix<f64>) -> DMatrix<f64> {
        let p = info.nrows();
        let d: Vec<f64> = (0..p).map(|c| info[(c, c)].max(1e-300).sqrt()).collect();
        DMatrix::from_fn(p, p, |r, c| {
            info[(r, c)] / (d[r] * d[c]) + if r == c { RIDGE } else { 0.0 }
        })
    }

    /// Condition number of the column-scaled regressor behind `info`.
    fn cond(info: &DMatrix<f64>) -> f64 {
        let eig = Self::scaled(info).symmetric_eigenvalues();
        (eig.max() / eig.min().max(1e-300)).sqrt()
    }

    /// Criterion of an information matrix (columns scaled to unit norm).
    fn criterion(&self, info: &DMatrix<f64>) -> f64 {
        match self.opts.criterion {
            SetCriterion::Cond => Self::cond(info).ln(),
            // -ln det / p from the Cholesky factor (cheaper than the eigenvalues).
            SetCriterion::DOptimal => match Self::scaled(info).cholesky() {
                Some(c) => {
                    let l = c.l_dirty();
                    let p = info.nrows();
                    -2.0 * (0..p).map(|i| l[(i, i)].ln()).sum::<f64>() / p as f64
                }
                None => 1e3,
            },
        }
    }

    /// Criterion of the set with member `k` at `x` and the others' information `fixed`, plus
    /// `weight` times the penalty of its limits (tightened).
    fn objective(&self, k: usize, fixed: &DMatrix<f64>, x: &[f64], weight: f64) -> f64 {
        let Ok(traj) = self.trajectory(k, x) else {
            return 1e6;
        };
        let (info, penalty) = self.information(k, &traj, OPTIMISATION_TIGHTENING);
        self.criterion(&(fixed + info)) + weight * penalty
    }

    /// Penalty of member `k`'s limits at `x`, not tightened (0: within every limit).
    fn violation(&self, k: usize, x: &[f64]) -> Result<f64> {
        Ok(self.information(k, &self.trajectory(k, x)?, 1.0).1)
    }

    /// CMA-ES step size `sigma` (rad) for member `k`, reduced where a coefficient step of
    /// `sigma` at its highest harmonic would already exceed a joint's usable speed or
    /// acceleration (slow cells): otherwise nearly every trial point is far outside the
    /// limits and the optimiser learns nothing in its budget.
    fn step_size(&self, k: usize, sigma: f64) -> f64 {
        let o = self.opts;
        let omega =
            2.0 * std::f64::consts::PI * o.members[k].base_freq_hz * (o.harmonics - 1) as f64;
        self.robot
            .joints()
            .iter()
            .zip(&o.accel_limits)
            .fold(1.0_f64, |scale, (j, &a)| {
                let (v, a) = (j.limits.velocity.min(10.0), a);
                scale
                    .min(v * o.limit_fraction / (sigma * omega))
                    .min(a * o.limit_fraction / (sigma * omega * omega))
            })
            * sigma
    }

    /// The start point `x` of member `k`, its amplitudes halved (at most
    /// [`START_HALVINGS`] times) while it violates the limits: a start far outside them,
    /// where a cell's limits are tight, costs the optimiser most of its evaluations.
    fn within_limits(&self, k: usize, mut x: Vec<f64>) -> Result<Vec<f64>> {
        let per = 2 * self.opts.harmonics - 1;
        for _ in 0..START_HALVINGS {
            if self.violation(k, &x)? == 0.0 {
                break;
            }
            for (i, v) in x.iter_mut().enumerate() {
                if i % per != 0 {
                    *v *= 0.5;
                }
            }
        }
        Ok(x)
    }

    /// One block of the design: CMA-ES on member `k` from `x` (replaced by the best point
    /// when it improves) with the others' information `fixed`. With `insist` (the last
    /// round), a best point still outside the limits is optimised again with the heavier
    /// penalty weights of [`PENALTY_WEIGHTS`]. Returns the evaluations spent.
    fn optimise_block(
        &self,
        k: usize,
        fixed: &DMatrix<f64>,
        x: &mut Vec<f64>,
        (sigma, seed): (f64, u64),
        insist: bool,
    ) -> Result<usize> {
        let mut evaluations = 0;
        for (attempt, &weight) in PENALTY_WEIGHTS.iter().enumerate() {
            if attempt > 0 && (!insist || self.violation(k, x)? == 0.0) {
                break;
            }
            let objective =
                |v: &cmaes::DVector<f64>| self.objective(k, fixed, v.as_slice(), weight);
            let mut state = cmaes::CMAESOptions::new(x.clone(), self.step_size(k, sigma))
                .max_function_evals(self.opts.max_evals)
                .seed(seed.wrapping_add(100 * attempt as u64))
                .build(objective)
                .map_err(|e| Error::Numerical(format!("CMA-ES options: {e:?}")))?;
            let result = state.run_parallel();
            evaluations += state.function_evals();
            if let Some(b) = result.overall_best
                && b.value < self.objective(k, fixed, x, weight)
            {
                *x = b.point.as_slice().to_vec();
            }
        }
        Ok(evaluations)
    }
}

/// `robot` with its position limits lifted: base parameters belong to the arm's structure,
/// so they are found on states over whole turns, whatever narrower range a cell
/// ([`crate::trajectory::cell::Cell::limit`]) leaves the joints (random states in a narrow
/// range can make the regrouping numerically unreliable).
fn structural(robot: &Robot) -> Result<Robot> {
    let mut joints = robot.joints().to_vec();
    for j in &mut joints {
        j.limits.lower = f64::NEG_INFINITY;
        j.limits.upper = f64::INFINITY;
    }
    robot.with_joints(joints)
}

/// Refuse the options [`design_set`] cannot design with (see its errors).
fn check_options(robot: &Robot, opts: &SetOptions) -> Result<()> {
    let n = robot.dof();
    if opts.members.is_empty() || opts.rounds == 0 || opts.harmonics < 2 {
        return Err(Error::InvalidInput(
            "a set design needs >= 1 excitation, >= 1 round and >= 2 harmonics".into(),
        ));
    }
    if !(opts.sample_rate_hz.is_finite() && opts.sample_rate_hz > 0.0) {
        return Err(Error::InvalidInput(format!(
            "sample rate {} Hz must be positive",
            opts.sample_rate_hz
        )));
    }
    if opts.accel_limits.len() != n || !(opts.limit_fraction > 0.0 && opts.limit_fraction <= 1.0) {
        return Err(Error::InvalidInput(format!(
            "need {n} acceleration limits and a limit fraction in (0, 1]"
        )));
    }
    for (k, m) in opts.members.iter().enumerate() {
        robot.check_len(&m.centre, "excitation centre")?;
        robot
            .check_position_limits(&m.centre)
            .map_err(|e| e.context(&format!("excitation {}", k + 1)))?;
        if !(m.base_freq_hz.is_finite() && m.base_freq_hz > 0.0) || m.periods == 0 {
            return Err(Error::InvalidInput(format!(
                "excitation {}: base frequency {} Hz and {} periods must be positive",
                k + 1,
                m.base_freq_hz,
                m.periods
            )));
        }
    }
    Ok(())
}

/// Design the identification set of `opts` for `robot` (see the module docs).
///
/// Errors: no members, a centre of the wrong length or outside the position limits, a
/// non-positive frequency or rate, zero periods or rounds, fewer than 2 harmonics, a payload
/// that is not physical, or a result that still violates a limit.
pub fn design_set(robot: &Robot, opts: &SetOptions) -> Result<SetDesign> {
    let start = Instant::now();
    check_options(robot, opts)?;
    let problem = SetProblem::new(robot, opts)?;
    let count = opts.members.len();
    let mut xs = problem.start_points()?;
    let mut info = problem.all_information(&xs)?;
    let cond_initial = SetProblem::cond(&problem.summed(&info, None, count));
    let rounds = problem.optimise_rounds(&mut xs, &mut info)?;
    let (trajectories, member_conds) = problem.checked_trajectories(&xs)?;
    Ok(SetDesign {
        trajectories,
        cond_initial,
        cond_final: SetProblem::cond(&problem.summed(&info, None, count)),
        member_conds,
        criterion_by_round: rounds.criterion_by_round,
        evaluations: rounds.evaluations,
        wall_s: start.elapsed().as_secs_f64(),
    })
}

/// What the block-coordinate rounds of [`design_set`] spent and reached.
struct Rounds {
    /// Criterion value after each round.
    criterion_by_round: Vec<f64>,
    /// Objective evaluations in all.
    evaluations: usize,
}

impl SetProblem<'_> {
    /// Each member's seeded start point (member `k` from `seed + k`), within its limits
    /// ([`SetProblem::within_limits`]).
    fn start_points(&self) -> Result<Vec<Vec<f64>>> {
        let opts = self.opts;
        opts.members
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let mut rng = ChaCha8Rng::seed_from_u64(opts.seed.wrapping_add(k as u64));
                self.within_limits(
                    k,
                    start_point(&m.centre, &self.joints, opts.harmonics, &mut rng),
                )
            })
            .collect()
    }

    /// Information `A^T A` (unscaled) of member `k`'s excitation at `x`.
    fn member_information(&self, k: usize, x: &[f64]) -> Result<DMatrix<f64>> {
        Ok(self.information(k, &self.trajectory(k, x)?, 1.0).0)
    }

    /// Information of every member at its point of `xs`, computed in parallel.
    fn all_information(&self, xs: &[Vec<f64>]) -> Result<Vec<DMatrix<f64>>> {
        (0..self.opts.members.len())
            .into_par_iter()
            .map(|k| self.member_information(k, &xs[k]))
            .collect()
    }

    /// Sum of the first `upto` members' information `infos`, leaving out member `skip`.
    fn summed(&self, infos: &[DMatrix<f64>], skip: Option<usize>, upto: usize) -> DMatrix<f64> {
        let p = self.params();
        infos
            .iter()
            .enumerate()
            .take(upto)
            .filter(|(j, _)| Some(*j) != skip)
            .fold(DMatrix::zeros(p, p), |acc, (_, i)| acc + i)
    }

    /// The block-coordinate rounds: each member's point in `xs` optimised in turn, its
    /// information in `info` kept up to date.
    fn optimise_rounds(&self, xs: &mut [Vec<f64>], info: &mut [DMatrix<f64>]) -> Result<Rounds> {
        let opts = self.opts;
        let count = opts.members.len();
        let mut evaluations = 0;
        let mut criterion_by_round = Vec::with_capacity(opts.rounds);
        for round in 0..opts.rounds {
            for k in 0..count {
                // Round 1 designs for the excitations already designed; later rounds for all.
                let fixed = self.summed(info, Some(k), if round == 0 { k } else { count });
                let sigma = if round == 0 {
                    SIGMA_FIRST
                } else {
                    SIGMA_REFINE
                };
                let seed = opts
                    .seed
                    .wrapping_add(1000 * round as u64)
                    .wrapping_add(k as u64);
                let before = xs[k].clone();
                evaluations += self.optimise_block(
                    k,
                    &fixed,
                    &mut xs[k],
                    (sigma, seed),
                    round + 1 == opts.rounds,
                )?;
                if xs[k] != before {
                    info[k] = self.member_information(k, &xs[k])?;
                }
            }
            criterion_by_round.push(self.criterion(&self.summed(info, None, count)));
        }
        Ok(Rounds {
            criterion_by_round,
            evaluations,
        })
    }

    /// The designed excitations at the points `xs` and the condition number of each one's
    /// own regressor; errors when one violates a limit (its penalty, then [`check_limits`]).
    fn checked_trajectories(&self, xs: &[Vec<f64>]) -> Result<(Vec<Fourier>, Vec<f64>)> {
        let count = xs.len();
        let mut trajectories = Vec::with_capacity(count);
        let mut member_conds = Vec::with_capacity(count);
        for (k, x) in xs.iter().enumerate() {
            let traj = self.trajectory(k, x)?;
            let (own, penalty) = self.information(k, &traj, 1.0);
            if penalty > 0.0 {
                return Err(Error::JointLimit(format!(
                    "excitation {} of the set still violates limits or the workspace (penalty {penalty:.3e}); widen the limits or reduce the harmonics",
                    k + 1
                )));
            }
            check_limits(self.robot, &traj, 1e-3, Some(&self.opts.accel_limits))
                .map_err(|e| e.context(&format!("excitation {} of the set", k + 1)))?;
            member_conds.push(SetProblem::cond(&own));
            trajectories.push(traj);
        }
        Ok((trajectories, member_conds))
    }
}
