//! The prior of identification: what the user already knows about the robot before any log,
//! from the URDF's inertials and the drive file's data-sheet values, each with a stated width.
//!
//! Identification is a posterior: the logs decide the directions of the base-parameter space
//! they determine, and the prior the rest ([`crate::identification::fit`]). A log that excites
//! only a few joints, or a few short moves, then gives a model instead of a rank-deficient
//! regressor, and its prediction intervals carry the prior's width where the data said
//! nothing.
//!
//! The prior is Gaussian on the base parameters `theta = K phi`. Each link's standard
//! parameters `phi` (inertia about the link frame's origin, first moments `m c`, mass) are
//! functions of its mass `m`, centre of mass `c` and inertia about the centre of mass `I_c`;
//! those are independent with the widths of [`PriorWidths`], and the standard parameters'
//! covariance is their linearisation at the URDF's values (the parallel-axis term included).
//! The drive terms (Coulomb and viscous friction, rotor inertia) are independent with a width
//! relative to the drive file's value; where the file gives none (zero), a width from the
//! joint's rating (see [`PriorWidths`]).
//!
//! The drive file's copper-loss coefficients are a prior too ([`Prior::copper`]), independent
//! of the rest, where the file gives one: a joint whose logged torques stay small leaves its
//! coefficient at the data sheet's value, not at zero, so a payload heavier than the logs
//! carried still pays its copper loss.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::dynamics::base_params::{BaseParams, SamplingOptions};
use crate::dynamics::{DriveTerms, ParamLayout};
use crate::error::{Error, Result};
use crate::identification::model::{PowerModel, Stribeck};
use crate::model::Robot;
use crate::model::drive::Drive;

/// Widths (one standard deviation) of the prior. The defaults are what CAD and data sheets
/// usually miss by: a link's mass by 30 %, its centre of mass by 2 cm, its inertia by 50 %,
/// a data-sheet friction or rotor inertia by 50 %, a data-sheet copper-loss coefficient by
/// 50 % (a winding's resistance alone rises by 30 % from 20 to 100 degC), a data-sheet gear
/// friction by 100 % (data sheets rarely state it; it is an estimate where they do).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorWidths {
    /// Link mass, relative (0.3 = 30 %).
    pub mass_rel: f64,
    /// Centre of mass, each coordinate, m.
    pub com_m: f64,
    /// Inertia about the centre of mass, each entry, relative to the mean principal moment.
    pub inertia_rel: f64,
    /// Coulomb and viscous friction, relative to the drive file's (or URDF's) value.
    pub friction_rel: f64,
    /// Rotor inertia, relative to the drive file's value.
    pub rotor_rel: f64,
    /// Copper-loss coefficient, relative to the drive file's value.
    #[serde(default = "default_copper_rel")]
    pub copper_rel: f64,
    /// Load-dependent gear friction, relative to the drive file's value.
    #[serde(default = "default_gear_rel")]
    pub gear_rel: f64,
}

/// [`PriorWidths::gear_rel`] by default.
fn default_gear_rel() -> f64 {
    1.0
}

/// [`PriorWidths::copper_rel`] by default.
fn default_copper_rel() -> f64 {
    0.5
}

impl Default for PriorWidths {
    fn default() -> Self {
        PriorWidths {
            mass_rel: 0.3,
            com_m: 0.02,
            inertia_rel: 0.5,
            friction_rel: 0.5,
            rotor_rel: 0.5,
            copper_rel: default_copper_rel(),
            gear_rel: default_gear_rel(),
        }
    }
}

/// Width of a link mass the URDF gives as zero, relative to the robot's total mass.
const MASS_FLOOR_REL: f64 = 0.01;

/// Width of a Coulomb friction the drive file does not give, relative to the joint's effort
/// limit (typical Coulomb friction of a geared joint is a few per cent of its rated torque).
const COULOMB_FLOOR_OF_EFFORT: f64 = 0.05;

/// Time (s) to reach the velocity limit at the acceleration assumed for a missing rotor
/// inertia: its width is `COULOMB_FLOOR_OF_EFFORT * effort / (velocity / ACCEL_TIME_S)`.
const ACCEL_TIME_S: f64 = 0.3;

