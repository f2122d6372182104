//! The shipped IRB 1200 URDF (parsed with urdf_rs until the project's loader is available) and
//! the third-party robot fixtures (`tests/data/`).

use super::*;

fn pose(p: &urdf_rs::Pose) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(p.xyz[0], p.xyz[1], p.xyz[2]),
        UnitQuaternion::from_euler_angles(p.rpy[0], p.rpy[1], p.rpy[2]),
    )
}

fn inertial(l: &urdf_rs::Link) -> RigidInertia {
    let i = &l.inertial.inertia;
    let local = RigidInertia::new(
        l.inertial.mass.value,
        Vector3::zeros(),
        [i.ixx, i.iyy, i.izz, i.ixy, i.ixz, i.iyz],
    );
    local.transformed(&pose(&l.inertial.origin))
}

#[test]
fn irb1200_urdf_matches_ros_kinematics_and_datasheet_limits() {
    let urdf = urdf_rs::read_from_string(IRB1200_URDF).unwrap();
    assert_eq!(urdf.name, "abb_irb1200_7_70");
    let names: Vec<&str> = urdf.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "joint_1",
            "joint_2",
            "joint_3",
            "joint_4",
            "joint_5",
            "joint_6",
            "joint_6-tool0"
        ]
    );
    let links: Vec<&str> = urdf.links.iter().map(|l| l.name.as_str()).collect();
    for l in [
        "base_link",
        "link_1",
        "link_2",
        "link_3",
        "link_4",
        "link_5",
        "link_6",
        "tool0",
    ] {
        assert!(links.contains(&l), "{l}");
    }
    // (xyz, axis, lower deg, upper deg, speed deg/s), docs/design/irb1200-data.md 1.1 and 2.
    let expected = [
        (
            [0.0, 0.0, 0.3991],
            [0.0, 0.0, 1.0],
            -170.0_f64,
            170.0_f64,
            288.0_f64,
        ),
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], -100.0, 135.0, 240.0),
        ([0.0, 0.0, 0.350], [0.0, 1.0, 0.0], -200.0, 70.0, 300.0),
        ([0.0, 0.0, 0.042], [1.0, 0.0, 0.0], -270.0, 270.0, 400.0),
        ([0.351, 0.0, 0.0], [0.0, 1.0, 0.0], -130.0, 130.0, 405.0),
        ([0.082, 0.0, 0.0], [1.0, 0.0, 0.0], -360.0, 360.0, 600.0),
    ];
    let parents = [
        "base_link",
        "link_1",
        "link_2",
        "link_3",
        "link_4",
        "link_5",
    ];
    for (i, (xyz, axis, lo, hi, v)) in expected.iter().enumerate() {
        let j = &urdf.joints[i];
        assert_eq!(j.joint_type, urdf_rs::JointType::Revolute);
        assert_eq!(j.parent.link, parents[i]);
        assert_eq!(j.child.link, format!("link_{}", i + 1));
        assert_eq!(*j.origin.xyz, *xyz, "{}", j.name);
        assert_eq!(*j.origin.rpy, [0.0; 3], "{}", j.name);
        assert_eq!(*j.axis.xyz, *axis, "{}", j.name);
        assert!((j.limit.lower - lo.to_radians()).abs() < 1e-8, "{}", j.name);
        assert!((j.limit.upper - hi.to_radians()).abs() < 1e-8, "{}", j.name);
        assert!(
            (j.limit.velocity - v.to_radians()).abs() < 1e-8,
            "{}",
            j.name
        );
        assert!(j.limit.effort > 0.0, "{}", j.name);
        assert!(j.dynamics.is_some(), "{}", j.name);
    }
    let t = &urdf.joints[6];
    assert_eq!(t.joint_type, urdf_rs::JointType::Fixed);
    assert_eq!(
        (t.parent.link.as_str(), t.child.link.as_str()),
        ("link_6", "tool0")
    );
    // At home the tool z axis points along +x_base and tool x along -z_base.
    let r = pose(&t.origin).rotation;
    assert!((r * Vector3::z() - Vector3::x()).norm() < 1e-15);
    assert!((r * Vector3::x() + Vector3::z()).norm() < 1e-15);
}

#[test]
fn irb1200_urdf_mass_properties_and_geometry() {
    let urdf = urdf_rs::read_from_string(IRB1200_URDF).unwrap();
    let mut total = 0.0;
    for l in urdf.links.iter().filter(|l| l.name != "tool0") {
        let body = inertial(l);
        body.validate(&l.name).unwrap();
        total += body.mass;
        assert!(
            !l.visual.is_empty() && !l.collision.is_empty(),
            "{}",
            l.name
        );
        for v in &l.visual {
            assert!(
                !matches!(v.geometry, urdf_rs::Geometry::Mesh { .. }),
                "{}",
                l.name
            );
            let colour = v.material.as_ref().and_then(|m| m.color.as_ref());
            assert!(colour.is_some(), "{}: visual without colour", l.name);
        }
    }
    // docs/design/irb1200-data.md 3.2: total 52.13 kg.
    assert!((total - 52.129).abs() < 1e-9, "{total}");
    let l2 = urdf.links.iter().find(|l| l.name == "link_2").unwrap();
    assert_eq!(*l2.inertial.origin.xyz, [0.0004, 0.0007, 0.1842]);
    assert_eq!(l2.inertial.mass.value, 16.005);
}

