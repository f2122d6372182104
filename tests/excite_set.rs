//! `powertwin excite --set N`: an identification set for any arm in its cell, its files
//! (trajectory CSVs, URScript programs, the runs manifest) and the cells it refuses.

use crate::common;

use std::path::{Path, PathBuf};

use powertwin::kinematics::fk::{flange_pose, link_poses};
use powertwin::model::payload::{Payload, resolve};
use powertwin::model::urdf::{LoadOptions, load_file};
use powertwin::{Robot, trajectory::cell::Cell};

use common::{run, run_ok, tmp};

/// A file of the repository.
fn repo(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(rel)
        .display()
        .to_string()
}

fn ur5() -> Robot {
    load_file(Path::new(&repo("models/ur5.urdf")), &LoadOptions::default()).unwrap()
}

/// A table cell: the plane 0.1 m above the base frame's origin, half speed and acceleration,
/// the shoulder kept raised and the elbow off its stops.
const CELL: &str = r#"
floor_z_m = 0.1
floor_margin_m = 0.05
speed_scaling = 0.5
accel_scaling = 0.5

[[joint]]
name = "shoulder_lift_joint"
lower_rad = -2.5
upper_rad = -0.6

[[joint]]
name = "elbow_joint"
lower_rad = -2.5
upper_rad = 2.5
"#;

