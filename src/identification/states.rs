//! Joint states (q, dq, ddq) at the logged sample times: what the regressors are evaluated at.
//!
//! Routes, all from logged positions only:
//! - [`from_fourier`]: the paper's route for periodic excitation: the fitted series
//!   ([`crate::identification::fourier_fit`]) differentiated analytically;
//! - [`from_spline`]: the general route for any motion: rests found in the log are held
//!   exactly still, and each motion between them is the least-jerk quintic spline through the
//!   samples ([`crate::identification::spline`]), starting and stopping with zero velocity
//!   and acceleration at instants the displacements place inside the sample intervals next
//!   to the rests ([`SplineRoute::knots`]);
//! - [`from_smoothing`]: a local polynomial least-squares fit (Savitzky–Golay) around each
//!   sample, differentiated analytically. Near the ends the window is shifted inwards, so no
//!   sample is lost.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result, ensure_finite};
use crate::identification::rests::{
    EDGE_SIGMA_FLOOR, join_still_gaps, rest_jitter, rests_show_noise, stretches,
};
use crate::identification::spline::{End, quintic, smooth};
use crate::trajectory::Trajectory;

pub use crate::identification::rests::{
    DIFFERENCE_ORDERS, MIN_REST_DOF, REST_SPEED, REST_WINDOW_S, noise_levels, rest_intervals,
};

pub use crate::identification::tuning::{
    AGREED_NOISE_RATIO, EDGE_Z, EDGE_Z_AGREED, MOVE_Z, SLOPE_HALF_WINDOW_S, START_FROM_REST_RATIO,
    WHITE_RATIO,
};

/// States of every joint at sample times; vectors are joint-major (`q[i][m]`).
#[derive(Debug, Clone, PartialEq)]
pub struct States {
    /// Sample times, s.
    pub t: Vec<f64>,
    /// Positions, rad.
    pub q: Vec<Vec<f64>>,
    /// Velocities, rad/s.
    pub dq: Vec<Vec<f64>>,
    /// Accelerations, rad/s^2.
    pub ddq: Vec<Vec<f64>>,
}

impl States {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Append the samples of `other` (same joints): pools the data of several runs for
    /// estimators that use states one sample at a time (times are then not increasing).
    pub fn append(&mut self, other: &States) -> Result<()> {
        if other.q.len() != self.q.len() {
            return Err(Error::InvalidInput(format!(
                "cannot pool states of {} and {} joints",
                self.q.len(),
                other.q.len()
            )));
        }
        self.t.extend_from_slice(&other.t);
        for i in 0..self.q.len() {
            self.q[i].extend_from_slice(&other.q[i]);
            self.dq[i].extend_from_slice(&other.dq[i]);
            self.ddq[i].extend_from_slice(&other.ddq[i]);
        }
        Ok(())
    }

    /// Indices of the samples at which every joint of `joints` moves at `min_speed` (rad/s) or
    /// faster.
    pub fn moving(&self, joints: &[usize], min_speed: f64) -> Vec<usize> {
        (0..self.len())
            .filter(|&m| joints.iter().all(|&i| self.dq[i][m].abs() >= min_speed))
            .collect()
    }

    /// The samples `keep` (indices), in that order.
    pub fn select(&self, keep: &[usize]) -> States {
        let pick = |v: &[f64]| keep.iter().map(|&m| v[m]).collect::<Vec<f64>>();
        States {
            t: pick(&self.t),
            q: self.q.iter().map(|v| pick(v)).collect(),
            dq: self.dq.iter().map(|v| pick(v)).collect(),
            ddq: self.ddq.iter().map(|v| pick(v)).collect(),
        }
    }

    /// Copy the state of sample `m` into the three slices.
    pub fn at(&self, m: usize, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        for i in 0..self.q.len() {
            q[i] = self.q[i][m];
            dq[i] = self.dq[i][m];
            ddq[i] = self.ddq[i][m];
        }
    }
}

