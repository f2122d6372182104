//! Joint torque controller: computed-torque feedforward from a nominal model plus PD feedback.
//!
//! `a = ddq_ref + kd (dq_ref - dq) + kp (q_ref - q)` and
//! `tau = RNEA_nominal(q, dq, a) + Ia a + fv dq + fc sign(dq_ref)` (a reference slower than
//! [`crate::dynamics::REST_SPEED_EPS`] is at rest: no friction feedforward),
//! clipped to the joint effort limits when the model has them. The nominal model is the true
//! one by default; [`perturbed`] makes the imperfect model a real controller would have.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::dynamics::rnea::rnea;
use crate::dynamics::{DriveTerms, Workspace, sign};
use crate::error::Result;
use crate::model::{RigidInertia, Robot};

/// PD gains on the tracking error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gains {
    /// Position gain, 1/s^2.
    #[serde(rename = "kp_per_s2")]
    pub kp: f64,
    /// Velocity gain, 1/s.
    #[serde(rename = "kd_per_s")]
    pub kd: f64,
}

impl Default for Gains {
    /// Critically damped at 20 rad/s: kp = 400 /s^2, kd = 40 /s.
    fn default() -> Self {
        Gains {
            kp: 400.0,
            kd: 40.0,
        }
    }
}

/// A model with every link's mass, first moment and inertia, and every drive term, scaled by
/// its own factor `1 + e`, `e` uniform in `[-relative, relative]` (seeded). Scaling a body's
/// mass and inertia together keeps it physically consistent.
pub fn perturbed(
    robot: &Robot,
    drive: &DriveTerms,
    relative: f64,
    seed: u64,
) -> Result<(Robot, DriveTerms)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let factor = |rng: &mut ChaCha8Rng| {
        if relative > 0.0 {
            1.0 + rng.random_range(-relative..relative)
        } else {
            1.0
        }
    };
    let mut r = robot.clone();
    for i in 0..robot.dof() {
        let l = robot.links()[i].inertia;
        let f = factor(&mut rng);
        r = r.with_link_inertia(
            i,
            RigidInertia {
                mass: l.mass * f,
                com: l.com,
                inertia_com: l.inertia_com * f,
            },
        )?;
    }
    let mut scale = |v: &[f64]| v.iter().map(|x| x * factor(&mut rng)).collect::<Vec<_>>();
    let d = DriveTerms {
        rotor_inertia: scale(&drive.rotor_inertia),
        viscous: scale(&drive.viscous),
        coulomb: scale(&drive.coulomb),
    };
    Ok((r, d))
}

/// Computed-torque controller state.
#[derive(Debug, Clone)]
pub struct Controller {
    nominal: Robot,
    terms: DriveTerms,
    gains: Gains,
    ws: Workspace,
    a: Vec<f64>,
    effort: Vec<Option<f64>>,
}

impl Controller {
    /// A controller using `nominal` and `terms` as its model of the robot.
    pub fn new(nominal: Robot, terms: DriveTerms, gains: Gains) -> Self {
        let ws = Workspace::new(&nominal);
        let effort = nominal.joints().iter().map(|j| j.limits.effort).collect();
        let n = nominal.dof();
        Controller {
            nominal,
            terms,
            gains,
            ws,
            a: vec![0.0; n],
            effort,
        }
    }

    /// Replace the nominal model's last-link mass properties (the controller is told the
    /// payload, as with ABB's load data).
    pub fn set_last_link_inertia(&mut self, inertia: RigidInertia) -> Result<()> {
        let last = self.nominal.dof() - 1;
        self.nominal = self.nominal.with_link_inertia(last, inertia)?;
        Ok(())
    }

    /// Torque command (N m) for the measured state `(q, dq)` and the reference. Returns a
    /// bit mask of the joints whose command was clipped to the effort limit.
    pub fn torque(
        &mut self,
        q: &[f64],
        dq: &[f64],
        q_ref: &[f64],
        dq_ref: &[f64],
        ddq_ref: &[f64],
        tau: &mut [f64],
    ) -> u64 {
        let g = self.gains;
        for i in 0..q.len() {
            self.a[i] = ddq_ref[i] + g.kd * (dq_ref[i] - dq[i]) + g.kp * (q_ref[i] - q[i]);
        }
        rnea(&self.nominal, &mut self.ws, q, dq, &self.a, None, tau);
        let mut clipped = 0u64;
        for i in 0..q.len() {
            let t = &self.terms;
            tau[i] += t.rotor_inertia[i] * self.a[i]
                + t.viscous[i] * dq[i]
                + t.coulomb[i] * sign(dq_ref[i]);
            if let Some(limit) = self.effort[i]
                && tau[i].abs() > limit
            {
                tau[i] = tau[i].clamp(-limit, limit);
                clipped |= 1 << i;
            }
        }
        clipped
    }
}
