//! Power-model fitting on pooled logs, with what a user knows and nothing else: the fitted
//! states, the measured power of a stated [`PowerSignal`](crate::measurement::PowerSignal), and the known payload timeline.
//!
//! The model (paper eqs. 9–13 with PMSM losses) is, per sample,
//! `P = sum_i [dq_i tau_i + c_i tau_i^2] + P0` with `tau = W_base (theta + delta(t))`, where
//! `delta(t)` is the base-parameter change of the payload known to be at the flange then (so
//! data recorded with tools and loads identify the bare robot). A DC-bus or grid signal
//! cannot go negative (braking energy is burnt in the brake resistor), so the model of such a
//! signal is `max(P, F)`, with `F` a load the meter sees after the clip (0 without one; see
//! `floor`). When the logs have each motor's power, motor `i`'s is observed too,
//! `P_i = dq_i tau_i + c_i tau_i^2 + P0_i` with a standby of its own (the paper's eq. 13 with
//! per-motor power; [`FitOptions::motor_power`]): the same `theta` and `c`, each joint's part
//! seen in its own motor. Estimators:
//! - [`Estimator::Total`]: `c = 0`, linear least squares (clipped samples left out);
//! - [`Estimator::Pmsm`]: copper loss too, Levenberg–Marquardt from the linear solution
//!   (copper coefficients >= 0 by an active set; those the data cannot tell from zero held
//!   at zero). Each iteration evaluates the samples in parallel.
//!
//! [`select`] chooses between them by K-fold cross-validation on contiguous time blocks of
//! the identification logs (never against a twin's truth) and measures the model-structure
//! error that the parameter covariance does not explain, which widens the prediction
//! intervals ([`crate::identification::model::PowerModel::predict`]).
//!
//! The stages, one file each:
//! - `samples`: the pooled observations ([`Samples`]) and `power`, the power model of one
//!   observation and its gradient;
//! - `floor`: the floor under a clipped meter's reading, from the logs or the drive file;
//! - `layout`: where each parameter of the model sits in the parameter vector and its name
//!   ([`Layout`], [`Param`]);
//! - `estimate`: one estimator's fit ([`fit`]), its weighted rounds and its
//!   Levenberg–Marquardt;
//! - `weighting`: the weights of iterated weighted least squares;
//! - `covariance`: the HAC covariance of an estimate;
//! - `cv` and `structure`: cross-validation ([`select`]) and the structure-error posterior;
//! - `refit`: the loss terms refitted under the consistent base parameters;
//! - `lag`: the lag of the logged power behind the joints, found by the model's fit;
//! - `pipeline`: logs to a selected, consistent model ([`identify_logs`]).

use nalgebra::DMatrix;
use serde::Serialize;

use crate::identification::lsq::Estimate;
use crate::identification::model::PowerModel;
use crate::identification::tuning;

mod covariance;
mod cv;
mod estimate;
mod floor;
mod lag;
mod layout;
mod nonlinear;
mod pipeline;
mod power;
mod refit;
mod samples;
mod structure;
mod weighting;

pub use cv::select;
pub use estimate::fit;
pub use layout::{Layout, Param};
pub use pipeline::identify_logs;
pub use samples::Samples;

/// The estimators [`select`] compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Estimator {
    /// Base parameters and a constant from total power, linear (no copper loss).
    Total,
    /// Base parameters, copper-loss coefficients and a constant, nonlinear.
    Pmsm,
    /// [`Estimator::Pmsm`] with load-dependent gear friction: a loss `g_i |tau_i dq_i|` per
    /// joint, a fraction of the power transmitted (Coulomb friction that grows with the
    /// torque, as in harmonic and cycloidal drives), nonlinear.
    Gear,
}

impl Estimator {
    /// The estimators `--method auto` chooses among by cross-validation: `total` and
    /// `pmsm`. [`Estimator::Gear`] is asked for by name: on the family of truths it is more
    /// accurate than `pmsm`, but on the single-truth benchmark less
    /// (docs/experiments.md#load-dependent-gear-friction-in-the-model).
    pub fn auto() -> Vec<Estimator> {
        vec![Estimator::Total, Estimator::Pmsm]
    }

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Total => "total",
            Estimator::Pmsm => "pmsm",
            Estimator::Gear => "gear",
        }
    }

    /// Whether the estimator fits the copper-loss coefficients.
    pub fn fits_copper(self) -> bool {
        self != Estimator::Total
    }

    /// Whether the estimator fits the gear-friction coefficients.
    pub fn fits_gear(self) -> bool {
        self == Estimator::Gear
    }
}

/// A fitted model with its parameter covariance.
pub struct Fit {
    /// The model (filled in).
    pub model: PowerModel,
    /// Least-squares statistics of the fit: `values` are all of `z = [theta, c_1..c_n, P0]`,
    /// the names, standard deviations and covariance only the parameters fitted. Use
    /// [`Fit::free_estimate`] for the values and statistics of the fitted ones, aligned.
    pub estimate: Estimate,
    /// Covariance of `z = [theta, c_1..c_n, P0]` (zero rows and columns for parameters the
    /// estimator holds fixed).
    pub covariance: DMatrix<f64>,
    /// Where each parameter sits in `z` (the rows of `covariance`, the `values` of
    /// `estimate`).
    pub layout: Layout,
}

