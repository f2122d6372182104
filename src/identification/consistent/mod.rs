//! Physically consistent standard parameters from an estimate of the base parameters.
//!
//! Least squares on power identifies the base parameters `theta = K phi`, a linear map of the
//! standard parameters `phi` ([`BaseParams::base_values`]). Nothing keeps the estimate
//! physical, and many `phi` give the same `theta`. [`project`] finds the standard vector that
//! minimises
//!
//! `(K phi - theta_hat)^T Info (K phi - theta_hat) + lambda |W (phi - phi_prior)|^2`
//!
//! over the physically consistent set, where `Info = Cov^-1` is the information of the
//! estimate, `phi_prior` the declared prior (the input URDF's values) and `W` a diagonal of
//! inverse natural scales (per link: mass `m`, first moments `m L`, inertias `m L^2`, with `L`
//! the prior's COM distance or radius of gyration, at least 0.01 m; drive terms: their prior,
//! at least the largest prior of their kind, rotor inertia at least the link's `m L^2`). With a
//! small `lambda` the prior only decides the directions that the data
//! cannot see (the null space of `K`); for a model linear in the parameters the data term is
//! exactly the least-squares cost, so this is least squares with the consistency
//! constraints.
//!
//! Consistency holds by construction of the parametrisation:
//! - each link's 4x4 pseudo-inertia `J = [[Sigma, h], [h^T, m]]` (`Sigma = 0.5 tr(I) 1 - I`
//!   with `I` the inertia about the link-frame origin, `h = m c`) is `U U^T` with
//!   `U = e^a [[e^d1, s12, s13, t1], [0, e^d2, s23, t2], [0, 0, e^d3, t3], [0, 0, 0, 1]]`,
//!   the log-Cholesky parametrisation of Rucker & Wensing (2022, "Smooth parameterization of
//!   rigid-body inertia"): `J` positive definite, equivalently mass > 0 and principal moments
//!   about the COM positive and satisfying the triangle inequality strictly (a margin of
//!   `1e-6 diag(m L^2, m L^2, m L^2, m)` is added to `U U^T`, so that bodies the data push to
//!   the boundary, zero thickness, stay strictly inside);
//! - Coulomb friction, viscous friction and rotor inertia are squares `z^2 >= 0`.
//!
//! Levenberg–Marquardt (damping in the natural units of the parametrisation, steps of at most
//! one unit per coordinate, each step a least-squares solve of the damped Jacobian by QR) from the unconstrained minimiser, links that are not consistent
//! there starting from the prior.

use nalgebra::{DMatrix, DVector, Matrix4};
use serde::Serialize;

use crate::dynamics::base_params::BaseParams;
use crate::error::{Error, Result};
use crate::identification::fit::Param;
use crate::identification::lsq::Estimate;
use crate::identification::model::PowerModel;
use crate::model::Robot;
use crate::numerics::lm;

mod inertia;
mod projection;
mod twin;

pub use inertia::pseudo_inertia;
pub use twin::IdentifiedTwin;

use inertia::{log_cholesky, margin, scales, standard_of};
use projection::Projection;

/// Settings of [`project`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Weight of the prior term (dimensionless: the data term is in units of the estimate's
    /// variance, the prior term in units of the natural scales).
    pub lambda: f64,
    /// Iteration limit of Levenberg–Marquardt.
    pub max_iterations: usize,
    /// Levenberg–Marquardt stops when the cost fell by less than this fraction over the last
    /// [`STALL_WINDOW`] iterations (`1e-3`: the Mahalanobis distance of the projection moves
    /// by less than 0.05 %). Far from the estimate the first iterations fall by orders of
    /// magnitude; near the boundary of consistency (a drive term squeezed to zero) the last
    /// ones crawl.
    pub stall: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            lambda: 1e-12,
            max_iterations: 500,
            stall: 1e-3,
        }
    }
}

