//! Linear TCP moves and the pick-and-place scenario: the TCP on the straight lines with the
//! right orientation, stops at the via points, cruise speed, joint derivatives against finite
//! differences of an independent IK of the path, joint limits over the sweep, slowed segments,
//! load events, and error cases (unreachable points, bad files, bad inputs).

use crate::common;

use nalgebra::{Isometry3, Translation3, Vector3};
use powertwin::kinematics::fk::tcp_pose;
use powertwin::kinematics::ik::Opw;
use powertwin::kinematics::jacobian::geometric;
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::limits::check_limits;
use powertwin::trajectory::linear_move::{LinearMoveOptions, SlowReason, ViaPose, plan};
use powertwin::trajectory::s_curve::SCurve;
use powertwin::trajectory::task::{Scenario, TaskRun};
use powertwin::{Error, Robot};

/// Tool mass of the built-in scenario, kg.
const TOOL_KG: f64 = 1.32;

fn at(traj: &dyn Trajectory, t: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = traj.dof();
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    traj.sample(t, &mut q, &mut dq, &mut ddq);
    (q, dq, ddq)
}

fn builtin_run(robot: &Robot, speed: f64, load: f64) -> (Scenario, TaskRun) {
    let sc = Scenario::builtin().expect("the built-in scenario parses");
    let run = sc
        .plan(robot, speed, load)
        .expect("the built-in scenario plans");
    (sc, run)
}

/// Times strictly inside leg `k`, not on the sample grid.
fn times_in_leg(run: &TaskRun, k: usize, count: usize) -> Vec<f64> {
    let (t0, t1) = (run.via[k].arrival_s, run.via[k + 1].arrival_s);
    (0..count)
        .map(|i| t0 + (t1 - t0) * (i as f64 + 0.377) / count as f64)
        .collect()
}

/// The pick-and-place text with `from` replaced by `to` (which must occur).
fn edited(from: &str, to: &str) -> String {
    let text = powertwin::model::builtin::PICK_AND_PLACE;
    assert!(text.contains(from), "scenario text contains {from:?}");
    text.replacen(from, to, 1)
}

#[test]
fn builtin_scenario_has_the_papers_path_points_and_sweep() {
    let sc = Scenario::builtin().unwrap();
    let path: Vec<&str> = sc.path().iter().map(String::as_str).collect();
    assert_eq!(
        path,
        [
            "A", "B", "C", "B", "A", "D", "A", "D", "A", "E", "F", "E", "A"
        ]
    );
    assert_eq!(sc.point("C"), Some(Vector3::new(0.30, 0.30, 0.15)));
    assert_eq!(sc.sweep.speeds_m_s, [0.05, 0.1, 0.3, 0.5, 0.8, 1.0]);
    assert_eq!(sc.sweep.loads_kg, [0.0, 2.0, 4.0]);
    assert_eq!(sc.tool.as_ref().map(|t| t.inertia.mass), Some(TOOL_KG));
    assert_eq!(sc.tcp().translation.vector, Vector3::new(0.0, 0.0, 0.120));
    // Tool pointing down: tool z = -z_base, tool x = -x_base.
    let r = sc.orientation();
    assert!((r * Vector3::z() + Vector3::z()).norm() < 1e-12);
    assert!((r * Vector3::x() + Vector3::x()).norm() < 1e-12);
    // The same file as scenarios/pick_and_place.toml.
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/pick_and_place.toml");
    assert_eq!(Scenario::from_file(&path).unwrap(), sc);
}

