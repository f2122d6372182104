//! Loading robots from URDF: public robots, fixed-joint merging, and every bad-input case
//! with an error that names the link or joint.

use crate::common;

use nalgebra::{DMatrix, DVector};
use powertwin::Error;
use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
use powertwin::dynamics::regressor::regressor;
use powertwin::dynamics::rnea::rnea_checked;
use powertwin::dynamics::{DriveTerms, ParamLayout, Workspace};
use powertwin::model::urdf::{LoadOptions, load_file, load_str};

const LINK: &str = r#"<inertial><origin xyz="0.05 0 0.1"/><mass value="2"/><inertia ixx="0.02" iyy="0.02" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>"#;

/// A three-joint arm; `extra` is spliced in before `</robot>`, `link2` replaces link b's body.
fn arm(link2: &str, joint2_type: &str, extra: &str) -> String {
    format!(
        r#"<robot name="arm">
  <link name="base"/>
  <link name="a">{LINK}</link>
  <link name="b">{link2}</link>
  <link name="c">{LINK}</link>
  <joint name="j1" type="revolute"><origin xyz="0 0 0.3"/><parent link="base"/><child link="a"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="j2" type="{joint2_type}"><origin xyz="0 0.1 0.2" rpy="0.3 0 0"/><parent link="a"/><child link="b"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="2"/></joint>
  <joint name="j3" type="revolute"><origin xyz="0.4 0 0"/><parent link="b"/><child link="c"/><axis xyz="1 0 1"/><limit lower="-2" upper="2" effort="10" velocity="2"/></joint>
  {extra}
</robot>"#
    )
}

