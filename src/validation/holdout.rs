//! Is my model good? A held-out check of an identification on the user's own logs
//! (`identify --holdout K`): leave out every K-th run (or, with fewer than four runs, every
//! K-th rest-to-rest move; along the Fourier route always runs), identify on the rest with
//! the same options, and predict what was left out as `predict` would
//! ([`crate::validation::log_price`]).
//!
//! Unlike the rest of [`crate::validation`], nothing here uses a twin's truth: the figures are
//! out of sample on the user's own robot, measured energy against predicted, and say how well
//! the model fitted on everything will predict motions like the logged ones.

use std::fmt;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::identification::data::{Route, prepare};
use crate::identification::fit::{FitOptions, identify_logs};
use crate::measurement::Log;
use crate::measurement::segments::{MoveOptions, auto_moves, slice_time};
use crate::model::Robot;
use crate::validation::log_price::price_log;

/// Every how many runs (or moves) one is held out unless told otherwise (K), where there are
/// that many ([`default_every`]).
pub const DEFAULT_EVERY: usize = 4;

/// Fewest pieces a default holdout leaves one of out (the last): below, two pieces would
/// leave half the logs to identify on.
const MIN_DEFAULT_PIECES: usize = 3;

/// Logs from which the held-out pieces are whole logs rather than moves.
pub const MIN_RUNS: usize = 4;

/// Fewest samples of a piece left to identify on between held-out moves (shorter ones are
/// dropped).
const MIN_TRAIN_SAMPLES: usize = 5;

/// What is held out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Unit {
    /// Whole logs (runs).
    Run,
    /// Rest-to-rest moves of the logs.
    Move,
}

impl Unit {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Unit::Run => "run",
            Unit::Move => "move",
        }
    }
}

/// The logs cut for a holdout: what to identify on and what to predict.
#[derive(Debug, Clone, PartialEq)]
pub struct Split {
    /// Whole logs or moves held out.
    pub unit: Unit,
    /// The logs (or their parts between held-out moves) to identify on.
    pub train: Vec<Log>,
    /// The held-out pieces, in order.
    pub held_out: Vec<Log>,
}

/// The K of a holdout the user did not choose: [`DEFAULT_EVERY`], or the number of pieces
/// where there are fewer but at least three (the last piece held out), so that three logs of
/// one excitation each are checked out of sample too. The pieces are [`split`]'s: whole logs
/// from [`MIN_RUNS`] logs on or along the Fourier `route`, else rest-to-rest moves
/// ([`auto_moves`] with `moves`).
pub fn default_every(logs: &[Log], route: Route, moves: &MoveOptions) -> usize {
    let pieces = if whole_logs(route) || logs.len() >= MIN_RUNS {
        logs.len()
    } else {
        logs.iter().map(|l| auto_moves(l, moves).len()).sum()
    };
    if (MIN_DEFAULT_PIECES..DEFAULT_EVERY).contains(&pieces) {
        pieces
    } else {
        DEFAULT_EVERY
    }
}

/// Whether `route` leaves out whole logs only: the Fourier route fits whole periodic logs.
fn whole_logs(route: Route) -> bool {
    matches!(route, Route::Fourier { .. })
}