/// Effort (N m) assumed for a joint whose URDF gives none.
const DEFAULT_EFFORT_NM: f64 = 10.0;

/// A Gaussian prior on the base parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Prior {
    /// Mean, in the base set's order, SI.
    pub mean: Vec<f64>,
    /// Covariance, SI squared.
    pub covariance: DMatrix<f64>,
    /// A root of the precision, `R = L^-1` with `covariance = L L^T` (lower triangular):
    /// `R^T R = covariance^-1`.
    pub root_precision: DMatrix<f64>,
    /// Per joint, the drive file's copper-loss coefficient, W/(N m)^2, with its width
    /// (independent of the base parameters); `None` where the file gives none (zero, or no
    /// drive file): the data alone then decide it, held at zero where they cannot tell it
    /// from zero.
    pub copper: Vec<Option<Normal>>,
    /// Per joint, the drive file's load-dependent gear friction (the mean of its motoring and
    /// braking values, the form the `gear` estimator fits), dimensionless, with its width;
    /// `None` where the file gives none.
    pub gear: Vec<Option<Normal>>,
    /// The drive file's standby power summed over the drives, W (`None` where it gives none):
    /// what the fitted constant holds beyond it is a load the meter sees after the bus clip
    /// ([`crate::identification::model::PowerModel::bus_floor`]).
    pub standby_w: Option<f64>,
    /// Per joint, the drive file's Stribeck law ([`Stribeck::of_drive`]); `None` where it
    /// gives none. Empty without a drive file.
    pub stribeck: Vec<Option<Stribeck>>,
}

/// A normal distribution of one value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normal {
    /// Mean.
    pub mean: f64,
    /// Standard deviation (> 0).
    pub std: f64,
}

impl Prior {
    /// The prior of `robot`'s base parameters in the set `base` (with friction and rotor
    /// inertia columns) from its URDF inertials and `drive` (the URDF's `<dynamics>`
    /// friction and no rotor inertia without one), with `widths`. Errors: widths that are not
    /// finite and positive, a layout without drive terms.
    pub fn new(
        robot: &Robot,
        drive: Option<&Drive>,
        base: &BaseParams,
        widths: &PriorWidths,
    ) -> Result<Prior> {
        check_widths(widths)?;
        let layout = *base.layout();
        if !(layout.friction && layout.armature) {
            return Err(Error::InvalidInput(
                "the prior needs a layout with friction and rotor inertia".into(),
            ));
        }
        let terms = match drive {
            Some(d) => DriveTerms {
                rotor_inertia: d.rotor_inertia(),
                viscous: d.viscous(),
                coulomb: d.coulomb(),
            },
            None => DriveTerms::from_urdf(robot),
        };
        let phi = layout.theta(robot, &terms);
        let std_cov = standard_covariance(robot, &layout, &terms, widths);
        // K: the base values of each standard unit vector (base_values is linear).
        let p = layout.len();
        let mut k = DMatrix::zeros(base.rank(), p);
        let mut unit = vec![0.0; p];
        for c in 0..p {
            unit[c] = 1.0;
            k.set_column(c, &DVector::from_vec(base.base_values(&unit)?));
            unit[c] = 0.0;
        }
        let covariance = &k * std_cov * k.transpose();
        let chol = covariance.clone().cholesky().ok_or_else(|| {
            Error::Numerical("the prior covariance of the base parameters is not positive".into())
        })?;
        // covariance = L L^T, so covariance^-1 = L^-T L^-1 and R = L^-1 is a root.
        let l_inv = chol
            .l()
            .solve_lower_triangular(&DMatrix::identity(base.rank(), base.rank()))
            .ok_or_else(|| Error::Numerical("prior covariance root not invertible".into()))?;
        let copper = (0..robot.dof())
            .map(|j| {
                let c = drive.map_or(0.0, |d| d.joints()[j].copper_loss);
                (c > 0.0).then_some(Normal {
                    mean: c,
                    std: widths.copper_rel * c,
                })
            })
            .collect();
        let gear = (0..robot.dof())
            .map(|j| {
                let g = drive.map_or(0.0, |d| {
                    let u = &d.joints()[j].unmodelled;
                    0.5 * (u.gear_friction + u.gear_friction_braking)
                });
                (g > 0.0).then_some(Normal {
                    mean: g,
                    std: widths.gear_rel * g,
                })
            })
            .collect();
        let standby_w = drive
            .map(|d| d.joints().iter().map(|j| j.standby_power).sum::<f64>())
            .filter(|w| *w > 0.0);
        let stribeck = drive.map_or_else(Vec::new, |d| {
            d.joints().iter().map(Stribeck::of_drive).collect()
        });
        Ok(Prior {
            mean: base.base_values(&phi)?,
            covariance,
            root_precision: l_inv,
            copper,
            gear,
            standby_w,
            stribeck,
        })
    }