/// A physically consistent standard-parameter vector and how well it reproduces the estimate.
#[derive(Debug, Clone, Serialize)]
pub struct Consistent {
    /// Standard parameter names (layout order, e.g. `XX1`, `fc1`, `Ia1`).
    pub names: Vec<String>,
    /// Consistent standard parameters (kg m^2 about the link-frame origin, kg m, kg, N m,
    /// N m s/rad, kg m^2), in the MDH link frames of [`crate::model`].
    pub phi: Vec<f64>,
    /// Base parameter names.
    pub base_names: Vec<String>,
    /// `K phi`: the consistent base parameters (SI).
    pub theta: Vec<f64>,
    /// The non-negative extra parameters (the estimate's values after the base parameters,
    /// e.g. copper-loss coefficients and standby power), consistent with `theta`.
    pub extras: Vec<f64>,
    /// Mahalanobis distance of `(K phi, extras)` from the estimate (in
    /// standard deviations of the estimate).
    pub mahalanobis: f64,
    /// `|K phi - theta_hat|_k / sigma_k` per estimated value (base parameters, then extras).
    pub change_sigma: Vec<f64>,
    /// Largest entry of `change_sigma`.
    pub max_change_sigma: f64,
    /// Standard parameters that are not a function of the base parameters (a component in the
    /// null space of `K`): the data cannot reveal them, their split is set by the prior.
    pub from_prior: Vec<String>,
    /// Levenberg–Marquardt iterations used.
    pub iterations: usize,
}

/// Number of inertial parameters per link.
const INERTIAL: usize = 10;
/// Iterations over which [`Options::stall`] measures the progress of Levenberg–Marquardt.
pub const STALL_WINDOW: usize = 10;
/// Largest Levenberg–Marquardt step per coordinate, in natural units.
const MAX_STEP: f64 = 1.0;
/// Relative margin of the pseudo-inertias from the boundary of consistency (see [`margin`]).
const MARGIN: f64 = 1e-6;
/// A standard parameter counts as set by the prior when the null-space part of its unit
/// vector (in scaled coordinates) exceeds this.
const NULL_TOL: f64 = 1e-6;

/// `K` as a matrix: base values of the unit standard vectors (`rank x layout.len()`).
pub fn base_map(base: &BaseParams) -> Result<DMatrix<f64>> {
    let p = base.layout().len();
    let mut k = DMatrix::zeros(base.rank(), p);
    let mut e = vec![0.0; p];
    for c in 0..p {
        e[c] = 1.0;
        for (r, v) in base.base_values(&e)?.into_iter().enumerate() {
            k[(r, c)] = v;
        }
        e[c] = 0.0;
    }
    Ok(k)
}

