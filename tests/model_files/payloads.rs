//! Payloads: the shipped files, the built-in names, the parser's errors, combining and
//! attaching them.

use super::*;

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
