//! Any arm end to end: the Universal Robots UR5 (6 joints, not of the OPW class) and the Franka
//! Emika Panda (7 joints, fingers locked) through excite -> simulate -> identify -> predict ->
//! sweep, with the models, drive files and scenarios of `models/` and `scenarios/`. The library
//! chain is checked with numbers; one CLI run per robot checks that every command takes
//! `--robot`, `--drive` (and `--lock`).

use crate::common;

use std::path::{Path, PathBuf};

use common::{run as powertwin, tmp};
use nalgebra::{Isometry3, Translation3, Vector3};
use powertwin::dataset::Dataset;
use powertwin::dataset::generate::{RunSpec, simulate};
use powertwin::dataset::meta::Urdf;
use powertwin::dynamics::ParamLayout;
use powertwin::identification::consistency::consistency;
use powertwin::identification::data::{Route, prepare};
use powertwin::identification::excitation::{ExcitationOptions, design, rest_pose};
use powertwin::identification::model::PowerModel;
use powertwin::identification::pmsm;
use powertwin::identification::states::States;
use powertwin::kinematics::dls::{self, DlsOptions};
use powertwin::kinematics::fk::tcp_pose;
use powertwin::model::drive::Drive;
use powertwin::model::urdf::{LoadOptions, load_file};
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::limits::check_limits;
use powertwin::trajectory::linear_move::{LinearMoveOptions, ViaPose, plan};
use powertwin::trajectory::random::{RandomFourierOptions, random_fourier};
use powertwin::trajectory::s_curve::SCurve;
use powertwin::trajectory::task::Scenario;
use powertwin::twin::TwinConfig;
use powertwin::twin::physics::PhysicsSettings;
use powertwin::twin::sensor::SensorSettings;
use powertwin::validation::heldout::{self, HeldoutOptions};
use powertwin::validation::idset::IdSetOptions;
use powertwin::validation::rig::{Rig, Silent};
use powertwin::validation::sweep;
use powertwin::{Error, Robot};

/// Panda finger joints, locked (closed) for every command.
const PANDA_LOCK: [&str; 2] = ["panda_finger_joint1", "panda_finger_joint2"];

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// One arm's files.
struct Arm {
    urdf: &'static str,
    lock: &'static [&'static str],
    drive: &'static str,
    scenario: &'static str,
    /// Load level of the sweep, kg.
    load_kg: f64,
}

const UR5: Arm = Arm {
    urdf: "models/ur5.urdf",
    lock: &[],
    drive: "models/ur5.drive.toml",
    scenario: "scenarios/ur5_pick_and_place.toml",
    load_kg: 4.0,
};

const PANDA: Arm = Arm {
    urdf: "models/panda.urdf",
    lock: &PANDA_LOCK,
    drive: "models/panda.drive.toml",
    scenario: "scenarios/panda_pick_and_place.toml",
    load_kg: 2.0,
};

/// Bounds a chain must meet.
struct Bounds {
    /// Condition number of each excitation design (its identifiable columns).
    cond: f64,
    /// Condition number of the stacked identification regressor (PMSM, all designs).
    ident_cond: f64,
    /// RMS of the identification residual, W (the power meter's noise is 1 W).
    residual_w: f64,
    /// |error| of the predicted energy of the held-out motion, % of the simulated energy.
    heldout_pct: f64,
    /// |error| of every sweep cell's energy predicted from the plan, %.
    sweep_pct: f64,
}

fn load(arm: &Arm) -> (Robot, Drive, Urdf) {
    let path = repo(arm.urdf);
    let opts = LoadOptions {
        lock: arm.lock.iter().map(|s| s.to_string()).collect(),
    };
    let robot = load_file(&path, &opts).expect("the model loads");
    let drive = Drive::from_file(&repo(arm.drive), &robot).expect("the drive file loads");
    let text = std::fs::read_to_string(&path).unwrap();
    (robot, drive, Urdf::file(arm.urdf, &text))
}

/// Excitations designed per arm, and 10 s periods of each.
const EXCITATIONS: usize = 3;
const PERIODS: usize = 4;
/// Seeds of the held-out random motions.
const HELDOUT_SEEDS: [u64; 3] = [11, 12, 13];
/// Rapier substeps per physics step.
const SUBSTEPS: usize = 3;

