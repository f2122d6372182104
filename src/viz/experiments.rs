//! Whole experiments: one twin run with a model's prediction, a speed x load sweep, and all
//! that `powertwin reproduce` runs, each run under its own prefix and logged in parallel.

use nalgebra::Isometry3;
use rayon::prelude::*;

use super::recording::decimated_rows;
use super::{Tab, Viz, path_part};
use crate::dataset::Dataset;
use crate::error::{Error, Result};
use crate::identification::model::PowerModel;
use crate::model::Robot;
use crate::model::payload::PayloadEvent;
use crate::trajectory::Trajectory;
use crate::trajectory::task::TaskRun;
use crate::validation::reproduce::{Outcome, Plan};
use crate::validation::sweep::{Cell, Predictor, Sweep};

/// What predicts a run's power: an identified model, the drives' nominal efficiency (to add
/// known payloads to an efficiency-scaled model) and the commanded motion with its payload
/// timeline (see [`PowerModel::joint_powers_with_payloads`]).
#[derive(Clone, Copy)]
pub struct Prediction<'a> {
    /// The identified model.
    pub model: &'a PowerModel,
    /// Drives' nominal efficiency, in (0, 1].
    pub efficiency: f64,
    /// The commanded joint trajectory of the run.
    pub trajectory: &'a dyn Trajectory,
    /// What the flange carries from when (none before the first event).
    pub events: &'a [PayloadEvent],
}

/// One run of an experiment to log.
struct Job<'a> {
    prefix: String,
    dataset: &'a Dataset,
    prediction: Option<Prediction<'a>>,
    task: Option<&'a TaskRun>,
}

impl Viz {
    /// Log a twin run's dataset under `prefix`: the ground truth at `display_hz`
    /// ([`Viz::log_recording`]), the measurements ([`Viz::log_measured`]) and, with
    /// `prediction`, the model's per-motor and total power and energy at the displayed times
    /// ([`Viz::log_prediction`]).
    ///
    /// Errors: those of the logging calls, and of the prediction (a model of another robot,
    /// an efficiency outside (0, 1], a non-physical payload).
    pub fn log_run(
        &self,
        robot: &Robot,
        dataset: &Dataset,
        prediction: Option<Prediction>,
        prefix: &str,
        display_hz: f64,
    ) -> Result<()> {
        let truth = &dataset.truth;
        self.log_recording(robot, truth, prefix, display_hz)?;
        self.log_measured(&dataset.measured, prefix)?;
        if let Some(p) = prediction {
            let rows = decimated_rows(truth.len(), truth.dt, display_hz)?;
            let t: Vec<f64> = rows.iter().map(|&k| truth.t[k]).collect();
            let joints = p.model.joint_powers_with_payloads(
                robot,
                p.trajectory,
                p.events,
                p.efficiency,
                &t,
            )?;
            self.log_prediction(&t, &joints, prefix)?;
        }
        Ok(())
    }

    /// Log a speed x load sweep: every cell's run under `{root}/{v}mps_{L}kg` (e.g. `0p5mps_4kg`)
    /// with its plan ([`Viz::log_task`]; `tcp`: the TCP in the flange frame, m) and, with
    /// `predictor`, the model's power from the plan and the known payloads; and the energies and
    /// table of the cells under `root` ([`Viz::log_sweep_cells`]). First sends a layout that shows
    /// the [representative](Sweep::representative) cell's run and the energy plot.
    ///
    /// Errors: those of [`Viz::log_run`] and [`Viz::log_task`]; [`Error::InvalidInput`] when
    /// the sweep has no cells or its cells, datasets and plans differ in number.
    pub fn log_sweep(
        &self,
        robot: &Robot,
        sweep: &Sweep,
        tcp: &Isometry3<f64>,
        predictor: Option<Predictor>,
        root: &str,
        display_hz: f64,
    ) -> Result<()> {
        let (run, energies) = sweep_tabs(robot, sweep, root);
        let tabs: Vec<Tab> = run.into_iter().chain([energies]).collect();
        self.send_blueprint(&tabs)?;
        self.log_sweep_data(robot, sweep, tcp, predictor, root, display_hz)
    }

