//! A trajectory through time-stamped joint samples, smoothly interpolated.
//!
//! Which interpolant is used depends on what the samples carry ([`Interpolation`]):
//!
//! * positions, velocities and accelerations: quintic Hermite per interval. The curve passes
//!   through every sample with the given velocity and acceleration, so it is C2.
//! * positions and velocities: cubic Hermite per interval (C1; the acceleration jumps at the
//!   samples).
//! * positions only: a C2 cubic spline. Per joint and per end, the end condition is chosen
//!   from the data: a joint whose first two position samples are equal (bit for bit) is taken
//!   to start at rest and its spline is *clamped* to zero velocity at the start; otherwise the
//!   start is *natural* (zero acceleration). The end is treated the same way with the last two
//!   samples. Recorded motions that begin and end standing still therefore also begin and end
//!   with zero interpolated velocity.
//!
//! Trajectory time is measured from the first sample: `tau = t - t_0` (s), so the trajectory
//! is defined on `[0, t_last - t_0]`; [`Sampled::start_time`] returns `t_0`.

use crate::dynamics::sign;
use crate::error::{Error, Result};
use crate::io::table::Table;

use super::Trajectory;

/// How a [`Sampled`] trajectory interpolates between samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    /// Quintic Hermite through positions, velocities and accelerations (C2).
    QuinticHermite,
    /// Cubic Hermite through positions and velocities (C1).
    CubicHermite,
    /// C2 cubic spline through positions (clamped to zero velocity at an end where the joint
    /// is at rest, natural otherwise).
    CubicSpline,
}

/// A trajectory interpolating time-stamped joint samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Sampled {
    /// Time of the first sample, s.
    start_time: f64,
    /// Sample times relative to the first sample, s (strictly increasing, starts at 0).
    knots: Vec<f64>,
    dof: usize,
    /// Polynomial coefficients in `s = tau - knots[k]` (s), ascending powers, of joint `i` on
    /// interval `k` at index `i * (knots.len() - 1) + k`; units rad / s^p.
    coeffs: Vec<[f64; 6]>,
    interpolation: Interpolation,
    /// How clearly each joint is seen to move at each sample, in `[0, 1]`, joint-major
    /// (`[i][k]`); `None`: every moving joint fully.
    move_weights: Option<Vec<Vec<f64>>>,
}

/// A validation failure located at a sample (0-based) or not located.
struct Invalid {
    sample: Option<usize>,
    message: String,
}

impl Invalid {
    fn at(sample: usize, message: String) -> Self {
        Invalid {
            sample: Some(sample),
            message,
        }
    }

    fn general(message: String) -> Self {
        Invalid {
            sample: None,
            message,
        }
    }
}

impl Sampled {
    /// Interpolate samples.
    ///
    /// `t`: sample times, s, strictly increasing, at least 2. `q[i][k]`: position of joint `i`
    /// at `t[k]`, rad (joint-major). `dq`, `ddq`: optional velocities (rad/s) and accelerations
    /// (rad/s^2) in the same layout; `ddq` requires `dq`. The interpolant follows from what is
    /// given (see the [module docs](self)).
    ///
    /// Errors ([`Error::InvalidInput`], naming the 1-based sample): fewer than 2 samples, no
    /// joint, series of the wrong length, non-finite values, times not strictly increasing,
    /// `ddq` without `dq`.
    pub fn new(
        t: Vec<f64>,
        q: Vec<Vec<f64>>,
        dq: Option<Vec<Vec<f64>>>,
        ddq: Option<Vec<Vec<f64>>>,
    ) -> Result<Sampled> {
        Self::build(&t, &q, dq.as_deref(), ddq.as_deref()).map_err(|e| {
            Error::InvalidInput(match e.sample {
                Some(k) => format!("sample {}: {}", k + 1, e.message),
                None => e.message,
            })
        })
    }

    /// Read samples from a table: time column `t_s` or `t` (s), positions `q1..qn` (rad,
    /// also `q1_rad`...) required; velocities `dq1..dqn` (`dq1_rad_s`...) and accelerations
    /// `ddq1..ddqn` (`ddq1_rad_s2`...) optional, each kind all or none. `dof` is the number of
    /// joints to read.
    ///
    /// Errors ([`Error::Table`], naming the row, header = row 1): missing columns, a kind
    /// given for only some joints, fewer than 2 data rows, times not strictly increasing,
    /// accelerations without velocities. `dof == 0` is [`Error::InvalidInput`].
    pub fn from_table(table: &Table, dof: usize) -> Result<Sampled> {
        if dof == 0 {
            return Err(Error::InvalidInput(
                "a sampled trajectory needs at least one joint".into(),
            ));
        }
        let table_err = |row: usize, message: String| Error::Table {
            file: table.label().to_string(),
            row,
            message,
        };
        let t = table.column(&["t_s", "t"])?.to_vec();
        let q = owned(table.joint_columns("q", "rad", dof)?);
        let dq = optional_kind(table, "dq", "rad_s", dof)?;
        let ddq = optional_kind(table, "ddq", "rad_s2", dof)?;
        Self::build(&t, &q, dq.as_deref(), ddq.as_deref())
            .map_err(|e| table_err(e.sample.map_or(1, |k| k + 2), e.message))
    }