/// Run the twin along `traj` (noise seed offset `run`) and check that it tracked the
/// reference without hitting a torque limit.
fn run(rig: &Rig, traj: &dyn Trajectory, run: u64) -> Dataset {
    let (data, report) = simulate(&RunSpec {
        robot: rig.robot,
        urdf: rig.urdf.clone(),
        drive: rig.drive,
        events: &[],
        brakes: &[],
        twin: rig.twin.clone(),
        sensor: SensorSettings {
            seed: run,
            ..rig.sensor
        },
        trajectory: traj,
        trajectory_description: serde_json::json!({"run": run}),
        trajectory_seed: None,
        family: None,
    })
    .unwrap();
    assert!(
        report.torque_limit_hits.is_empty() && report.max_tracking_error_rad < 1e-3,
        "{}: run {run}: {report:?}",
        rig.robot.name()
    );
    data
}

/// The arm's true standby power, W (for scoring only).
fn standby_w(drive: &Drive) -> f64 {
    drive.joints().iter().map(|j| j.standby_power).sum()
}

/// The library chain on one arm, with the figures printed and checked against `bounds`.
fn chain(arm: &Arm, bounds: &Bounds) {
    let (robot, drive, urdf) = load(arm);
    let n = robot.dof();
    let scenario = Scenario::from_file(&repo(arm.scenario)).expect("the scenario parses");
    let accel = scenario.motion.limits.joint_accel_rad_s2.clone();

    // Excite: all joints, EXCITATIONS designs (optimiser seeds 1, 2, ...) of PERIODS 10 s
    // periods each, a short optimisation.
    let mut designs = Vec::new();
    for k in 0..EXCITATIONS {
        let mut opts =
            ExcitationOptions::new(&robot, (0..n).collect(), vec![0.0; n], accel.clone());
        opts.rest_pose = rest_pose(
            &robot,
            opts.position_margin + 0.05,
            opts.floor_z,
            opts.base_radius,
        )
        .expect("a rest pose exists");
        opts.periods = PERIODS;
        opts.starts = 1;
        opts.max_evals = 2000;
        opts.seed = 1 + k as u64;
        let clock = std::time::Instant::now();
        designs.push(design(&robot, &opts).expect("the excitation design succeeds"));
        eprintln!(
            "{}: design {:.1} s",
            robot.name(),
            clock.elapsed().as_secs_f64()
        );
    }

    // Simulate: the twin with default noise, 10 Hz logging, 3 Rapier substeps per 1 ms step
    // (as `reproduce`).
    let rig = Rig {
        plant: None,
        robot: &robot,
        urdf,
        drive: &drive,
        twin: TwinConfig {
            physics: PhysicsSettings {
                dt: 1e-3,
                substeps: SUBSTEPS,
            },
            ..TwinConfig::default()
        },
        sensor: SensorSettings::default(),
    };

    // Identify: PMSM losses, all base parameters at once, samples near reversals left out.
    let mut states: Option<States> = None;
    let mut y = Vec::new();
    for (k, ex) in designs.iter().enumerate() {
        let data = run(&rig, &ex.trajectory, k as u64);
        let mut prepared = prepare(
            &data.log("excitation").unwrap(),
            Route::Fourier {
                base_freq_hz: 0.1,
                harmonics: 5,
            },
        )
        .unwrap();
        prepared.drop_slow_samples(0.05).unwrap();
        y.extend_from_slice(&prepared.p_total);
        match &mut states {
            None => states = Some(prepared.states),
            Some(s) => s.append(&prepared.states).unwrap(),
        }
    }
    let states = states.unwrap();
    let mut model = PowerModel::new(&robot, ParamLayout::new(&robot, true, true), false).unwrap();
    let est = pmsm::identify(&robot, &mut model, &states, &y).unwrap();
    let consistent = consistency(&robot, &model, 1.0, 200, 1).unwrap();
    let ex = designs
        .iter()
        .max_by(|a, b| a.cond_final.total_cmp(&b.cond_final))
        .unwrap();

    // Predict held-out motions: random Fourier motions from other seeds, differentiated
    // along the spline route as for any logged motion.
    let heldout_opts = RandomFourierOptions {
        accel_limits: accel,
        limit_fraction: 0.6,
        min_amplitude: 0.3,
        ..RandomFourierOptions::default()
    };
    let mut heldout = Vec::new();
    for seed in HELDOUT_SEEDS {
        let traj = random_fourier(&robot, &mut common::rng(seed), &heldout_opts).unwrap();
        let data = run(&rig, &traj, 100 + seed);
        let p = prepare(&data.log("held out").unwrap(), Route::Spline).unwrap();
        let predicted = model.energy(&robot, p.motion.as_ref(), 1e-3).unwrap();
        let simulated = data.meta.summary.energy_total_j;
        // The share above the true standby power (scored with the truth, never fitted on it).
        let above = simulated - standby_w(&drive) * traj.duration();
        heldout.push((
            predicted,
            simulated,
            100.0 * (predicted - simulated) / simulated,
            100.0 * (predicted - simulated) / above,
        ));
    }
    let heldout_pct = heldout
        .iter()
        .map(|h| h.2)
        .fold(0.0f64, |a, b| if b.abs() > a.abs() { b } else { a });

    // Sweep: two speeds, one load, predicted from the plan with the known tool and loads.
    let mut scenario = scenario;
    scenario.sweep.speeds_m_s = vec![0.1, 0.5];
    scenario.sweep.loads_kg = vec![arm.load_kg];
    let planned = sweep::plan(&robot, &scenario).unwrap();
    let result = sweep::run(
        &rig,
        &scenario,
        planned,
        Some((&model, drive.nominal_efficiency())),
        &Silent,
    )
    .unwrap();

    eprintln!(
        "{}: excitation cond {:.1} -> {:.1}; identification residual RMS {:.3} W over {} \
         samples, cond {:.1}, consistent {} (min mass-matrix eigenvalue {:.4} kg m^2, \
         negative drive terms {:?}); held out (predicted J, simulated J, error %, error % of the energy above \
         standby): {heldout:.3?}; identified standby {:.2} W, true {:.2} W",
        robot.name(),
        ex.cond_initial,
        ex.cond_final,
        est.residual_rms,
        est.rows,
        est.cond,
        consistent.consistent,
        consistent.min_eigenvalue,
        consistent.negative_drive_terms,
        model.constant.iter().sum::<f64>(),
        standby_w(&drive),
    );
    for c in &result.cells {
        eprintln!(
            "{}: sweep {} m/s, {} kg: cycle {:.2} s, simulated {:.1} J, predicted {:.1} J ({:+.3} %), {} slowed",
            robot.name(),
            c.speed_m_s,
            c.load_kg,
            c.cycle_time_s,
            c.simulated_j,
            c.predicted_j.unwrap(),
            c.error_pct.unwrap(),
            c.slowed.len()
        );
    }

    assert!(
        ex.cond_final < bounds.cond && ex.cond_final < ex.cond_initial,
        "{}: condition number {} (start {})",
        robot.name(),
        ex.cond_final,
        ex.cond_initial
    );
    assert!(
        est.cond < bounds.ident_cond,
        "{}: identification condition number {}",
        robot.name(),
        est.cond
    );
    assert!(
        est.residual_rms < bounds.residual_w,
        "{}: residual RMS {} W",
        robot.name(),
        est.residual_rms
    );
    assert!(
        heldout_pct.abs() < bounds.heldout_pct,
        "{}: worst held-out energy error {heldout_pct} %",
        robot.name()
    );
    let [slow, fast] = [&result.cells[0], &result.cells[1]];
    assert!(slow.speed_m_s < fast.speed_m_s);
    // Faster is shorter, and at 0.1 m/s the cycle's standby and holding losses outweigh the
    // extra friction and copper losses of 0.5 m/s.
    assert!(fast.cycle_time_s < 0.5 * slow.cycle_time_s);
    assert!(
        slow.simulated_j > fast.simulated_j,
        "{}: {} J at 0.1 m/s, {} J at 0.5 m/s",
        robot.name(),
        slow.simulated_j,
        fast.simulated_j
    );
    for c in &result.cells {
        assert!(
            c.error_pct.unwrap().abs() < bounds.sweep_pct,
            "{}: sweep cell {} m/s: {} %",
            robot.name(),
            c.speed_m_s,
            c.error_pct.unwrap()
        );
    }
}

