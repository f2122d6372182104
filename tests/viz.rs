//! Rerun logging: write a robot, a synthetic run and results to an `.rrd` file, read it back
//! with Rerun's own decoder and check entities, timelines and decimated row counts.
#![cfg(feature = "viz")]

use crate::common;

use std::path::PathBuf;

use common::rrd;
use powertwin::Robot;
use powertwin::trajectory::task::Scenario;
use powertwin::twin::record::{Measured, Recording};
use powertwin::validation::score::ParamRow;
use powertwin::validation::sweep::Cell;
use powertwin::viz::{DEFAULT_DISPLAY_HZ, EVENTS_ENTITY, SPEED_TIMELINE, Sink, TIMELINE, Tab, Viz};

/// A hand-made 2 s run at 1 kHz: sinusoidal joints, power from tau dq, a payload from 1 s on.
fn synthetic_recording(robot: &Robot) -> Recording {
    let (n, dt, len) = (robot.dof(), 1e-3, 2000);
    let t: Vec<f64> = (0..len).map(|k| k as f64 * dt).collect();
    let joint = |f: &dyn Fn(usize, f64) -> f64| -> Vec<Vec<f64>> {
        (0..n)
            .map(|i| t.iter().map(|&tk| f(i, tk)).collect())
            .collect()
    };
    let w = |i: usize| 1.0 + 0.3 * i as f64;
    let q = joint(&|i, tk| 0.3 * (w(i) * tk).sin());
    let dq = joint(&|i, tk| 0.3 * w(i) * (w(i) * tk).cos());
    let tau = joint(&|i, tk| 10.0 / (i + 1) as f64 * (1.0 + tk));
    let p_mech: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..len).map(|k| tau[i][k] * dq[i][k]).collect())
        .collect();
    let p_elec: Vec<Vec<f64>> = p_mech
        .iter()
        .map(|s| s.iter().map(|p| p + 5.0).collect())
        .collect();
    let p_total: Vec<f64> = (0..len)
        .map(|k| p_elec.iter().map(|s| s[k]).sum())
        .collect();
    Recording {
        dt,
        q_ref: q.clone(),
        dq_ref: dq.clone(),
        ddq_ref: joint(&|_, _| 0.0),
        p_grid: p_total.iter().map(|p| p.max(0.0)).collect(),
        payload_mass: t
            .iter()
            .map(|&tk| if tk >= 1.0 { 2.0 } else { 0.0 })
            .collect(),
        t,
        q,
        dq,
        tau,
        p_mech,
        p_elec,
        p_total,
    }
}

/// The recording's 10 Hz samples (no noise).
fn measured(rec: &Recording) -> Measured {
    let rows: Vec<usize> = (0..rec.len()).step_by(100).collect();
    let pick = |s: &[f64]| rows.iter().map(|&k| s[k]).collect::<Vec<f64>>();
    Measured {
        rate_hz: 10.0,
        t: pick(&rec.t),
        q: rec.q.iter().map(|s| pick(s)).collect(),
        p_joint: rec.p_elec.iter().map(|s| pick(s)).collect(),
        p_total: pick(&rec.p_total),
    }
}

fn rrd_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("powertwin_{name}.rrd"))
}

