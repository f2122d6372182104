//! Rerun logging: write a robot, a synthetic run and results to an `.rrd` file, read it back
//! with Rerun's own decoder and check entities, timelines and decimated row counts.
#![cfg(feature = "viz")]

mod common;

use std::collections::BTreeMap;
use std::path::PathBuf;

use powertwin::Robot;
use powertwin::twin::record::{Measured, Recording};
use powertwin::viz::{DEFAULT_DISPLAY_HZ, EVENTS_ENTITY, Sink, TIMELINE, Viz};
use rerun::StoreKind;
use rerun::external::re_log_encoding::DecoderApp;
use rerun::log::{Chunk, LogMsg};

/// What one entity holds in the file: static chunks and rows per timeline.
#[derive(Debug, Default)]
struct EntityContent {
    has_static: bool,
    rows: BTreeMap<String, usize>,
}

/// What an `.rrd` file holds.
#[derive(Debug, Default)]
struct FileContent {
    entities: BTreeMap<String, EntityContent>,
    blueprint_chunks: usize,
}

impl FileContent {
    fn rows(&self, entity: &str, timeline: &str) -> usize {
        self.entities
            .get(entity)
            .unwrap_or_else(|| panic!("entity {entity} missing; have {:?}", self.entity_names()))
            .rows
            .get(timeline)
            .copied()
            .unwrap_or(0)
    }

    fn entity_names(&self) -> Vec<&String> {
        self.entities.keys().collect()
    }
}

fn read_rrd(path: &PathBuf) -> FileContent {
    let file = std::fs::File::open(path).expect("rrd file exists");
    let decoder = DecoderApp::decode_eager(std::io::BufReader::new(file)).expect("valid rrd");
    let mut content = FileContent::default();
    for msg in decoder {
        let LogMsg::ArrowMsg(store_id, arrow) = msg.expect("message decodes") else {
            continue;
        };
        if store_id.kind() == StoreKind::Blueprint {
            content.blueprint_chunks += 1;
            continue;
        }
        let chunk = Chunk::from_arrow_msg(&arrow).expect("chunk decodes");
        // Entity paths print with a leading slash.
        let name = chunk.entity_path().to_string();
        let e = content
            .entities
            .entry(name.trim_start_matches('/').to_owned())
            .or_default();
        if chunk.is_static() {
            e.has_static = true;
        }
        for timeline in chunk.timelines().keys() {
            *e.rows.entry(timeline.to_string()).or_default() += chunk.num_rows();
        }
    }
    content
}

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
        let pred: Vec<f64> = m.p_total.iter().map(|p| 1.05 * p).collect();
        viz.log_power_prediction(&m.t, &pred, "run").unwrap();
        viz.log_events(&[(1.0, "pick 2 kg".to_owned()), (1.9, "release".to_owned())])
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
        viz.send_blueprint("run").unwrap();
        viz.flush().unwrap();
    }
    let content = read_rrd(&path);

    // 2000 rows at 1 kHz shown at 50 Hz: every 20th row, 100 rows.
    let shown = 100;
    for j in 1..=robot.dof() {
        for name in [
            format!("run/joints/q/q{j}_rad"),
            format!("run/joints/dq/dq{j}_rad_s"),
            format!("run/joints/tau/tau{j}_Nm"),
            format!("run/power/joint/p{j}_W"),
        ] {
            assert_eq!(content.rows(&name, TIMELINE), shown, "{name}");
        }
        // The zero pose of log_robot at t = 0, then the recording.
        assert_eq!(
            content.rows(&format!("run/robot/link_{j}"), TIMELINE),
            1 + shown
        );
        assert_eq!(
            content.rows(&format!("run/measured/q/q{j}_rad"), TIMELINE),
            m.t.len()
        );
    }
    for name in [
        "run/power/total/simulated_W",
        "run/power/total/grid_W",
        "run/energy/total_J",
        "run/energy/grid_J",
        "run/payload/mass_kg",
    ] {
        assert_eq!(content.rows(name, TIMELINE), shown, "{name}");
    }
    // Predicted and measured in the simulated power's plot (same parent).
    assert_eq!(content.rows("run/power/total/predicted_W", TIMELINE), 20);
    assert_eq!(content.rows("run/power/total/measured_W", TIMELINE), 20);
    assert_eq!(content.rows(EVENTS_ENTITY, TIMELINE), 2);
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
        let e = content
            .entities
            .get(name)
            .unwrap_or_else(|| panic!("{name} missing; have {:?}", content.entity_names()));
        assert!(e.has_static, "{name} is not static");
    }
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
    assert!(viz.log_power_prediction(&[0.0, 1.0], &[1.0], "r").is_err());
    assert!(viz.log_series("s", "x", &[1, 2], &[1.0]).is_err());
    assert!(viz.log_events(&[(f64::NAN, "e".into())]).is_err());
    assert!(
        viz.log_points("p", &[("A".into(), [0.0, f64::INFINITY, 0.0])])
            .is_err()
    );

    assert!(Viz::new("powertwin_test", &[]).is_err());
    assert!(Viz::new("", &[Sink::Save(rrd_path("bad2"))]).is_err());
    let url = Some("http://example.invalid/not-rerun".to_owned());
    assert!(Viz::new("powertwin_test", &[Sink::Connect(url)]).is_err());
    let missing_dir = rrd_path("no_such_dir").join("x.rrd");
    assert!(Viz::new("powertwin_test", &[Sink::Save(missing_dir)]).is_err());
}
