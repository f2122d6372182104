//! The shipped model files (`models/`), the drive and payload parsers, and the third-party
//! robot fixtures (`tests/data/`).

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use powertwin::model::builtin::{self, IDEAL_DRIVE, IRB1200_DRIVE, IRB1200_URDF};
use powertwin::model::drive::Drive;
use powertwin::model::payload::{Payload, attach};
use powertwin::model::urdf::{LoadOptions, load_file, load_str};
use powertwin::model::{RigidInertia, Robot};
use powertwin::{Error, Result};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

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

/// The IRB 1200 from the embedded URDF.
fn irb1200() -> Robot {
    load_str(IRB1200_URDF, &LoadOptions::default()).expect("IRB 1200 URDF loads")
}

fn drive(text: &str) -> Result<Drive> {
    Drive::from_toml_str(text, "test.drive.toml", &irb1200())
}

fn toml_message(e: Error) -> String {
    match e {
        Error::Toml { file, message } => format!("{file}: {message}"),
        other => panic!("expected a TOML error, got {other:?}"),
    }
}

/// The shipped drive file with `from` replaced by `to` (must occur).
fn edited_drive(from: &str, to: &str) -> String {
    assert!(IRB1200_DRIVE.contains(from), "{from}");
    IRB1200_DRIVE.replacen(from, to, 1)
}

// ------------------------------------------------------------------------------------------
// URDF (parsed with urdf_rs until the project's loader is available)
// ------------------------------------------------------------------------------------------

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
// Drive files
// ------------------------------------------------------------------------------------------

#[test]
fn irb1200_drive_file_parses_with_the_estimates() {
    let robot = irb1200();
    let d = Drive::from_file(&repo("models/irb1200_7_70.drive.toml"), &robot).unwrap();
    assert_eq!(d.joints().len(), 6);
    assert_eq!(d.rotor_inertia(), [0.36, 0.36, 0.10, 0.031, 0.047, 0.011]);
    assert_eq!(d.efficiency(), [0.87; 6]);
    assert_eq!(d.coulomb(), [10.0, 12.0, 8.0, 3.0, 3.0, 0.6]);
    assert_eq!(d.viscous(), [8.0, 7.0, 3.0, 1.5, 1.5, 0.7]);
    // The drive file repeats the URDF's <dynamics> values.
    let u = Drive::from_urdf(&robot);
    assert_eq!(u.coulomb(), d.coulomb());
    assert_eq!(u.viscous(), d.viscous());
    for j in d.joints() {
        assert!(j.standby_power > 0.0 && j.standby_power <= 5.0);
        assert!(j.copper_loss > 0.0);
    }
}

#[test]
fn efficiency_at_the_stated_rated_points_is_in_the_papers_range() {
    // (rated link torque N m, rated link speed rad/s): the table in the drive file's header.
    let rated = [
        (60.0, 2.5),
        (120.0, 2.0),
        (50.0, 2.5),
        (15.0, 3.5),
        (15.0, 3.5),
        (6.0, 5.0),
    ];
    let d = drive(IRB1200_DRIVE).unwrap();
    for (i, (j, (tau, w))) in d.joints().iter().zip(rated).enumerate() {
        let p_mech: f64 = tau * w;
        let eff = p_mech / (p_mech + j.copper_loss * tau * tau + j.standby_power);
        assert!((0.83..=0.92).contains(&eff), "joint {}: {eff}", i + 1);
        assert!(
            (eff - 0.88).abs() < 0.005,
            "joint {}: {eff} (header table says 0.880-0.883)",
            i + 1
        );
    }
}

#[test]
fn ideal_drive_file_equals_ideal_drive() {
    let robot = irb1200();
    let d = Drive::from_toml_str(IDEAL_DRIVE, "ideal", &robot).unwrap();
    assert_eq!(d, Drive::ideal(&robot));
    assert_eq!(d.rotor_inertia(), [0.0; 6]);
    assert_eq!(d.efficiency(), [1.0; 6]);
    assert!(
        d.joints()
            .iter()
            .all(|j| j.copper_loss == 0.0 && j.standby_power == 0.0)
    );
}

#[test]
fn from_urdf_uses_urdf_friction_and_ideal_motors() {
    let robot = irb1200();
    let d = Drive::from_urdf(&robot);
    for (j, jd) in robot.joints().iter().zip(d.joints()) {
        assert_eq!(jd.friction, j.friction);
        assert_eq!(
            (
                jd.rotor_inertia,
                jd.efficiency,
                jd.copper_loss,
                jd.standby_power
            ),
            (0.0, 1.0, 0.0, 0.0)
        );
    }
    assert_eq!(d.coulomb()[1], 12.0);
}