/// Sample a trajectory (e.g. a fitted Fourier series) at times `t` (s).
pub fn from_fourier(traj: &dyn Trajectory, t: &[f64]) -> States {
    let n = traj.dof();
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut s = States {
        t: t.to_vec(),
        q: vec![Vec::with_capacity(t.len()); n],
        dq: vec![Vec::with_capacity(t.len()); n],
        ddq: vec![Vec::with_capacity(t.len()); n],
    };
    for &tk in t {
        traj.sample(tk, &mut q, &mut dq, &mut ddq);
        for i in 0..n {
            s.q[i].push(q[i]);
            s.dq[i].push(dq[i]);
            s.ddq[i].push(ddq[i]);
        }
    }
    s
}

/// Smooth and differentiate positions `q[i][m]` (rad) sampled at times `t` (s, increasing)
/// with a local polynomial of `degree` (2..=6) over `window` samples (odd, > degree).
pub fn from_smoothing(t: &[f64], q: &[Vec<f64>], window: usize, degree: usize) -> Result<States> {
    let m = t.len();
    if !(2..=6).contains(&degree) || window.is_multiple_of(2) || window <= degree {
        return Err(Error::InvalidInput(format!(
            "smoothing needs an odd window > degree and a degree in 2..=6 (window {window}, degree {degree})"
        )));
    }
    if m < window {
        return Err(Error::InvalidInput(format!(
            "{m} samples are fewer than the smoothing window {window}"
        )));
    }
    check_samples(t, q)?;
    let half = window / 2;
    let mut s = States {
        t: t.to_vec(),
        q: vec![vec![0.0; m]; q.len()],
        dq: vec![vec![0.0; m]; q.len()],
        ddq: vec![vec![0.0; m]; q.len()],
    };
    for k in 0..m {
        let start = k.saturating_sub(half).min(m - window);
        let tc = t[k];
        // Polynomial in (t - t_k): value, first and second derivative are c0, c1, 2 c2.
        let x = DMatrix::from_fn(window, degree + 1, |r, c| {
            (t[start + r] - tc).powi(c as i32)
        });
        let svd = x.svd(true, true);
        for (i, qi) in q.iter().enumerate() {
            let y = DVector::from_fn(window, |r, _| qi[start + r]);
            let c = svd
                .solve(&y, 0.0)
                .map_err(|e| Error::Numerical(format!("smoothing fit failed: {e}")))?;
            s.q[i][k] = c[0];
            s.dq[i][k] = c[1];
            s.ddq[i][k] = 2.0 * c[2];
        }
    }
    Ok(s)
}

/// The spline route through a log ([`from_spline`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SplineRoute {
    /// States at the sample times: what the regressors are evaluated at.
    pub states: States,
    /// The route's knots: the sample times and the instants inside sample intervals at which
    /// a motion leaves or reaches a rest (by the `(t - t0)^3` law of a jerk-limited start
    /// through the motion's first two samples), at rest there. A quintic
    /// Hermite through them ([`crate::trajectory::sampled::Sampled`]) is the motion between
    /// the samples.
    pub knots: States,
    /// How clearly each joint is seen to move at each knot, in `[0, 1]` (`[i][k]`; 1 at the
    /// rests, where the route's speed is 0 anyway, and at the instants inside sample
    /// intervals): the weights of the expected Coulomb sign along the motion (see
    /// [`MOVE_Z`]).
    pub move_weights: Vec<Vec<f64>>,
}

