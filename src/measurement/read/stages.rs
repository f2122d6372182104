//! The stages of [`read_log`](super::read_log) after the columns are read, in order.

use crate::error::{Error, Result};
use crate::measurement::clean::{self, Frame, median_period};
use crate::measurement::columns::{
    AngleUnit, ColumnMap, PowerKind, PowerSource, PowerUnit, RateUnit,
};
use crate::measurement::lag::{self, LagEstimate};
use crate::measurement::{Log, segments};

use super::LagOption;

/// The columns to read, in this order: time, positions, velocities, power, motors.
pub(super) struct Wanted {
    /// Column names in reading order.
    pub(super) names: Vec<String>,
    /// Index of the first velocity column.
    dq_at: usize,
    /// Index of the power column (or the voltage, followed by the current).
    p_at: usize,
    /// Index of the first motor power column.
    motors_at: usize,
}

impl Wanted {
    /// The columns `map` names for the power `source`.
    pub(super) fn of(map: &ColumnMap, source: &PowerSource) -> Wanted {
        let mut names = vec![map.time.column.clone()];
        names.extend(map.joints.position.iter().cloned());
        let dq_at = names.len();
        names.extend(map.joints.velocity.iter().flatten().cloned());
        let p_at = names.len();
        match source {
            PowerSource::Column { name, .. } => names.push(name.clone()),
            PowerSource::VoltageCurrent { voltage, current } => {
                names.push(voltage.clone());
                names.push(current.clone());
            }
            PowerSource::MotorSum => {}
        }
        let motors_at = names.len();
        names.extend(map.power.motors.iter().flatten().cloned());
        Wanted {
            names,
            dq_at,
            p_at,
            motors_at,
        }
    }

    /// Refuse a file whose `header` lacks a wanted column, listing the columns found.
    pub(super) fn check_present(&self, header: &[String], label: &str) -> Result<()> {
        let absent: Vec<&String> = self.names.iter().filter(|w| !header.contains(w)).collect();
        if absent.is_empty() {
            return Ok(());
        }
        Err(Error::InvalidInput(format!(
            "{label}: missing column(s) {} (columns found: {})",
            absent
                .iter()
                .map(|a| format!("'{a}'"))
                .collect::<Vec<_>>()
                .join(", "),
            header.join(", ")
        )))
    }
}

/// The columns left after dropping rows with missing cells.
pub(super) struct Kept {
    /// One vector per wanted column.
    pub(super) cols: Vec<Vec<f64>>,
    /// File row (0-based data row) of every kept row.
    pub(super) file_rows: Vec<usize>,
    /// Rows dropped for a missing cell.
    pub(super) dropped: usize,
}

/// Missing cells (NaN): refuse, naming the first, or drop their rows (`[clean]
/// drop_missing`).
pub(super) fn drop_missing(
    mut cols: Vec<Vec<f64>>,
    wanted: &Wanted,
    map: &ColumnMap,
    label: &str,
    row_name: &dyn Fn(usize) -> String,
) -> Result<Kept> {
    let rows = cols[0].len();
    let bad_rows: Vec<usize> = (0..rows)
        .filter(|&k| cols.iter().any(|c| c[k].is_nan()))
        .collect();
    if let Some(&k) = bad_rows.first()
        && !map.clean.drop_missing
    {
        let c = cols.iter().position(|c| c[k].is_nan()).unwrap_or(0);
        return Err(Error::InvalidInput(format!(
            "{label}: {}: column '{}' is empty or NaN ({} rows have missing cells; set [clean] drop_missing = true in a column map to drop them)",
            row_name(k),
            wanted.names[c],
            bad_rows.len()
        )));
    }
    let mut file_rows: Vec<usize> = (0..rows).collect();
    if !bad_rows.is_empty() {
        let keep: Vec<bool> = (0..rows)
            .map(|k| bad_rows.binary_search(&k).is_err())
            .collect();
        for c in &mut cols {
            *c = c
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(v, _)| *v)
                .collect();
        }
        file_rows.retain(|&k| keep[k]);
        if file_rows.len() < 2 {
            return Err(Error::InvalidInput(format!(
                "{label}: {} of {rows} data rows have missing cells; dropping them leaves {}, and a log needs at least 2",
                bad_rows.len(),
                file_rows.len()
            )));
        }
    }
    Ok(Kept {
        cols,
        file_rows,
        dropped: bad_rows.len(),
    })
}

