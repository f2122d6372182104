//! `powertwin validate`: judge an identified model on held-out motions run on the twin.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use powertwin::validation::family::{Family, FamilyOptions};
use powertwin::validation::heldout::{self, Heldout, HeldoutOptions};
use powertwin::validation::idset::IdSetOptions;

use crate::cli::identify::Method;
use crate::cli::progress::Bars;
use crate::cli::{Setup, TwinArgs, emit, read_model, write_all};

/// Default seed of the held-out motions.
const HELDOUT_SEED: u64 = 90_210;

/// Arguments of `validate`.
///
/// Draws held-out motions from a seed of their own (random Fourier motions about random
/// centres, random point-to-point moves, linear TCP moves at 0.05–1 m/s, payloads from none
/// to --max-payload), runs each on the twin, and predicts its energy with the model from the
/// 10 Hz log and from the commanded trajectory, beside a baseline without identification
/// (the URDF with the data-sheet efficiency). Prints median / 95th percentile / worst of the
/// energy error, the error above standby, the mean-power error, the power RMSE and the
/// coverage of the 95 % intervals; with --out, writes heldout.json and the datasets.
///
/// With --family N instead of --model: N robots we did not build, drawn around the URDF and
/// drive file (see --truth family:SEED), each identified the way a user would (the
/// identification set run on it, cross-validated, with the files' prior as identify's
/// default; the files are all identification sees) and
/// judged on --count held-out motions from each of two seeds; prints each robot and the
/// pooled figures, and with --out writes family.json. The IRB 1200 runs the identification
/// set of `reproduce`; any other arm the same set derived for it (eight excitations about
/// centres spread over its joint space, loads from none to --max-payload), as `excite --set`
/// designs one.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    #[command(flatten)]
    twin: TwinArgs,
    /// Identified model (`identify --out`, or `reproduce`'s model.json).
    #[arg(long, value_name = "MODEL.json", required_unless_present = "family")]
    model: Option<PathBuf>,
    /// Draw N robots from the family of truths and identify and judge each (no --model).
    #[arg(long, value_name = "N", conflicts_with = "model")]
    family: Option<usize>,
    /// Number of held-out motions [default: 30; 12 per seed with --family].
    #[arg(long)]
    count: Option<usize>,
    /// Seed of the motions (keep it apart from the identification data's) [default: 90210];
    /// with --family, the seed of the family [default: 1] (robot r's family seed is printed).
    #[arg(long)]
    seed: Option<u64>,
    /// Largest payload, kg [default: the drive file's rated payload (rated_payload_kg; the
    /// IRB 1200's 7 kg)]; with --family also the heaviest identification load.
    #[arg(long)]
    max_payload: Option<f64>,
    /// With --family: the estimators each robot's identification chooses from by
    /// cross-validation, as identify's --method [default: auto].
    #[arg(long, value_enum)]
    method: Option<Method>,
    /// Output directory for heldout.json and the twin datasets.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print heldout.json to stdout instead of a table.
    #[arg(long)]
    json: bool,
}

/// Held-out motion sets per family robot.
const FAMILY_HELDOUT_SEEDS: usize = 2;

/// Run `validate`.
pub fn run(args: &ValidateArgs) -> Result<ExitCode> {
    if args.method.is_some() && args.family.is_none() {
        anyhow::bail!("--method applies to --family (a --model is already identified)");
    }
    let setup = args.twin.setup()?;
    let Some(model_path) = &args.model else {
        return family(args, &setup);
    };
    let model = read_model(model_path, &setup.robot)?;
    let opts = heldout_options(args, &setup)?;
    let rig = setup.rig();
    let bars = Bars::new();
    let (h, datasets) = heldout::run(&rig, &model, &opts, &bars)?;
    bars.finish();
    let json = serde_json::to_string_pretty(&h)?;
    if let Some(dir) = &args.out {
        write_heldout(args, dir, &json, &h, &datasets)?;
    }
    if args.json {
        return emit(&format!("{json}\n")).map(|_| ExitCode::SUCCESS);
    }
    emit(&heldout_table(&h))?;
    Ok(ExitCode::SUCCESS)
}