    /// Time of the first sample, s; trajectory time `tau` corresponds to sample time
    /// `start_time + tau`.
    pub fn start_time(&self) -> f64 {
        self.start_time
    }

    /// The same motion with the expected sign of each joint's Coulomb friction
    /// ([`Trajectory::coulomb_signs`]) weighed down by `weights[i][k]` in `[0, 1]`: how
    /// clearly joint `i` is seen to move at sample `k` (linear between samples). An estimate
    /// of the motion from noisy positions gives a joint that stands still while the others
    /// move speeds of the noise's size, whose signs would switch its full Coulomb torque.
    /// Such an estimate also swings back next to a rest when the joint breaks away late (or
    /// overshoots as it stops), so a joint moving in an interval next to a sample at rest
    /// takes the sign of its displacement over that interval, the way it leaves or reaches
    /// the rest.
    ///
    /// Errors ([`Error::InvalidInput`]): not one weight per joint and sample, or a weight
    /// outside `[0, 1]`.
    pub fn with_move_weights(mut self, weights: Vec<Vec<f64>>) -> Result<Self> {
        if weights.len() != self.dof || weights.iter().any(|w| w.len() != self.knots.len()) {
            return Err(Error::InvalidInput(format!(
                "move weights need {} joints of {} samples",
                self.dof,
                self.knots.len()
            )));
        }
        if weights.iter().flatten().any(|w| !(0.0..=1.0).contains(w)) {
            return Err(Error::InvalidInput("move weights must be in [0, 1]".into()));
        }
        self.move_weights = Some(weights);
        Ok(self)
    }

    /// The interval `k` holding trajectory time `t` (s, clamped to the knots) and the time
    /// from its start, s.
    fn interval(&self, t: f64) -> (usize, f64) {
        let intervals = self.knots.len() - 1;
        let tau = t.clamp(0.0, self.duration());
        let k = self
            .knots
            .partition_point(|&x| x <= tau)
            .saturating_sub(1)
            .min(intervals - 1);
        (k, tau - self.knots[k])
    }

    /// Sample times relative to the first sample, s (strictly increasing, from 0).
    pub fn sample_times(&self) -> &[f64] {
        &self.knots
    }

    /// The interpolant in use.
    pub fn interpolation(&self) -> Interpolation {
        self.interpolation
    }

    fn build(
        t: &[f64],
        q: &[Vec<f64>],
        dq: Option<&[Vec<f64>]>,
        ddq: Option<&[Vec<f64>]>,
    ) -> std::result::Result<Sampled, Invalid> {
        check_samples(t, q, dq, ddq)?;
        let dof = q.len();
        let knots: Vec<f64> = t.iter().map(|&v| v - t[0]).collect();
        let (coeffs, interpolation) = interpolate(&knots, q, dq, ddq);
        if let Some(c) = coeffs.iter().flatten().find(|c| !c.is_finite()) {
            return Err(Invalid::general(format!(
                "interpolation overflowed (coefficient {c}); are the sample times too close?"
            )));
        }
        Ok(Sampled {
            start_time: t[0],
            knots,
            dof,
            coeffs,
            interpolation,
            move_weights: None,
        })
    }
}

/// Check the samples of [`Sampled::build`]: at least 2 times (s), finite and strictly
/// increasing, at least one joint, velocities whenever accelerations are given, and every
/// given series with one finite value per joint and sample.
fn check_samples(
    t: &[f64],
    q: &[Vec<f64>],
    dq: Option<&[Vec<f64>]>,
    ddq: Option<&[Vec<f64>]>,
) -> std::result::Result<(), Invalid> {
    let n = t.len();
    if n < 2 {
        return Err(Invalid::general(format!(
            "a sampled trajectory needs at least 2 samples, got {n}"
        )));
    }
    let dof = q.len();
    if dof == 0 {
        return Err(Invalid::general("no joint positions given".into()));
    }
    if ddq.is_some() && dq.is_none() {
        return Err(Invalid::general(
            "accelerations given without velocities".into(),
        ));
    }
    check_times(t)?;
    for (name, series) in [("q", Some(q)), ("dq", dq), ("ddq", ddq)] {
        let Some(series) = series else { continue };
        check_series(name, series, dof, n)?;
    }
    Ok(())
}