/// States at the sample times `t` (s, increasing) of positions `q[i][m]` (rad) along the
/// rest-aware least-jerk route, and the knots of that route: the samples of each rest
/// ([`rest_intervals`]) are replaced by their mean and get zero velocity and acceleration;
/// each motion between rests is the least-jerk smoothing spline of its samples for the
/// joint's noise level ([`noise_levels`]; at 10 Hz practically the interpolating spline),
/// starting and ending at rest (or free at a log end that is not at rest, unless the log
/// begins as the robot starts from rest: [`starts_from_rest`]). A motion leaves (reaches) a
/// rest inside the sample interval next to it, at the instant the `(t - t0)^3` law of a
/// jerk-limited start places through the motion's first two samples; a rest's edge sample
/// that has already moved off the rest ([`EDGE_Z`], [`EDGE_Z_AGREED`]) belongs to the
/// motion.
///
/// Errors: fewer than 2 samples, series of the wrong length, non-finite values, times that
/// do not increase.
pub fn from_spline(t: &[f64], q: &[Vec<f64>]) -> Result<SplineRoute> {
    let m = t.len();
    if m < 2 {
        return Err(Error::InvalidInput(format!(
            "the spline route needs at least 2 samples, got {m}"
        )));
    }
    check_samples(t, q)?;
    let mut rest = rest_intervals(t, q);
    join_still_gaps(q, &mut rest);
    let n = q.len();
    let mut s = States {
        t: t.to_vec(),
        q: q.to_vec(),
        dq: vec![vec![0.0; m]; n],
        ddq: vec![vec![0.0; m]; n],
    };
    let stretches = stretches(&rest);
    let sigma = noise_levels(t, q, &rest);
    let jitter = rest_jitter(q, &rest);
    let (leave, reach) = hold_rests(t, q, &stretches, &jitter, &mut s);
    let extra = spline_moves(t, q, &stretches, &sigma, (&leave, &reach), &mut s)?;
    let knots = with_knots(&s, &extra);
    // The noise the log shows at its rests; where it has none to show, at least the assumed.
    let floor = if rests_show_noise(&rest) {
        0.0
    } else {
        ASSUMED_ENCODER_NOISE
    };
    let noise: Vec<f64> = sigma.iter().map(|s| s.max(floor)).collect();
    let move_weights = knot_weights(t, &knots, move_weights(t, q, &s.dq, &noise));
    Ok(SplineRoute {
        states: s,
        knots,
        move_weights,
    })
}

/// The first stage of [`from_spline`]: each rest's samples, less the edge samples the motions
/// next to it have already moved, held at their mean in `s`; returns the instants inside the
/// sample intervals next to each rest at which those motions leave and reach it, keyed by
/// the motion's sample next to the rest. `jitter`: each joint's [`rest_jitter`].
fn hold_rests(
    t: &[f64],
    q: &[Vec<f64>],
    stretches: &[(bool, usize, usize)],
    jitter: &[f64],
    s: &mut States,
) -> (Vec<Option<Edge>>, Vec<Option<Edge>>) {
    let m = t.len();
    let mut leave: Vec<Option<Edge>> = vec![None; m];
    let mut reach: Vec<Option<Edge>> = vec![None; m];
    for &(_, first, last) in stretches.iter().filter(|r| r.0) {
        let (mut a, mut b) = (first, last);
        let moved_start = b + 1 < m
            && b > a
            && edge_moved(t, q, jitter, b, a..b, b + 1, (b + 2 < m).then_some(b + 2));
        if moved_start {
            b -= 1;
        }
        let moved_stop =
            a > 0 && a < b && edge_moved(t, q, jitter, a, a + 1..b + 1, a - 1, a.checked_sub(2));
        if moved_stop {
            a += 1;
        }
        let means: Vec<f64> = q
            .iter()
            .map(|x| x[a..=b].iter().sum::<f64>() / (b - a + 1) as f64)
            .collect();
        for (x, mean) in s.q.iter_mut().zip(&means) {
            x[a..=b].fill(*mean);
        }
        // The motion after the rest: its first moving sample `b + 1` and the next.
        if b + 2 < m && (moved_start || b + 2 <= next_rest(stretches, last)) {
            let f = b + 1;
            let fraction = edge_fraction(t, q, jitter, &means, b, f, f + 1);
            leave[if moved_start { f } else { b }] = edge_instant(t, b, f, fraction, moved_start)
                .map(|at| Edge {
                    at,
                    held: means.clone(),
                });
        }
        if a >= 2 && (moved_stop || a - 2 >= previous_rest(stretches, first)) {
            let f = a - 1;
            let fraction = edge_fraction(t, q, jitter, &means, a, f, f - 1);
            reach[if moved_stop { f } else { a }] = edge_instant(t, a, f, fraction, moved_stop)
                .map(|at| Edge {
                    at,
                    held: means.clone(),
                });
        }
    }
    (leave, reach)
}

