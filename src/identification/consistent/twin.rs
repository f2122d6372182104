//! The identified robot as a twin: consistent URDF and drive file.

use nalgebra::DMatrix;

use super::{Consistent, Options, extra_params, project_estimate};
use crate::dynamics::DriveTerms;
use crate::error::{Error, Result};
use crate::identification::fit::Param;
use crate::identification::lsq::Estimate;
use crate::identification::model::PowerModel;
use crate::model::Robot;
use crate::model::drive::{Brakes, Drive, JointDrive};
use crate::model::export::{drive_string, urdf_string, with_standard_params};

/// The identified robot as a twin: a physically consistent robot and drive that reproduce an
/// identified [`PowerModel`], ready to be written as URDF and drive TOML.
#[derive(Debug, Clone)]
pub struct IdentifiedTwin {
    /// The input robot with the consistent link mass properties and friction.
    pub robot: Robot,
    /// Rotor inertia and friction from the consistent parameters; copper loss and standby
    /// power from the model (the standby power of the whole arm on joint 1); efficiency 1
    /// (the PMSM model has losses instead of an efficiency).
    pub drive: Drive,
    /// The projection.
    pub consistent: Consistent,
    /// Model values that were negative and written as 0 (copper or standby), with the value.
    pub clamped: Vec<String>,
}

impl IdentifiedTwin {
    /// Project the estimate behind `model` (SI, not efficiency-scaled) onto consistent
    /// parameters (see [`project`](super::project)): its base parameters (which must come first and carry the
    /// model's names) and its other values, the copper-loss coefficients `c<i>_W_per_Nm2` and
    /// the constant power `P0_W` of a PMSM fit, kept non-negative, with the estimate's full
    /// covariance. `prior` is a standard vector of the model's layout (e.g. the input URDF with
    /// [`crate::dynamics::DriveTerms::from_urdf`]).
    ///
    /// Errors: an efficiency-scaled model (power cannot separate the parameters from 1/eta),
    /// an estimate that does not cover the model's base parameters, or what [`project`](super::project)
    /// refuses.
    pub fn new(
        robot: &Robot,
        model: &PowerModel,
        estimate: &Estimate,
        prior: &[f64],
        opts: &Options,
    ) -> Result<IdentifiedTwin> {
        let consistent = project_estimate(robot, model, estimate, prior, opts)?;
        let nb = model.theta.len();
        // Copper, gear friction and standby from the consistent extras where the estimate
        // has them.
        let mut copper = model.copper.clone();
        let mut gear = model.gear_friction.clone();
        let mut standby: f64 = model.constant.iter().sum();
        for (param, v) in extra_params(estimate, nb).zip(&consistent.extras) {
            match param {
                Param::Standby => standby = *v,
                Param::Copper(i) if i < copper.len() => copper[i] = *v,
                Param::Gear(i) if i < gear.len() => gear[i] = *v,
                _ => {}
            }
        }
        let layout = model.layout;
        let identified = with_standard_params(robot, &layout, &consistent.phi)?;
        let mut clamped = Vec::new();
        let mut non_negative = |what: String, v: f64| {
            if v < 0.0 {
                clamped.push(format!("{what} = {v:.6e}"));
                0.0
            } else {
                v
            }
        };
        let joints = (0..robot.dof())
            .map(|j| JointDrive {
                rotor_inertia: layout.armature_col(j).map_or(0.0, |c| consistent.phi[c]),
                efficiency: 1.0,
                copper_loss: non_negative(
                    format!("copper_loss_W_per_Nm2 of joint {}", j + 1),
                    copper[j],
                ),
                standby_power: if j == 0 {
                    non_negative("standby_W of the arm".into(), standby)
                } else {
                    0.0
                },
                friction: identified.joints()[j].friction,
                // The model's gear friction loses `g |tau dq|`: Coulomb friction `g |tau|`,
                // alike in both directions of the power flow.
                unmodelled: crate::model::drive::Unmodelled {
                    gear_friction: gear.get(j).copied().unwrap_or(0.0).max(0.0),
                    gear_friction_braking: gear.get(j).copied().unwrap_or(0.0).max(0.0),
                    ..Default::default()
                },
            })
            .collect();
        let drive = Drive::new(&identified, joints)?;
        Ok(IdentifiedTwin {
            robot: identified,
            drive,
            consistent,
            clamped,
        })
    }