    /// [`Prior::new`] in the base-parameter set every power model of `robot` uses (friction
    /// and rotor inertia columns).
    pub fn for_robot(robot: &Robot, drive: Option<&Drive>, widths: &PriorWidths) -> Result<Prior> {
        let layout = ParamLayout::new(robot, true, true);
        let base = BaseParams::compute(robot, layout, &SamplingOptions::default())?;
        Prior::new(robot, drive, &base, widths)
    }

    /// What the data determined in `model` (identified with this prior or without one): its
    /// base-parameter covariance against the prior's. See [`Determination`].
    pub fn determination(&self, model: &PowerModel) -> Result<Determination> {
        let nb = self.mean.len();
        let np = (model.covariance.len() as f64).sqrt() as usize;
        if model.theta.len() != nb || np * np != model.covariance.len() || np < nb {
            return Err(Error::InvalidInput(format!(
                "a model of {} base parameters (covariance of {} values) for a prior of {nb}",
                model.theta.len(),
                model.covariance.len()
            )));
        }
        let post = DMatrix::from_fn(nb, nb, |r, c| model.covariance[r * np + c]);
        // The posterior covariance in the prior's whitened coordinates: eigenvalue 1 where the
        // data said nothing, near 0 where they decided.
        let r = &self.root_precision;
        let whitened = r * &post * r.transpose();
        let eig = whitened.symmetric_eigen();
        let directions = eig
            .eigenvalues
            .iter()
            .filter(|v| **v < MOSTLY_PRIOR_RATIO * MOSTLY_PRIOR_RATIO)
            .count();
        let prior_std = self.std();
        let per_link = model.layout.per_link();
        let parameters: Vec<ParamSource> = (0..nb)
            .map(|k| {
                let std = post[(k, k)].max(0.0).sqrt();
                let ratio = std / prior_std[k];
                ParamSource {
                    name: model.names[k].clone(),
                    joint: model.columns[k] / per_link + 1,
                    value: model.theta[k],
                    std,
                    prior_std: prior_std[k],
                    prior_ratio: ratio,
                    source: if ratio > MOSTLY_PRIOR_RATIO {
                        Source::Prior
                    } else {
                        Source::Data
                    },
                }
            })
            .collect();
        let mut joints: Vec<usize> = parameters
            .iter()
            .filter(|p| p.source == Source::Prior)
            .map(|p| p.joint)
            .collect();
        joints.sort_unstable();
        joints.dedup();
        Ok(Determination {
            directions,
            of: nb,
            parameters,
            mostly_prior_joints: joints,
        })
    }

    /// Prior standard deviation of each base parameter.
    pub fn std(&self) -> Vec<f64> {
        (0..self.mean.len())
            .map(|k| self.covariance[(k, k)].sqrt())
            .collect()
    }
}

/// Ratio of a parameter's posterior to prior standard deviation above which it is mostly
/// prior (the data halved its uncertainty at most); the same for a direction.
pub const MOSTLY_PRIOR_RATIO: f64 = 0.5;

/// Where a parameter's value comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// The data determined it (posterior std at most half the prior's).
    Data,
    /// Mostly the prior.
    Prior,
}