/// The second stage of [`from_spline`]: each motion between rests (of `stretches`) in `s`,
/// the least-jerk smoothing spline of its samples through the instants at which it leaves
/// and reaches its rests (`edges`: leave, reach, from [`hold_rests`]); returns those
/// instants' edges.
fn spline_moves<'a>(
    t: &[f64],
    q: &[Vec<f64>],
    stretches: &[(bool, usize, usize)],
    sigma: &[f64],
    edges: (&'a [Option<Edge>], &'a [Option<Edge>]),
    s: &mut States,
) -> Result<Vec<&'a Edge>> {
    let m = t.len();
    let (leave, reach) = edges;
    // A motion next to a rest starts or stops there, and so does one that the log's first
    // samples show starting from rest ([`starts_from_rest`]). At a log end it runs on beyond
    // the log (free), unless the free spline's end speed is one the samples do not support
    // ([`unsupported_end_speed`]): then the motion starts (stops) at rest there.
    let end = |next_to_rest: bool| if next_to_rest { End::Rest } else { End::Free };
    let mut extra: Vec<&Edge> = Vec::new();
    for &(_, first, last) in stretches.iter().filter(|r| !r.0) {
        let (from, to) = (&leave[first], &reach[last]);
        // The samples the spline passes through: a rest sample next to an instant inside the
        // interval stays held.
        let lo = first + usize::from(from.as_ref().is_some_and(|e| e.at > t[first]));
        let hi = last - usize::from(to.as_ref().is_some_and(|e| e.at < t[last]));
        let mut times = Vec::with_capacity(hi - lo + 3);
        times.extend(from.as_ref().map(|e| e.at));
        times.extend_from_slice(&t[lo..=hi]);
        times.extend(to.as_ref().map(|e| e.at));
        extra.extend(from.iter().chain(to.iter()));
        let lead = usize::from(from.is_some());
        let len = times.len();
        let from_rest = first > 0 || starts_from_rest(t, q);
        for (i, (((x, v), a), &sigma)) in
            s.q.iter_mut()
                .zip(&mut s.dq)
                .zip(&mut s.ddq)
                .zip(sigma)
                .enumerate()
        {
            let mut samples = Vec::with_capacity(len);
            samples.extend(from.as_ref().map(|e| e.held[i]));
            samples.extend_from_slice(&x[lo..=hi]);
            samples.extend(to.as_ref().map(|e| e.held[i]));
            let (mut start, mut stop) = (end(from_rest), end(last < m - 1));
            let mut smoothed = smooth(&times, &samples, start, stop, sigma)?;
            let (mut vel, mut acc) = quintic(&times, &smoothed, start, stop)?;
            let rest_start = start == End::Free
                && unsupported_end_speed(vel[0], smoothed[1] - smoothed[0], times[1] - times[0]);
            let rest_stop = stop == End::Free
                && unsupported_end_speed(
                    vel[len - 1],
                    smoothed[len - 1] - smoothed[len - 2],
                    times[len - 1] - times[len - 2],
                );
            if rest_start {
                start = End::Rest;
            }
            if rest_stop {
                stop = End::Rest;
            }
            if rest_start || rest_stop {
                smoothed = smooth(&times, &samples, start, stop, sigma)?;
                (vel, acc) = quintic(&times, &smoothed, start, stop)?;
            }
            let on_samples = lead..lead + hi - lo + 1;
            x[lo..=hi].copy_from_slice(&smoothed[on_samples.clone()]);
            v[lo..=hi].copy_from_slice(&vel[on_samples.clone()]);
            a[lo..=hi].copy_from_slice(&acc[on_samples]);
        }
    }
    Ok(extra)
}

/// The last stage of [`from_spline`]: the move weights at the route's knots from those at the
/// samples `t` (`at_samples[i][sample]`). The knots are the sample times and the instants
/// inside intervals, which get weight 1: the motion next to them is seen from its own
/// samples.
fn knot_weights(t: &[f64], knots: &States, at_samples: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let m = t.len();
    at_samples
        .iter()
        .map(|w| {
            let mut sample = 0;
            knots
                .t
                .iter()
                .map(|&at| {
                    if sample < m && at == t[sample] {
                        sample += 1;
                        w[sample - 1]
                    } else {
                        1.0
                    }
                })
                .collect()
        })
        .collect()
}

