//! `powertwin optimize`: the cheapest timing (and placement) of a task in the same cycle time,
//! checked on the twin.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::Args;
use powertwin::identification::model::{DATASHEET_EFFICIENCY, PowerModel};
use powertwin::model::drive::Brakes;
use powertwin::optimize::placement::{self, PlacementSearch, SearchBox};
use powertwin::optimize::priced::{
    PlanEnergies, PlanEnergy, PlanSaving, ScheduledSegment, scheduled_segments,
};
use powertwin::optimize::schedule::Schedule;
use powertwin::optimize::segment::Task;
use powertwin::optimize::{self, CycleBound, FrontPoint, Optimized, Options, UniformPoint};
use powertwin::report::figures::{pareto_chart, plan_power_chart};
use powertwin::report::plot::write_chart;
use powertwin::trajectory::task::Scenario;
use powertwin::validation::optimized::{self, Candidate, Checked, PlanCheck};
use powertwin::validation::sweep::{TwinChoice, identified_rig};
use serde::Serialize;

use crate::cli::export::identified_twin;
use crate::cli::progress::Bars;
use crate::cli::{Exit, OverloadArgs, Setup, TwinArgs, emit, read_model, write_all};

/// Arguments of `optimize`.
///
/// Times every segment of the task (TCP speed and acceleration within the joint limits) and
/// the wait that fills the cycle (servos holding, or brakes applied where the drive file gives
/// a `[brakes]` mode) for the least energy the model predicts within the cycle-time bound; the
/// default bound is the cycle time of the uniform plan at --speed. Both plans then run on the
/// twin (--twin: the twin of --robot and --drive, the identified model's, or none). Writes
/// plan.json, pareto.svg/.png (least energy against cycle time, beside the uniform-speed
/// curve), power.svg/.png (power of both plans on the twin) and the twin datasets under --out;
/// with --twin none only plan.json (no simulated values) and pareto.svg/.png.
#[derive(Debug, Args)]
pub struct OptimizeArgs {
    #[command(flatten)]
    twin: TwinArgs,
    /// Which twin checks the plans: `urdf` (the twin of --robot and --drive), `identified`
    /// (the twin of --model's consistent URDF and drive file, as `identify --export-urdf
    /// --export-drive` writes them, with --drive's brakes) or `none` (no physics: the plans
    /// are chosen and reported on the model's predictions with their 95 % intervals). For a
    /// robot that is not our twin, `none` or `identified` is the honest choice.
    #[arg(
        long = "twin",
        value_name = "urdf|none|identified",
        default_value = "urdf"
    )]
    twin_choice: TwinChoice,
    /// Identified model (`identify --out`, or `reproduce`'s out/model.json).
    #[arg(long, value_name = "MODEL.json")]
    model: PathBuf,
    /// Scenario TOML [default: built-in scenarios/pick_and_place.toml].
    #[arg(long, value_name = "PATH")]
    scenario: Option<PathBuf>,
    /// Load level L, kg (load 1 = L/2, heavier load = L, as in the sweep).
    #[arg(long, default_value_t = 2.0)]
    load: f64,
    /// TCP speed of the user's uniform plan, m/s: the reference the saving is measured
    /// against.
    #[arg(long, default_value_t = 0.5)]
    speed: f64,
    /// Cycle-time bound, s [default: the uniform plan's cycle time].
    #[arg(long, value_name = "S", conflicts_with = "max_slowdown")]
    cycle_time: Option<f64>,
    /// Cycle-time bound as a slowdown of the uniform plan, %.
    #[arg(long, value_name = "PCT")]
    max_slowdown: Option<f64>,
    /// Also search for a cheaper placement of the whole task within +-X, +-Y, +-Z (m) and
    /// +-YAW (deg, about the base z axis) of the user's, e.g. 0.1,0.1,0.05,20.
    #[arg(long, value_name = "X,Y,Z,YAW_DEG", value_delimiter = ',')]
    search_offset: Vec<f64>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Print plan.json to stdout instead of a summary.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    overload: OverloadArgs,
    #[cfg(feature = "viz")]
    #[command(flatten)]
    viz: crate::cli::viz::VizArgs,
}

