//! The family of truths: drawing robots we did not build, the effects they add to the twin
//! (direction-dependent gear friction, cabinet load, power lag, stamp jitter), the lag the
//! identification finds, and the CLI's errors.

use crate::common;

use powertwin::identification::data::Route;
use powertwin::identification::fit::{FitOptions, identify_logs};
use powertwin::identification::model::PowerModel;
use powertwin::model::drive::Drive;
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::fourier::Fourier;
use powertwin::twin::Fidelity;
use powertwin::twin::family::FamilyTable;
use powertwin::twin::sensor::{NoiseSettings, SensorSettings};
use powertwin::validation::rig::Rig;

/// Robot `seed` of the family `table` draws around the IRB 1200's files and realistic rig.
fn draw_plant(table: &FamilyTable, seed: u64) -> powertwin::twin::family::Plant {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let rig = common::irb1200_rig(
        &robot,
        &drive,
        Fidelity::Realistic,
        NoiseSettings::default(),
    );
    table
        .draw(&robot, &drive, &rig.twin, &rig.sensor, seed)
        .unwrap()
}

#[test]
fn a_draw_is_reproducible_and_within_the_table() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let table = FamilyTable::default();
    let draw = |seed| draw_plant(&table, seed);
    let (a, b, c) = (draw(7), draw(7), draw(8));
    assert_eq!(a.draw, b.draw);
    assert_ne!(a.draw, c.draw);
    for seed in 0..20 {
        let p = draw(seed);
        for (i, l) in p.robot.links().iter().enumerate() {
            let nominal = &robot.links()[i].inertia;
            let rel = l.inertia.mass / nominal.mass - 1.0;
            assert!(rel.abs() <= 0.2 + 1e-12, "link {i} mass off by {rel}");
            assert!((l.inertia.com - nominal.com).amax() <= 0.02 + 1e-12);
        }
        for (t, n) in p.drive.joints().iter().zip(drive.joints()) {
            let rel = t.friction.coulomb / n.friction.coulomb - 1.0;
            assert!(rel.abs() <= 0.5 + 1e-12);
            let peak = t.unmodelled.stribeck_static.unwrap() / t.friction.coulomb;
            assert!((1.1..=1.6).contains(&peak), "Stribeck peak {peak}");
            assert!((0.0..=0.04).contains(&t.unmodelled.gear_friction_braking));
            assert!((t.standby_power / n.standby_power - 1.0).abs() <= 0.2 + 1e-12);
        }
        let s = &p.sensor;
        assert!(
            [
                10.0, 20.0, 25.0, 40.0, 50.0, 100.0, 125.0, 200.0, 250.0, 500.0
            ]
            .contains(&s.rate_hz)
        );
        assert!(s.stamp_jitter_s <= 0.2 / s.rate_hz + 1e-12);
        assert!((0.0..=0.04 + 1e-12).contains(&s.power_lag_s));
        assert_eq!(p.twin.fidelity, Fidelity::Realistic);
        assert!((0.0..=0.2).contains(&p.twin.nominal_error));
    }
    // The user's files stay as they were.
    assert_eq!(
        robot.links()[1].inertia,
        common::irb1200().links()[1].inertia
    );
}

