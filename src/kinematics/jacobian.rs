//! Geometric Jacobian of a tool centre point.
//!
//! Column `i` is the twist of the TCP produced by a unit velocity (1 rad/s) of joint `i`
//! (0-based), in the base frame (frame 0 of the model): rows 0..3 are the linear velocity of
//! the TCP point (m/s per rad/s), `z_i x (p_tcp - o_i)`, rows 3..6 the angular velocity
//! (rad/s per rad/s), `z_i`, where `z_i` and `o_i` are the axis and origin of link frame
//! `i+1` in the base frame.
//!
//! [`bias_acceleration`] gives `Jdot dq`, the part of the TCP acceleration that the joint
//! velocities produce, for mapping Cartesian accelerations to joint accelerations.

use nalgebra::{
    Isometry3, Matrix3, Matrix6xX, Rotation3, Translation3, UnitQuaternion, Vector3, Vector6,
};

use crate::kinematics::fk::rot_then_z;
use crate::model::Robot;

/// The `6 x n` geometric Jacobian of the TCP at joint angles `q` (rad); `tcp` is the TCP pose
/// in the flange frame (m). See the module docs for the layout. Allocates the result; use
/// [`geometric_into`] in loops.
///
/// # Panics
/// If `q` does not have `robot.dof()` entries.
pub fn geometric(robot: &Robot, q: &[f64], tcp: &Isometry3<f64>) -> Matrix6xX<f64> {
    let mut j = Matrix6xX::zeros(robot.dof());
    geometric_into(robot, q, tcp, &mut j);
    j
}

/// Write the `6 x n` geometric Jacobian of the TCP at `q` (rad) into `out` (see the module
/// docs for the layout) and return the TCP pose in the base frame (m), which it computes on
/// the way. `tcp` is the TCP pose in the flange frame. Allocates nothing.
///
/// # Panics
/// If `q` or the columns of `out` do not number `robot.dof()`.
pub fn geometric_into(
    robot: &Robot,
    q: &[f64],
    tcp: &Isometry3<f64>,
    out: &mut Matrix6xX<f64>,
) -> Isometry3<f64> {
    let n = robot.dof();
    assert_eq!(
        q.len(),
        n,
        "jacobian: q has {} values for {n} joints",
        q.len()
    );
    assert_eq!(
        out.ncols(),
        n,
        "jacobian: out has {} columns for {n} joints",
        out.ncols()
    );
    let mut r = Matrix3::identity();
    let mut p = Vector3::zeros();
    // First pass: axis z_i into rows 3..6, origin o_i (temporarily) into rows 0..3.
    for (i, (c, &qi)) in robot.chain().iter().zip(q).enumerate() {
        p += r * c.pos;
        let (s, co) = qi.sin_cos();
        r = rot_then_z(&(r * c.rot), s, co);
        let mut col = out.column_mut(i);
        col.fixed_rows_mut::<3>(0).copy_from(&p);
        col.fixed_rows_mut::<3>(3).copy_from(&r.column(2));
    }
    let flange = robot.flange();
    let rf = r * flange.rotation.to_rotation_matrix().matrix();
    let p_tcp = p + r * flange.translation.vector + rf * tcp.translation.vector;
    for mut col in out.column_iter_mut() {
        let z = col.fixed_rows::<3>(3).into_owned();
        let o = col.fixed_rows::<3>(0).into_owned();
        col.fixed_rows_mut::<3>(0).copy_from(&z.cross(&(p_tcp - o)));
    }
    Isometry3::from_parts(
        Translation3::from(p_tcp),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rf)) * tcp.rotation,
    )
}

/// The TCP acceleration produced by the joint velocities `dq` (rad/s) alone at `q` (rad),
/// i.e. `Jdot(q, dq) dq` for the geometric Jacobian of the module docs: rows 0..3 the
/// acceleration of the TCP point (m/s^2), rows 3..6 the angular acceleration (rad/s^2), base
/// frame. With it the joint accelerations that give a TCP acceleration `a` (same layout) are
/// `J^-1 (a - Jdot dq)`. `tcp` is the TCP pose in the flange frame (m). Allocates nothing.
///
/// Computed by the forward recursion of link velocities and accelerations with zero joint
/// acceleration: `w_i = w_{i-1} + z_i dq_i`, `alpha_i = alpha_{i-1} + w_{i-1} x z_i dq_i`, and
/// every origin (then the TCP) accelerates as a point fixed in the previous link.
///
/// # Panics
/// If `q` or `dq` does not have `robot.dof()` entries.
pub fn bias_acceleration(
    robot: &Robot,
    q: &[f64],
    dq: &[f64],
    tcp: &Isometry3<f64>,
) -> Vector6<f64> {
    let n = robot.dof();
    assert!(
        q.len() == n && dq.len() == n,
        "bias_acceleration: q has {} and dq {} values for {n} joints",
        q.len(),
        dq.len()
    );
    let mut r = Matrix3::identity();
    let mut p = Vector3::zeros();
    // Angular velocity and acceleration of the previous link, acceleration of its origin.
    let (mut w, mut alpha, mut acc) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
    for ((c, &qi), &dqi) in robot.chain().iter().zip(q).zip(dq) {
        let step = r * c.pos;
        acc += alpha.cross(&step) + w.cross(&w.cross(&step));
        p += step;
        let (s, co) = qi.sin_cos();
        r = rot_then_z(&(r * c.rot), s, co);
        let z = r.column(2).into_owned() * dqi;
        alpha += w.cross(&z);
        w += z;
    }
    let flange = robot.flange();
    let rf = r * flange.rotation.to_rotation_matrix().matrix();
    let step = r * flange.translation.vector + rf * tcp.translation.vector;
    acc += alpha.cross(&step) + w.cross(&w.cross(&step));
    Vector6::new(acc.x, acc.y, acc.z, alpha.x, alpha.y, alpha.z)
}
