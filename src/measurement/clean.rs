//! Time-base repair of a log read from a file, before it becomes a [`crate::measurement::Log`].
//!
//! In the order [`crate::measurement::read::read_log`] applies them:
//! 1. **Time going backwards** is an error naming the file row.
//! 2. **Duplicated time stamps**: rows with the same time stamp are averaged into one
//!    (counted as merged).
//! 3. **Wrapped joints** (`wrapped` in the map): a step of more than pi between consecutive
//!    samples is taken as a wrap and 2 pi is added or subtracted from there on, so a
//!    multi-turn joint stays continuous (q near 12.6 rad is kept as is). Steps of more than
//!    pi in other joints are counted as suspect (not changed).
//! 4. **Gaps**: a step longer than `max_gap_periods` times the median period splits the log
//!    into gap-free pieces (or is an error naming the row, `on_gap = "error"`); pieces with
//!    fewer than `min_piece_samples` samples are dropped (counted).
//! 5. **Rates above `working_rate_hz`**: blocks of `k = ceil(rate / working_rate_hz)`
//!    consecutive samples are averaged (time, positions, velocities and power alike), so a
//!    1 kHz log is worked on at 100 Hz; the mean of the power over a block keeps the energy.
//!
//! 6. **Jittered stamps of a fixed-rate logger** (`regularize_jitter`, on by default): when
//!    every stamp of a gap-free piece lies within `max_jitter_periods` of one period of the
//!    least-squares uniform grid `t0 + k T`, either the samples were taken on the controller's
//!    clock and the jitter is the stamp's (host receive time, clock quantisation), or the
//!    logger really samples unevenly and stamps each sample at the time it was taken. The
//!    positions tell the two apart, being smooth in the times the samples were really taken
//!    at: the stamps are replaced by the grid (counted, with the largest deviation) unless
//!    the positions are clearly smoother against the stamps as logged ([`regularize`],
//!    [`STAMPS_SMOOTHER_RATIO`]). Differentiating positions against jittered stamps would
//!    turn 3 ms of jitter into rad/s^2 of acceleration error; snapping correct but uneven
//!    stamps to the grid does the same the other way. Otherwise (uneven stamps that fit
//!    the positions, or deviations beyond `max_jitter_periods`) the actual times are kept,
//!    and every later step (the spline route, energy windows, the lag estimate) works with
//!    them.

use std::f64::consts::{PI, TAU};

use crate::error::{Error, Result};
use crate::measurement::columns::{CleanOptions, GapPolicy};
use crate::numerics::scaled_divided_differences;

/// A log being repaired: samples with their file rows. Series are joint-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Sample times, s.
    pub t_s: Vec<f64>,
    /// 0-based data row in the file of each sample (of the first row of a merged or
    /// averaged block), for messages.
    pub row: Vec<usize>,
    /// Joint positions, rad.
    pub q_rad: Vec<Vec<f64>>,
    /// Joint velocities, rad/s, when logged.
    pub dq_rad_s: Option<Vec<Vec<f64>>>,
    /// Power of the arm, W.
    pub power_w: Vec<f64>,
    /// Electrical power of each motor, W, when logged.
    pub motor_power_w: Option<Vec<Vec<f64>>>,
}

impl Frame {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Every numeric series (time, positions, velocities, power, motor powers).
    fn series_mut(&mut self) -> Vec<&mut Vec<f64>> {
        let mut v: Vec<&mut Vec<f64>> = vec![&mut self.t_s, &mut self.power_w];
        v.extend(self.q_rad.iter_mut());
        if let Some(d) = &mut self.dq_rad_s {
            v.extend(d.iter_mut());
        }
        if let Some(p) = &mut self.motor_power_w {
            v.extend(p.iter_mut());
        }
        v
    }

    /// The samples `range`.
    pub fn slice(&self, range: std::ops::Range<usize>) -> Frame {
        let cut = |v: &Vec<f64>| v[range.clone()].to_vec();
        Frame {
            t_s: cut(&self.t_s),
            row: self.row[range.clone()].to_vec(),
            q_rad: self.q_rad.iter().map(cut).collect(),
            dq_rad_s: self.dq_rad_s.as_ref().map(|d| d.iter().map(cut).collect()),
            power_w: cut(&self.power_w),
            motor_power_w: self
                .motor_power_w
                .as_ref()
                .map(|d| d.iter().map(cut).collect()),
        }
    }

    /// Replace every series by the means over the index groups `groups` (consecutive,
    /// covering all samples); a group's row is its first. Times are averaged too unless
    /// `keep_time` (then a group's time is its first: for groups of equal times).
    fn average_groups(&mut self, groups: &[std::ops::Range<usize>], keep_time: bool) {
        self.row = groups.iter().map(|g| self.row[g.start]).collect();
        let t: Vec<f64> = groups.iter().map(|g| self.t_s[g.start]).collect();
        for s in self.series_mut() {
            *s = groups
                .iter()
                .map(|g| s[g.clone()].iter().sum::<f64>() / g.len() as f64)
                .collect();
        }
        if keep_time {
            self.t_s = t;
        }
    }
}

