//! `--log FILE...` or `--runs runs.toml` and their options, shared by `identify` and
//! `predict`: a user's measured logs read into [`Log`]s, with each file's read report printed
//! to stderr.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use powertwin::measurement::Log;
use powertwin::measurement::columns::{ColumnMap, PowerKind};
use powertwin::measurement::manifest::Manifest;
use powertwin::measurement::read::{LagOption, ReadOptions, read_log};
use powertwin::measurement::segments::{MoveOptions, SegmentSpec, select};

/// Measured logs (CSV or Parquet) instead of twin datasets.
#[derive(Debug, Args)]
pub struct LogArgs {
    /// Measured log files, CSV or Parquet: time, joint positions, optional joint velocities,
    /// power. Without --columns, powertwin's own names: t_s, q1_rad.., dq1_rad_s..,
    /// P_total_W or p_elec1_W.. (see docs/guide/log-columns.md).
    #[arg(long, value_name = "FILE", num_args = 1.., group = "log_input")]
    pub log: Vec<PathBuf>,
    /// A runs manifest (TOML): several logs, each with its own payload, and optionally its
    /// own column map, power kind and segments (`[[run]] log = "..." payload = "none"`; see
    /// docs/guide/your-robot.md). Paths in it are relative to the manifest.
    #[arg(
        long,
        value_name = "runs.toml",
        group = "log_input",
        conflicts_with_all = ["columns", "power", "segments", "payload", "payload_events"]
    )]
    pub runs: Option<PathBuf>,
    /// Column map: a TOML file naming the columns and units, or the preset `ur-rtde`
    /// (Universal Robots RTDE recordings).
    #[arg(long, value_name = "MAP.toml|ur-rtde", requires = "log")]
    pub columns: Option<String>,
    /// What the logged power is (overrides the column map): per-motor, total, bus (DC bus,
    /// never negative) or grid.
    #[arg(long, value_name = "per-motor|total|bus|grid", requires = "log")]
    pub power: Option<PowerKind>,
    /// Lag of the power behind the joints: `report` (estimate and print only), `auto`
    /// (estimate and align), or a lag in seconds to align by (positive: power is late).
    #[arg(
        long,
        value_name = "auto|report|SECONDS",
        default_value = "report",
        requires = "log_input"
    )]
    pub power_lag: LagOption,
    /// Parts of the logs to use: `all`, `auto` (rest-to-rest moves) or time ranges in seconds
    /// from each file's first sample, e.g. `0-12.5,20-40`.
    #[arg(
        long,
        value_name = "all|auto|START-END,...",
        default_value = "all",
        requires = "log"
    )]
    pub segments: SegmentSpec,
}

/// Read every `--log` file, or every run of `--runs` (printing each file's read report to
/// stderr), and cut the segments.
pub fn load_logs(args: &LogArgs) -> Result<Vec<Log>> {
    if let Some(path) = &args.runs {
        return load_runs(path, args.power_lag);
    }
    if args.log.is_empty() {
        bail!("no --log file given");
    }
    let map = args
        .columns
        .as_deref()
        .map(ColumnMap::load)
        .transpose()
        .with_context(|| {
            format!(
                "loading the column map {}",
                args.columns.as_deref().unwrap_or_default()
            )
        })?;
    let opts = ReadOptions {
        power: args.power,
        lag: args.power_lag,
    };
    let moves = map
        .as_ref()
        .map_or(MoveOptions::default(), |m| MoveOptions {
            rest_speed_rad_s: m.clean.rest_speed_rad_s,
            ..MoveOptions::default()
        });
    let mut logs = Vec::new();
    for path in &args.log {
        let (pieces, report) = read_log(path, map.as_ref(), &opts)
            .with_context(|| format!("reading log {}", path.display()))?;
        eprintln!("{report}");
        logs.extend(pieces);
    }
    let selected = select(&logs, &args.segments, &moves)?;
    if args.segments != SegmentSpec::All {
        print_segments(&selected, 0);
    }
    Ok(selected)
}

/// Read every run of the manifest at `path` (printing each file's read report and its
/// segments to stderr), with the power aligned as `lag` says.
fn load_runs(path: &std::path::Path, lag: LagOption) -> Result<Vec<Log>> {
    let manifest = Manifest::from_file(path)?;
    let mut logs = Vec::new();
    for run in &manifest.runs {
        let (pieces, report) = manifest.read_run(run, lag)?;
        eprintln!("{}: {report}", run.label());
        if run.segments != SegmentSpec::All {
            print_segments(&pieces, logs.len());
        }
        logs.extend(pieces);
    }
    Ok(logs)
}

/// Print the segments `logs` on stderr, numbered from `first + 1`.
fn print_segments(logs: &[Log], first: usize) {
    for (k, l) in logs.iter().enumerate() {
        eprintln!(
            "segment {}: {} ({:.3}-{:.3} s, {} samples)",
            first + k + 1,
            l.source,
            l.t_s[0],
            l.t_s[l.len() - 1],
            l.len()
        );
    }
}
