//! `results.json`: the machine-readable outcome of `powertwin reproduce`. The schema is the
//! serialisation of [`Results`]; every field is documented here and in
//! `docs/design/results-schema.md`. Energies in J, powers in W, speeds in m/s, masses in kg, times
//! in s, errors in % of the simulated value (`100 (predicted - simulated) / simulated`).

use serde::Serialize;

use crate::dataset::meta::Program;
use crate::identification::consistency::Consistency;
use crate::identification::excitation_set::SetCriterion;
use crate::identification::fit::{CvScore, Weighting};
use crate::report::markdown::WELL_EXCITED_REL_STD_PCT;
use crate::trajectory::Trajectory;
use crate::validation::family::Family;
use crate::validation::heldout::Heldout;
use crate::validation::payloads::CaseRow;
use crate::validation::reproduce::{Outcome, StageTime};
use crate::validation::score::ParamRow;
use crate::validation::sweep::{Cell, Optimum};

/// Version of this schema; bumped on any incompatible change.
pub const SCHEMA_VERSION: u32 = 3;

/// The whole file.
#[derive(Debug, Clone, Serialize)]
pub struct Results {
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// The program that wrote it.
    pub program: Program,
    /// How the twin and logger were set up.
    pub settings: Settings,
    /// The held-out benchmark of the identified model (motions, payloads and a seed no
    /// identification saw): per motion under `motions`, summaries per prediction route.
    pub heldout: Heldout,
    /// The identified model used for the held-out benchmark, Table 4's known payloads and
    /// the sweep.
    pub model: ModelInfo,
    /// Table 3: one row per identification step (in-sample: each step predicted on the data
    /// it was fitted on).
    pub table3: Vec<Table3Row>,
    /// Every estimator on the steps' data, with its Table 2 (in-sample energies).
    pub estimators: Vec<Estimator>,
    /// Table 4: one row per tool/load case.
    pub table4: Vec<CaseRow>,
    /// Figure 14.
    pub sweep: SweepResults,
    /// The held-out benchmark across a family of robots we did not build, each identified
    /// from its own identification set: per robot and pooled.
    pub family: Family,
    /// Wall time per stage.
    pub timings: Vec<StageTime>,
    /// Wall time of the whole run, s.
    pub total_wall_s: f64,
}

/// How the model used downstream was identified.
#[derive(Debug, Clone, Serialize)]
pub struct ModelInfo {
    /// `cv:` and the estimator chosen by cross-validation.
    pub name: String,
    /// Cross-validation score of every candidate estimator.
    pub cv: Vec<CvScore>,
    /// Structure error of the chosen model (cross-validated: the posterior root mean square
    /// over what the pieces allow), W.
    #[serde(rename = "structure_sigma_W")]
    pub structure_sigma_w: f64,
    /// Relative structure error of the chosen model's active power (cross-validated, as
    /// `structure_sigma_W`).
    pub structure_rel: f64,
    /// Structure error the pieces of one left-out run share, W (cross-validated, as
    /// `structure_sigma_W`): predictions take it in proportion to the time a motion rests.
    #[serde(rename = "structure_fold_W")]
    pub structure_fold_w: f64,
    /// Least mean active power at which predictions take the relative part, W.
    #[serde(rename = "structure_active_W")]
    pub structure_active_w: f64,
    /// Lowest power the identification logs show a clipped meter at, W: what it reads below
    /// is undetermined and widens the intervals of motions that go there.
    #[serde(rename = "lowest_seen_W")]
    pub lowest_seen_w: Option<f64>,
    /// Floor under a clipped meter's reading, W: the fitted standby less the drive file's.
    #[serde(rename = "bus_floor_W")]
    pub bus_floor_w: Option<f64>,
    /// Weighting of the samples in the fit (`none`, `per-log`, `power-level`).
    pub weighting: Weighting,
    /// Whether the model was made physically consistent in the pipeline.
    pub consistent: bool,
    /// Whether each motor's logged power was fitted besides the arm's.
    pub motor_power: bool,
    /// How the identification set was designed.
    pub design: DesignInfo,
    /// Condition number of each identification excitation's own regressor.
    pub excitation_conds: Vec<f64>,
    /// Duration of each identification excitation, s.
    #[serde(rename = "excitation_duration_s")]
    pub excitation_duration_s: Vec<f64>,
    /// Known load carried in each identification run, kg.
    pub loads_kg: Vec<f64>,
    /// The standby rest among those runs (the last): its pose, rad, and the URDF's gravity
    /// torques there, N m; `null` without one.
    pub standby: Option<StandbyInfo>,
    /// RMS of the final fit's power residual, W.
    #[serde(rename = "residual_rms_W")]
    pub residual_rms_w: f64,
    /// Base parameters whose relative standard deviation is below 1 %.
    pub well_determined: usize,
    /// Largest absolute error against the twin's truth of those, % (`null` when none).
    pub well_determined_max_error_pct: Option<f64>,
    /// Base parameters in all.
    pub parameters: usize,
    /// Identified against true base parameters (truth only scores).
    pub table2: Vec<ParamRow>,
}

