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
//! one unit per coordinate, each step an SVD least-squares solve of the augmented Jacobian) from the unconstrained minimiser, links that are not consistent
//! there starting from the prior.

use nalgebra::{DMatrix, DVector, Matrix4};
use serde::Serialize;

use crate::dynamics::ParamLayout;
use crate::dynamics::base_params::BaseParams;
use crate::error::{Error, Result};
use crate::identification::fit::Param;
use crate::identification::lsq::Estimate;
use crate::identification::model::PowerModel;
use crate::model::Robot;
use crate::model::drive::{Drive, JointDrive};
use crate::model::export::{drive_string, urdf_string, with_standard_params};
use crate::numerics::lm;

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

/// Pseudo-inertia `[[Sigma, h], [h^T, m]]` of one link's standard parameters
/// `[XX YY ZZ XY XZ YZ MX MY MZ M]` (about the frame origin).
pub fn pseudo_inertia(p: &[f64]) -> Matrix4<f64> {
    let [xx, yy, zz, xy, xz, yz, mx, my, mz, m] =
        [p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9]];
    let half_tr = 0.5 * (xx + yy + zz);
    Matrix4::new(
        half_tr - xx,
        -xy,
        -xz,
        mx,
        -xy,
        half_tr - yy,
        -yz,
        my,
        -xz,
        -yz,
        half_tr - zz,
        mz,
        mx,
        my,
        mz,
        m,
    )
}

/// Inverse of [`pseudo_inertia`] (linear, so it maps derivatives too).
fn standard_of(j: &Matrix4<f64>) -> [f64; INERTIAL] {
    let (sxx, syy, szz) = (j[(0, 0)], j[(1, 1)], j[(2, 2)]);
    [
        syy + szz,
        sxx + szz,
        sxx + syy,
        -j[(0, 1)],
        -j[(0, 2)],
        -j[(1, 2)],
        j[(0, 3)],
        j[(1, 3)],
        j[(2, 3)],
        j[(3, 3)],
    ]
}

/// Entries of `U` that the log-Cholesky vector `[a d1 d2 d3 s12 s13 s23 t1 t2 t3]` sets
/// (after `a`, `d1..d3`): row, column.
const OFF_DIAGONAL: [(usize, usize); 6] = [(0, 1), (0, 2), (1, 2), (0, 3), (1, 3), (2, 3)];

/// `U` of a log-Cholesky vector.
fn cholesky_factor(z: &[f64]) -> Matrix4<f64> {
    let s = z[0].exp();
    let mut u = Matrix4::zeros();
    for i in 0..3 {
        u[(i, i)] = s * z[1 + i].exp();
    }
    u[(3, 3)] = s;
    for (k, &(r, c)) in OFF_DIAGONAL.iter().enumerate() {
        u[(r, c)] = s * z[4 + k];
    }
    u
}

/// The log-Cholesky vector of a positive-definite pseudo-inertia; `None` if it is not.
fn log_cholesky(j: &Matrix4<f64>) -> Option<[f64; INERTIAL]> {
    // Reversing rows and columns turns the lower Cholesky factor into the upper one:
    // P J P = L L^T  =>  J = (P L P)(P L P)^T with P L P upper triangular.
    let rev = Matrix4::from_fn(|r, c| j[(3 - r, 3 - c)]);
    let l = rev.cholesky()?.unpack();
    let u = Matrix4::from_fn(|r, c| l[(3 - r, 3 - c)]);
    let s = u[(3, 3)];
    let mut z = [0.0; INERTIAL];
    z[0] = s.ln();
    for i in 0..3 {
        z[1 + i] = (u[(i, i)] / s).ln();
    }
    for (k, &(r, c)) in OFF_DIAGONAL.iter().enumerate() {
        z[4 + k] = u[(r, c)] / s;
    }
    z.iter().all(|v| v.is_finite()).then_some(z)
}

/// Link inertial parameters of a log-Cholesky vector and their 10x10 Jacobian
/// `d phi / d z` (column k: derivative by `z[k]`).
fn link_of(z: &[f64]) -> ([f64; INERTIAL], [[f64; INERTIAL]; INERTIAL]) {
    let u = cholesky_factor(z);
    let phi = standard_of(&(u * u.transpose()));
    let s = z[0].exp();
    let mut jac = [[0.0; INERTIAL]; INERTIAL];
    for (k, col) in jac.iter_mut().enumerate() {
        let mut du = Matrix4::zeros();
        match k {
            0 => du = u,
            1..=3 => du[(k - 1, k - 1)] = u[(k - 1, k - 1)],
            _ => {
                let (r, c) = OFF_DIAGONAL[k - 4];
                du[(r, c)] = s;
            }
        }
        let dj = du * u.transpose() + u * du.transpose();
        *col = standard_of(&dj);
    }
    (phi, jac)
}

