//! From a measured [`Log`] to regressor inputs: states at the sample times, the observations,
//! and a continuous motion for energy integrals. Only what a user has is used (time stamps,
//! joint positions and powers, known payloads): a [`Log`] cannot reach a twin's truth.

use crate::error::{Error, Result};
use crate::identification::fourier_fit::fit_fourier;
use crate::identification::states::{
    REST_SPEED, States, from_fourier, from_smoothing, from_spline,
};
use crate::measurement::{Log, PowerSignal};
use crate::model::payload::{PayloadEvent, carried_from_before};
use crate::trajectory::Trajectory;
use crate::trajectory::sampled::Sampled;

/// Range of logged position (rad) above which a joint counts as excited: well above the
/// tracking error of a joint held still while the others move (below 1e-3 rad on the twin),
/// well below any excitation's amplitude.
pub const EXCITED_RANGE: f64 = 0.01;

/// How positions become velocities and accelerations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Route {
    /// Fit the Fourier series of a periodic excitation (the paper's route).
    Fourier {
        /// Base frequency, Hz.
        base_freq_hz: f64,
        /// Harmonics.
        harmonics: usize,
    },
    /// Rests held still and the least-jerk quintic spline through the samples between them
    /// (any motion; [`from_spline`]).
    Spline,
    /// Local polynomial smoothing (any motion); a smoothed joint slower than [`REST_SPEED`]
    /// at a sample gets zero velocity and acceleration there, so that Coulomb friction
    /// (whose sign the noise would otherwise flip) and its copper loss are not predicted for a
    /// joint held by stiction.
    Smoothing {
        /// Window, samples (odd).
        window: usize,
        /// Polynomial degree.
        degree: usize,
    },
}

/// A dataset ready for the estimators.
pub struct Prepared {
    /// The states the logged power belongs to, one per sample, stamped with the sample
    /// times: the states at the [`power_times`] (the sample times, or for a logger that
    /// averages power the middle of each sample period).
    pub states: States,
    /// A continuous motion through them (for energy integrals and predictions); its time 0
    /// is log time `motion_t0_s`.
    pub motion: Box<dyn Trajectory>,
    /// Log time (s) at the motion's time 0.
    pub motion_t0_s: f64,
    /// Measured power of the arm at the samples (of the kind `signal`), W.
    pub p_total: Vec<f64>,
    /// What `p_total` is.
    pub signal: PowerSignal,
    /// Per-motor power, sample-major `[m * n + i]`, W (empty when not logged).
    pub p_joint: Vec<f64>,
    /// Known payloads at the flange, sorted by time; the one the log starts with is in force
    /// from `-inf` ([`carried_from_before`]).
    pub payloads: Vec<PayloadEvent>,
    /// Joints that move (range of the logged position above [`EXCITED_RANGE`]), 0-based.
    pub excited: Vec<usize>,
    /// Whether the logger averaged power over each sample period.
    pub power_averaged: bool,
    /// For a logger that averages power: [`PERIOD_NODES`] states per sample (sample-major,
    /// stamped with their log times) at the middles of equal parts of the sample's period,
    /// whose mean model power is the sample's. The power at the period's middle alone misses
    /// the power's curvature over the period (the copper loss is convex in the torque, a bus
    /// clips): at 10 Hz the fit then pushes that gap into the copper coefficients and
    /// overpredicts slow, holding motions (docs/experiments.md#averaging-meter-over-its-period).
    /// `None` for an instantaneous meter.
    pub period_nodes: Option<States>,
}

/// States per sample period at which the model of an averaging logger's sample is taken (the
/// midpoint rule on equal parts: its error a sixteenth of the period's middle alone).
pub const PERIOD_NODES: usize = 4;

impl Prepared {
    /// The known payload timeline in the motion's time (for predictions along `motion`).
    pub fn motion_events(&self) -> Vec<PayloadEvent> {
        self.payloads
            .iter()
            .map(|e| PayloadEvent {
                t_s: e.t_s - self.motion_t0_s,
                payload: e.payload.clone(),
            })
            .collect()
    }

