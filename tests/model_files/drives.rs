//! Drive files: the shipped ones, and the parser's defaults and errors.

use super::*;

fn drive(text: &str) -> Result<Drive> {
    Drive::from_toml_str(text, "test.drive.toml", &irb1200())
}

/// The shipped drive file with `from` replaced by `to` (must occur).
fn edited_drive(from: &str, to: &str) -> String {
    assert!(IRB1200_DRIVE.contains(from), "{from}");
    IRB1200_DRIVE.replacen(from, to, 1)
}

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