#[test]
fn omitted_friction_defaults_to_the_urdf_and_integers_are_accepted() {
    let text = edited_drive("coulomb_Nm = 12.0                # EST\n", "")
        .replacen("viscous_Nms_per_rad = 3.0        # EST\n", "", 1)
        .replacen("standby_W = 1.5", "standby_W = 2", 1);
    let d = drive(&text).unwrap();
    assert_eq!(d.coulomb()[1], 12.0); // from the URDF
    assert_eq!(d.viscous()[2], 3.0); // from the URDF
    assert_eq!(d.joints()[5].standby_power, 2.0);
    // An explicit override wins over the URDF.
    let d = drive(&edited_drive("coulomb_Nm = 12.0", "coulomb_Nm = 5.5")).unwrap();
    assert_eq!(d.coulomb()[1], 5.5);
}

#[test]
fn drive_joint_order_follows_the_robot() {
    // Same file with the joint tables reversed.
    let mut tables: Vec<&str> = IRB1200_DRIVE.split("[[joint]]").collect();
    let head = tables.remove(0);
    tables.reverse();
    let text = format!("{head}[[joint]]{}", tables.join("[[joint]]"));
    assert_eq!(drive(&text).unwrap(), drive(IRB1200_DRIVE).unwrap());
}

#[test]
fn drive_unknown_key_is_an_error_with_position() {
    let text = edited_drive("standby_W = 5.0", "standby_W = 5.0\nstandby_watts = 5.0");
    let msg = toml_message(drive(&text).unwrap_err());
    assert!(msg.starts_with("test.drive.toml: "), "{msg}");
    assert!(msg.contains("standby_watts"), "{msg}");
    assert!(msg.contains("line"), "{msg}");
    let msg = toml_message(drive(&format!("robots = \"x\"\n{IRB1200_DRIVE}")).unwrap_err());
    assert!(msg.contains("robots"), "{msg}");
}

#[test]
fn drive_missing_key_and_bad_syntax_are_errors() {
    let text = edited_drive("efficiency = 0.87                # EST\n", "");
    let msg = toml_message(drive(&text).unwrap_err());
    assert!(msg.contains("efficiency"), "{msg}");
    let msg = toml_message(drive("[[joint]\nname = 1").unwrap_err());
    assert!(msg.contains("line 1"), "{msg}");
    let msg = toml_message(drive("robot = \"abb_irb1200_7_70\"\n").unwrap_err());
    assert!(msg.contains("joint"), "{msg}");
}

#[test]
fn drive_joint_set_errors_name_the_joints() {
    // Missing joint_6.
    let cut = IRB1200_DRIVE.rfind("[[joint]]").unwrap();
    let msg = toml_message(drive(&IRB1200_DRIVE[..cut]).unwrap_err());
    assert!(msg.contains("missing joint(s): 'joint_6'"), "{msg}");
    // Duplicate joint_1 (in place of joint_2).
    let msg =
        toml_message(drive(&edited_drive("name = \"joint_2\"", "name = \"joint_1\"")).unwrap_err());
    assert!(msg.contains("more than once: 'joint_1'"), "{msg}");
    assert!(msg.contains("missing joint(s): 'joint_2'"), "{msg}");
    // Unknown name.
    let msg =
        toml_message(drive(&edited_drive("name = \"joint_3\"", "name = \"axis_3\"")).unwrap_err());
    assert!(msg.contains("unknown joint(s) 'axis_3'"), "{msg}");
    assert!(msg.contains("joint_1, joint_2"), "{msg}");
    assert!(msg.contains("'joint_3'"), "{msg}");
}