/// A table that pins effects (ranges of zero width) draws every other effect as the default
/// table does: an ablation compares the same robots with and without those effects.
#[test]
fn pinning_an_effect_leaves_the_other_draws_alone() {
    let default = FamilyTable::default();
    let pinned = FamilyTable {
        mass_rel: 0.0,
        stribeck_peak: [1.3, 1.3],
        gear_friction: [0.0, 0.0],
        rate_hz: [100.0, 100.0],
        power_lag_s: [0.02, 0.02],
        ..default.clone()
    };
    for seed in [1, 2_000_030] {
        let draw = |t: &FamilyTable| draw_plant(t, seed).draw;
        let (a, b) = (draw(&default), draw(&pinned));
        // The pinned effects take their values.
        assert!(b.link_mass_error_rel.iter().all(|&e| e == 0.0));
        assert_eq!(b.rate_hz, 100.0);
        assert!((b.power_lag_s - 0.02).abs() < 1e-12, "{}", b.power_lag_s);
        for j in &b.joints {
            assert!((j.stribeck_static_nm / j.coulomb_nm - 1.3).abs() < 1e-12);
            assert_eq!(
                (j.gear_friction_per_nm, j.gear_friction_braking_per_nm),
                (0.0, 0.0)
            );
        }
        // Every other effect is the default table's draw.
        let other = |d: &powertwin::twin::family::Draw| {
            let joints: Vec<_> = d
                .joints
                .iter()
                .map(|j| (j.coulomb_nm, j.viscous_nms_per_rad, j.stribeck_speed_rad_s))
                .collect();
            (joints, d.cabinet_w, d.bandwidth_rad_s, d.nominal_error)
        };
        assert_eq!(other(&a), other(&b), "seed {seed}");
        assert_eq!(a.power_averaging, b.power_averaging);
        assert_eq!(a.power_sigma_w, b.power_sigma_w);
        // The jitter is drawn in sample periods.
        let periods = |d: &powertwin::twin::family::Draw| d.stamp_jitter_s * d.rate_hz;
        assert!((periods(&a) - periods(&b)).abs() < 1e-12, "seed {seed}");
    }
}

#[test]
fn bad_family_tables_are_refused_with_the_key() {
    for (text, key) in [
        ("gear_friction = [0.04, 0.0]", "gear_friction"),
        ("power_lag_s = [-0.01, 0.02]", "power_lag_s"),
        ("mass_rel = -0.2", "mass_rel"),
        ("cabinet_seen = 1.5", "cabinet_seen"),
        ("rate_hz = [10.0, nan]", "rate_hz"),
        ("no_such_key = 1.0", "no_such_key"),
    ] {
        let e = FamilyTable::from_toml_str(text, "family.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("family.toml") && e.contains(key), "{text}: {e}");
    }
    let t = FamilyTable::from_toml_str("mass_rel = 0.1", "family.toml").unwrap();
    assert_eq!(t.mass_rel, 0.1);
    assert_eq!(t.com_m, FamilyTable::default().com_m);
}

#[test]
fn gear_friction_follows_the_direction_of_power_flow() {
    let robot = common::irb1200();
    let text = powertwin::model::builtin::IRB1200_DRIVE.replacen(
        "gear_friction_per_Nm = ",
        "gear_friction_braking_per_Nm = 0.05\ngear_friction_per_Nm = ",
        1,
    );
    let drive = Drive::from_toml_str(&text, "drive.toml", &robot).unwrap();
    let u = drive.joints()[0].unmodelled;
    assert_eq!(u.gear_friction_braking, 0.05);
    let base = u.friction(10.0, 1.0, 0.0);
    // Motoring (torque along the motion) and braking (against it).
    assert!((u.friction(10.0, 1.0, 100.0) - base - 100.0 * u.gear_friction).abs() < 1e-9);
    assert!((u.friction(10.0, 1.0, -100.0) - base - 5.0).abs() < 1e-9);
    // Without the key, braking is as motoring.
    let plain = common::irb1200_drive(&robot).joints()[0].unmodelled;
    assert_eq!(plain.gear_friction_braking, plain.gear_friction);
    let bad = powertwin::model::builtin::IRB1200_DRIVE.replacen(
        "gear_friction_per_Nm = ",
        "gear_friction_braking_per_Nm = -0.1\ngear_friction_per_Nm = ",
        1,
    );
    let e = Drive::from_toml_str(&bad, "drive.toml", &robot)
        .unwrap_err()
        .to_string();
    assert!(e.contains("gear_friction_braking_per_Nm"), "{e}");
}

/// Two runs of `traj` on `rig` (noise seeds 0 and 1), as logged.
fn two_logs(rig: &Rig, traj: &Fourier) -> Vec<powertwin::measurement::Log> {
    (0..2)
        .map(|k| {
            rig.run(traj, &[], k, serde_json::json!({}))
                .unwrap()
                .log("run")
                .unwrap()
        })
        .collect()
}

/// A 20 s excitation of the IRB 1200 (four periods of 0.2 Hz, 5 harmonics).
fn excitation(robot: &powertwin::Robot) -> Fourier {
    let n = robot.dof();
    let q0 = vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0];
    let a: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..5)
                .map(|k| 0.3 / (1.0 + k as f64) * if (i + k) % 2 == 0 { 1.0 } else { -0.7 })
                .collect()
        })
        .collect();
    let b: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..5)
                .map(|k| 0.25 / (1.0 + k as f64) * if (i + 2 * k) % 3 == 0 { -1.0 } else { 0.8 })
                .collect()
        })
        .collect();
    Fourier::new(0.2, q0, a, b, 4.0).unwrap()
}

