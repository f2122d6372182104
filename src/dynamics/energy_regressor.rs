//! Energy regressor: `KE(q, dq) + PE(q) = h(q, dq) theta`, linear in the same parameters and
//! column order as the torque regressor ([`crate::dynamics::ParamLayout`]).
//!
//! Per link `j`, with `v` the velocity of origin `j` and `w` the angular velocity, both in
//! frame `j`: `KE_j = 1/2 m v.v + mc . (v x w) + 1/2 w^T I_o w`, and
//! `PE_j = -m g . p_j - (R_j^T g) . mc` with `p_j`, `R_j` the frame's pose in the base.
//! Rotor inertia adds `1/2 Ia dq^2`. Friction columns are zero: friction is work along the
//! path, not a state function. Over a time window, `h(t1) theta - h(t0) theta` plus the
//! friction work equals the energy the joints received, so parameters can be identified
//! from energy without accelerations (Gautier's energy model).

use nalgebra::{Matrix3, Vector3};

use crate::dynamics::ParamLayout;
use crate::model::Robot;

/// Fill `h` (`layout.len()` entries, overwritten) with the energy regressor at `(q, dq)`
/// under gravity `g` (base frame, m/s^2). Energies in J.
pub fn energy_regressor(
    robot: &Robot,
    layout: &ParamLayout,
    g: &Vector3<f64>,
    q: &[f64],
    dq: &[f64],
    h: &mut [f64],
) {
    debug_assert_eq!(h.len(), layout.len());
    h.fill(0.0);
    let per = layout.per_link();
    let mut rot = Matrix3::identity();
    let mut pos = Vector3::zeros();
    let mut w = Vector3::zeros();
    let mut v = Vector3::zeros();
    for (j, cj) in robot.chain().iter().enumerate() {
        let (s, c) = q[j].sin_cos();
        let r0 = cj.rot.column(0);
        let r1 = cj.rot.column(1);
        let r = Matrix3::from_columns(&[r0 * c + r1 * s, r1 * c - r0 * s, cj.rot.column(2).into()]);
        v = r.tr_mul(&(v + w.cross(&cj.pos)));
        w = r.tr_mul(&w) + Vector3::new(0.0, 0.0, dq[j]);
        pos += rot * cj.pos;
        rot *= r;
        let gj = rot.tr_mul(g);
        let vxw = v.cross(&w);
        let col = j * per;
        let vals = [
            0.5 * w.x * w.x,
            0.5 * w.y * w.y,
            0.5 * w.z * w.z,
            w.x * w.y,
            w.x * w.z,
            w.y * w.z,
            vxw.x - gj.x,
            vxw.y - gj.y,
            vxw.z - gj.z,
            0.5 * v.norm_squared() - g.dot(&pos),
        ];
        h[col..col + 10].copy_from_slice(&vals);
        if let Some(c) = layout.armature_col(j) {
            h[c] = 0.5 * dq[j] * dq[j];
        }
    }
}