#[test]
fn drive_values_out_of_range_are_errors() {
    let cases = [
        ("efficiency = 0.87", "efficiency = 0.0", "efficiency"),
        ("efficiency = 0.87", "efficiency = 1.2", "efficiency"),
        ("efficiency = 0.87", "efficiency = nan", "efficiency"),
        ("standby_W = 4.0", "standby_W = -1.0", "standby_W"),
        (
            "rotor_inertia_kgm2 = 0.36",
            "rotor_inertia_kgm2 = inf",
            "rotor_inertia_kgm2",
        ),
        (
            "copper_loss_W_per_Nm2 = 0.0045",
            "copper_loss_W_per_Nm2 = -0.1",
            "copper_loss_W_per_Nm2",
        ),
        ("coulomb_Nm = 10.0", "coulomb_Nm = -10.0", "coulomb_Nm"),
        (
            "viscous_Nms_per_rad = 8.0",
            "viscous_Nms_per_rad = -8.0",
            "viscous_Nms_per_rad",
        ),
    ];
    for (from, to, key) in cases {
        let msg = toml_message(drive(&edited_drive(from, to)).unwrap_err());
        assert!(
            msg.contains("joint 'joint_1'") && msg.contains(key),
            "{to}: {msg}"
        );
    }
}

#[test]
fn drive_for_another_robot_is_an_error() {
    let text = edited_drive("robot = \"abb_irb1200_7_70\"", "robot = \"ur5\"");
    let msg = toml_message(drive(&text).unwrap_err());
    assert!(
        msg.contains("'ur5'") && msg.contains("'abb_irb1200_7_70'"),
        "{msg}"
    );
    // The robot key is optional.
    let text = edited_drive("robot = \"abb_irb1200_7_70\"\n", "");
    assert!(drive(&text).is_ok());
}

#[test]
fn missing_files_are_io_errors() {
    let robot = irb1200();
    let path = repo("models/no_such.drive.toml");
    assert!(matches!(
        Drive::from_file(&path, &robot),
        Err(Error::Io { .. })
    ));
    assert!(matches!(Payload::from_file(&path), Err(Error::Io { .. })));
}

// ------------------------------------------------------------------------------------------
// Payloads
// ------------------------------------------------------------------------------------------

#[test]
fn tool_payload_has_the_proposed_parameters() {
    let tool = Payload::from_file(&repo("models/tool_1p32kg.payload.toml")).unwrap();
    assert_eq!(tool.name, "tool 1.32 kg");
    assert_eq!(tool.inertia.mass, 1.32);
    assert_eq!(tool.inertia.com, Vector3::new(0.0, 0.0, 0.060));
    assert_eq!(tool.tcp, Some(Vector3::new(0.0, 0.0, 0.120)));
    // Solid cylinder r = 0.04 m, h = 0.12 m (docs/design/irb1200-data.md 5.4).
    let (m, r, h): (f64, f64, f64) = (1.32, 0.04, 0.12);
    let i = tool.inertia.inertia_com;
    assert!((i[(0, 0)] - m * (3.0 * r * r + h * h) / 12.0).abs() < 1e-12);
    assert!((i[(1, 1)] - i[(0, 0)]).abs() < 1e-15);
    assert!((i[(2, 2)] - m * r * r / 2.0).abs() < 1e-12);
    // Standard parameters about the flange origin: XX = Ixx + m c^2, MZ = m c.
    let p = tool.inertia.standard_params();
    assert!((p[0] - (2.112e-3 + 1.32 * 0.06 * 0.06)).abs() < 1e-12);
    assert!((p[2] - 1.056e-3).abs() < 1e-12);
    assert!((p[8] - 1.32 * 0.06).abs() < 1e-12);
    assert_eq!(p[9], 1.32);
}

