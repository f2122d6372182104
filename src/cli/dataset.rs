//! `powertwin dataset`: bulk randomised ground truth on all cores, shardable.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use powertwin::dataset::bulk::{BulkFamily, BulkSpec, Shard, item, item_duration};
use powertwin::dataset::schedule::longest_first;
use powertwin::model::payload::Payload;

use super::{Setup, TruthArgs, TwinArgs};

/// Arguments of `dataset`.
///
/// Item j of the global set is drawn from (seed, j) alone: a random rest-to-rest Fourier
/// excitation or point-to-point motion within the robot's acceleration bounds (those of
/// `excite`), no payload / the tool / the tool plus a 0.5-4 kg steel cube (at most what the
/// drive file's rated payload leaves beside the tool), drive friction, rotor inertia and
/// losses scaled by 0.7-1.3 from the drive file and efficiency 0.83-0.92 (see
/// docs/guide/bulk-datasets.md). With --truth family:SEED, item j instead runs robot j of
/// that family (the robot validate --family --seed SEED draws j-th, family seed
/// SEED * 1000000 + 10 j): its own inertias, friction laws, losses, controller and logger,
/// recorded in its meta.json. A robot whose torque saturates along the item's motion is
/// redrawn (family seed + 1, + 2, ..., at most 5 times), the refused ones listed in
/// meta.json.
#[derive(Debug, Args)]
pub struct DatasetArgs {
    #[command(flatten)]
    twin: TwinArgs,
    /// Number of items in the global set.
    #[arg(long)]
    count: usize,
    /// Seed of the global set.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Produce only shard K of N (items j with j mod N == K, K = 0..N-1), e.g. a Slurm array
    /// task or a Kubernetes indexed Job.
    #[arg(long, value_name = "K/N", default_value = "0/1")]
    shard: Shard,
    /// Output directory; items go to DIR/item_NNNNNN (existing items are skipped).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

/// The tool of every item when no --payload is given (built-in).
const DEFAULT_TOOL: &str = "liu2018_tool";

/// Run `dataset`.
pub fn run(args: &DatasetArgs) -> Result<ExitCode> {
    let setup = args.twin.setup()?;
    let tool = item_tool(&setup)?;
    let family = bulk_family(args.twin.truth_args())?;
    let spec = BulkSpec {
        robot: &setup.robot,
        urdf: setup.urdf.clone(),
        drive: &setup.drive,
        tool: &tool,
        twin: setup.twin.clone(),
        sensor: setup.sensor,
        seed: args.seed,
        family,
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let todo = pending_items(args);
    let skipped = args.shard.items(args.count).count() - todo.len();
    let batch = write_items(args, &spec, &todo);
    Ok(summarise(todo.len(), skipped, &batch))
}

/// The tool of every item: the setup's --payload, else the built-in default tool (warning
/// when it was not made for this robot).
fn item_tool(setup: &Setup) -> Result<Payload> {
    Ok(match setup.payload.clone() {
        Some(p) => p,
        None => {
            crate::cli::warn_foreign_payload(DEFAULT_TOOL, &setup.robot);
            powertwin::model::builtin::payload(DEFAULT_TOOL)?
        }
    })
}

/// The robot family items run instead of scaled drives (`--truth family:SEED`), if any.
fn bulk_family(truth: &TruthArgs) -> Result<Option<BulkFamily>> {
    Ok(match truth.family_seed() {
        Some(seed) => Some(BulkFamily {
            table: truth.family_table()?,
            seed,
        }),
        None => None,
    })
}

/// Global indices of this shard's items that have no `meta.json` in the output directory yet.
fn pending_items(args: &DatasetArgs) -> Vec<usize> {
    args.shard
        .items(args.count)
        .filter(|j| {
            !args
                .out
                .join(format!("item_{j:06}"))
                .join("meta.json")
                .exists()
        })
        .collect()
}

/// What a batch of items came to.
struct Batch {
    /// The error of every item that failed, with its context chain.
    failed: Vec<String>,
    /// Motion time simulated by the written items, s.
    simulated: f64,
    /// Wall-clock time of the batch, s.
    wall: f64,
}

/// Simulates and writes the items `todo` on all cores, longest first, with a progress bar.
fn write_items(args: &DatasetArgs, spec: &BulkSpec, todo: &[usize]) -> Batch {
    let bar = ProgressBar::new(todo.len() as u64).with_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} items, {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let simulated_ms = AtomicUsize::new(0);
    let start = Instant::now();
    // Longest items first, so the batch ends without one long run alone on a core.
    let duration = |&j: &usize| item_duration(spec, j).unwrap_or(f64::INFINITY);
    let results: Vec<Result<()>> = longest_first(todo, duration, |&j| {
        let dir = args.out.join(format!("item_{j:06}"));
        let (ds, _) = item(spec, j).with_context(|| format!("item {j}"))?;
        ds.write(&dir, args.twin.format)
            .with_context(|| format!("writing {}", dir.display()))?;
        let total = simulated_ms.fetch_add(
            (ds.meta.summary.duration_s * 1e3) as usize,
            Ordering::Relaxed,
        );
        let wall = start.elapsed().as_secs_f64();
        bar.set_message(format!(
            "{:.0} simulated s per wall s",
            total as f64 / 1e3 / wall
        ));
        bar.inc(1);
        Ok(())
    });
    bar.finish();
    let failed: Vec<String> = results
        .into_iter()
        .filter_map(|r| r.err())
        .map(|e| format!("{e:#}"))
        .collect();
    let wall = start.elapsed().as_secs_f64();
    let simulated = simulated_ms.load(Ordering::Relaxed) as f64 / 1e3;
    Batch {
        failed,
        simulated,
        wall,
    }
}

/// Prints the batch's counts and throughput and every failure; the exit code is 1 when an
/// item failed.
fn summarise(todo: usize, skipped: usize, batch: &Batch) -> ExitCode {
    let Batch {
        failed,
        simulated,
        wall,
    } = batch;
    eprintln!(
        "{} items written, {skipped} already present, {} failed; {simulated:.0} s simulated in {wall:.1} s ({:.0} simulated s per wall s on {} threads)",
        todo - failed.len(),
        failed.len(),
        simulated / wall.max(1e-9),
        rayon::current_num_threads()
    );
    if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        for f in failed {
            eprintln!("error: {f}");
        }
        ExitCode::from(1)
    }
}
