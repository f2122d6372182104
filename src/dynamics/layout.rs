//! Column order of the parameter vector `theta` and of the regressor `W`.
//!
//! Per link `j = 1..n`, in this order: the ten inertial parameters
//! `[XXj YYj ZZj XYj XZj YZj MXj MYj MZj Mj]` (kg m^2 about the frame origin, kg m, kg;
//! see [`crate::model::inertia`]), then, if friction is on, `[fcj fvj]` (N m, N m s/rad),
//! then, if armature is on, `[Iaj]` (rotor inertia, kg m^2). Keeping each link's block
//! together lets the paper's step-by-step method identify one link at a time; putting the
//! drive terms after the inertial ones makes the base-parameter selection keep `ZZ1`
//! (regrouped with `Ia1`) rather than `Ia1`.

use serde::{Deserialize, Serialize};

use crate::dynamics::DriveTerms;
use crate::model::Robot;
use crate::model::inertia::STANDARD_NAMES;

/// Which parameter groups the regressor has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ParamLayout {
    /// Number of joints.
    pub dof: usize,
    /// Coulomb and viscous friction columns (2 per joint).
    pub friction: bool,
    /// Rotor-inertia (armature) column (1 per joint).
    pub armature: bool,
}

impl ParamLayout {
    /// Layout for `robot` with the chosen drive-term columns.
    pub fn new(robot: &Robot, friction: bool, armature: bool) -> Self {
        ParamLayout {
            dof: robot.dof(),
            friction,
            armature,
        }
    }

    /// Columns per link.
    pub fn per_link(&self) -> usize {
        10 + 2 * usize::from(self.friction) + usize::from(self.armature)
    }

    /// Total number of columns.
    pub fn len(&self) -> usize {
        self.dof * self.per_link()
    }

    /// Always false (a robot has at least one joint).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// First column of link `j` (0-based).
    pub fn link_start(&self, j: usize) -> usize {
        j * self.per_link()
    }

    /// Column of `fc` of joint `j`, if friction is on.
    pub fn coulomb_col(&self, j: usize) -> Option<usize> {
        self.friction.then(|| self.link_start(j) + 10)
    }

    /// Column of `fv` of joint `j`, if friction is on.
    pub fn viscous_col(&self, j: usize) -> Option<usize> {
        self.friction.then(|| self.link_start(j) + 11)
    }

    /// Column of `Ia` of joint `j`, if armature is on.
    pub fn armature_col(&self, j: usize) -> Option<usize> {
        self.armature
            .then(|| self.link_start(j) + 10 + 2 * usize::from(self.friction))
    }

    /// Parameter names, e.g. `XX1`, `fc1`, `Ia1` (1-based link numbers).
    pub fn names(&self) -> Vec<String> {
        let mut names = Vec::with_capacity(self.len());
        for j in 1..=self.dof {
            names.extend(STANDARD_NAMES.iter().map(|s| format!("{s}{j}")));
            if self.friction {
                names.push(format!("fc{j}"));
                names.push(format!("fv{j}"));
            }
            if self.armature {
                names.push(format!("Ia{j}"));
            }
        }
        names
    }

    /// The parameter vector of `robot` with drive terms `drive` (ignored where off).
    pub fn theta(&self, robot: &Robot, drive: &DriveTerms) -> Vec<f64> {
        let mut theta = Vec::with_capacity(self.len());
        for (j, p) in robot.standard_params().iter().enumerate() {
            theta.extend_from_slice(p);
            if self.friction {
                theta.push(drive.coulomb[j]);
                theta.push(drive.viscous[j]);
            }
            if self.armature {
                theta.push(drive.rotor_inertia[j]);
            }
        }
        theta
    }
}