/// `plan.json`.
#[derive(Serialize)]
struct PlanFile<'a> {
    scenario: &'a str,
    load_kg: f64,
    reference_speed_m_s: f64,
    cycle_time_bound_s: f64,
    uniform: &'a UniformPoint,
    segments: Vec<ScheduledSegment>,
    cycle_time_s: f64,
    #[serde(rename = "predicted_J")]
    predicted_j: f64,
    predicted_saving_pct: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    simulated_saving_pct: Option<f64>,
    saving_interval_95_pct: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    within_interval: Option<bool>,
    twin: &'static str,
    twin_note: &'static str,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    twin_runs: Vec<&'a PlanCheck>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    predicted_plans: Vec<&'a PlanEnergy>,
    placement: Option<PlacementOut<'a>>,
    pareto: &'a [FrontPoint],
    uniform_curve: &'a [UniformPoint],
    method: &'static str,
}

#[derive(Serialize)]
struct PlacementOut<'a> {
    search: &'a PlacementSearch,
    #[serde(rename = "optimized_predicted_J")]
    optimized_predicted_j: f64,
    optimized_cycle_time_s: f64,
    saving: PlanSaving,
}

const METHOD: &str = "Every segment is planned alone at 12 TCP speeds (0.15-2 m/s, log-spaced) \
    plus the reference speed, x 3 accelerations (0.25, 0.5 and 1 x the scenario's bound), slowed \
    by the planner where a joint limit binds, and priced by the model; an exact dynamic programme \
    (1 ms slots) picks one timing per segment and the cheapest wait (servos or brakes, at the \
    cheapest via point) under the bound. It needs no smooth objective: the joint-limit kinks are \
    just other candidates. If nothing beats the uniform plan, the uniform plan is returned.";

/// Run the optimisation and the twin check.
pub fn run(args: &OptimizeArgs) -> Result<ExitCode> {
    let (setup, scenario, model) = load(args)?;
    let search_box = search_box(&args.search_offset)?;
    let bound = match (args.cycle_time, args.max_slowdown) {
        (Some(s), _) => CycleBound::Seconds(s),
        (None, Some(p)) => CycleBound::SlowdownPct(p),
        (None, None) => CycleBound::SlowdownPct(0.0),
    };
    let task = Task {
        robot: &setup.robot,
        scenario: &scenario,
        load_kg: args.load,
        model: &model,
        efficiency: DATASHEET_EFFICIENCY,
    };
    #[cfg(feature = "viz")]
    let viz = args.viz.open(None)?;
    #[cfg(feature = "viz")]
    if viz.is_some() && args.twin_choice == TwinChoice::None {
        bail!("--twin none runs no twin: there is nothing to show in Rerun");
    }
    let brakes = setup.drive.brakes();
    let opts = Options::default();
    let started = std::time::Instant::now();
    let found = optimize::optimize(&task, args.speed, bound, brakes, &opts)
        .context("optimising the task's timing")?;
    let placed = match &search_box {
        Some(area) => Some(search_placement(
            &task, args.speed, &found, area, brakes, &opts,
        )?),
        None => None,
    };
    let optimise_s = started.elapsed().as_secs_f64();
    let candidates = candidates(&task, &found, placed.as_ref());
    let (checked, energies) = check_or_price(args, &setup, &task, &found, &candidates)?;
    let out = Outcome {
        found: &found,
        placed: placed.as_ref(),
        checked: checked.as_ref(),
        energies: &energies,
    };
    let json = write_outputs(args, &scenario, &out)?;
    #[cfg(feature = "viz")]
    if let (Some(viz), Some(checked)) = (&viz, &checked) {
        log_viz(viz, &setup.robot, &scenario, checked)?;
    }
    emit(&if args.json {
        json + "\n"
    } else {
        summary(args.twin_choice, &out, optimise_s)
    })?;
    match &checked {
        Some(c) => exit_for_flagged(c, args),
        None => Ok(ExitCode::SUCCESS),
    }
}

/// The robot setup, the scenario and the model, with the load checked against the rating.
fn load(args: &OptimizeArgs) -> Result<(Setup, Scenario, PowerModel)> {
    let setup = args.twin.setup()?;
    if setup.payload.is_some() {
        bail!("--payload does not apply to optimize: the scenario defines the tool and loads");
    }
    let scenario = match &args.scenario {
        Some(p) => Scenario::from_file(p)?,
        None => Scenario::builtin()?,
    };
    args.overload.check_payload(
        scenario.max_payload_kg(args.load),
        &setup.drive,
        &format!(
            "scenario '{}' at load level {} kg",
            scenario.name, args.load
        ),
    )?;
    let model = read_model(&args.model, &setup.robot)?;
    Ok((setup, scenario, model))
}