/// The held-out motions `args` ask for on `setup`'s robot: `--count` motions up to
/// `--max-payload` (the drive file's rated payload by default), from `--seed`.
fn heldout_options(args: &ValidateArgs, setup: &Setup) -> Result<HeldoutOptions> {
    let rated = setup.drive.rated_payload_kg();
    let Some(max_payload) = args.max_payload.or(rated) else {
        anyhow::bail!(
            "the drive file gives no rated payload (rated_payload_kg): pass --max-payload KG, \
             the largest payload of the held-out motions"
        );
    };
    if !(max_payload.is_finite() && max_payload > 0.0) {
        anyhow::bail!("--max-payload {max_payload} must be a positive mass in kg");
    }
    powertwin::model::payload::check_rated(max_payload, rated, "--max-payload")?;
    let count = args.count.unwrap_or(30);
    if count == 0 {
        anyhow::bail!("--count must be at least 1");
    }
    Ok(HeldoutOptions {
        seed: args.seed.unwrap_or(HELDOUT_SEED),
        ..HeldoutOptions::for_robot(&setup.robot, count, max_payload)?
    })
}

/// `heldout.json` (`json`) and every held-out motion's dataset into `dir`.
fn write_heldout(
    args: &ValidateArgs,
    dir: &std::path::Path,
    json: &str,
    h: &Heldout,
    datasets: &[powertwin::dataset::Dataset],
) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    powertwin::io::write_atomic(&dir.join("heldout.json"), json.as_bytes())?;
    let names: Vec<String> = h
        .motions
        .iter()
        .map(|m| format!("heldout_{:02}_{}", m.index, m.kind))
        .collect();
    let items: Vec<(String, &powertwin::dataset::Dataset)> =
        names.into_iter().zip(datasets).collect();
    write_all(&items, &dir.join("datasets"), args.twin.format())?;
    Ok(())
}

/// The held-out benchmark as printed: a row per motion, the summaries.
fn heldout_table(h: &Heldout) -> String {
    let mut o = String::new();
    outln!(
        o,
        "{:>3} {:<15} {:>6} {:>6} {:>9} {:>9} {:>8} {:>9} {:>8} {:>8} {:>9}",
        "#",
        "motion",
        "kg",
        "s",
        "true J",
        "log %",
        "±95% J",
        "plan %",
        "RMSE W",
        "plan W",
        "base %"
    );
    for m in &h.motions {
        outln!(
            o,
            "{:>3} {:<15} {:>6.2} {:>6.1} {:>9.1} {:>+9.3} {:>8.1} {:>+9.3} {:>8.2} {:>8.2} {:>+9.1}",
            m.index,
            m.kind,
            m.payload_kg,
            m.duration_s,
            m.true_j,
            m.from_log.energy_error_pct,
            m.from_log.interval_j,
            m.from_plan.energy_error_pct,
            m.power_rmse_w,
            m.plan_power_rmse_w,
            m.baseline.energy_error_pct
        );
    }
    for (name, s) in [
        ("from the log ", &h.from_log),
        ("from the plan", &h.from_plan),
        ("baseline     ", &h.baseline),
    ] {
        outln!(
            o,
            "{name}: energy error % median {:.3} p95 {:.3} worst {:.3}; above standby worst {:.3} %; mean power worst {:.3} W; 95 % coverage {:.0} %{}",
            s.energy_error_pct.median,
            s.energy_error_pct.p95,
            s.energy_error_pct.worst,
            s.above_standby_error_pct.worst,
            s.mean_power_error_w.worst,
            s.coverage_pct,
            s.median_z.map_or(String::new(), |z| format!(
                " (median |error| {z:.2} sigma; calibrated 0.67)"
            ))
        );
    }
    outln!(
        o,
        "power RMSE W median {:.2} p95 {:.2} worst {:.2} from the log; worst {:.2} from the plan (baseline worst {:.1})",
        h.power_rmse_w.median,
        h.power_rmse_w.p95,
        h.power_rmse_w.worst,
        h.plan_power_rmse_w.worst,
        h.baseline_power_rmse_w.worst
    );
    o
}