#[test]
fn builtin_constants_are_the_files_in_models() {
    for (text, file) in [
        (IRB1200_URDF, "models/irb1200_7_70.urdf"),
        (IRB1200_DRIVE, "models/irb1200_7_70.drive.toml"),
        (IDEAL_DRIVE, "models/ideal.drive.toml"),
    ] {
        assert_eq!(text, std::fs::read_to_string(repo(file)).unwrap(), "{file}");
    }
}

// ------------------------------------------------------------------------------------------
// Third-party robot fixtures
// ------------------------------------------------------------------------------------------

fn read_fixture(name: &str) -> urdf_rs::Robot {
    urdf_rs::read_file(repo(&format!("tests/data/{name}"))).unwrap()
}

/// Every link with an inertial block has a physically valid one; returns the names of the
/// links with mass.
fn valid_inertials(r: &urdf_rs::Robot) -> Vec<String> {
    let mut with_mass = Vec::new();
    for l in &r.links {
        if l.inertial.mass.value > 0.0 {
            inertial(l).validate(&l.name).unwrap();
            with_mass.push(l.name.clone());
        }
    }
    with_mass
}

#[test]
fn ur5_fixture_is_a_valid_serial_urdf() {
    let r = read_fixture("ur5.urdf");
    assert_eq!(r.name, "ur5");
    let revolute: Vec<&str> = r
        .joints
        .iter()
        .filter(|j| j.joint_type == urdf_rs::JointType::Revolute)
        .map(|j| j.name.as_str())
        .collect();
    assert_eq!(
        revolute,
        [
            "shoulder_pan_joint",
            "shoulder_lift_joint",
            "elbow_joint",
            "wrist_1_joint",
            "wrist_2_joint",
            "wrist_3_joint"
        ]
    );
    let with_mass = valid_inertials(&r);
    for l in [
        "shoulder_link",
        "upper_arm_link",
        "forearm_link",
        "wrist_1_link",
        "wrist_2_link",
        "wrist_3_link",
    ] {
        assert!(with_mass.iter().any(|m| m == l), "{l}");
    }
    assert!(r.joints.iter().any(|j| j.child.link == "tool0"));
}

#[test]
fn panda_fixture_has_seven_revolute_joints_and_prismatic_fingers() {
    let r = read_fixture("panda.urdf");
    assert_eq!(r.name, "panda");
    let count = |t: urdf_rs::JointType| r.joints.iter().filter(|j| j.joint_type == t).count();
    assert_eq!(count(urdf_rs::JointType::Revolute), 7);
    assert_eq!(count(urdf_rs::JointType::Prismatic), 2);
    assert_eq!(count(urdf_rs::JointType::Fixed), 2);
    let finger2 = r
        .joints
        .iter()
        .find(|j| j.name == "panda_finger_joint2")
        .unwrap();
    assert_eq!(finger2.mimic.as_ref().unwrap().joint, "panda_finger_joint1");
    let with_mass = valid_inertials(&r);
    for i in 1..=7 {
        assert!(
            with_mass.contains(&format!("panda_link{i}")),
            "panda_link{i}"
        );
    }
    for l in ["panda_hand", "panda_leftfinger", "panda_rightfinger"] {
        assert!(with_mass.iter().any(|m| m == l), "{l}");
    }
    // Joint 4's range excludes q = 0.
    let j4 = r.joints.iter().find(|j| j.name == "panda_joint4").unwrap();
    assert!(j4.limit.upper < 0.0);
}

#[test]
fn fixtures_load_as_serial_robots() {
    let ur5 = load_file(&repo("tests/data/ur5.urdf"), &LoadOptions::default()).unwrap();
    assert_eq!(ur5.dof(), 6);
    assert_eq!(ur5.flange_name(), "tool0");
    let fingers = LoadOptions {
        lock: vec!["panda_finger_joint1".into(), "panda_finger_joint2".into()],
    };
    let panda = load_file(&repo("tests/data/panda.urdf"), &fingers).unwrap();
    assert_eq!(panda.dof(), 7);
    // Unlocked prismatic fingers are refused, naming a finger joint.
    let e = load_file(&repo("tests/data/panda.urdf"), &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("panda_finger_joint"), "{e}");
    // Drive files work for any robot: the ideal and URDF drives have one entry per joint.
    assert_eq!(Drive::ideal(&panda).joints().len(), 7);
    assert_eq!(Drive::from_urdf(&ur5).coulomb(), [0.0; 6]);
}
