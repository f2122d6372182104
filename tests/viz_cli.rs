//! The Rerun flags of the CLI (`--save`, `--spawn`) and the recording `reproduce` always
//! writes, read back with Rerun's own decoder.
#![cfg(feature = "viz")]

use crate::common;

use std::path::Path;

use common::rrd::{self, FileContent};
use common::{run, tmp};
use powertwin::viz::{SPEED_TIMELINE, TIMELINE, path_part};

/// Via points reached after the start of the built-in path (13 steps).
const VIA_REACHED: usize = 12;

/// Rows shown at the default 50 Hz of a run lasting `cycle_s` (1 kHz recording, every 20th
/// row from the first).
fn displayed_rows(content: &FileContent, entity: &str, cycle_s: f64) -> usize {
    let rows = content.rows(entity, TIMELINE);
    let expected = cycle_s * 50.0;
    assert!(
        (rows as f64 - expected).abs() <= 2.0,
        "{entity}: {rows} rows for a {cycle_s} s run at 50 Hz"
    );
    rows
}

/// Cycle time (s) of each cell in a sweep.json, by (speed, load).
fn cycle_times(sweep_json: &Path) -> Vec<(f64, f64, f64)> {
    let text = std::fs::read_to_string(sweep_json).expect("sweep.json written");
    let v: serde_json::Value = serde_json::from_str(&text).expect("sweep.json parses");
    v["cells"]
        .as_array()
        .expect("cells")
        .iter()
        .map(|c| {
            let f = |k: &str| c[k].as_f64().expect(k);
            (f("speed_m_s"), f("load_kg"), f("cycle_time_s"))
        })
        .collect()
}

/// Every run's robot, joints, power, plan and events under `prefix`, shown for `cycle_s`.
fn assert_task_run(content: &FileContent, prefix: &str, cycle_s: f64, predicted: bool) {
    let rows = displayed_rows(
        content,
        &format!("{prefix}/power/joint1/simulated_W"),
        cycle_s,
    );
    for name in [
        format!("{prefix}/robot/link_6"),
        format!("{prefix}/joints/q/q6_rad"),
        format!("{prefix}/power/total/simulated_W"),
        format!("{prefix}/energy/simulated_J"),
    ] {
        assert_eq!(content.rows(&name, TIMELINE), rows, "{name}");
    }
    for name in ["robot/via_points", "robot/tcp_path", "robot/link_6/tcp"] {
        assert!(content.is_static(&format!("{prefix}/{name}")), "{name}");
    }
    assert!(content.rows(&format!("{prefix}/power/total/measured_W"), TIMELINE) > 0);
    if predicted {
        for name in [
            format!("{prefix}/power/joint6/predicted_W"),
            format!("{prefix}/power/total/predicted_W"),
            format!("{prefix}/energy/predicted_J"),
        ] {
            assert_eq!(content.rows(&name, TIMELINE), rows, "{name}");
        }
    }
}