/// Encoder noise (rad) the rest test is built for ([`REST_SPEED`] x [`REST_WINDOW_S`] is
/// seven standard deviations of the difference of two samples): the route's move weights
/// ([`SplineRoute::move_weights`]) assume at least this much where the log has no rests to
/// show its own ([`noise_levels`] then estimates it from each joint's differences, and gives
/// 0 where the motion hides it).
pub const ASSUMED_ENCODER_NOISE: f64 =
    REST_SPEED * REST_WINDOW_S / (7.0 * std::f64::consts::SQRT_2);

/// How clearly each joint is seen to move at each sample, in `[0, 1]` (`[i][k]`): from
/// `z = |b| / sd(b)` by [`MOVE_Z`], with `b` the slope (rad/s) of the straight line through
/// the joint's logged positions `q` within [`SLOPE_HALF_WINDOW_S`] of the sample (at least
/// one neighbour on each side) and `sd(b) = sigma_i / sqrt(sum (t - mean t)^2)` its standard
/// deviation under the joint's encoder noise `sigma_i` (rad; `z` is infinite for any slope
/// but 0 without noise). A joint whose route speed `dq` is 0 there gets 1 (no sign to weigh, and no
/// weight falling across the next interval, where it may move). The slope of a parabola through
/// the window is its speed at the sample, so a joint that moves, reversals included, gets
/// about 1; one that stands still while the others move gets the chance that noise alone
/// shows no trend: its Coulomb torque, whose sign the noise would pick, is then expected at
/// zero ([`crate::trajectory::Trajectory::coulomb_signs`]).
fn move_weights(t: &[f64], q: &[Vec<f64>], dq: &[Vec<f64>], sigma: &[f64]) -> Vec<Vec<f64>> {
    let m = t.len();
    q.iter()
        .zip(dq)
        .zip(sigma)
        .map(|((x, v), &sd)| {
            (0..m)
                .map(|k| {
                    if v[k] == 0.0 {
                        return 1.0;
                    }
                    let near = |j: usize| (t[j] - t[k]).abs() <= SLOPE_HALF_WINDOW_S * (1.0 + 1e-9);
                    let mut lo = k.saturating_sub(1);
                    while lo > 0 && near(lo - 1) {
                        lo -= 1;
                    }
                    let mut hi = (k + 1).min(m - 1);
                    while hi + 1 < m && near(hi + 1) {
                        hi += 1;
                    }
                    let len = (hi - lo + 1) as f64;
                    let tm = t[lo..=hi].iter().sum::<f64>() / len;
                    let xm = x[lo..=hi].iter().sum::<f64>() / len;
                    let (mut stt, mut stx) = (0.0, 0.0);
                    for j in lo..=hi {
                        stt += (t[j] - tm).powi(2);
                        stx += (t[j] - tm) * (x[j] - xm);
                    }
                    // Without noise any slope but 0 is a motion.
                    let z = match (stx / stt).abs() * stt.sqrt() {
                        0.0 => 0.0,
                        b if sd == 0.0 => b * f64::INFINITY,
                        b => b / sd,
                    };
                    ((z - MOVE_Z.still) / (MOVE_Z.moving - MOVE_Z.still)).clamp(0.0, 1.0)
                })
                .collect()
        })
        .collect()
}

/// An instant inside a sample interval at which a motion leaves or reaches a rest.
#[derive(Debug, Clone)]
struct Edge {
    /// Time, s.
    at: f64,
    /// The rest's positions, rad.
    held: Vec<f64>,
}

/// First sample of the rest after the rest stretch ending at sample `last` (`usize::MAX` if
/// none).
fn next_rest(stretches: &[(bool, usize, usize)], last: usize) -> usize {
    stretches
        .iter()
        .find(|r| r.0 && r.1 > last)
        .map_or(usize::MAX, |r| r.1)
}

/// Last sample of the rest before the rest stretch starting at sample `first` (0 if none).
fn previous_rest(stretches: &[(bool, usize, usize)], first: usize) -> usize {
    stretches
        .iter()
        .rev()
        .find(|r| r.0 && r.2 < first)
        .map_or(0, |r| r.2)
}

