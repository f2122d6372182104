//! Writing robots out as URDF and drive TOML: what is written loads back to the same model.

use crate::common;

use nalgebra::{Matrix3, Vector3};
use powertwin::Robot;
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::export::{drive_string, urdf_string};
use powertwin::model::urdf::{LoadOptions, load_file, load_str};

fn data(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// Largest difference between the two robots' standard parameters, relative to the largest
/// parameter of its kind (inertia, first moment, mass) over the robot.
fn max_param_diff(a: &Robot, b: &Robot) -> f64 {
    let (pa, pb) = (a.standard_params(), b.standard_params());
    let kinds: [std::ops::Range<usize>; 3] = [0..6, 6..9, 9..10];
    let mut worst = 0.0_f64;
    for kind in kinds {
        let scale = pa
            .iter()
            .flat_map(|p| p[kind.clone()].iter().map(|v| v.abs()))
            .fold(0.0, f64::max);
        for (x, y) in pa.iter().zip(&pb) {
            for k in kind.clone() {
                worst = worst.max((x[k] - y[k]).abs() / scale);
            }
        }
    }
    worst
}

/// The exported URDF of `robot` loads back to the same joints, frames, limits, friction,
/// flange, shapes and standard parameters.
fn assert_round_trip(robot: &Robot) {
    let text = urdf_string(robot, "a -- test header", &[]);
    let back = load_str(&text, &LoadOptions::default()).unwrap();
    assert_eq!(back.name(), robot.name());
    assert_eq!(back.dof(), robot.dof());
    let diff = max_param_diff(robot, &back);
    assert!(
        diff < 1e-12,
        "{}: standard parameters differ by {diff:e}",
        robot.name()
    );
    for (a, b) in robot.joints().iter().zip(back.joints()) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.limits, b.limits);
        assert_eq!(a.friction, b.friction);
        let d = a.origin.inverse() * b.origin;
        assert!(
            d.translation.vector.norm() < 1e-12 && d.rotation.angle() < 1e-12,
            "joint {}",
            a.name
        );
    }
    let d = robot.flange().inverse() * back.flange();
    assert!(d.translation.vector.norm() < 1e-12 && d.rotation.angle() < 1e-12);
    assert_eq!(back.flange_name(), robot.flange_name());
    for (a, b) in robot.links().iter().zip(back.links()) {
        assert_eq!(a.visuals.len(), b.visuals.len());
        assert_eq!(a.collisions.len(), b.collisions.len());
        for (sa, sb) in a.visuals.iter().zip(&b.visuals) {
            assert_eq!(sa.geometry, sb.geometry);
            assert_eq!(sa.rgba, sb.rgba);
            assert!((sa.pose.translation.vector - sb.pose.translation.vector).norm() < 1e-12);
        }
    }
}

#[test]
fn exported_urdfs_load_back_to_the_same_robot() {
    assert_round_trip(&common::irb1200());
    assert_round_trip(&load_file(&data("ur5.urdf"), &LoadOptions::default()).unwrap());
    // The Panda's hand and locked fingers were merged into link 7: written as one body.
    let panda = load_file(
        &data("panda.urdf"),
        &LoadOptions {
            lock: vec!["panda_finger_joint1".into(), "panda_finger_joint2".into()],
        },
    )
    .unwrap();
    assert_round_trip(&panda);
}

#[test]
fn exported_urdf_is_valid_for_urdf_rs_with_physical_inertias() {
    let robot = common::irb1200();
    let text = urdf_string(&robot, "header", &["note <&> -- of link 1".to_string()]);
    let urdf = urdf_rs::read_from_string(&text).unwrap();
    assert_eq!(urdf.joints.len(), robot.dof() + 1);
    let mut checked = 0;
    for link in &urdf.links {
        let i = &link.inertial.inertia;
        if link.inertial.mass.value == 0.0 {
            continue;
        }
        checked += 1;
        let m = Matrix3::new(
            i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz,
        );
        let e = m.symmetric_eigenvalues();
        assert!(e.min() > 0.0, "{}: {e}", link.name);
        assert!(
            e.sum() - 2.0 * e.max() >= -1e-12 * e.max(),
            "{}: {e}",
            link.name
        );
        assert!(link.inertial.mass.value > 0.0);
    }
    assert_eq!(checked, robot.dof() + 1);
    // The ROS link frames are kept: link_2's COM is where the input URDF puts it.
    let link2 = urdf.links.iter().find(|l| l.name == "link_2").unwrap();
    let com = Vector3::from(link2.inertial.origin.xyz.0);
    assert!(
        (com - Vector3::new(0.0004, 0.0007, 0.1842)).norm() < 1e-12,
        "{com}"
    );
}