#[test]
fn builtin_payloads_load_by_name() {
    for (name, alias, mass, file) in [
        ("liu2018_tool", "tool", 1.32, "tool_1p32kg"),
        ("liu2018_load_1kg", "load_1kg", 1.0, "load_1kg"),
        ("liu2018_load_2kg", "load_2kg", 2.0, "load_2kg"),
        ("liu2018_load_4kg", "load_4kg", 4.0, "load_4kg"),
    ] {
        let p = builtin::payload(name).unwrap();
        assert_eq!(p.inertia.mass, mass, "{name}");
        let on_disk = Payload::from_file(&repo(&format!("models/{file}.payload.toml"))).unwrap();
        assert_eq!(p, on_disk, "{name}");
        // The old name is an alias of the same payload.
        assert_eq!(builtin::payload(alias).unwrap(), p, "{alias}");
        assert!(builtin::is_payload_name(alias));
        if name != "liu2018_tool" {
            // Steel cube (7850 kg/m^3) with its COM at the tool's TCP.
            assert_eq!(p.inertia.com, Vector3::new(0.0, 0.0, 0.120));
            assert_eq!(p.tcp, None);
            let a = (mass / 7850.0_f64).cbrt();
            let i = mass * a * a / 6.0;
            assert!(
                (p.inertia.inertia_com[(0, 0)] / i - 1.0).abs() < 2e-3,
                "{name}"
            );
        }
    }
    assert_eq!(
        builtin::PAYLOAD_NAMES,
        [
            "liu2018_tool",
            "liu2018_load_1kg",
            "liu2018_load_2kg",
            "liu2018_load_4kg"
        ]
    );
    let e = builtin::payload("load_3kg").unwrap_err();
    assert!(matches!(e, Error::InvalidInput(_)));
    let msg = e.to_string();
    assert!(
        msg.contains("load_3kg")
            && msg.contains("liu2018_tool, liu2018_load_1kg, liu2018_load_2kg, liu2018_load_4kg")
            && msg.contains("tool, load_1kg, load_2kg, load_4kg"),
        "{msg}"
    );
    assert!(!builtin::is_payload_name("load_3kg"));
    // They are the IRB 1200's: a warning on another robot, none on the IRB 1200 or for files.
    assert!(builtin::is_foreign_payload("tool", "ur5"));
    assert!(!builtin::is_foreign_payload(
        "liu2018_tool",
        builtin::IRB1200_NAME
    ));
    assert!(!builtin::is_foreign_payload("my_tool.payload.toml", "ur5"));
    let w = builtin::foreign_payload_warning("liu2018_load_2kg", "ur5").unwrap();
    assert!(w.contains("liu2018_load_2kg") && w.contains("ur5"), "{w}");
    assert_eq!(
        builtin::foreign_payload_warning("liu2018_tool", builtin::IRB1200_NAME),
        None
    );
}

#[test]
fn model_schema_version_is_written_and_checked() {
    use powertwin::dynamics::ParamLayout;
    use powertwin::identification::model::{PowerModel, SCHEMA_VERSION, check_schema_version};
    let robot = irb1200();
    let model = PowerModel::new(&robot, ParamLayout::new(&robot, true, false), false).unwrap();
    assert_eq!(SCHEMA_VERSION, 1);
    let mut v = serde_json::to_value(&model).unwrap();
    assert_eq!(v["schema_version"], 1, "written on save");
    check_schema_version(&v).unwrap();
    // A file without the field is version 1 and loads as before.
    v.as_object_mut().unwrap().remove("schema_version");
    check_schema_version(&v).unwrap();
    let read: PowerModel = serde_json::from_value(v.clone()).unwrap();
    assert_eq!(read, model);
    read.validate(&robot).unwrap();
    // An unknown version is refused before the rest is read, naming the version.
    v["schema_version"] = serde_json::json!(2);
    let e = check_schema_version(&v).unwrap_err();
    assert!(matches!(e, Error::InvalidInput(_)));
    assert!(e.to_string().contains("schema_version 2"), "{e}");
    let mut future = model.clone();
    future.schema_version = 2;
    let e = future.validate(&robot).unwrap_err();
    assert!(e.to_string().contains("schema_version 2"), "{e}");
}

/// A model with gear friction reads back, with the covariance of `[theta, copper, gear, P0]`
/// and its model without gear friction beside as its alternative (read also from an older
/// file's `without_gear`); the wrong sizes and an alternative that does not belong are
/// refused, naming the field.
#[test]
fn a_model_with_gear_friction_is_written_and_checked() {
    use powertwin::dynamics::ParamLayout;
    use powertwin::identification::model::PowerModel;
    let robot = irb1200();
    let n = robot.dof();
    let pmsm = PowerModel::new(&robot, ParamLayout::new(&robot, true, true), false).unwrap();
    let mut gear = pmsm.clone();
    gear.gear_friction = vec![0.02; n];
    gear.alternative = Some(Box::new(pmsm.clone()));
    let np = gear.params();
    assert_eq!(np, pmsm.params() + n);
    gear.covariance = vec![0.0; np * np];
    let v = serde_json::to_value(&gear).unwrap();
    assert!(v["alternative"].is_object() && v["gear_friction"].is_array());
    assert!(
        serde_json::to_value(&pmsm)
            .unwrap()
            .get("gear_friction")
            .is_none()
    );
    let read: PowerModel = serde_json::from_value(v.clone()).unwrap();
    assert_eq!(read, gear);
    read.validate(&robot).unwrap();
    // A file written before the alternative had its name.
    let mut older = v;
    let alt = older
        .as_object_mut()
        .unwrap()
        .remove("alternative")
        .unwrap();
    older["without_gear"] = alt;
    let read: PowerModel = serde_json::from_value(older).unwrap();
    assert_eq!(read, gear);
    let refused = |m: PowerModel, what: &str| {
        let e = m.validate(&robot).unwrap_err().to_string();
        assert!(e.contains(what), "{e}");
    };
    refused(
        PowerModel {
            gear_friction: vec![0.02; n - 1],
            ..gear.clone()
        },
        "gear_friction has 5 entries",
    );
    refused(
        PowerModel {
            covariance: vec![0.0; pmsm.params().pow(2)],
            ..gear.clone()
        },
        "covariance has",
    );
    // Both with gear friction, both without, or an alternative of the alternative.
    refused(
        PowerModel {
            alternative: Some(Box::new(gear.clone())),
            ..gear.clone()
        },
        "alternative",
    );
    refused(
        PowerModel {
            alternative: Some(Box::new(pmsm.clone())),
            ..pmsm.clone()
        },
        "alternative",
    );
    refused(
        PowerModel {
            alternative: Some(Box::new(PowerModel {
                alternative: Some(Box::new(gear.clone())),
                ..pmsm.clone()
            })),
            ..gear.clone()
        },
        "alternative",
    );
}