/// Whether a rest's edge sample `edge` has already moved off the rest samples `rest` toward
/// the motion's sample `toward` (its neighbour): its shift off their mean along the direction
/// from `edge` to `toward`, weighed by each joint's noise `sigma` (rad), is at least
/// [`EDGE_Z`] standard deviations, or [`EDGE_Z_AGREED`] where the motion's samples `toward`
/// and `beyond` place the start (stop) on the rest's side of `edge` ([`edge_fraction`]).
fn edge_moved(
    t: &[f64],
    q: &[Vec<f64>],
    sigma: &[f64],
    edge: usize,
    rest: std::ops::Range<usize>,
    toward: usize,
    beyond: Option<usize>,
) -> bool {
    if rest.is_empty() {
        return false;
    }
    let count = rest.len() as f64;
    let (mut num, mut den) = (0.0, 0.0);
    let mut held = Vec::with_capacity(q.len());
    for (x, s) in q.iter().zip(sigma) {
        let mean = x[rest.clone()].iter().sum::<f64>() / count;
        held.push(mean);
        let var = s.max(EDGE_SIGMA_FLOOR).powi(2) * (1.0 + 1.0 / count);
        let dir = x[toward] - x[edge];
        num += dir * (x[edge] - mean) / var;
        den += dir * dir / var;
    }
    if den <= 0.0 {
        return false;
    }
    let z = num / den.sqrt();
    // Weaker evidence suffices where the motion's own samples place its start (stop) on the
    // far side of the edge sample.
    let before = beyond.is_some_and(|g| edge_fraction(t, q, sigma, &held, edge, toward, g) < 0.0);
    z >= EDGE_Z || (before && z >= EDGE_Z_AGREED)
}

/// The instant (s) inside the sample interval between a rest's last sample `inner` and the
/// motion's first `f` (going back in time for a motion that reaches the rest) at which the
/// motion leaves (reaches) the rest, `fraction` of the way from `inner` to `f`
/// ([`edge_fraction`]), or `None` if it does so at `inner`. Kept within the middle 90 % of
/// the interval; at least 5 % from `inner` if `moved` (the sample `f` was a rest's edge
/// sample that has already moved off).
fn edge_instant(t: &[f64], inner: usize, f: usize, fraction: f64, moved: bool) -> Option<f64> {
    match fraction {
        x if x >= 0.05 => Some(t[inner] + x.min(0.95) * (t[f] - t[inner])),
        _ if moved => Some(t[inner] + 0.05 * (t[f] - t[inner])),
        _ => None,
    }
}

/// Where between the rest's sample `inner` (0) and the motion's first sample `f` (1) the
/// motion leaves (reaches) the rest held at `held` (rad); negative when it places the instant
/// beyond `inner`, inside the rest. A jerk-limited start leaves a rest as `(t - t0)^3`, as
/// the least-jerk spline does, so with the motion a fraction `r` as far from the rest at `f`
/// as at the next sample `g` (least squares over the joints, weighed by their noise
/// `sigma`), `(t_f - t0) / (t_g - t0) = r^(1/3)` (a constant-acceleration start would put
/// the instant later; this puts such a start earlier, toward the rest sample;
/// docs/experiments.md#rest-edges).
fn edge_fraction(
    t: &[f64],
    q: &[Vec<f64>],
    sigma: &[f64],
    held: &[f64],
    inner: usize,
    f: usize,
    g: usize,
) -> f64 {
    // Where the motion is a fraction `ratio` as far from the rest at `f` as at `g`, it left
    // (reaches) the rest this fraction of the interval away from `inner`.
    let fraction_at = |ratio: f64| {
        let root = ratio.clamp(0.0, 1.0).cbrt().min(0.99);
        let t0 = (t[f] - root * t[g]) / (1.0 - root);
        (t0 - t[inner]) / (t[f] - t[inner])
    };
    let (mut num, mut den) = (0.0, 0.0);
    // A joint already clearly off the rest at `f` bounds the instant on its own: joints that
    // do not start together (stick-slip, a joint the controller moves first) must not be
    // hurried by the others.
    let mut earliest = f64::INFINITY;
    for ((x, s), r) in q.iter().zip(sigma).zip(held) {
        let var = s.max(EDGE_SIGMA_FLOOR).powi(2);
        num += (x[g] - r) * (x[f] - r) / var;
        den += (x[g] - r) * (x[g] - r) / var;
        if (x[f] - r).abs() >= EDGE_Z * var.sqrt() {
            // One that went the other way first was on its way well before.
            let own = (x[f] - r) / (x[g] - r);
            earliest = earliest.min(if own > 0.0 { fraction_at(own) } else { 0.0 });
        }
    }
    let ratio = if den > 0.0 { num / den } else { 0.0 };
    fraction_at(ratio).min(earliest)
}