/// Median of the positive time steps of `t`, s (0 when there are fewer than two samples).
pub fn median_period(t: &[f64]) -> f64 {
    let mut d: Vec<f64> = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// Refuse time going backwards (error naming the file row, via `row_name`, and the time
/// stamps as the file holds them: `t0_s` (s) added back to the frame's times) and average
/// rows with equal time stamps. Returns how many rows were merged away.
pub fn merge_duplicates(
    frame: &mut Frame,
    t0_s: f64,
    label: &str,
    row_name: &dyn Fn(usize) -> String,
) -> Result<usize> {
    let t = &frame.t_s;
    if let Some(k) = (1..t.len()).find(|&k| t[k] < t[k - 1]) {
        return Err(Error::InvalidInput(format!(
            "{label}: {}: time goes backwards ({} s after {} s at {}); a log must be in time \
             order: sort its rows by time, or split it where its clock was reset",
            row_name(frame.row[k]),
            as_logged(t0_s + t[k]),
            as_logged(t0_s + t[k - 1]),
            row_name(frame.row[k - 1])
        )));
    }
    let mut groups = Vec::new();
    let mut start = 0;
    for k in 1..=t.len() {
        if k == t.len() || t[k] != t[start] {
            groups.push(start..k);
            start = k;
        }
    }
    let merged = t.len() - groups.len();
    if merged > 0 {
        frame.average_groups(&groups, true);
    }
    Ok(merged)
}

/// A time stamp (s) rounded to the microsecond, as a log writes it (adding the first stamp
/// back leaves digits of rounding behind).
fn as_logged(t_s: f64) -> f64 {
    (t_s * 1e6).round() / 1e6
}

/// Unwrap the joints `wrapped` (0-based): a step of more than pi becomes the equivalent step
/// of at most pi. Returns the number of steps changed.
pub fn unwrap(frame: &mut Frame, wrapped: &[usize]) -> usize {
    let mut count = 0;
    for &i in wrapped {
        let q = &mut frame.q_rad[i];
        let mut offset = 0.0;
        let mut prev = q.first().copied().unwrap_or(0.0);
        for v in q.iter_mut().skip(1) {
            let raw = *v;
            let step = raw - prev;
            if step.abs() > PI {
                offset -= TAU * (step / TAU).round();
                count += 1;
            }
            prev = raw;
            *v = raw + offset;
        }
    }
    count
}

/// Steps of more than pi between consecutive samples in the joints not in `wrapped`
/// (0-based): likely a wrapped column that the map does not declare.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Jumps {
    /// How many, over all those joints.
    pub count: usize,
    /// The first joint (0-based) with one, and the frame index of the sample after its
    /// first jump.
    pub first: Option<(usize, usize)>,
}

/// The [`Jumps`] of `frame`'s joints not in `wrapped` (0-based).
pub fn suspect_jumps(frame: &Frame, wrapped: &[usize]) -> Jumps {
    let mut jumps = Jumps::default();
    for (i, q) in frame.q_rad.iter().enumerate() {
        if wrapped.contains(&i) {
            continue;
        }
        let mut at = (1..q.len()).filter(|&k| (q[k] - q[k - 1]).abs() > PI);
        if let Some(k) = at.next() {
            jumps.first.get_or_insert((i, k));
            jumps.count += 1 + at.count();
        }
    }
    jumps
}

/// Gap handling (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Pieces {
    /// The gap-free pieces kept.
    pub pieces: Vec<Frame>,
    /// Number of gaps found.
    pub gaps: usize,
    /// Samples in pieces shorter than `min_piece_samples`, dropped.
    pub dropped_samples: usize,
}

/// Order of the divided differences whose sum of squares measures how rough the positions
/// are against a time base ([`regularize`]): the residual of the quadratic through four
/// samples, blind to the motion's velocity and acceleration, left by its jerk, the noise,
/// and timing errors.
pub const ROUGHNESS_ORDER: usize = 3;

/// Largest ratio of the positions' roughness against the stamps as logged to their roughness
/// against the stamps' uniform grid for which [`regularize`] keeps the logged stamps (the
/// sum over the joints of the squared [`ROUGHNESS_ORDER`]-th divided differences, scaled to
/// unit noise variance, rad^2: [`crate::numerics::scaled_divided_differences`]). Why a
/// half: the stamps are kept only where they are clearly the smoother time base; a logger
/// that samples unevenly gives ratios far below it and one whose stamps alone are jittered
/// far above (docs/experiments.md#logs-sampled-at-uneven-times). Where the positions cannot
/// tell (a log at rest, or noise above what the jitter moves), the grid is taken.
pub const STAMPS_SMOOTHER_RATIO: f64 = 0.5;