/// Write `text` as the cell file `name` in the scratch directory.
fn cell_file(name: &str, text: &str) -> PathBuf {
    let path = tmp(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Small designs: the test binary must run in seconds.
const SMALL: [&str; 4] = ["--evals", "150", "--duration", "10"];

/// `excite --set 3` on the UR5 in `cell` with `extra` options; returns the output directory.
fn design_three(dir: &str, cell: &Path, extra: &[&str]) -> PathBuf {
    let out = tmp(dir);
    let (robot, drive) = (repo("models/ur5.urdf"), repo("models/ur5.drive.toml"));
    let loads = format!("none,none,{}", repo("models/load_2kg.payload.toml"));
    let mut args = vec![
        "excite",
        "--robot",
        &robot,
        "--drive",
        &drive,
        "--set",
        "3",
        "--loads",
        &loads,
        "--cell",
        cell.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(SMALL);
    args.extend(extra);
    run_ok(&args);
    out
}

/// The rows of a CSV file: header and numbers.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// Every pose within the cell's joint ranges and the URDF's, the flange and wrist above
/// the floor plus margin.
fn assert_in_cell(robot: &Robot, limited: &Robot, cell: &Cell, q: &[f64], what: &str) {
    for (i, (j, l)) in robot.joints().iter().zip(limited.joints()).enumerate() {
        assert!(
            q[i] >= l.limits.lower && q[i] <= l.limits.upper,
            "{what}: joint {} at {} rad outside the cell's [{}, {}]",
            i + 1,
            q[i],
            l.limits.lower,
            l.limits.upper
        );
        assert!(q[i] >= j.limits.lower && q[i] <= j.limits.upper);
    }
    let n = robot.dof();
    let mut poses = vec![nalgebra::Isometry3::identity(); n];
    link_poses(robot, q, &mut poses);
    let floor = cell.floor_z_m + cell.floor_margin_m;
    let flange = flange_pose(robot, q).translation.z;
    let wrist = poses[n - 2].translation.z;
    assert!(
        flange >= floor && wrist >= floor,
        "{what}: flange z {flange} m, wrist z {wrist} m below {floor} m"
    );
}

#[test]
fn a_set_in_a_floor_cell_writes_csvs_and_a_manifest_and_respects_the_cell() {
    let cell_path = cell_file("table.cell.toml", CELL);
    let dir = design_three("set_csv", &cell_path, &[]);
    let robot = ur5();
    let cell = Cell::from_file(&cell_path).unwrap();
    let limited = cell.limit(&robot).unwrap();
    // The manifest, parsed back: exactly the keys identify --runs reads.
    let manifest: toml::Table =
        toml::from_str(&std::fs::read_to_string(dir.join("runs.toml")).unwrap()).unwrap();
    assert!(manifest.keys().all(|k| k == "run"), "{manifest:?}");
    let runs = manifest["run"].as_array().unwrap();
    assert_eq!(runs.len(), 3);
    let two_kg = Payload::from_file(Path::new(&repo("models/load_2kg.payload.toml"))).unwrap();
    for (k, r) in runs.iter().enumerate() {
        let r = r.as_table().unwrap();
        let mut keys: Vec<&str> = r.keys().map(String::as_str).collect();
        keys.sort();
        assert_eq!(keys, ["log", "payload"]);
        assert_eq!(
            r["log"].as_str().unwrap(),
            format!("logs/excitation_{:02}.csv", k + 1)
        );
        let payload = r["payload"].as_str().unwrap();
        if k < 2 {
            assert_eq!(payload, "none");
        } else {
            // Resolved from the manifest's directory, wherever the user's payload file was.
            let p = resolve(payload, &dir).unwrap();
            assert_eq!(p.inertia.mass, two_kg.inertia.mass);
        }
    }
    let vmax: Vec<f64> = robot
        .joints()
        .iter()
        .map(|j| j.limits.velocity * cell.speed_scaling)
        .collect();
    for k in 1..=3 {
        let (header, rows) = read_csv(&dir.join(format!("excitation_{k:02}.csv")));
        assert_eq!(header[0], "t_s");
        assert_eq!(header[1], "q1_rad");
        assert_eq!(header[7], "dq1_rad_s");
        assert_eq!(header[13], "ddq1_rad_s2");
        assert_eq!(header.len(), 19);
        // 100 Hz by default, 10 s (whole periods).
        assert!((rows[1][0] - 0.01).abs() < 1e-12);
        assert!((rows.last().unwrap()[0] - 10.0).abs() < 1e-9);
        let mut moved = 0.0_f64;
        for row in &rows {
            assert_in_cell(
                &robot,
                &limited,
                &cell,
                &row[1..7],
                &format!("excitation {k}"),
            );
            for i in 0..6 {
                assert!(
                    row[7 + i].abs() <= vmax[i],
                    "joint {} speed {}",
                    i + 1,
                    row[7 + i]
                );
                moved = moved.max((row[1 + i] - rows[0][1 + i]).abs());
            }
        }
        assert!(moved > 0.1, "excitation {k} hardly moves ({moved} rad)");
    }
    assert!(!dir.join("excitation_01.script").exists());
}

/// The `servoj` poses of a URScript program, with its `movej` start and the step period.
fn servoj_poses(text: &str) -> (Vec<f64>, Vec<Vec<f64>>, f64) {
    let list = |s: &str| -> Vec<f64> {
        let inner = &s[s.find('[').unwrap() + 1..s.find(']').unwrap()];
        inner
            .split(',')
            .map(|v| v.trim().parse().unwrap())
            .collect()
    };
    let mut start = Vec::new();
    let mut poses = Vec::new();
    let mut period = 0.0;
    for line in text.lines().map(str::trim) {
        if line.starts_with("movej([") {
            start = list(line);
        } else if line.starts_with("servoj([") {
            poses.push(list(line));
            let args: Vec<&str> = line[line.find(']').unwrap() + 2..line.len() - 1]
                .split(',')
                .map(str::trim)
                .collect();
            assert_eq!(args[..2], ["0", "0"], "{line}");
            assert_eq!(args[3..], ["0.1", "300"], "{line}");
            period = args[2].parse().unwrap();
        }
    }
    (start, poses, period)
}

#[test]
fn urscript_programs_stay_within_the_cell_and_its_speed_scaling() {
    let cell_path = cell_file("urscript.cell.toml", CELL);
    let dir = design_three("set_urscript", &cell_path, &["--format", "urscript"]);
    let robot = ur5();
    let cell = Cell::from_file(&cell_path).unwrap();
    let limited = cell.limit(&robot).unwrap();
    for k in 1..=3 {
        let text = std::fs::read_to_string(dir.join(format!("excitation_{k:02}.script"))).unwrap();
        let name = format!("excitation_{k:02}");
        assert!(text.starts_with(&format!("def {name}():\n")), "{text:.200}");
        let tail: Vec<&str> = text.lines().rev().take(2).collect();
        assert_eq!(tail[0], "end");
        assert!(tail[1].trim().starts_with("stopj("), "{}", tail[1]);
        let (start, poses, period) = servoj_poses(&text);
        // e-Series rate by default: 10 s at 500 Hz.
        assert_eq!(period, 0.002);
        assert_eq!(poses.len(), 5001);
        assert_eq!(start, poses[0]);
        for (s, pair) in poses.windows(2).enumerate() {
            assert_in_cell(
                &robot,
                &limited,
                &cell,
                &pair[1],
                &format!("{name} step {s}"),
            );
            for (i, j) in robot.joints().iter().enumerate() {
                // Positions are written to 1e-6 rad.
                let speed = (pair[1][i] - pair[0][i]).abs() / period;
                let limit = j.limits.velocity * cell.speed_scaling + 2e-6 / period;
                assert!(
                    speed <= limit,
                    "{name} step {s}: joint {} at {speed} rad/s",
                    i + 1
                );
            }
        }
        // Starts and ends at rest.
        let last = &poses[poses.len() - 2..];
        assert!(
            last[0]
                .iter()
                .zip(&last[1])
                .all(|(a, b)| (a - b).abs() < 1e-4)
        );
    }
    // The CSVs come along, at the controller's rate.
    let (_, rows) = read_csv(&dir.join("excitation_01.csv"));
    assert_eq!(rows.len(), 5001);
}

/// Run `excite --set 2` on the UR5 in the cell `text`; returns exit code and stderr.
fn refused(name: &str, text: &str) -> (i32, String) {
    let cell = cell_file(name, text);
    let out = tmp(&format!("{name}.out"));
    let robot = repo("models/ur5.urdf");
    let mut args = vec![
        "excite",
        "--robot",
        &robot,
        "--set",
        "2",
        "--cell",
        cell.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(SMALL);
    let (code, _, err) = run(&args);
    assert!(!out.join("runs.toml").exists(), "{name}: wrote a set");
    (code, err)
}

#[test]
fn a_cell_where_nothing_can_be_designed_is_refused_with_the_reason() {
    // The floor above anything the arm reaches: it cannot stand.
    let (code, err) = refused("high_floor.toml", "floor_z_m = 2.0\n");
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("cannot stand") && err.contains("2.05"),
        "{err}"
    );
    // No motion allowed.
    let (code, err) = refused("no_speed.toml", "speed_scaling = 0.0\n");
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("no_speed.toml") && err.contains("speed_scaling"),
        "{err}"
    );
    let (code, err) = refused("fast.toml", "accel_scaling = 1.5\n");
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("accel_scaling") && err.contains("(0, 1]"),
        "{err}"
    );
    // An empty joint range, and one outside the URDF's.
    let empty = "[[joint]]\nname = \"elbow_joint\"\nlower_rad = 1.0\nupper_rad = 0.5\n";
    let (code, err) = refused("empty_range.toml", empty);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("elbow_joint") && err.contains("empty"),
        "{err}"
    );
    let outside = "[[joint]]\nname = \"elbow_joint\"\nlower_rad = 4.0\nupper_rad = 5.0\n";
    let (code, err) = refused("outside_range.toml", outside);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("elbow_joint") && err.contains("outside the URDF"),
        "{err}"
    );
    let unknown = "[[joint]]\nname = \"elbow\"\nlower_rad = 0.0\nupper_rad = 1.0\n";
    let (code, err) = refused("unknown_joint.toml", unknown);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("'elbow'") && err.contains("shoulder_pan_joint"),
        "{err}"
    );
}