#[test]
fn simulate_saves_the_run_with_its_payload() {
    // 2 s at 1 kHz: joint i moves 0.1 i (1 - cos(pi t)) rad.
    let traj = tmp("traj.csv");
    let mut text = String::from("t,q1,q2,q3,q4,q5,q6\n");
    for k in 0..=40 {
        let t = k as f64 * 0.05;
        let q: Vec<String> = (1..=6)
            .map(|i| {
                format!(
                    "{}",
                    0.1 * i as f64 * (1.0 - (std::f64::consts::PI * t).cos())
                )
            })
            .collect();
        text.push_str(&format!("{t},{}\n", q.join(",")));
    }
    std::fs::write(&traj, text).unwrap();
    let (out, rrd_path) = (tmp("simulated"), tmp("simulate.rrd"));
    let (code, _, err) = run(&[
        "simulate",
        "--trajectory",
        traj.to_str().unwrap(),
        "--payload",
        "load_2kg",
        "--out",
        out.to_str().unwrap(),
        "--save",
        rrd_path.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let content = rrd::read(&rrd_path);
    let rows = displayed_rows(&content, "run/power/joint1/simulated_W", 2.0);
    for name in [
        "run/robot/link_6",
        "run/energy/simulated_J",
        "run/payload/mass_kg",
    ] {
        assert_eq!(content.rows(name, TIMELINE), rows, "{name}");
    }
    // 10 Hz measurements over 2 s; the payload mounted at t = 0.
    assert_eq!(content.rows("run/power/joint1/measured_W", TIMELINE), 20);
    assert_eq!(content.rows("run/events", TIMELINE), 1);
    assert!(content.is_static("run/robot/flange_path"));
    assert!(content.blueprint_chunks > 0);
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&rrd_path).unwrap();
    std::fs::remove_file(&traj).unwrap();
}

#[test]
fn sweep_saves_every_cell_and_the_energies() {
    let out = tmp("sweep");
    let rrd_path = tmp("sweep.rrd");
    let (code, _, err) = run(&[
        "sweep",
        "--speeds",
        "1",
        "--loads",
        "0,2",
        "--noise",
        "none",
        "--out",
        out.to_str().unwrap(),
        "--save",
        rrd_path.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let content = rrd::read(&rrd_path);
    let cells = cycle_times(&out.join("sweep.json"));
    assert_eq!(cells.len(), 2);
    for (speed, load, cycle_s) in cells {
        let prefix = format!("sweep/{}mps_{}kg", path_part(&speed.to_string()), load);
        assert_task_run(&content, &prefix, cycle_s, false);
        // The tool mounted (and with a load: two picks, two releases), then every via point.
        let payload_events = if load > 0.0 { 5 } else { 1 };
        assert_eq!(
            content.rows(&format!("{prefix}/events"), TIMELINE),
            payload_events + VIA_REACHED
        );
        assert_eq!(
            content.rows(
                &format!("sweep/energy_J/load_{load}kg_twin"),
                SPEED_TIMELINE
            ),
            1
        );
        assert!(
            !content
                .entities
                .contains_key(&format!("sweep/energy_J/load_{load}kg_model")),
            "no --model, no prediction"
        );
    }
    assert!(content.is_static("sweep/table"));
    assert!(content.blueprint_chunks > 0);
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&rrd_path).unwrap();
}

#[test]
fn reproduce_always_saves_its_recording_and_any_other_asked_for() {
    let out = tmp("reproduce");
    let extra = tmp("extra.rrd");
    let (code, stdout, err) = run(&[
        "reproduce",
        "--quick",
        "--out",
        out.to_str().unwrap(),
        "--save",
        extra.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("powertwin.rrd"), "{stdout}");
    let content = rrd::read(&out.join("powertwin.rrd"));
    for k in 1..=6 {
        let prefix = format!("table3/step{k}");
        let rows = content.rows(&format!("{prefix}/power/joint1/simulated_W"), TIMELINE);
        assert!(rows > 0, "{prefix}");
        assert_eq!(
            content.rows(&format!("{prefix}/power/total/predicted_W"), TIMELINE),
            rows
        );
    }
    for case in ["no_tool", "tool", "tool_1_kg", "tool_2_kg", "tool_4_kg"] {
        let name = format!("table4/{case}/power/total/predicted_W");
        assert!(content.rows(&name, TIMELINE) > 0, "{name}");
    }
    for method in ["paper_steps", "total", "pmsm"] {
        assert!(content.is_static(&format!("identification/{method}/error_pct")));
        assert!(content.is_static(&format!("identification/{method}/table")));
    }
    // The quick sweep: 0.1, 0.5, 1 m/s with 0 and 4 kg, twin and model.
    for load in [0, 4] {
        for speed in ["0p1", "0p5", "1"] {
            let prefix = format!("sweep/{speed}mps_{load}kg");
            assert!(content.is_static(&format!("{prefix}/robot/via_points")));
            assert!(
                content.rows(&format!("{prefix}/energy/predicted_J"), TIMELINE) > 0,
                "{prefix}"
            );
        }
        for what in ["twin", "model"] {
            let name = format!("sweep/energy_J/load_{load}kg_{what}");
            assert_eq!(content.rows(&name, SPEED_TIMELINE), 3, "{name}");
        }
    }
    assert!(content.blueprint_chunks > 0);
    // --save wrote the same recording elsewhere.
    let copy = rrd::read(&extra);
    assert_eq!(copy.entity_names(), content.entity_names());
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&extra).unwrap();
}

#[test]
fn spawn_without_a_viewer_on_path_says_how_to_install_one() {
    if rrd::viewer_listens() {
        return;
    }
    let out = tmp("spawn");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_powertwin"))
        .args(["reproduce", "--quick", "--spawn", "--out"])
        .arg(&out)
        .env("PATH", "")
        .current_dir(std::env::temp_dir())
        .output()
        .expect("the powertwin binary runs");
    let err = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{err}");
    assert!(err.contains("pip install rerun-sdk==0.36.*"), "{err}");
    assert!(
        err.contains("cargo install rerun-cli --version 0.36.* --locked"),
        "{err}"
    );
    // It failed before running anything.
    assert!(!out.join("datasets").exists());
    assert!(!err.contains("panicked"), "{err}");
    std::fs::remove_dir_all(&out).unwrap();
}