fn family(args: &ValidateArgs, setup: &Setup) -> Result<ExitCode> {
    let robots = args.family.unwrap_or(0);
    if robots == 0 {
        anyhow::bail!("--family {robots}: give at least 1 robot");
    }
    if setup.plant.is_some() {
        anyhow::bail!("--family draws its own robots: leave out --truth family:SEED");
    }
    let count = args.count.unwrap_or(12);
    if count == 0 {
        anyhow::bail!("--count must be at least 1");
    }
    let irb1200 = setup.robot.name() == powertwin::model::builtin::IRB1200_NAME;
    let max_payload = match args.max_payload.or(setup.drive.rated_payload_kg()) {
        Some(kg) => kg,
        None if irb1200 => 7.0,
        None => anyhow::bail!(
            "--family: the drive file has no rated_payload_kg; give --max-payload, the \
             heaviest load the identification set and the held-out motions may carry"
        ),
    };
    let mut idset = if irb1200 {
        IdSetOptions::irb1200(false)
    } else {
        IdSetOptions::for_arm(&setup.robot, max_payload, false)
            .context("--family: designing the identification set of this arm")?
    };
    if let Some(method) = args.method {
        idset.fit.candidates = method.candidates().with_context(|| {
            format!(
                "--method {}: validate --family identifies with the cross-validated \
                 estimators (auto, total, pmsm or gear)",
                method
                    .to_possible_value()
                    .map_or_else(String::new, |v| v.get_name().to_owned())
            )
        })?;
    }
    let opts = FamilyOptions {
        robots,
        seed: args.seed.unwrap_or(1),
        table: args.twin.truth_args().family_table()?,
        idset,
        heldout: HeldoutOptions::for_robot(&setup.robot, count, max_payload)?,
        heldout_seeds: FAMILY_HELDOUT_SEEDS,
        prior: Some(powertwin::identification::prior::PriorWidths::default()),
    };
    let bars = Bars::new();
    let rig = setup.rig();
    let f = powertwin::validation::family::run(&rig, &opts, &bars)?;
    bars.finish();
    let json = serde_json::to_string_pretty(&f)?;
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        powertwin::io::write_atomic(&dir.join("family.json"), json.as_bytes())?;
    }
    if args.json {
        return emit(&format!("{json}\n")).map(|_| ExitCode::SUCCESS);
    }
    emit(&family_table(&f))?;
    Ok(ExitCode::SUCCESS)
}

/// The family's per-robot and pooled figures as text.
fn family_table(f: &Family) -> String {
    let mut o = String::new();
    outln!(
        o,
        "{:>3} {:>12} {:>6} {:>4} {:>5} {:>6} {:>6} {:>8} {:>8} {:>8} {:>6} {:>8} {:>8} {:>7} {:<14}",
        "#",
        "family seed",
        "Hz",
        "avg",
        "cab W",
        "lag ms",
        "fit ms",
        "log med%",
        "log max%",
        "plan max%",
        "cover%",
        "|z| med",
        "RMSE W",
        "redraws",
        "model"
    );
    for r in &f.robots {
        outln!(
            o,
            "{:>3} {:>12} {:>6.0} {:>4} {:>5.0} {:>6.0} {:>6.1} {:>8.3} {:>8.3} {:>8.3} {:>6.0} {:>8.2} {:>8.2} {:>7} {:<14}",
            r.index,
            r.family_seed,
            r.rate_hz,
            if r.power_averaging { "yes" } else { "no" },
            r.cabinet_seen_w,
            1e3 * r.power_lag_s,
            1e3 * r.fitted_power_lag_s,
            r.from_log.energy_error_pct.median,
            r.from_log.energy_error_pct.worst,
            r.from_plan.energy_error_pct.worst,
            r.from_log.coverage_pct,
            r.from_log.median_z.unwrap_or(f64::NAN),
            r.power_rmse_w.worst,
            r.redraws.len(),
            r.model
        );
    }
    for (name, s) in [
        ("from the log ", &f.from_log),
        ("from the plan", &f.from_plan),
    ] {
        outln!(
            o,
            "pooled {name}: energy error % median {:.3} p95 {:.3} worst {:.3}; above standby worst {:.3} %; 95 % coverage {:.0} % (median |z| {:.2}; calibrated 0.67)",
            s.energy_error_pct.median,
            s.energy_error_pct.p95,
            s.energy_error_pct.worst,
            s.above_standby_error_pct.worst,
            s.coverage_pct,
            s.median_z.unwrap_or(f64::NAN)
        );
    }
    outln!(
        o,
        "pooled power RMSE W median {:.2} worst {:.2}; lowest coverage of one robot {:.0} %",
        f.power_rmse_w.median,
        f.power_rmse_w.worst,
        f.worst_robot_coverage_pct
    );
    o
}