#[test]
fn tcp_follows_the_lines_and_stops_at_every_via_point() {
    let robot = common::irb1200();
    for speed in [0.05, 1.0] {
        let (sc, run) = builtin_run(&robot, speed, 0.0);
        let traj = &run.motion;
        let tcp = sc.tcp();
        assert_eq!(run.via.len(), 13);
        assert_eq!(run.via[0].arrival_s, 0.0);
        assert_eq!(run.motion.duration_s, run.via[12].arrival_s);
        assert!((traj.duration() - run.motion.duration_s).abs() < 1e-12);
        // Stops exactly on the via points, at rest.
        for v in &run.via {
            let (q, dq, ddq) = at(traj, v.arrival_s);
            let p = tcp_pose(&robot, &q, &tcp);
            assert!(
                (p.translation.vector - v.tcp_m).norm() < 1e-9,
                "{speed} m/s, {}",
                v.name
            );
            assert!(
                dq.iter().chain(&ddq).all(|x| x.abs() < 1e-9),
                "{}: {dq:?}",
                v.name
            );
        }
        // On the straight line between them, with the tool pointing down, everywhere.
        let mut worst: (f64, f64) = (0.0, 0.0);
        for k in 0..12 {
            let (a, b) = (run.via[k].tcp_m, run.via[k + 1].tcp_m);
            let dir = (b - a).normalize();
            let len = (b - a).norm();
            for t in times_in_leg(&run, k, 400) {
                let (q, _, _) = at(traj, t);
                let p = tcp_pose(&robot, &q, &tcp);
                let rel = p.translation.vector - a;
                let along = rel.dot(&dir);
                assert!(
                    (-1e-9..=len + 1e-9).contains(&along),
                    "leg {k}: {along} m along a {len} m leg"
                );
                let off = (rel - dir * along).norm();
                let angle = p.rotation.angle_to(&sc.orientation());
                worst = (worst.0.max(off), worst.1.max(angle));
            }
        }
        assert!(
            worst.0 < 1e-6 && worst.1 < 1e-6,
            "{speed} m/s: {:.3e} m off the line, {:.3e} rad off the orientation",
            worst.0,
            worst.1
        );
    }
}

#[test]
fn tcp_cruises_at_the_commanded_speed_when_the_leg_is_long_enough() {
    let robot = common::irb1200();
    // The library's default (Pilz) limits, not the scenario's faster ones: no leg is slowed.
    let lim = LinearMoveOptions::default().limits;
    let mut sc = Scenario::builtin().unwrap();
    sc.motion = LinearMoveOptions::default();
    for speed in [0.05, 0.5, 1.0] {
        let run = sc.plan(&robot, speed, 0.0).unwrap();
        assert!(
            run.motion.slowed.is_empty(),
            "{speed}: {:?}",
            run.motion.slowed
        );
        let tcp = sc.tcp();
        let mut cruised = 0;
        for k in 0..12 {
            let len = (run.via[k + 1].tcp_m - run.via[k].tcp_m).norm();
            let profile = SCurve::new(len, speed, lim.accel_m_s2, lim.jerk_m_s3).unwrap();
            let leg_time = run.via[k + 1].arrival_s - run.via[k].arrival_s;
            assert!((leg_time - profile.duration()).abs() < 1e-9, "leg {k}");
            let mut peak: f64 = 0.0;
            for t in times_in_leg(&run, k, 1000) {
                let (q, dq, _) = at(&run.motion, t);
                let v = geometric(&robot, &q, &tcp) * nalgebra::DVector::from_column_slice(&dq);
                peak = peak.max(v.fixed_rows::<3>(0).norm());
            }
            assert!(
                peak <= speed * (1.0 + 1e-6),
                "leg {k}: {peak} > {speed} m/s"
            );
            if profile.cruises() {
                cruised += 1;
                assert!((peak - speed).abs() < 1e-6 * speed, "leg {k}: {peak} m/s");
            } else {
                assert!(peak < speed && (peak - profile.peak_speed()).abs() < 1e-4);
            }
        }
        // At 0.05 m/s every leg cruises, at 0.5 m/s the long ones, at 1 m/s none (2.25 m/s^2).
        let expected = match speed {
            0.05 => 12,
            0.5 => 8,
            _ => 0,
        };
        assert_eq!(cruised, expected, "{speed} m/s");
    }
}