/// How the samples are weighted in a fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Weighting {
    /// Ordinary least squares: every sample alike.
    None,
    /// Each log by the inverse of its residual variance (iterated from the residuals).
    PerLog,
    /// Each sample by the inverse of a residual variance that grows with the predicted active
    /// power, `a + b (P - P0)^2` (fitted to the squared residuals, iterated).
    PowerLevel,
}

impl Weighting {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Weighting::None => "none",
            Weighting::PerLog => "per-log",
            Weighting::PowerLevel => "power-level",
        }
    }
}

/// One estimator's cross-validation score.
#[derive(Debug, Clone, Serialize)]
pub struct CvScore {
    /// Estimator name.
    pub estimator: Estimator,
    /// RMS over held-out pieces (one log's time block) of the mean-power error, W: the
    /// energy error per second of a motion not fitted on.
    #[serde(rename = "mean_power_rms_W")]
    pub mean_power_rms_w: f64,
    /// RMS of the held-out sample power residuals, W.
    #[serde(rename = "power_rmse_W")]
    pub power_rmse_w: f64,
    /// Held-out pieces scored.
    pub pieces: usize,
}

/// The outcome of [`select`].
pub struct Selection {
    /// Scores of every candidate, in the order given.
    pub scores: Vec<CvScore>,
    /// The candidate with the smallest mean-power error.
    pub chosen: Estimator,
    /// The chosen estimator fitted on all samples, with `structure_sigma` set (its model made
    /// physically consistent when [`FitOptions::consistent`] asks for it).
    pub fit: Fit,
    /// The consistent projection of the fit, when asked for.
    pub consistent: Option<crate::identification::consistent::Consistent>,
    /// The other friction structure fitted on all samples: [`Estimator::Gear`] when the
    /// chosen estimator has no gear friction, [`Estimator::Pmsm`] when it has (`None` when it
    /// cannot be fitted). Predictions take the mean of its power and the chosen model's, and
    /// half their difference in the intervals ([`PowerModel::alternative`]).
    pub alternative: Option<(Estimator, Fit)>,
    /// Whether each motor's logged power was fitted besides the arm's.
    pub motor_power: bool,
}

/// Settings of [`identify_logs`].
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Samples at which an excited joint moves slower than this (rad/s) are not fitted on
    /// (Coulomb sign and stiction around velocity reversals), except where the robot is held
    /// exactly still; they still count in the cross-validated energies.
    pub min_speed: f64,
    /// Fastest rate (Hz) at which a log's states are fitted on: a faster log is fitted on
    /// every `k`-th state (`k` whole), all of them still counted in the cross-validated
    /// energies; 0: every state.
    pub max_fit_rate_hz: f64,
    /// Contiguous time blocks each log is cut into: the energy pieces of cross-validation,
    /// and its folds when there are fewer than three logs.
    pub folds: usize,
    /// Estimators to choose from.
    pub candidates: Vec<Estimator>,
    /// Weighting of the samples.
    pub weighting: Weighting,
    /// Make the chosen model physically consistent
    /// ([`crate::identification::consistent::constrain`]; the URDF decides what the data
    /// cannot see), then refit its loss terms (copper, standby) on the data with those base
    /// parameters held. The intervals keep the unconstrained covariance and structure error.
    pub consistent: bool,
    /// Also fit each motor's logged power when every log has it ([`Samples::new`]), else
    /// the arm's power alone.
    pub motor_power: bool,
    /// Prior of the base parameters ([`crate::identification::prior`]): every fit is then
    /// the posterior, and a log that leaves directions undetermined still gives a model
    /// (those directions from the prior, with its width in the intervals). `None`: the data
    /// alone, and rank-deficient data are an error.
    pub prior: Option<crate::identification::prior::Prior>,
    /// Largest lag of the logged power behind the joints searched for, s (either sign): the
    /// lag whose states explain the power best (a linear fit at each trial lag) is the
    /// model's [`PowerModel::power_lag_s`] and every fit uses the states it gives. 0: none.
    pub max_power_lag_s: f64,
}

impl Default for FitOptions {
    /// The values of the tuning table ([`crate::identification::tuning`]): 0.05 rad/s,
    /// 5 folds, `total` and `pmsm`, power-level weighting, the model made physically
    /// consistent (loss terms refitted), each motor's power fitted where the logs have it.
    fn default() -> Self {
        FitOptions {
            min_speed: tuning::MIN_SPEED,
            max_fit_rate_hz: tuning::MAX_FIT_RATE_HZ,
            folds: tuning::FOLDS,
            candidates: Estimator::auto(),
            weighting: tuning::WEIGHTING,
            consistent: tuning::CONSISTENT,
            motor_power: tuning::MOTOR_POWER,
            prior: None,
            max_power_lag_s: tuning::MAX_POWER_LAG_S,
        }
    }
}