/// One base parameter's posterior against its prior.
#[derive(Debug, Clone, Serialize)]
pub struct ParamSource {
    /// Base-parameter name.
    pub name: String,
    /// Joint (1-based) whose link or drive the parameter belongs to: moving that joint
    /// determines it.
    pub joint: usize,
    /// Identified value, SI.
    pub value: f64,
    /// Posterior standard deviation, SI.
    pub std: f64,
    /// Prior standard deviation, SI.
    pub prior_std: f64,
    /// `std / prior_std`.
    pub prior_ratio: f64,
    /// Data or mostly prior ([`MOSTLY_PRIOR_RATIO`]).
    pub source: Source,
}

/// What the logs determined: the directions of the base-parameter space where the posterior
/// standard deviation is at most half the prior's (of how many), each parameter's source, and
/// the joints whose parameters are mostly prior (an excitation of those joints would
/// determine them).
#[derive(Debug, Clone, Serialize)]
pub struct Determination {
    /// Directions the data determined.
    pub directions: usize,
    /// Dimension of the base-parameter space.
    pub of: usize,
    /// Each base parameter's source.
    pub parameters: Vec<ParamSource>,
    /// Joints (1-based) with a mostly-prior parameter.
    pub mostly_prior_joints: Vec<usize>,
}

impl Determination {
    /// Names of the mostly-prior parameters.
    pub fn mostly_prior(&self) -> Vec<&str> {
        self.parameters
            .iter()
            .filter(|p| p.source == Source::Prior)
            .map(|p| p.name.as_str())
            .collect()
    }

    /// Advice on what motion would determine the mostly-prior parameters, e.g. "add an
    /// excitation of joints 4-6" (`None` when the data determined every parameter).
    pub fn advice(&self) -> Option<String> {
        let j = &self.mostly_prior_joints;
        let (first, last) = (j.first()?, j.last()?);
        let list = if last - first + 1 == j.len() && j.len() > 1 {
            format!("joints {first}-{last}")
        } else if j.len() == 1 {
            format!("joint {first}")
        } else {
            format!(
                "joints {}",
                j.iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        Some(format!(
            "add an excitation that moves {list} over their range, fast and slow"
        ))
    }
}

/// Refuse widths that are not finite and positive.
fn check_widths(w: &PriorWidths) -> Result<()> {
    for (name, v) in [
        ("mass", w.mass_rel),
        ("com", w.com_m),
        ("inertia", w.inertia_rel),
        ("friction", w.friction_rel),
        ("rotor", w.rotor_rel),
        ("copper", w.copper_rel),
        ("gear", w.gear_rel),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::InvalidInput(format!(
                "prior width {name} = {v} must be finite and > 0"
            )));
        }
    }
    Ok(())
}

/// Covariance of the standard parameter vector ([`ParamLayout::theta`] order): per link the
/// linearised map of independent mass, centre-of-mass and inertia errors, per joint
/// independent drive terms.
fn standard_covariance(
    robot: &Robot,
    layout: &ParamLayout,
    terms: &DriveTerms,
    widths: &PriorWidths,
) -> DMatrix<f64> {
    let p = layout.len();
    let mut cov = DMatrix::zeros(p, p);
    let params = robot.standard_params();
    let total_mass: f64 = params.iter().map(|s| s[9]).sum();
    for (j, s) in params.iter().enumerate() {
        let block = link_covariance(s, total_mass, widths);
        let o = layout.link_start(j);
        cov.view_mut((o, o), (10, 10)).copy_from(&block);
        let joint = &robot.joints()[j];
        let effort = joint
            .limits
            .effort
            .filter(|e| *e > 0.0)
            .unwrap_or(DEFAULT_EFFORT_NM);
        let velocity = joint.limits.velocity.max(1e-3);
        let fc_floor = COULOMB_FLOOR_OF_EFFORT * effort;
        let drive_std = [
            (
                layout.coulomb_col(j),
                terms.coulomb[j],
                widths.friction_rel,
                fc_floor,
            ),
            (
                layout.viscous_col(j),
                terms.viscous[j],
                widths.friction_rel,
                fc_floor / velocity,
            ),
            (
                layout.armature_col(j),
                terms.rotor_inertia[j],
                widths.rotor_rel,
                fc_floor * ACCEL_TIME_S / velocity,
            ),
        ];
        for (col, value, rel, floor) in drive_std {
            if let Some(c) = col {
                let sd = if value.abs() > 0.0 {
                    rel * value.abs()
                } else {
                    floor
                };
                cov[(c, c)] = sd * sd;
            }
        }
    }
    cov
}