/// Find physically consistent standard parameters for the base-parameter estimate
/// `theta_hat` (SI, in `base`'s order, optionally followed by extra estimated values that must
/// be non-negative, e.g. copper-loss coefficients) with covariance `covariance` (symmetric
/// positive definite, one row per value of `theta_hat`), closest to the data and, where the
/// data are silent, to `prior` (a standard vector of `base.layout()`, e.g.
/// [`crate::dynamics::ParamLayout::theta`] of the input URDF; drive terms may be zero). See the module docs.
///
/// Errors: [`Error::InvalidInput`] for wrong lengths, non-finite values, a covariance that is
/// not symmetric positive definite, a negative or non-finite `lambda`; [`Error::Numerical`]
/// when a least-squares solve of the projection fails.
pub fn project(
    base: &BaseParams,
    theta_hat: &[f64],
    covariance: &DMatrix<f64>,
    prior: &[f64],
    opts: &Options,
) -> Result<Consistent> {
    let layout = *base.layout();
    let (nb, p) = (base.rank(), layout.len());
    let nt = theta_hat.len();
    check_inputs(theta_hat, covariance, prior, opts, nb, p)?;
    let r_info = information_root(covariance)?;
    let k = base_map(base)?;
    let k_aug = augmented_map(&k, nt, nb);
    let extras = &theta_hat[nb..];
    let scales = natural_scales(&layout, prior, extras);
    let mut prior_aug = prior.to_vec();
    prior_aug.extend(extras.iter().map(|v| v.max(0.0)));
    let (phi, iterations) = minimise(
        &layout, &r_info, &k_aug, theta_hat, &prior_aug, &scales, opts,
    )?;

    let fitted = &k_aug * &phi;
    let dtheta = &fitted - DVector::from_column_slice(theta_hat);
    let mahalanobis = (&r_info * &dtheta).norm();
    let change_sigma: Vec<f64> = (0..nt)
        .map(|i| dtheta[i].abs() / covariance[(i, i)].sqrt())
        .collect();
    let max_change_sigma = change_sigma.iter().cloned().fold(0.0, f64::max);
    let names = layout.names();
    let from_prior = set_by_prior(&k, &scales.s, &names)?;
    Ok(Consistent {
        names,
        phi: phi.as_slice()[..p].to_vec(),
        base_names: base.base_names(),
        theta: fitted.as_slice()[..nb].to_vec(),
        extras: phi.as_slice()[p..].to_vec(),
        mahalanobis,
        change_sigma,
        max_change_sigma,
        from_prior,
        iterations,
    })
}

/// Check the projection's inputs: `theta_hat` holds at least the `nb` base parameters,
/// `covariance` is its square, `prior` has the `p` standard parameters, all finite, and the
/// prior weight is finite and non-negative.
fn check_inputs(
    theta_hat: &[f64],
    covariance: &DMatrix<f64>,
    prior: &[f64],
    opts: &Options,
    nb: usize,
    p: usize,
) -> Result<()> {
    let nt = theta_hat.len();
    if nt < nb || covariance.shape() != (nt, nt) || prior.len() != p {
        return Err(Error::InvalidInput(format!(
            "consistent projection: {} estimated values and a {}x{} covariance for {nb} base parameters (and non-negative extras), {} prior values for {p} standard parameters",
            theta_hat.len(),
            covariance.nrows(),
            covariance.ncols(),
            prior.len()
        )));
    }
    if theta_hat
        .iter()
        .chain(covariance.iter())
        .chain(prior)
        .any(|v| !v.is_finite())
    {
        return Err(Error::InvalidInput(
            "consistent projection: the estimate, its covariance or the prior is not finite".into(),
        ));
    }
    if !(opts.lambda.is_finite() && opts.lambda >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "prior weight lambda = {} must be finite and >= 0",
            opts.lambda
        )));
    }
    Ok(())
}

/// `R` with `R^T R = Info = Cov^-1`: `R = diag(1/sqrt(e)) V^T` from the eigen-decomposition
/// of `covariance`, which must be symmetric positive definite.
fn information_root(covariance: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let nt = covariance.nrows();
    let asym = (covariance - covariance.transpose()).abs().max();
    let eig = covariance.clone().symmetric_eigen();
    let emax = eig.eigenvalues.max();
    if asym > 1e-9 * emax.abs() || eig.eigenvalues.min() <= 1e-14 * emax || emax <= 0.0 {
        return Err(Error::InvalidInput(
            "consistent projection: the covariance of the estimate is not symmetric positive definite"
                .into(),
        ));
    }
    Ok(DMatrix::from_fn(nt, nt, |i, j| {
        eig.eigenvectors[(j, i)] / eig.eigenvalues[i].sqrt()
    }))
}

/// The map from the `q = p + ne` unknowns (standard parameters, then the estimate's
/// non-negative extras) to the `nt = nb + ne` estimated values: the base map `k` for the base
/// parameters, the identity for the extras.
fn augmented_map(k: &DMatrix<f64>, nt: usize, nb: usize) -> DMatrix<f64> {
    let p = k.ncols();
    let ne = nt - nb;
    let mut k_aug = DMatrix::zeros(nt, p + ne);
    k_aug.view_mut((0, 0), (nb, p)).copy_from(k);
    for e in 0..ne {
        k_aug[(nb + e, p + e)] = 1.0;
    }
    k_aug
}