/// A model carries its drive file's Stribeck law per joint: written and read back, left out
/// of a file without one, and refused with the wrong length or values, naming the field.
#[test]
fn a_model_s_stribeck_law_is_written_and_checked() {
    use powertwin::dynamics::ParamLayout;
    use powertwin::identification::model::{PowerModel, Stribeck};
    let robot = irb1200();
    let n = robot.dof();
    let plain = PowerModel::new(&robot, ParamLayout::new(&robot, true, true), false).unwrap();
    assert!(
        serde_json::to_value(&plain)
            .unwrap()
            .get("stribeck")
            .is_none()
    );
    let law = Stribeck {
        rise: 0.25,
        speed: 0.05,
    };
    let mut with = plain.clone();
    with.stribeck = vec![Some(law); n];
    with.stribeck[5] = None;
    let v = serde_json::to_value(&with).unwrap();
    assert_eq!(v["stribeck"][0]["speed_rad_s"], 0.05);
    assert!(v["stribeck"][5].is_null());
    let read: PowerModel = serde_json::from_value(v).unwrap();
    assert_eq!(read, with);
    read.validate(&robot).unwrap();
    // The drive file's joint 2 (static 15 N m over Coulomb 12 N m at 0.05 rad/s).
    let drive = Drive::from_file(&repo("models/irb1200_7_70.drive.toml"), &robot).unwrap();
    let j2 = Stribeck::of_drive(&drive.joints()[1]).expect("the drive file's law");
    assert!((j2.rise - 0.25).abs() < 1e-12 && j2.speed == 0.05, "{j2:?}");
    for (stribeck, what) in [
        (vec![Some(law); n - 1], "stribeck has 5 entries"),
        (
            vec![Some(Stribeck { rise: -0.1, ..law }); n],
            "stribeck of joint 1",
        ),
        (
            vec![Some(Stribeck { speed: 0.0, ..law }); n],
            "stribeck of joint 1",
        ),
    ] {
        let e = PowerModel {
            stribeck,
            ..plain.clone()
        }
        .validate(&robot)
        .unwrap_err()
        .to_string();
        assert!(e.contains(what), "{e}");
    }
}

const GOOD_PAYLOAD: &str = r#"
name = "p"
frame = "tool0"
mass_kg = 2.0
com_m = [0.0, 0.0, 0.1]
inertia_kgm2 = [1e-3, 1e-3, 1e-3, 0.0, 0.0, 0.0]
"#;

fn payload_error(text: &str) -> String {
    toml_message(Payload::from_toml_str(text, "p.toml").unwrap_err())
}

