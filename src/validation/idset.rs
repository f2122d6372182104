//! The identification experiment a user would run on a robot: several excitations of every
//! joint about different centres of the workspace, each carrying a different known payload
//! (from none to the rated payload), designed together so that their stacked regressor at the
//! logging rate is well conditioned ([`crate::identification::excitation_set`]), run on the
//! twin; only their logs go on to identification
//! ([`crate::identification::fit::identify_logs`]), which chooses its estimator by
//! cross-validation.

use rayon::prelude::*;

use crate::dataset::Dataset;
use crate::error::{Error, Result};
use crate::identification::data::Route;
use crate::identification::excitation::standby_pose;
use crate::identification::excitation_set::arm::{self, ArmSet};
use crate::identification::excitation_set::{
    DESIGN_RATE_HZ, Member, SetCriterion, SetDesign, SetOptions, design_set,
};
use crate::identification::fit::{FitOptions, Selection, Weighting, identify_logs};
use crate::measurement::Log;
use crate::model::Robot;
use crate::model::payload::{Payload, PayloadEvent};
use crate::trajectory::cell::Cell;
use crate::trajectory::fourier::Fourier;
use crate::trajectory::limits::{IRB1200_ACCEL_LIMITS, default_accel_limits};
use crate::validation::rig::{Progress, Rig};

/// Harmonics of each excitation (and of the Fourier route its log is read along).
const HARMONICS: usize = 5;

/// Workspace of the excitations and the standby pose.
struct Workspace {
    /// Margin inside the position limits, rad.
    margin_rad: f64,
    /// Lowest height of the TCP above the base, m.
    floor_z_m: f64,
    /// Radius of the base column the TCP keeps out of, m.
    base_radius_m: f64,
}

/// The workspace of the identification set.
const WORKSPACE: Workspace = Workspace {
    margin_rad: 0.05,
    floor_z_m: 0.05,
    base_radius_m: 0.15,
};

/// Load of each excitation of [`IdSetOptions::for_arm`]'s set as a fraction of the rated
/// payload: the IRB 1200's 0, 2, 4.5, 7, 1, 3, 5.5 and 6 kg of its 7 kg.
const LOAD_FRACTIONS: [f64; 8] = [
    0.0,
    2.0 / 7.0,
    4.5 / 7.0,
    1.0,
    1.0 / 7.0,
    3.0 / 7.0,
    5.5 / 7.0,
    6.0 / 7.0,
];

/// Base frequency of [`IdSetOptions::for_arm`]'s 1st, 3rd, ... excitations, Hz (the others
/// at twice it, as `excite --set` alternates them): the IRB 1200 set's 0.1 and 0.2 Hz.
const ARM_BASE_FREQ_HZ: f64 = 0.1;

/// Seed of the identification set's design (and of [`IdSetOptions::for_arm`]'s centres).
const DESIGN_SEED: u64 = 101;

/// Centre of mass of the identification loads in the flange frame, m (a cube bolted to the
/// flange face).
pub const LOAD_COM_M: [f64; 3] = [0.0, 0.0, 0.05];

/// Settings of the identification set.
#[derive(Debug, Clone, PartialEq)]
pub struct IdSetOptions {
    /// Start guess of each excitation's centre pose, rad (one excitation per entry).
    pub centres: Vec<Vec<f64>>,
    /// Known load (kg) carried during each excitation (0: nothing on the flange).
    pub loads_kg: Vec<f64>,
    /// Base frequency of each excitation, Hz (10 s divided by a whole number of periods).
    pub base_freq_hz: Vec<f64>,
    /// Acceleration limits of the excitations, rad/s^2 per joint.
    pub accel_limits: Vec<f64>,
    /// Stretches of 10 s each excitation runs (whole periods of its base frequency).
    pub periods: usize,
    /// Length of an extra run holding the robot (without payload) at its
    /// [`standby_pose`], s; 0: none. Its log pins the standby power; [`IdSetOptions::irb1200`]
    /// has none (it did not improve the held-out benchmark, see
    /// docs/experiments.md#standby-rest-run).
    pub standby_rest_s: f64,
    /// Criterion of the set design.
    pub criterion: SetCriterion,
    /// Block-coordinate rounds of the set design.
    pub rounds: usize,
    /// Objective evaluations per excitation and round.
    pub max_evals: usize,
    /// Seed of the design.
    pub seed: u64,
    /// Identification settings.
    pub fit: FitOptions,
}