// Bounds: about twice the figures measured (2026-11-23, this machine) unless stated; the
// residual at the power meter's noise (1 W) plus 30 %. Measured UR5: design condition numbers
// up to 1067, identification 106.1, residual 0.99 W, held out -0.71, -0.94, -0.62 %, sweep
// -0.60 % and -0.33 %. Measured Panda: 4194, 75.2, 0.94 W, -2.47, -1.76, -1.08 %, +0.13 % and
// +0.09 %. The held-out bound is the accuracy issue's "realistic truth" worst case (2 %) for
// the UR5; the Panda's motions spend little above its standby power (about 50 of 330 J), so
// its identified standby (27.46 W against 28 W) dominates the miss and its bound is 4 %.

#[test]
fn ur5_excite_identify_predict_and_sweep() {
    chain(
        &UR5,
        &Bounds {
            cond: 2000.0,
            ident_cond: 300.0,
            residual_w: 1.3,
            heldout_pct: 2.0,
            sweep_pct: 1.5,
        },
    );
}

#[test]
fn panda_excite_identify_predict_and_sweep() {
    chain(
        &PANDA,
        &Bounds {
            cond: 8000.0,
            ident_cond: 300.0,
            residual_w: 1.3,
            heldout_pct: 4.0,
            sweep_pct: 1.0,
        },
    );
}