/// Natural scales of every standard parameter of `prior` (see the module docs), and per link
/// the length scale `L`, m.
fn scales(layout: &ParamLayout, prior: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut s = vec![0.0; layout.len()];
    let mut lengths = Vec::with_capacity(layout.dof);
    // Drive-term scales: the term's prior, at least the largest prior of its kind (1 N m or
    // 1 N m s/rad when every friction prior is zero); rotor inertia at least the link's own
    // inertia scale. Generous on purpose: a zero prior means "unknown", not "zero".
    let largest = |col: fn(&ParamLayout, usize) -> Option<usize>, default: f64| {
        let v = (0..layout.dof)
            .filter_map(|j| col(layout, j))
            .map(|c| prior[c].abs())
            .fold(0.0, f64::max);
        if v > 0.0 { v } else { default }
    };
    let fc = largest(ParamLayout::coulomb_col, 1.0);
    let fv = largest(ParamLayout::viscous_col, 1.0);
    let ia = largest(ParamLayout::armature_col, 0.0);
    for j in 0..layout.dof {
        let start = layout.link_start(j);
        let p = &prior[start..start + INERTIAL];
        let m = if p[9] > 0.0 { p[9] } else { 1.0 };
        let c2 = (p[6] * p[6] + p[7] * p[7] + p[8] * p[8]) / (m * m);
        // tr(I_origin) = tr(I_com) + 2 m |c|^2; the radius of gyration about the COM is
        // sqrt(tr(I_com) / (2 m)).
        let gyr2 = ((p[0] + p[1] + p[2]) / (2.0 * m) - c2).max(0.0);
        let l = c2.max(gyr2).sqrt().max(0.01);
        lengths.push(l);
        for k in 0..6 {
            s[start + k] = m * l * l;
        }
        for k in 6..9 {
            s[start + k] = m * l;
        }
        s[start + 9] = m;
        for (col, floor) in [
            (layout.coulomb_col(j), fc),
            (layout.viscous_col(j), fv),
            (layout.armature_col(j), ia.max(m * l * l)),
        ] {
            if let Some(c) = col {
                s[c] = prior[c].abs().max(floor);
            }
        }
    }
    (s, lengths)
}

/// The margin `E` added to every link's pseudo-inertia, `J = U U^T + E`, so that `J` stays
/// positive definite by at least `MARGIN` times the link's natural scales even where the data
/// push a body to the boundary (zero thickness): `E = MARGIN diag(m L^2, m L^2, m L^2, m)`.
fn margin(s: &[f64], start: usize) -> Matrix4<f64> {
    Matrix4::from_diagonal(&nalgebra::Vector4::new(
        s[start],
        s[start],
        s[start],
        s[start + 9],
    )) * MARGIN
}

