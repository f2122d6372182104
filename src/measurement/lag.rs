//! The lag between the power stream and the joint stream, for a power meter on its own clock.
//!
//! Convention: a lag `L > 0` s means the power is late: the power logged at time `t` was
//! drawn at `t - L`. Aligning replaces the power at `t` by the logged power at `t + L`.
//!
//! The estimate needs no robot model: the power of a serial arm is, to first order, a linear
//! combination of terms computed from the joint stream alone: a constant; the pose, `sin`,
//! `cos` and `cos 2x` of each `q_j` and of each adjacent sum `q_j + q_j+1` (the holding
//! torque's copper loss changes from one rest pose to the next); and per joint `i`,
//! `dq_i ddq_i` (inertia), `dq_i` and `|dq_i|` (friction), `dq_i cos q_j` and `dq_i sin q_j`
//! for every joint `j` (gravity). For each shift of the power by a whole number of samples
//! within `+-max_lag_s`, the shifted power is regressed on these terms (least squares, one QR
//! factorisation for all shifts; at most 8000 samples, a longer log thinned evenly); the
//! shift explaining the most variance wins, refined by a parabola through it and its
//! neighbours, times the median sample period. (Shifting by fractions of a sample would
//! interpolate the power, average its noise and favour half-sample lags.) Velocities and
//! accelerations are central differences of the (logged or differentiated) positions on the
//! actual, possibly non-uniform, time stamps.
//!
//! Treat the estimate as good to about one sample period (tests/logs.rs checks it on a twin
//! log; see docs/experiments.md#power-lag-estimate).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::measurement::clean::median_period;

/// Most samples the regression uses (a longer log is thinned evenly).
const MAX_ROWS: usize = 8000;

/// What [`estimate_lag`] found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LagEstimate {
    /// Estimated lag of the power behind the joints, s.
    pub lag_s: f64,
    /// Fraction of the power's variance the joint-stream terms explain at that lag.
    pub r2: f64,
    /// The same at zero lag.
    pub r2_at_zero: f64,
}

/// Linear interpolation of `(t, y)` at `x` (None outside `[t0, tn]`).
pub(crate) fn interp(t: &[f64], y: &[f64], x: f64) -> Option<f64> {
    let (first, last) = (*t.first()?, *t.last()?);
    if !(x >= first && x <= last) {
        return None;
    }
    let k = t.partition_point(|&v| v <= x);
    if k >= t.len() {
        return Some(y[t.len() - 1]);
    }
    let (t0, t1) = (t[k - 1], t[k]);
    let a = (x - t0) / (t1 - t0);
    Some(y[k - 1] + a * (y[k] - y[k - 1]))
}

/// Central-difference derivative of `y` on the non-uniform times `t` (one-sided at the ends).
pub(crate) fn derivative(t: &[f64], y: &[f64]) -> Vec<f64> {
    let m = t.len();
    (0..m)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(m - 1));
            if b > a {
                (y[b] - y[a]) / (t[b] - t[a])
            } else {
                0.0
            }
        })
        .collect()
}

/// Estimate the lag of `power_w` behind the joint stream (positions `q_rad`, joint-major;
/// velocities `dq_rad_s` when logged) at the times `t_s`, searching `+-max_lag_s`.
///
/// Errors: fewer than 50 samples inside the lag-trimmed range, or a search range that leaves
/// none.
pub fn estimate_lag(
    t_s: &[f64],
    q_rad: &[Vec<f64>],
    dq_rad_s: Option<&[Vec<f64>]>,
    power_w: &[f64],
    max_lag_s: f64,
) -> Result<LagEstimate> {
    let rows = search_rows(t_s, q_rad.len(), max_lag_s)?;
    let dq: Vec<Vec<f64>> = match dq_rad_s {
        Some(d) => d.to_vec(),
        None => q_rad.iter().map(|q| derivative(t_s, q)).collect(),
    };
    let ddq: Vec<Vec<f64>> = dq.iter().map(|v| derivative(t_s, v)).collect();
    let x = joint_terms(q_rad, &dq, &ddq, &rows.inner);
    let q = orthonormal_terms(&x);
    let s = rows.steps as i64;
    let grid: Vec<(i64, f64)> = (-s..=s)
        .map(|j| (j, explained(&q, &rows.inner, power_w, j)))
        .collect();
    let best = (0..grid.len())
        .max_by(|&a, &b| grid[a].1.total_cmp(&grid[b].1))
        .unwrap_or(0);
    let mut lag = grid[best].0 as f64;
    if best > 0 && best + 1 < grid.len() {
        let (a, b, c) = (grid[best - 1].1, grid[best].1, grid[best + 1].1);
        let denom = a - 2.0 * b + c;
        if denom < 0.0 {
            lag += 0.5 * (a - c) / denom;
        }
    }
    Ok(LagEstimate {
        lag_s: lag * rows.period,
        r2: grid[best].1,
        // The grid runs from -steps, so the zero shift is its middle entry.
        r2_at_zero: grid[rows.steps].1,
    })
}

/// The samples the lag regression uses and the shifts it tries.
struct SearchRows {
    /// Median sample period, s.
    period: f64,
    /// Largest shift tried either way, samples.
    steps: usize,
    /// Indices of the samples regressed: those at least `steps` from either end, thinned
    /// to at most [`MAX_ROWS`].
    inner: Vec<usize>,
}