/// The CLI commands take `--robot`, `--drive` and `--lock` for another arm.
fn cli(arm: &Arm, tag: &str) {
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (urdf, drive, scenario) = (repo(arm.urdf), repo(arm.drive), repo(arm.scenario));
    let lock = arm.lock.join(",");
    let mut robot = vec!["--robot".to_string(), s(&urdf)];
    if !lock.is_empty() {
        robot.extend(["--lock".to_string(), lock]);
    }
    let with_drive = |mut v: Vec<String>| {
        v.extend(["--drive".to_string(), s(&drive)]);
        v
    };
    let call = |cmd: &str, extra: &[String]| {
        let mut args: Vec<&str> = vec![cmd];
        args.extend(extra.iter().map(String::as_str));
        let (code, out, err) = powertwin(&args);
        assert_eq!(code, 0, "{tag} {cmd}: {err}");
        out
    };
    let (model, sw) = (tmp(&format!("{tag}.json")), tmp(&format!("{tag}_sweep")));
    // Three excitations (optimiser seeds 1-3), each run on the twin.
    let mut datasets = Vec::new();
    for seed in 1..=EXCITATIONS {
        let (traj, data) = (
            tmp(&format!("{tag}_{seed}.csv")),
            tmp(&format!("{tag}_{seed}_data")),
        );
        let mut a = robot.clone();
        a.extend(
            [
                "--periods",
                "4",
                "--starts",
                "1",
                "--evals",
                "300",
                "--json",
            ]
            .map(String::from),
        );
        a.extend(["--seed".into(), seed.to_string(), "--out".into(), s(&traj)]);
        let report: serde_json::Value = serde_json::from_str(&call("excite", &a)).unwrap();
        // An infinite condition number (rank-deficient start) is written as null.
        let cond = |k: &str| report[k].as_f64().unwrap_or(f64::INFINITY);
        assert!(
            cond("cond_final") < cond("cond_initial") / 1000.0,
            "{tag}: {report}"
        );
        let mut a = with_drive(robot.clone());
        a.extend(["--trajectory".into(), s(&traj), "--out".into(), s(&data)]);
        a.extend(["--noise-seed".into(), seed.to_string()]);
        a.extend(["--substeps".into(), SUBSTEPS.to_string()]);
        a.extend(["--truth".into(), "exact".into()]);
        call("simulate", &a);
        datasets.push(s(&data));
    }
    let data = datasets[0].clone();
    let mut a = robot.clone();
    a.extend(
        [
            "--method",
            "pmsm",
            "--base-freq",
            "0.1",
            "--min-speed",
            "0.05",
        ]
        .map(String::from),
    );
    a.push("--data".into());
    a.extend(datasets);
    a.extend(["--out".into(), s(&model)]);
    call("identify", &a);
    let mut a = robot.clone();
    a.extend(["--model".into(), s(&model), "--data".into(), data]);
    a.extend(["--base-freq", "0.1", "--json"].map(String::from));
    let v: serde_json::Value = serde_json::from_str(&call("predict", &a)).unwrap();
    // In-sample (the first excitation was fitted on): a smoke check of the command, not of
    // accuracy; the library test above and the sweep below are held out.
    let e = v["error_vs_simulated_pct"].as_f64().unwrap();
    assert!(
        e.is_finite() && v["interval_95_J"].as_f64().unwrap() > 0.0,
        "{tag}: {v}"
    );
    // The held-out benchmark on this arm: its own acceleration bounds, start poses and rated
    // payload (from the drive file).
    let mut a = with_drive(robot.clone());
    a.extend(["--model".into(), s(&model)]);
    a.extend(["--count", "3", "--truth", "exact", "--json"].map(String::from));
    let v: serde_json::Value = serde_json::from_str(&call("validate", &a)).unwrap();
    let motions = v["motions"].as_array().unwrap();
    assert_eq!(motions.len(), 3, "{tag}: {v}");
    assert_eq!(motions[2]["kind"], "linear", "{tag}: {v}");
    // The excitations carried no payload, so the wrists' copper losses are held at zero; the
    // loaded motions' intervals keep those coefficients' spread and cover the truth (on the
    // UR5 the loaded motions were 0.5-1.3 % low and outside their intervals before).
    for m in motions {
        let e = m["from_log"]["energy_error_pct"].as_f64().unwrap();
        assert!(e.abs() < 5.0, "{tag} held-out motion: {m}");
        assert_eq!(m["from_log"]["covered"], true, "{tag} held-out motion: {m}");
    }
    // The optimised timing at the uniform plan's own cycle time is never dearer than that
    // plan, as one motion (it was 0.3 % dearer on the Panda when the segments' summed
    // durations passed the plan's by a rounding error and the uniform plan was excluded).
    let opt = tmp(&format!("{tag}_opt"));
    let mut a = with_drive(robot.clone());
    a.extend([
        "--model".into(),
        s(&model),
        "--scenario".into(),
        s(&scenario),
        "--out".into(),
        s(&opt),
    ]);
    a.extend(["--load", "1", "--speed", "0.5", "--json"].map(String::from));
    let v: serde_json::Value = serde_json::from_str(&call("optimize", &a)).unwrap();
    let saving = v["predicted_saving_pct"].as_f64().unwrap();
    assert!(saving >= -1e-9, "{tag}: optimised plan {saving} % dearer");
    // Bulk ground truth on this arm: its acceleration bounds, payloads within its rating.
    let bulk = tmp(&format!("{tag}_bulk"));
    let mut a = with_drive(robot.clone());
    a.extend(["--count", "6", "--seed", "3", "--out"].map(String::from));
    a.push(s(&bulk));
    call("dataset", &a);
    let rated = load(arm).1.rated_payload_kg().unwrap();
    for k in 0..6 {
        let meta = std::fs::read_to_string(bulk.join(format!("item_{k:06}/meta.json"))).unwrap();
        let meta: serde_json::Value = serde_json::from_str(&meta).unwrap();
        for p in meta["payloads"].as_array().unwrap() {
            let kg = p["mass_kg"].as_f64().unwrap();
            assert!(kg <= rated, "{tag} item {k}: {kg} kg");
        }
    }
    // Without a rated payload in the drive file, the largest payload must be given.
    let unrated = tmp(&format!("{tag}_unrated.drive.toml"));
    let text = std::fs::read_to_string(&drive).unwrap();
    assert!(
        text.contains("\nrated_payload_kg"),
        "{tag}: the drive file rates a payload"
    );
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| !l.starts_with("rated_payload_kg"))
        .collect();
    std::fs::write(&unrated, kept.join("\n")).unwrap();
    let mut a = robot.clone();
    a.extend(["--drive".into(), s(&unrated), "--model".into(), s(&model)]);
    a.extend(["--count", "3"].map(String::from));
    let mut args: Vec<&str> = vec!["validate"];
    args.extend(a.iter().map(String::as_str));
    let (code, _, err) = powertwin(&args);
    assert!(code != 0 && err.contains("--max-payload"), "{tag}: {err}");
    // So must it for a family, whose identification loads go up to it.
    let unrated_path = s(&unrated);
    let mut args: Vec<&str> = vec!["validate", "--family", "1", "--drive", &unrated_path];
    args.extend(robot.iter().map(String::as_str));
    let (code, _, err) = powertwin(&args);
    assert!(
        code != 0 && err.contains("--max-payload"),
        "{tag} family: {err}"
    );
    let mut a = with_drive(robot);
    a.extend([
        "--scenario".into(),
        s(&scenario),
        "--model".into(),
        s(&model),
    ]);
    a.extend(["--substeps".into(), SUBSTEPS.to_string()]);
    a.extend(["--truth".into(), "exact".into()]);
    a.extend(["--speeds", "0.3", "--loads", "1", "--json", "--out"].map(String::from));
    a.push(s(&sw));
    let v: serde_json::Value = serde_json::from_str(&call("sweep", &a)).unwrap();
    let cell = &v["cells"][0];
    eprintln!(
        "{tag} CLI: in-sample prediction {e:+.3} %, sweep cell at 0.3 m/s with 1 kg {:+.3} %",
        cell["error_pct"].as_f64().unwrap_or(f64::NAN)
    );
    assert!(cell["simulated_J"].as_f64().unwrap() > 0.0, "{tag}: {v}");
    assert!(
        cell["error_pct"].as_f64().unwrap().abs() < 3.0,
        "{tag}: {v}"
    );
}