impl IdSetOptions {
    /// Eight excitations of the IRB 1200 about centres spread over the workspace, with 0, 2,
    /// 4.5, 7 (the rated payload), 1, 3, 5.5 and 6 kg at the flange; three 10 s stretches each.
    /// `quick`: the first four with two stretches, smaller designs.
    ///
    /// Three stretches, eight excitations and the power-level weighting were chosen on the
    /// held-out benchmark, see docs/experiments.md#identification-set-design.
    pub fn irb1200(quick: bool) -> IdSetOptions {
        let mut o = IdSetOptions {
            centres: vec![
                vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0],
                vec![1.0, 0.5, -0.2, 1.0, 1.2, 0.5],
                vec![-1.0, -0.2, 0.4, -1.0, 0.6, -0.5],
                vec![0.5, 0.7, 0.0, -0.5, 1.4, 1.0],
                vec![-0.5, 0.4, 0.1, 0.8, 1.0, -1.0],
                vec![1.5, 0.1, 0.3, -1.2, 0.9, 1.5],
                vec![-1.5, 0.6, -0.1, 0.5, 1.3, 0.0],
                vec![0.2, -0.1, 0.5, -0.8, 0.7, -1.2],
            ],
            loads_kg: vec![0.0, 2.0, 4.5, 7.0, 1.0, 3.0, 5.5, 6.0],
            base_freq_hz: vec![0.1, 0.2, 0.1, 0.2, 0.2, 0.1, 0.2, 0.1],
            accel_limits: IRB1200_ACCEL_LIMITS.to_vec(),
            periods: if quick { 2 } else { 3 },
            standby_rest_s: 0.0,
            criterion: SetCriterion::DOptimal,
            rounds: 2,
            max_evals: if quick { 300 } else { 800 },
            seed: DESIGN_SEED,
            fit: FitOptions::default(),
        };
        if quick {
            o.centres.truncate(4);
            o.loads_kg.truncate(4);
            o.base_freq_hz.truncate(4);
        }
        o
    }

    /// The same experiment for any arm, planned as `excite --set` plans it in the default
    /// cell ([`arm::plan`]): eight excitations (`quick`: four of two stretches) about centres
    /// spread over the joint space, alternating 0.1 and 0.2 Hz, carrying the IRB 1200 set's
    /// loads scaled to `rated_payload_kg` (0 to the rated payload), with the robot's default
    /// acceleration limits ([`default_accel_limits`]).
    ///
    /// Errors ([`Error::InvalidInput`]): a rated payload that is not finite and positive, or
    /// those of [`arm::plan`] (a joint space in which no centre can be placed).
    pub fn for_arm(robot: &Robot, rated_payload_kg: f64, quick: bool) -> Result<IdSetOptions> {
        if !(rated_payload_kg.is_finite() && rated_payload_kg > 0.0) {
            return Err(Error::InvalidInput(format!(
                "rated payload {rated_payload_kg} kg: give a finite payload above 0 kg"
            )));
        }
        let count = if quick { 4 } else { LOAD_FRACTIONS.len() };
        let base = IdSetOptions::irb1200(quick);
        let loads_kg: Vec<f64> = LOAD_FRACTIONS[..count]
            .iter()
            .map(|f| f * rated_payload_kg)
            .collect();
        let plan = arm::plan(
            robot,
            &Cell::default(),
            &ArmSet {
                payloads: load_payloads(&loads_kg)?,
                duration_s: base.periods as f64 * 10.0,
                base_freq_hz: ARM_BASE_FREQ_HZ,
                harmonics: HARMONICS,
                accel_limits: default_accel_limits(robot),
                rounds: base.rounds,
                max_evals: base.max_evals,
                seed: base.seed,
            },
        )?;
        let members = plan.options.members;
        Ok(IdSetOptions {
            centres: members.iter().map(|m| m.centre.clone()).collect(),
            base_freq_hz: members.iter().map(|m| m.base_freq_hz).collect(),
            loads_kg,
            accel_limits: default_accel_limits(robot),
            ..base
        })
    }
}