/// `s` with the knots `extra` (at rest) merged in by time.
fn with_knots(s: &States, extra: &[&Edge]) -> States {
    let mut order: Vec<(f64, Option<usize>)> = s.t.iter().map(|&at| (at, None)).collect();
    order.extend(extra.iter().enumerate().map(|(k, e)| (e.at, Some(k))));
    order.sort_by(|x, y| x.0.total_cmp(&y.0));
    let n = s.q.len();
    let mut out = States {
        t: order.iter().map(|o| o.0).collect(),
        q: vec![Vec::with_capacity(order.len()); n],
        dq: vec![Vec::with_capacity(order.len()); n],
        ddq: vec![Vec::with_capacity(order.len()); n],
    };
    let mut sample = 0;
    for (_, e) in &order {
        for i in 0..n {
            let (x, v, a) = match e {
                Some(k) => (extra[*k].held[i], 0.0, 0.0),
                None => (s.q[i][sample], s.dq[i][sample], s.ddq[i][sample]),
            };
            out.q[i].push(x);
            out.dq[i].push(v);
            out.ddq[i].push(a);
        }
        if e.is_none() {
            sample += 1;
        }
    }
    out
}

/// Whether a free spline end's speed `v` (rad/s) is one the samples do not support. Over the
/// sample interval of `h` s next to the end the joint moves `dx` (rad, the later sample less
/// the earlier); one that leaves (reaches) the end at speed `v` covers at least half of
/// `|v| h` in the direction of `v` unless it reverses within the interval. When `dx` falls
/// short of that, the joint starts (stops) at rest there or is held by stiction, and the
/// free end's quartic extrapolates a speed the samples do not show
/// (docs/experiments.md#starts-from-rest).
pub fn unsupported_end_speed(v: f64, dx: f64, h: f64) -> bool {
    dx * v.signum() < 0.5 * v.abs() * h
}

/// Whether a log's first samples, positions `q[i][m]` (rad) at times `t[m]` (s, increasing),
/// show the robot starting from rest at the first one: over the second interval the joints
/// move at least [`START_FROM_REST_RATIO`] times as fast as over the first. The motion then
/// starts at rest there instead of already moving, as the free end's quartic through the
/// first samples would have it (with every joint's Coulomb torque switched on at a sample
/// where the robot still stands; docs/experiments.md#starts-from-rest). False with fewer
/// than 3 samples (of `t` or of any joint).
pub fn starts_from_rest(t: &[f64], q: &[Vec<f64>]) -> bool {
    if t.len() < 3 || q.iter().any(|qi| qi.len() < 3) {
        return false;
    }
    let speed =
        |k: usize| q.iter().map(|qi| (qi[k + 1] - qi[k]).abs()).sum::<f64>() / (t[k + 1] - t[k]);
    let (first, second) = (speed(0), speed(1));
    second > 0.0 && second >= START_FROM_REST_RATIO * first
}

/// Check sample times (finite, strictly increasing) and position series (one per joint, as
/// long as `t`, finite).
fn check_samples(t: &[f64], q: &[Vec<f64>]) -> Result<()> {
    let m = t.len();
    ensure_finite(t, "t")?;
    if let Some(k) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(Error::InvalidInput(format!(
            "sample times must increase (sample {})",
            k + 2
        )));
    }
    for (i, c) in q.iter().enumerate() {
        if c.len() != m {
            return Err(Error::InvalidInput(format!(
                "q{} has {} samples, t has {m}",
                i + 1,
                c.len()
            )));
        }
        ensure_finite(c, &format!("q{}", i + 1))?;
    }
    Ok(())
}
