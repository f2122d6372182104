//! `model.json`: the schema version, gear friction and the Stribeck law, written and checked.

use super::*;

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