/// Covariance of one link's standard parameters `[XX YY ZZ XY XZ YZ MX MY MZ M]` (inertia
/// about the frame origin, first moments, mass) from independent errors of its mass, centre
/// of mass and inertia about the centre of mass, linearised at `s`.
fn link_covariance(s: &[f64; 10], total_mass: f64, w: &PriorWidths) -> DMatrix<f64> {
    let m = s[9];
    let c = if m > 0.0 {
        Vector3::new(s[6], s[7], s[8]) / m
    } else {
        Vector3::zeros()
    };
    let io = Matrix3::new(s[0], s[3], s[4], s[3], s[1], s[5], s[4], s[5], s[2]);
    let ic = io - m * (c.norm_squared() * Matrix3::identity() - c * c.transpose());
    let sd_m = (w.mass_rel * m).max(MASS_FLOOR_REL * total_mass);
    let sd_i = w.inertia_rel * (ic.trace() / 3.0).max((m + sd_m) * w.com_m * w.com_m);
    // A link the URDF gives (almost) no mass still gets first moments of its possible mass:
    // otherwise their prior would be exactly zero and the covariance singular.
    let m_c = m.max(sd_m);
    // Jacobian columns: d/dm, d/dc_x, d/dc_y, d/dc_z, d/dIc (6 entries), each scaled by its
    // standard deviation.
    let mut jac = DMatrix::zeros(10, 10);
    let (cx, cy, cz) = (c.x, c.y, c.z);
    let dm = [
        cy * cy + cz * cz,
        cx * cx + cz * cz,
        cx * cx + cy * cy,
        -cx * cy,
        -cx * cz,
        -cy * cz,
        cx,
        cy,
        cz,
        1.0,
    ];
    let dcx = [0.0, 2.0 * cx, 2.0 * cx, -cy, -cz, 0.0, 1.0, 0.0, 0.0, 0.0];
    let dcy = [2.0 * cy, 0.0, 2.0 * cy, -cx, 0.0, -cz, 0.0, 1.0, 0.0, 0.0];
    let dcz = [2.0 * cz, 2.0 * cz, 0.0, 0.0, -cx, -cy, 0.0, 0.0, 1.0, 0.0];
    for r in 0..10 {
        jac[(r, 0)] = dm[r] * sd_m;
        jac[(r, 1)] = m_c * dcx[r] * w.com_m;
        jac[(r, 2)] = m_c * dcy[r] * w.com_m;
        jac[(r, 3)] = m_c * dcz[r] * w.com_m;
    }
    for e in 0..6 {
        jac[(e, 4 + e)] = sd_i;
    }
    &jac * jac.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::builtin;
    use crate::model::urdf::{LoadOptions, load_str};

    /// The linearised link covariance matches the spread of sampled links: mass, centre of
    /// mass and inertia drawn with the widths, mapped to standard parameters exactly.
    #[test]
    fn the_link_covariance_is_the_spread_of_sampled_links() {
        use rand::SeedableRng;
        use rand_chacha::ChaCha8Rng;
        use rand_distr::{Distribution, StandardNormal};
        let (m, c, ic) = (
            4.0,
            Vector3::new(0.1, -0.05, 0.2),
            Matrix3::new(0.05, 0.001, 0.0, 0.001, 0.04, 0.002, 0.0, 0.002, 0.03),
        );
        let standard = |m: f64, c: Vector3<f64>, ic: Matrix3<f64>| -> [f64; 10] {
            let io = ic + m * (c.norm_squared() * Matrix3::identity() - c * c.transpose());
            [
                io[(0, 0)],
                io[(1, 1)],
                io[(2, 2)],
                io[(0, 1)],
                io[(0, 2)],
                io[(1, 2)],
                m * c.x,
                m * c.y,
                m * c.z,
                m,
            ]
        };
        // Small widths: the linearisation is then exact to first order.
        let w = PriorWidths {
            mass_rel: 0.01,
            com_m: 0.002,
            inertia_rel: 0.01,
            ..PriorWidths::default()
        };
        let nominal = standard(m, c, ic);
        let cov = link_covariance(&nominal, m, &w);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let draws = 20_000;
        let sd_i = w.inertia_rel * ic.trace() / 3.0;
        let mut sampled = DMatrix::zeros(10, 10);
        for _ in 0..draws {
            let dm = w.mass_rel * m * g();
            let dc = Vector3::new(g(), g(), g()) * w.com_m;
            let e = [g(), g(), g(), g(), g(), g()];
            let di = Matrix3::new(e[0], e[3], e[4], e[3], e[1], e[5], e[4], e[5], e[2]) * sd_i;
            let s = standard(m + dm, c + dc, ic + di);
            let d = DVector::from_fn(10, |k, _| s[k] - nominal[k]);
            sampled += &d * d.transpose() / draws as f64;
        }
        for k in 0..10 {
            let (a, b) = (cov[(k, k)].sqrt(), sampled[(k, k)].sqrt());
            assert!(
                (a - b).abs() < 0.05 * b,
                "parameter {k}: {a} vs sampled {b}"
            );
        }
    }

    /// A link the URDF gives no mass or inertia still has a positive-definite prior.
    #[test]
    fn a_massless_link_has_a_positive_definite_prior() {
        let cov = link_covariance(&[0.0; 10], 20.0, &PriorWidths::default());
        let min = cov.symmetric_eigen().eigenvalues.min();
        assert!(min > 0.0, "smallest eigenvalue {min}");
    }

    #[test]
    fn the_prior_of_the_irb1200_is_centred_on_its_files_and_positive() {
        let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).unwrap();
        let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "built-in drive", &robot).unwrap();
        let layout = ParamLayout::new(&robot, true, true);
        let base = BaseParams::compute(&robot, layout, &SamplingOptions::default()).unwrap();
        let prior = Prior::new(&robot, Some(&drive), &base, &PriorWidths::default()).unwrap();
        let terms = DriveTerms {
            rotor_inertia: drive.rotor_inertia(),
            viscous: drive.viscous(),
            coulomb: drive.coulomb(),
        };
        let expected = base.base_values(&layout.theta(&robot, &terms)).unwrap();
        assert_eq!(prior.mean, expected);
        let std = prior.std();
        assert!(std.iter().all(|s| s.is_finite() && *s > 0.0), "{std:?}");
        // R^T R is the inverse of the covariance.
        let rtr = prior.root_precision.transpose() * &prior.root_precision;
        let eye = &rtr * &prior.covariance;
        let err = (eye - DMatrix::identity(base.rank(), base.rank())).amax();
        assert!(err < 1e-6, "R^T R covariance - 1: {err}");
        // The copper-loss coefficients: the drive file's, with the relative width.
        for (c, j) in prior.copper.iter().zip(drive.joints()) {
            let c = c.expect("the built-in drive gives every copper coefficient");
            assert_eq!(c.mean, j.copper_loss);
            assert!((c.std - 0.5 * j.copper_loss).abs() < 1e-15);
        }
        // Without a drive file, no copper-loss prior.
        let bare = Prior::new(&robot, None, &base, &PriorWidths::default()).unwrap();
        assert!(bare.copper.iter().all(Option::is_none));
        for bad in [
            PriorWidths {
                com_m: 0.0,
                ..PriorWidths::default()
            },
            PriorWidths {
                copper_rel: f64::NAN,
                ..PriorWidths::default()
            },
        ] {
            assert!(Prior::new(&robot, Some(&drive), &base, &bad).is_err());
        }
    }
}
