//! Rigid-body mass properties and the paper's standard inertial parameters.
//!
//! A [`RigidInertia`] holds mass (kg), centre of mass (m) and the inertia tensor about the
//! centre of mass (kg m^2), all expressed in one frame that the owner names (usually a link
//! frame). Products of inertia are tensor elements: `I[0][1] = -∫ x y dm` (the URDF and
//! Khalil convention), so a diagonal body has zero products.
//!
//! The standard parameter vector of a link follows Liu et al. 2018 (docs/design/method.md):
//! `[XX YY ZZ XY XZ YZ MX MY MZ M]`: inertia tensor about the *frame origin* (kg m^2),
//! first moments `m * c` (kg m) and mass (kg).

use nalgebra::{Isometry3, Matrix3, Vector3};

use crate::error::{Error, Result};

/// Names of the ten standard inertial parameters of one link, in vector order.
pub const STANDARD_NAMES: [&str; 10] = ["XX", "YY", "ZZ", "XY", "XZ", "YZ", "MX", "MY", "MZ", "M"];

/// Mass properties of a rigid body in a given frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidInertia {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass, m.
    pub com: Vector3<f64>,
    /// Inertia tensor about the centre of mass, kg m^2 (symmetric).
    pub inertia_com: Matrix3<f64>,
}

impl Default for RigidInertia {
    fn default() -> Self {
        Self::zero()
    }
}

impl RigidInertia {
    /// The massless body.
    pub fn zero() -> Self {
        RigidInertia {
            mass: 0.0,
            com: Vector3::zeros(),
            inertia_com: Matrix3::zeros(),
        }
    }

    /// From the six tensor elements `[ixx iyy izz ixy ixz iyz]` about the COM.
    pub fn new(mass: f64, com: Vector3<f64>, i: [f64; 6]) -> Self {
        let [xx, yy, zz, xy, xz, yz] = i;
        RigidInertia {
            mass,
            com,
            inertia_com: Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz),
        }
    }

    /// The same body expressed in another frame: `pose` is the pose of the current frame in
    /// the new one (new <- current).
    pub fn transformed(&self, pose: &Isometry3<f64>) -> Self {
        let r = pose.rotation.to_rotation_matrix();
        let r = r.matrix();
        RigidInertia {
            mass: self.mass,
            com: (pose * nalgebra::Point3::from(self.com)).coords,
            inertia_com: r * self.inertia_com * r.transpose(),
        }
    }

    /// Inertia tensor about the frame origin (parallel-axis theorem), kg m^2.
    pub fn inertia_origin(&self) -> Matrix3<f64> {
        self.inertia_com + parallel_axis(self.mass, &self.com)
    }

    /// Rigidly joins two bodies expressed in the same frame.
    pub fn combined(&self, other: &RigidInertia) -> Self {
        let mass = self.mass + other.mass;
        if mass <= 0.0 {
            return RigidInertia::zero();
        }
        let com = (self.com * self.mass + other.com * other.mass) / mass;
        let i_origin = self.inertia_origin() + other.inertia_origin();
        RigidInertia {
            mass,
            com,
            inertia_com: i_origin - parallel_axis(mass, &com),
        }
    }

    /// Standard parameters `[XX YY ZZ XY XZ YZ MX MY MZ M]` about the frame origin.
    pub fn standard_params(&self) -> [f64; 10] {
        let [xx, yy, zz, xy, xz, yz] = tensor_elements(&self.inertia_origin());
        let mc = self.com * self.mass;
        [xx, yy, zz, xy, xz, yz, mc.x, mc.y, mc.z, self.mass]
    }

    /// Inverse of [`RigidInertia::standard_params`]; a zero mass gives a zero COM.
    pub fn from_standard_params(p: &[f64; 10]) -> Self {
        let mass = p[9];
        let com = if mass != 0.0 {
            Vector3::new(p[6], p[7], p[8]) / mass
        } else {
            Vector3::zeros()
        };
        let i_origin = Matrix3::new(p[0], p[3], p[4], p[3], p[1], p[5], p[4], p[5], p[2]);
        RigidInertia {
            mass,
            com,
            inertia_com: i_origin - parallel_axis(mass, &com),
        }
    }

    /// Physical consistency: finite, positive mass, symmetric positive-definite inertia about the
    /// COM that satisfies the triangle inequality. `what` names the body in the error message.
    pub fn validate(&self, what: &str) -> Result<()> {
        let finite = self.mass.is_finite()
            && self.com.iter().all(|v| v.is_finite())
            && self.inertia_com.iter().all(|v| v.is_finite());
        if !finite {
            return Err(Error::Model(format!(
                "{what}: mass properties are not finite"
            )));
        }
        if self.mass <= 0.0 {
            return Err(Error::Model(format!(
                "{what}: mass is {} kg (must be positive; a moving link needs an <inertial>)",
                self.mass
            )));
        }
        let i = &self.inertia_com;
        let asym = (i - i.transpose()).abs().max();
        let eig = i.symmetric_eigenvalues();
        let scale = eig.abs().max().max(1e-300);
        if asym > 1e-12 * scale {
            return Err(Error::Model(format!(
                "{what}: inertia tensor is not symmetric"
            )));
        }
        let min = eig.min();
        if min <= 0.0 {
            return Err(Error::Model(format!(
                "{what}: inertia tensor about the COM is not positive definite (eigenvalues {:.3e}, {:.3e}, {:.3e} kg m^2)",
                eig[0], eig[1], eig[2]
            )));
        }
        let (a, b, c) = (eig[0], eig[1], eig[2]);
        let tol = 1e-9 * scale;
        if a + b < c - tol || a + c < b - tol || b + c < a - tol {
            return Err(Error::Model(format!(
                "{what}: principal moments {a:.3e}, {b:.3e}, {c:.3e} kg m^2 violate the triangle inequality"
            )));
        }
        Ok(())
    }
}

