//! The pooled identification samples: per logged state the regressor rows, speeds and known
//! payload torques; per observation the measured power, its series and its
//! cross-validation piece and fold.

use std::borrow::Cow;

use nalgebra::{DMatrix, DVector};

use super::floor::Floor;
use super::layout::Layout;
use crate::dynamics::Workspace;
use crate::dynamics::regressor::regressor;
use crate::error::{Error, Result};
use crate::identification::data::{PERIOD_NODES, Prepared};
use crate::identification::lsq::ColumnPrior;
use crate::identification::model::PowerModel;
use crate::identification::prior::{Normal, Prior};
use crate::model::Robot;

/// A cross-validation piece: one time block of one log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) struct PieceId {
    /// Index of the log.
    pub log: usize,
    /// Time block of the log.
    pub block: usize,
}

/// When an observation was taken: the log and the state (states numbered in time order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) struct Instant {
    /// Index of the log.
    pub log: usize,
    /// Index of the state among all pooled states.
    pub state: usize,
}

/// A known payload from time `from_s` on: its base-parameter change (model units, not
/// scaled), `None` without payload.
struct PayloadSpan {
    /// Start, s (log time).
    from_s: f64,
    /// Base-parameter change of the payload.
    delta: Option<Vec<f64>>,
}

/// Pooled identification samples: per logged state the regressor rows, speeds and known
/// payload torques; per observation (the arm's power at a state, or one motor's power there
/// when the logs have it and the fit uses it) the measured power and the cross-validation
/// block.
#[derive(Clone)]
pub struct Samples {
    pub(super) n: usize,
    pub(super) nb: usize,
    /// Base regressor rows, `n x nb` per state, row-major, states one after the other
    /// (flat, so that evaluating the model allocates nothing).
    pub(super) wb: Vec<f64>,
    /// Joint speeds, `n` per state, rad/s.
    pub(super) dq: Vec<f64>,
    /// Torque of the known payload, `n` per state, N m (zero without payload).
    pub(super) tau_known: Vec<f64>,
    /// The (first) state of each observation.
    pub(super) state: Vec<usize>,
    /// The states each observation averages, consecutive from its `state`: 1 for an
    /// instantaneous meter, [`PERIOD_NODES`] for one that averages over its sample period.
    pub(super) span: Vec<usize>,
    /// What each observation measured: the arm's power (`None`) or motor `i`'s (0-based).
    pub(super) motor: Vec<Option<usize>>,
    /// Whether the parameters hold a standby power per motor (the logs' motor power is fitted).
    pub(super) motors: bool,
    /// Whether the parameters hold a gear-friction coefficient per joint
    /// ([`Samples::for_estimator`]).
    pub(super) gear: bool,
    /// Series of each observation: one measured signal of one log, in time order (the
    /// residuals of neighbours in a series are correlated).
    pub(super) series: Vec<usize>,
    /// Measured power, W.
    pub(super) y: Vec<f64>,
    /// Whether the observation is used for fitting (every excited joint moves fast enough).
    pub(super) fit: Vec<bool>,
    /// Cross-validation piece.
    pub(super) piece: Vec<PieceId>,
    /// Cross-validation fold of each sample.
    pub(super) fold: Vec<usize>,
    /// Number of folds.
    pub(super) folds: usize,
    /// Each fold holds out a whole log (three logs or more), not a time block of every log.
    pub(super) folds_are_logs: bool,
    /// The signal cannot go negative.
    pub(super) clipped: bool,
    /// Prior of the base parameters: pseudo-observations every fit adds to the samples'
    /// (`None`: the data alone, a rank-deficient log refused).
    pub(super) prior: Option<Prior>,
    /// The floor under the clipped arm's signal (`None`: 0).
    pub(super) floor: Option<Floor>,
}