/// Hold out every `every`-th piece of `logs` (pieces `every`, `2 every`, ..., 1-based): whole
/// logs when there are at least [`MIN_RUNS`] and `every` of them or when `runs` asks for
/// them (the Fourier route fits whole periodic logs), else rest-to-rest moves
/// ([`auto_moves`] with `moves`), numbered across the logs in order. Errors
/// ([`Error::InvalidInput`]): `every` below 2, fewer than `every` pieces.
pub fn split(logs: &[Log], every: usize, runs: bool, moves: &MoveOptions) -> Result<Split> {
    if every < 2 {
        return Err(Error::InvalidInput(format!(
            "holdout every {every}-th piece: give 0 (no holdout) or at least 2"
        )));
    }
    let held = |n: usize| (n + 1).is_multiple_of(every);
    if runs && logs.len() < every {
        return Err(Error::InvalidInput(format!(
            "too few logs to leave out every {}: {} (the Fourier route, --base-freq, fits whole \
             periodic logs and leaves out runs, not moves cut from them)",
            ordinal(every),
            logs.len()
        )));
    }
    if runs || logs.len() >= MIN_RUNS.max(every) {
        let pick = |out: bool| -> Vec<Log> {
            logs.iter()
                .enumerate()
                .filter(|(n, _)| held(*n) == out)
                .map(|(_, l)| l.clone())
                .collect()
        };
        return Ok(Split {
            unit: Unit::Run,
            train: pick(false),
            held_out: pick(true),
        });
    }
    let ranges: Vec<Vec<(f64, f64)>> = logs.iter().map(|l| auto_moves(l, moves)).collect();
    let count: usize = ranges.iter().map(Vec::len).sum();
    if count < every {
        return Err(Error::InvalidInput(format!(
            "too few pieces to leave out every {}: {} logs (runs are left out from {} logs on) \
             with {count} rest-to-rest moves",
            ordinal(every),
            logs.len(),
            MIN_RUNS.max(every)
        )));
    }
    let mut out = Split {
        unit: Unit::Move,
        train: Vec::new(),
        held_out: Vec::new(),
    };
    let mut n = 0;
    for (log, ranges) in logs.iter().zip(&ranges) {
        // The log's samples from `from` on not yet given to a piece.
        let mut from = 0;
        for &r in ranges {
            if held(n) {
                let a = log.t_s.partition_point(|&t| t < r.0);
                push_train(&mut out.train, log, from..a);
                let mut piece = slice_time(log, r)?;
                piece.source = format!("{} [{:.3}-{:.3} s]", log.source, r.0, r.1);
                out.held_out.push(piece);
                from = log.t_s.partition_point(|&t| t <= r.1);
            }
            n += 1;
        }
        push_train(&mut out.train, log, from..log.len());
    }
    Ok(out)
}

/// Add the samples `range` of `log` to `train` when there are at least
/// [`MIN_TRAIN_SAMPLES`].
fn push_train(train: &mut Vec<Log>, log: &Log, range: std::ops::Range<usize>) {
    if range.len() >= MIN_TRAIN_SAMPLES {
        train.push(if range.len() == log.len() {
            log.clone()
        } else {
            log.slice(range)
        });
    }
}

/// One held-out piece predicted by the model identified without it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOutPiece {
    /// Where the piece came from (a log, or a log's time range).
    pub source: String,
    /// Energy of the measured signal over the piece, J.
    #[serde(rename = "measured_J")]
    pub measured_j: f64,
    /// Predicted energy, J.
    #[serde(rename = "predicted_J")]
    pub predicted_j: f64,
    /// Half-width of the 95 % interval of the prediction, J.
    #[serde(rename = "interval_95_J")]
    pub interval_j: f64,
    /// Predicted minus measured energy, % of the measured.
    pub error_pct: f64,
    /// Whether the measured energy lies inside the 95 % interval.
    pub covered: bool,
    /// RMS of predicted minus measured power at the samples, W.
    #[serde(rename = "power_rmse_W")]
    pub power_rmse_w: f64,
}

/// The outcome of a holdout: out-of-sample figures on the user's own robot.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Holdout {
    /// Every how many pieces one was held out (K).
    pub every: usize,
    /// Whole runs or moves held out.
    pub unit: Unit,
    /// Logs (or parts of logs) identified on.
    pub trained_on: usize,
    /// The held-out pieces, in order.
    pub pieces: Vec<HeldOutPiece>,
    /// Median over the pieces of |energy error|, %.
    pub median_abs_error_pct: f64,
    /// Largest |energy error|, %.
    pub worst_abs_error_pct: f64,
    /// Fraction of the pieces whose measured energy lies inside the 95 % interval (0-1).
    pub coverage: f64,
    /// Median over the pieces of the power RMSE, W.
    #[serde(rename = "median_power_rmse_W")]
    pub median_power_rmse_w: f64,
}