    /// Drop the samples at which an excited joint moves slower than `min_speed` (rad/s):
    /// around velocity reversals the sign of the Coulomb term is uncertain and the twin's
    /// stiction holds the joint, so those samples bias the friction estimates. Returns how many
    /// were dropped. Only for estimators that use samples one by one (not energy windows,
    /// which need consecutive samples).
    ///
    /// Errors: a negative or non-finite `min_speed`, or nothing left.
    pub fn drop_slow_samples(&mut self, min_speed: f64) -> Result<usize> {
        if !(min_speed.is_finite() && min_speed >= 0.0) {
            return Err(Error::InvalidInput(format!(
                "minimum speed {min_speed} rad/s must be finite and >= 0"
            )));
        }
        let n = self.states.q.len();
        let keep = self.states.moving(&self.excited, min_speed);
        if keep.is_empty() {
            return Err(Error::InvalidInput(format!(
                "no sample has every excited joint moving at >= {min_speed} rad/s"
            )));
        }
        let dropped = self.states.len() - keep.len();
        self.states = self.states.select(&keep);
        if let Some(nodes) = &self.period_nodes {
            let kept: Vec<usize> = keep
                .iter()
                .flat_map(|&m| (0..PERIOD_NODES).map(move |j| m * PERIOD_NODES + j))
                .collect();
            self.period_nodes = Some(nodes.select(&kept));
        }
        self.p_total = keep.iter().map(|&m| self.p_total[m]).collect();
        if !self.p_joint.is_empty() {
            self.p_joint = keep
                .iter()
                .flat_map(|&m| (0..n).map(move |i| m * n + i))
                .map(|k| self.p_joint[k])
                .collect();
        }
        Ok(dropped)
    }
}

/// Errors unless some log of `prepared` moves a joint: rests alone identify nothing but the
/// standby power.
pub fn ensure_motion(prepared: &[Prepared]) -> Result<()> {
    if prepared.iter().all(|p| p.excited.is_empty()) {
        return Err(Error::InvalidInput(
            "no joint moves in any log: nothing to identify (a log of the robot at rest pins \
             the standby power, beside logs of motion)"
                .into(),
        ));
    }
    Ok(())
}

/// Times (s, log time) the logged power belongs to, one per sample of `t` (s): the sample
/// times, or, when the logger averages power over each sample period, the middle of each
/// period `[t_k-1, t_k]`, where a smooth power takes its period's mean to second order (the
/// first sample, whose period precedes the log, keeps its own time). Taking the sample times
/// for an averaging logger lags the power by half a period
/// (docs/experiments.md#averaged-power-times).
pub fn power_times(t: &[f64], power_averaged: bool) -> Vec<f64> {
    (0..t.len())
        .map(|k| match k {
            k if k > 0 && power_averaged => 0.5 * (t[k - 1] + t[k]),
            _ => t[k],
        })
        .collect()
}

/// Times (s, log time) at which a model's power is taken for each logged power sample of the
/// sample times `t` (s), sample-major, and how many per sample: the sample times, one each, or,
/// when the logger averages power over each sample period, the [`PERIOD_NODES`] nodes of each
/// period, whose mean is the sample's (as the fit models it).
pub fn power_sample_nodes(t: &[f64], power_averaged: bool) -> (Vec<f64>, usize) {
    if power_averaged {
        (period_node_times(t), PERIOD_NODES)
    } else {
        (t.to_vec(), 1)
    }
}

/// The log times of the [`PERIOD_NODES`] nodes of each sample period `[t_k-1, t_k]` of the
/// sample times `t` (s), sample-major; the first sample's period is taken as long as the
/// second's.
fn period_node_times(t: &[f64]) -> Vec<f64> {
    let first = if t.len() > 1 { t[1] - t[0] } else { 0.0 };
    (0..t.len())
        .flat_map(|k| {
            let (a, b) = if k > 0 {
                (t[k - 1], t[k])
            } else {
                (t[0] - first, t[0])
            };
            (0..PERIOD_NODES).map(move |j| a + (j as f64 + 0.5) / PERIOD_NODES as f64 * (b - a))
        })
        .collect()
}

/// Prepare the log along `route`. A log in which no joint moves (a robot held at rest: its
/// standby and holding power) is prepared too, with no excited joint; identification needs
/// logs of motion beside it ([`ensure_motion`]).
pub fn prepare(log: &Log, route: Route) -> Result<Prepared> {
    prepare_lagged(log, route, 0.0)
}

/// [`prepare`] for power that lags the joints by `power_lag_s` s (positive: late): the
/// power sampled at `t` belongs to the states at `t - power_lag_s` (the motion extended
/// past its ends by its boundary polynomial or its period).
pub fn prepare_lagged(log: &Log, route: Route, power_lag_s: f64) -> Result<Prepared> {
    if !power_lag_s.is_finite() {
        return Err(Error::InvalidInput(format!(
            "power lag {power_lag_s} s must be finite"
        )));
    }
    log.validate()?;
    let t = &log.t_s;
    let (states, motion) = route_motion(t, &log.q_rad, route)?;
    let excited = excited_joints(&log.q_rad);
    let p_joint = motor_power_rows(log);
    let motion_t0_s = match route {
        Route::Fourier { .. } => 0.0,
        Route::Spline | Route::Smoothing { .. } => t[0],
    };
    let shift = (power_lag_s, motion_t0_s);
    let states = if log.power_averaged || power_lag_s != 0.0 {
        // The states of the power's times along the motion, stamped with the sample times.
        let times = power_times(t, log.power_averaged);
        States {
            t: t.clone(),
            ..states_along(motion.as_ref(), &times, shift)
        }
    } else {
        states
    };
    let period_nodes = log.power_averaged.then(|| {
        let t_nodes = period_node_times(t);
        let along = states_along(motion.as_ref(), &t_nodes, shift);
        States {
            t: t_nodes,
            ..along
        }
    });
    Ok(Prepared {
        period_nodes,
        states,
        motion,
        motion_t0_s,
        p_total: log.power_w.clone(),
        signal: log.signal,
        p_joint,
        payloads: carried_from_before(&log.payloads, t[0]),
        excited,
        power_averaged: log.power_averaged,
    })
}

