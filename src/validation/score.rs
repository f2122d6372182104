//! Scoring against the twin's truth, the only place experiments compare with it. Nothing here
//! feeds back into identification (which chooses its estimator by cross-validation on logs).
//!
//! * [`energy_error_pct`]: a predicted energy against the simulated one (Tables 3 and 4, the
//!   estimators).
//! * [`heldout_motion`]: one held-out motion's predictions ([`Scores`] per route,
//!   [`MotionResult`]), and their spread over motions ([`Spread`], [`RouteSummary`]).
//! * [`table`]: identified against true base parameters (Table 2, [`ParamRow`]).

use serde::{Deserialize, Serialize};

use crate::dataset::Dataset;
use crate::dynamics::DriveTerms;
use crate::error::Result;
use crate::identification::data::{Prepared, power_sample_nodes, prepare};
use crate::identification::lsq::Estimate;
use crate::identification::model::{PowerModel, Prediction};
use crate::measurement::Log;
use crate::model::Robot;
use crate::model::drive::Drive;
use crate::model::payload::PayloadEvent;
use crate::validation::heldout::{HeldoutOptions, Motion};
use crate::validation::rig::Rig;

/// True values below this fraction of the largest true value of the same kind are "zero":
/// their relative error is not reported.
const NEGLIGIBLE: f64 = 1e-9;

/// Error of a predicted energy against the true (simulated) one, J each:
/// `100 (predicted - truth) / truth`, %.
pub fn energy_error_pct(predicted_j: f64, truth_j: f64) -> f64 {
    100.0 * (predicted_j - truth_j) / truth_j
}

/// Scores of one prediction.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Scores {
    /// Predicted energy of the measured signal, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// Half-width of its 95 % interval, J.
    #[serde(rename = "interval_95_J")]
    pub interval_j: f64,
    /// `100 (predicted - true) / true`, %.
    pub energy_error_pct: f64,
    /// Error relative to the true energy above standby, %.
    pub above_standby_error_pct: f64,
    /// `(predicted - true) / duration`, W.
    #[serde(rename = "mean_power_error_W")]
    pub mean_power_error_w: f64,
    /// Whether the 95 % interval holds the true energy.
    pub covered: bool,
    /// The error in units of the interval's standard deviation, `|predicted - true| / (interval
    /// / 1.96)`: normal with unit variance when the interval is calibrated. `None` for a
    /// prediction without an interval (the baseline).
    pub z: Option<f64>,
}

impl Scores {
    /// `prediction` against the true energy `truth_j` (J) over `duration_s` (s), of which
    /// `standby_w` (W, summed over the drives) is standby.
    fn of(prediction: &Prediction, truth_j: f64, duration_s: f64, standby_w: f64) -> Scores {
        let err = prediction.energy_j - truth_j;
        Scores {
            predicted_j: prediction.energy_j,
            interval_j: prediction.interval_j,
            energy_error_pct: energy_error_pct(prediction.energy_j, truth_j),
            above_standby_error_pct: 100.0 * err / (truth_j - standby_w * duration_s),
            mean_power_error_w: err / duration_s,
            covered: err.abs() <= prediction.interval_j,
            z: (prediction.interval_j > 0.0).then(|| 1.96 * err.abs() / prediction.interval_j),
        }
    }
}

/// One held-out motion's result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MotionResult {
    /// 1-based index.
    pub index: usize,
    /// Kind of motion.
    pub kind: String,
    /// Payload mass, kg.
    pub payload_kg: f64,
    /// TCP speed of a linear motion, m/s.
    pub tcp_speed_m_s: Option<f64>,
    /// Duration of the logged span, s.
    pub duration_s: f64,
    /// True energy of the measured signal over the logged span, J (twin truth).
    #[serde(rename = "true_J")]
    pub true_j: f64,
    /// True standby energy over the span, J (twin truth).
    #[serde(rename = "true_standby_J")]
    pub standby_j: f64,
    /// Prediction from the logged positions.
    pub from_log: Scores,
    /// Prediction from the commanded trajectory (true energy over the whole run).
    pub from_plan: Scores,
    /// The baseline (URDF + data-sheet efficiency) from the logged positions.
    pub baseline: Scores,
    /// RMS of predicted (from the log) minus measured power at the logged samples, W.
    #[serde(rename = "power_rmse_W")]
    pub power_rmse_w: f64,
    /// The same with the power predicted from the commanded trajectory, W: without the 10 Hz
    /// route's error, with the twin's tracking error.
    #[serde(rename = "plan_power_rmse_W")]
    pub plan_power_rmse_w: f64,
    /// The same for the baseline, W.
    #[serde(rename = "baseline_power_rmse_W")]
    pub baseline_power_rmse_w: f64,
    /// Largest tracking error of the twin run, rad.
    pub max_tracking_error_rad: f64,
}

/// Median, 95th percentile and worst of a metric's absolute values.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Spread {
    /// Median.
    pub median: f64,
    /// 95th percentile (nearest rank).
    pub p95: f64,
    /// Largest.
    pub worst: f64,
}