/// Hold out every `every`-th run or move of `logs` ([`split`]), identify `robot` on the rest
/// along `route` with `opts` ([`identify_logs`]), and predict each held-out piece with that
/// model; along the Fourier route the pieces are whole logs (it fits whole periodic logs). The
/// figures are out of sample on the user's own robot. Errors: those of [`split`], those of
/// the identification on the remaining logs (e.g. too little excitation left) and of the
/// prediction.
pub fn holdout(
    robot: &Robot,
    logs: &[Log],
    every: usize,
    route: Route,
    opts: &FitOptions,
    moves: &MoveOptions,
) -> Result<Holdout> {
    let s = split(logs, every, whole_logs(route), moves)?;
    let model = identify_logs(robot, &s.train, &[route], opts)?.fit.model;
    let pieces = s
        .held_out
        .iter()
        .map(|log| {
            let p = prepare(log, route)?;
            let price = price_log(&model, robot, &p, &log.source)?;
            let pred = price.prediction;
            Ok(HeldOutPiece {
                source: log.source.clone(),
                measured_j: price.measured_j,
                predicted_j: pred.energy_j,
                interval_j: pred.interval_j,
                error_pct: price.error_pct(),
                covered: (pred.energy_j - price.measured_j).abs() <= pred.interval_j,
                power_rmse_w: price.rmse_w(),
            })
        })
        .collect::<Result<Vec<HeldOutPiece>>>()?;
    let abs_err: Vec<f64> = pieces.iter().map(|p| p.error_pct.abs()).collect();
    let rmse: Vec<f64> = pieces.iter().map(|p| p.power_rmse_w).collect();
    Ok(Holdout {
        every,
        unit: s.unit,
        trained_on: s.train.len(),
        median_abs_error_pct: median(&abs_err),
        worst_abs_error_pct: abs_err.iter().copied().fold(0.0, f64::max),
        coverage: pieces.iter().filter(|p| p.covered).count() as f64 / pieces.len() as f64,
        median_power_rmse_w: median(&rmse),
        pieces,
    })
}

/// Median of `v` (mean of the middle two for an even count; NaN when empty).
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// `1st`, `2nd`, `3rd`, `4th`, ..., `11th`, ..., `21st`.
fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