#[test]
fn exported_drive_file_reads_back() {
    let robot = common::irb1200();
    let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "drive", &robot).unwrap();
    let text = drive_string(
        &robot,
        &drive,
        "line one\nline two",
        &["joint 1 note".into()],
    );
    assert!(text.starts_with("# line one\n# line two\n"));
    assert!(text.contains("# joint 1 note\n[[joint]]"));
    let back = Drive::from_toml_str(&text, "exported", &robot).unwrap();
    // An identified drive has the model's structure: of the twin's unmodelled effects only
    // the gear friction is written (`identify --method gear` identifies it), the others not.
    let expected: Vec<_> = drive
        .exact()
        .joints()
        .iter()
        .zip(drive.joints())
        .map(|(exact, full)| powertwin::model::drive::JointDrive {
            unmodelled: powertwin::model::drive::Unmodelled {
                gear_friction: full.unmodelled.gear_friction,
                gear_friction_braking: full.unmodelled.gear_friction_braking,
                ..Default::default()
            },
            ..*exact
        })
        .collect();
    assert!(drive.joints()[0].unmodelled.gear_friction > 0.0);
    assert_eq!(back.joints(), expected.as_slice());
}

/// `identify --export-urdf --export-drive` writes files that load as a robot and its drives
/// (physically consistent), and refuses a model scaled by 1/efficiency.
#[test]
fn identify_exports_the_identified_robot() {
    use powertwin::dataset::Format;
    use powertwin::dataset::meta::Urdf;
    use powertwin::trajectory::random::{RandomFourierOptions, random_fourier};
    use powertwin::twin::TwinConfig;
    use powertwin::twin::sensor::SensorSettings;
    use powertwin::validation::rig::Rig;
    let robot = common::irb1200();
    let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "drive", &robot).unwrap();
    let rig = Rig {
        plant: None,
        robot: &robot,
        urdf: Urdf::inline(builtin::IRB1200_URDF),
        drive: &drive,
        twin: TwinConfig::default(),
        sensor: SensorSettings::default(),
    };
    let opts = RandomFourierOptions {
        periods: 2.0,
        ..RandomFourierOptions::default()
    };
    let mut args: Vec<String> = vec!["identify".into(), "--data".into()];
    for seed in 300..303 {
        let traj = random_fourier(&robot, &mut common::rng(seed), &opts).unwrap();
        let dir = common::tmp(&format!("ds{seed}"));
        rig.run(&traj, &[], seed, serde_json::json!({}))
            .unwrap()
            .write(&dir, Format::Parquet)
            .unwrap();
        args.push(dir.display().to_string());
    }
    let (urdf, drv, model) = (
        common::tmp("out.urdf"),
        common::tmp("out.drive.toml"),
        common::tmp("model.json"),
    );
    args.extend(
        [
            "--base-freq",
            "0.1",
            "--min-speed",
            "0.05",
            "--out",
            model.to_str().unwrap(),
            "--export-urdf",
            urdf.to_str().unwrap(),
            "--export-drive",
            drv.to_str().unwrap(),
        ]
        .map(String::from),
    );
    let argv = |method: &str| {
        let mut a = args.clone();
        a.extend(["--method".to_string(), method.to_string()]);
        a
    };
    let pmsm = argv("pmsm");
    let (code, _, err) = common::run(&pmsm.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("export: consistent parameters"), "{err}");
    let b = load_file(&urdf, &LoadOptions::default()).unwrap();
    let d = Drive::from_file(&drv, &b).unwrap();
    check_with_external_loaders(&urdf, &b);
    assert!(
        d.joints()
            .iter()
            .all(|j| j.copper_loss >= 0.0 && j.rotor_inertia >= 0.0)
    );
    let text = std::fs::read_to_string(&urdf).unwrap();
    assert!(text.contains("Set by the prior") && text.contains("identified by powertwin"));
    // With gear friction (the twin's drives have 0.02), the drive file carries what the model
    // identified, alike in both directions (the export's own projection, as for the copper
    // loss: it moves the loss terms along their correlation with the base parameters).
    let gear = argv("gear");
    let (code, _, err) = common::run(&gear.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(code, 0, "{err}");
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    let g: Vec<f64> = serde_json::from_value(m["model"]["gear_friction"].clone()).unwrap();
    let d = Drive::from_file(&drv, &b).unwrap();
    for (j, gj) in d.joints().iter().zip(&g) {
        let u = &j.unmodelled;
        assert_eq!(u.gear_friction, u.gear_friction_braking);
        assert!(
            (u.gear_friction - gj).abs() < 0.01,
            "{} against {gj}",
            u.gear_friction
        );
    }
    assert!(g.iter().any(|v| *v > 0.0), "{g:?}");
    // Its prediction says what it predicts without the gear friction, and the interval holds
    // the difference.
    let data = common::tmp("ds300");
    let (code, out, err) = common::run(&[
        "predict",
        "--model",
        model.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--base-freq",
        "0.1",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let p: serde_json::Value = serde_json::from_str(&out).unwrap();
    let (e, without) = (p["predicted_J"].as_f64(), p["alternative_J"].as_f64());
    let (e, without) = (e.unwrap(), without.expect("alternative_J"));
    assert!(
        p["interval_95_J"].as_f64().unwrap() >= 1.96 * (e - without).abs(),
        "{p}"
    );
    // A step-by-step model (scaled by 1/efficiency, no joint covariance) cannot be exported.
    std::fs::remove_file(&urdf).unwrap();
    let total = argv("paper-steps");
    let (code, _, err) = common::run(&total.iter().map(String::as_str).collect::<Vec<_>>());
    assert_ne!(code, 0);
    assert!(err.contains("--method auto, total, pmsm or gear"), "{err}");
    assert!(!urdf.exists());
}

/// MuJoCo and Pinocchio (Python packages `mujoco`, `pin`) load the URDF at `path` with the
/// joints and link masses of `robot`; MuJoCo's compiler also checks every inertia (positive,
/// triangle inequality). A package (or `python3`) that is absent is skipped with a message.
fn check_with_external_loaders(path: &std::path::Path, robot: &Robot) {
    let masses: Vec<f64> = robot.links().iter().map(|l| l.inertia.mass).collect();
    let scripts = [
        (
            "mujoco",
            "import sys, mujoco\n\
             m = mujoco.MjModel.from_xml_path(sys.argv[1])\n\
             print(m.nv, *[m.body(m.jnt_bodyid[j]).mass[0] for j in range(m.njnt)])",
        ),
        (
            "pinocchio",
            "import sys, pinocchio\n\
             m = pinocchio.buildModelFromUrdf(sys.argv[1])\n\
             print(m.nv, *[m.inertias[j].mass for j in range(1, m.njoints)])",
        ),
    ];
    for (package, script) in scripts {
        let out = std::process::Command::new("python3")
            .args(["-c", script, path.to_str().unwrap()])
            .output();
        let out = match out {
            Ok(o) if o.status.success() => o,
            Ok(o) if String::from_utf8_lossy(&o.stderr).contains("No module named") => {
                println!("{package} is not installed: skipped");
                continue;
            }
            Ok(o) => panic!("{package}: {}", String::from_utf8_lossy(&o.stderr)),
            Err(e) => {
                println!("python3 is not available ({e}): {package} skipped");
                continue;
            }
        };
        let v: Vec<f64> = String::from_utf8_lossy(&out.stdout)
            .split_whitespace()
            .map(|s| s.parse().unwrap())
            .collect();
        assert_eq!(v.len(), robot.dof() + 1, "{package}: {v:?}");
        assert_eq!(v[0], robot.dof() as f64, "{package}: {v:?}");
        for (a, b) in v[1..].iter().zip(&masses) {
            assert!(
                (a - b).abs() < 1e-9 * b,
                "{package}: masses {v:?} vs {masses:?}"
            );
        }
        println!(
            "{package} loads {}: link masses {:?}",
            path.display(),
            &v[1..]
        );
    }
}

#[test]
fn mujoco_and_pinocchio_load_the_exported_urdf() {
    let robot = common::irb1200();
    let path = common::tmp("irb1200_export.urdf");
    std::fs::write(
        &path,
        urdf_string(&robot, "export for MuJoCo/Pinocchio", &[]),
    )
    .unwrap();
    check_with_external_loaders(&path, &robot);
}
