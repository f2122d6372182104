//! The log-Cholesky parametrisation of a link's pseudo-inertia (Rucker & Wensing 2022) and
//! the natural scales and margins of the standard parameters.

use nalgebra::{DMatrix, Matrix4};

use super::{INERTIAL, MARGIN};
use crate::dynamics::ParamLayout;

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
pub(super) fn standard_of(j: &Matrix4<f64>) -> [f64; INERTIAL] {
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
pub(super) fn log_cholesky(j: &Matrix4<f64>) -> Option<[f64; INERTIAL]> {
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
pub(super) fn link_of(z: &[f64]) -> ([f64; INERTIAL], [[f64; INERTIAL]; INERTIAL]) {
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
pub(super) fn scales(layout: &ParamLayout, prior: &[f64]) -> (Vec<f64>, Vec<f64>) {
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
pub(super) fn margin(s: &[f64], start: usize) -> Matrix4<f64> {
    Matrix4::from_diagonal(&nalgebra::Vector4::new(
        s[start],
        s[start],
        s[start],
        s[start + 9],
    )) * MARGIN
}

/// The standard vector of a parameter vector `z` (plus the constant `offset`, the margins)
/// and the diagonal blocks of `d phi / d z` as a dense matrix.
pub(super) fn phi_of(layout: &ParamLayout, z: &[f64], offset: &[f64]) -> (Vec<f64>, DMatrix<f64>) {
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