#[test]
fn run_round_trips_through_an_rrd_file() {
    let robot = common::irb1200();
    let rec = synthetic_recording(&robot);
    let m = measured(&rec);
    let path = rrd_path("run");
    {
        let viz = Viz::new("powertwin_test", &[Sink::Save(path.clone())]).unwrap();
        viz.log_robot(&robot, "run").unwrap();
        viz.log_recording(&robot, &rec, "run", DEFAULT_DISPLAY_HZ)
            .unwrap();
        viz.log_measured(&m, "run").unwrap();
        let pred: Vec<Vec<f64>> = m
            .p_joint
            .iter()
            .map(|s| s.iter().map(|p| 1.05 * p).collect())
            .collect();
        viz.log_prediction(&m.t, &pred, "run").unwrap();
        viz.log_events(
            &[(1.0, "pick 2 kg".to_owned()), (1.9, "release".to_owned())],
            "run",
        )
        .unwrap();
        viz.log_points(
            "run/robot/via_points",
            &[
                ("A".to_owned(), [0.4, 0.0, 0.5]),
                ("B".to_owned(), [0.3, 0.2, 0.4]),
            ],
        )
        .unwrap();
        viz.log_bar_chart("identification/error_pct", &[1.0, -2.0, 0.5])
            .unwrap();
        for (load, e) in [("load_0kg", 100.0), ("load_2kg", 120.0)] {
            viz.log_series(
                &format!("sweep/energy_J/{load}"),
                "speed_pct",
                &[20, 50, 100],
                &[e, 1.5 * e, 2.5 * e],
            )
            .unwrap();
        }
        let tab = Tab::Run {
            title: "run".into(),
            prefix: "run".into(),
            joints: robot.dof(),
        };
        viz.send_blueprint(&[tab]).unwrap();
        viz.flush().unwrap();
    }
    let content = rrd::read(&path);

    // 2000 rows at 1 kHz shown at 50 Hz: every 20th row, 100 rows.
    let shown = 100;
    for j in 1..=robot.dof() {
        for name in [
            format!("run/joints/q/q{j}_rad"),
            format!("run/joints/dq/dq{j}_rad_s"),
            format!("run/joints/tau/tau{j}_Nm"),
            format!("run/power/joint{j}/simulated_W"),
        ] {
            assert_eq!(content.rows(&name, TIMELINE), shown, "{name}");
        }
        // The zero pose of log_robot at t = 0, then the recording.
        assert_eq!(
            content.rows(&format!("run/robot/link_{j}"), TIMELINE),
            1 + shown
        );
        // Measured and predicted motor power in the simulated one's plot (same parent).
        for name in [
            format!("run/measured/q/q{j}_rad"),
            format!("run/power/joint{j}/measured_W"),
            format!("run/power/joint{j}/predicted_W"),
        ] {
            assert_eq!(content.rows(&name, TIMELINE), m.t.len(), "{name}");
        }
    }
    for name in [
        "run/power/total/simulated_W",
        "run/power/total/grid_W",
        "run/energy/simulated_J",
        "run/energy/grid_J",
        "run/payload/mass_kg",
    ] {
        assert_eq!(content.rows(name, TIMELINE), shown, "{name}");
    }
    // Predicted and measured in the simulated power's plot (same parent).
    for name in [
        "run/power/total/predicted_W",
        "run/power/total/measured_W",
        "run/energy/predicted_J",
    ] {
        assert_eq!(content.rows(name, TIMELINE), 20, "{name}");
    }
    assert_eq!(content.rows(&format!("run/{EVENTS_ENTITY}"), TIMELINE), 2);
    assert_eq!(content.rows("sweep/energy_J/load_2kg", "speed_pct"), 3);

    // Static geometry: the base and every link's shapes, the flange path, points, bars.
    for name in [
        "run/robot",
        "run/robot/base/visual_0",
        "run/robot/link_1/visual_0",
        "run/robot/link_6/visual_0",
        "run/robot/flange_path",
        "run/robot/via_points",
        "identification/error_pct",
    ] {
        assert!(content.is_static(name), "{name} is not static");
    }
    assert!(content.blueprint_chunks > 0, "no blueprint in the file");
}