#[test]
fn s_curve_reaches_its_bounds_and_degrades_on_short_moves() {
    let (v, a, j) = (1.0, 2.25, 20.0);
    // Long: cruises at v; medium: reaches a but not v; short: reaches neither.
    for (d, cruise, full_accel) in [(2.0, true, true), (0.3, false, true), (0.01, false, false)] {
        let p = SCurve::new(d, v, a, j).unwrap();
        assert_eq!(p.cruises(), cruise, "{d}");
        assert_eq!((p.peak_acceleration() - a).abs() < 1e-12, full_accel, "{d}");
        assert!(p.peak_speed() <= v + 1e-12 && p.peak_acceleration() <= a + 1e-12);
        assert_eq!(p.sample(0.0), [0.0, 0.0, 0.0]);
        assert_eq!(p.sample(p.duration()), [d, 0.0, 0.0]);
        // Continuous, within the bounds, consistent derivatives.
        let n = 2000;
        let h = p.duration() / n as f64;
        let mut prev = p.sample(0.0);
        for i in 1..=n {
            let s = p.sample(i as f64 * h);
            assert!(s[1] >= -1e-12 && s[1] <= v + 1e-12 && s[2].abs() <= a + 1e-12);
            assert!((s[0] - prev[0] - 0.5 * (s[1] + prev[1]) * h).abs() < j * h * h * h);
            assert!((s[1] - prev[1] - 0.5 * (s[2] + prev[2]) * h).abs() < j * h * h);
            assert!((s[2] - prev[2]).abs() <= j * h * (1.0 + 1e-9));
            prev = s;
        }
    }
    assert!(SCurve::new(1.0, 0.0, a, j).is_err());
    assert!(SCurve::new(-1.0, v, a, j).is_err());
    assert!(SCurve::new(1.0, v, f64::NAN, j).is_err());
    assert_eq!(SCurve::new(0.0, v, a, j).unwrap().duration(), 0.0);
}

#[test]
fn joint_velocity_and_acceleration_match_finite_differences_of_the_path() {
    // An independent reconstruction of q(t): the S-curve of each leg, the point on the line,
    // closed-form IK. Its central differences must match the planned dq and ddq.
    let robot = common::irb1200();
    let opw = Opw::from_robot(&robot).unwrap();
    let speed = 0.3;
    let (sc, run) = builtin_run(&robot, speed, 0.0);
    assert!(run.motion.slowed.is_empty(), "{:?}", run.motion.slowed);
    let lim = sc.motion.limits.clone();
    let tcp = sc.tcp();
    let h = 1e-4;
    let (mut ep, mut ev, mut ea) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..12 {
        let (a, b) = (run.via[k].tcp_m, run.via[k + 1].tcp_m);
        let len = (b - a).norm();
        let profile = SCurve::new(len, speed, lim.accel_m_s2, lim.jerk_m_s3).unwrap();
        let t0 = run.via[k].arrival_s;
        for t in times_in_leg(&run, k, 60) {
            let (q, dq, ddq) = at(&run.motion, t);
            let q_true = |t: f64| {
                let p = a + (b - a) * (profile.sample(t - t0)[0] / len);
                let pose = Isometry3::from_parts(Translation3::from(p), sc.orientation());
                opw.solve_nearest(&pose, &tcp, &q).unwrap()
            };
            let (qm, q0, qp) = (q_true(t - h), q_true(t), q_true(t + h));
            for i in 0..6 {
                ep = ep.max((q[i] - q0[i]).abs());
                ev = ev.max(((qp[i] - qm[i]) / (2.0 * h) - dq[i]).abs());
                ea = ea.max(((qp[i] - 2.0 * q0[i] + qm[i]) / (h * h) - ddq[i]).abs());
            }
        }
    }
    assert!(ep < 1e-8, "q differs by {ep:.3e} rad");
    assert!(ev < 1e-6, "dq differs by {ev:.3e} rad/s");
    assert!(ea < 1e-3, "ddq differs by {ea:.3e} rad/s^2");
}

#[test]
fn joint_limits_hold_at_every_speed_and_load_of_the_sweep() {
    let robot = common::irb1200();
    let sc = Scenario::builtin().unwrap();
    let acc = sc.motion.limits.joint_accel_rad_s2.clone();
    for &speed in &sc.sweep.speeds_m_s {
        for &load in &sc.sweep.loads_kg {
            let run = sc.plan(&robot, speed, load).unwrap();
            check_limits(&robot, &run.motion, 1e-3, Some(&acc))
                .unwrap_or_else(|e| panic!("{speed} m/s, {load} kg: {e}"));
        }
    }
}