    /// Log what `powertwin reproduce` found by running `plan`: each identification step's run under
    /// `table3/step{k}`, each tool and load case under `table4/{case}` and each sweep cell under
    /// `sweep/{v}mps_{L}kg` (e.g. `sweep/0p5mps_4kg`), all with the power of the cross-validated
    /// model (known payloads added with the drives' nominal `efficiency`); every estimator's
    /// parameter errors under `identification/{method}` (Table 2); and the sweep's energies under
    /// `sweep` (Figure 14). First sends a layout with tabs for the representative sweep cell, the
    /// last identification step, the parameter errors and energy against speed.
    ///
    /// Errors: those of [`Viz::log_sweep`]; [`Error::InvalidInput`] when the outcome does not
    /// match the plan (numbers of steps, cases, estimators).
    pub fn log_reproduce(
        &self,
        robot: &Robot,
        plan: &Plan,
        outcome: &Outcome,
        efficiency: f64,
        display_hz: f64,
    ) -> Result<()> {
        let last = last_step_trajectory(plan, outcome)?;
        let roots: Vec<String> = outcome
            .estimators
            .iter()
            .map(|e| format!("identification/{}", path_part(&e.method)))
            .collect();
        self.send_blueprint(&reproduce_tabs(robot, outcome, &roots))?;

        let case_events = case_events(plan);
        let jobs = reproduce_jobs(plan, outcome, efficiency, last, &case_events);
        self.log_jobs(robot, &jobs, &plan.scenario.tcp(), display_hz)?;
        for (root, e) in roots.iter().zip(&outcome.estimators) {
            self.log_parameters(root, &e.parameters)?;
        }
        self.log_sweep_data(
            robot,
            &outcome.sweep,
            &plan.scenario.tcp(),
            Some((&outcome.model, efficiency)),
            "sweep",
            display_hz,
        )
    }

    /// The runs and energies of a sweep ([`Viz::log_sweep`] without the layout).
    fn log_sweep_data(
        &self,
        robot: &Robot,
        sweep: &Sweep,
        tcp: &Isometry3<f64>,
        predictor: Option<Predictor>,
        root: &str,
        display_hz: f64,
    ) -> Result<()> {
        let jobs = sweep_jobs(sweep, predictor, root)?;
        self.log_jobs(robot, &jobs, tcp, display_hz)?;
        self.log_sweep_cells(root, &sweep.cells)
    }

    /// Log `jobs` in parallel; a task's plan uses the TCP `tcp` (flange frame, m).
    fn log_jobs(
        &self,
        robot: &Robot,
        jobs: &[Job],
        tcp: &Isometry3<f64>,
        display_hz: f64,
    ) -> Result<()> {
        jobs.par_iter().try_for_each(|job| {
            self.log_run(robot, job.dataset, job.prediction, &job.prefix, display_hz)?;
            if let Some(task) = job.task {
                self.log_task(robot, task, tcp, &job.prefix, display_hz)?;
            }
            Ok(())
        })
    }
}

/// Check that `outcome` matches `plan` (one dataset per step trajectory, one per tool and
/// load case) and return the last identification step's trajectory, which the cases run.
fn last_step_trajectory<'a>(plan: &Plan, outcome: &'a Outcome) -> Result<&'a dyn Trajectory> {
    let mismatch = |what: &str| Error::InvalidInput(format!("the outcome's {what} do not match"));
    let steps = &outcome.steps;
    if steps.datasets.len() != steps.trajectories.len() {
        return Err(mismatch("step datasets and trajectories"));
    }
    if outcome.cases.datasets.len() != plan.cases.len() {
        return Err(mismatch("tool and load cases"));
    }
    let last = steps
        .trajectories
        .last()
        .ok_or_else(|| mismatch("identification steps"))?;
    Ok(last)
}

/// The layout of `reproduce`'s recording: the representative sweep cell, the last
/// identification step, the parameter errors under `roots` and energy against speed.
fn reproduce_tabs(robot: &Robot, outcome: &Outcome, roots: &[String]) -> Vec<Tab> {
    let n_steps = outcome.steps.datasets.len();
    let (run, energies) = sweep_tabs(robot, &outcome.sweep, "sweep");
    let mut tabs: Vec<Tab> = run.into_iter().collect();
    tabs.extend([
        Tab::Run {
            title: format!("identification step {n_steps}"),
            prefix: format!("table3/step{n_steps}"),
            joints: robot.dof(),
        },
        Tab::Parameters {
            title: "parameter errors (Table 2)".into(),
            roots: roots.to_vec(),
        },
        energies,
    ]);
    tabs
}