/// The standby rest of the identification set.
#[derive(Debug, Clone, Serialize)]
pub struct StandbyInfo {
    /// Pose held, rad.
    pub pose_rad: Vec<f64>,
    /// Gravity torques of the URDF there, N m.
    #[serde(rename = "gravity_torque_Nm")]
    pub gravity_torque_nm: Vec<f64>,
}

/// The design of the identification set.
#[derive(Debug, Clone, Serialize)]
pub struct DesignInfo {
    /// Criterion (`cond` or `d-optimal`) of the stacked regressor.
    pub criterion: SetCriterion,
    /// Block-coordinate rounds.
    pub rounds: usize,
    /// Condition number of the stacked, column-scaled regressor of all excitations.
    pub stacked_cond: f64,
    /// Wall time of the design, s.
    pub wall_s: f64,
}

/// Twin and logger settings.
#[derive(Debug, Clone, Serialize)]
pub struct Settings {
    /// Robot name.
    pub robot: String,
    /// Motor model of the twin (`pmsm` or `efficiency`).
    pub motor_model: String,
    /// Twin fidelity (`exact` or `realistic`).
    pub truth: String,
    /// Logged power signal (`total` or `bus`).
    pub power_signal: String,
    /// Physics step, s.
    pub dt_s: f64,
    /// Rapier substeps per physics step.
    pub substeps: usize,
    /// Logger rate, Hz.
    pub sample_rate_hz: f64,
    /// Whether measurement noise was on.
    pub noise: bool,
    /// Seed of the sensor noise and the controller's nominal-model error (`--noise-seed`).
    pub noise_seed: u64,
    /// Whether this was a `--quick` run.
    pub quick: bool,
}

/// One row of Table 3.
#[derive(Debug, Clone, Serialize)]
pub struct Table3Row {
    /// 1-based step.
    pub step: usize,
    /// Excited joints, 1-based.
    pub joints: Vec<usize>,
    /// Condition number of the excitation regressor before the design.
    pub design_cond_initial: f64,
    /// After the design.
    pub design_cond_final: f64,
    /// Base parameters identified in this step.
    pub identified: Vec<String>,
    /// RMS of the step's power residual, W.
    #[serde(rename = "residual_rms_W")]
    pub residual_rms_w: f64,
    /// Twin's motor energy, J.
    #[serde(rename = "simulated_J")]
    pub simulated_j: f64,
    /// Predicted with the parameters known after the step, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// Error, %.
    pub error_pct: f64,
}

/// One estimator.
#[derive(Debug, Clone, Serialize)]
pub struct Estimator {
    /// `paper-steps`, `total` or `pmsm`.
    pub method: String,
    /// Predicted energy of each step's trajectory with the final model, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: Vec<f64>,
    /// Its error per step, %.
    pub error_pct: Vec<f64>,
    /// Largest absolute error, %.
    pub max_abs_error_pct: f64,
    /// Physical-consistency check.
    pub consistency: Consistency,
    /// Table 2: identified against true base parameters.
    pub table2: Vec<ParamRow>,
}

/// Figure 14.
#[derive(Debug, Clone, Serialize)]
pub struct SweepResults {
    /// Every cell (speed x load).
    pub cells: Vec<Cell>,
    /// Energy-optimal speed per load.
    pub optima: Vec<Optimum>,
    /// Cells on the energy / cycle-time Pareto front of their load (indices into `cells`).
    pub pareto: Vec<usize>,
}