/// Check the uniform plan and the candidates on the twin `--twin` chooses, or price them with
/// the model alone (`--twin none`: no twin run).
fn check_or_price(
    args: &OptimizeArgs,
    setup: &Setup,
    task: &Task,
    found: &Optimized,
    candidates: &[Candidate],
) -> Result<(Option<Checked>, PlanEnergies)> {
    let brakes = setup.drive.brakes();
    if args.twin_choice == TwinChoice::None {
        let energies = PlanEnergies::priced(task, found, candidates, brakes)?;
        return Ok((None, energies));
    }
    let identified = (args.twin_choice == TwinChoice::Identified)
        .then(|| identified_twin(&setup.robot, task.model, brakes))
        .transpose()?;
    let input = setup.rig();
    let rig = match &identified {
        Some(t) => identified_rig(t, &input),
        None => input,
    };
    let bars = Bars::new();
    let checked = optimized::check(&rig, task, found, candidates, &bars)?;
    bars.finish();
    let energies = PlanEnergies::from_twin(&checked);
    Ok((Some(checked), energies))
}

/// What the optimisation found and what the twin (or the model alone) says of its plans.
struct Outcome<'a> {
    found: &'a Optimized,
    placed: Option<&'a Placed>,
    checked: Option<&'a Checked>,
    energies: &'a PlanEnergies,
}

/// The placement search area of `--search-offset` (X,Y,Z in m, YAW in degrees), if given.
fn search_box(offset: &[f64]) -> Result<Option<SearchBox>> {
    Ok(match offset {
        [] => None,
        [x, y, z, yaw] => Some(SearchBox {
            half_m: [*x, *y, *z],
            half_yaw_rad: yaw.to_radians(),
        }),
        other => bail!(
            "--search-offset takes 4 values (X,Y,Z,YAW_DEG), got {}",
            other.len()
        ),
    })
}

/// The best placement found in the search area, the task moved there, and its optimised
/// timing.
struct Placed {
    search: PlacementSearch,
    moved: Scenario,
    schedule: Schedule,
}

/// Search placements in `area` for the cycle-time bound `found` chose, then optimise the
/// timing at the best one.
fn search_placement(
    task: &Task,
    speed: f64,
    found: &Optimized,
    area: &SearchBox,
    brakes: Option<&Brakes>,
    opts: &Options,
) -> Result<Placed> {
    let search =
        placement::search(task, speed, found.bound_s, area).context("searching placements")?;
    let moved = search.moved(task.scenario);
    let moved_task = Task {
        scenario: &moved,
        ..*task
    };
    let at_best = optimize::optimize(
        &moved_task,
        speed,
        CycleBound::Seconds(found.bound_s),
        brakes,
        opts,
    )
    .context("optimising the task at the best placement")?;
    Ok(Placed {
        search,
        moved,
        schedule: at_best.schedule,
    })
}

/// The optimised plan and (if any) the one at the best placement, to check or price.
fn candidates<'a>(
    task: &Task<'a>,
    found: &'a Optimized,
    placed: Option<&'a Placed>,
) -> Vec<Candidate<'a>> {
    let mut candidates = vec![Candidate {
        name: "optimized",
        task: *task,
        schedule: &found.schedule,
    }];
    if let Some(p) = placed {
        candidates.push(Candidate {
            name: "optimized at the best placement",
            task: Task {
                scenario: &p.moved,
                ..*task
            },
            schedule: &p.schedule,
        });
    }
    candidates
}

/// The twin runs' datasets with their plan names: the uniform plan first.
fn traces(checked: &Checked) -> Vec<(&str, &powertwin::dataset::Dataset)> {
    std::iter::once("uniform")
        .chain(checked.plans.iter().map(|p| p.check.name.as_str()))
        .zip(&checked.datasets)
        .collect()
}