#[test]
fn the_logger_lags_jitters_and_sees_the_cabinet() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let base = common::irb1200_rig(&robot, &drive, Fidelity::Realistic, NoiseSettings::NONE);
    let traj = excitation(&robot);
    let with = |sensor: SensorSettings, cabinet: f64| {
        let rig = Rig {
            sensor,
            twin: powertwin::twin::TwinConfig {
                cabinet_power_w: cabinet,
                ..base.twin.clone()
            },
            ..base.clone()
        };
        rig.run(&traj, &[], 0, serde_json::json!({})).unwrap()
    };
    let plain = with(base.sensor, 0.0);
    let lagged = with(
        SensorSettings {
            power_lag_s: 0.03,
            ..base.sensor
        },
        0.0,
    );
    // Sample k (10 Hz, 100 steps apart) logs the power 30 steps earlier.
    let k = 57;
    let at = 100 * k - 30;
    let expected = 0.5 * (plain.truth.p_grid[at - 1] + plain.truth.p_grid[at]);
    assert!((lagged.measured.p_total[k] - expected).abs() < 1e-9);
    assert_eq!(lagged.measured.t, plain.measured.t);
    let jittered = with(
        SensorSettings {
            stamp_jitter_s: 0.02,
            ..base.sensor
        },
        0.0,
    );
    let dev = jittered
        .measured
        .t
        .iter()
        .zip(&plain.measured.t)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(dev > 0.005 && dev <= 0.02 + 1e-12, "{dev}");
    // What a user has: the stamps back on their uniform grid.
    let log = jittered.log("jittered").unwrap();
    assert!(log.t_s.windows(2).all(|w| (w[1] - w[0] - 0.1).abs() < 1e-3));
    let cabinet = with(base.sensor, 40.0);
    assert!((cabinet.truth.energy_grid() - plain.truth.energy_grid() - 40.0 * 20.0).abs() < 0.5);
    // Jitter of half a period is refused.
    let e = SensorSettings {
        stamp_jitter_s: 0.05,
        ..base.sensor
    }
    .stride(1e-3)
    .unwrap_err()
    .to_string();
    assert!(e.contains("jitter"), "{e}");
}

#[test]
fn identification_finds_the_power_lag() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let base = common::irb1200_rig(
        &robot,
        &drive,
        Fidelity::Realistic,
        NoiseSettings::default(),
    );
    let traj = excitation(&robot);
    let route = [Route::Fourier {
        base_freq_hz: 0.2,
        harmonics: 5,
    }];
    // (rate, averaging meter, true lag, how close the found lag must be). At 10 Hz with an
    // averaging meter this excitation's power hardly depends on the lag: the fit may keep
    // none, but must not invent a wrong one. At 20 Hz the refinement on the residual's root
    // mean square found 26.1 ms for 30 ms; on its mean square, 31.9 ms.
    let cases = [
        (20.0, false, 0.03, 0.003),
        (20.0, false, 0.0, 0.006),
        (10.0, true, 0.04, 0.04),
    ];
    for (rate_hz, averaging, lag, tolerance) in cases {
        let rig = Rig {
            sensor: SensorSettings {
                rate_hz,
                power_averaging: averaging,
                power_lag_s: lag,
                ..base.sensor
            },
            ..base.clone()
        };
        let logs = two_logs(&rig, &traj);
        let sel = identify_logs(&robot, &logs, &route, &FitOptions::default()).unwrap();
        let found = sel.fit.model.power_lag_s;
        assert!(
            (found - lag).abs() <= tolerance,
            "{rate_hz} Hz (averaging {averaging}): lag {lag} s found as {found} s"
        );
    }
}