#[test]
fn a_speed_the_joints_cannot_follow_is_slowed_and_reported() {
    let robot = common::irb1200();
    let sc = Scenario::builtin().unwrap();
    let acc = sc.motion.limits.joint_accel_rad_s2.clone();
    // 5 m/s with a TCP acceleration high enough to reach it: joint speeds limit.
    let mut fast = sc.clone();
    fast.motion.limits.accel_m_s2 = 50.0;
    fast.motion.limits.jerk_m_s3 = 2000.0;
    fast.motion.limits.joint_accel_rad_s2 = vec![1e3; 6];
    let run = fast.plan(&robot, 5.0, 0.0).unwrap();
    assert!(!run.motion.slowed.is_empty());
    check_limits(&robot, &run.motion, 1e-3, Some(&[1e3; 6])).unwrap();
    assert!(
        run.motion
            .slowed
            .iter()
            .any(|s| s.reason == SlowReason::JointVelocity)
    );
    for s in &run.motion.slowed {
        assert!(s.segment < 12 && s.limiting_joint < 6);
        assert!(
            s.used_m_s < s.commanded_m_s && s.commanded_m_s <= 5.0,
            "{s:?}"
        );
    }
    // The defaults at 5 m/s: the legs are too short to get near 5 m/s at 2.25 m/s^2, and the
    // plan stays within the limits.
    let run = sc.plan(&robot, 5.0, 0.0).unwrap();
    check_limits(&robot, &run.motion, 1e-3, Some(&acc)).unwrap();
    // Tight joint accelerations at a moderate speed: slowed for acceleration.
    let mut tight = sc.clone();
    tight.motion.limits.joint_accel_rad_s2 = vec![0.5; 6];
    let run = tight.plan(&robot, 0.3, 0.0).unwrap();
    assert!(
        run.motion
            .slowed
            .iter()
            .any(|s| s.reason == SlowReason::JointAcceleration)
    );
    check_limits(&robot, &run.motion, 1e-3, Some(&[0.5; 6])).unwrap();
    // Limits no speed can meet: an error naming the segment.
    tight.motion.limits.joint_accel_rad_s2 = vec![1e-6; 6];
    let err = tight.plan(&robot, 0.3, 0.0).unwrap_err();
    assert!(matches!(err, Error::JointLimit(_)), "{err}");
    let m = err.to_string();
    assert!(
        m.contains("segment 1 (A -> B)") && m.contains("below 1 %"),
        "{m}"
    );
    let unslowed = sc.plan(&robot, 0.3, 0.0).unwrap();
    assert!(unslowed.motion.slowed.is_empty());
    assert!(run.motion.duration_s > unslowed.motion.duration_s);
}

#[test]
fn load_events_follow_the_literal_reading_of_the_paper() {
    let robot = common::irb1200();
    let (_, run) = builtin_run(&robot, 0.5, 4.0);
    let mass = |i: usize| run.events[i].payload.as_ref().unwrap().inertia.mass;
    let times: Vec<f64> = run.events.iter().map(|e| e.t_s).collect();
    let arrival = |step: usize| run.via[step - 1].arrival_s;
    assert_eq!(
        times,
        [0.0, arrival(3), arrival(5), arrival(7), arrival(10)]
    );
    let expected = [TOOL_KG, TOOL_KG + 2.0, TOOL_KG, TOOL_KG + 4.0, TOOL_KG];
    for (i, m) in expected.iter().enumerate() {
        assert!((mass(i) - m).abs() < 1e-12, "event {i}: {} kg", mass(i));
    }
    // The loads hang at the TCP: combined COM between the tool's (0.06 m) and the TCP.
    let heavy = run.events[3].payload.as_ref().unwrap();
    let z = (TOOL_KG * 0.060 + 4.0 * 0.120) / (TOOL_KG + 4.0);
    assert!((heavy.inertia.com - Vector3::new(0.0, 0.0, z)).norm() < 1e-12);
    assert_eq!(heavy.tcp, Some(Vector3::new(0.0, 0.0, 0.120)));
    // Load level 0: the tool alone throughout.
    let (_, run) = builtin_run(&robot, 0.5, 0.0);
    assert_eq!(run.events.len(), 1);
    assert_eq!(
        run.events[0].payload.as_ref().unwrap().inertia.mass,
        TOOL_KG
    );
}

#[test]
fn dwell_adds_a_standstill_at_every_via_point_reached() {
    let robot = common::irb1200();
    let mut sc = Scenario::builtin().unwrap();
    let plain = sc.plan(&robot, 0.5, 0.0).unwrap();
    sc.motion.dwell_s = 0.25;
    let run = sc.plan(&robot, 0.5, 0.0).unwrap();
    assert!((run.motion.duration_s - plain.motion.duration_s - 12.0 * 0.25).abs() < 1e-9);
    let t = run.via[3].arrival_s;
    let (q0, _, _) = at(&run.motion, t);
    let (q1, dq, _) = at(&run.motion, t + 0.2);
    assert_eq!(q0, q1);
    assert!(dq.iter().all(|v| v.abs() < 1e-12));
}