/// The samples and shifts of the lag search over `+-max_lag_s` (s) for a log with the
/// times `t_s` (s) of `n` joints. Errors: too few samples for the search or for the
/// regression's terms.
fn search_rows(t_s: &[f64], n: usize, max_lag_s: f64) -> Result<SearchRows> {
    let m = t_s.len();
    let period = median_period(t_s);
    if m < 2 || period <= 0.0 {
        return Err(Error::InvalidInput(
            "too few samples to estimate the power lag".into(),
        ));
    }
    // Whole-sample shifts: interpolating the power between samples would average its noise
    // and favour half-sample lags.
    let steps = (max_lag_s / period).floor() as usize;
    let inside: Vec<usize> = (steps..m.saturating_sub(steps)).collect();
    // Long logs: every `stride`-th sample (shifts still move by single samples, so the lag
    // resolution is kept) bounds the cost.
    let stride = inside.len().div_ceil(MAX_ROWS).max(1);
    let inner: Vec<usize> = inside.into_iter().step_by(stride).collect();
    let features = term_count(n);
    if inner.len() < 50.max(2 * features) {
        return Err(Error::InvalidInput(format!(
            "{} samples inside the +-{max_lag_s} s lag search are too few to estimate the power lag from this log alone (need {}: a longer or faster log)",
            inner.len(),
            50.max(2 * features)
        )));
    }
    Ok(SearchRows {
        period,
        steps,
        inner,
    })
}

/// Number of joint-stream terms for `n` joints (see the module docs).
fn term_count(n: usize) -> usize {
    1 + 6 * n + n * (3 + 2 * n)
}

/// The joint-stream terms (see the module docs) at the samples `inner`, one row each, from
/// the positions `q_rad` (rad), velocities `dq` (rad/s) and accelerations `ddq` (rad/s^2),
/// joint-major.
fn joint_terms(
    q_rad: &[Vec<f64>],
    dq: &[Vec<f64>],
    ddq: &[Vec<f64>],
    inner: &[usize],
) -> DMatrix<f64> {
    let n = q_rad.len();
    let mut x = DMatrix::<f64>::zeros(inner.len(), term_count(n));
    for (r, &k) in inner.iter().enumerate() {
        let mut c = 0;
        let mut put = |v: f64| {
            x[(r, c)] = v;
            c += 1;
        };
        put(1.0);
        // Pose: holding-torque copper loss changes from rest to rest.
        for j in 0..n {
            let a = q_rad[j][k];
            let b = if j + 1 < n { a + q_rad[j + 1][k] } else { a };
            put(a.sin());
            put(a.cos());
            put((2.0 * a).cos());
            put(b.sin());
            put(b.cos());
            put((2.0 * b).cos());
        }
        for i in 0..n {
            let (v, acc) = (dq[i][k], ddq[i][k]);
            put(v * acc);
            put(v);
            put(v.abs());
            for qj in q_rad {
                put(v * qj[k].cos());
                put(v * qj[k].sin());
            }
        }
    }
    x
}

/// An orthonormal basis (the `Q` of a QR factorisation) of the terms `x`, its columns
/// scaled to unit norm and those that are (numerically) zero left out: a joint at rest.
fn orthonormal_terms(x: &DMatrix<f64>) -> DMatrix<f64> {
    let (rows, features) = x.shape();
    let keep: Vec<usize> = (0..features)
        .filter(|&c| x.column(c).norm() > 1e-9 * (rows as f64).sqrt())
        .collect();
    let mut xs = DMatrix::<f64>::zeros(rows, keep.len());
    for (j, &c) in keep.iter().enumerate() {
        let col = x.column(c);
        let norm = col.norm();
        xs.set_column(j, &(col / norm));
    }
    xs.qr().q()
}

/// Fraction of the variance of the power `power_w` (W) shifted by `shift` samples, taken at
/// the samples `inner`, that the terms with the orthonormal basis `q` explain.
fn explained(q: &DMatrix<f64>, inner: &[usize], power_w: &[f64], shift: i64) -> f64 {
    let y = DVector::from_iterator(
        inner.len(),
        inner.iter().map(|&k| power_w[(k as i64 + shift) as usize]),
    );
    let mean = y.mean();
    let total = y.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
    let residual = (y.norm_squared() - (q.transpose() * &y).norm_squared()).max(0.0);
    if total > 0.0 {
        1.0 - residual / total
    } else {
        0.0
    }
}

/// Resample `power_w` (and each of `others`) at `t + lag_s` by linear interpolation, keeping
/// the samples whose shifted time lies inside the log. Returns the indices kept (a
/// contiguous range) and the shifted series.
pub fn shift(
    t_s: &[f64],
    power_w: &[f64],
    others: &[Vec<f64>],
    lag_s: f64,
) -> (std::ops::Range<usize>, Vec<f64>, Vec<Vec<f64>>) {
    let keep: Vec<usize> = (0..t_s.len())
        .filter(|&k| interp(t_s, power_w, t_s[k] + lag_s).is_some())
        .collect();
    let range = match (keep.first(), keep.last()) {
        (Some(&a), Some(&b)) => a..b + 1,
        _ => 0..0,
    };
    let at = |y: &[f64]| -> Vec<f64> {
        range
            .clone()
            .map(|k| interp(t_s, y, t_s[k] + lag_s).unwrap_or(y[k]))
            .collect()
    };
    let p = at(power_w);
    let o = others.iter().map(|y| at(y)).collect();
    (range, p, o)
}