fn err(text: &str, lock: &[&str]) -> String {
    let opts = LoadOptions {
        lock: lock.iter().map(|s| s.to_string()).collect(),
    };
    match load_str(text, &opts) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

fn data(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

#[test]
fn generic_arm_loads_and_its_dynamics_are_consistent() {
    let robot = load_str(&arm(LINK, "revolute", ""), &LoadOptions::default()).unwrap();
    assert_eq!(robot.dof(), 3);
    check_regressor(&robot);
}

/// W theta == RNEA and W_base theta_base == W theta for any loaded robot.
fn check_regressor(robot: &powertwin::Robot) {
    let n = robot.dof();
    let layout = ParamLayout::new(robot, true, true);
    let drive = DriveTerms {
        rotor_inertia: vec![0.1; n],
        viscous: vec![1.0; n],
        coulomb: vec![2.0; n],
    };
    let theta_v = layout.theta(robot, &drive);
    let bp = BaseParams::compute(robot, layout, &SamplingOptions::default()).unwrap();
    let theta_b = DVector::from_vec(bp.base_values(&theta_v).unwrap());
    let theta = DVector::from_vec(theta_v);
    let mut ws = Workspace::new(robot);
    let mut w = DMatrix::zeros(n, layout.len());
    let mut rng = common::rng(5);
    for _ in 0..100 {
        let (q, dq, ddq) = common::random_state(robot, &mut rng);
        let tau = rnea_checked(robot, &mut ws, &q, &dq, &ddq, Some(&drive)).unwrap();
        regressor(robot, &mut ws, &layout, &q, &dq, &ddq, &mut w);
        let wt = &w * &theta;
        let wb = bp.base_regressor(&w) * &theta_b;
        for i in 0..n {
            assert!((wt[i] - tau[i]).abs() < 1e-9 * (1.0 + tau[i].abs()));
            assert!((wb[i] - tau[i]).abs() < 1e-8 * (1.0 + tau[i].abs()));
        }
    }
}

#[test]
fn public_robot_urdfs_load() {
    let ur5 = load_file(&data("ur5.urdf"), &LoadOptions::default()).unwrap();
    assert_eq!(ur5.dof(), 6);
    assert_eq!(ur5.flange_name(), "tool0");
    check_regressor(&ur5);
    let e = load_file(&data("panda.urdf"), &LoadOptions::default()).unwrap_err();
    assert!(
        e.to_string().contains("panda_finger_joint1") && e.to_string().contains("--lock"),
        "{e}"
    );
    let opts = LoadOptions {
        lock: vec!["panda_finger_joint1".into(), "panda_finger_joint2".into()],
    };
    let panda = load_file(&data("panda.urdf"), &opts).unwrap();
    assert_eq!(panda.dof(), 7);
    check_regressor(&panda);
    // Hand and fingers are merged into link 7: its mass is link 7's plus theirs.
    let total: f64 = panda.links().iter().map(|l| l.inertia.mass).sum();
    let urdf = urdf_rs::read_file(data("panda.urdf")).unwrap();
    let urdf_total: f64 = urdf
        .links
        .iter()
        .filter(|l| l.name != "panda_link0")
        .map(|l| l.inertial.mass.value)
        .sum();
    assert!(
        (total - urdf_total).abs() < 1e-12,
        "{total} vs {urdf_total}"
    );
}

#[test]
fn fixed_children_are_merged_with_the_right_mass_properties() {
    // A 1 kg point-like block fixed 0.5 m along x of link c (joint 3 axis is (1,0,1)/sqrt 2).
    let block = r#"<link name="block"><inertial><mass value="1"/><inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="fix" type="fixed"><origin xyz="0.5 0 0"/><parent link="c"/><child link="block"/></joint>"#;
    let plain = load_str(&arm(LINK, "revolute", ""), &LoadOptions::default()).unwrap();
    let with = load_str(&arm(LINK, "revolute", block), &LoadOptions::default()).unwrap();
    assert!((with.links()[2].inertia.mass - 3.0).abs() < 1e-15);
    // At rest the extra gravity torque on joint 1 (vertical axis) is zero; on joint 2 (axis
    // y_a rotated 0.3 rad about x) it is the moment of 9.81 N at the block position.
    let mut ws = Workspace::new(&plain);
    let z = [0.0; 3];
    let t0 = rnea_checked(&plain, &mut ws, &z, &z, &z, None).unwrap();
    let t1 = rnea_checked(&with, &mut ws, &z, &z, &z, None).unwrap();
    assert!((t1[0] - t0[0]).abs() < 1e-12);
    // Block at base position: a origin (0,0,0.3) -> b origin +(0,0.1,0.2) rotated frame ->
    // c origin 0.4 along x_b (= x) -> block 0.5 along x: x = 0.9. Joint 2 axis through
    // (0, 0.1, 0.5) along (0, cos 0.3, sin 0.3); moment of -9.81 z at (0.9, ., .) about it:
    let axis = nalgebra::Vector3::new(0.0, 0.3f64.cos(), 0.3f64.sin());
    let r = nalgebra::Vector3::new(0.9, 0.0, 0.0);
    let moment = r.cross(&nalgebra::Vector3::new(0.0, 0.0, -9.81)).dot(&axis);
    // RNEA gives the torque the motor must supply: minus the gravity moment.
    assert!(
        (t1[1] - t0[1] + moment).abs() < 1e-12,
        "{} vs {}",
        t1[1] - t0[1],
        -moment
    );
}

#[test]
fn continuous_joints_are_unlimited_revolute() {
    let robot = load_str(&arm(LINK, "continuous", ""), &LoadOptions::default()).unwrap();
    let l = robot.joints()[1].limits;
    assert!(l.lower == f64::NEG_INFINITY && l.upper == f64::INFINITY);
    assert!(robot.check_position_limits(&[0.0, 100.0, 0.0]).is_ok());
    let e = robot.check_position_limits(&[0.0, 0.0, 2.5]).unwrap_err();
    assert!(
        matches!(e, Error::JointLimit(_)) && e.to_string().contains("j3"),
        "{e}"
    );
}

#[test]
fn locked_joints_are_frozen_at_zero() {
    let robot = load_str(
        &arm(LINK, "revolute", ""),
        &LoadOptions {
            lock: vec!["j2".into()],
        },
    )
    .unwrap();
    assert_eq!(robot.dof(), 2);
    assert_eq!(robot.joints()[1].name, "j3");
    assert!(
        (robot.links()[0].inertia.mass - 4.0).abs() < 1e-15,
        "b merged into a"
    );
    assert!(err(&arm(LINK, "revolute", ""), &["nope"]).contains("unknown joint 'nope'"));
}

#[test]
fn bad_models_give_errors_naming_the_culprit() {
    let cases: Vec<(String, &[&str], &str)> = vec![
        (
            "<robot name=\"x\"><link name=\"a\"></robot>".into(),
            &[],
            "malformed URDF",
        ),
        (
            arm("", "revolute", ""),
            &[],
            "link 'b' (moved by joint 'j2') has no <inertial>",
        ),
        (
            arm(
                r#"<inertial><mass value="0"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>"#,
                "revolute",
                "",
            ),
            &[],
            "link 'b': mass is 0",
        ),
        (
            arm(
                r#"<inertial><mass value="-1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>"#,
                "revolute",
                "",
            ),
            &[],
            "link 'b': mass is -1",
        ),
        (
            arm(
                r#"<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="-0.1" ixy="0" ixz="0" iyz="0"/></inertial>"#,
                "revolute",
                "",
            ),
            &[],
            "link 'b': inertia tensor about the COM is not positive definite",
        ),
        (arm(LINK, "prismatic", ""), &[], "joint 'j2' is Prismatic"),
        (
            arm(LINK, "floating", ""),
            &[],
            "floating or planar bases are not supported",
        ),
        (
            arm(
                LINK,
                "revolute",
                &format!(
                    r#"<link name="d">{LINK}</link><joint name="j4" type="revolute"><parent link="b"/><child link="d"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1"/></joint>"#
                ),
            ),
            &[],
            "the chain branches: joints 'j3' and 'j4'",
        ),
        (
            arm(LINK, "revolute", "<link name=\"lonely\"/>"),
            &[],
            "2 root links (base, lonely)",
        ),
        (
            arm(LINK, "revolute", "").replace(
                r#"<limit lower="-2" upper="2" effort="10" velocity="2"/></joint>
  <joint name="j3""#,
                r#"</joint>
  <joint name="j3""#,
            ),
            &[],
            "revolute joint 'j2' has no <limit lower upper>",
        ),
        (
            arm(LINK, "revolute", "").replace("axis xyz=\"1 0 1\"", "axis xyz=\"0 0 0\""),
            &[],
            "joint 'j3' has a zero or invalid <axis>",
        ),
        (
            arm(LINK, "revolute", "").replace("<child link=\"c\"/>", "<child link=\"zz\"/>"),
            &[],
            "joint 'j3' refers to unknown link 'zz'",
        ),
        (
            "<robot name=\"x\"><link name=\"a\"/></robot>".into(),
            &[],
            "no revolute or continuous joint",
        ),
    ];
    for (text, lock, expect) in cases {
        let msg = err(&text, lock);
        assert!(msg.contains(expect), "expected '{expect}' in '{msg}'");
    }
}
