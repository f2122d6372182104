//! Joint-torque regressor `W(q, dq, ddq)` with `tau = W theta` (paper eqs. 5–6), and the
//! power regressor rows of eq. 11.
//!
//! Entry `(i, link j)` is the torque on joint `i <= j` produced by link `j`'s wrench. With
//! `u` = axis `i` and `v = u x (o_j - o_i)`, both in frame `j`, the wrench `(n_j, f_j)` about
//! origin `j` gives `tau_i = u . n_j + v . f_j`. Writing `n_j` and `f_j` linearly in the
//! ten parameters gives each entry in closed form, so the cost is about 60 flops per
//! `(i, j)` pair plus one frame change of `(u, v)` per pair; no 6x10 blocks are propagated.

use nalgebra::{DMatrix, Vector3};

use crate::dynamics::{ParamLayout, Workspace, sign};
use crate::model::Robot;

/// Fill `w` (`n x layout.len()`, overwritten) with the torque regressor at `(q, dq, ddq)`.
/// Allocates nothing. Column order: [`ParamLayout`].
pub fn regressor(
    robot: &Robot,
    ws: &mut Workspace,
    layout: &ParamLayout,
    q: &[f64],
    dq: &[f64],
    ddq: &[f64],
    w: &mut DMatrix<f64>,
) {
    let n = robot.dof();
    debug_assert!(w.nrows() == n && w.ncols() == layout.len());
    ws.forward(robot, q, dq, ddq);
    let chain = robot.chain();
    let per = layout.per_link();
    // Column-major storage: entry (i, c) is data[c * n + i].
    let data = w.as_mut_slice();
    for i in 0..n {
        // Links before joint i do not act on it.
        for c in 0..i * per {
            data[c * n + i] = 0.0;
        }
        let mut u = Vector3::z();
        let mut v = Vector3::zeros();
        for (j, cj) in chain.iter().enumerate().skip(i) {
            if j > i {
                let r = &ws.rot[j];
                let p = cj.pos;
                v = r.tr_mul(&(v + u.cross(&p)));
                u = r.tr_mul(&u);
            }
            let (om, dom, a) = (ws.w[j], ws.dw[j], ws.a[j]);
            let c2 = u.cross(&om);
            let mc = a.cross(&u) + v.cross(&dom) + v.cross(&om).cross(&om);
            let col = j * per;
            let vals = [
                u.x * dom.x + c2.x * om.x,
                u.y * dom.y + c2.y * om.y,
                u.z * dom.z + c2.z * om.z,
                u.x * dom.y + u.y * dom.x + c2.x * om.y + c2.y * om.x,
                u.x * dom.z + u.z * dom.x + c2.x * om.z + c2.z * om.x,
                u.y * dom.z + u.z * dom.y + c2.y * om.z + c2.z * om.y,
                mc.x,
                mc.y,
                mc.z,
                v.dot(&a),
            ];
            for (k, val) in vals.into_iter().enumerate() {
                data[(col + k) * n + i] = val;
            }
            // Drive-term columns of link j act on joint j only.
            if per > 10 {
                let on = j == i;
                let mut c = col + 10;
                if layout.friction {
                    data[c * n + i] = if on { sign(dq[i]) } else { 0.0 };
                    data[(c + 1) * n + i] = if on { dq[i] } else { 0.0 };
                    c += 2;
                }
                if layout.armature {
                    data[c * n + i] = if on { ddq[i] } else { 0.0 };
                }
            }
        }
    }
}

/// Turn a torque regressor into the per-joint power regressor in place: row `i` times
/// `dq_i` (paper eq. 11), so that `P_i = (W theta)_i dq_i` in W.
pub fn to_power_rows(w: &mut DMatrix<f64>, dq: &[f64]) {
    for (i, &v) in dq.iter().enumerate() {
        w.row_mut(i).scale_mut(v);
    }
}

/// Total-power row: `sum_i dq_i W_i`, so that `P_total = row . theta` (W). `out` has
/// `w.ncols()` entries and is overwritten.
pub fn total_power_row(w: &DMatrix<f64>, dq: &[f64], out: &mut [f64]) {
    debug_assert_eq!(out.len(), w.ncols());
    for (c, o) in out.iter_mut().enumerate() {
        *o = w.column(c).iter().zip(dq).map(|(x, v)| x * v).sum();
    }
}
