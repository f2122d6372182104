//! Forward kinematics against the paper's MDH table, the Jacobian and its time derivative
//! against finite differences, closed-form IK round trips (IRB 1200 and other OPW arms), IK error cases and
//! damped least squares on OPW and non-OPW chains.

use crate::common;

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use powertwin::kinematics::dls::{self, DlsOptions};
use powertwin::kinematics::fk::{flange_pose, link_poses, tcp_pose};
use powertwin::kinematics::ik::{self, Opw};
use powertwin::kinematics::jacobian::{bias_acceleration, geometric};
use powertwin::model::frames::MdhRow;
use powertwin::model::urdf::{LoadOptions, load_str};
use powertwin::{Error, Robot};
use proptest::prelude::*;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;

/// IRB 1200-7/0.7 lengths L1..L5, m (reference sheet, section 1.1).
const L: [f64; 5] = [0.3991, 0.350, 0.042, 0.351, 0.082];

/// Position (m) and angle (rad) between two poses; the angle is accurate for tiny rotations.
fn pose_err(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
    let dp = (a.translation.vector - b.translation.vector).norm();
    let d = a.rotation.inverse() * b.rotation;
    (dp, 2.0 * d.imag().norm().atan2(d.w.abs()))
}

/// Rotation vector of a small rotation, rad (accurate where `scaled_axis` is not).
fn rotation_vector(r: &UnitQuaternion<f64>) -> Vector3<f64> {
    let v = r.imag() * r.w.signum();
    let s = v.norm();
    if s == 0.0 {
        v
    } else {
        v * (2.0 * s.atan2(r.w.abs()) / s)
    }
}

/// A TCP 0.1 m along the flange normal, slightly offset and tilted.
fn tool() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(0.01, -0.02, 0.1),
        UnitQuaternion::from_euler_angles(0.1, -0.2, 0.3),
    )
}

/// Random joint angles within the limits (and within [-pi, pi]), `|q5| >= 1e-3`.
fn random_q(robot: &Robot, rng: &mut ChaCha8Rng) -> [f64; 6] {
    loop {
        let q: [f64; 6] = std::array::from_fn(|i| {
            let l = robot.joints()[i].limits;
            rng.random_range(l.lower.max(-PI)..l.upper.min(PI))
        });
        if q[4].abs() >= 1e-3 {
            return q;
        }
    }
}

/// Largest difference of two angles modulo 2 pi, rad.
fn angle_gap(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let d = (x - y).rem_euclid(TAU);
            d.min(TAU - d)
        })
        .fold(0.0, f64::max)
}

/// One revolute joint of a generated URDF: origin, axis and position limits.
struct UrdfJoint {
    xyz: [f64; 3],
    rpy: [f64; 3],
    axis: [f64; 3],
    limits: (f64, f64),
}

/// A serial chain `base_link -> link_1 .. link_n -> tool0` with unit-ish inertials.
fn chain_urdf(joints: &[UrdfJoint], tool_rpy: [f64; 3]) -> String {
    let v = |a: [f64; 3]| format!("{} {} {}", a[0], a[1], a[2]);
    let inertial = r#"<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>"#;
    let mut s = format!(
        r#"<robot name="test_chain"><link name="base_link">{inertial}</link><link name="tool0"/>"#
    );
    for (i, j) in joints.iter().enumerate() {
        let parent = if i == 0 {
            "base_link".to_string()
        } else {
            format!("link_{i}")
        };
        s += &format!(
            r#"<link name="link_{n}">{inertial}</link><joint name="joint_{n}" type="revolute"><origin xyz="{}" rpy="{}"/><parent link="{parent}"/><child link="link_{n}"/><axis xyz="{}"/><limit lower="{}" upper="{}" effort="10" velocity="3"/></joint>"#,
            v(j.xyz),
            v(j.rpy),
            v(j.axis),
            j.limits.0,
            j.limits.1,
            n = i + 1
        );
    }
    s += &format!(
        r#"<joint name="tool" type="fixed"><origin xyz="0 0 0" rpy="{}"/><parent link="link_{}"/><child link="tool0"/></joint></robot>"#,
        v(tool_rpy),
        joints.len()
    );
    s
}