    /// The twin of a model read from a file, built as [`IdentifiedTwin::new`] builds the one
    /// `identify --export-urdf --export-drive` writes, from the values and the covariance the
    /// model itself carries: its base parameters, copper-loss coefficients (those the fit held
    /// at zero, with zero variance, left out) and standby power, with the parameter
    /// covariance of the fit (its eigenvalues raised to at least `1e-12` of the largest, so
    /// that values the data fix exactly keep a positive definite metric). The prior is
    /// `robot` itself (its URDF mass properties and `<dynamics>` friction, no rotor inertia),
    /// as in the export. The twin's base parameters reproduce the model's: a model identified
    /// with the consistency constraint (the default) is already consistent, so the projection
    /// moves it by rounding only.
    ///
    /// Errors: a model without a covariance (written by a step-by-step or linear estimator),
    /// an efficiency-scaled model, and what [`IdentifiedTwin::new`] refuses.
    pub fn from_model(robot: &Robot, model: &PowerModel, opts: &Options) -> Result<IdentifiedTwin> {
        let estimate = model_estimate(model)?;
        let prior = model.layout.theta(robot, &DriveTerms::from_urdf(robot));
        IdentifiedTwin::new(robot, model, &estimate, &prior, opts)
    }

    /// The same twin with the brakes-applied standstill mode `brakes` (a data-sheet value of
    /// the controller that power does not identify, e.g. the input drive file's `[brakes]`),
    /// for runs that wait with brakes applied; the drive TOML written by
    /// [`IdentifiedTwin::drive_toml`] stays without it. `None` leaves the twin as it is.
    ///
    /// Errors: brakes the drive file format refuses (negative or non-finite values).
    pub fn with_brakes(mut self, brakes: Option<&Brakes>) -> Result<IdentifiedTwin> {
        if let Some(b) = brakes {
            let text = format!(
                "{}\n[brakes]\npower_W = {:?}\nengage_s = {:?}\nrelease_s = {:?}\n",
                drive_string(&self.robot, &self.drive, "", &[]),
                b.power_w,
                b.engage_s,
                b.release_s
            );
            self.drive = Drive::from_toml_str(&text, "identified drive with brakes", &self.robot)?;
        }
        Ok(self)
    }

    /// Names of the standard parameters of joint/link `j` (0-based) that came from the prior,
    /// without the link number.
    fn prior_of(&self, j: usize) -> Vec<String> {
        let suffix = (j + 1).to_string();
        self.consistent
            .from_prior
            .iter()
            .filter(|n| {
                n.strip_suffix(&suffix)
                    .is_some_and(|s| s.chars().all(|c| c.is_ascii_alphabetic()))
            })
            .map(|n| n[..n.len() - suffix.len()].to_string())
            .collect()
    }

    fn summary(&self) -> String {
        let c = &self.consistent;
        format!(
            "Physically consistent standard parameters (log-Cholesky pseudo-inertia, squared friction\nand rotor inertia) that reproduce the identified base parameters within a Mahalanobis\ndistance of {:.3e} (largest change {:.3e} standard deviations of the estimate).\nSet by the prior (the input URDF; not revealed by the data, only their combinations are):\n{}",
            c.mahalanobis,
            c.max_change_sigma,
            if c.from_prior.is_empty() {
                "none".to_string()
            } else {
                c.from_prior.join(", ")
            }
        )
    }

    /// The URDF text of the identified robot (see [`crate::model::export::urdf_string`]),
    /// saying in comments which parameters were identified and which came from the prior.
    pub fn urdf(&self) -> String {
        let notes: Vec<String> = (0..self.robot.dof())
            .map(|j| {
                let prior = self.prior_of(j);
                format!(
                    "identified by powertwin (consistent); from the prior: {}",
                    if prior.is_empty() {
                        "nothing".to_string()
                    } else {
                        prior.join(" ")
                    }
                )
            })
            .collect();
        let header = format!(
            "Robot '{}' identified from motor power by powertwin.\nLink inertials (mass, COM, inertia about the COM, URDF link frames) and joint friction\n(<dynamics damping friction>) are identified; geometry, joints and limits are the input's.\n{}",
            self.robot.name(),
            self.summary()
        );
        urdf_string(&self.robot, &header, &notes)
    }