/// The motion through the logged positions `q` (rad, joint-major) at the sample times `t`
/// (s, log time) along `route`, and the states at the sample times along it (the Fourier
/// series is fitted once and evaluated there; the spline and smoothing routes give the
/// states and interpolate them).
fn route_motion(t: &[f64], q: &[Vec<f64>], route: Route) -> Result<(States, Box<dyn Trajectory>)> {
    Ok(match route {
        Route::Fourier {
            base_freq_hz,
            harmonics,
        } => {
            let series = fit_fourier(t, q, base_freq_hz, harmonics)?.series;
            (from_fourier(&series, t), Box::new(series))
        }
        Route::Spline => {
            let route = from_spline(t, q)?;
            let m = sampled(&route.knots)?.with_move_weights(route.move_weights)?;
            (route.states, Box::new(m))
        }
        Route::Smoothing { window, degree } => {
            let mut s = from_smoothing(t, q, window, degree)?;
            for i in 0..q.len() {
                for m in 0..s.len() {
                    if s.dq[i][m].abs() < REST_SPEED {
                        s.dq[i][m] = 0.0;
                        s.ddq[i][m] = 0.0;
                    }
                }
            }
            let m = sampled(&s)?;
            (s, Box::new(m))
        }
    })
}

/// The quintic Hermite motion through the states `s` (positions, velocities and
/// accelerations at their times).
fn sampled(s: &States) -> Result<Sampled> {
    Sampled::new(
        s.t.clone(),
        s.q.clone(),
        Some(s.dq.clone()),
        Some(s.ddq.clone()),
    )
}

/// The joints (0-based) whose logged positions `q` (rad, joint-major) span more than
/// [`EXCITED_RANGE`].
fn excited_joints(q: &[Vec<f64>]) -> Vec<usize> {
    (0..q.len())
        .filter(|&i| {
            let (lo, hi) = q[i]
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(*v), b.max(*v))
                });
            hi - lo > EXCITED_RANGE
        })
        .collect()
}

/// The log's per-motor power (W), sample-major `[m * n + i]` (empty when not logged).
fn motor_power_rows(log: &Log) -> Vec<f64> {
    let n = log.q_rad.len();
    match &log.motor_power_w {
        Some(p) => (0..log.t_s.len())
            .flat_map(|k| (0..n).map(move |i| p[i][k]))
            .collect(),
        None => Vec::new(),
    }
}

/// The states along `motion` at the log times `times` (s) less the power's lag and the
/// motion's start, `shift = (power_lag_s, motion_t0_s)` (s); stamped with the motion's
/// times, for the caller to restamp.
fn states_along(
    motion: &dyn Trajectory,
    times: &[f64],
    (power_lag_s, motion_t0_s): (f64, f64),
) -> States {
    let at: Vec<f64> = times
        .iter()
        .map(|s| s - power_lag_s - motion_t0_s)
        .collect();
    from_fourier(motion, &at)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_averaging_loggers_sample_is_taken_over_its_period() {
        let t = [1.0, 1.1, 1.3];
        assert_eq!(power_sample_nodes(&t, false), (t.to_vec(), 1));
        let (nodes, per) = power_sample_nodes(&t, true);
        assert_eq!(per, PERIOD_NODES);
        assert_eq!(nodes.len(), t.len() * per);
        // Each sample's nodes lie inside its period, spread evenly about its middle; the
        // first sample's period precedes the log, as long as the second's.
        for (k, (a, b)) in [(0.9, 1.0), (1.0, 1.1), (1.1, 1.3)].into_iter().enumerate() {
            let own = &nodes[k * per..(k + 1) * per];
            assert!(
                own.iter().all(|x| *x > a && *x < b),
                "{own:?} in [{a}, {b}]"
            );
            let mean = own.iter().sum::<f64>() / per as f64;
            assert!((mean - 0.5 * (a + b)).abs() < 1e-12);
        }
    }
}