/// The kept columns in SI units as a [`Frame`], times from the first kept row; the power
/// from its `source`.
pub(super) fn to_si(
    kept: Kept,
    wanted: &Wanted,
    map: &ColumnMap,
    source: &PowerSource,
    label: &str,
) -> Result<Frame> {
    let Kept {
        cols, file_rows, ..
    } = kept;
    let n = map.dof();
    let deg = std::f64::consts::PI / 180.0;
    let q_scale = match map.joints.position_unit {
        AngleUnit::Rad => 1.0,
        AngleUnit::Deg => deg,
    };
    let dq_scale = match map.joints.velocity_unit {
        RateUnit::RadS => 1.0,
        RateUnit::DegS => deg,
    };
    let p_scale = match map.power.unit {
        PowerUnit::W => 1.0,
        PowerUnit::KW => 1e3,
    };
    let scaled = |c: &Vec<f64>, s: f64| c.iter().map(|v| v * s).collect::<Vec<f64>>();
    let t0 = cols[0][0];
    let (dq_at, p_at, motors_at) = (wanted.dq_at, wanted.p_at, wanted.motors_at);
    let motors: Option<Vec<Vec<f64>>> = map.power.motors.as_ref().map(|_| {
        (0..n)
            .map(|i| scaled(&cols[motors_at + i], p_scale))
            .collect()
    });
    let power_w = match source {
        PowerSource::Column { scale, .. } => scaled(&cols[p_at], *scale),
        PowerSource::VoltageCurrent { .. } => cols[p_at]
            .iter()
            .zip(&cols[p_at + 1])
            .map(|(u, i)| u * i)
            .collect(),
        PowerSource::MotorSum => {
            let m = motors.as_ref().ok_or_else(|| {
                Error::InvalidInput(format!("{label}: no motor power columns to sum"))
            })?;
            (0..file_rows.len())
                .map(|k| m.iter().map(|p| p[k]).sum())
                .collect()
        }
    };
    Ok(Frame {
        t_s: cols[0].iter().map(|t| t - t0).collect(),
        row: file_rows,
        q_rad: (0..n).map(|i| scaled(&cols[1 + i], q_scale)).collect(),
        dq_rad_s: map
            .joints
            .velocity
            .as_ref()
            .map(|_| (0..n).map(|i| scaled(&cols[dq_at + i], dq_scale)).collect()),
        power_w,
        motor_power_w: motors,
    })
}

/// The slowest median sample period read as a log, s: 1 Hz, a decade below the slowest
/// rate powertwin works at (10 Hz). A slower one is a log of another time unit.
const MAX_PERIOD_S: f64 = 1.0;

/// What repairing the time base and the joint angles did.
pub(super) struct TimeBase {
    /// Rows merged into the row before for the same time stamp.
    pub(super) duplicates_merged: usize,
    /// Steps of more than pi unwrapped in joints declared `wrapped`.
    pub(super) unwrapped_jumps: usize,
    /// Steps of more than pi in the other joints.
    pub(super) suspect_jumps: usize,
    /// The first of them, as a warning naming the joint and the file row.
    pub(super) jump_warning: Option<String>,
    /// Median sample period, s.
    pub(super) median_period_s: f64,
    /// RMS deviation of the sample periods (gaps left out) from the median, s.
    pub(super) period_jitter_s: f64,
}

