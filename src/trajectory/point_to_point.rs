//! Rest-to-rest point-to-point motion through joint configurations.
//!
//! Every segment from via point `A` to via point `B` is the quintic (minimum-jerk) blend
//!
//! ```text
//! q(t) = A + (B - A) p(s),   p(s) = 10 s^3 - 15 s^4 + 6 s^5,   s = (t - t_A) / T
//! ```
//!
//! which starts and ends with zero velocity and acceleration and never overshoots. With
//! `D_i = |B_i - A_i|`, the peaks are `|dq_i| = 15/8 D_i / T` (at `s = 1/2`) and
//! `|ddq_i| = 10/sqrt(3) D_i / T^2` (at `s = (1 -+ 1/sqrt(3)) / 2`), so the shortest
//! duration meeting velocity limits `vmax` and acceleration limits `amax` is, in closed form,
//!
//! ```text
//! T = max_i max( 15/8 D_i / vmax_i,  sqrt(10/sqrt(3) D_i / amax_i) )
//! ```
//!
//! multiplied by a slow-down factor (>= 1). Optionally the robot dwells at every via point,
//! including the first and the last.

use crate::error::{Error, Result, ensure_finite};

use super::Trajectory;

/// Peak of `p'(s)` of the quintic blend.
const PEAK_VELOCITY: f64 = 15.0 / 8.0;
/// Peak of `|p''(s)|` of the quintic blend, `10 / sqrt(3)`.
const PEAK_ACCELERATION: f64 = 5.773_502_691_896_258;

/// Timing options of a [`PointToPoint`] motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointToPointOptions {
    /// Factor (>= 1) applied to every limit-optimal segment duration; 1 runs at the limits.
    pub slowdown: f64,
    /// Time spent standing at every via point, including the first and the last, s (>= 0).
    pub dwell_s: f64,
}

impl Default for PointToPointOptions {
    /// No slow-down, no dwell.
    fn default() -> Self {
        PointToPointOptions {
            slowdown: 1.0,
            dwell_s: 0.0,
        }
    }
}

/// One piece of the motion: a blend from one via point to the next, or a dwell (`from == to`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    /// Start time, s.
    start: f64,
    /// Duration, s (> 0).
    duration: f64,
    from: usize,
    to: usize,
}

/// A rest-to-rest motion through via points (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct PointToPoint {
    points: Vec<Vec<f64>>,
    arrivals: Vec<f64>,
    pieces: Vec<Piece>,
    duration: f64,
}

impl PointToPoint {
    /// A motion through `points` (each a joint configuration, rad; at least 2) with
    /// per-joint velocity limits `vmax` (rad/s) and acceleration limits `amax` (rad/s^2),
    /// both positive. Errors ([`Error::InvalidInput`]): fewer than 2 points, points of
    /// different lengths, non-finite values, non-positive limits, `slowdown < 1`, negative
    /// dwell, or a motion of zero duration (all points equal and no dwell);
    /// [`Error::Numerical`] when the planned duration is not finite.
    pub fn new(
        points: Vec<Vec<f64>>,
        vmax: &[f64],
        amax: &[f64],
        options: &PointToPointOptions,
    ) -> Result<PointToPoint> {
        let dof = check_points(&points)?;
        check_limits(dof, vmax, amax)?;
        check_options(options)?;
        let (pieces, arrivals, t) = plan_pieces(&points, vmax, amax, options);
        if pieces.is_empty() {
            return Err(Error::InvalidInput(
                "all via points coincide and there is no dwell: the motion has zero duration"
                    .into(),
            ));
        }
        if !t.is_finite() {
            return Err(Error::Numerical(format!(
                "the motion's duration {t} s is not finite"
            )));
        }
        Ok(PointToPoint {
            points,
            arrivals,
            pieces,
            duration: t,
        })
    }

    /// The via points, rad.
    pub fn points(&self) -> &[Vec<f64>] {
        &self.points
    }

    /// Time at which each via point is reached (the start of its dwell), s.
    pub fn arrival_times(&self) -> &[f64] {
        &self.arrivals
    }
}

/// Checks that there are at least 2 via points, all with the same non-zero number of
/// joints and finite coordinates (rad); returns that number of joints.
fn check_points(points: &[Vec<f64>]) -> Result<usize> {
    if points.len() < 2 {
        return Err(Error::InvalidInput(format!(
            "a point-to-point motion needs at least 2 points, got {}",
            points.len()
        )));
    }
    let dof = points[0].len();
    if dof == 0 {
        return Err(Error::InvalidInput("via points without joints".into()));
    }
    for (k, p) in points.iter().enumerate() {
        if p.len() != dof {
            return Err(Error::InvalidInput(format!(
                "via point {} has {} joints, point 1 has {dof}",
                k + 1,
                p.len()
            )));
        }
        ensure_finite(p, &format!("via point {}", k + 1))?;
    }
    Ok(dof)
}