/// Natural scales of the projection's unknowns (standard parameters, then extras).
struct Scales {
    /// Scale of each unknown (its unit: kg, kg m, kg m^2, N m, W, ...).
    s: Vec<f64>,
    /// Natural unit of each coordinate of `z` for the damping and the step limit:
    /// log-Cholesky logs are dimensionless, its off-diagonal entries are lengths (scale L),
    /// drive terms and extras `sqrt(scale)`.
    unit: Vec<f64>,
    /// Each link's margin as standard parameters (added to the parametrised inertials).
    offset: Vec<f64>,
    /// Each link's consistency margin (pseudo-inertia), one per joint.
    margins: Vec<Matrix4<f64>>,
}

/// The scales of the standard parameters from `prior`, of the `extras` from their own sizes
/// (at least `1e-3` of the largest), and the units, offsets and margins they give.
fn natural_scales(layout: &crate::dynamics::ParamLayout, prior: &[f64], extras: &[f64]) -> Scales {
    let p = layout.len();
    let q = p + extras.len();
    let (mut s, lengths) = scales(layout, prior);
    let largest_extra = extras.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    s.extend(
        extras
            .iter()
            .map(|v| v.abs().max(1e-3 * largest_extra).max(1e-300)),
    );
    let mut unit = vec![1.0; q];
    for (j, l) in lengths.iter().enumerate() {
        let start = layout.link_start(j);
        for u in &mut unit[start + 4..start + INERTIAL] {
            *u = 1.0 / l;
        }
        for c in start + INERTIAL..start + layout.per_link() {
            unit[c] = 1.0 / s[c].sqrt();
        }
    }
    for c in p..q {
        unit[c] = 1.0 / s[c].sqrt();
    }
    let mut offset = vec![0.0; q];
    let margins: Vec<Matrix4<f64>> = (0..layout.dof)
        .map(|j| margin(&s, layout.link_start(j)))
        .collect();
    for (j, e) in margins.iter().enumerate() {
        let start = layout.link_start(j);
        offset[start..start + INERTIAL].copy_from_slice(&standard_of(e));
    }
    Scales {
        s,
        unit,
        offset,
        margins,
    }
}