/// Sum over the joints `q[i][m]` (rad) of the squared [`ROUGHNESS_ORDER`]-th divided
/// differences at the times `t` (s, increasing), scaled to unit noise variance (rad^2).
fn roughness(t: &[f64], q: &[Vec<f64>]) -> f64 {
    q.iter()
        .map(|x| {
            scaled_divided_differences(t, x, ROUGHNESS_ORDER)
                .iter()
                .map(|d| d * d)
                .sum::<f64>()
        })
        .sum()
}

/// Replace the stamps of `frame` by their least-squares uniform grid when no stamp deviates
/// from it by more than `max_periods` sample periods and the positions are not clearly
/// smoother against the stamps as logged (their roughness there below
/// [`STAMPS_SMOOTHER_RATIO`] times that against the grid, which they are when the logger
/// really sampled at the stamped times; see the module docs, step 6). Returns the largest
/// deviation, s, when the stamps were replaced.
pub fn regularize(frame: &mut Frame, max_periods: f64) -> Option<f64> {
    let mut grid = frame.t_s.clone();
    let worst = regularize_stamps(&mut grid, max_periods)?;
    let (logged, even) = (
        roughness(&frame.t_s, &frame.q_rad),
        roughness(&grid, &frame.q_rad),
    );
    if logged < STAMPS_SMOOTHER_RATIO * even {
        return None;
    }
    frame.t_s = grid;
    Some(worst)
}

/// [`regularize`] on bare time stamps `t_s` (s), without positions to tell whether the
/// stamps or the sampling are uneven: the stamps are taken as jittered.
pub fn regularize_stamps(t_s: &mut [f64], max_periods: f64) -> Option<f64> {
    let m = t_s.len();
    if m < 3 {
        return None;
    }
    let n = m as f64;
    let mean_k = (n - 1.0) / 2.0;
    let mean_t = t_s.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (k, t) in t_s.iter().enumerate() {
        let dk = k as f64 - mean_k;
        sxy += dk * (t - mean_t);
        sxx += dk * dk;
    }
    let period = sxy / sxx;
    if !(period.is_finite() && period > 0.0) {
        return None;
    }
    let grid = |k: usize| mean_t + period * (k as f64 - mean_k);
    let worst = t_s
        .iter()
        .enumerate()
        .map(|(k, t)| (t - grid(k)).abs())
        .fold(0.0, f64::max);
    if worst > max_periods * period {
        return None;
    }
    for (k, t) in t_s.iter_mut().enumerate() {
        *t = grid(k);
    }
    Some(worst)
}

/// Split `frame` at its gaps (steps longer than `max_gap_periods` median periods), or refuse
/// it (`on_gap = "error"`, naming the row after the gap).
pub fn split_gaps(
    frame: Frame,
    opts: &CleanOptions,
    label: &str,
    row_name: &dyn Fn(usize) -> String,
) -> Result<Pieces> {
    let limit = opts.max_gap_periods * median_period(&frame.t_s);
    let t = &frame.t_s;
    let breaks: Vec<usize> = (1..t.len()).filter(|&k| t[k] - t[k - 1] > limit).collect();
    if let (Some(&k), GapPolicy::Error) = (breaks.first(), opts.on_gap) {
        return Err(Error::InvalidInput(format!(
            "{label}: {}: gap of {:.6} s before this sample (more than {} median periods of {} s); set [clean] on_gap = \"split\" to split the log there",
            row_name(frame.row[k]),
            t[k] - t[k - 1],
            opts.max_gap_periods,
            limit / opts.max_gap_periods
        )));
    }
    let mut bounds = vec![0];
    bounds.extend(&breaks);
    bounds.push(t.len());
    let mut pieces = Vec::new();
    let mut dropped_samples = 0;
    for w in bounds.windows(2) {
        if w[1] - w[0] >= opts.min_piece_samples {
            pieces.push(frame.slice(w[0]..w[1]));
        } else {
            dropped_samples += w[1] - w[0];
        }
    }
    Ok(Pieces {
        pieces,
        gaps: breaks.len(),
        dropped_samples,
    })
}

/// Block-average `frame` down to at most `working_rate_hz` (from its median rate); returns
/// the block length `k` (1: unchanged). The last block may be shorter.
pub fn decimate(frame: &mut Frame, working_rate_hz: f64) -> usize {
    let period = median_period(&frame.t_s);
    if period <= 0.0 {
        return 1;
    }
    let rate = 1.0 / period;
    // The small tolerance keeps a log exactly at the working rate (up to rounding) at k = 1.
    let k = ((rate / working_rate_hz) * (1.0 - 1e-9)).ceil().max(1.0) as usize;
    if k > 1 {
        let m = frame.len();
        let groups: Vec<_> = (0..m).step_by(k).map(|s| s..(s + k).min(m)).collect();
        frame.average_groups(&groups, false);
    }
    k
}