impl Samples {
    /// Build the samples of `logs` for `model`'s base parameters. Samples at which an
    /// excited joint moves slower than `min_speed` (rad/s) are kept for cross-validated
    /// energies but not fitted on, unless every joint's velocity and acceleration is exactly
    /// zero (a rest held still by the route). Each log is cut into `folds` contiguous time
    /// blocks (the energy pieces); with three logs or more, each fold holds out a whole log (a
    /// motion, centre and payload the fit did not see, as a prediction meets), else one block
    /// of every log.
    ///
    /// `max_fit_rate_hz` (0: no limit): a log sampled faster is fitted on a whole-number
    /// fraction of its states ([`FitOptions::max_fit_rate_hz`](super::FitOptions)).
    ///
    /// `motor_power`: also observe each motor's logged power, `dq_i tau_i + c_i tau_i^2 +
    /// P0_i` with a standby `P0_i` of its own (the paper's eq. 13 with per-motor power: each
    /// joint's parameters seen in its own motor rather than under the larger joints' power).
    /// Cross-validation still scores the arm's power only.
    ///
    /// Errors: logs of different power signals, no log that moves a joint
    /// ([`ensure_motion`](crate::identification::data::ensure_motion)), a model of another
    /// robot, a payload that is not physical, `motor_power` with a log without it.
    pub fn new(
        robot: &Robot,
        model: &PowerModel,
        logs: &[Prepared],
        min_speed: f64,
        max_fit_rate_hz: f64,
        folds: usize,
        motor_power: bool,
    ) -> Result<Samples> {
        model.check_robot(robot)?;
        let first = check_logs(logs, robot.dof(), motor_power)?;
        let n = robot.dof();
        let nb = model.columns.len();
        let needs_base = logs
            .iter()
            .any(|p| p.payloads.iter().any(|e| e.payload.is_some()));
        let base = needs_base.then(|| model.base_params(robot)).transpose()?;
        let mut s = Samples {
            n,
            nb,
            wb: Vec::new(),
            dq: Vec::new(),
            tau_known: Vec::new(),
            state: Vec::new(),
            span: Vec::new(),
            motor: Vec::new(),
            motors: motor_power,
            gear: false,
            series: Vec::new(),
            y: Vec::new(),
            fit: Vec::new(),
            piece: Vec::new(),
            fold: Vec::new(),
            folds: if logs.len() >= 3 {
                logs.len()
            } else {
                folds.max(2)
            },
            folds_are_logs: logs.len() >= 3,
            clipped: first.signal.clipped(),
            prior: None,
            floor: None,
        };
        let mut ws = Workspace::new(robot);
        for (l, p) in logs.iter().enumerate() {
            if p.p_total.len() != p.states.len() {
                return Err(Error::InvalidInput(format!(
                    "log {}: {} power samples for {} states",
                    l + 1,
                    p.p_total.len(),
                    p.states.len()
                )));
            }
            let spans = payload_spans(robot, model, base.as_ref(), p)?;
            let fit = fitted(p, min_speed, max_fit_rate_hz);
            // The model's states: the period's nodes of an averaging meter, else one per
            // sample.
            let (states, span) = match &p.period_nodes {
                Some(nodes) if nodes.len() == p.states.len() * PERIOD_NODES => {
                    (nodes, PERIOD_NODES)
                }
                Some(nodes) => {
                    return Err(Error::InvalidInput(format!(
                        "log {}: {} period nodes for {} samples",
                        l + 1,
                        nodes.len(),
                        p.states.len()
                    )));
                }
                None => (&p.states, 1),
            };
            let first_state = s.dq.len() / n;
            s.push_states(robot, model, &mut ws, states, &spans);
            s.push_observations(l, p, &fit, (first_state, span), folds, logs.len() >= 3);
        }
        Ok(s)
    }

    /// Append the regressor rows, speeds and known payload torques of `states` (the payload
    /// at the flange at each state's time from `spans`).
    fn push_states(
        &mut self,
        robot: &Robot,
        model: &PowerModel,
        ws: &mut Workspace,
        states: &crate::identification::states::States,
        spans: &[PayloadSpan],
    ) {
        let n = self.n;
        let mut w = DMatrix::zeros(n, model.layout.len());
        let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for m in 0..states.len() {
            states.at(m, &mut q, &mut dq, &mut ddq);
            regressor(robot, ws, &model.layout, &q, &dq, &ddq, &mut w);
            model.apply_coulomb_law(&mut w, &dq);
            let t = states.t[m];
            let delta = spans
                .iter()
                .rev()
                .find(|span| span.from_s <= t)
                .and_then(|span| span.delta.as_ref());
            for i in 0..n {
                let row = model.columns.iter().map(|&c| w[(i, c)]);
                self.tau_known.push(match delta {
                    Some(d) => row.clone().zip(d).map(|(a, b)| a * b).sum(),
                    None => 0.0,
                });
                self.wb.extend(row);
            }
            self.dq.extend_from_slice(&dq);
        }
    }

