//! The held-out benchmark across a family of truths: robots we did not build.
//!
//! Each robot is drawn from the family ([`crate::twin::family`]) around the user's URDF and
//! drive file, identified the way a user would (the identification set run on it, its logs
//! identified with the estimator chosen by cross-validation and the nominal files' prior, as
//! `identify` does by default; the nominal files are all the identification sees) and judged
//! on held-out motions from several seeds of its own. The family's truth only scores. A
//! drawn robot whose torque saturates in any run cannot be tracked: it is redrawn, and the
//! redraw is recorded.

use rayon::prelude::*;
use serde::Serialize;

use crate::dataset::Dataset;
use crate::error::{Error, Result};
use crate::identification::excitation_set::SetDesign;
use crate::identification::prior::{Prior, PriorWidths};
use crate::model::Robot;
pub use crate::twin::family::family_seed;
use crate::twin::family::{FamilyTable, MAX_REDRAWS, Plant, Redraw};
use crate::validation::heldout::{self, Heldout, HeldoutOptions};
use crate::validation::idset::{self, IdSetOptions};
use crate::validation::rig::{Progress, Rig, Together};
use crate::validation::score::{MotionResult, RouteSummary, Spread};

/// Settings of the family benchmark.
#[derive(Debug, Clone)]
pub struct FamilyOptions {
    /// Robots drawn.
    pub robots: usize,
    /// Seed of the family: robot `r`'s family seed is [`family_seed`]`(seed, r, 0)`.
    pub seed: u64,
    /// Sizes of the differences.
    pub table: FamilyTable,
    /// The identification set each robot runs.
    pub idset: IdSetOptions,
    /// The held-out motions (the seed of the first set; the others follow it).
    pub heldout: HeldoutOptions,
    /// Held-out motion sets per robot, seeds `heldout.seed`, `heldout.seed + 1`, ...
    pub heldout_seeds: usize,
    /// Identify with the prior of the user's files (URDF and drive file) at these widths, as
    /// `identify` does by default; `None`: from the data alone.
    pub prior: Option<PriorWidths>,
}

impl FamilyOptions {
    /// The family stage of `reproduce` on the IRB 1200: 4 robots of the default table from
    /// family seed 1, each identified from the quick identification set (four excitations
    /// of 20 s with 0, 2, 4.5 and 7 kg) and judged on 2 x 6 held-out motions up to 7 kg.
    /// `quick`: 2 robots.
    pub fn irb1200(quick: bool) -> FamilyOptions {
        FamilyOptions {
            robots: if quick { 2 } else { 4 },
            seed: 1,
            table: FamilyTable::default(),
            idset: IdSetOptions::irb1200(true),
            heldout: HeldoutOptions::irb1200(6),
            heldout_seeds: 2,
            prior: Some(PriorWidths::default()),
        }
    }
}

/// One robot of the family and its benchmark.
#[derive(Debug, Clone, Serialize)]
pub struct FamilyRobot {
    /// Index in the family (1-based).
    pub index: usize,
    /// Its family seed (`--truth family:SEED`).
    pub family_seed: u64,
    /// Robots drawn before it and refused.
    pub redraws: Vec<Redraw>,
    /// Log rate, Hz.
    pub rate_hz: f64,
    /// Whether the meter averages.
    pub power_averaging: bool,
    /// Cabinet load the meter sees, W.
    #[serde(rename = "cabinet_seen_W")]
    pub cabinet_seen_w: f64,
    /// Power lag, s.
    pub power_lag_s: f64,
    /// The power lag its identification found, s (scored against `power_lag_s`).
    pub fitted_power_lag_s: f64,
    /// Largest tracking error over the held-out motions, rad.
    pub max_tracking_error_rad: f64,
    /// The estimator cross-validation chose.
    pub model: String,
    /// Held-out motions predicted, over all seeds.
    pub motions: usize,
    /// Each held-out motion's scores, seed after seed.
    pub results: Vec<MotionResult>,
    /// From the logs.
    pub from_log: RouteSummary,
    /// From the plans.
    pub from_plan: RouteSummary,
    /// Power RMSE at the logged samples from the logs, W.
    #[serde(rename = "power_rmse_W")]
    pub power_rmse_w: Spread,
}