#[test]
fn unreachable_via_points_and_blocked_segments_are_named() {
    let robot = common::irb1200();
    let sc = Scenario::from_toml_str(
        &edited("B = [0.30, 0.30, 0.30]", "B = [2.0, 0.30, 0.30]"),
        "far",
    )
    .unwrap();
    let err = sc.plan(&robot, 0.5, 0.0).unwrap_err();
    assert!(matches!(err, Error::Unreachable(_)), "{err}");
    assert!(err.to_string().contains("via point 2 'B'"), "{err}");
    // Directly through the planner: a line through the base region runs into joint 3's limit.
    let tcp = sc.tcp();
    let pose = |x: f64, y: f64| ViaPose {
        name: String::new(),
        tcp: Isometry3::from_parts(Translation3::new(x, y, 0.3), sc.orientation()),
    };
    let opts = LinearMoveOptions::default();
    let err = plan(
        &robot,
        &tcp,
        &sc.seed_rad,
        &[pose(0.4, 0.0), pose(-0.4, -0.01)],
        0.5,
        &opts,
    )
    .unwrap_err();
    assert!(matches!(err, Error::JointLimit(_)), "{err}");
    assert!(
        err.to_string().contains("segment 1 (via 1 -> via 2)"),
        "{err}"
    );
}

#[test]
fn a_robot_carrying_its_own_end_effector_needs_only_a_tcp() {
    let text = edited(
        "tool = \"tool\"",
        "tool = \"none\"\ntcp_m = [0.0, 0.0, 0.1]",
    );
    let sc = Scenario::from_toml_str(&text, "none.toml").unwrap();
    assert_eq!(sc.tool, None);
    assert_eq!(sc.tcp().translation.vector, Vector3::new(0.0, 0.0, 0.1));
    let run = sc.plan(&common::irb1200(), 0.3, 2.0).unwrap();
    // Nothing on the flange at the start and after each release; the cube alone in between.
    let masses: Vec<Option<f64>> = run
        .events
        .iter()
        .map(|e| e.payload.as_ref().map(|p| p.inertia.mass))
        .collect();
    assert_eq!(masses, [None, Some(1.0), None, Some(2.0), None]);
    let com = run.events[1].payload.as_ref().unwrap().inertia.com;
    assert_eq!(com, Vector3::new(0.0, 0.0, 0.1));
    // tool = "none" without tcp_m, and tcp_m beside a real tool, are errors.
    for (text, needle) in [
        (edited("tool = \"tool\"", "tool = \"none\""), "needs tcp_m"),
        (
            edited(
                "tool = \"tool\"",
                "tool = \"tool\"\ntcp_m = [0.0, 0.0, 0.1]",
            ),
            "applies only",
        ),
        (
            edited(
                "tool = \"tool\"",
                "tool = \"none\"\ntcp_m = [0.0, nan, 0.1]",
            ),
            "finite",
        ),
    ] {
        let e = Scenario::from_toml_str(&text, "bad.toml").unwrap_err();
        assert!(e.to_string().contains(needle), "{e}");
    }
}