/// The standard vector of a parameter vector `z` (plus the constant `offset`, the margins)
/// and the diagonal blocks of `d phi / d z` as a dense matrix.
fn phi_of(layout: &ParamLayout, z: &[f64], offset: &[f64]) -> (Vec<f64>, DMatrix<f64>) {
    let p = layout.len();
    let mut phi = offset.to_vec();
    let mut jac = DMatrix::zeros(p, p);
    for j in 0..layout.dof {
        let start = layout.link_start(j);
        let (link, d) = link_of(&z[start..start + INERTIAL]);
        for (v, l) in phi[start..start + INERTIAL].iter_mut().zip(link) {
            *v += l;
        }
        for (k, col) in d.iter().enumerate() {
            for (r, v) in col.iter().enumerate() {
                jac[(start + r, start + k)] = *v;
            }
        }
        for c in start + INERTIAL..start + layout.per_link() {
            phi[c] += z[c] * z[c];
            jac[(c, c)] = 2.0 * z[c];
        }
    }
    (phi, jac)
}

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
/// [`ParamLayout::theta`] of the input URDF; drive terms may be zero). See the module docs.
///
/// Errors ([`Error::InvalidInput`]): wrong lengths, non-finite values, a covariance that is
/// not symmetric positive definite, a negative or non-finite `lambda`.
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
    let asym = (covariance - covariance.transpose()).abs().max();
    let eig = covariance.clone().symmetric_eigen();
    let emax = eig.eigenvalues.max();
    if asym > 1e-9 * emax.abs() || eig.eigenvalues.min() <= 1e-14 * emax || emax <= 0.0 {
        return Err(Error::InvalidInput(
            "consistent projection: the covariance of the estimate is not symmetric positive definite"
                .into(),
        ));
    }
    // R^T R = Info = Cov^-1 with R = diag(1/sqrt(e)) V^T.
    let r_info = DMatrix::from_fn(nt, nt, |i, j| {
        eig.eigenvectors[(j, i)] / eig.eigenvalues[i].sqrt()
    });
    let k = base_map(base)?;
    // Extras: the estimate's values after the base parameters, non-negative (x = z^2), mapped
    // to themselves. q = p + ne unknowns in all.
    let ne = nt - nb;
    let q = p + ne;
    let mut k_aug = DMatrix::zeros(nt, q);
    k_aug.view_mut((0, 0), (nb, p)).copy_from(&k);
    for e in 0..ne {
        k_aug[(nb + e, p + e)] = 1.0;
    }
    let rk = &r_info * &k_aug;
    let rtheta = &r_info * DVector::from_column_slice(theta_hat);
    let (mut s, lengths) = scales(&layout, prior);
    let extras = &theta_hat[nb..];
    let largest_extra = extras.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    s.extend(
        extras
            .iter()
            .map(|v| v.abs().max(1e-3 * largest_extra).max(1e-300)),
    );
    let mut prior_aug = prior.to_vec();
    prior_aug.extend(extras.iter().map(|v| v.max(0.0)));
    // Natural units of z for the damping and the step limit: log-Cholesky logs are
    // dimensionless, its off-diagonal entries are lengths (scale L), drive terms sqrt(scale).
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
    let sq = opts.lambda.sqrt();
    let w = DVector::from_iterator(q, s.iter().map(|v| sq / v));
    let prior_v = DVector::from_column_slice(&prior_aug);
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
        .map_err(|e| Error::InvalidInput(format!("consistent projection: {e}")))?;
    let mut z = vec![0.0; q];
    for c in p..q {
        z[c] = free[c].max(1e-3 * s[c]).sqrt();
    }
    for (j, e) in margins.iter().enumerate() {
        let start = layout.link_start(j);
        let link = |v: &[f64]| log_cholesky(&(pseudo_inertia(&v[start..start + INERTIAL]) - e));
        let zl = link(free.as_slice())
            .or_else(|| link(prior))
            .unwrap_or_else(|| {
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

    // Levenberg–Marquardt in z.
    let mut problem = Projection {
        layout: &layout,
        offset: &offset,
        j_phi: &j_phi,
        rk: &rk,
        rtheta: &rtheta,
        prior: &prior_v,
        w: &w,
        unit: &unit,
        z: Vec::new(),
        phi: DVector::zeros(0),
        dphi: DMatrix::zeros(0, 0),
        r: DVector::zeros(0),
        cost: 0.0,
        jac: DMatrix::zeros(0, 0),
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
    let (phi, iterations) = (problem.phi, report.iterations);

    let fitted = &k_aug * &phi;
    let dtheta = &fitted - DVector::from_column_slice(theta_hat);
    let mahalanobis = (&r_info * &dtheta).norm();
    let change_sigma: Vec<f64> = (0..nt)
        .map(|i| dtheta[i].abs() / covariance[(i, i)].sqrt())
        .collect();
    let max_change_sigma = change_sigma.iter().cloned().fold(0.0, f64::max);
    // Null space of K in scaled coordinates: 1 - |V_r^T e_k|^2 is the squared null part of
    // the unit vector e_k.
    let ks = DMatrix::from_fn(nb, p, |i, c| k[(i, c)] * s[c]);
    let svd = ks.svd(false, true);
    let v_t = svd
        .v_t
        .ok_or_else(|| Error::InvalidInput("consistent projection: SVD without V".into()))?;
    let smax = svd.singular_values.max();
    let names = layout.names();
    let from_prior = (0..p)
        .filter(|&c| {
            let row: f64 = (0..v_t.nrows())
                .filter(|&i| svd.singular_values[i] > 1e-10 * smax)
                .map(|i| v_t[(i, c)].powi(2))
                .sum();
            (1.0 - row).max(0.0).sqrt() > NULL_TOL
        })
        .map(|c| names[c].clone())
        .collect();
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

/// The projection as a problem of [`lm::minimise`]: the residual
/// `[R (K_aug phi(z) - theta_hat); W (phi(z) - phi_prior)]` in the parametrisation `z`, its
/// step damped in the natural units of `z` and capped at [`MAX_STEP`] of them.
struct Projection<'a> {
    layout: &'a ParamLayout,
    /// The margins' standard vector (`q` long).
    offset: &'a [f64],
    /// Jacobian of the residual in `phi`.
    j_phi: &'a DMatrix<f64>,
    /// `R K_aug`.
    rk: &'a DMatrix<f64>,
    /// `R theta_hat`.
    rtheta: &'a DVector<f64>,
    /// The prior (augmented with the extras).
    prior: &'a DVector<f64>,
    /// Weights of the prior term.
    w: &'a DVector<f64>,
    /// Natural units of `z` (inverse scales) for the damping and the step cap.
    unit: &'a [f64],
    /// The current point.
    z: Vec<f64>,
    /// `phi(z)`.
    phi: DVector<f64>,
    /// `d phi / d z`.
    dphi: DMatrix<f64>,
    /// Residual at `phi`.
    r: DVector<f64>,
    /// `|r|^2`.
    cost: f64,
    /// Jacobian of the residual in `z` (this iteration's).
    jac: DMatrix<f64>,
}

/// A trial point of [`Projection`] with its evaluation.
struct ProjectionTrial {
    z: Vec<f64>,
    phi: DVector<f64>,
    dphi: DMatrix<f64>,
    r: DVector<f64>,
}

impl Projection<'_> {
    /// Number of unknowns `q` (standard parameters and extras).
    fn unknowns(&self) -> usize {
        self.unit.len()
    }

    /// `phi(z)` (standard parameters, margins included, then the extras `z^2`) and
    /// `d phi / d z`.
    fn eval(&self, z: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
        let (p, q) = (self.layout.len(), self.unknowns());
        let (mut phi, mut d) = phi_of(self.layout, &z[..p], &self.offset[..p]);
        phi.extend(z[p..].iter().map(|v| v * v));
        d = d.resize(q, q, 0.0);
        for c in p..q {
            d[(c, c)] = 2.0 * z[c];
        }
        (DVector::from_vec(phi), d)
    }

    /// The residual at `phi`.
    fn residual(&self, phi: &DVector<f64>) -> DVector<f64> {
        let (nt, q) = (self.rk.nrows(), self.unknowns());
        let mut r = DVector::zeros(nt + q);
        r.rows_mut(0, nt).copy_from(&(self.rk * phi - self.rtheta));
        r.rows_mut(nt, q)
            .copy_from(&(phi - self.prior).component_mul(self.w));
        r
    }
}

impl lm::Problem for Projection<'_> {
    type Trial = ProjectionTrial;

    fn cost(&self) -> f64 {
        self.cost
    }

    fn linearise(&mut self) {
        self.jac = self.j_phi * &self.dphi;
    }

    fn trial(&mut self, mu: f64) -> Option<(ProjectionTrial, f64)> {
        let (nt, q) = (self.rk.nrows(), self.unknowns());
        let mut a = DMatrix::zeros(nt + 2 * q, q);
        a.rows_mut(0, nt + q).copy_from(&self.jac);
        for (c, u) in self.unit.iter().enumerate() {
            a[(nt + q + c, c)] = mu.sqrt() * u;
        }
        let mut b = DVector::zeros(nt + 2 * q);
        b.rows_mut(0, nt + q).copy_from(&(-&self.r));
        let mut step = a.svd(true, true).solve(&b, 0.0).ok()?;
        // At most one natural unit per coordinate and step: a factor e on the log-Cholesky
        // diagonal, L on its other entries.
        lm::cap_step(&mut step, self.unit, MAX_STEP);
        let z: Vec<f64> = self.z.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
        let (phi, dphi) = self.eval(&z);
        if phi.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let r = self.residual(&phi);
        let c = r.norm_squared();
        Some((ProjectionTrial { z, phi, dphi, r }, c))
    }

    fn accept(&mut self, trial: ProjectionTrial, cost: f64) {
        self.z = trial.z;
        self.phi = trial.phi;
        self.dphi = trial.dphi;
        self.r = trial.r;
        self.cost = cost;
    }
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
            "the model is scaled by 1/efficiency (power alone cannot separate them); export needs a model in SI units (identify --method auto, total or pmsm)".into(),
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
            "the estimate does not cover all base parameters of the model at once (a step-by-step fit has no joint covariance); export needs identify --method auto, total or pmsm".into(),
        ));
    }
    project(&base, &estimate.values, &estimate.covariance, prior, opts)
}