/// The payload timeline of each tool and load case of `plan`: its payload from `t = 0` s
/// (none for an empty flange).
fn case_events(plan: &Plan) -> Vec<Vec<PayloadEvent>> {
    plan.cases
        .iter()
        .map(|(_, payload)| {
            payload
                .iter()
                .map(|p| PayloadEvent {
                    t_s: 0.0,
                    payload: Some(p.clone()),
                })
                .collect()
        })
        .collect()
}

/// One job per identification step, under `table3/step{k}`, then one per tool and load case,
/// under `table4/{case}` (the `last` step's trajectory with the case's `case_events`), all
/// predicted by the outcome's model with the drives' nominal `efficiency`.
fn reproduce_jobs<'a>(
    plan: &Plan,
    outcome: &'a Outcome,
    efficiency: f64,
    last: &'a dyn Trajectory,
    case_events: &'a [Vec<PayloadEvent>],
) -> Vec<Job<'a>> {
    let steps = &outcome.steps;
    let mut jobs: Vec<Job> = steps
        .datasets
        .iter()
        .zip(&steps.trajectories)
        .enumerate()
        .map(|(k, (dataset, traj))| Job {
            prefix: format!("table3/step{}", k + 1),
            dataset,
            prediction: Some(Prediction {
                model: &outcome.model,
                efficiency,
                trajectory: traj,
                events: &[],
            }),
            task: None,
        })
        .collect();
    for (((name, _), events), dataset) in plan
        .cases
        .iter()
        .zip(case_events)
        .zip(&outcome.cases.datasets)
    {
        jobs.push(Job {
            prefix: format!("table4/{}", path_part(name)),
            dataset,
            prediction: Some(Prediction {
                model: &outcome.model,
                efficiency,
                trajectory: last,
                events,
            }),
            task: None,
        });
    }
    jobs
}

/// One job per sweep cell, under `{root}/{v}mps_{L}kg` (e.g. `0p5mps_4kg`).
fn sweep_jobs<'a>(
    sweep: &'a Sweep,
    predictor: Option<Predictor<'a>>,
    root: &str,
) -> Result<Vec<Job<'a>>> {
    let n = sweep.cells.len();
    if n == 0 || sweep.datasets.len() != n || sweep.plans.len() != n {
        return Err(Error::InvalidInput(format!(
            "a sweep to log needs cells with one dataset and plan each ({n} cells, {} datasets, \
             {} plans)",
            sweep.datasets.len(),
            sweep.plans.len()
        )));
    }
    Ok(sweep
        .cells
        .iter()
        .zip(&sweep.datasets)
        .zip(&sweep.plans)
        .map(|((cell, dataset), plan)| Job {
            prefix: cell_prefix(root, cell),
            dataset,
            prediction: predictor.map(|(model, efficiency)| Prediction {
                model,
                efficiency,
                trajectory: &plan.motion.trajectory,
                events: &plan.events,
            }),
            task: Some(plan),
        })
        .collect())
}

/// Entity prefix of a sweep cell's run: `{root}/{v}mps_{L}kg` (e.g. `0p5mps_4kg`).
fn cell_prefix(root: &str, cell: &Cell) -> String {
    let (v, load) = (cell.speed_m_s.to_string(), cell.load_kg.to_string());
    format!("{root}/{}mps_{}kg", path_part(&v), path_part(&load))
}

/// The tabs of a sweep logged under `root`: the representative cell's run (none without
/// cells) and the energies against speed.
fn sweep_tabs(robot: &Robot, sweep: &Sweep, root: &str) -> (Option<Tab>, Tab) {
    let run = sweep.representative().map(|k| {
        let c = &sweep.cells[k];
        Tab::Run {
            title: format!("task at {} m/s, load {} kg", c.speed_m_s, c.load_kg),
            prefix: cell_prefix(root, c),
            joints: robot.dof(),
        }
    });
    let energies = Tab::Sweep {
        title: "energy against speed".into(),
        root: root.into(),
    };
    (run, energies)
}