/// The six independent elements `[xx yy zz xy xz yz]` of a symmetric inertia tensor
/// (kg m^2), the order of URDF and of the standard parameters.
pub fn tensor_elements(i: &Matrix3<f64>) -> [f64; 6] {
    [
        i[(0, 0)],
        i[(1, 1)],
        i[(2, 2)],
        i[(0, 1)],
        i[(0, 2)],
        i[(1, 2)],
    ]
}

/// `m (|c|^2 I - c c^T)`: inertia of a point mass at `c` about the origin.
fn parallel_axis(mass: f64, c: &Vector3<f64>) -> Matrix3<f64> {
    mass * (Matrix3::identity() * c.norm_squared() - c * c.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    fn body() -> RigidInertia {
        RigidInertia::new(
            2.0,
            Vector3::new(0.1, -0.2, 0.3),
            [0.05, 0.04, 0.03, 0.001, -0.002, 0.003],
        )
    }

    #[test]
    fn standard_params_round_trip() {
        let b = body();
        let back = RigidInertia::from_standard_params(&b.standard_params());
        assert!((back.com - b.com).norm() < 1e-14);
        assert!((back.inertia_com - b.inertia_com).norm() < 1e-14);
    }

    #[test]
    fn combining_split_body_gives_whole() {
        // Two point-like halves at +-x make a body with Iyy = Izz = m x^2 about the joint COM.
        let half = |x: f64| RigidInertia::new(1.0, Vector3::new(x, 0.0, 0.0), [0.0; 6]);
        let whole = half(0.5).combined(&half(-0.5));
        assert_eq!(whole.mass, 2.0);
        assert!(whole.com.norm() < 1e-15);
        assert!((whole.inertia_com[(1, 1)] - 0.5).abs() < 1e-15);
        assert!(whole.inertia_com[(0, 0)].abs() < 1e-15);
    }

    #[test]
    fn transform_preserves_principal_moments() {
        let b = body();
        let pose = Isometry3::from_parts(
            Translation3::new(1.0, 2.0, 3.0),
            UnitQuaternion::from_euler_angles(0.3, -0.7, 1.1),
        );
        let t = b.transformed(&pose);
        let mut a: Vec<f64> = b
            .inertia_com
            .symmetric_eigenvalues()
            .iter()
            .copied()
            .collect();
        let mut c: Vec<f64> = t
            .inertia_com
            .symmetric_eigenvalues()
            .iter()
            .copied()
            .collect();
        a.sort_by(f64::total_cmp);
        c.sort_by(f64::total_cmp);
        for (x, y) in a.iter().zip(&c) {
            assert!((x - y).abs() < 1e-14);
        }
        assert!((t.com - (pose * nalgebra::Point3::from(b.com)).coords).norm() < 1e-14);
    }

    #[test]
    fn validate_rejects_bad_bodies() {
        assert!(body().validate("b").is_ok());
        let mut b = body();
        b.mass = 0.0;
        assert!(
            b.validate("link_x")
                .unwrap_err()
                .to_string()
                .contains("link_x")
        );
        let b = RigidInertia::new(1.0, Vector3::zeros(), [1.0, 1.0, -1.0, 0.0, 0.0, 0.0]);
        assert!(
            b.validate("l")
                .unwrap_err()
                .to_string()
                .contains("positive definite")
        );
        let b = RigidInertia::new(1.0, Vector3::zeros(), [1.0, 1.0, 3.0, 0.0, 0.0, 0.0]);
        assert!(
            b.validate("l")
                .unwrap_err()
                .to_string()
                .contains("triangle")
        );
    }
}