    /// Samples of pooled `states` (any order) with their total power `p` (W, a signal that
    /// can go negative), no payload, all fitted on, in one fold: for estimators that pool
    /// already-selected samples.
    pub fn from_states(
        robot: &Robot,
        model: &PowerModel,
        states: &crate::identification::states::States,
        p: &[f64],
    ) -> Result<Samples> {
        model.check_robot(robot)?;
        if p.len() != states.len() {
            return Err(Error::InvalidInput(format!(
                "{} power samples for {} states",
                p.len(),
                states.len()
            )));
        }
        let n = robot.dof();
        let nb = model.columns.len();
        let mut ws = Workspace::new(robot);
        let mut w = DMatrix::zeros(n, model.layout.len());
        let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut wbs = Vec::with_capacity(states.len() * n * nb);
        let mut dqs = Vec::with_capacity(states.len() * n);
        for m in 0..states.len() {
            states.at(m, &mut q, &mut dq, &mut ddq);
            regressor(robot, &mut ws, &model.layout, &q, &dq, &ddq, &mut w);
            model.apply_coulomb_law(&mut w, &dq);
            for i in 0..n {
                wbs.extend(model.columns.iter().map(|&c| w[(i, c)]));
            }
            dqs.extend_from_slice(&dq);
        }
        let len = states.len();
        Ok(Samples {
            n,
            nb,
            wb: wbs,
            dq: dqs,
            tau_known: vec![0.0; len * n],
            state: (0..len).collect(),
            span: vec![1; len],
            motor: vec![None; len],
            motors: false,
            gear: false,
            series: vec![0; len],
            y: p.to_vec(),
            fit: vec![true; len],
            piece: vec![PieceId { log: 0, block: 0 }; len],
            fold: vec![0; len],
            folds: 1,
            folds_are_logs: false,
            clipped: false,
            prior: None,
            floor: None,
        })
    }

    /// Fit only on the observations that `keep` (one per observation) marks as well.
    /// Errors: a mask of another length.
    pub(super) fn keep_only(&mut self, keep: &[bool]) -> Result<()> {
        if keep.len() != self.fit.len() {
            return Err(Error::InvalidInput(format!(
                "a mask of {} observations for {}",
                keep.len(),
                self.fit.len()
            )));
        }
        self.fit.iter_mut().zip(keep).for_each(|(f, &k)| *f &= k);
        Ok(())
    }

    /// The samples with `prior` on their base parameters: each fit is then the posterior
    /// (the data decide the directions they determine, the prior the rest). A clipped arm's
    /// signal then reads no less than a floor, the fitted standby less the drive file's where
    /// the prior holds it ([`PowerModel::bus_floor`]). Errors: a prior of another
    /// base-parameter count.
    pub fn with_prior(mut self, prior: Prior) -> Result<Samples> {
        if prior.mean.len() != self.nb || prior.copper.len() != self.n || prior.gear.len() != self.n
        {
            return Err(Error::InvalidInput(format!(
                "prior of {} base parameters and {} joints for a model of {} and {}",
                prior.mean.len(),
                prior.copper.len(),
                self.nb,
                self.n
            )));
        }
        self.floor = prior
            .standby_w
            .zip(self.lowest_seen())
            .map(|(standby_w, lowest_w)| Floor::Standby {
                standby_w,
                lowest_w,
            });
        self.prior = Some(prior);
        Ok(self)
    }