/// Minimise `|R (K phi - theta_hat)|^2 + lambda |W (phi - prior)|^2` over consistent `phi`
/// by Levenberg–Marquardt in the parametrisation `z`, from the unconstrained minimiser made
/// consistent; `prior_aug` is the prior of the standard parameters followed by the extras'.
/// Returns `phi` (standard parameters, then extras) and the iterations used.
fn minimise(
    layout: &crate::dynamics::ParamLayout,
    r_info: &DMatrix<f64>,
    k_aug: &DMatrix<f64>,
    theta_hat: &[f64],
    prior_aug: &[f64],
    scales: &Scales,
    opts: &Options,
) -> Result<(DVector<f64>, usize)> {
    let (nt, q) = k_aug.shape();
    let rk = r_info * k_aug;
    let rtheta = r_info * DVector::from_column_slice(theta_hat);
    let sq = opts.lambda.sqrt();
    let w = DVector::from_iterator(q, scales.s.iter().map(|v| sq / v));
    let prior_v = DVector::from_column_slice(prior_aug);
    // The residual's Jacobian in phi.
    let mut j_phi = DMatrix::zeros(nt + q, q);
    j_phi.rows_mut(0, nt).copy_from(&rk);
    for c in 0..q {
        j_phi[(nt + c, c)] = w[c];
    }

    // Start: the unconstrained minimiser, made consistent link by link.
    let mut rhs = DVector::zeros(nt + q);
    rhs.rows_mut(0, nt).copy_from(&rtheta);
    rhs.rows_mut(nt, q).copy_from(&prior_v.component_mul(&w));
    let free = j_phi
        .clone()
        .svd(true, true)
        .solve(&rhs, 1e-15)
        .map_err(|e| Error::Numerical(format!("consistent projection: {e}")))?;
    let prior = &prior_aug[..layout.len()];
    let z = start_point(layout, free.as_slice(), prior, &scales.margins, &scales.s);

    // Levenberg–Marquardt in z.
    let mut problem = Projection {
        layout,
        offset: &scales.offset,
        j_phi: &j_phi,
        rk: &rk,
        rtheta: &rtheta,
        prior: &prior_v,
        w: &w,
        unit: &scales.unit,
        z: Vec::new(),
        phi: DVector::zeros(0),
        dphi: DMatrix::zeros(0, 0),
        r: DVector::zeros(0),
        cost: 0.0,
        jac_r: DMatrix::zeros(0, 0),
        jac_qtr: DVector::zeros(0),
    };
    let (phi, dphi) = problem.eval(&z);
    problem.r = problem.residual(&phi);
    problem.cost = problem.r.norm_squared();
    (problem.z, problem.phi, problem.dphi) = (z, phi, dphi);
    let report = lm::minimise(
        &mut problem,
        &lm::Options {
            max_iterations: opts.max_iterations,
            max_tries: 30,
            initial_damping: 1e-3,
            min_damping: 1e-15,
            max_damping: f64::INFINITY,
            shrink: lm::Shrink::Divide(10.0),
            fall: Some(lm::Fall {
                scale: 1.0,
                threshold: 1e-15,
            }),
            stall: Some(lm::Stall {
                window: STALL_WINDOW,
                fraction: opts.stall,
            }),
            stop_when_stuck: true,
        },
    );
    Ok((problem.phi, report.iterations))
}

/// The start of the projection's Levenberg–Marquardt: the unconstrained minimiser `free`
/// (`q` values: standard parameters, then extras) made consistent link by link (a link that
/// is not consistent there starts from `prior`, or from a small ball), its drive terms and
/// extras as square roots of at least `1e-3` of their natural scales `s`.
fn start_point(
    layout: &crate::dynamics::ParamLayout,
    free: &[f64],
    prior: &[f64],
    margins: &[Matrix4<f64>],
    s: &[f64],
) -> Vec<f64> {
    let (p, q) = (layout.len(), s.len());
    let mut z = vec![0.0; q];
    for c in p..q {
        z[c] = free[c].max(1e-3 * s[c]).sqrt();
    }
    for (j, e) in margins.iter().enumerate() {
        let start = layout.link_start(j);
        let link = |v: &[f64]| log_cholesky(&(pseudo_inertia(&v[start..start + INERTIAL]) - e));
        let zl = link(free).or_else(|| link(prior)).unwrap_or_else(|| {
            // A unit-mass ball of 0.1 m gyration radius at the origin.
            let mut d = [0.0; INERTIAL];
            for v in &mut d[1..4] {
                *v = (0.1f64 / 3f64.sqrt()).ln();
            }
            d
        });
        z[start..start + INERTIAL].copy_from_slice(&zl);
        for c in start + INERTIAL..start + layout.per_link() {
            z[c] = free[c].max(1e-3 * s[c]).sqrt();
        }
    }

    z
}