/// `validate --family` on an arm other than the IRB 1200: each drawn robot is identified
/// from the identification set derived for the arm (centres spread over its joint space,
/// loads up to its rated payload) with the estimator asked for, and judged on held-out
/// motions it was not fitted on.
#[test]
fn a_family_of_ur5s_is_identified_from_a_set_derived_for_the_arm() {
    let (robot, drive, _) = load(&UR5);
    let rated = drive.rated_payload_kg().unwrap();
    let set = IdSetOptions::for_arm(&robot, rated, false).unwrap();
    assert_eq!(set.centres.len(), 8);
    assert_eq!(set.loads_kg.iter().cloned().fold(0.0, f64::max), rated);
    assert_eq!(set.loads_kg[0], 0.0);
    for centre in &set.centres {
        for (q, j) in centre.iter().zip(robot.joints()) {
            assert!(*q > j.limits.lower && *q < j.limits.upper, "{centre:?}");
        }
    }
    let err = IdSetOptions::for_arm(&robot, 0.0, false).unwrap_err();
    assert!(err.to_string().contains("rated payload"), "{err}");
    let (urdf, drive) = (repo(UR5.urdf), repo(UR5.drive));
    let (urdf, drive) = (urdf.to_str().unwrap(), drive.to_str().unwrap());
    let args = [
        "validate", "--robot", urdf, "--drive", drive, "--family", "1", "--count", "3", "--method",
        "pmsm", "--json",
    ];
    let (code, out, err) = powertwin(&args);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let robot = &v["robots"][0];
    assert_eq!(robot["model"], "cv:pmsm", "{robot}");
    assert_eq!(robot["motions"], 6, "{robot}");
    // The lag identification found is reported beside the drawn one (30 ms, found as 30.1).
    let (drawn, found) = (&robot["power_lag_s"], &robot["fitted_power_lag_s"]);
    let (drawn, found) = (drawn.as_f64().unwrap(), found.as_f64().unwrap());
    assert!(
        (found - drawn).abs() < 0.002,
        "drawn {drawn} s, found {found} s"
    );
    let error = &v["from_log"]["energy_error_pct"];
    eprintln!("a UR5 of the family, 6 held-out motions: energy error from the log {error}");
    assert!(error["worst"].as_f64().unwrap() < 3.0, "{error}");
    // A method that fits no candidates is refused.
    let mut bad = args.to_vec();
    bad[10] = "energy";
    let (code, _, err) = powertwin(&bad);
    assert!(code != 0 && err.contains("cross-validated"), "{err}");
}

