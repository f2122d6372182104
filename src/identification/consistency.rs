//! A check of an identified model's physical consistency that needs no truth and no mapping
//! back to standard parameters: the joint-space mass matrix the model implies must be
//! positive definite at every pose, and its friction and rotor-inertia base parameters must
//! not be negative. [`super::consistent`] goes further: it projects an estimate onto the
//! consistent set of standard parameters.

use nalgebra::{DMatrix, SymmetricEigen};
use serde::Serialize;

use crate::dynamics::Workspace;
use crate::dynamics::regressor::regressor;
use crate::error::Result;
use crate::identification::model::PowerModel;
use crate::model::Robot;
use crate::model::sampling::StateSampler;

/// Outcome of [`consistency`].
#[derive(Debug, Clone, Serialize)]
pub struct Consistency {
    /// Random poses within the position limits at which the mass matrix was checked.
    pub poses: usize,
    /// Smallest eigenvalue of the model's joint-space mass matrix (rotor inertia included)
    /// over those poses, kg m^2 (times the efficiency for an efficiency-scaled model).
    #[serde(rename = "min_mass_matrix_eigenvalue_kgm2")]
    pub min_eigenvalue: f64,
    /// Friction and rotor-inertia base parameters that came out negative.
    pub negative_drive_terms: Vec<String>,
    /// No negative drive term and a positive-definite mass matrix at every pose.
    pub consistent: bool,
}

/// A necessary check of physical consistency: the mass matrix the model implies,
/// `M(q) e_j = tau(q, 0, e_j) - tau(q, 0, 0)` (joint space; `e_j` a unit acceleration of
/// joint `j`), must be positive definite at every pose, and friction and rotor inertias must not be negative.
/// `poses` random poses within the limits, seeded with `seed`. `efficiency` undoes the scale
/// of an efficiency-scaled model (positive definiteness does not depend on it).
pub fn consistency(
    robot: &Robot,
    model: &PowerModel,
    efficiency: f64,
    poses: usize,
    seed: u64,
) -> Result<Consistency> {
    model.check_robot(robot)?;
    let n = robot.dof();
    let scale = if model.efficiency_scaled {
        efficiency
    } else {
        1.0
    };
    let mut sampler = StateSampler::new(robot, 1.0, 1.0, seed)?;
    let mut ws = Workspace::new(robot);
    let mut w = DMatrix::zeros(n, model.layout.len());
    let zero = vec![0.0; n];
    let mut tau = |q: &[f64], ddq: &[f64]| -> Vec<f64> {
        regressor(robot, &mut ws, &model.layout, q, &zero, ddq, &mut w);
        (0..n)
            .map(|i| {
                model
                    .columns
                    .iter()
                    .zip(&model.theta)
                    .map(|(&c, t)| w[(i, c)] * t * scale)
                    .sum()
            })
            .collect()
    };
    let mut min_eigenvalue = f64::INFINITY;
    for _ in 0..poses {
        let q = sampler.pose();
        let gravity = tau(&q, &zero);
        let mut m = DMatrix::zeros(n, n);
        for j in 0..n {
            let mut e = zero.clone();
            e[j] = 1.0;
            let col = tau(&q, &e);
            for i in 0..n {
                m[(i, j)] = col[i] - gravity[i];
            }
        }
        let sym = (&m + m.transpose()) * 0.5;
        min_eigenvalue = SymmetricEigen::new(sym)
            .eigenvalues
            .min()
            .min(min_eigenvalue);
    }
    let negative_drive_terms: Vec<String> = model
        .names
        .iter()
        .zip(&model.theta)
        .filter(|(name, v)| ["fc", "fv", "Ia"].iter().any(|p| name.starts_with(p)) && **v < 0.0)
        .map(|(name, _)| name.clone())
        .collect();
    Ok(Consistency {
        poses,
        min_eigenvalue,
        consistent: negative_drive_terms.is_empty() && min_eigenvalue > 0.0,
        negative_drive_terms,
    })
}
