//! Table 2: identified base parameters next to the twin's true ones, and a physical-consistency
//! check of an identified model.

use nalgebra::{DMatrix, SymmetricEigen};
use serde::Serialize;

use crate::dynamics::regressor::regressor;
use crate::dynamics::{DriveTerms, Workspace};
use crate::error::Result;
use crate::identification::lsq::Estimate;
use crate::identification::model::PowerModel;
use crate::model::Robot;
use crate::model::drive::Drive;
use crate::model::sampling::StateSampler;

/// True values below this fraction of the largest true value of the same kind are "zero":
/// their relative error is not reported.
const NEGLIGIBLE: f64 = 1e-9;

/// One row of Table 2.
#[derive(Debug, Clone, Serialize)]
pub struct ParamRow {
    /// Base parameter name.
    pub name: String,
    /// Identified value (SI; divided by the efficiency for an efficiency-scaled model).
    pub identified: f64,
    /// The twin's true value, on the same scale.
    pub truth: f64,
    /// `100 (identified - truth) / |truth|`, %; `None` where the truth is zero.
    pub error_pct: Option<f64>,
    /// Relative standard deviation of the estimate, %; `None` if no estimate covers it.
    pub rel_std_pct: Option<f64>,
}

/// Table 2 for `model`, identified on a twin of `robot` with drives `drive`. `estimates` are
/// the least-squares results the model came from (for the standard deviations; a parameter
/// in several takes the last). An efficiency-scaled model is compared with the truth divided
/// by the drives' nominal efficiency.
pub fn table(
    robot: &Robot,
    drive: &Drive,
    model: &PowerModel,
    estimates: &[&Estimate],
) -> Result<Vec<ParamRow>> {
    let base = model.base_params(robot)?;
    let scale = if model.efficiency_scaled {
        1.0 / drive.nominal_efficiency()
    } else {
        1.0
    };
    let truth: Vec<f64> = base
        .base_values(&model.layout.theta(robot, &DriveTerms::from(drive)))?
        .into_iter()
        .map(|v| v * scale)
        .collect();
    let largest = truth.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    Ok(model
        .names
        .iter()
        .zip(&model.theta)
        .zip(&truth)
        .map(|((name, &identified), &truth)| {
            let rel_std_pct = estimates.iter().rev().find_map(|e| {
                e.names
                    .iter()
                    .position(|n| n == name)
                    .map(|k| 100.0 * e.rel_std[k])
            });
            ParamRow {
                name: name.clone(),
                identified,
                truth,
                error_pct: (truth.abs() > NEGLIGIBLE * largest)
                    .then(|| 100.0 * (identified - truth) / truth.abs()),
                rel_std_pct,
            }
        })
        .collect())
}

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

/// A necessary check of physical consistency that needs no mapping back to standard
/// parameters: the mass matrix the model implies, `M(q) e_j = tau(q, 0, e_j) - tau(q, 0, 0)`,
/// must be positive definite at every pose, and friction and rotor inertias must not be
/// negative. `poses` random poses within the limits, seeded with `seed`. `efficiency` undoes
/// the scale of an efficiency-scaled model.
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