#[test]
fn ur5_cli_commands_take_robot_and_drive() {
    cli(&UR5, "ur5");
}

#[test]
fn panda_cli_commands_take_robot_drive_and_lock() {
    cli(&PANDA, "panda");
}

/// The held-out benchmark's motions on an arm other than the IRB 1200 stay within its joint
/// limits and its acceleration bounds, with payloads up to its rated payload, and include
/// linear moves (drawn from the middle of its joint ranges).
fn heldout_motions_fit(arm: &Arm) {
    let (robot, drive, _) = load(arm);
    let rated = drive
        .rated_payload_kg()
        .expect("the drive file rates a payload");
    let opts = HeldoutOptions::for_robot(&robot, 12, rated).unwrap();
    assert_eq!(opts.accel_limits.len(), robot.dof());
    let motions = heldout::motions(&robot, &opts).expect("the motions draw");
    assert_eq!(motions.len(), 12);
    for m in &motions {
        check_limits(
            &robot,
            m.trajectory.as_ref(),
            0.002,
            Some(&opts.accel_limits),
        )
        .unwrap_or_else(|e| panic!("{}: {} motion: {e}", arm.urdf, m.kind));
        assert!(m.payload_kg <= rated, "{}: {} kg", arm.urdf, m.payload_kg);
    }
    assert_eq!(motions.iter().filter(|m| m.kind == "linear").count(), 4);
    // Options sized for another arm are refused, not drawn.
    let wrong = HeldoutOptions {
        linear_start: vec![(0.0, 1.0); robot.dof() + 1],
        ..opts
    };
    let err = heldout::motions(&robot, &wrong).err().expect("refused");
    assert!(err.to_string().contains("linear_start"), "{err}");
}

