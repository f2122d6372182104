//! Mass matrix by the composite-rigid-body algorithm, forward dynamics, and energies.
//!
//! The CRBA here works in the base frame: for each joint `j` the links `j..n` form one
//! composite body; a unit acceleration of joint `j` needs the wrench
//! `(m_C z_j x (c_C - o_j), I_C z_j)` at the composite COM, whose moment about axis `i <= j`
//! is `M_ij`. It shares no code with the RNEA, so the two check each other.

use nalgebra::{DMatrix, DVector, Isometry3, Point3};

use crate::dynamics::{DriveTerms, Workspace, rnea::rnea};
use crate::error::{Error, Result};
use crate::kinematics::fk::link_poses;
use crate::model::{RigidInertia, Robot};

/// Joint-space mass matrix `M(q)` (kg m^2), plus `diag(Ia)` when `rotor_inertia` is given.
pub fn mass_matrix(robot: &Robot, q: &[f64], rotor_inertia: Option<&[f64]>) -> DMatrix<f64> {
    let n = robot.dof();
    let mut poses = vec![Isometry3::identity(); n];
    link_poses(robot, q, &mut poses);
    let mut m = DMatrix::zeros(n, n);
    let mut composite = RigidInertia::zero();
    for j in (0..n).rev() {
        composite = composite.combined(&robot.links()[j].inertia.transformed(&poses[j]));
        let zj = poses[j].rotation * nalgebra::Vector3::z();
        let oj = poses[j].translation.vector;
        let c = composite.com;
        let f = (zj.cross(&(c - oj))) * composite.mass;
        let nc = composite.inertia_com * zj;
        for i in 0..=j {
            let zi = poses[i].rotation * nalgebra::Vector3::z();
            let oi = poses[i].translation.vector;
            let mij = zi.dot(&(nc + (c - oi).cross(&f)));
            m[(i, j)] = mij;
            m[(j, i)] = mij;
        }
    }
    if let Some(ia) = rotor_inertia {
        for (i, v) in ia.iter().enumerate() {
            m[(i, i)] += v;
        }
    }
    m
}

/// Forward dynamics: `ddq = (M + diag Ia)^-1 (tau - h(q, dq))` with `h` the bias torques
/// (Coriolis, centrifugal, gravity and, when `drive` is given, friction `fv dq + fc sign dq`).
pub fn forward_dynamics(
    robot: &Robot,
    ws: &mut Workspace,
    q: &[f64],
    dq: &[f64],
    tau: &[f64],
    drive: Option<&DriveTerms>,
) -> Result<Vec<f64>> {
    robot.check_len(q, "q")?;
    robot.check_len(dq, "dq")?;
    robot.check_len(tau, "tau")?;
    let n = robot.dof();
    let mut h = vec![0.0; n];
    rnea(robot, ws, q, dq, &vec![0.0; n], drive, &mut h);
    let m = mass_matrix(robot, q, drive.map(|d| d.rotor_inertia.as_slice()));
    let rhs = DVector::from_iterator(n, tau.iter().zip(&h).map(|(t, b)| t - b));
    let chol = m
        .cholesky()
        .ok_or_else(|| Error::Model("mass matrix is not positive definite at this q".into()))?;
    Ok(chol.solve(&rhs).iter().copied().collect())
}

/// Kinetic energy `0.5 dq^T (M + diag Ia) dq`, J.
pub fn kinetic_energy(robot: &Robot, q: &[f64], dq: &[f64], rotor_inertia: Option<&[f64]>) -> f64 {
    let m = mass_matrix(robot, q, rotor_inertia);
    let v = DVector::from_column_slice(dq);
    0.5 * v.dot(&(m * &v))
}

/// Potential energy `-sum m_i g . c_i` relative to the base origin, J, under gravity `g`
/// (base frame, m/s^2).
pub fn potential_energy(robot: &Robot, q: &[f64], g: &nalgebra::Vector3<f64>) -> f64 {
    let mut poses = vec![Isometry3::identity(); robot.dof()];
    link_poses(robot, q, &mut poses);
    robot
        .links()
        .iter()
        .zip(&poses)
        .map(|(l, p)| -l.inertia.mass * g.dot(&(p * Point3::from(l.inertia.com)).coords))
        .sum()
}