/// Check that the sample times `t` (s) are finite and strictly increasing.
fn check_times(t: &[f64]) -> std::result::Result<(), Invalid> {
    if let Some(k) = t.iter().position(|v| !v.is_finite()) {
        return Err(Invalid::at(k, format!("time is {} (must be finite)", t[k])));
    }
    for k in 1..t.len() {
        if t[k] <= t[k - 1] {
            return Err(Invalid::at(
                k,
                format!(
                    "time {} s does not increase (previous sample at {} s)",
                    t[k],
                    t[k - 1]
                ),
            ));
        }
    }
    Ok(())
}

/// Polynomial coefficients of every joint on every interval between `knots` (s from the
/// first sample), joint-major, and the interpolant: quintic Hermite with velocities and
/// accelerations, cubic Hermite with velocities only, else a cubic spline through `q`.
fn interpolate(
    knots: &[f64],
    q: &[Vec<f64>],
    dq: Option<&[Vec<f64>]>,
    ddq: Option<&[Vec<f64>]>,
) -> (Vec<[f64; 6]>, Interpolation) {
    let dof = q.len();
    let intervals = knots.len() - 1;
    let mut coeffs = Vec::with_capacity(dof * intervals);
    let interpolation = match (dq, ddq) {
        (Some(dq), Some(ddq)) => {
            for i in 0..dof {
                for k in 0..intervals {
                    coeffs.push(quintic_hermite(
                        knots[k + 1] - knots[k],
                        [q[i][k], dq[i][k], ddq[i][k]],
                        [q[i][k + 1], dq[i][k + 1], ddq[i][k + 1]],
                    ));
                }
            }
            Interpolation::QuinticHermite
        }
        (Some(dq), None) => {
            for i in 0..dof {
                push_cubic_hermite(&mut coeffs, knots, &q[i], &dq[i]);
            }
            Interpolation::CubicHermite
        }
        (None, _) => {
            for qi in q {
                let slopes = spline_slopes(knots, qi);
                push_cubic_hermite(&mut coeffs, knots, qi, &slopes);
            }
            Interpolation::CubicSpline
        }
    };
    (coeffs, interpolation)
}

impl Trajectory for Sampled {
    fn dof(&self) -> usize {
        self.dof
    }

    fn duration(&self) -> f64 {
        self.knots[self.knots.len() - 1]
    }

    fn sample(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        let intervals = self.knots.len() - 1;
        let (k, s) = self.interval(t);
        let outputs = q.iter_mut().zip(dq.iter_mut()).zip(ddq.iter_mut());
        for (i, ((qi, dqi), ddqi)) in outputs.enumerate().take(self.dof) {
            let [c0, c1, c2, c3, c4, c5] = self.coeffs[i * intervals + k];
            *qi = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))));
            *dqi = c1 + s * (2.0 * c2 + s * (3.0 * c3 + s * (4.0 * c4 + s * 5.0 * c5)));
            *ddqi = 2.0 * c2 + s * (6.0 * c3 + s * (12.0 * c4 + s * 20.0 * c5));
        }
    }

    fn coulomb_signs(&self, t: f64, dq: &[f64], s: &mut [f64]) {
        let Some(weights) = &self.move_weights else {
            return super::exact_coulomb_signs(dq, s);
        };
        let intervals = self.knots.len() - 1;
        let (k, from_knot) = self.interval(t);
        let h = self.knots[k + 1] - self.knots[k];
        let f = from_knot / h;
        for (i, ((si, &v), w)) in s.iter_mut().zip(dq).zip(weights).enumerate() {
            let [_, c1, c2, c3, c4, c5] = self.coeffs[i * intervals + k];
            let end_speed = c1 + h * (2.0 * c2 + h * (3.0 * c3 + h * (4.0 * c4 + h * 5.0 * c5)));
            // Moving next to a rest, the joint leaves (reaches) it the way it is displaced
            // over the interval; the route's speed may ring against that near the rest.
            let speed = if sign(v) != 0.0 && (sign(c1) == 0.0 || sign(end_speed) == 0.0) {
                c1 + h * (c2 + h * (c3 + h * (c4 + h * c5)))
            } else {
                v
            };
            *si = sign(speed) * (w[k] + f * (w[k + 1] - w[k]));
        }
    }
}

/// Check one kind of joint series: `dof` joints of `n` finite samples each.
fn check_series(
    name: &str,
    series: &[Vec<f64>],
    dof: usize,
    n: usize,
) -> std::result::Result<(), Invalid> {
    if series.len() != dof {
        return Err(Invalid::general(format!(
            "{name} has {} joints, q has {dof}",
            series.len()
        )));
    }
    for (i, s) in series.iter().enumerate() {
        if s.len() != n {
            return Err(Invalid::general(format!(
                "{name}{} has {} samples, t has {n}",
                i + 1,
                s.len()
            )));
        }
        if let Some(k) = s.iter().position(|v| !v.is_finite()) {
            return Err(Invalid::at(
                k,
                format!("{name}{} is {} (must be finite)", i + 1, s[k]),
            ));
        }
    }
    Ok(())
}