/// IRB 1200 geometry with lengths `l`, the given limits, as a generated URDF.
fn irb_like(l: [f64; 5], limits: [(f64, f64); 6]) -> Robot {
    let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    let xyz = [
        [0.0, 0.0, l[0]],
        [0.0; 3],
        [0.0, 0.0, l[1]],
        [0.0, 0.0, l[2]],
        [l[3], 0.0, 0.0],
        [l[4], 0.0, 0.0],
    ];
    let axes = [z, y, y, x, y, x];
    let joints: Vec<UrdfJoint> = (0..6)
        .map(|i| UrdfJoint {
            xyz: xyz[i],
            rpy: [0.0; 3],
            axis: axes[i],
            limits: limits[i],
        })
        .collect();
    load_str(
        &chain_urdf(&joints, [0.0, FRAC_PI_2, 0.0]),
        &LoadOptions::default(),
    )
    .expect("generated IRB-like URDF loads")
}

/// Position limits of the IRB 1200-7/0.7 model, rad.
fn irb_limits() -> [(f64, f64); 6] {
    let robot = common::irb1200();
    std::array::from_fn(|i| {
        let l = robot.joints()[i].limits;
        (l.lower, l.upper)
    })
}

/// A 6R arm whose axes are offset and skewed: not of the OPW class.
fn skewed_arm() -> Robot {
    let j = |xyz, axis: [f64; 3]| UrdfJoint {
        xyz,
        rpy: [0.0, 0.0, 0.0],
        axis,
        limits: (-3.0, 3.0),
    };
    let joints = [
        j([0.0, 0.0, 0.3], [0.0, 0.0, 1.0]),
        j([0.05, 0.02, 0.1], [0.0, 1.0, 0.0]),
        j([0.0, 0.03, 0.35], [0.0, 0.8, 0.6]),
        j([0.1, 0.0, 0.05], [1.0, 0.0, 0.0]),
        j([0.25, 0.02, 0.0], [0.0, 1.0, 0.3]),
        j([0.08, 0.0, 0.02], [1.0, 0.1, 0.0]),
    ];
    load_str(
        &chain_urdf(&joints, [0.0, FRAC_PI_2, 0.0]),
        &LoadOptions::default(),
    )
    .expect("skewed arm loads")
}

