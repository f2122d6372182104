//! Forward kinematics: base-frame poses of the link frames, the flange and a TCP.
//!
//! Frames are those of [`crate::model`]: the base frame is frame 0 of the model (the URDF
//! root link); link frame `i` (1-based) has its z axis along joint `i` and its pose in frame
//! `i-1` is `origin_i * Rz(q_i)` ([`Robot::joint_transform`]). Joint angles are in rad,
//! positions in m.
//!
//! The chain is `R_i = R_{i-1} A_i Rz(q_i)`, `p_i = p_{i-1} + R_{i-1} a_i` with `(A_i, a_i)`
//! the rotation and translation of `origin_i`.

use nalgebra::{Isometry3, Matrix3, Quaternion, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::model::Robot;

/// Base-frame pose of every link frame at joint angles `q` (rad): `out[i]` is the pose of
/// link frame `i+1` (moved by joint `i`, 0-based) in frame 0. Allocates nothing.
///
/// Composed with quaternions, since every pose is returned as one.
///
/// # Panics
/// If `q` or `out` does not have `robot.dof()` entries.
pub fn link_poses(robot: &Robot, q: &[f64], out: &mut [Isometry3<f64>]) {
    let n = robot.dof();
    assert_eq!(
        q.len(),
        n,
        "link_poses: q has {} values for {n} joints",
        q.len()
    );
    assert_eq!(
        out.len(),
        n,
        "link_poses: out has {} slots for {n} joints",
        out.len()
    );
    let mut rot = Quaternion::identity();
    let mut pos = Vector3::zeros();
    for ((j, &qi), o) in robot.joints().iter().zip(q).zip(out.iter_mut()) {
        pos += UnitQuaternion::new_unchecked(rot) * j.origin.translation.vector;
        let (s, c) = (0.5 * qi).sin_cos();
        rot = rot * j.origin.rotation.into_inner() * Quaternion::new(c, 0.0, 0.0, s);
        *o = Isometry3::from_parts(Translation3::from(pos), UnitQuaternion::new_unchecked(rot));
    }
}

/// Base-frame pose of the tool flange (the model's flange frame, `tool0` for ABB URDFs) at
/// joint angles `q` (rad); translation in m. Allocates nothing.
///
/// This is the hot path of trajectory sampling: it composes the cached rotation matrices and
/// converts to a quaternion once.
///
/// # Panics
/// If `q` does not have `robot.dof()` entries.
pub fn flange_pose(robot: &Robot, q: &[f64]) -> Isometry3<f64> {
    let (r, p) = last_frame(robot, q);
    let f = robot.flange();
    Isometry3::from_parts(
        Translation3::from(p + r * f.translation.vector),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r)) * f.rotation,
    )
}

/// Base-frame pose of a tool centre point at joint angles `q` (rad). `tcp` is the pose of the
/// TCP frame in the flange frame (m). Allocates nothing.
///
/// # Panics
/// If `q` does not have `robot.dof()` entries.
pub fn tcp_pose(robot: &Robot, q: &[f64], tcp: &Isometry3<f64>) -> Isometry3<f64> {
    flange_pose(robot, q) * tcp
}

/// Rotation matrix and position (m) of the last link frame in the base frame.
///
/// # Panics
/// If `q` does not have `robot.dof()` entries.
pub(crate) fn last_frame(robot: &Robot, q: &[f64]) -> (Matrix3<f64>, Vector3<f64>) {
    let n = robot.dof();
    assert_eq!(
        q.len(),
        n,
        "forward kinematics: q has {} values for {n} joints",
        q.len()
    );
    let chain = robot.chain();
    // A robot has at least one joint; the first frame needs no product with the identity.
    let (s0, c0) = q[0].sin_cos();
    let mut r = rot_then_z(&chain[0].rot, s0, c0);
    let mut p = chain[0].pos;
    // Sines and cosines in batches, so that the libm calls do not wait on the matrix
    // products (measurably faster in `cargo bench --bench core`).
    let mut sc = [(0.0, 0.0); 8];
    for (links, angles) in chain[1..].chunks(sc.len()).zip(q[1..].chunks(sc.len())) {
        for (o, a) in sc.iter_mut().zip(angles) {
            *o = a.sin_cos();
        }
        for (c, &(s, co)) in links.iter().zip(&sc) {
            p += r * c.pos;
            r = rot_then_z(&(r * c.rot), s, co);
        }
    }
    (r, p)
}

/// `m * Rz(q)` given `(sin q, cos q)`: only the first two columns change.
#[inline]
pub(crate) fn rot_then_z(m: &Matrix3<f64>, s: f64, c: f64) -> Matrix3<f64> {
    let c0 = m.column(0);
    let c1 = m.column(1);
    Matrix3::from_columns(&[c0 * c + c1 * s, c1 * c - c0 * s, m.column(2).into_owned()])
}