/// Checks that the velocity limits `vmax` (rad/s) and acceleration limits `amax` (rad/s^2)
/// have `dof` values each, all finite and positive (`vmax` first).
fn check_limits(dof: usize, vmax: &[f64], amax: &[f64]) -> Result<()> {
    for (name, lim) in [("vmax", vmax), ("amax", amax)] {
        if lim.len() != dof {
            return Err(Error::InvalidInput(format!(
                "{name} has {} values, the via points have {dof} joints",
                lim.len()
            )));
        }
        if let Some(i) = lim.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(Error::InvalidInput(format!(
                "{name}[{}] is {} (must be finite and positive)",
                i + 1,
                lim[i]
            )));
        }
    }
    Ok(())
}

/// Checks that the slow-down factor is finite and at least 1, and the dwell time (s) finite
/// and non-negative.
fn check_options(options: &PointToPointOptions) -> Result<()> {
    let PointToPointOptions { slowdown, dwell_s } = *options;
    if !(slowdown.is_finite() && slowdown >= 1.0) {
        return Err(Error::InvalidInput(format!(
            "slow-down factor {slowdown} must be finite and at least 1"
        )));
    }
    if !(dwell_s.is_finite() && dwell_s >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "dwell time {dwell_s} s must be finite and non-negative"
        )));
    }
    Ok(())
}

/// Lays out the pieces in time: the options' dwell (s) at every via point and the shortest
/// blend, stretched by the slow-down factor, between consecutive ones, skipping pieces of zero
/// duration. Returns the pieces, the arrival time at each via point (s) and the total
/// duration (s).
fn plan_pieces(
    points: &[Vec<f64>],
    vmax: &[f64],
    amax: &[f64],
    options: &PointToPointOptions,
) -> (Vec<Piece>, Vec<f64>, f64) {
    let PointToPointOptions { slowdown, dwell_s } = *options;
    let mut pieces = Vec::with_capacity(2 * points.len());
    let mut arrivals = Vec::with_capacity(points.len());
    let mut t = 0.0;
    let mut push = |t: &mut f64, duration: f64, from: usize, to: usize| {
        if duration > 0.0 {
            pieces.push(Piece {
                start: *t,
                duration,
                from,
                to,
            });
            *t += duration;
        }
    };
    for k in 0..points.len() {
        if k > 0 {
            let d = slowdown * min_duration(&points[k - 1], &points[k], vmax, amax);
            push(&mut t, d, k - 1, k);
        }
        arrivals.push(t);
        push(&mut t, dwell_s, k, k);
    }
    (pieces, arrivals, t)
}

/// Shortest quintic blend duration from `a` to `b` within `vmax`, `amax` (s).
fn min_duration(a: &[f64], b: &[f64], vmax: &[f64], amax: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .zip(vmax.iter().zip(amax))
        .map(|((x, y), (v, acc))| {
            let d = (y - x).abs();
            (PEAK_VELOCITY * d / v).max((PEAK_ACCELERATION * d / acc).sqrt())
        })
        .fold(0.0, f64::max)
}

impl Trajectory for PointToPoint {
    fn dof(&self) -> usize {
        self.points[0].len()
    }

    fn duration(&self) -> f64 {
        self.duration
    }

    fn sample(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        let t = t.clamp(0.0, self.duration);
        let k = self
            .pieces
            .partition_point(|p| p.start <= t)
            .saturating_sub(1);
        let piece = &self.pieces[k];
        let s = ((t - piece.start) / piece.duration).clamp(0.0, 1.0);
        let s2 = s * s;
        let p = s2 * s * (10.0 + s * (-15.0 + s * 6.0));
        let dp = s2 * (30.0 + s * (-60.0 + s * 30.0)) / piece.duration;
        let ddp = s * (60.0 + s * (-180.0 + s * 120.0)) / (piece.duration * piece.duration);
        let ends = self.points[piece.from].iter().zip(&self.points[piece.to]);
        let outputs = q.iter_mut().zip(dq.iter_mut()).zip(ddq.iter_mut());
        for ((a, b), ((qi, dqi), ddqi)) in ends.zip(outputs) {
            let d = b - a;
            *qi = a + d * p;
            *dqi = d * dp;
            *ddqi = d * ddp;
        }
    }
}