/// The physically consistent model nearest to a fitted one, for predictions (estimation
/// within the consistent set rather than a check afterwards): the base parameters of the
/// consistent standard parameters that [`project`] finds for `model`'s `estimate` (closest
/// in the estimate's Mahalanobis metric; `prior` decides only what the data cannot see), and
/// the estimate's other values (copper-loss coefficients `c<i>_W_per_Nm2`, standby `P0_W`)
/// as the projection moved them (kept >= 0). The covariance and intervals stay the
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

/// The identified robot as a twin: a physically consistent robot and drive that reproduce an
/// identified [`PowerModel`], ready to be written as URDF and drive TOML.
#[derive(Debug, Clone)]
pub struct IdentifiedTwin {
    /// The input robot with the consistent link mass properties and friction.
    pub robot: Robot,
    /// Rotor inertia and friction from the consistent parameters; copper loss and standby
    /// power from the model (the standby power of the whole arm on joint 1); efficiency 1
    /// (the PMSM model has losses instead of an efficiency).
    pub drive: Drive,
    /// The projection.
    pub consistent: Consistent,
    /// Model values that were negative and written as 0 (copper or standby), with the value.
    pub clamped: Vec<String>,
}

impl IdentifiedTwin {
    /// Project the estimate behind `model` (SI, not efficiency-scaled) onto consistent
    /// parameters (see [`project`]): its base parameters (which must come first and carry the
    /// model's names) and its other values, the copper-loss coefficients `c<i>_W_per_Nm2` and
    /// the constant power `P0_W` of a PMSM fit, kept non-negative, with the estimate's full
    /// covariance. `prior` is a standard vector of the model's layout (e.g. the input URDF with
    /// [`crate::dynamics::DriveTerms::from_urdf`]).
    ///
    /// Errors: an efficiency-scaled model (power cannot separate the parameters from 1/eta),
    /// an estimate that does not cover the model's base parameters, or what [`project`]
    /// refuses.
    pub fn new(
        robot: &Robot,
        model: &PowerModel,
        estimate: &Estimate,
        prior: &[f64],
        opts: &Options,
    ) -> Result<IdentifiedTwin> {
        let consistent = project_estimate(robot, model, estimate, prior, opts)?;
        let nb = model.theta.len();
        // Copper and standby from the consistent extras where the estimate has them.
        let mut copper = model.copper.clone();
        let mut standby: f64 = model.constant.iter().sum();
        for (param, v) in extra_params(estimate, nb).zip(&consistent.extras) {
            match param {
                Param::Standby => standby = *v,
                Param::Copper(i) if i < copper.len() => copper[i] = *v,
                _ => {}
            }
        }
        let layout = model.layout;
        let identified = with_standard_params(robot, &layout, &consistent.phi)?;
        let mut clamped = Vec::new();
        let mut non_negative = |what: String, v: f64| {
            if v < 0.0 {
                clamped.push(format!("{what} = {v:.6e}"));
                0.0
            } else {
                v
            }
        };
        let joints = (0..robot.dof())
            .map(|j| JointDrive {
                rotor_inertia: layout.armature_col(j).map_or(0.0, |c| consistent.phi[c]),
                efficiency: 1.0,
                copper_loss: non_negative(
                    format!("copper_loss_W_per_Nm2 of joint {}", j + 1),
                    copper[j],
                ),
                standby_power: if j == 0 {
                    non_negative("standby_W of the arm".into(), standby)
                } else {
                    0.0
                },
                friction: identified.joints()[j].friction,
                unmodelled: Default::default(),
            })
            .collect();
        let drive = Drive::new(&identified, joints)?;
        Ok(IdentifiedTwin {
            robot: identified,
            drive,
            consistent,
            clamped,
        })
    }

