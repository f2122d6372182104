//! `powertwin reproduce`: the paper's experiments end to end on one rig: the six steps
//! (Table 3), the estimators compared on their data (Table 2, in-sample), then the
//! identification a user would run (an identification set over the workspace and payload
//! range, the estimator chosen by cross-validation) and its model judged on held-out motions
//! (the benchmark that leads the report), the tool and load cases (Table 4) and the
//! pick-and-place sweep (Figure 14) predicted with that model.

use std::time::Instant;

use serde::Serialize;

use crate::dataset::Dataset;
use crate::error::{Error, Result};
use crate::identification::data::Route;
use crate::identification::model::{DATASHEET_EFFICIENCY, PowerModel};
use crate::model::builtin;
use crate::model::payload::Payload;
use crate::trajectory::limits::IRB1200_ACCEL_LIMITS;
use crate::trajectory::task::Scenario;
use crate::validation::estimators::{EstimatorResult, compare};
use crate::validation::family::{self, Family, FamilyOptions};
use crate::validation::heldout::{self, Heldout, HeldoutOptions};
use crate::validation::idset::{self, IdSet, IdSetOptions};
use crate::validation::payloads::{self, Cases};
use crate::validation::rig::{Progress, Rig, Together};
use crate::validation::score::{self, ParamRow};
use crate::validation::steps::{self, Steps, StepsOptions};
use crate::validation::sweep::{self, Sweep};

/// What to run.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The six steps.
    pub steps: StepsOptions,
    /// Table 4 cases: name and payload (`None`: nothing on the flange).
    pub cases: Vec<(String, Option<Payload>)>,
    /// The task and its sweep grid.
    pub scenario: Scenario,
    /// The identification set.
    pub idset: IdSetOptions,
    /// The held-out benchmark.
    pub heldout: HeldoutOptions,
    /// The held-out benchmark across a family of robots we did not build.
    pub family: FamilyOptions,
}

impl Plan {
    /// The paper's experiments on the IRB 1200 with the built-in scenario. Rest pose of the
    /// steps (0, 0.2, 0.2, 0, 0.8, 0) rad; two 10 s periods per step (one leaves the
    /// all-at-once estimates noticeably noisier, see docs/experiments.md#steps-periods); designs with 2 CMA-ES starts of 1000 evaluations. `quick`: one
    /// period, one start of 300 evaluations and a 3 x 2 sweep (0.1, 0.5, 1 m/s; 0 and 4 kg).
    pub fn irb1200(quick: bool) -> Result<Plan> {
        let tool = builtin::payload("tool")?;
        let mut cases = vec![
            ("no tool".to_string(), None),
            ("tool".into(), Some(tool.clone())),
        ];
        for load in ["load_1kg", "load_2kg", "load_4kg"] {
            let load = builtin::payload(load)?;
            cases.push((
                format!("tool + {} kg", load.inertia.mass),
                Some(tool.combined(&load)),
            ));
        }
        let mut scenario = Scenario::builtin()?;
        if quick {
            scenario.sweep.speeds_m_s = vec![0.1, 0.5, 1.0];
            scenario.sweep.loads_kg = vec![0.0, 4.0];
        }
        Ok(Plan {
            steps: StepsOptions {
                rest_pose: vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0],
                accel_limits: IRB1200_ACCEL_LIMITS.to_vec(),
                periods: if quick { 1 } else { 2 },
                starts: if quick { 1 } else { 2 },
                max_evals: if quick { 300 } else { 1000 },
                seed: 1,
            },
            cases,
            scenario,
            idset: IdSetOptions::irb1200(quick),
            heldout: HeldoutOptions::irb1200(if quick { 12 } else { 30 }),
            family: FamilyOptions::irb1200(quick),
        })
    }
}

/// Wall time of one stage.
#[derive(Debug, Clone, Serialize)]
pub struct StageTime {
    /// Stage name.
    pub stage: String,
    /// Wall time, s.
    pub wall_s: f64,
}

/// Everything `reproduce` found.
pub struct Outcome {
    /// Table 3.
    pub steps: Steps,
    /// The estimators on the steps' data (Table 2 per estimator; in-sample).
    pub estimators: Vec<EstimatorResult>,
    /// The identification set and its cross-validated fit.
    pub idset: IdSet,
    /// The model identified from the identification set (used for the held-out benchmark,
    /// Table 4's known payloads and the sweep).
    pub model: PowerModel,
    /// `model`'s base parameters against the twin's truth (truth only scores), with the
    /// relative standard deviations of its estimate.
    pub parameters: Vec<ParamRow>,
    /// The held-out benchmark of `model`.
    pub heldout: Heldout,
    /// The twin's dataset of each held-out motion.
    pub heldout_datasets: Vec<Dataset>,
    /// Table 4.
    pub cases: Cases,
    /// Figure 14.
    pub sweep: Sweep,
    /// The held-out benchmark across the family.
    pub family: Family,
    /// Wall time per stage.
    pub timings: Vec<StageTime>,
}

impl Outcome {
    /// Name of the model used downstream: `cv:` and the estimator cross-validation chose.
    pub fn model_name(&self) -> String {
        format!("cv:{}", self.idset.selection.chosen.name())
    }
}