/// Write the datasets, plan.json and the charts under `--out` (with no twin run: plan.json
/// and the Pareto chart); returns plan.json's text.
fn write_outputs(args: &OptimizeArgs, scenario: &Scenario, out: &Outcome) -> Result<String> {
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let found = out.found;
    if let Some(checked) = out.checked {
        let names: Vec<(String, &powertwin::dataset::Dataset)> = ["uniform", "optimized", "placed"]
            .iter()
            .zip(&checked.datasets)
            .map(|(n, d)| (n.to_string(), d))
            .collect();
        write_all(&names, &args.out, args.twin.format)?;
    }
    let e = out.energies;
    let (optimised, saving) = e.plans.first().context("no optimised plan")?;
    let file = PlanFile {
        scenario: &scenario.name,
        load_kg: args.load,
        reference_speed_m_s: args.speed,
        cycle_time_bound_s: found.bound_s,
        uniform: &found.uniform,
        segments: scheduled_segments(scenario.path(), &found.schedule),
        cycle_time_s: found.schedule.cycle_time_s,
        predicted_j: optimised.predicted_j,
        predicted_saving_pct: saving.predicted_saving_pct,
        simulated_saving_pct: saving.simulated_saving_pct,
        saving_interval_95_pct: saving.interval_95_pct,
        within_interval: saving.within_interval,
        twin: args.twin_choice.name(),
        twin_note: args.twin_choice.statement(),
        twin_runs: out.checked.map_or(Vec::new(), |c| {
            std::iter::once(&c.uniform)
                .chain(c.plans.iter().map(|p| &p.check))
                .collect()
        }),
        predicted_plans: match out.checked {
            Some(_) => Vec::new(),
            None => std::iter::once(&e.uniform)
                .chain(e.plans.iter().map(|p| &p.0))
                .collect(),
        },
        placement: out
            .placed
            .zip(e.plans.get(1))
            .map(|(p, (plan, saving))| PlacementOut {
                search: &p.search,
                optimized_predicted_j: plan.predicted_j,
                optimized_cycle_time_s: p.schedule.cycle_time_s,
                saving: *saving,
            }),
        pareto: &found.front,
        uniform_curve: &found.uniform_curve,
        method: METHOD,
    };
    let json = serde_json::to_string_pretty(&file).context("serialising plan.json")?;
    powertwin::io::write_atomic(&args.out.join("plan.json"), json.as_bytes())?;
    write_chart(&pareto_chart(found), &args.out, "pareto", 960, 600)?;
    if let Some(checked) = out.checked {
        write_chart(
            &plan_power_chart(&traces(checked)),
            &args.out,
            "power",
            960,
            600,
        )?;
    }
    Ok(json)
}

/// Send the plans' twin runs, planned motions and brake events to Rerun, side by side.
#[cfg(feature = "viz")]
fn log_viz(
    viz: &powertwin::viz::Viz,
    robot: &powertwin::Robot,
    scenario: &Scenario,
    checked: &Checked,
) -> Result<()> {
    let traces = traces(checked);
    let tcp = scenario.tcp();
    let prefixes: Vec<String> = traces
        .iter()
        .map(|(name, _)| format!("optimize/{}", powertwin::viz::path_part(name)))
        .collect();
    viz.send_blueprint(&[powertwin::viz::Tab::Compare {
        title: "uniform and optimised plans".into(),
        prefixes: prefixes.clone(),
    }])?;
    for (((prefix, (_, ds)), run), windows) in prefixes
        .iter()
        .zip(&traces)
        .zip(&checked.runs)
        .zip(&checked.brakes)
    {
        let events: Vec<(f64, String)> = windows
            .iter()
            .flat_map(|w| {
                [
                    (w.start_s, "brakes hold (servos off)".to_string()),
                    (w.end_s, "brakes released".to_string()),
                ]
            })
            .collect();
        viz.log_events(&events, prefix)?;
        viz.log_run(robot, ds, None, prefix, powertwin::viz::DEFAULT_DISPLAY_HZ)?;
        viz.log_task(robot, run, &tcp, prefix, powertwin::viz::DEFAULT_DISPLAY_HZ)?;
    }
    viz.flush()?;
    Ok(())
}