/// Names of the standard parameters (of `names`, layout order) that are not a function of the
/// base parameters `K` (a component in the null space of `K`, in the coordinates scaled by
/// `s`, beyond [`NULL_TOL`]): their split is set by the prior.
fn set_by_prior(k: &DMatrix<f64>, s: &[f64], names: &[String]) -> Result<Vec<String>> {
    let (nb, p) = k.shape();
    // Null space of K in scaled coordinates: 1 - |V_r^T e_k|^2 is the squared null part of
    // the unit vector e_k.
    let ks = DMatrix::from_fn(nb, p, |i, c| k[(i, c)] * s[c]);
    let svd = ks.svd(false, true);
    let v_t = svd
        .v_t
        .ok_or_else(|| Error::Numerical("consistent projection: SVD without V".into()))?;
    let smax = svd.singular_values.max();
    Ok((0..p)
        .filter(|&c| {
            let row: f64 = (0..v_t.nrows())
                .filter(|&i| svd.singular_values[i] > 1e-10 * smax)
                .map(|i| v_t[(i, c)].powi(2))
                .sum();
            (1.0 - row).max(0.0).sqrt() > NULL_TOL
        })
        .map(|c| names[c].clone())
        .collect())
}

/// [`project`] the estimate behind `model` (SI, not efficiency-scaled): its base parameters
/// (which must come first and carry the model's names) and its other values, kept
/// non-negative, with the estimate's full covariance.
///
/// Errors: an efficiency-scaled model, an estimate that does not cover the model's base
/// parameters at once, or what [`project`] refuses.
fn project_estimate(
    robot: &Robot,
    model: &PowerModel,
    estimate: &Estimate,
    prior: &[f64],
    opts: &Options,
) -> Result<Consistent> {
    let base = model.base_params(robot)?;
    if model.efficiency_scaled {
        return Err(Error::InvalidInput(
            "the model is scaled by 1/efficiency (power alone cannot separate them); export needs a model in SI units (identify --method auto, total, pmsm or gear)".into(),
        ));
    }
    let nb = model.theta.len();
    let nt = estimate.values.len();
    let covers = nt >= nb
        && estimate.names.len() == nt
        && estimate.names[..nb] == model.names[..]
        && estimate.covariance.shape() == (nt, nt);
    if !covers {
        return Err(Error::InvalidInput(
            "the estimate does not cover all base parameters of the model at once (a step-by-step fit has no joint covariance); export needs identify --method auto, total, pmsm or gear".into(),
        ));
    }
    project(&base, &estimate.values, &estimate.covariance, prior, opts)
}

/// The physically consistent model nearest to a fitted one, for predictions (estimation
/// within the consistent set rather than a check afterwards): the base parameters of the
/// consistent standard parameters that [`project`] finds for `model`'s `estimate` (closest
/// in the estimate's Mahalanobis metric; `prior` decides only what the data cannot see), and
/// the estimate's other values (copper-loss coefficients `c<i>_W_per_Nm2`, gear friction
/// `g<i>_gear_friction`, standby `P0_W`) as the projection moved them (kept >= 0). The covariance and intervals stay the
/// unconstrained estimate's.
///
/// Errors: as [`IdentifiedTwin::new`].
pub fn constrain(
    robot: &Robot,
    model: &PowerModel,
    estimate: &Estimate,
    prior: &[f64],
    opts: &Options,
) -> Result<(PowerModel, Consistent)> {
    let consistent = project_estimate(robot, model, estimate, prior, opts)?;
    let mut out = model.clone();
    out.theta.copy_from_slice(&consistent.theta);
    let nb = model.theta.len();
    for (param, v) in extra_params(estimate, nb).zip(&consistent.extras) {
        match param {
            Param::Standby => {
                out.constant.fill(0.0);
                out.constant[0] = *v;
            }
            Param::Copper(i) if i < out.copper.len() => out.copper[i] = *v,
            Param::Gear(i) if i < out.gear_friction.len() => out.gear_friction[i] = *v,
            _ => {}
        }
    }
    Ok((out, consistent))
}

/// What each of the estimate's values after its `nb` base parameters is in the power model
/// ([`Estimate::params`]; nothing for an estimate that does not say).
fn extra_params(estimate: &Estimate, nb: usize) -> impl Iterator<Item = Param> + '_ {
    estimate.params.iter().skip(nb).copied()
}
