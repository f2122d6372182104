//! Segments of a log: explicit time ranges (`0-12.5,20-40`, seconds from the log's first
//! sample) or rest-to-rest moves found automatically (`auto`), to identify on some moves and
//! predict others from the same log.
//!
//! A move is a stretch between two rests, a rest being a stretch of at least `min_rest_s`
//! during which every joint is slower than `rest_speed_rad_s`. Each move's range reaches
//! `pad_s` into the rests on either side (within the log), so a move's energy includes the
//! start and stop and a little standby.

use std::str::FromStr;

use crate::error::{Error, Result};
use crate::measurement::Log;
use crate::measurement::lag::derivative;

/// Which parts of a log to use (`--segments`).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum SegmentSpec {
    /// The whole log.
    #[default]
    All,
    /// These time ranges, s from the first sample (start, end).
    Ranges(Vec<(f64, f64)>),
    /// Rest-to-rest moves found from joint speed.
    Auto,
}

impl FromStr for SegmentSpec {
    type Err = Error;

    /// `all`, `auto`, or comma-separated `START-END` ranges in seconds (`0-12.5,20-40`).
    fn from_str(s: &str) -> Result<Self> {
        match s.trim() {
            "all" => return Ok(SegmentSpec::All),
            "auto" => return Ok(SegmentSpec::Auto),
            _ => {}
        }
        let mut ranges = Vec::new();
        for part in s.split(',') {
            let bad = || {
                Error::InvalidInput(format!(
                    "segment '{part}' is not START-END in seconds (e.g. 0-12.5,20-40), 'auto' or 'all'"
                ))
            };
            let (a, b) = part.trim().split_once('-').ok_or_else(bad)?;
            let a: f64 = a.trim().parse().map_err(|_| bad())?;
            let b: f64 = b.trim().parse().map_err(|_| bad())?;
            if !(a.is_finite() && b.is_finite() && a >= 0.0 && b > a) {
                return Err(Error::InvalidInput(format!(
                    "segment '{part}': need 0 <= START < END, finite"
                )));
            }
            ranges.push((a, b));
        }
        Ok(SegmentSpec::Ranges(ranges))
    }
}

/// Options of [`auto_moves`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveOptions {
    /// Every joint slower than this, rad/s: at rest.
    pub rest_speed_rad_s: f64,
    /// Shortest rest, s.
    pub min_rest_s: f64,
    /// How far a move's range reaches into the rests around it, s.
    pub pad_s: f64,
}

impl Default for MoveOptions {
    fn default() -> Self {
        MoveOptions {
            rest_speed_rad_s: 0.02,
            min_rest_s: 0.3,
            pad_s: 0.2,
        }
    }
}

/// The largest joint speed at each sample, rad/s: from the logged velocities when there are
/// any, else central differences of the positions.
pub fn joint_speed(log: &Log) -> Vec<f64> {
    let dq: Vec<Vec<f64>> = match &log.dq_rad_s {
        Some(d) => d.clone(),
        None => log.q_rad.iter().map(|q| derivative(&log.t_s, q)).collect(),
    };
    (0..log.len())
        .map(|k| dq.iter().map(|v| v[k].abs()).fold(0.0, f64::max))
        .collect()
}

/// Rests of `log`: maximal stretches of at least `min_rest_s` with every joint slower than
/// `rest_speed_rad_s`, as sample index ranges.
pub fn rests(log: &Log, rest_speed_rad_s: f64, min_rest_s: f64) -> Vec<std::ops::Range<usize>> {
    let speed = joint_speed(log);
    let t = &log.t_s;
    let mut out = Vec::new();
    let mut k = 0;
    while k < speed.len() {
        if speed[k] < rest_speed_rad_s {
            let start = k;
            while k < speed.len() && speed[k] < rest_speed_rad_s {
                k += 1;
            }
            if t[k - 1] - t[start] >= min_rest_s {
                out.push(start..k);
            }
        } else {
            k += 1;
        }
    }
    out
}

/// Rest-to-rest moves of `log` as time ranges (s, the log's own times), in order. Motion
/// before the first or after the last rest counts as a move too.
pub fn auto_moves(log: &Log, opts: &MoveOptions) -> Vec<(f64, f64)> {
    let t = &log.t_s;
    if t.is_empty() {
        return Vec::new();
    }
    let rests = rests(log, opts.rest_speed_rad_s, opts.min_rest_s);
    // Moving stretches: between consecutive rests (and before the first / after the last).
    let mut bounds = Vec::new();
    let mut prev_end = 0;
    for r in &rests {
        if r.start > prev_end {
            bounds.push((prev_end, r.start));
        }
        prev_end = r.end;
    }
    if prev_end < t.len() {
        bounds.push((prev_end, t.len()));
    }
    let (t0, t1) = (t[0], t[t.len() - 1]);
    bounds
        .into_iter()
        .filter(|(a, b)| b - a >= 2)
        .map(|(a, b)| ((t[a] - opts.pad_s).max(t0), (t[b - 1] + opts.pad_s).min(t1)))
        .collect()
}

/// The samples of `log` with times in `[start, end]` (s, the log's own times). Errors when
/// fewer than two samples fall inside.
pub fn slice_time(log: &Log, (start, end): (f64, f64)) -> Result<Log> {
    let a = log.t_s.partition_point(|&t| t < start);
    let b = log.t_s.partition_point(|&t| t <= end);
    if b < a + 2 {
        return Err(Error::InvalidInput(format!(
            "{}: segment {start}-{end} s holds {} samples (the log spans {}-{} s)",
            log.source,
            b.saturating_sub(a),
            log.t_s.first().copied().unwrap_or(0.0),
            log.t_s.last().copied().unwrap_or(0.0)
        )));
    }
    let mut s = log.slice(a..b);
    s.source = format!("{} [{}-{} s]", log.source, ms(start), ms(end));
    Ok(s)
}

/// A time (s) rounded to the millisecond for a label: the ranges of auto segments are sample
/// times, whose last digits say nothing.
fn ms(t_s: f64) -> f64 {
    // Adding 0 turns the -0 of a tiny negative time into 0.
    (t_s * 1e3).round() / 1e3 + 0.0
}

/// The segments of `logs` (pieces of one or more files, times from the first sample of
/// their file) that `spec` selects. A range is cut from every log it overlaps; ranges that
/// overlap no log are an error.
pub fn select(logs: &[Log], spec: &SegmentSpec, moves: &MoveOptions) -> Result<Vec<Log>> {
    match spec {
        SegmentSpec::All => Ok(logs.to_vec()),
        SegmentSpec::Auto => {
            let mut out = Vec::new();
            for log in logs {
                for r in auto_moves(log, moves) {
                    out.push(slice_time(log, r)?);
                }
            }
            if out.is_empty() {
                return Err(Error::InvalidInput(
                    "no rest-to-rest move found in the logs".into(),
                ));
            }
            Ok(out)
        }
        SegmentSpec::Ranges(ranges) => {
            let mut out = Vec::new();
            for &(a, b) in ranges {
                let hits: Vec<&Log> = logs
                    .iter()
                    .filter(|l| l.t_s.first().is_some_and(|&t0| t0 <= b))
                    .filter(|l| l.t_s.last().is_some_and(|&t1| t1 >= a))
                    .collect();
                if hits.is_empty() {
                    return Err(Error::InvalidInput(format!(
                        "segment {a}-{b} s overlaps no log"
                    )));
                }
                for l in hits {
                    out.push(slice_time(l, (a, b))?);
                }
            }
            Ok(out)
        }
    }
}