#[test]
fn heldout_motions_fit_the_ur5_and_the_panda() {
    heldout_motions_fit(&UR5);
    heldout_motions_fit(&PANDA);
}

/// The planned motion at `t`.
fn at(traj: &dyn Trajectory, t: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = traj.dof();
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    traj.sample(t, &mut q, &mut dq, &mut ddq);
    (q, dq, ddq)
}

#[test]
fn numerical_linear_moves_stay_on_the_lines_with_exact_derivatives() {
    // An independent reconstruction of q(t) for each leg: the S-curve, the point on the line,
    // damped least squares to 1e-13 from the planned q with the same joints held. Its central
    // differences must match the planned dq and ddq; the TCP must stop on the via points.
    let tight = DlsOptions {
        position_tolerance: 1e-13,
        orientation_tolerance: 1e-13,
        ..DlsOptions::default()
    };
    for (arm, held) in [(&UR5, vec![]), (&PANDA, vec![2])] {
        let (robot, _, _) = load(arm);
        let sc = Scenario::from_file(&repo(arm.scenario)).unwrap();
        // Slow enough that no leg is slowed for the joint limits (the Panda's are low).
        let speed = 0.1;
        let run = sc.plan(&robot, speed, 0.0).unwrap();
        assert!(run.motion.slowed.is_empty(), "{:?}", run.motion.slowed);
        let (lim, tcp) = (sc.motion.limits.clone(), sc.tcp());
        check_limits(&robot, &run.motion, 1e-3, Some(&lim.joint_accel_rad_s2)).unwrap();
        for v in &run.via {
            let (q, dq, _) = at(&run.motion, v.arrival_s);
            let p = tcp_pose(&robot, &q, &tcp);
            assert!((p.translation.vector - v.tcp_m).norm() < 1e-9, "{}", v.name);
            assert!(p.rotation.angle_to(&sc.orientation()) < 1e-9, "{}", v.name);
            assert!(dq.iter().all(|x| x.abs() < 1e-9), "{}: {dq:?}", v.name);
        }
        // Steps for the first and second differences, s: small enough for the truncation
        // error, large enough for the IK tolerance.
        let (h1, h2) = (1e-4, 1e-3);
        let (mut ep, mut ev, mut ea, mut held_moved) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for k in 0..run.via.len() - 1 {
            let (a, b) = (run.via[k].tcp_m, run.via[k + 1].tcp_m);
            let len = (b - a).norm();
            let profile = SCurve::new(len, speed, lim.accel_m_s2, lim.jerk_m_s3).unwrap();
            let (t0, t1) = (run.via[k].arrival_s, run.via[k + 1].arrival_s);
            for i in 0..40 {
                let t = t0 + (t1 - t0) * (i as f64 + 0.377) / 40.0;
                let (q, dq, ddq) = at(&run.motion, t);
                let q_true = |t: f64| {
                    let p = a + (b - a) * (profile.sample(t - t0)[0] / len);
                    let pose = Isometry3::from_parts(Translation3::from(p), sc.orientation());
                    dls::solve_held(&robot, &pose, &tcp, &q, &tight, &held).unwrap()
                };
                let q0 = q_true(t);
                let (vm, vp) = (q_true(t - h1), q_true(t + h1));
                let (am, ap) = (q_true(t - h2), q_true(t + h2));
                for j in 0..robot.dof() {
                    ep = ep.max((q[j] - q0[j]).abs());
                    ev = ev.max(((vp[j] - vm[j]) / (2.0 * h1) - dq[j]).abs());
                    ea = ea.max(((ap[j] - 2.0 * q0[j] + am[j]) / (h2 * h2) - ddq[j]).abs());
                }
                for &j in &held {
                    held_moved = held_moved.max((q[j] - sc.seed_rad[j]).abs());
                    held_moved = held_moved.max(dq[j].abs()).max(ddq[j].abs());
                }
            }
        }
        eprintln!(
            "{}: q {ep:.3e} rad, dq {ev:.3e} rad/s, ddq {ea:.3e} rad/s^2 from the \
             reconstruction; held joints moved {held_moved:.3e}",
            robot.name()
        );
        assert!(ep < 1e-8, "{}: q differs by {ep:.3e} rad", robot.name());
        assert!(ev < 2e-6, "{}: dq differs by {ev:.3e} rad/s", robot.name());
        assert!(
            ea < 1e-2,
            "{}: ddq differs by {ea:.3e} rad/s^2",
            robot.name()
        );
        assert_eq!(held_moved, 0.0, "{}", robot.name());
    }
}