    /// Names of the standard parameters of joint/link `j` (0-based) that came from the prior,
    /// without the link number.
    fn prior_of(&self, j: usize) -> Vec<String> {
        let suffix = (j + 1).to_string();
        self.consistent
            .from_prior
            .iter()
            .filter(|n| {
                n.strip_suffix(&suffix)
                    .is_some_and(|s| s.chars().all(|c| c.is_ascii_alphabetic()))
            })
            .map(|n| n[..n.len() - suffix.len()].to_string())
            .collect()
    }

    fn summary(&self) -> String {
        let c = &self.consistent;
        format!(
            "Physically consistent standard parameters (log-Cholesky pseudo-inertia, squared friction\nand rotor inertia) that reproduce the identified base parameters within a Mahalanobis\ndistance of {:.3e} (largest change {:.3e} standard deviations of the estimate).\nSet by the prior (the input URDF; not revealed by the data, only their combinations are):\n{}",
            c.mahalanobis,
            c.max_change_sigma,
            if c.from_prior.is_empty() {
                "none".to_string()
            } else {
                c.from_prior.join(", ")
            }
        )
    }

    /// The URDF text of the identified robot (see [`crate::model::export::urdf_string`]),
    /// saying in comments which parameters were identified and which came from the prior.
    pub fn urdf(&self) -> String {
        let notes: Vec<String> = (0..self.robot.dof())
            .map(|j| {
                let prior = self.prior_of(j);
                format!(
                    "identified by powertwin (consistent); from the prior: {}",
                    if prior.is_empty() {
                        "nothing".to_string()
                    } else {
                        prior.join(" ")
                    }
                )
            })
            .collect();
        let header = format!(
            "Robot '{}' identified from motor power by powertwin.\nLink inertials (mass, COM, inertia about the COM, URDF link frames) and joint friction\n(<dynamics damping friction>) are identified; geometry, joints and limits are the input's.\n{}",
            self.robot.name(),
            self.summary()
        );
        urdf_string(&self.robot, &header, &notes)
    }

