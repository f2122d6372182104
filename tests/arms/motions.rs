//! Motions planned for the UR5 and the Panda: the held-out benchmark's motions, numerical
//! linear moves and the scenarios' sweep cells, within the joint limits.

use super::*;

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