    /// The prior of the parameters `z` (zero columns for those without one), if any: the
    /// base parameters' rows, then a row per loss coefficient (copper, gear friction) with a
    /// prior.
    pub(super) fn z_prior(&self) -> Option<ColumnPrior> {
        let prior = self.prior.as_ref()?;
        let np = self.params();
        // The loss coefficients with a prior: their index in `z` and the prior.
        let layout = self.layout();
        let gear = if layout.gear { &prior.gear[..] } else { &[] };
        let losses: Vec<(usize, Normal)> = (prior.copper.iter().enumerate())
            .filter_map(|(i, c)| c.map(|c| (layout.copper(i), c)))
            .chain((gear.iter().enumerate()).filter_map(|(i, g)| g.map(|g| (layout.gear(i), g))))
            .collect();
        let mut root = DMatrix::zeros(self.nb + losses.len(), np);
        root.view_mut((0, 0), (self.nb, self.nb))
            .copy_from(&prior.root_precision);
        let mut mean = DVector::zeros(np);
        mean.rows_mut(0, self.nb).copy_from_slice(&prior.mean);
        for (r, &(k, c)) in losses.iter().enumerate() {
            root[(self.nb + r, k)] = 1.0 / c.std;
            mean[k] = c.mean;
        }
        Some(ColumnPrior { root, mean })
    }

    /// Whether entry `k` of `z` is a loss coefficient with a prior (copper or gear friction).
    pub(super) fn loss_has_prior(&self, k: usize) -> bool {
        let Some(p) = &self.prior else {
            return false;
        };
        match self.layout().param(k) {
            super::Param::Copper(i) => p.copper.get(i).is_some_and(|c| c.is_some()),
            super::Param::Gear(i) => p.gear.get(i).is_some_and(|g| g.is_some()),
            _ => false,
        }
    }

    /// Number of observations.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// True when there are no observations.
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    /// Layout of the parameters `z = [theta, c_1..c_n, g_1..g_n, P0_1..P0_n, P0]` (the gear
    /// friction `g_i` only for the `gear` estimator ([`Samples::for_estimator`]), the motors' own standby powers `P0_i` only
    /// when their power is observed).
    pub(super) fn layout(&self) -> Layout {
        Layout {
            base: self.nb,
            joints: self.n,
            motors: self.motors,
            gear: self.gear,
        }
    }

    /// The samples `estimator` fits: these, or for the `gear` estimator a copy whose
    /// parameters hold a gear-friction coefficient per joint. (The others' fits leave them
    /// out, so that their every evaluation does not carry them.)
    pub(super) fn for_estimator(&self, estimator: super::Estimator) -> Cow<'_, Samples> {
        if estimator.fits_gear() && !self.gear {
            Cow::Owned(Samples {
                gear: true,
                ..self.clone()
            })
        } else {
            Cow::Borrowed(self)
        }
    }

    /// Number of parameters of `z`.
    pub(super) fn params(&self) -> usize {
        self.layout().len()
    }

    /// The log and state of observation `m`: when it was taken.
    pub(super) fn instant(&self, m: usize) -> Instant {
        Instant {
            log: self.piece[m].log,
            state: self.state[m],
        }
    }

    /// Index in `z` of the standby power observation `m` measures.
    pub(super) fn constant(&self, m: usize) -> usize {
        let layout = self.layout();
        match self.motor[m] {
            Some(i) => layout.motor_standby(i),
            None => layout.standby(),
        }
    }

    /// For a clipped signal, the 1st percentile of the arm's measured power, W: the lowest
    /// level the logs show the meter at, robust to its noise (`None` for an unclipped signal
    /// or no arm's power).
    pub(super) fn lowest_seen(&self) -> Option<f64> {
        if !self.clipped {
            return None;
        }
        let mut arm: Vec<f64> = (0..self.len())
            .filter(|&m| self.motor[m].is_none())
            .map(|m| self.y[m])
            .collect();
        if arm.is_empty() {
            return None;
        }
        arm.sort_by(f64::total_cmp);
        Some(arm[(arm.len() - 1) / 100])
    }
}