/// Round trip of `solve_all` and `solve_nearest` on `count` random configurations.
fn ik_round_trip(robot: &Robot, count: usize, seed: u64) {
    let opw = Opw::from_robot(robot).expect("robot is of the OPW class");
    let tcp = tool();
    let mut rng = common::rng(seed);
    let (mut worst_pose, mut worst_q) = (0.0f64, 0.0f64);
    for _ in 0..count {
        let q = random_q(robot, &mut rng);
        let flange = flange_pose(robot, &q);
        let sols = ik::solve_all(robot, &flange).unwrap();
        assert!(
            !sols.is_empty() && sols.len() <= 8,
            "{} solutions",
            sols.len()
        );
        let gap = sols
            .iter()
            .map(|s| angle_gap(s, &q))
            .fold(f64::INFINITY, f64::min);
        assert!(gap < 1e-8, "q = {q:?} not among {sols:?} (gap {gap:e})");
        worst_q = worst_q.max(gap);
        for s in &sols {
            assert!(
                s.iter().all(|v| (-PI..=PI).contains(v)),
                "{s:?} not in [-pi, pi]"
            );
            let (dp, dr) = pose_err(&flange_pose(robot, s), &flange);
            assert!(
                dp < 1e-9 && dr < 1e-9,
                "{s:?} misses by {dp:e} m, {dr:e} rad"
            );
            worst_pose = worst_pose.max(dp).max(dr);
        }
        let target = tcp_pose(robot, &q, &tcp);
        let near = ik::solve_nearest(robot, &target, &tcp, &q).unwrap();
        let diff = near
            .iter()
            .zip(&q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(diff < 1e-8, "nearest {near:?} vs true {q:?}");
        let again = opw.solve_nearest(&target, &tcp, &q).unwrap();
        assert_eq!(again.to_vec(), near);
    }
    eprintln!("worst pose error {worst_pose:e}, worst joint error {worst_q:e}");
}

#[test]
fn home_flange_matches_the_data_sheet() {
    let robot = common::irb1200();
    let f = flange_pose(&robot, &[0.0; 6]);
    let p = f.translation.vector;
    assert!((p - Vector3::new(0.433, 0.0, 0.7911)).norm() < 1e-12, "{p}");
    assert!((f.rotation * Vector3::z() - Vector3::x()).norm() < 1e-12);
    assert!((f.rotation * Vector3::x() + Vector3::z()).norm() < 1e-12);
}

#[test]
fn fk_matches_the_paper_mdh_chain() {
    let robot = common::irb1200();
    let row = |a, alpha, d, theta| MdhRow { a, alpha, d, theta };
    let table = [
        row(0.0, 0.0, L[0], 0.0),
        row(0.0, -FRAC_PI_2, 0.0, -FRAC_PI_2),
        row(L[1], 0.0, 0.0, 0.0),
        row(L[2], -FRAC_PI_2, L[3], 0.0),
        row(0.0, FRAC_PI_2, 0.0, 0.0),
        row(0.0, -FRAC_PI_2, 0.0, 0.0),
    ];
    let flange_row = row(0.0, 0.0, L[4], PI);
    let tcp = tool();
    let mut rng = common::rng(10);
    let mut poses = [Isometry3::identity(); 6];
    for _ in 0..1000 {
        let (q, _, _) = common::random_state(&robot, &mut rng);
        link_poses(&robot, &q, &mut poses);
        let mut mdh = Isometry3::identity();
        let mut by_joint = Isometry3::identity();
        for i in 0..6 {
            mdh *= table[i].transform(q[i]);
            by_joint *= robot.joint_transform(i, q[i]);
            let (dp, dr) = pose_err(&poses[i], &mdh);
            assert!(
                dp < 1e-12 && dr < 1e-12,
                "link {}: {dp:e} m {dr:e} rad",
                i + 1
            );
            let (dp, dr) = pose_err(&poses[i], &by_joint);
            assert!(dp < 1e-12 && dr < 1e-12, "link {}", i + 1);
        }
        let f = flange_pose(&robot, &q);
        let (dp, dr) = pose_err(&f, &(mdh * flange_row.transform(0.0)));
        assert!(dp < 1e-12 && dr < 1e-12, "flange: {dp:e} m {dr:e} rad");
        let (dp, dr) = pose_err(&tcp_pose(&robot, &q, &tcp), &(f * tcp));
        assert!(dp < 1e-12 && dr < 1e-12);
    }
}

#[test]
fn jacobian_matches_finite_differences() {
    let tcp = tool();
    for robot in [common::irb1200(), skewed_arm()] {
        let mut rng = common::rng(11);
        let h = 1e-6;
        for _ in 0..200 {
            let (q, _, _) = common::random_state(&robot, &mut rng);
            let j = geometric(&robot, &q, &tcp);
            for k in 0..robot.dof() {
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[k] += h;
                qm[k] -= h;
                let (tp, tm) = (tcp_pose(&robot, &qp, &tcp), tcp_pose(&robot, &qm, &tcp));
                let v = (tp.translation.vector - tm.translation.vector) / (2.0 * h);
                let w = rotation_vector(&(tp.rotation * tm.rotation.inverse())) / (2.0 * h);
                let col = j.column(k);
                for r in 0..3 {
                    assert!(
                        (col[r] - v[r]).abs() < 1e-7,
                        "joint {k} row {r}: {} vs {}",
                        col[r],
                        v[r]
                    );
                    assert!((col[r + 3] - w[r]).abs() < 1e-7, "joint {k} row {}", r + 3);
                }
            }
        }
    }
}

#[test]
fn bias_acceleration_is_jacobian_derivative_times_dq() {
    let tcp = tool();
    for robot in [common::irb1200(), skewed_arm()] {
        let mut rng = common::rng(12);
        let h = 1e-6;
        for _ in 0..200 {
            let (q, dq, _) = common::random_state(&robot, &mut rng);
            let shifted = |sign: f64| -> Vec<f64> {
                q.iter().zip(&dq).map(|(a, b)| a + sign * h * b).collect()
            };
            let jdot = (geometric(&robot, &shifted(1.0), &tcp)
                - geometric(&robot, &shifted(-1.0), &tcp))
                / (2.0 * h);
            let expected = jdot * nalgebra::DVector::from_column_slice(&dq);
            let got = bias_acceleration(&robot, &q, &dq, &tcp);
            for r in 0..6 {
                assert!(
                    (got[r] - expected[r]).abs() < 1e-6,
                    "row {r}: {} vs {}",
                    got[r],
                    expected[r]
                );
            }
        }
    }
}

#[test]
fn ik_round_trip_irb1200_7_70() {
    ik_round_trip(&common::irb1200(), 5000, 20);
}

#[test]
fn ik_round_trip_irb1200_5_90() {
    let mut limits = irb_limits();
    limits[1].1 = 2.269;
    ik_round_trip(
        &irb_like([0.3991, 0.448, 0.042, 0.451, 0.082], limits),
        2000,
        21,
    );
}

#[test]
fn ik_round_trip_general_opw_arm() {
    // Tilted and shifted base, shoulder offset from axis 1 (a1) and sideways (b), axis 3
    // opposite to axis 2, wrist with rotated frames, tool flange tilted.
    let joints = [
        UrdfJoint {
            xyz: [0.1, -0.2, 0.3],
            rpy: [0.2, -0.1, 0.4],
            axis: [0.0, 0.0, 1.0],
            limits: (-3.0, 3.0),
        },
        UrdfJoint {
            xyz: [0.07, 0.03, 0.1],
            rpy: [0.0; 3],
            axis: [0.0, 1.0, 0.0],
            limits: (-3.0, 3.0),
        },
        UrdfJoint {
            xyz: [0.02, 0.05, 0.4],
            rpy: [0.0; 3],
            axis: [0.0, -1.0, 0.0],
            limits: (-3.0, 3.0),
        },
        UrdfJoint {
            xyz: [0.0, 0.0, 0.06],
            rpy: [0.3, 0.0, 0.0],
            axis: [1.0, 0.0, 0.0],
            limits: (-6.0, 6.0),
        },
        UrdfJoint {
            xyz: [0.3, 0.0, 0.0],
            rpy: [0.0; 3],
            axis: [0.0, 0.0, -1.0],
            limits: (-3.0, 3.0),
        },
        UrdfJoint {
            xyz: [0.05, 0.0, 0.0],
            rpy: [0.0, 0.0, 0.0],
            axis: [1.0, 0.0, 0.0],
            limits: (-6.0, 6.0),
        },
    ];
    let robot = load_str(
        &chain_urdf(&joints, [0.3, 1.0, -0.5]),
        &LoadOptions::default(),
    )
    .unwrap();
    ik_round_trip(&robot, 2000, 22);
}

#[test]
fn non_opw_arm_is_rejected_by_the_closed_form() {
    let robot = skewed_arm();
    assert!(Opw::from_robot(&robot).is_none());
    match ik::solve_all(&robot, &flange_pose(&robot, &[0.1; 6])) {
        Err(Error::Model(m)) => assert!(m.contains("not of the OPW class"), "{m}"),
        other => panic!("expected a model error, got {other:?}"),
    }
}

#[test]
fn unreachable_pose_is_reported() {
    let robot = common::irb1200();
    let far = Isometry3::translation(2.0, 0.0, 0.8) * flange_pose(&robot, &[0.0; 6]).rotation;
    for result in [
        ik::solve_all(&robot, &far).map(|_| ()),
        ik::solve_nearest(&robot, &far, &Isometry3::identity(), &[0.0; 6]).map(|_| ()),
    ] {
        match result {
            Err(Error::Unreachable(m)) => assert!(m.contains("from axis 2"), "{m}"),
            other => panic!("expected Unreachable, got {other:?}"),
        }
    }
    let skewed = skewed_arm();
    let far = Isometry3::translation(2.0, 0.0, 0.8);
    assert!(matches!(
        ik::solve_nearest(&skewed, &far, &Isometry3::identity(), &[0.0; 6]),
        Err(Error::Unreachable(_))
    ));
}

#[test]
fn pose_outside_the_joint_limits_is_reported() {
    // Joint 5 may not pass 1 rad; a pose that needs |q5| = 1.5 on every branch.
    let mut limits = irb_limits();
    limits[4] = (-1.0, 1.0);
    let robot = irb_like(L, limits);
    let q = [0.3, 0.2, -0.3, 0.4, 1.5, 0.2];
    let target = flange_pose(&robot, &q);
    let sols = ik::solve_all(&robot, &target).unwrap();
    assert!(sols.iter().all(|s| s[4].abs() > 1.0), "{sols:?}");
    match ik::solve_nearest(&robot, &target, &Isometry3::identity(), &q) {
        Err(Error::JointLimit(m)) => assert!(m.contains("'joint_5'"), "{m}"),
        other => panic!("expected JointLimit, got {other:?}"),
    }
}

#[test]
fn nearest_uses_whole_turns_where_the_limits_allow() {
    let robot = common::irb1200();
    let q = [0.3, 0.2, -0.3, 4.0, 0.8, -5.0];
    let target = flange_pose(&robot, &q);
    let id = Isometry3::identity();
    let near = ik::solve_nearest(&robot, &target, &id, &q).unwrap();
    assert!(
        angle_gap(&near, &q) < 1e-9 && (near[3] - 4.0).abs() < 1e-9,
        "{near:?}"
    );
    assert!((near[5] + 5.0).abs() < 1e-9, "{near:?}");
    // From a seed near the wrapped angles, the wrapped representatives come back.
    let seed = [0.3, 0.2, -0.3, 4.0 - TAU, 0.8, -5.0 + TAU];
    let near = ik::solve_nearest(&robot, &target, &id, &seed).unwrap();
    assert!((near[3] - seed[3]).abs() < 1e-9 && (near[5] - seed[5]).abs() < 1e-9);
}

#[test]
fn wrist_singularity_takes_q4_from_the_seed() {
    let robot = common::irb1200();
    let q = [0.2, 0.3, -0.5, 0.7, 0.0, -0.4];
    let target = flange_pose(&robot, &q);
    for s in ik::solve_all(&robot, &target).unwrap() {
        let (dp, dr) = pose_err(&flange_pose(&robot, &s), &target);
        assert!(dp < 1e-9 && dr < 1e-9, "{s:?}");
    }
    let mut seed = q;
    seed[3] = 1.2;
    let near = ik::solve_nearest(&robot, &target, &Isometry3::identity(), &seed).unwrap();
    assert!((near[3] - 1.2).abs() < 1e-12, "{near:?}");
    assert!((near[3] + near[5] - (q[3] + q[5])).abs() < 1e-9, "{near:?}");
    let (dp, dr) = pose_err(&flange_pose(&robot, &near), &target);
    assert!(dp < 1e-9 && dr < 1e-9);
}

#[test]
fn shoulder_singularity_takes_q1_from_the_seed() {
    // Wrist centre on axis 1: q3 = 0 and the arm leaning back until L3, L4 point up.
    let robot = common::irb1200();
    let q2 = -(L[3].atan2(L[1] + L[2]));
    let q = [0.2, q2, 0.0, 0.7, 0.5, -0.4];
    let target = flange_pose(&robot, &q);
    for s in ik::solve_all(&robot, &target).unwrap() {
        let (dp, dr) = pose_err(&flange_pose(&robot, &s), &target);
        assert!(dp < 1e-9 && dr < 1e-9, "{s:?}");
    }
    let mut seed = q;
    seed[0] = -0.6;
    let near = ik::solve_nearest(&robot, &target, &Isometry3::identity(), &seed).unwrap();
    assert!((near[0] + 0.6).abs() < 1e-12, "{near:?}");
    let (dp, dr) = pose_err(&flange_pose(&robot, &near), &target);
    assert!(dp < 1e-9 && dr < 1e-9);
}

#[test]
fn wrist_singularity_moves_q4_when_q6_is_blocked() {
    let mut limits = irb_limits();
    limits[5] = (-1.0, 1.0);
    let robot = irb_like(L, limits);
    let q = [0.2, 0.3, -0.5, 0.5, 0.0, 0.2];
    let target = flange_pose(&robot, &q);
    let mut seed = q;
    seed[3] = 2.0; // would need q6 = -1.3
    let near = ik::solve_nearest(&robot, &target, &Isometry3::identity(), &seed).unwrap();
    assert!(
        (near[5] + 1.0).abs() < 1e-9 && (near[3] - 1.7).abs() < 1e-9,
        "{near:?}"
    );
    let (dp, dr) = pose_err(&flange_pose(&robot, &near), &target);
    assert!(dp < 1e-9 && dr < 1e-9);
}

#[test]
fn bad_inputs_are_rejected() {
    let robot = common::irb1200();
    let id = Isometry3::identity();
    let target = flange_pose(&robot, &[0.1; 6]);
    assert!(matches!(
        ik::solve_nearest(&robot, &target, &id, &[0.0; 5]),
        Err(Error::InvalidInput(_))
    ));
    assert!(matches!(
        ik::solve_nearest(&robot, &target, &id, &[f64::NAN; 6]),
        Err(Error::InvalidInput(_))
    ));
    let nan = Isometry3::translation(f64::NAN, 0.0, 0.0);
    assert!(matches!(
        ik::solve_all(&robot, &nan),
        Err(Error::InvalidInput(_))
    ));
    assert!(matches!(
        dls::solve(&robot, &nan, &id, &[0.0; 6], &DlsOptions::default()),
        Err(Error::InvalidInput(_))
    ));
}

/// DLS from a seed perturbed by up to `spread` rad converges to the target pose.
fn dls_converges(robot: &Robot, spread: f64, count: usize, seed: u64) {
    let tcp = tool();
    let opts = DlsOptions::default();
    let mut rng = common::rng(seed);
    for _ in 0..count {
        let q = random_q(robot, &mut rng);
        let target = tcp_pose(robot, &q, &tcp);
        let start: Vec<f64> = q
            .iter()
            .map(|v| v + rng.random_range(-spread..spread))
            .collect();
        let sol = dls::solve(robot, &target, &tcp, &start, &opts)
            .unwrap_or_else(|e| panic!("from {start:?} to {q:?}: {e}"));
        let (dp, dr) = pose_err(&tcp_pose(robot, &sol, &tcp), &target);
        assert!(dp < 1e-10 && dr < 1e-10, "{dp:e} m {dr:e} rad");
        for (v, j) in sol.iter().zip(robot.joints()) {
            assert!((j.limits.lower..=j.limits.upper).contains(v));
        }
    }
}

#[test]
fn dls_converges_on_irb1200() {
    dls_converges(&common::irb1200(), 0.2, 300, 30);
}

#[test]
fn dls_converges_on_a_non_opw_arm() {
    let robot = skewed_arm();
    dls_converges(&robot, 0.2, 300, 31);
    // solve_nearest falls back to DLS for it.
    let q = [0.4, -0.3, 0.6, 1.0, -0.8, 0.5];
    let tcp = tool();
    let target = tcp_pose(&robot, &q, &tcp);
    let seed: Vec<f64> = q.iter().map(|v| v + 0.1).collect();
    let sol = ik::solve_nearest(&robot, &target, &tcp, &seed).unwrap();
    assert!(angle_gap(&sol, &q) < 1e-8, "{sol:?}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Every closed-form solution reproduces the pose, and one of them is the original q.
    #[test]
    fn every_ik_solution_reproduces_the_pose(
        q1 in -2.967..2.967f64, q2 in -1.745..2.356f64, q3 in -PI..1.222f64,
        q4 in -PI..PI, q5 in -2.269..2.269f64, q6 in -PI..PI,
    ) {
        prop_assume!(q5.abs() > 1e-3);
        let robot = common::irb1200();
        let q = [q1, q2, q3, q4, q5, q6];
        let target = flange_pose(&robot, &q);
        let sols = ik::solve_all(&robot, &target).unwrap();
        prop_assert!(sols.iter().any(|s| angle_gap(s, &q) < 1e-8));
        for s in &sols {
            let (dp, dr) = pose_err(&flange_pose(&robot, s), &target);
            prop_assert!(dp < 1e-9 && dr < 1e-9);
        }
    }
}
