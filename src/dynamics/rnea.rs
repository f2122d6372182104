//! Recursive Newton–Euler inverse dynamics (Luh, Walker, Paul; modified DH frames).
//!
//! Forward: angular velocity/acceleration and origin acceleration of each link in its frame,
//! with gravity entered as a base acceleration. Backward: the wrench each link receives
//! from its parent; the joint torque is its z component (joint axis), plus the drive terms.

use nalgebra::Vector3;

use crate::dynamics::{DriveTerms, Workspace};
use crate::error::Result;
use crate::model::Robot;

/// Joint torques `tau` (N m) for the state `(q, dq, ddq)` (rad, rad/s, rad/s^2), rigid body
/// plus `drive` terms when given. Slices must have `robot.dof()` entries (checked in debug
/// builds only; see [`rnea_checked`]). Allocates nothing.
#[inline]
pub fn rnea(
    robot: &Robot,
    ws: &mut Workspace,
    q: &[f64],
    dq: &[f64],
    ddq: &[f64],
    drive: Option<&DriveTerms>,
    tau: &mut [f64],
) {
    let n = robot.dof();
    debug_assert!(q.len() == n && dq.len() == n && ddq.len() == n && tau.len() == n);
    ws.forward(robot, q, dq, ddq);
    let chain = robot.chain();
    let mut f_next = Vector3::zeros();
    let mut n_next = Vector3::zeros();
    for i in (0..n).rev() {
        let (w, dw, a) = (ws.w[i], ws.dw[i], ws.a[i]);
        let link = &chain[i];
        let (io, mc) = (&link.inertia_o, link.mc);
        let mut f = a * link.mass + dw.cross(&mc) + w.cross(&w.cross(&mc));
        let mut m = io * dw + w.cross(&(io * w)) + mc.cross(&a);
        if i + 1 < n {
            let r = &ws.rot[i + 1];
            let fr = r * f_next;
            f += fr;
            m += r * n_next + chain[i + 1].pos.cross(&fr);
        }
        tau[i] = m.z;
        f_next = f;
        n_next = m;
    }
    if let Some(d) = drive {
        for i in 0..n {
            tau[i] += d.torque(i, dq[i], ddq[i]);
        }
    }
}

/// [`rnea`] with input validation (lengths and finite values) and a fresh output vector.
pub fn rnea_checked(
    robot: &Robot,
    ws: &mut Workspace,
    q: &[f64],
    dq: &[f64],
    ddq: &[f64],
    drive: Option<&DriveTerms>,
) -> Result<Vec<f64>> {
    robot.check_len(q, "q")?;
    robot.check_len(dq, "dq")?;
    robot.check_len(ddq, "ddq")?;
    let mut tau = vec![0.0; robot.dof()];
    rnea(robot, ws, q, dq, ddq, drive, &mut tau);
    Ok(tau)
}