/// Merge duplicated time stamps, unwrap the wrapped joints, count suspect jumps, and measure
/// the sample period and its jitter.
pub(super) fn repair_time_base(
    frame: &mut Frame,
    map: &ColumnMap,
    (t0_s, label): (f64, &str),
    row_name: &dyn Fn(usize) -> String,
) -> Result<TimeBase> {
    let duplicates_merged = clean::merge_duplicates(frame, t0_s, label, row_name)?;
    let wrapped: Vec<usize> = map.joints.wrapped.iter().map(|j| j - 1).collect();
    let unwrapped_jumps = clean::unwrap(frame, &wrapped);
    let jumps = clean::suspect_jumps(frame, &wrapped);
    let jump_warning = jumps.first.map(|(i, k)| {
        let more = match jumps.count - 1 {
            0 => String::new(),
            m => format!(" (and {m} more such step(s) in the log)"),
        };
        format!(
            "joint {} steps by more than pi rad at {}{more}: if its column is logged modulo a \
             turn, declare it in a column map (`wrapped = [{}]`)",
            i + 1,
            row_name(frame.row[k]),
            i + 1
        )
    });
    let median = median_period(&frame.t_s);
    if median <= 0.0 {
        return Err(Error::InvalidInput(format!(
            "{label}: fewer than two distinct time stamps"
        )));
    }
    if median > MAX_PERIOD_S {
        return Err(Error::InvalidInput(format!(
            "{label}: median sample period {median} s, slower than one sample per \
             {MAX_PERIOD_S} s: a robot log is sampled at 10 Hz or faster; if its times are in \
             milliseconds or another unit, say so in a column map (`[time] unit = \"ms\"`)"
        )));
    }
    let steps: Vec<f64> = frame
        .t_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d <= map.clean.max_gap_periods * median)
        .collect();
    let period_jitter_s = (steps.iter().map(|d| (d - median).powi(2)).sum::<f64>()
        / steps.len().max(1) as f64)
        .sqrt();
    Ok(TimeBase {
        duplicates_merged,
        unwrapped_jumps,
        suspect_jumps: jumps.count,
        jump_warning,
        median_period_s: median,
        period_jitter_s,
    })
}

/// The gap-free pieces at the working rate, and what it took.
pub(super) struct Resampled {
    /// The pieces, in time order.
    pub(super) pieces: Vec<Frame>,
    /// Gaps found.
    pub(super) gaps: usize,
    /// Samples in pieces too short to keep, dropped.
    pub(super) short_piece_samples_dropped: usize,
    /// Pieces whose jittered stamps were replaced by their uniform grid.
    pub(super) regularized_pieces: usize,
    /// Largest stamp deviation from the grid among them, s.
    pub(super) regularized_max_dev_s: f64,
    /// Samples averaged per block (1: none).
    pub(super) decimation: usize,
    /// Sample rate worked at, Hz (median of the first piece).
    pub(super) working_rate_hz: f64,
}

/// Split at the gaps, regularize jittered stamps (if asked) and block-average to the working
/// rate.
pub(super) fn split_and_resample(
    frame: Frame,
    map: &ColumnMap,
    label: &str,
    row_name: &dyn Fn(usize) -> String,
) -> Result<Resampled> {
    let split = clean::split_gaps(frame, &map.clean, label, row_name)?;
    if split.pieces.is_empty() {
        return Err(Error::InvalidInput(format!(
            "{label}: every gap-free piece has fewer than {} samples ({} gaps)",
            map.clean.min_piece_samples, split.gaps
        )));
    }
    let mut pieces = split.pieces;
    let (mut regularized_pieces, mut regularized_max_dev_s) = (0, 0.0_f64);
    if map.clean.regularize_jitter {
        for p in &mut pieces {
            if let Some(dev) = clean::regularize(p, map.clean.max_jitter_periods) {
                regularized_pieces += 1;
                regularized_max_dev_s = regularized_max_dev_s.max(dev);
            }
        }
    }
    let mut decimation = 1;
    for p in &mut pieces {
        decimation = clean::decimate(p, map.clean.working_rate_hz);
    }
    let working_rate_hz = 1.0 / median_period(&pieces[0].t_s);
    Ok(Resampled {
        pieces,
        gaps: split.gaps,
        short_piece_samples_dropped: split.dropped_samples,
        regularized_pieces,
        regularized_max_dev_s,
        decimation,
        working_rate_hz,
    })
}