/// The family benchmark's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct Family {
    /// Seed of the family.
    pub seed: u64,
    /// Held-out motion sets per robot.
    pub heldout_seeds: usize,
    /// Per robot.
    pub robots: Vec<FamilyRobot>,
    /// Pooled over every robot and motion, from the logs.
    pub from_log: RouteSummary,
    /// Pooled, from the plans.
    pub from_plan: RouteSummary,
    /// Pooled power RMSE from the logs, W.
    #[serde(rename = "power_rmse_W")]
    pub power_rmse_w: Spread,
    /// Lowest coverage of one robot from the logs, %.
    pub worst_robot_coverage_pct: f64,
}

/// Run the benchmark over `opts.robots` robots drawn around `rig`'s robot, drive, twin and
/// logger (which must not already be a family robot).
pub fn run(rig: &Rig, opts: &FamilyOptions, progress: &dyn Progress) -> Result<Family> {
    if opts.robots == 0 {
        return Err(Error::InvalidInput(
            "a family needs at least 1 robot".into(),
        ));
    }
    if opts.heldout_seeds == 0 {
        return Err(Error::InvalidInput(
            "a family benchmark needs at least 1 set of held-out motions per robot".into(),
        ));
    }
    if rig.plant.is_some() {
        return Err(Error::InvalidInput(
            "the family is drawn around the files: start from a rig without a family robot".into(),
        ));
    }
    opts.table
        .validate()
        .map_err(|m| Error::InvalidInput(format!("family table: {m}")))?;
    // The robots side by side (each one's runs and fits are parallel too): a robot whose
    // fit is long does not leave a core idle at the end.
    // One identification set for every robot: it is designed on the user's files, which
    // are the same for all of them.
    progress.stage("family: identification set design", 1);
    let design = idset::design(rig.robot, &opts.idset)?;
    progress.advance();
    progress.stage(&format!("family of {} robots", opts.robots), 0);
    let together = Together(progress);
    let drawn = (0..opts.robots)
        .into_par_iter()
        .map(|r| one_robot(rig, opts, &design, r, &together))
        .collect::<Result<Vec<_>>>()?;
    let mut robots = Vec::with_capacity(opts.robots);
    let mut all = Vec::new();
    for (robot, motions) in drawn {
        robots.push(robot);
        all.extend(motions);
    }
    Ok(Family {
        seed: opts.seed,
        heldout_seeds: opts.heldout_seeds,
        worst_robot_coverage_pct: robots
            .iter()
            .map(|r| r.from_log.coverage_pct)
            .fold(100.0, f64::min),
        from_log: RouteSummary::of(all.iter().map(|m| &m.from_log)),
        from_plan: RouteSummary::of(all.iter().map(|m| &m.from_plan)),
        power_rmse_w: Spread::of(all.iter().map(|m| m.power_rmse_w)),
        robots,
    })
}