fn owned(columns: Vec<&[f64]>) -> Vec<Vec<f64>> {
    columns.into_iter().map(<[f64]>::to_vec).collect()
}

/// Columns `{prefix}1..{prefix}n` when all are present, `None` when none is, an error naming
/// the first missing one otherwise.
fn optional_kind(
    table: &Table,
    prefix: &str,
    unit: &str,
    dof: usize,
) -> Result<Option<Vec<Vec<f64>>>> {
    let present = (1..=dof)
        .filter(|i| {
            table
                .column(&[&format!("{prefix}{i}_{unit}"), &format!("{prefix}{i}")])
                .is_ok()
        })
        .count();
    if present == 0 {
        return Ok(None);
    }
    // All present, or `joint_columns` names the first missing column.
    table.joint_columns(prefix, unit, dof).map(owned).map(Some)
}

/// Quintic on `[0, h]` with position, velocity, acceleration `p0` at 0 and `p1` at `h`.
fn quintic_hermite(h: f64, p0: [f64; 3], p1: [f64; 3]) -> [f64; 6] {
    let [x0, v0, a0] = p0;
    let [x1, v1, a1] = p1;
    // Residuals left for the s^3..s^5 terms after the Taylor part at 0.
    let r0 = x1 - (x0 + v0 * h + 0.5 * a0 * h * h);
    let r1 = (v1 - (v0 + a0 * h)) * h;
    let r2 = (a1 - a0) * h * h;
    let h3 = h * h * h;
    [
        x0,
        v0,
        0.5 * a0,
        (10.0 * r0 - 4.0 * r1 + 0.5 * r2) / h3,
        (-15.0 * r0 + 7.0 * r1 - r2) / (h3 * h),
        (6.0 * r0 - 3.0 * r1 + 0.5 * r2) / (h3 * h * h),
    ]
}

/// Append the cubic Hermite pieces of one joint through positions `x` with slopes `v`.
fn push_cubic_hermite(out: &mut Vec<[f64; 6]>, knots: &[f64], x: &[f64], v: &[f64]) {
    for k in 0..knots.len() - 1 {
        let h = knots[k + 1] - knots[k];
        let r0 = x[k + 1] - x[k] - v[k] * h;
        let r1 = (v[k + 1] - v[k]) * h;
        out.push([
            x[k],
            v[k],
            (3.0 * r0 - r1) / (h * h),
            (r1 - 2.0 * r0) / (h * h * h),
            0.0,
            0.0,
        ]);
    }
}

/// Knot slopes of the C2 cubic spline through `x` (end conditions in the module docs).
fn spline_slopes(knots: &[f64], x: &[f64]) -> Vec<f64> {
    let n = knots.len();
    let h: Vec<f64> = knots.windows(2).map(|w| w[1] - w[0]).collect();
    let delta: Vec<f64> = (0..n - 1).map(|k| (x[k + 1] - x[k]) / h[k]).collect();
    // Tridiagonal system: sub[k] m[k-1] + diag[k] m[k] + sup[k] m[k+1] = rhs[k].
    let mut sub = vec![0.0; n];
    let mut diag = vec![0.0; n];
    let mut sup = vec![0.0; n];
    let mut rhs = vec![0.0; n];
    if x[0] == x[1] {
        diag[0] = 1.0; // clamped: m[0] = 0
    } else {
        diag[0] = 2.0;
        sup[0] = 1.0;
        rhs[0] = 3.0 * delta[0];
    }
    for k in 1..n - 1 {
        sub[k] = h[k];
        diag[k] = 2.0 * (h[k - 1] + h[k]);
        sup[k] = h[k - 1];
        rhs[k] = 3.0 * (h[k] * delta[k - 1] + h[k - 1] * delta[k]);
    }
    if x[n - 1] == x[n - 2] {
        diag[n - 1] = 1.0;
    } else {
        sub[n - 1] = 1.0;
        diag[n - 1] = 2.0;
        rhs[n - 1] = 3.0 * delta[n - 2];
    }
    // Thomas algorithm; the system is strictly diagonally dominant, no pivoting needed.
    for k in 1..n {
        let w = sub[k] / diag[k - 1];
        diag[k] -= w * sup[k - 1];
        rhs[k] -= w * rhs[k - 1];
    }
    rhs[n - 1] /= diag[n - 1];
    for k in (0..n - 1).rev() {
        rhs[k] = (rhs[k] - sup[k] * rhs[k + 1]) / diag[k];
    }
    rhs
}