impl fmt::Display for Holdout {
    /// The report `identify --holdout` prints: one line per held-out piece, then the summary.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "holdout (out of sample, on your own robot): every {} {} left out ({}), identified on the other {} logs or parts, each left out predicted",
            ordinal(self.every),
            self.unit.name(),
            self.pieces.len(),
            self.trained_on
        )?;
        for p in &self.pieces {
            writeln!(
                f,
                "  {}: measured {:.2} J, predicted {:.2} ± {:.2} J (95 %), error {:+.3} % ({}), power RMSE {:.3} W",
                p.source,
                p.measured_j,
                p.predicted_j,
                p.interval_j,
                p.error_pct,
                if p.covered {
                    "inside the interval"
                } else {
                    "OUTSIDE the interval"
                },
                p.power_rmse_w
            )?;
        }
        write!(
            f,
            "holdout: median |energy error| {:.3} %, worst {:.3} %, {} of {} inside the 95 % interval ({:.0} %), median power RMSE {:.3} W",
            self.median_abs_error_pct,
            self.worst_abs_error_pct,
            self.pieces.iter().filter(|p| p.covered).count(),
            self.pieces.len(),
            100.0 * self.coverage,
            self.median_power_rmse_w
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measurement::PowerSignal;

    /// A one-joint log at 10 Hz: `moves` moves of 1 s between rests of 1 s.
    fn log(moves: usize) -> Log {
        let t_s: Vec<f64> = (0..=(20 * moves + 10)).map(|k| k as f64 * 0.1).collect();
        let q: Vec<f64> = t_s
            .iter()
            .map(|&t| {
                let (m, s) = ((t / 2.0).floor(), t % 2.0);
                let ramp = if s < 1.0 { 0.0 } else { s - 1.0 };
                m.min(moves as f64) + if m < moves as f64 { ramp } else { 0.0 }
            })
            .collect();
        Log {
            source: "log".into(),
            robot: None,
            power_w: vec![1.0; t_s.len()],
            t_s,
            q_rad: vec![q],
            dq_rad_s: None,
            signal: PowerSignal::Total,
            motor_power_w: None,
            power_averaged: false,
            payloads: Vec::new(),
        }
    }

    #[test]
    fn runs_then_moves_are_held_out() {
        let opts = MoveOptions::default();
        let five: Vec<Log> = (0..5).map(|_| log(1)).collect();
        let s = split(&five, 4, false, &opts).unwrap();
        assert_eq!((s.unit, s.train.len(), s.held_out.len()), (Unit::Run, 4, 1));
        let s = split(&five, 2, false, &opts).unwrap();
        assert_eq!((s.train.len(), s.held_out.len()), (3, 2));
        // Two logs of four moves: moves 4 and 8 held out, the rests around them kept.
        let two = vec![log(4), log(4)];
        assert_eq!(auto_moves(&two[0], &opts).len(), 4);
        let s = split(&two, 4, false, &opts).unwrap();
        assert_eq!((s.unit, s.held_out.len()), (Unit::Move, 2));
        assert_eq!(s.train.len(), 4);
        let held: usize = s.held_out.iter().map(Log::len).sum();
        let train: usize = s.train.iter().map(Log::len).sum();
        assert!(held + train <= 2 * two[0].len(), "{held} + {train}");
        assert!(split(&[log(3)], 4, false, &opts).is_err());
        assert!(split(&five, 1, false, &opts).is_err());
        // Runs asked for (the Fourier route): whole logs, never moves.
        let s = split(&two, 2, true, &opts).unwrap();
        assert_eq!((s.unit, s.train.len(), s.held_out.len()), (Unit::Run, 1, 1));
        assert!(split(&two, 4, true, &opts).is_err());
    }

    /// Three logs of one move each are checked by default too: the third held out.
    #[test]
    fn a_default_holdout_leaves_out_the_last_of_three_pieces() {
        let opts = MoveOptions::default();
        let logs = |k: usize, moves: usize| -> Vec<Log> { (0..k).map(|_| log(moves)).collect() };
        let fourier = Route::Fourier {
            base_freq_hz: 0.5,
            harmonics: 3,
        };
        assert_eq!(default_every(&logs(3, 1), Route::Spline, &opts), 3);
        assert_eq!(default_every(&logs(3, 1), fourier, &opts), 3);
        assert_eq!(
            default_every(&logs(5, 1), Route::Spline, &opts),
            DEFAULT_EVERY
        );
        // Two logs of four moves: every 4th move; of one move each: too few either way.
        assert_eq!(
            default_every(&logs(2, 4), Route::Spline, &opts),
            DEFAULT_EVERY
        );
        assert_eq!(default_every(&logs(2, 4), fourier, &opts), DEFAULT_EVERY);
        assert_eq!(
            default_every(&logs(2, 1), Route::Spline, &opts),
            DEFAULT_EVERY
        );
        let s = split(&logs(3, 1), 3, false, &opts).unwrap();
        assert_eq!((s.unit, s.held_out.len()), (Unit::Move, 1));
    }

    #[test]
    fn ordinals() {
        let o: Vec<String> = [2, 3, 4, 11, 12, 21, 22, 113].map(ordinal).to_vec();
        assert_eq!(
            o,
            ["2nd", "3rd", "4th", "11th", "12th", "21st", "22nd", "113th"]
        );
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }
}