/// Run `plan` on `rig`. Work that does not depend on each other runs side by side on the
/// thread pool: the family beside everything else; the six steps and the estimators beside
/// the identification set and the held-out benchmark, then Table 4 beside the sweep. Each
/// stage's wall time is its own (side-by-side stages overlap).
pub fn run(rig: &Rig, plan: &Plan, progress: &dyn Progress) -> Result<Outcome> {
    let mut timings = Vec::new();
    let mut clock = Instant::now();
    let planned = sweep::plan(rig.robot, &plan.scenario)?;
    timings.push(lap(&mut clock, "task planned for every sweep cell"));
    progress.stage(
        "Tables 3, 2 and 4, identification set, held-out benchmark, Figure 14 and the family",
        0,
    );
    let together = Together(progress);
    // The family needs nothing of the rest: beside it from the start.
    let (single, family) = rayon::join(
        || single_truth(rig, plan, planned, &together),
        || -> Result<_> {
            let mut clock = Instant::now();
            let family = family::run(rig, &plan.family, &together)?;
            Ok((
                family,
                lap(
                    &mut clock,
                    "family of truths: robots drawn, identified and judged (side by side)",
                ),
            ))
        },
    );
    let single = single?;
    let (family, family_time) = family?;
    timings.extend(single.timings);
    timings.push(family_time);
    Ok(Outcome {
        steps: single.steps,
        estimators: single.estimators,
        idset: single.idset,
        model: single.model,
        parameters: single.parameters,
        heldout: single.heldout,
        heldout_datasets: single.heldout_datasets,
        cases: single.cases,
        sweep: single.sweep,
        family,
        timings,
    })
}

/// What the stages on the rig's own truth found ([`Outcome`] without the family).
struct Single {
    steps: Steps,
    estimators: Vec<EstimatorResult>,
    idset: IdSet,
    model: PowerModel,
    parameters: Vec<ParamRow>,
    heldout: Heldout,
    heldout_datasets: Vec<Dataset>,
    cases: Cases,
    sweep: Sweep,
    timings: Vec<StageTime>,
}

/// Every stage on the rig's own truth: the six steps and the estimators beside the
/// identification set and the held-out benchmark, then Table 4 beside the sweep.
fn single_truth(
    rig: &Rig,
    plan: &Plan,
    planned: Vec<sweep::Planned>,
    together: &Together,
) -> Result<Single> {
    let (paper, identified) = rayon::join(
        || -> Result<_> {
            let mut clock = Instant::now();
            let steps = steps::run(rig, &plan.steps, together)?;
            let t1 = lap(
                &mut clock,
                "excitation, twin runs and six-step identification (Table 3; side by side)",
            );
            let estimators = compare(rig, &steps)?;
            let t2 = lap(
                &mut clock,
                "estimators compared on the steps' data (Table 2, in-sample; side by side)",
            );
            Ok((steps, estimators, [t1, t2]))
        },
        || -> Result<_> {
            let mut clock = Instant::now();
            // The held-out motions' twin runs need no model: beside the identification.
            let (idset, runs) = rayon::join(
                || idset::run(rig, &plan.idset, together),
                || heldout::simulate(rig, &plan.heldout, together),
            );
            let (idset, runs) = (idset?, runs?);
            let model = idset.selection.fit.model.clone();
            let parameters = score::table(
                rig.true_robot(),
                rig.true_drive(),
                &model,
                &[&idset.selection.fit.free_estimate()],
            )?;
            let t1 = lap(
                &mut clock,
                "identification set (joint design, twin runs, cross-validated fit) and the held-out motions' twin runs (side by side)",
            );
            let (heldout, heldout_datasets) =
                heldout::evaluate(rig, &model, &plan.heldout, runs, together)?;
            let t2 = lap(
                &mut clock,
                "held-out benchmark's predictions (side by side)",
            );
            Ok((
                idset,
                model,
                parameters,
                heldout,
                heldout_datasets,
                [t1, t2],
            ))
        },
    );
    let (steps, estimators, paper_times) = paper?;
    let (idset, model, parameters, heldout, heldout_datasets, identified_times) = identified?;
    let mut timings = Vec::new();
    timings.extend(paper_times);
    timings.extend(identified_times);
    let (cases, sweep) = tables_and_sweep(rig, plan, &steps, &model, planned, together);
    let (cases, cases_time) = cases?;
    let (sweep, sweep_time) = sweep?;
    timings.extend([cases_time, sweep_time]);
    Ok(Single {
        steps,
        estimators,
        idset,
        model,
        parameters,
        heldout,
        heldout_datasets,
        cases,
        sweep,
        timings,
    })
}

/// The wall time since `clock` as stage `stage`; restarts the clock.
fn lap(clock: &mut Instant, stage: &str) -> StageTime {
    let t = StageTime {
        stage: stage.to_string(),
        wall_s: clock.elapsed().as_secs_f64(),
    };
    *clock = Instant::now();
    t
}

/// A stage's result with its wall time.
type Timed<T> = Result<(T, StageTime)>;

/// Table 4 beside the sweep.
fn tables_and_sweep(
    rig: &Rig,
    plan: &Plan,
    steps: &Steps,
    model: &PowerModel,
    planned: Vec<sweep::Planned>,
    together: &Together,
) -> (Timed<Cases>, Timed<Sweep>) {
    let efficiency = DATASHEET_EFFICIENCY;
    let Some(last) = steps.trajectories.last() else {
        let none = || Error::InvalidInput("no step ran".into());
        return (Err(none()), Err(none()));
    };
    rayon::join(
        || -> Result<_> {
            let mut clock = Instant::now();
            let cases = payloads::run(
                rig,
                &steps.model,
                model,
                last,
                Route::Fourier {
                    base_freq_hz: 0.1,
                    harmonics: 5,
                },
                &plan.cases,
                efficiency,
                together,
            )?;
            Ok((
                cases,
                lap(&mut clock, "tool and load cases (Table 4; side by side)"),
            ))
        },
        || -> Result<_> {
            let mut clock = Instant::now();
            let sweep = sweep::run(
                rig,
                &plan.scenario,
                planned,
                Some((model, efficiency)),
                together,
            )?;
            Ok((
                sweep,
                lap(&mut clock, "pick-and-place sweep (Figure 14; side by side)"),
            ))
        },
    )
}
