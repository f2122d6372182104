//! The projection's nonlinear least-squares problem, solved by the shared
//! Levenberg–Marquardt loop ([`crate::numerics::lm`]).

use nalgebra::{DMatrix, DVector};

use super::MAX_STEP;
use super::inertia::phi_of;
use crate::dynamics::ParamLayout;
use crate::numerics::lm;

/// The projection as a problem of [`lm::minimise`]: the residual
/// `[R (K_aug phi(z) - theta_hat); W (phi(z) - phi_prior)]` in the parametrisation `z`, its
/// step damped in the natural units of `z` and capped at [`MAX_STEP`] of them.
pub(super) struct Projection<'a> {
    pub(super) layout: &'a ParamLayout,
    /// The margins' standard vector (`q` long).
    pub(super) offset: &'a [f64],
    /// Jacobian of the residual in `phi`.
    pub(super) j_phi: &'a DMatrix<f64>,
    /// `R K_aug`.
    pub(super) rk: &'a DMatrix<f64>,
    /// `R theta_hat`.
    pub(super) rtheta: &'a DVector<f64>,
    /// The prior (augmented with the extras).
    pub(super) prior: &'a DVector<f64>,
    /// Weights of the prior term.
    pub(super) w: &'a DVector<f64>,
    /// Natural units of `z` (inverse scales) for the damping and the step cap.
    pub(super) unit: &'a [f64],
    /// The current point.
    pub(super) z: Vec<f64>,
    /// `phi(z)`.
    pub(super) phi: DVector<f64>,
    /// `d phi / d z`.
    pub(super) dphi: DMatrix<f64>,
    /// Residual at `phi`.
    pub(super) r: DVector<f64>,
    /// `|r|^2`.
    pub(super) cost: f64,
    /// This iteration's linearisation: the triangular factor `R` of the Jacobian of the
    /// residual in `z` (`J = Q R`) and `-Q^T r`, so that each damped trial rotates only the
    /// damping's `q` rows into `R` ([`lm::damped_triangular_solve`]).
    pub(super) jac_r: DMatrix<f64>,
    /// `-Q^T r` of this iteration.
    pub(super) jac_qtr: DVector<f64>,
}

/// A trial point of [`Projection`] with its evaluation.
pub(super) struct ProjectionTrial {
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
    pub(super) fn eval(&self, z: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
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
    pub(super) fn residual(&self, phi: &DVector<f64>) -> DVector<f64> {
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
        // J has at least as many rows (n_theta + q) as columns (q): its thin QR.
        // Q^T r by the Householder reflections themselves (Q is never formed): its first q
        // entries are the thin Q's.
        let q = self.unknowns();
        let qr = (self.j_phi * &self.dphi).qr();
        let mut qtr = self.r.clone();
        qr.q_tr_mul(&mut qtr);
        self.jac_qtr = -qtr.rows(0, q);
        self.jac_r = qr.r();
    }

    fn trial(&mut self, mu: f64) -> Option<(ProjectionTrial, f64)> {
        // min |J s + r|^2 + mu |D s|^2 = min |R s - (-Q^T r)|^2 + |sqrt(mu) D s|^2.
        let damping: Vec<f64> = self.unit.iter().map(|u| mu.sqrt() * u).collect();
        let mut step = lm::damped_triangular_solve(&self.jac_r, &self.jac_qtr, &damping)?;
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