/// The power lag: estimated, applied, and what applying it cost.
pub(super) struct LagOutcome {
    /// The estimate (None when not estimated).
    pub(super) estimate: Option<LagEstimate>,
    /// Why it could not be estimated, if it could not.
    pub(super) note: Option<String>,
    /// Lag applied to the power, s (0: none).
    pub(super) applied_s: f64,
    /// Samples at the ends dropped because the shifted power falls outside the log.
    pub(super) trimmed: usize,
}

/// Estimate the power-vs-joint lag on the longest piece (unless it is fixed) and, if asked,
/// shift the power of every piece by it, dropping pieces left with fewer than 2 samples.
pub(super) fn align_power(
    pieces: &mut Vec<Frame>,
    option: LagOption,
    map: &ColumnMap,
    label: &str,
) -> Result<LagOutcome> {
    let (mut estimate, mut note) = (None, None);
    if !matches!(option, LagOption::Fixed(_)) {
        let longest = pieces.iter().max_by_key(|p| p.len()).unwrap_or(&pieces[0]);
        let max_lag = map
            .clean
            .max_lag_s
            .min(0.25 * longest.t_s.last().unwrap_or(&0.0));
        match lag::estimate_lag(
            &longest.t_s,
            &longest.q_rad,
            longest.dq_rad_s.as_deref(),
            &longest.power_w,
            max_lag,
        ) {
            Ok(l) => estimate = Some(l),
            Err(Error::InvalidInput(m)) => note = Some(m),
            Err(e) => note = Some(e.to_string()),
        }
    }
    let applied_s = match option {
        LagOption::Report => 0.0,
        LagOption::Fixed(v) => v,
        LagOption::Auto => estimate.map(|l| l.lag_s).ok_or_else(|| {
            Error::InvalidInput(format!(
                "{label}: --power-lag auto: {}",
                note.clone().unwrap_or_default()
            ))
        })?,
    };
    let mut trimmed = 0;
    if applied_s != 0.0 {
        for p in pieces.iter_mut() {
            let others = p.motor_power_w.clone().unwrap_or_default();
            let (range, power, motors) = lag::shift(&p.t_s, &p.power_w, &others, applied_s);
            trimmed += p.len() - range.len();
            let mut s = p.slice(range);
            s.power_w = power;
            if s.motor_power_w.is_some() {
                s.motor_power_w = Some(motors);
            }
            *p = s;
        }
        pieces.retain(|p| p.len() >= 2);
        if pieces.is_empty() {
            return Err(Error::InvalidInput(format!(
                "{label}: a power lag of {applied_s} s leaves no two samples whose shifted time lies inside the log"
            )));
        }
    }
    Ok(LagOutcome {
        estimate,
        note,
        applied_s,
        trimmed,
    })
}

/// One [`Log`] per piece, named by the file and, when there are several, the piece's time
/// range.
pub(super) fn into_logs(pieces: Vec<Frame>, label: &str, kind: PowerKind) -> Vec<Log> {
    let split_source = pieces.len() > 1;
    pieces
        .into_iter()
        .map(|p| {
            let source = if split_source {
                format!("{label} [{:.3}-{:.3} s]", p.t_s[0], p.t_s[p.len() - 1])
            } else {
                label.to_string()
            };
            Log {
                source,
                robot: None,
                t_s: p.t_s,
                q_rad: p.q_rad,
                dq_rad_s: p.dq_rad_s,
                power_w: p.power_w,
                signal: kind.signal(),
                motor_power_w: p.motor_power_w,
                power_averaged: false,
                payloads: Vec::new(),
            }
        })
        .collect()
}

/// Rests of at least `long_rest_s` (kept in the logs).
pub(super) struct LongRests {
    /// How many.
    pub(super) count: usize,
    /// Their total duration, s.
    pub(super) total_s: f64,
}

/// Validate every log and count its long rests.
pub(super) fn long_rests(logs: &[Log], map: &ColumnMap) -> Result<LongRests> {
    let (mut count, mut total_s) = (0, 0.0);
    for l in logs {
        l.validate()?;
        for r in segments::rests(l, map.clean.rest_speed_rad_s, map.clean.long_rest_s) {
            count += 1;
            total_s += l.t_s[r.end - 1] - l.t_s[r.start];
        }
    }
    Ok(LongRests { count, total_s })
}