impl Spread {
    /// Of the absolute values of `v` (zeros when empty).
    pub fn of(v: impl IntoIterator<Item = f64>) -> Spread {
        let mut a: Vec<f64> = v.into_iter().map(f64::abs).collect();
        if a.is_empty() {
            return Spread {
                median: 0.0,
                p95: 0.0,
                worst: 0.0,
            };
        }
        a.sort_by(f64::total_cmp);
        let rank = |p: f64| a[((p * a.len() as f64).ceil() as usize).clamp(1, a.len()) - 1];
        Spread {
            median: if a.len() % 2 == 1 {
                a[a.len() / 2]
            } else {
                0.5 * (a[a.len() / 2 - 1] + a[a.len() / 2])
            },
            p95: rank(0.95),
            worst: a[a.len() - 1],
        }
    }
}

/// Summary of one prediction route over all motions.
#[derive(Debug, Clone, Serialize)]
pub struct RouteSummary {
    /// Energy error, %.
    pub energy_error_pct: Spread,
    /// Error of the energy above standby, %.
    pub above_standby_error_pct: Spread,
    /// Mean-power error, W.
    #[serde(rename = "mean_power_error_W")]
    pub mean_power_error_w: Spread,
    /// Share of motions whose 95 % interval holds the truth, %.
    pub coverage_pct: f64,
    /// Median of the errors in units of the interval's standard deviation ([`Scores::z`]).
    /// Calibrated intervals give 0.674 (the median of `|N(0, 1)|`); below, they are too wide;
    /// above, too narrow. With 30 motions it says more than the coverage, which calibrated
    /// intervals put at 100 % one time in five (0.95^30) if the errors were independent. They
    /// are not: every motion's error projects the same model's parameter error, so one
    /// benchmark of one model is one draw, and calibration shows over several
    /// identifications. `None` without intervals.
    pub median_z: Option<f64>,
}

impl RouteSummary {
    /// Of one route's scores over the motions.
    pub fn of<'a>(scores: impl Iterator<Item = &'a Scores> + Clone) -> RouteSummary {
        let count = scores.clone().count().max(1) as f64;
        RouteSummary {
            energy_error_pct: Spread::of(scores.clone().map(|s| s.energy_error_pct)),
            above_standby_error_pct: Spread::of(scores.clone().map(|s| s.above_standby_error_pct)),
            mean_power_error_w: Spread::of(scores.clone().map(|s| s.mean_power_error_w)),
            coverage_pct: 100.0 * scores.clone().filter(|s| s.covered).count() as f64 / count,
            median_z: scores
                .clone()
                .any(|s| s.z.is_some())
                .then(|| Spread::of(scores.filter_map(|s| s.z)).median),
        }
    }
}

/// Score held-out motion `m` (0-based index `k`) and its twin run `ds` on `rig`: `model`
/// predicts from the logged stream (states through `opts.route`) and from the commanded
/// trajectory, `base_model` (the baseline) from the logged stream; known payloads enter
/// with `opts.baseline_efficiency`. The truth is the twin's measured signal (the motor sum,
/// or the grid-side power for a clipped model) integrated over the logged span
/// `[t_0, t_last)` for the log routes and over the whole run for the plan, and the drives'
/// standby power.
pub fn heldout_motion(
    rig: &Rig,
    model: &PowerModel,
    base_model: &PowerModel,
    k: usize,
    m: &Motion,
    ds: &Dataset,
    opts: &HeldoutOptions,
) -> Result<MotionResult> {
    let robot = rig.robot;
    let dt = rig.twin.physics.dt;
    let standby_w = standby_power_w(rig);
    let clipped = model.signal.clipped();
    let truth = &ds.truth;
    // Truth over the logged span [t_0, t_last) and over the whole run.
    let log = ds.log(&format!("held-out motion {}", k + 1))?;
    let (t0, t1) = (log.t_s[0], log.t_s[log.len() - 1]);
    let span = truth.energy_between(t0, t1, clipped);
    let whole = if clipped {
        truth.energy_grid()
    } else {
        truth.energy_total()
    };
    let prepared = prepare(&log, opts.route)?;
    let eff = opts.baseline_efficiency;
    let span_s = t1 - t0;
    let events = prepared.motion_events();
    let from_log = model.predict(robot, prepared.motion.as_ref(), &events, eff, dt)?;
    let from_plan = model.predict(robot, m.trajectory.as_ref(), &m.events, eff, dt)?;
    let base = base_model.predict(robot, prepared.motion.as_ref(), &events, eff, dt)?;
    let (power_t, per_sample) = power_sample_nodes(&log.t_s, log.power_averaged);
    let samples = PowerSamples {
        robot,
        log: &log,
        prepared: &prepared,
        events: &events,
        motion: m,
        efficiency: eff,
        power_t: &power_t,
        per_sample,
    };
    Ok(MotionResult {
        index: k + 1,
        kind: m.kind.to_string(),
        payload_kg: m.payload_kg,
        tcp_speed_m_s: m.tcp_speed_m_s,
        duration_s: span_s,
        true_j: span,
        standby_j: standby_w * span_s,
        from_log: Scores::of(&from_log, span, span_s, standby_w),
        from_plan: Scores::of(&from_plan, whole, ds.meta.summary.duration_s, standby_w),
        baseline: Scores::of(&base, span, span_s, standby_w),
        power_rmse_w: samples.rmse(model, false)?,
        plan_power_rmse_w: samples.rmse(model, true)?,
        baseline_power_rmse_w: samples.rmse(base_model, false)?,
        max_tracking_error_rad: max_tracking_error_rad(&truth.q, &truth.q_ref),
    })
}