#[test]
fn task_parameters_and_sweep_results_round_trip() {
    let robot = common::irb1200();
    let scenario = Scenario::builtin().unwrap();
    let run = scenario.plan(&robot, 0.5, 2.0).unwrap();
    let rows: Vec<ParamRow> = ["m6", "fc1", "XX6R"]
        .iter()
        .zip([Some(1.5), Some(-0.2), None])
        .map(|(name, error_pct)| ParamRow {
            name: name.to_string(),
            identified: 1.0,
            truth: 1.0,
            error_pct,
            rel_std_pct: Some(0.1),
        })
        .collect();
    let cell = |speed_m_s: f64, load_kg: f64, predicted: Option<f64>| Cell {
        speed_m_s,
        load_kg,
        cycle_time_s: 1.0 / speed_m_s,
        simulated_j: 100.0 + load_kg,
        simulated_grid_j: 110.0,
        predicted_j: predicted,
        predicted_grid_j: predicted,
        error_pct: predicted.map(|p| p - 100.0 - load_kg),
        slowed: Vec::new(),
        max_tracking_error_rad: 1e-4,
        torque_limit_hits: Vec::new(),
        flagged: false,
    };
    let cells = [
        cell(0.1, 0.0, Some(101.0)),
        cell(0.5, 0.0, Some(99.0)),
        cell(0.1, 0.5, None),
        cell(0.5, 0.5, None),
    ];
    let path = rrd_path("task");
    {
        let viz = Viz::new("powertwin_test", &[Sink::Save(path.clone())]).unwrap();
        viz.log_task(&robot, &run, &scenario.tcp(), "task", DEFAULT_DISPLAY_HZ)
            .unwrap();
        viz.log_parameters("identification/paper-steps", &rows)
            .unwrap();
        viz.log_sweep_cells("sweep", &cells).unwrap();
        let tabs = [
            Tab::Parameters {
                title: "parameters".into(),
                roots: vec!["identification/paper-steps".into()],
            },
            Tab::Sweep {
                title: "sweep".into(),
                root: "sweep".into(),
            },
        ];
        viz.send_blueprint(&tabs).unwrap();
        assert!(viz.send_blueprint(&[]).is_err());
        viz.flush().unwrap();
    }
    let content = rrd::read(&path);
    for name in [
        "task/robot/via_points",
        "task/robot/tcp_path",
        "task/robot/link_6/tcp",
        "identification/paper-steps/error_pct",
        "identification/paper-steps/table",
        "sweep/table",
    ] {
        assert!(content.is_static(name), "{name} is not static");
    }
    // Events: the tool mounted, two picks and two releases, and every via point after the
    // start (12 of the 13 steps of the path).
    assert_eq!(content.rows("task/events", TIMELINE), 5 + 12);
    assert_eq!(
        content.rows("sweep/energy_J/load_0kg_twin", SPEED_TIMELINE),
        2
    );
    assert_eq!(
        content.rows("sweep/energy_J/load_0kg_model", SPEED_TIMELINE),
        2
    );
    assert_eq!(
        content.rows("sweep/energy_J/load_0p5kg_twin", SPEED_TIMELINE),
        2
    );
    assert!(
        !content
            .entities
            .contains_key("sweep/energy_J/load_0p5kg_model"),
        "no prediction, no model series"
    );
    assert!(content.blueprint_chunks > 0, "no blueprint in the file");
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let robot = common::irb1200();
    let path = rrd_path("bad");
    let viz = Viz::new("powertwin_test", &[Sink::Save(path)]).unwrap();
    let mut rec = synthetic_recording(&robot);
    assert!(viz.log_recording(&robot, &rec, "r", 0.0).is_err());
    assert!(
        viz.log_recording(&robot, &Recording::default(), "r", 50.0)
            .is_err()
    );
    rec.tau[2].pop();
    assert!(viz.log_recording(&robot, &rec, "r", 50.0).is_err());
    assert!(viz.log_prediction(&[0.0, 1.0], &[vec![1.0]], "r").is_err());
    assert!(
        viz.log_prediction(&[1.0, 0.0], &[vec![1.0, 2.0]], "r")
            .is_err()
    );
    assert!(viz.log_prediction(&[0.0, 1.0], &[], "r").is_err());
    assert!(viz.log_series("s", "x", &[1, 2], &[1.0]).is_err());
    assert!(viz.log_events(&[(f64::NAN, "e".into())], "r").is_err());
    assert!(
        viz.log_points("p", &[("A".into(), [0.0, f64::INFINITY, 0.0])])
            .is_err()
    );

    assert!(Viz::new("powertwin_test", &[]).is_err());
    assert!(Viz::new("", &[Sink::Save(rrd_path("bad2"))]).is_err());
    let url = Some("http://example.invalid/not-rerun".to_owned());
    assert!(Viz::new("powertwin_test", &[Sink::Connect(url)]).is_err());
    // Nothing listens on port 1: an error at once, not a recording that blocks later.
    let url = Some("rerun+http://127.0.0.1:1/proxy".to_owned());
    match Viz::new("powertwin_test", &[Sink::Connect(url)]) {
        Err(powertwin::Error::Viz(msg)) => assert!(msg.contains("no Rerun viewer"), "{msg}"),
        other => panic!("expected a missing-viewer error, got {other:?}"),
    }
    let missing_dir = rrd_path("no_such_dir").join("x.rrd");
    assert!(Viz::new("powertwin_test", &[Sink::Save(missing_dir)]).is_err());
}