#[test]
fn payload_errors_name_the_problem() {
    let p = Payload::from_toml_str(GOOD_PAYLOAD, "p.toml").unwrap();
    assert_eq!(p.tcp, None);
    let msg = payload_error(&GOOD_PAYLOAD.replace("frame = \"tool0\"", "frame = \"link_6\""));
    assert!(msg.contains("link_6") && msg.contains("tool0"), "{msg}");
    let msg = payload_error(&GOOD_PAYLOAD.replace("mass_kg = 2.0", "mass_kg = 0.0"));
    assert!(msg.starts_with("p.toml: ") && msg.contains("mass"), "{msg}");
    let msg = payload_error(&GOOD_PAYLOAD.replace("mass_kg = 2.0", "mass_kg = -2.0"));
    assert!(msg.contains("mass"), "{msg}");
    let msg = payload_error(&GOOD_PAYLOAD.replace("[1e-3, 1e-3, 1e-3,", "[1e-3, 1e-3, 3e-3,"));
    assert!(msg.contains("triangle"), "{msg}");
    let msg = payload_error(&GOOD_PAYLOAD.replace("mass_kg", "mass"));
    assert!(msg.contains("mass") && msg.contains("line"), "{msg}");
    let msg = payload_error(&format!("{GOOD_PAYLOAD}colour = \"red\"\n"));
    assert!(msg.contains("colour"), "{msg}");
    let msg = payload_error(&GOOD_PAYLOAD.replace("[0.0, 0.0, 0.1]", "[0.0, 0.1]"));
    assert!(msg.contains("com_m") || msg.contains("line"), "{msg}");
    let msg = payload_error(&format!("{GOOD_PAYLOAD}tcp_m = [0.0, nan, 0.0]\n"));
    assert!(msg.contains("tcp_m"), "{msg}");
}

#[test]
fn combined_payload_is_the_rigid_union() {
    let tool = builtin::payload("tool").unwrap();
    let load = builtin::payload("load_4kg").unwrap();
    let both = tool.combined(&load);
    assert_eq!(both.name, "tool 1.32 kg + load 4 kg");
    assert!((both.inertia.mass - 5.32).abs() < 1e-12);
    let cz = (1.32 * 0.06 + 4.0 * 0.12) / 5.32;
    assert!((both.inertia.com - Vector3::new(0.0, 0.0, cz)).norm() < 1e-12);
    let sum = tool.inertia.standard_params();
    let l = load.inertia.standard_params();
    for (k, (a, b)) in both
        .inertia
        .standard_params()
        .iter()
        .zip(sum.iter().zip(l))
        .enumerate()
    {
        assert!((a - (b.0 + b.1)).abs() < 1e-12, "parameter {k}");
    }
    assert_eq!(both.tcp, tool.tcp);
    assert_eq!(load.combined(&tool).tcp, tool.tcp);
}

/// Checks `attach` on any robot: the last link gains the payload, expressed through the flange.
fn check_attach(robot: &Robot, payload: &Payload) {
    let in_last = payload.in_last_link_frame(robot);
    let com = (robot.flange() * Point3::from(payload.inertia.com)).coords;
    assert!((in_last.com - com).norm() < 1e-14);
    assert!((in_last.mass - payload.inertia.mass).abs() < 1e-15);
    let n = robot.dof();
    let loaded = attach(robot, payload).unwrap();
    let before = robot.links()[n - 1].inertia;
    let after = loaded.links()[n - 1].inertia;
    assert!((after.mass - (before.mass + payload.inertia.mass)).abs() < 1e-12);
    let c = (before.com * before.mass + com * payload.inertia.mass) / after.mass;
    assert!((after.com - c).norm() < 1e-12);
    assert_eq!(loaded.links()[..n - 1], robot.links()[..n - 1]);
    assert_eq!(loaded.joints(), robot.joints());
}

#[test]
fn attach_adds_the_payload_to_the_last_link() {
    let robot = irb1200();
    let tool = builtin::payload("tool").unwrap();
    // The flange normal (tool z) is the axis of joint 6 (z of the last link frame), so the tool
    // COM lies 0.06 m beyond the flange on that axis and the tool's axial moment Izz stays Izz.
    let in_last = tool.in_last_link_frame(&robot);
    let flange = robot.flange();
    assert!((flange.rotation * Vector3::z() - Vector3::z()).norm() < 1e-12);
    let offset = in_last.com - flange.translation.vector;
    assert!((offset - Vector3::new(0.0, 0.0, 0.06)).norm() < 1e-12);
    assert!((in_last.inertia_com[(2, 2)] - 1.056e-3).abs() < 1e-12);
    check_attach(&robot, &tool);
    check_attach(
        &robot,
        &tool.combined(&builtin::payload("load_4kg").unwrap()),
    );
    // UR5: tool0 is offset from the last link frame's origin.
    let ur5 = load_file(&repo("tests/data/ur5.urdf"), &LoadOptions::default()).unwrap();
    assert!(ur5.flange().translation.vector.norm() > 0.05);
    check_attach(&ur5, &tool);
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