/// Standby power of the rig's true drives, summed over the joints, W.
fn standby_power_w(rig: &Rig) -> f64 {
    rig.true_drive()
        .joints()
        .iter()
        .map(|j| j.standby_power)
        .sum()
}

/// Largest deviation of the joint positions `q` from their references `q_ref` over the run,
/// rad.
fn max_tracking_error_rad(q: &[Vec<f64>], q_ref: &[Vec<f64>]) -> f64 {
    q.iter()
        .zip(q_ref)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max)
}

/// What the power predictions of a held-out motion are scored against: the logged power and
/// the two routes to its states, the log route (its clock starts at the route's origin) and
/// the plan (the run's clock).
struct PowerSamples<'a> {
    robot: &'a Robot,
    log: &'a Log,
    prepared: &'a Prepared,
    /// Known payloads on the log route's clock.
    events: &'a [PayloadEvent],
    motion: &'a Motion,
    /// Efficiency known payloads enter with.
    efficiency: f64,
    /// Times (log clock, s) the logged power is evaluated at, `per_sample` per logged sample.
    power_t: &'a [f64],
    per_sample: usize,
}

impl PowerSamples<'_> {
    /// RMSE of `mm`'s power against the logged power, W, along the plan when `plan`, else
    /// along the log route. The logged power belongs to the motion at its sample times (the
    /// mean over each period for an averaging meter), the model's lag earlier.
    fn rmse(&self, mm: &PowerModel, plan: bool) -> Result<f64> {
        let (robot, eff, per_sample) = (self.robot, self.efficiency, self.per_sample);
        let lagged = |t0: f64| -> Vec<f64> {
            self.power_t
                .iter()
                .map(|t| t - t0 - mm.power_lag_s)
                .collect()
        };
        let log_t = lagged(self.prepared.motion_t0_s);
        let p = if plan {
            let m = self.motion;
            mm.power_with_payloads(robot, m.trajectory.as_ref(), &m.events, eff, &lagged(0.0))?
        } else {
            let motion = self.prepared.motion.as_ref();
            mm.power_with_payloads(robot, motion, self.events, eff, &log_t)?
        };
        let se: f64 = p
            .chunks(per_sample)
            .zip(&self.log.power_w)
            .map(|(nodes, y)| {
                let read = nodes.iter().map(|p| mm.reading(*p)).sum::<f64>();
                (read / per_sample as f64 - y).powi(2)
            })
            .sum();
        Ok((se / self.log.len() as f64).sqrt())
    }
}

/// One row of Table 2.
#[derive(Debug, Clone, Serialize)]
pub struct ParamRow {
    /// Base parameter name.
    pub name: String,
    /// Identified value (SI; divided by the efficiency for an efficiency-scaled model).
    pub identified: f64,
    /// The twin's true value, on the same scale.
    pub truth: f64,
    /// `100 (identified - truth) / |truth|`, %; `None` where the truth is zero.
    pub error_pct: Option<f64>,
    /// Relative standard deviation of the estimate, %; `None` if no estimate covers it.
    pub rel_std_pct: Option<f64>,
}

/// Table 2 for `model`, identified on a twin of `robot` with drives `drive`. `estimates` are
/// the least-squares results the model came from (for the standard deviations; a parameter
/// in several takes the last). An efficiency-scaled model is compared with the truth divided
/// by the drives' nominal efficiency.
pub fn table(
    robot: &Robot,
    drive: &Drive,
    model: &PowerModel,
    estimates: &[&Estimate],
) -> Result<Vec<ParamRow>> {
    let base = model.base_params(robot)?;
    let scale = if model.efficiency_scaled {
        1.0 / drive.nominal_efficiency()
    } else {
        1.0
    };
    let truth: Vec<f64> = base
        .base_values(&model.layout.theta(robot, &DriveTerms::from(drive)))?
        .into_iter()
        .map(|v| v * scale)
        .collect();
    let largest = truth.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    Ok(model
        .names
        .iter()
        .zip(&model.theta)
        .zip(&truth)
        .map(|((name, &identified), &truth)| {
            let rel_std_pct = estimates.iter().rev().find_map(|e| {
                e.names
                    .iter()
                    .position(|n| n == name)
                    .map(|k| 100.0 * e.rel_std[k])
            });
            ParamRow {
                name: name.clone(),
                identified,
                truth,
                error_pct: (truth.abs() > NEGLIGIBLE * largest)
                    .then(|| 100.0 * (identified - truth) / truth.abs()),
                rel_std_pct,
            }
        })
        .collect())
}