/// Exit 3 (unless `--allow-overload`), after every output is written, when the twin did not
/// perform a plan as planned; the plans are listed on stderr.
fn exit_for_flagged(checked: &Checked, args: &OptimizeArgs) -> Result<ExitCode> {
    let flagged: Vec<&str> = std::iter::once(&checked.uniform)
        .chain(checked.plans.iter().map(|p| &p.check))
        .filter(|c| c.flagged)
        .map(|c| c.name.as_str())
        .collect();
    if !flagged.is_empty() && !args.overload.allowed() {
        eprintln!(
            "flagged: the twin did not perform these plans as planned (torque saturated or \
             tracking beyond 0.05 rad): {}; pass --allow-overload to accept them",
            flagged.join(", ")
        );
        return Ok(Exit::Flagged.into());
    }
    Ok(ExitCode::SUCCESS)
}

/// Why the timing saves under 1 % (`timing_saving`, %), with the least energy per cycle on the
/// Pareto front.
fn timing_note(found: &Optimized, timing_saving: f64) -> String {
    // The least energy per cycle at any cycle time the front spans.
    let least = found
        .front
        .iter()
        .min_by(|a, b| a.predicted_j.total_cmp(&b.predicted_j));
    let longer = found.bound_s > found.uniform.cycle_time_s * (1.0 + 1e-9);
    let what = if longer && timing_saving < 0.0 {
        "this cycle is longer than the uniform plan's, and the waiting and slower motion \
         over the difference cost more per cycle than they save"
    } else {
        "the uniform plan is already near the least energy the model finds for its cycle time"
    };
    let front = least.map_or(String::new(), |p| {
        format!(
            " Per cycle the model finds at least {:.1} J, at a {:.3} s cycle (Pareto \
             front in pareto.svg).",
            p.predicted_j, p.cycle_time_s
        )
    });
    format!(
        "note: the timing saves under 1 % ({timing_saving:+.1} %): {what}.{front} A placement \
         search (--search-offset) may save more."
    )
}

/// The text summary; under the twin's statement unless the twin is the input's.
fn summary(choice: TwinChoice, out: &Outcome, optimise_s: f64) -> String {
    let mut o = String::new();
    if choice != TwinChoice::Urdf {
        outln!(o, "{}", choice.statement());
    }
    let (found, e) = (out.found, out.energies);
    let twin = |p: &PlanEnergy| {
        p.simulated_j
            .map_or(String::new(), |j| format!(", twin {j:.1} J"))
    };
    let u = &e.uniform;
    outln!(
        o,
        "uniform plan at {} m/s: cycle {:.3} s, predicted {:.1} +- {:.1} J{}",
        found.uniform.speed_m_s,
        u.cycle_time_s,
        u.predicted_j,
        u.interval_j,
        twin(u)
    );
    for (c, s) in &e.plans {
        outln!(
            o,
            "{}: cycle {:.3} s (bound {:.3} s), predicted {:.1} +- {:.1} J{}, brakes {:.2} s",
            c.name,
            c.cycle_time_s,
            found.bound_s,
            c.predicted_j,
            c.interval_j,
            twin(c),
            c.braked_s.max(0.0)
        );
        let checked = match (s.simulated_saving_pct, s.within_interval) {
            (Some(sim), Some(within)) => format!(
                ", twin {sim:.1} % ({})",
                if within {
                    "within the interval"
                } else {
                    "OUTSIDE the interval"
                }
            ),
            _ => String::new(),
        };
        outln!(
            o,
            "  saving: predicted {:.1} +- {:.1} %{checked}",
            s.predicted_saving_pct,
            s.interval_95_pct,
        );
    }
    let timing_saving = e.plans.first().map_or(0.0, |p| p.1.predicted_saving_pct);
    let placed = out.placed.map(|p| &p.search);
    if placed.is_none() && timing_saving < 1.0 {
        outln!(o, "{}", timing_note(found, timing_saving));
    }
    if let Some(p) = placed {
        outln!(
            o,
            "placement: user {:.1} J, best {:.1} J at offset ({:.3}, {:.3}, {:.3}) m, yaw {:.1} deg \
             (uniform plan; {} placements priced, {} infeasible)",
            p.user.predicted_j,
            p.best.predicted_j,
            p.best.offset_m[0],
            p.best.offset_m[1],
            p.best.offset_m[2],
            p.best.yaw_deg,
            p.evaluated,
            p.infeasible
        );
    }
    outln!(o, "optimisation took {optimise_s:.1} s");
    o
}