/// What the identification set produced.
pub struct IdSet {
    /// The commanded runs: the excitations, then the standby rest when there is one (a
    /// series of zero amplitude).
    pub trajectories: Vec<Fourier>,
    /// Condition number of each excitation's own regressor (base parameters, copper and
    /// standby columns at the logging rate, columns scaled to unit norm) after the design.
    pub conds: Vec<f64>,
    /// Condition number of the stacked regressor of all excitations after the design.
    pub set_cond: f64,
    /// Wall time of the design, s.
    pub design_s: f64,
    /// Criterion of the design.
    pub criterion: SetCriterion,
    /// Block-coordinate rounds of the design.
    pub rounds: usize,
    /// Weighting of the samples in the fit.
    pub weighting: Weighting,
    /// The standby pose the rest held, rad, and the URDF's gravity torques there, N m.
    pub standby: Option<(Vec<f64>, Vec<f64>)>,
    /// The known payload timeline of each run.
    pub payloads: Vec<Vec<PayloadEvent>>,
    /// The twin's dataset of each run (truth included: for scoring and files only).
    pub datasets: Vec<Dataset>,
    /// The logs identification saw.
    pub logs: Vec<Log>,
    /// Cross-validation scores, the chosen estimator and its model.
    pub selection: Selection,
}

/// Design, run and identify the set on `rig`.
pub fn run(rig: &Rig, opts: &IdSetOptions, progress: &dyn Progress) -> Result<IdSet> {
    progress.stage("identification set: joint design", 1);
    let design = design(rig.robot, opts)?;
    progress.advance();
    run_designed(rig, opts, &design, progress)
}

/// Run and identify the set of `design` (from [`design`] with the same `robot` and `opts`)
/// on `rig`: robots that differ only in what the files do not show (a family's) share one
/// design, as a user's identification set does.
pub fn run_designed(
    rig: &Rig,
    opts: &IdSetOptions,
    design: &SetDesign,
    progress: &dyn Progress,
) -> Result<IdSet> {
    let robot = rig.robot;
    check_options(opts)?;
    let payloads = load_payloads(&opts.loads_kg)?;
    if design.trajectories.len() != payloads.len() {
        return Err(Error::InvalidInput(format!(
            "a design of {} excitations for a set of {}",
            design.trajectories.len(),
            payloads.len()
        )));
    }
    let (standby, rest) = standby_rest(rig, opts)?;
    let members = opts.centres.len();
    let plans: Vec<(Fourier, Option<Payload>)> = design
        .trajectories
        .iter()
        .cloned()
        .zip(payloads)
        .chain(rest.map(|t| (t, None)))
        .collect();
    let runs = run_twin(rig, opts, plans, members, progress)?;
    let logs = runs
        .iter()
        .enumerate()
        .map(|(k, r)| r.dataset.log(&format!("identification run {}", k + 1)))
        .collect::<Result<Vec<_>>>()?;
    progress.stage("identification: cross-validated fit", 1);
    let selection = identify_logs(robot, &logs, &routes(opts, runs.len()), &opts.fit)?;
    progress.advance();
    let mut set = IdSet {
        trajectories: Vec::new(),
        conds: design.member_conds.clone(),
        set_cond: design.cond_final,
        design_s: design.wall_s,
        criterion: opts.criterion,
        rounds: opts.rounds,
        weighting: opts.fit.weighting,
        standby,
        payloads: Vec::new(),
        datasets: Vec::new(),
        logs,
        selection,
    };
    for r in runs {
        set.trajectories.push(r.trajectory);
        set.payloads.push(r.events);
        set.datasets.push(r.dataset);
    }
    Ok(set)
}

/// Refuse options of inconsistent lengths and a bad standby rest.
fn check_options(opts: &IdSetOptions) -> Result<()> {
    if opts.centres.is_empty()
        || opts.centres.len() != opts.loads_kg.len()
        || opts.centres.len() != opts.base_freq_hz.len()
    {
        return Err(Error::InvalidInput(format!(
            "{} centres, {} loads and {} base frequencies: one of each per excitation",
            opts.centres.len(),
            opts.loads_kg.len(),
            opts.base_freq_hz.len()
        )));
    }
    if !(opts.standby_rest_s.is_finite() && opts.standby_rest_s >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "standby rest of {} s: give a length >= 0 s (0: none)",
            opts.standby_rest_s
        )));
    }
    Ok(())
}

/// The known load of every excitation (None: nothing on the flange).
fn load_payloads(loads_kg: &[f64]) -> Result<Vec<Option<Payload>>> {
    loads_kg
        .iter()
        .map(|&load| {
            (load > 0.0)
                .then(|| Payload::cube(&format!("load {load} kg"), load, LOAD_COM_M.into()))
                .transpose()
        })
        .collect::<Result<Vec<_>>>()
}