#[test]
fn bad_files_give_clear_errors() {
    let toml_err = |text: &str| match Scenario::from_toml_str(text, "bad.toml") {
        Err(Error::Toml { file, message }) => {
            assert_eq!(file, "bad.toml");
            message
        }
        other => panic!("expected a TOML error, got {other:?}"),
    };
    let m = toml_err(&edited("\n[points]\n", "\n[points\n"));
    assert!(m.contains("line"), "{m}");
    let m = toml_err(&edited("dwell_s = 0.0", "dwell_s = 0.0\nspeed = 1.0"));
    assert!(m.contains("speed"), "{m}");
    let m = toml_err(&edited("jerk_m_s3 = 80.0", "jerk = 20.0"));
    assert!(m.contains("jerk"), "{m}");
    let m = toml_err(&edited("\"F\", \"E\"", "\"G\", \"E\""));
    assert!(m.contains("'G'") && m.contains("path[11]"), "{m}");
    let m = toml_err(&edited("release_at = 5", "release_at = 8"));
    assert!(m.contains("picked at step 7 before"), "{m}");
    let m = toml_err(&edited("release_at = 10", "release_at = 14"));
    assert!(m.contains("release_at = 14"), "{m}");
    let m = toml_err(&edited(
        "x_base = [-1.0, 0.0, 0.0]",
        "x_base = [-1.0, 0.0, 0.5]",
    ));
    assert!(m.contains("x_base"), "{m}");
    let m = toml_err(&edited("loads_kg = [0.0, 2.0, 4.0]", "loads_kg = [-2.0]"));
    assert!(m.contains("loads_kg"), "{m}");
    let m = toml_err(&edited("tool = \"tool\"\n", ""));
    assert!(m.contains("tool"), "{m}");
    // A tool file relative to the scenario file.
    let dir = common::tmp("scenario");
    std::fs::create_dir_all(&dir).unwrap();
    let tool =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/tool_1p32kg.payload.toml");
    std::fs::copy(tool, dir.join("my_tool.payload.toml")).unwrap();
    std::fs::write(
        dir.join("ok.toml"),
        edited("tool = \"tool\"", "tool = \"my_tool.payload.toml\""),
    )
    .unwrap();
    let sc = Scenario::from_file(&dir.join("ok.toml")).unwrap();
    assert_eq!(sc.tool, Scenario::builtin().unwrap().tool);
    std::fs::write(
        dir.join("missing.toml"),
        edited("tool = \"tool\"", "tool = \"nope.payload.toml\""),
    )
    .unwrap();
    assert!(matches!(
        Scenario::from_file(&dir.join("missing.toml")),
        Err(Error::Io { .. })
    ));
    // A load file has no TCP.
    let load =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/load_1kg.payload.toml");
    std::fs::copy(load, dir.join("load.payload.toml")).unwrap();
    std::fs::write(
        dir.join("no_tcp.toml"),
        edited("tool = \"tool\"", "tool = \"load.payload.toml\""),
    )
    .unwrap();
    let err = Scenario::from_file(&dir.join("no_tcp.toml")).unwrap_err();
    assert!(err.to_string().contains("no TCP"), "{err}");
}

#[test]
fn bad_inputs_are_rejected() {
    let robot = common::irb1200();
    let sc = Scenario::builtin().unwrap();
    for speed in [f64::NAN, 0.0, -0.5, f64::INFINITY] {
        let err = sc.plan(&robot, speed, 0.0).unwrap_err();
        assert!(matches!(err, Error::InvalidInput(_)), "{speed}: {err}");
    }
    for load in [f64::NAN, -1.0] {
        assert!(matches!(
            sc.plan(&robot, 0.5, load),
            Err(Error::InvalidInput(_))
        ));
    }
    let mut bad = sc.clone();
    bad.motion.sample_period_s = 0.0;
    assert!(matches!(
        bad.plan(&robot, 0.5, 0.0),
        Err(Error::InvalidInput(_))
    ));
    let mut bad = sc.clone();
    bad.motion.limits.joint_accel_rad_s2 = vec![10.0; 5];
    assert!(matches!(
        bad.plan(&robot, 0.5, 0.0),
        Err(Error::InvalidInput(_))
    ));
    let mut bad = sc.clone();
    bad.motion.limits.jerk_m_s3 = f64::NAN;
    assert!(matches!(
        bad.plan(&robot, 0.5, 0.0),
        Err(Error::InvalidInput(_))
    ));
    let tcp = sc.tcp();
    let opts = LinearMoveOptions::default();
    let one = [ViaPose {
        name: "A".into(),
        tcp: Isometry3::from_parts(Translation3::new(0.4, 0.0, 0.4), sc.orientation()),
    }];
    assert!(matches!(
        plan(&robot, &tcp, &sc.seed_rad, &one, 0.5, &opts),
        Err(Error::InvalidInput(_))
    ));
    let same = [one[0].clone(), one[0].clone()];
    assert!(matches!(
        plan(&robot, &tcp, &sc.seed_rad, &same, 0.5, &opts),
        Err(Error::InvalidInput(_))
    ));
    assert!(matches!(
        plan(&robot, &tcp, &[0.0; 5], &same, 0.5, &opts),
        Err(Error::InvalidInput(_))
    ));
}