/// A meter that averages over its 10 Hz period logs the period's mean power, which a fast
/// motion's convex copper loss makes more than the power at the period's middle. Fitted at
/// the middle, that gap went into the copper coefficients and a slow motion holding the arm
/// against gravity was mispredicted (here -1.5 %, on a family robot +2 to +3 %); fitted on
/// the period's mean, the averaging meter's model predicts it about as the instantaneous
/// meter's does (here -0.4 % and -0.0 %; the rest is the 10 Hz averaged logs' spread, which
/// moves with the nodes per period, -0.4, +0.2 and -0.2 % at 4, 8 and 16).
#[test]
fn an_averaging_meter_is_fitted_on_its_periods_mean() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let base = common::irb1200_rig(&robot, &drive, Fidelity::Exact, NoiseSettings::NONE);
    let traj = excitation(&robot);
    let n = robot.dof();
    // Slow and near a pose where gravity loads joints 2 and 3: mostly holding.
    let slow = Fourier::new(
        0.05,
        vec![0.3, 0.7, 0.4, 0.0, 0.6, 0.0],
        vec![vec![0.05]; n],
        vec![vec![0.0]; n],
        1.0,
    )
    .unwrap();
    let truth = base.run(&slow, &[], 9, serde_json::json!({})).unwrap();
    let true_j = truth.truth.energy_total();
    let route = [Route::Fourier {
        base_freq_hz: 0.2,
        harmonics: 5,
    }];
    let error_pct = |averaging: bool| -> f64 {
        let rig = Rig {
            sensor: SensorSettings {
                rate_hz: 10.0,
                power_averaging: averaging,
                power_lag_s: 0.0,
                ..base.sensor
            },
            ..base.clone()
        };
        let logs = two_logs(&rig, &traj);
        let opts = FitOptions {
            max_power_lag_s: 0.0,
            ..FitOptions::default()
        };
        let model = identify_logs(&robot, &logs, &route, &opts)
            .unwrap()
            .fit
            .model;
        let predicted = model.energy(&robot, &slow, 1e-3).unwrap();
        100.0 * (predicted / true_j - 1.0)
    };
    let (instant, averaging) = (error_pct(false), error_pct(true));
    assert!(
        (averaging - instant).abs() < 0.7 && averaging.abs() < 0.7,
        "slow holding motion of {true_j:.1} J: {instant:+.2} % from the instantaneous \
         meter's model, {averaging:+.2} % from the averaging meter's"
    );
}