#[test]
fn bad_cell_toml_is_a_clear_error() {
    let (code, err) = refused("typo.toml", "floor_height_m = 0.1\n");
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("typo.toml") && err.contains("floor_height_m"),
        "{err}"
    );
    let (code, err) = refused("broken.toml", "floor_z_m = \n");
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("broken.toml") && err.contains("line 1"),
        "{err}"
    );
    let (code, err) = refused("text.toml", "floor_z_m = \"low\"\n");
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("text.toml") && err.contains("floor_z_m"),
        "{err}"
    );
}

#[test]
fn loads_must_match_the_set_and_the_rated_payload() {
    let out = tmp("loads.out");
    let robot = repo("models/ur5.urdf");
    let drive = repo("models/ur5.drive.toml");
    let base = [
        "excite", "--robot", &robot, "--drive", &drive, "--set", "3", "--out",
    ];
    let mut args: Vec<&str> = base.to_vec();
    args.extend([out.to_str().unwrap(), "--loads", "none,none"]);
    let (code, _, err) = run(&args);
    assert_eq!(code, 1);
    assert!(
        err.contains("--loads has 2 entries for 3 excitations"),
        "{err}"
    );
    // 4 kg + 2 kg exceed the UR5's 5 kg.
    let heavy = format!(
        "{}+{}",
        repo("models/load_4kg.payload.toml"),
        repo("models/load_2kg.payload.toml")
    );
    let mut args: Vec<&str> = base.to_vec();
    args.extend([out.to_str().unwrap(), "--loads", &heavy]);
    let (code, _, err) = run(&args);
    assert_eq!(code, 1);
    assert!(err.contains("rated payload"), "{err}");
    let mut args: Vec<&str> = base.to_vec();
    args.extend([out.to_str().unwrap(), "--loads", "no_such_load"]);
    let (code, _, err) = run(&args);
    assert_eq!(code, 1);
    assert!(err.contains("no_such_load"), "{err}");
}
