//! The identification set of any arm in its cell (`powertwin excite --set`): the members,
//! workspace and limits [`super::design_set`] needs, from a URDF, a [`Cell`] and the loads
//! the user can mount. The IRB 1200's set ([`crate::validation::idset`]) is hand-written;
//! this one is derived: centres spread over the cell's joint space
//! ([`super::centres::spread_centres`]), base frequencies alternating between `f` and `2 f`
//! (two speed spectra), the cell's joint ranges, floor, speed and acceleration scalings.

use crate::error::{Error, Result};
use crate::identification::excitation_set::centres::spread_centres;
use crate::identification::excitation_set::{
    DESIGN_RATE_HZ, Member, SetCriterion, SetDesign, SetOptions, design_set,
};
use crate::identification::tuning;
use crate::model::Robot;
use crate::model::payload::Payload;
use crate::trajectory::cell::Cell;

/// Distance the excitations keep from the cell's joint ranges, rad.
const POSITION_MARGIN_RAD: f64 = 0.05;
/// Fraction of the cell's speed and acceleration limits the optimiser may use (headroom
/// for tracking).
const LIMIT_FRACTION: f64 = 0.9;
/// Added to the cell's floor height and base radius for the optimiser, m: it checks the
/// workspace at 100 samples per period, and a motion may dip a few mm between them.
const WORKSPACE_CUSHION_M: f64 = 0.01;
/// Step at which each designed excitation is checked against the cell, s.
const CHECK_STEP_S: f64 = 1e-3;

/// What to design for an arm (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ArmSet {
    /// Known payload of each excitation (`None`: nothing on the flange); one excitation
    /// per entry.
    pub payloads: Vec<Option<Payload>>,
    /// Length of each excitation, s (rounded to whole periods of its base frequency).
    pub duration_s: f64,
    /// Base frequency of the 1st, 3rd, ... excitation, Hz; the 2nd, 4th, ... run at twice it.
    pub base_freq_hz: f64,
    /// Harmonics per joint (>= 2).
    pub harmonics: usize,
    /// Acceleration limits per joint before the cell's scaling, rad/s^2.
    pub accel_limits: Vec<f64>,
    /// Block-coordinate rounds of the design (>= 1).
    pub rounds: usize,
    /// CMA-ES evaluations per excitation and round.
    pub max_evals: usize,
    /// Seed of the centres and of the design.
    pub seed: u64,
}

/// The set problem of an arm in its cell.
#[derive(Debug, Clone)]
pub struct ArmPlan {
    /// The robot as the cell lets it move ([`Cell::limit`]): design and check against it.
    pub robot: Robot,
    /// Options of [`super::design_set`].
    pub options: SetOptions,
}

/// The set problem of `robot` in `cell` for `set`.
///
/// Errors ([`Error::InvalidInput`]): no payloads, a duration or base frequency that is not
/// finite and positive, acceleration limits of the wrong length or not positive, a cell
/// that does not fit the robot ([`Cell::limit`]), or one in which nothing can be designed
/// ([`spread_centres`]).
pub fn plan(robot: &Robot, cell: &Cell, set: &ArmSet) -> Result<ArmPlan> {
    if !(set.duration_s.is_finite() && set.duration_s > 0.0) {
        return Err(Error::InvalidInput(format!(
            "excitation duration {} s must be finite and positive",
            set.duration_s
        )));
    }
    if !(set.base_freq_hz.is_finite() && set.base_freq_hz > 0.0) {
        return Err(Error::InvalidInput(format!(
            "base frequency {} Hz must be finite and positive",
            set.base_freq_hz
        )));
    }
    robot.check_len(&set.accel_limits, "acceleration limits")?;
    if set
        .accel_limits
        .iter()
        .any(|a| !(a.is_finite() && *a > 0.0))
    {
        return Err(Error::InvalidInput(format!(
            "acceleration limits {:?} rad/s^2 must be finite and positive",
            set.accel_limits
        )));
    }
    let limited = cell.limit(robot)?;
    let centres = spread_centres(
        &limited,
        set.payloads.len(),
        POSITION_MARGIN_RAD,
        cell.floor_z(),
        cell.base_radius_m,
        set.seed,
    )?;
    let floor_z = cell.floor_z() + WORKSPACE_CUSHION_M;
    let base_radius = cell.base_radius_m + WORKSPACE_CUSHION_M;
    let members = centres
        .into_iter()
        .zip(&set.payloads)
        .enumerate()
        .map(|(k, (centre, payload))| {
            let f = set.base_freq_hz * if k % 2 == 0 { 1.0 } else { 2.0 };
            Member {
                centre,
                base_freq_hz: f,
                periods: (set.duration_s * f).round().max(1.0) as usize,
                payload: payload.clone(),
            }
        })
        .collect();
    let options = SetOptions {
        members,
        harmonics: set.harmonics,
        sample_rate_hz: DESIGN_RATE_HZ,
        min_speed: tuning::MIN_SPEED,
        criterion: SetCriterion::DOptimal,
        accel_limits: cell.accel_limits(&set.accel_limits),
        position_margin: POSITION_MARGIN_RAD,
        limit_fraction: LIMIT_FRACTION,
        floor_z,
        base_radius,
        rounds: set.rounds,
        max_evals: set.max_evals,
        seed: set.seed,
    };
    Ok(ArmPlan {
        robot: limited,
        options,
    })
}

/// Plan ([`plan`]), design ([`design_set`]) and check the set of `robot` in `cell`: every
/// excitation is checked every millisecond against the cell ([`Cell::check_motion`]).
///
/// Errors: those of [`plan`] and [`design_set`], and an excitation that leaves the cell.
pub fn design(robot: &Robot, cell: &Cell, set: &ArmSet) -> Result<(ArmPlan, SetDesign)> {
    let problem = plan(robot, cell, set)?;
    let designed = design_set(&problem.robot, &problem.options)?;
    for (k, traj) in designed.trajectories.iter().enumerate() {
        cell.check_motion(
            &problem.robot,
            traj,
            &problem.options.accel_limits,
            CHECK_STEP_S,
        )
        .map_err(|e| e.context(&format!("excitation {} of the set", k + 1)))?;
    }
    Ok((problem, designed))
}