    /// The drive TOML of the identified robot (see [`crate::model::export::drive_string`]).
    pub fn drive_toml(&self) -> String {
        let mut header = format!(
            "Drives of robot '{}' identified from motor power by powertwin (link side, SI).\nIdentified: coulomb_Nm, viscous_Nms_per_rad and rotor_inertia_kgm2 (consistent projection),\ncopper_loss_W_per_Nm2 and standby_W (PMSM model; power gives only the arm's total standby,\nwritten on joint 1). Not identified: efficiency = 1 (the PMSM model has losses instead).\n{}",
            self.robot.name(),
            self.summary()
        );
        if !self.clamped.is_empty() {
            header.push_str(&format!(
                "\nNegative identified values written as 0: {}",
                self.clamped.join(", ")
            ));
        }
        let notes: Vec<String> = (0..self.robot.dof())
            .map(|j| {
                let prior: Vec<String> = self
                    .prior_of(j)
                    .into_iter()
                    .filter(|n| matches!(n.as_str(), "fc" | "fv" | "Ia"))
                    .collect();
                if prior.is_empty() {
                    String::new()
                } else {
                    format!("from the prior: {}", prior.join(" "))
                }
            })
            .collect();
        drive_string(&self.robot, &self.drive, &header, &notes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_cholesky_round_trips_and_its_jacobian_matches_differences() {
        let body = crate::model::RigidInertia::new(
            2.0,
            nalgebra::Vector3::new(0.1, -0.2, 0.3),
            [0.05, 0.04, 0.03, 0.001, -0.002, 0.003],
        )
        .standard_params();
        let z = log_cholesky(&pseudo_inertia(&body)).unwrap();
        let (phi, jac) = link_of(&z);
        for (a, b) in phi.iter().zip(&body) {
            assert!((a - b).abs() < 1e-14, "{a} vs {b}");
        }
        let h = 1e-6;
        for k in 0..INERTIAL {
            let (mut zp, mut zm) = (z, z);
            zp[k] += h;
            zm[k] -= h;
            let (pp, pm) = (link_of(&zp).0, link_of(&zm).0);
            for r in 0..INERTIAL {
                let fd = (pp[r] - pm[r]) / (2.0 * h);
                assert!(
                    (fd - jac[k][r]).abs() < 1e-8,
                    "d{r}/d{k}: {fd} vs {}",
                    jac[k][r]
                );
            }
        }
        // Negative mass: no factor.
        let mut bad = body;
        bad[9] = -1.0;
        assert!(log_cholesky(&pseudo_inertia(&bad)).is_none());
    }
}
