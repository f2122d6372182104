//! Rigid-body dynamics of the serial chain: inverse dynamics (RNEA), the joint-torque and
//! power regressors, the mass matrix (CRBA), forward dynamics and base parameters.
//!
//! Quantities are expressed in the MDH link frames of [`crate::model`]; gravity is
//! [`GRAVITY`] in the base frame (m/s^2, -z up to down). Joint vectors are in rad, rad/s,
//! rad/s^2 and torques in N m.
//!
//! The joint-torque model (paper eq. 2) is
//! `tau = M(q) ddq + C(q, dq) dq + G(q) + Ia ddq + fv dq + fc sign(dq)`
//! with the drive terms `Ia`, `fv`, `fc` of [`DriveTerms`] optional. Its linear-in-parameters
//! form `tau = W(q, dq, ddq) theta` uses the column order of [`ParamLayout`].
//!
//! Hot paths ([`rnea::rnea`], [`regressor::regressor`]) take a preallocated [`Workspace`] and
//! output buffer and allocate nothing per sample.

pub mod base_params;
pub mod crba;
pub mod energy_regressor;
pub mod layout;
pub mod regressor;
pub mod rnea;

use nalgebra::{Matrix3, Vector3};

use crate::model::Robot;
use crate::model::drive::Drive;
pub use layout::ParamLayout;

/// Gravity in the base frame, m/s^2.
pub const GRAVITY: Vector3<f64> = Vector3::new(0.0, 0.0, -9.81);

/// Per-joint drive terms added to the rigid-body torque:
/// `Ia_i ddq_i + fv_i dq_i + fc_i sign(dq_i)` (N m).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DriveTerms {
    /// Rotor inertia reflected to the link side, kg m^2.
    pub rotor_inertia: Vec<f64>,
    /// Viscous friction coefficient, N m s/rad.
    pub viscous: Vec<f64>,
    /// Coulomb friction torque, N m.
    pub coulomb: Vec<f64>,
}

impl DriveTerms {
    /// All zero for an `n`-joint robot.
    pub fn zero(n: usize) -> Self {
        DriveTerms {
            rotor_inertia: vec![0.0; n],
            viscous: vec![0.0; n],
            coulomb: vec![0.0; n],
        }
    }

    /// The URDF `<dynamics>` friction of `robot`, no rotor inertia.
    pub fn from_urdf(robot: &Robot) -> Self {
        DriveTerms {
            rotor_inertia: vec![0.0; robot.dof()],
            viscous: robot.joints().iter().map(|j| j.friction.viscous).collect(),
            coulomb: robot.joints().iter().map(|j| j.friction.coulomb).collect(),
        }
    }

    /// Torque of the drive terms on joint `i`, N m.
    #[inline]
    pub fn torque(&self, i: usize, dq: f64, ddq: f64) -> f64 {
        self.rotor_inertia[i] * ddq + self.viscous[i] * dq + self.coulomb[i] * sign(dq)
    }
}

impl From<&Drive> for DriveTerms {
    fn from(d: &Drive) -> Self {
        DriveTerms {
            rotor_inertia: d.rotor_inertia(),
            viscous: d.viscous(),
            coulomb: d.coulomb(),
        }
    }
}

/// Joint speed (rad/s) at or below which the Coulomb model takes a joint as at rest: no
/// friction torque (stiction holds it with whatever torque the rest needs, and neither the
/// twin's controller nor a model adds any). Far below any speed a drive moves at, far above
/// the rounding error of a planned reference: a joint a linear TCP move leaves still gets
/// speeds of 1e-17 rad/s from the inverse kinematics, whose sign would switch the full
/// Coulomb torque on in a direction chosen by the rounding and bias every prediction of such
/// a move upwards.
pub const REST_SPEED_EPS: f64 = 1e-9;

/// `sign(x)` of a joint speed `x` (rad/s), and 0 where `|x| <= REST_SPEED_EPS` (the Coulomb
/// model at rest).
#[inline]
pub fn sign(x: f64) -> f64 {
    if x > REST_SPEED_EPS {
        1.0
    } else if x < -REST_SPEED_EPS {
        -1.0
    } else {
        0.0
    }
}

/// Scratch memory for the recursive algorithms, sized for a number of joints, plus the
/// gravity vector. It holds no model data, so it may serve any robot with the same number
/// of joints. Reuse it across calls.
#[derive(Debug, Clone)]
pub struct Workspace {
    /// Rotation of frame i in frame i-1 at the current q.
    pub(crate) rot: Vec<Matrix3<f64>>,
    /// Angular velocity of link i in frame i, rad/s.
    pub(crate) w: Vec<Vector3<f64>>,
    /// Angular acceleration of link i in frame i, rad/s^2.
    pub(crate) dw: Vec<Vector3<f64>>,
    /// Linear acceleration of origin i minus gravity, in frame i, m/s^2.
    pub(crate) a: Vec<Vector3<f64>>,
    /// `-gravity`, expressed in the base frame, m/s^2.
    pub(crate) a0: Vector3<f64>,
}

impl Workspace {
    /// Workspace for `robot` under [`GRAVITY`].
    pub fn new(robot: &Robot) -> Self {
        Self::with_gravity(robot, GRAVITY)
    }

    /// Workspace for `robot` under gravity `g` (base frame, m/s^2).
    pub fn with_gravity(robot: &Robot, g: Vector3<f64>) -> Self {
        let n = robot.dof();
        Workspace {
            rot: vec![Matrix3::identity(); n],
            w: vec![Vector3::zeros(); n],
            dw: vec![Vector3::zeros(); n],
            a: vec![Vector3::zeros(); n],
            a0: -g,
        }
    }

    /// Forward recursion: rotations, angular velocity/acceleration and origin acceleration
    /// (gravity included) of every link in its own frame.
    #[inline]
    pub(crate) fn forward(&mut self, robot: &Robot, q: &[f64], dq: &[f64], ddq: &[f64]) {
        let chain = robot.chain();
        assert_eq!(
            self.w.len(),
            chain.len(),
            "workspace sized for another number of joints"
        );
        let mut w = Vector3::zeros();
        let mut dw = Vector3::zeros();
        let mut a = self.a0;
        for i in 0..chain.len() {
            let cj = &chain[i];
            let (s, c) = q[i].sin_cos();
            let r0 = cj.rot.column(0);
            let r1 = cj.rot.column(1);
            let rot =
                Matrix3::from_columns(&[r0 * c + r1 * s, r1 * c - r0 * s, cj.rot.column(2).into()]);
            let p = cj.pos;
            let a_new = rot.tr_mul(&(a + dw.cross(&p) + w.cross(&w.cross(&p))));
            let wr = rot.tr_mul(&w);
            let dwr = rot.tr_mul(&dw);
            w = Vector3::new(wr.x, wr.y, wr.z + dq[i]);
            dw = Vector3::new(dwr.x + wr.y * dq[i], dwr.y - wr.x * dq[i], dwr.z + ddq[i]);
            a = a_new;
            self.rot[i] = rot;
            self.w[i] = w;
            self.dw[i] = dw;
            self.a[i] = a;
        }
    }
}