/// Draw robot `r` (redrawing while it saturates), identify it and score it.
fn one_robot(
    rig: &Rig,
    opts: &FamilyOptions,
    design: &SetDesign,
    r: usize,
    progress: &dyn Progress,
) -> Result<(FamilyRobot, Vec<MotionResult>)> {
    let mut redraws = Vec::new();
    for attempt in 0..=MAX_REDRAWS {
        let seed = family_seed(opts.seed, r, attempt);
        let plant = opts
            .table
            .draw(rig.robot, rig.drive, &rig.twin, &rig.sensor, seed)?;
        match benchmark(rig, &plant, opts, design, progress)? {
            Ok((model, fitted_lag, heldouts)) => {
                let motions: Vec<MotionResult> =
                    heldouts.into_iter().flat_map(|h| h.motions).collect();
                let d = &plant.draw;
                let robot = FamilyRobot {
                    index: r + 1,
                    family_seed: seed,
                    redraws,
                    rate_hz: d.rate_hz,
                    power_averaging: d.power_averaging,
                    cabinet_seen_w: plant.twin.cabinet_power_w,
                    power_lag_s: d.power_lag_s,
                    fitted_power_lag_s: fitted_lag,
                    max_tracking_error_rad: motions
                        .iter()
                        .map(|m| m.max_tracking_error_rad)
                        .fold(0.0, f64::max),
                    model,
                    motions: motions.len(),
                    from_log: RouteSummary::of(motions.iter().map(|m| &m.from_log)),
                    from_plan: RouteSummary::of(motions.iter().map(|m| &m.from_plan)),
                    power_rmse_w: Spread::of(motions.iter().map(|m| m.power_rmse_w)),
                    results: motions.clone(),
                };
                return Ok((robot, motions));
            }
            Err(reason) => redraws.push(Redraw {
                family_seed: seed,
                reason,
            }),
        }
    }
    Err(Error::InvalidInput(format!(
        "family robot {}: every one of {} draws saturated a joint's torque (last: {}); \
         the family table is too wide for this robot",
        r + 1,
        MAX_REDRAWS + 1,
        redraws.last().map_or("", |d| d.reason.as_str())
    )))
}

/// Identify `plant` the way a user would and score it on the held-out sets: the chosen
/// estimator's name, the power lag found (s) and the held-out sets; `Ok(Err(why))` when a
/// twin run saturated (the robot must be redrawn).
#[allow(clippy::type_complexity)]
fn benchmark(
    rig: &Rig,
    plant: &Plant,
    opts: &FamilyOptions,
    design: &SetDesign,
    progress: &dyn Progress,
) -> Result<std::result::Result<(String, f64, Vec<Heldout>), String>> {
    let family_rig = Rig {
        plant: Some(plant),
        ..rig.clone()
    };
    // The prior comes from the user's files (`rig.robot`, `rig.drive`), never the plant's.
    let mut idset_opts = opts.idset.clone();
    if let Some(widths) = &opts.prior {
        idset_opts.fit.prior = Some(Prior::for_robot(rig.robot, Some(rig.drive), widths)?);
    }
    let set = idset::run_designed(&family_rig, &idset_opts, design, progress)?;
    if let Some(why) = set
        .datasets
        .iter()
        .find_map(|ds| saturated(ds, &plant.robot))
    {
        return Ok(Err(format!("identification set: {why}")));
    }
    let model = set.selection.fit.model.clone();
    let mut heldouts = Vec::with_capacity(opts.heldout_seeds);
    for s in 0..opts.heldout_seeds {
        let ho = HeldoutOptions {
            seed: opts.heldout.seed.wrapping_add(s as u64),
            ..opts.heldout.clone()
        };
        let runs = heldout::simulate(&family_rig, &ho, progress)?;
        let (h, datasets) = heldout::evaluate(&family_rig, &model, &ho, runs, progress)?;
        if let Some(why) = datasets.iter().find_map(|ds| saturated(ds, &plant.robot)) {
            return Ok(Err(format!("held-out motions (seed {}): {why}", ho.seed)));
        }
        heldouts.push(h);
    }
    Ok(Ok((
        format!("cv:{}", set.selection.chosen.name()),
        model.power_lag_s,
        heldouts,
    )))
}

/// Why a twin run cannot be scored: a joint's torque at its effort limit (the controller
/// clipped it), with the first time.
fn saturated(ds: &Dataset, robot: &Robot) -> Option<String> {
    robot
        .joints()
        .iter()
        .zip(&ds.truth.tau)
        .find_map(|(j, tau)| {
            let limit = j.limits.effort?;
            let k = tau.iter().position(|t| t.abs() >= limit * (1.0 - 1e-9))?;
            Some(format!(
                "joint '{}' saturated at {limit} N m at t = {:.3} s",
                j.name,
                k as f64 * ds.truth.dt
            ))
        })
}
