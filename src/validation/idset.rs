//! The identification experiment a user would run on a robot: several excitations of every
//! joint about different centres of the workspace, each carrying a different known payload
//! (from none to the rated payload), run on the twin; only their logs go on to
//! identification ([`crate::identification::fit::identify_logs`]), which chooses its
//! estimator by cross-validation.

use rayon::prelude::*;

use crate::dataset::Dataset;
use crate::error::{Error, Result};
use crate::identification::data::Route;
use crate::identification::excitation::{ExcitationOptions, design};
use crate::identification::fit::{FitOptions, Selection, identify_logs};
use crate::measurement::Log;
use crate::model::payload::{Payload, PayloadEvent};
use crate::trajectory::fourier::Fourier;
use crate::trajectory::limits::IRB1200_ACCEL_LIMITS;
use crate::validation::rig::{Progress, Rig};

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
    /// CMA-ES starts per design.
    pub starts: usize,
    /// Objective evaluations per start.
    pub max_evals: usize,
    /// Seed of the designs (excitation `k` uses `seed + k`).
    pub seed: u64,
    /// Identification settings.
    pub fit: FitOptions,
}

impl IdSetOptions {
    /// Four excitations of the IRB 1200 about centres spread over the workspace, with 0, 2,
    /// 4.5 and 7 kg (the rated payload) at the flange; two 10 s stretches each (`quick`:
    /// smaller designs; one stretch made the quick sweep's worst cell 2.6 % instead of 0.7 %).
    pub fn irb1200(quick: bool) -> IdSetOptions {
        IdSetOptions {
            centres: vec![
                vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0],
                vec![1.0, 0.5, -0.2, 1.0, 1.2, 0.5],
                vec![-1.0, -0.2, 0.4, -1.0, 0.6, -0.5],
                vec![0.5, 0.7, 0.0, -0.5, 1.4, 1.0],
            ],
            loads_kg: vec![0.0, 2.0, 4.5, 7.0],
            base_freq_hz: vec![0.1, 0.2, 0.1, 0.2],
            accel_limits: IRB1200_ACCEL_LIMITS.to_vec(),
            periods: 2,
            starts: 1,
            max_evals: if quick { 300 } else { 800 },
            seed: 101,
            fit: FitOptions::default(),
        }
    }
}

/// What the identification set produced.
pub struct IdSet {
    /// The commanded excitations.
    pub trajectories: Vec<Fourier>,
    /// Condition number of each excitation's total-power regressor after its design.
    pub conds: Vec<f64>,
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
    let robot = rig.robot;
    let n = robot.dof();
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
    progress.stage(
        "identification set: design and twin runs",
        opts.centres.len(),
    );
    let runs: Vec<(Fourier, f64, Vec<PayloadEvent>, Dataset)> = opts
        .centres
        .par_iter()
        .zip(&opts.loads_kg)
        .enumerate()
        .map(|(k, (centre, &load))| {
            let mut o = ExcitationOptions::new(
                robot,
                (0..n).collect(),
                centre.clone(),
                opts.accel_limits.clone(),
            );
            let f = opts.base_freq_hz[k];
            o.base_freq_hz = f;
            // Each excitation lasts `periods` x 10 s.
            o.periods = ((opts.periods as f64) * 10.0 * f).round().max(1.0) as usize;
            o.starts = opts.starts;
            o.max_evals = opts.max_evals;
            o.samples = 100;
            o.seed = opts.seed.wrapping_add(k as u64);
            let ex = design(robot, &o)?;
            let events = if load > 0.0 {
                vec![PayloadEvent {
                    t_s: 0.0,
                    payload: Some(Payload::cube(
                        &format!("load {load} kg"),
                        load,
                        LOAD_COM_M.into(),
                    )?),
                }]
            } else {
                Vec::new()
            };
            let description = serde_json::json!({
                "kind": "fourier excitation",
                "experiment": "identification set",
                "index": k + 1,
                "load_kg": load,
            });
            let ds = rig.run(&ex.trajectory, &events, 100 + k as u64, description)?;
            progress.advance();
            Ok((ex.trajectory, ex.cond_final, events, ds))
        })
        .collect::<Result<_>>()?;
    let logs = runs
        .iter()
        .enumerate()
        .map(|(k, r)| r.3.log(&format!("identification run {}", k + 1)))
        .collect::<Result<Vec<_>>>()?;
    progress.stage("identification: cross-validated fit", 1);
    let routes: Vec<Route> = opts
        .base_freq_hz
        .iter()
        .map(|&f| Route::Fourier {
            base_freq_hz: f,
            harmonics: 5,
        })
        .collect();
    let selection = identify_logs(robot, &logs, &routes, &opts.fit)?;
    progress.advance();
    let mut set = IdSet {
        trajectories: Vec::new(),
        conds: Vec::new(),
        payloads: Vec::new(),
        datasets: Vec::new(),
        logs,
        selection,
    };
    for (traj, cond, events, ds) in runs {
        set.trajectories.push(traj);
        set.conds.push(cond);
        set.payloads.push(events);
        set.datasets.push(ds);
    }
    Ok(set)
}