#[test]
fn the_cli_refuses_bad_family_input() {
    for (args, needle) in [
        (vec!["validate", "--family", "0"], "at least 1"),
        (
            vec![
                "simulate",
                "--truth",
                "family:-1",
                "--trajectory",
                "x.csv",
                "--out",
                "o",
            ],
            "whole number",
        ),
        (
            vec![
                "simulate",
                "--truth",
                "family",
                "--trajectory",
                "x.csv",
                "--out",
                "o",
            ],
            "family:SEED",
        ),
        (
            vec![
                "dataset", "--truth", "family:x", "--count", "1", "--out", "o",
            ],
            "whole number",
        ),
    ] {
        let (code, _, err) = common::run(&args);
        assert_ne!(code, 0, "{args:?}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    let table = common::tmp("bad_family.toml");
    std::fs::write(&table, "stribeck_peak = [1.6, 1.1]\n").unwrap();
    let (code, _, err) = common::run(&[
        "validate",
        "--family",
        "1",
        "--family-table",
        table.to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("stribeck_peak"), "{err}");
}

/// `dataset --truth family:SEED`: item `j` runs robot `j` of the family (the one `validate
/// --family N --seed SEED` draws `j`-th), recorded in its `meta.json`, along the same motion
/// as item `j` of the set without the family.
#[test]
fn dataset_items_run_robots_of_the_family() {
    let (fam, plain) = (common::tmp("dataset_family"), common::tmp("dataset_plain"));
    for (dir, truth) in [(&fam, "family:2"), (&plain, "realistic")] {
        let (code, _, err) = common::run(&[
            "dataset",
            "--truth",
            truth,
            "--count",
            "2",
            "--seed",
            "5",
            "--format",
            "csv",
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
    }
    let meta = |d: &std::path::Path, j: usize| -> serde_json::Value {
        let text = std::fs::read_to_string(d.join(format!("item_{j:06}/meta.json"))).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    for j in 0..2 {
        let (f, p) = (meta(&fam, j), meta(&plain, j));
        assert_eq!(f["family"]["seed"], 2_000_000 + 10 * j as u64);
        assert!(p.get("family").is_none());
        assert_eq!(f["trajectory"], p["trajectory"]);
    }
}

/// A family robot the twin cannot track along an item's motion is redrawn, and the redraws
/// are recorded in the item's `meta.json`; an item whose every draw saturates is refused.
/// (Joint 2's effort limit is cut to 110 N m, about the torque item 0 needs.)
#[test]
fn dataset_items_redraw_robots_that_saturate() {
    let urdf = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/irb1200_7_70.urdf"),
    )
    .unwrap();
    let weak = |limit: &str| -> std::path::PathBuf {
        let cut = urdf.replace(
            r#"velocity="4.188790205" effort="250""#,
            &format!(r#"velocity="4.188790205" effort="{limit}""#),
        );
        assert_ne!(cut, urdf);
        let path = common::tmp(&format!("weak_joint_2_{limit}.urdf"));
        std::fs::write(&path, cut).unwrap();
        path
    };
    let dataset = |limit: &str| {
        let (urdf, out) = (weak(limit), common::tmp(&format!("dataset_redraw_{limit}")));
        let (code, _, err) = common::run(&[
            "dataset",
            "--robot",
            urdf.to_str().unwrap(),
            "--truth",
            "family:2",
            "--count",
            "1",
            "--seed",
            "5",
            "--format",
            "csv",
            "--out",
            out.to_str().unwrap(),
        ]);
        (code, err, out)
    };
    let (code, err, out) = dataset("110");
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(out.join("item_000000/meta.json")).unwrap();
    let meta: serde_json::Value = serde_json::from_str(&text).unwrap();
    let family = &meta["family"];
    let redraws = family["redraws"].as_array().expect("redraws recorded");
    assert!(!redraws.is_empty(), "{family}");
    for (k, r) in redraws.iter().enumerate() {
        assert_eq!(r["family_seed"], 2_000_000 + k as u64);
        assert!(r["reason"].as_str().unwrap().contains("joint_2"), "{r}");
    }
    assert_eq!(family["seed"], 2_000_000 + redraws.len() as u64);
    let (code, err, _) = dataset("60");
    assert_ne!(code, 0);
    assert!(
        err.contains("saturated") && err.contains("too wide"),
        "{err}"
    );
}

/// A cabinet load the meter sees after the bus clip puts a floor under the reading. Gentle
/// identification logs never reach it, so the fit cannot find it (the standby absorbs the
/// cabinet). The model records the lowest level its logs showed the meter at, and a motion
/// that brakes below that level gets an interval that holds what the meter might read there.
#[test]
fn a_meter_never_seen_low_widens_the_interval_of_a_motion_that_brakes() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let rig = common::irb1200_cabinet_rig(&robot, &drive);
    let traj = excitation(&robot);
    let logs = two_logs(&rig, &traj);
    let route = [Route::Fourier {
        base_freq_hz: 0.2,
        harmonics: 5,
    }];
    let opts = FitOptions {
        max_power_lag_s: 0.0,
        ..FitOptions::default()
    };
    let model = identify_logs(&robot, &logs, &route, &opts)
        .unwrap()
        .fit
        .model;
    let lowest = model
        .lowest_seen
        .expect("a bus signal has a lowest seen level");
    assert!(lowest > 45.0, "lowest seen {lowest} W with a 50 W cabinet");
    // The same excitation twice as fast and wider: the arm regenerates hard.
    let n = robot.dof();
    let fast = Fourier::new(
        0.4,
        vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0],
        vec![vec![0.45, -0.2]; n],
        vec![vec![0.3, 0.15]; n],
        2.0,
    )
    .unwrap();
    let truth = rig.run(&fast, &[], 7, serde_json::json!({})).unwrap();
    let true_j = truth.truth.energy_grid();
    let with = model.predict(&robot, &fast, &[], 1.0, 1e-3).unwrap();
    let without = |alternative| {
        PowerModel {
            lowest_seen: None,
            alternative,
            ..model.clone()
        }
        .predict(&robot, &fast, &[], 1.0, 1e-3)
        .unwrap()
        .interval_j
    };
    // The level never seen widens the interval, which then holds the truth (the other
    // friction structure's disagreement, which this motion's braking also shows, widens it
    // besides). The parameters and the structure error alone hold the miss only at their
    // edge here: the structure error is the mean's, taken at the pieces' activity.
    let (bare, no_level) = (without(None), without(model.alternative.clone()));
    let miss = (with.energy_j - true_j).abs();
    assert!(
        bare < no_level && 2.0 * no_level < with.interval_j && miss <= with.interval_j,
        "{true_j:.1} J true, {:.1} J predicted: interval +-{bare:.1} J without the unseen \
         level and the other friction structure, +-{no_level:.1} J without the level, \
         +-{:.1} J with both",
        with.energy_j,
        with.interval_j
    );
}

/// The relative part of the structure error is taken at no less than the model's
/// `structure_active_W`: a motion less active than the cross-validation pieces (here a model
/// that predicts only its standby, so no activity at all) keeps the error they showed.
#[test]
fn a_quiet_motion_keeps_the_structure_error_of_the_pieces() {
    let robot = common::irb1200();
    let layout = powertwin::dynamics::ParamLayout::new(&robot, true, true);
    let mut model = PowerModel::new(&robot, layout, false).unwrap();
    model.constant = vec![10.0; robot.dof()];
    model.structure_rel = 0.01;
    let traj = excitation(&robot);
    let interval = |active_w: f64| {
        let m = PowerModel {
            structure_active: active_w,
            ..model.clone()
        };
        m.predict(&robot, &traj, &[], 1.0, 1e-2).unwrap().interval_j
    };
    assert_eq!(interval(0.0), 0.0);
    let expected = 1.96 * 0.01 * 80.0 * traj.duration();
    assert!(
        (interval(80.0) - expected).abs() < 1e-9 * expected,
        "{}",
        interval(80.0)
    );
}

/// A model identified without payloads, asked about a 5.3 kg payload: with the drive file's
/// copper-loss coefficients as a prior, the wrist's copper loss (which unloaded torques barely
/// show) is kept, and the payload's losses beyond what the logs carried are in the interval,
/// so the prediction stays inside it; without that prior the unloaded fit holds the wrist's
/// coefficients at zero and predicts the payload's copper loss low
/// (docs/experiments.md#the-drive-files-copper-as-a-prior).
#[test]
fn an_unloaded_identification_keeps_the_copper_loss_a_payload_adds() {
    use powertwin::identification::prior::{Prior, PriorWidths};
    let u = unloaded_1000000();
    let prior = Prior::for_robot(&u.robot, Some(&u.drive), &PriorWidths::default()).unwrap();
    let identify = |prior: Prior| {
        let opts = FitOptions {
            prior: Some(prior),
            ..FitOptions::default()
        };
        identify_logs(&u.robot, &u.logs, &u.route, &opts)
            .unwrap()
            .fit
            .model
    };
    let with = identify(prior.clone());
    // A model without gear friction carries the same logs' model with it beside, and its
    // predictions report what that one predicts.
    assert!(with.gear_friction.is_empty());
    let alt = with.alternative.as_deref().expect("the gear model beside");
    assert!(!alt.gear_friction.is_empty());
    assert_eq!(
        u.predict(&with).alternative_j,
        Some(u.predict(alt).energy_j)
    );
    // Both carry the nominal drive file's Stribeck law (the drawn truth has its own), and a
    // prediction reports the energy with its whole rise, above the model's half.
    assert_eq!(with.stribeck, prior.stribeck);
    assert_eq!(alt.stribeck, prior.stribeck);
    let p = u.predict(&with);
    assert!(
        p.stribeck_j.expect("the whole rise's energy") > p.energy_j,
        "{p:?}"
    );
    let without = identify(Prior {
        copper: vec![None; u.robot.dof()],
        ..prior
    });
    let predict = |m: &PowerModel| {
        let p = u.predict(m);
        (p.energy_j - u.true_j, p.interval_j)
    };
    let ((err_with, int_with), (err_without, int_without)) = (predict(&with), predict(&without));
    // The model knows its logs carried nothing: the payload's losses beyond that are in the
    // interval (`unseen_load_J`), which without that term is narrower.
    assert_eq!(with.payload_seen, Some(0.0));
    let blind = PowerModel {
        payload_seen: None,
        ..with.clone()
    };
    let (_, int_blind) = predict(&blind);
    eprintln!(
        "copper {:?} / {:?}; true {:.1} J: with the copper prior {err_with:+.1} +- \
         {int_with:.1} J (+- {int_blind:.1} J without the unseen load), without it \
         {err_without:+.1} +- {int_without:.1} J",
        with.copper, without.copper, u.true_j
    );
    assert!(err_with.abs() <= int_with, "{err_with} +- {int_with}");
    assert!(err_with.abs() < err_without.abs());
    assert!(int_blind < int_with);
}

/// Family robot `1000000` (gear friction 0.039/0.016 and 0.014/0.018 motoring / braking on
/// joints 2 and 3) identified from two unloaded excitations (`--method gear`):
/// cross-validation prefers the gear-friction model to `pmsm`. It finds those joints' mean
/// friction within 0.01 and predicts a held-out motion with a 5.3 kg payload closer than the
/// model without it; the model's prediction, the mean of the two, is within an interval that
/// holds half their difference.
#[test]
fn gear_friction_is_found_in_unloaded_logs_and_carries_to_a_payload() {
    use powertwin::identification::fit::Estimator;
    use powertwin::identification::prior::{Prior, PriorWidths};
    let u = unloaded_1000000();
    let opts = FitOptions {
        prior: Some(Prior::for_robot(&u.robot, Some(&u.drive), &PriorWidths::default()).unwrap()),
        candidates: vec![Estimator::Pmsm, Estimator::Gear],
        ..FitOptions::default()
    };
    let selection = identify_logs(&u.robot, &u.logs, &u.route, &opts).unwrap();
    assert_eq!(selection.chosen, Estimator::Gear);
    let model = selection.fit.model;
    // Joints 2 and 3 carry gravity, which shows their gear friction in any motion; joint 1's
    // torque is inertia and friction alone, which two logs of one excitation barely separate.
    for (i, j) in u.gear_truth.iter().enumerate().take(3).skip(1) {
        assert!(
            (model.gear_friction[i] - j).abs() < 0.01,
            "joint {}: {} against {j}",
            i + 1,
            model.gear_friction[i]
        );
    }
    let without = model.alternative.as_deref().expect("the pmsm model beside");
    assert!(without.gear_friction.is_empty());
    // Each structure alone, and the model's prediction: their mean.
    let alone = PowerModel {
        alternative: None,
        ..model.clone()
    };
    let (gear, pmsm, mean) = (u.predict(&alone), u.predict(without), u.predict(&model));
    let true_j = u.true_j;
    eprintln!(
        "gear friction {:?}; true {true_j:.1} J: gear {:+.1} J, without {:+.1} J, mean {:+.1} \
         +- {:.1} J",
        model.gear_friction,
        gear.energy_j - true_j,
        pmsm.energy_j - true_j,
        mean.energy_j - true_j,
        mean.interval_j
    );
    assert!((gear.energy_j - true_j).abs() < (pmsm.energy_j - true_j).abs());
    assert_eq!(mean.alternative_j, Some(pmsm.energy_j));
    assert!((mean.energy_j - 0.5 * (gear.energy_j + pmsm.energy_j)).abs() < 1e-6 * true_j);
    assert!((mean.energy_j - true_j).abs() <= mean.interval_j);
    assert!(mean.interval_j >= 1.96 * 0.5 * (gear.energy_j - pmsm.energy_j).abs());
}

/// Family robot `1000000` logged unloaded, and a held-out motion with a payload, for the
/// tests of payloads beyond what identification carried.
struct Unloaded {
    robot: powertwin::Robot,
    drive: Drive,
    /// Two runs of the 20 s excitation, unloaded.
    logs: Vec<powertwin::measurement::Log>,
    route: [Route; 1],
    /// The drawn gear friction per joint, mean of motoring and braking (truth, for scoring).
    gear_truth: Vec<f64>,
    /// A held-out motion carrying the tool and the 4 kg load (5.32 kg).
    held_out: Fourier,
    events: [powertwin::model::payload::PayloadEvent; 1],
    /// Its true energy on the bus, J.
    true_j: f64,
}

impl Unloaded {
    /// `model`'s prediction of the held-out motion.
    fn predict(&self, model: &PowerModel) -> powertwin::identification::model::Prediction {
        model
            .predict(&self.robot, &self.held_out, &self.events, 1.0, 1e-3)
            .unwrap()
    }
}

/// [`Unloaded`] of family robot `1000000` on the realistic IRB 1200 rig.
fn unloaded_1000000() -> Unloaded {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let base = common::irb1200_rig(
        &robot,
        &drive,
        Fidelity::Realistic,
        NoiseSettings::default(),
    );
    let plant = FamilyTable::default()
        .draw(&robot, &drive, &base.twin, &base.sensor, 1_000_000)
        .unwrap();
    let rig = Rig {
        plant: Some(&plant),
        ..base.clone()
    };
    let logs = two_logs(&rig, &excitation(&robot));
    let payload = powertwin::model::builtin::payload("tool")
        .unwrap()
        .combined(&powertwin::model::builtin::payload("load_4kg").unwrap());
    let events = [powertwin::model::payload::PayloadEvent {
        t_s: 0.0,
        payload: Some(payload),
    }];
    let n = robot.dof();
    let held_out = Fourier::new(
        0.1,
        vec![0.3, 0.4, 0.0, 0.5, 1.0, -0.5],
        vec![vec![0.4, -0.2, 0.1]; n],
        vec![vec![-0.3, 0.2, 0.05]; n],
        2.0,
    )
    .unwrap();
    let true_j = rig
        .run(&held_out, &events, 5, serde_json::json!({}))
        .unwrap()
        .truth
        .energy_grid();
    let gear_truth = (plant.draw.joints.iter())
        .map(|j| 0.5 * (j.gear_friction_per_nm + j.gear_friction_braking_per_nm))
        .collect();
    drop(rig);
    Unloaded {
        robot,
        drive,
        logs,
        route: [Route::Fourier {
            base_freq_hz: 0.2,
            harmonics: 5,
        }],
        gear_truth,
        held_out,
        events,
        true_j,
    }
}