#[test]
fn numerical_linear_moves_name_what_fails() {
    let (ur5, _, _) = load(&UR5);
    let sc = Scenario::from_file(&repo(UR5.scenario)).unwrap();
    let pose = |name: &str, p: [f64; 3]| ViaPose {
        name: name.into(),
        tcp: Isometry3::from_parts(Translation3::from(Vector3::from(p)), sc.orientation()),
    };
    let a = pose("A", [0.45, 0.0, 0.30]);
    let opts = &sc.motion;
    // A via point out of reach is named.
    let far = [a.clone(), pose("far", [1.5, 0.0, 0.3])];
    let e = plan(&ur5, &sc.tcp(), &sc.seed_rad, &far, 0.3, opts).unwrap_err();
    assert!(matches!(e, Error::Unreachable(_)), "{e}");
    assert!(e.to_string().contains("via point 2 'far'"), "{e}");
    // A leg over the base axis (the UR5's shoulder singularity) fails on the segment, named.
    let over = [a.clone(), pose("behind", [-0.45, 0.0, 0.30])];
    let e = plan(&ur5, &sc.tcp(), &sc.seed_rad, &over, 0.3, opts).unwrap_err();
    eprintln!("ur5 over the base axis: {e}");
    assert!(e.to_string().contains("segment 1 (A -> behind)"), "{e}");
    // A 6-joint arm holds no joint; a 7-joint arm holds one, given once and in range.
    let mut held = opts.clone();
    held.hold_joints = vec![3];
    let e = plan(&ur5, &sc.tcp(), &sc.seed_rad, &far, 0.3, &held).unwrap_err();
    assert!(e.to_string().contains("holds 0 joints"), "{e}");
    let (panda, _, _) = load(&PANDA);
    let sp = Scenario::from_file(&repo(PANDA.scenario)).unwrap();
    for bad in [vec![3, 4], vec![8], vec![0]] {
        let mut sc = sp.clone();
        sc.motion.hold_joints = bad.clone();
        let e = sc.plan(&panda, 0.3, 0.0).unwrap_err();
        assert!(matches!(e, Error::InvalidInput(_)), "{bad:?}: {e}");
    }
    // Without hold_joints, one joint is chosen and held for the whole task.
    let mut auto = sp.clone();
    auto.motion.hold_joints.clear();
    let run = auto.plan(&panda, 0.3, 0.0).unwrap();
    let fixed: Vec<usize> = (0..7)
        .filter(|&j| {
            let q0 = at(&run.motion, 0.0).0[j];
            (0..200).all(|i| {
                let t = run.motion.duration_s * i as f64 / 199.0;
                at(&run.motion, t).0[j] == q0
            })
        })
        .collect();
    eprintln!("panda: automatically held joint(s) {fixed:?} (1-based: +1)");
    assert_eq!(fixed.len(), 1, "{fixed:?}");
    // A robot with fewer than 6 joints cannot follow a TCP pose.
    let five = load_file(
        &repo(UR5.urdf),
        &LoadOptions {
            lock: vec!["wrist_3_joint".into()],
        },
    )
    .unwrap();
    let e = plan(
        &five,
        &sc.tcp(),
        &[0.0; 5],
        &far,
        0.3,
        &LinearMoveOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, Error::Model(_)), "{e}");
}

#[test]
fn every_cell_of_both_scenarios_plans_within_the_joint_limits() {
    for arm in [&UR5, &PANDA] {
        let (robot, _, _) = load(arm);
        let sc = Scenario::from_file(&repo(arm.scenario)).unwrap();
        let acc = &sc.motion.limits.joint_accel_rad_s2;
        let planned = sweep::plan(&robot, &sc).unwrap();
        assert_eq!(
            planned.len(),
            sc.sweep.speeds_m_s.len() * sc.sweep.loads_kg.len()
        );
        let mut cycle = Vec::new();
        for p in &planned {
            check_limits(&robot, &p.plan.motion, 1e-3, Some(acc)).unwrap();
            if p.load == 0.0 {
                cycle.push((
                    p.speed,
                    p.plan.motion.duration_s,
                    p.plan.motion.slowed.len(),
                ));
            }
        }
        eprintln!(
            "{}: (speed m/s, cycle s, slowed legs) {cycle:?}",
            robot.name()
        );
        // Faster commands never give a longer cycle.
        assert!(cycle.windows(2).all(|w| w[1].1 <= w[0].1), "{cycle:?}");
    }
}