impl Samples {
    /// Append the observations of log `l` (`p`, whose states start at `first_state`, `span`
    /// of them per sample): the arm's power, then each motor's when the samples observe them,
    /// every series contiguous and in time order, with their fit flags `fit` (one per
    /// sample), pieces (`folds` blocks of the log) and folds (the log itself when `by_log`,
    /// else its block).
    fn push_observations(
        &mut self,
        l: usize,
        p: &Prepared,
        fit: &[bool],
        (first_state, span): (usize, usize),
        folds: usize,
        by_log: bool,
    ) {
        let (n, len) = (self.n, fit.len());
        let kinds = std::iter::once(None).chain((0..n).map(Some).filter(|_| self.motors));
        for motor in kinds {
            let series = self.series.last().map_or(0, |v| v + 1);
            // A motor's samples are fitted where the arm's are: near another joint's
            // reversal the motion leaves the route too (docs/experiments.md#motor-power).
            for (m, &fit_m) in fit.iter().enumerate() {
                self.state.push(first_state + m * span);
                self.span.push(span);
                self.motor.push(motor);
                self.series.push(series);
                self.y.push(match motor {
                    None => p.p_total[m],
                    Some(i) => p.p_joint[m * n + i],
                });
                self.fit.push(fit_m);
                let block = (m * folds.max(1)) / len;
                self.piece.push(PieceId { log: l, block });
                self.fold.push(if by_log { l } else { block });
            }
        }
    }
}

/// The first of `logs` (of a robot of `n` joints), after refusing none, logs without
/// motion, mixed power signals, and logs without each motor's power when `motor_power`.
fn check_logs(logs: &[Prepared], n: usize, motor_power: bool) -> Result<&Prepared> {
    let first = logs
        .first()
        .ok_or_else(|| Error::InvalidInput("no logs to identify from".into()))?;
    crate::identification::data::ensure_motion(logs)?;
    if logs
        .iter()
        .any(|p| p.signal.clipped() != first.signal.clipped())
    {
        return Err(Error::InvalidInput(
            "the logs mix power signals that can and cannot go negative (total vs bus/grid)".into(),
        ));
    }
    if motor_power
        && let Some(l) = logs
            .iter()
            .position(|p| p.p_joint.len() != p.states.len() * n)
    {
        return Err(Error::InvalidInput(format!(
            "log {} has no power of each motor: identify from the arm's power only",
            l + 1
        )));
    }
    Ok(first)
}

/// The known payloads of log `p` from when each is at the flange, with its base-parameter
/// change (model units, not scaled; `base` is the model's base-parameter set, needed only
/// when a payload is present).
fn payload_spans(
    robot: &Robot,
    model: &PowerModel,
    base: Option<&crate::dynamics::base_params::BaseParams>,
    p: &Prepared,
) -> Result<Vec<PayloadSpan>> {
    p.payloads
        .iter()
        .map(|e| {
            let d = match (&e.payload, base) {
                (Some(pl), Some(b)) => Some(model.payload_delta(b, robot, pl)?),
                _ => None,
            };
            Ok(PayloadSpan {
                from_s: e.t_s,
                delta: d,
            })
        })
        .collect()
}

/// Whether each state of log `p` is fitted on: every excited joint moves at least
/// `min_speed` (rad/s), or the robot is held exactly still.
///
/// A log faster than `max_rate_hz` (0: no limit) is fitted on every `k`-th state only, `k` the
/// whole number of its samples in `1 / max_rate_hz` (all still count in the cross-validated
/// energies).
pub(super) fn fitted(p: &Prepared, min_speed: f64, max_rate_hz: f64) -> Vec<bool> {
    let len = p.states.len();
    let stride = fit_stride(&p.states.t, max_rate_hz);
    let mut fit = vec![false; len];
    for m in p.states.moving(&p.excited, min_speed) {
        fit[m] = true;
    }
    // A robot held exactly still (the spline route's rests) has no Coulomb sign to doubt: its
    // power is the standby plus the copper loss of holding the pose, which pins the constant.
    for (m, f) in fit.iter_mut().enumerate() {
        *f |= p.states.dq.iter().all(|v| v[m] == 0.0) && p.states.ddq.iter().all(|a| a[m] == 0.0);
        *f &= m % stride == 0;
    }
    fit
}

/// Every how many states a log sampled at times `t` (s) is fitted on to stay within
/// `max_rate_hz` (1 for a slower log, or no limit at 0).
fn fit_stride(t: &[f64], max_rate_hz: f64) -> usize {
    let (Some(first), Some(last)) = (t.first(), t.last()) else {
        return 1;
    };
    if max_rate_hz <= 0.0 || t.len() < 2 || last <= first {
        return 1;
    }
    let rate = (t.len() - 1) as f64 / (last - first);
    ((rate / max_rate_hz + 1e-9).floor() as usize).max(1)
}