/// The joint design of the set's excitations on the nominal `robot` (the user's files), at
/// [`DESIGN_RATE_HZ`] whatever the logs' rate, as `excite --set` designs it.
pub fn design(robot: &Robot, opts: &IdSetOptions) -> Result<SetDesign> {
    check_options(opts)?;
    let payloads = load_payloads(&opts.loads_kg)?;
    design_set(
        robot,
        &SetOptions {
            members: opts
                .centres
                .iter()
                .zip(&opts.base_freq_hz)
                .zip(&payloads)
                .map(|((centre, &f), payload)| Member {
                    centre: centre.clone(),
                    base_freq_hz: f,
                    // Each excitation lasts `periods` x 10 s.
                    periods: ((opts.periods as f64) * 10.0 * f).round().max(1.0) as usize,
                    payload: payload.clone(),
                })
                .collect(),
            harmonics: HARMONICS,
            sample_rate_hz: DESIGN_RATE_HZ,
            min_speed: opts.fit.min_speed,
            criterion: opts.criterion,
            accel_limits: opts.accel_limits.clone(),
            position_margin: WORKSPACE.margin_rad,
            limit_fraction: 0.9,
            floor_z: WORKSPACE.floor_z_m,
            base_radius: WORKSPACE.base_radius_m,
            rounds: opts.rounds,
            max_evals: opts.max_evals,
            seed: opts.seed,
        },
    )
}

/// The standby pose and the URDF's gravity torques there, as [`standby_pose`] gives them.
type Standby = (Vec<f64>, Vec<f64>);

/// The standby rest, if asked: the pose (with its gravity torques) and a zero-amplitude
/// series, the robot held still at the pose.
fn standby_rest(rig: &Rig, opts: &IdSetOptions) -> Result<(Option<Standby>, Option<Fourier>)> {
    let robot = rig.robot;
    let standby = (opts.standby_rest_s > 0.0)
        .then(|| {
            let w = &WORKSPACE;
            standby_pose(robot, w.margin_rad, w.floor_z_m, w.base_radius_m)
        })
        .transpose()?;
    let rest = standby
        .as_ref()
        .map(|(pose, _)| {
            let n = pose.len();
            Fourier::new(
                1.0 / opts.standby_rest_s,
                pose.clone(),
                vec![vec![0.0]; n],
                vec![vec![0.0]; n],
                1.0,
            )
        })
        .transpose()?;
    Ok((standby, rest))
}

/// One twin run of the set: the trajectory, the payload timeline and the logged dataset.
struct TwinRun {
    trajectory: Fourier,
    events: Vec<PayloadEvent>,
    dataset: Dataset,
}

/// Run every plan on the twin in parallel; the first `members` are the excitations, any
/// further one the standby rest.
fn run_twin(
    rig: &Rig,
    opts: &IdSetOptions,
    plans: Vec<(Fourier, Option<Payload>)>,
    members: usize,
    progress: &dyn Progress,
) -> Result<Vec<TwinRun>> {
    progress.stage("identification set: twin runs", plans.len());
    plans
        .into_par_iter()
        .enumerate()
        .map(|(k, (traj, payload))| {
            let load = opts.loads_kg.get(k).copied().unwrap_or(0.0);
            let events = payload
                .map(|p| {
                    vec![PayloadEvent {
                        t_s: 0.0,
                        payload: Some(p),
                    }]
                })
                .unwrap_or_default();
            let kind = if k < members {
                "fourier excitation"
            } else {
                "standby rest"
            };
            let description = serde_json::json!({
                "kind": kind,
                "experiment": "identification set",
                "index": k + 1,
                "load_kg": load,
            });
            let ds = rig.run(&traj, &events, 100 + k as u64, description)?;
            progress.advance();
            Ok(TwinRun {
                trajectory: traj,
                events,
                dataset: ds,
            })
        })
        .collect()
}

/// The route each of the `runs` logs is read along: the excitations along their Fourier
/// series; the rest along the spline route, which holds it exactly still.
fn routes(opts: &IdSetOptions, runs: usize) -> Vec<Route> {
    (0..runs)
        .map(|k| match opts.base_freq_hz.get(k) {
            Some(&f) => Route::Fourier {
                base_freq_hz: f,
                harmonics: HARMONICS,
            },
            None => Route::Spline,
        })
        .collect()
}