impl Results {
    /// The results of `outcome`; `settings` describe the run, `total_wall_s` its wall time.
    pub fn new(outcome: &Outcome, settings: Settings, total_wall_s: f64) -> Results {
        Results {
            schema_version: SCHEMA_VERSION,
            program: Program::current(),
            settings,
            table3: table3_rows(outcome),
            estimators: estimators(outcome),
            heldout: outcome.heldout.clone(),
            model: ModelInfo::of(outcome),
            table4: outcome.cases.rows.clone(),
            sweep: SweepResults {
                cells: outcome.sweep.cells.clone(),
                optima: outcome.sweep.optima.clone(),
                pareto: outcome.sweep.pareto.clone(),
            },
            family: outcome.family.clone(),
            timings: outcome.timings.clone(),
            total_wall_s,
        }
    }
}

/// Table 3 of `outcome`: one row per identification step.
fn table3_rows(outcome: &Outcome) -> Vec<Table3Row> {
    outcome
        .steps
        .rows
        .iter()
        .map(|r| Table3Row {
            step: r.step,
            joints: r.joints.clone(),
            design_cond_initial: r.design_cond_initial,
            design_cond_final: r.design_cond_final,
            identified: r.estimate.names.clone(),
            residual_rms_w: r.estimate.residual_rms,
            simulated_j: r.simulated_j,
            predicted_j: r.predicted_j,
            error_pct: r.error_pct,
        })
        .collect()
}

/// Every estimator of `outcome` on the steps' data, with its Table 2.
fn estimators(outcome: &Outcome) -> Vec<Estimator> {
    outcome
        .estimators
        .iter()
        .map(|e| Estimator {
            method: e.method.clone(),
            predicted_j: e.predicted_j.clone(),
            error_pct: e.error_pct.clone(),
            max_abs_error_pct: e.max_abs_error_pct,
            consistency: e.consistency.clone(),
            table2: e.parameters.clone(),
        })
        .collect()
}

impl ModelInfo {
    /// The model `outcome` used downstream: its cross-validation, structure errors,
    /// identification set and Table 2 against the twin's truth.
    fn of(outcome: &Outcome) -> ModelInfo {
        let well: Vec<&ParamRow> = outcome
            .parameters
            .iter()
            .filter(|p| p.rel_std_pct.is_some_and(|s| s < WELL_EXCITED_REL_STD_PCT))
            .collect();
        let idset = &outcome.idset;
        ModelInfo {
            name: outcome.model_name(),
            cv: idset.selection.scores.clone(),
            structure_sigma_w: outcome.model.structure_sigma,
            structure_rel: outcome.model.structure_rel,
            structure_fold_w: outcome.model.structure_fold,
            structure_active_w: outcome.model.structure_active,
            lowest_seen_w: outcome.model.lowest_seen,
            bus_floor_w: outcome.model.bus_floor,
            weighting: idset.weighting,
            consistent: idset.selection.consistent.is_some(),
            motor_power: idset.selection.motor_power,
            design: DesignInfo {
                criterion: idset.criterion,
                rounds: idset.rounds,
                stacked_cond: idset.set_cond,
                wall_s: idset.design_s,
            },
            excitation_conds: idset.conds.clone(),
            excitation_duration_s: excitation_durations_s(outcome),
            loads_kg: identification_loads_kg(outcome),
            standby: idset.standby.as_ref().map(|(pose, tau)| StandbyInfo {
                pose_rad: pose.clone(),
                gravity_torque_nm: tau.clone(),
            }),
            residual_rms_w: idset.selection.fit.estimate.residual_rms,
            well_determined: well.len(),
            well_determined_max_error_pct: well
                .iter()
                .filter_map(|p| p.error_pct)
                .map(f64::abs)
                .reduce(f64::max),
            parameters: outcome.model.theta.len(),
            table2: outcome.parameters.clone(),
        }
    }
}

/// Duration of each identification excitation of `outcome`, s.
fn excitation_durations_s(outcome: &Outcome) -> Vec<f64> {
    outcome
        .idset
        .trajectories
        .iter()
        .take(outcome.idset.conds.len())
        .map(|t| t.duration())
        .collect()
}

/// Known load carried in each identification run of `outcome`: the masses of its payload
/// events summed, kg.
fn identification_loads_kg(outcome: &Outcome) -> Vec<f64> {
    outcome
        .idset
        .payloads
        .iter()
        .map(|e| {
            e.iter()
                .filter_map(|e| e.payload.as_ref())
                .fold(0.0, |m, p| m + p.inertia.mass)
        })
        .collect()
}