    /// The drive TOML of the identified robot (see [`crate::model::export::drive_string`]).
    pub fn drive_toml(&self) -> String {
        let mut header = format!(
            "Drives of robot '{}' identified from motor power by powertwin (link side, SI).\nIdentified: coulomb_Nm, viscous_Nms_per_rad and rotor_inertia_kgm2 (consistent projection),\ncopper_loss_W_per_Nm2 and standby_W (PMSM model; power gives only the arm's total standby,\nwritten on joint 1). Not identified: efficiency = 1 (the PMSM model has losses instead).\n{}",
            self.robot.name(),
            self.summary()
        );
        if !self.clamped.is_empty() {
            header.push_str(&format!(
                "\nNegative identified values written as 0: {}",
                self.clamped.join(", ")
            ));
        }
        let notes: Vec<String> = (0..self.robot.dof())
            .map(|j| {
                let prior: Vec<String> = self
                    .prior_of(j)
                    .into_iter()
                    .filter(|n| matches!(n.as_str(), "fc" | "fv" | "Ia"))
                    .collect();
                if prior.is_empty() {
                    String::new()
                } else {
                    format!("from the prior: {}", prior.join(" "))
                }
            })
            .collect();
        drive_string(&self.robot, &self.drive, &header, &notes)
    }
}

/// The estimate a model carries: `z = [theta, c_1..c_n, g_1..g_n, P0]` (`g` when the model
/// has gear friction) with the model's covariance, loss coefficients of zero variance (held
/// at zero by the fit) left out, the covariance made positive definite (eigenvalues at least
/// `1e-12` of the largest).
fn model_estimate(model: &PowerModel) -> Result<Estimate> {
    let (nb, n, ng) = (
        model.theta.len(),
        model.copper.len(),
        model.gear_friction.len(),
    );
    let np = model.params();
    if model.covariance.len() != np * np {
        return Err(Error::InvalidInput(format!(
            "model of '{}' has no parameter covariance ({} entries, expected {np}^2): the identified twin needs a model from identify --method auto, total, pmsm or gear",
            model.robot,
            model.covariance.len()
        )));
    }
    let cov = DMatrix::from_row_slice(np, np, &model.covariance);
    let params: Vec<Param> = (0..nb)
        .map(Param::Base)
        .chain((0..n).map(Param::Copper))
        .chain((0..ng).map(Param::Gear))
        .chain([Param::Standby])
        .collect();
    let z: Vec<f64> = model
        .theta
        .iter()
        .chain(&model.copper)
        .chain(&model.gear_friction)
        .copied()
        .chain([model.constant.iter().sum()])
        .collect();
    let free: Vec<usize> = (0..np)
        .filter(|&k| !matches!(params[k], Param::Copper(_) | Param::Gear(_)) || cov[(k, k)] > 0.0)
        .collect();
    let covariance = DMatrix::from_fn(free.len(), free.len(), |r, c| cov[(free[r], free[c])]);
    let eig = covariance.symmetric_eigen();
    let floor = 1e-12 * eig.eigenvalues.max().max(0.0);
    let covariance = &eig.eigenvectors
        * DMatrix::from_diagonal(&eig.eigenvalues.map(|v| v.max(floor)))
        * eig.eigenvectors.transpose();
    let values: Vec<f64> = free.iter().map(|&k| z[k]).collect();
    let std: Vec<f64> = (0..free.len()).map(|k| covariance[(k, k)].sqrt()).collect();
    Ok(Estimate {
        names: free.iter().map(|&k| params[k].name(&model.names)).collect(),
        rel_std: crate::identification::lsq::rel_std(&values, &std),
        values,
        std,
        cond: f64::NAN,
        residual_rms: f64::NAN,
        rows: 0,
        covariance,
        params: free.iter().map(|&k| params[k]).collect(),
    })
}
