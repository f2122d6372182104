//! The `powertwin` binary as a user runs it: outputs, JSON fields, and clear errors.

use crate::common;

use common::{run as powertwin, tmp};

#[test]
fn model_works_from_any_directory_and_prints_table_1() {
    let (code, out, err) = powertwin(&["model", "--mdh", "--json"]);
    assert_eq!(code, 0, "{err}");
    let rows: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 7);
    assert!((rows[0]["d"].as_f64().unwrap() - 0.3991).abs() < 1e-12);
    assert!((rows[3]["a"].as_f64().unwrap() - 0.042).abs() < 1e-12);
    assert!((rows[6]["theta"].as_f64().unwrap() - std::f64::consts::PI).abs() < 1e-12);
    let (code, out, _) = powertwin(&["model", "--json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["dof"], 6);
    assert_eq!(v["base_params"]["inertial"], 36);
    assert_eq!(v["base_params"]["with_friction"], 48);
    assert_eq!(v["base_params"]["with_friction_and_armature"], 52);
    assert!((v["links"][1]["standard"]["MX"].as_f64().unwrap() - 2.95).abs() < 0.01);
}

#[test]
fn base_params_json_has_the_documented_fields() {
    let (code, out, err) = powertwin(&["base-params", "--friction", "--armature", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["standard"], 78);
    assert_eq!(v["base"], 52);
    assert_eq!(v["independent"].as_array().unwrap().len(), 52);
    assert_eq!(v["relations"].as_array().unwrap().len(), 52);
    assert_eq!(v["independent"][0], "ZZ1R");
}

#[test]
fn dynamics_writes_gravity_torques_and_names_bad_rows() {
    let input = tmp("states.csv");
    let output = tmp("torques.csv");
    let header = "t,q1,q2,q3,q4,q5,q6,dq1,dq2,dq3,dq4,dq5,dq6,ddq1,ddq2,ddq3,ddq4,ddq5,ddq6";
    std::fs::write(&input, format!("{header}\n0{}\n", ",0".repeat(18))).unwrap();
    let args = [
        "dynamics",
        "--input",
        input.to_str().unwrap(),
        "--output",
        output.to_str().unwrap(),
    ];
    let (code, _, err) = powertwin(&args);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&output).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "tau1_Nm,tau2_Nm,tau3_Nm,tau4_Nm,tau5_Nm,tau6_Nm"
    );
    let tau: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    // Gravity load at q = 0 (docs/design/irb1200-data.md section 2: 13.4 and 13.3 N m on axes 2 and 3).
    assert!(
        (tau[1].abs() - 13.4).abs() < 0.05 && (tau[2].abs() - 13.3).abs() < 0.05,
        "{tau:?}"
    );
    std::fs::write(
        &input,
        format!(
            "{header}\n0{}\n1{}\n",
            ",0".repeat(18),
            ",0".repeat(17) + ",nan"
        ),
    )
    .unwrap();
    let (code, _, err) = powertwin(&args);
    assert_eq!(code, 1);
    assert!(err.contains("row 3") && err.contains("ddq6"), "{err}");
    std::fs::write(&input, "q1,q2\n0,0\n").unwrap();
    let (code, _, err) = powertwin(&args);
    assert_eq!(code, 1);
    assert!(err.contains("missing column 'q3_rad' or 'q3'"), "{err}");
}

#[test]
fn bad_robot_files_are_clear_errors_not_panics() {
    let bad = tmp("bad.urdf");
    std::fs::write(&bad, "<robot name=\"x\"><link name=\"a\"></robot>").unwrap();
    let (code, _, err) = powertwin(&["model", "--robot", bad.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(
        err.contains("malformed URDF") && !err.contains("panicked"),
        "{err}"
    );
    let (code, _, err) = powertwin(&["model", "--robot", "/nonexistent/robot.urdf"]);
    assert_eq!(code, 1);
    assert!(err.contains("/nonexistent/robot.urdf"), "{err}");
    let bad_drive = tmp("bad.drive.toml");
    std::fs::write(
        &bad_drive,
        "[[joint]]\nname = \"joint_1\"\nefficiency = 2\n",
    )
    .unwrap();
    let (code, _, err) = powertwin(&[
        "base-params",
        "--friction",
        "--drive",
        bad_drive.to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("bad.drive.toml") && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn error_chains_print_each_cause_once() {
    let missing = tmp("missing.csv");
    let out = tmp("never-written");
    let (code, _, err) = powertwin(&[
        "simulate",
        "--trajectory",
        missing.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    let cause = "No such file or directory";
    assert!(err.contains(cause), "{err}");
    assert_eq!(err.matches(cause).count(), 1, "{err}");
    assert!(err.contains(missing.to_str().unwrap()), "{err}");
}

#[test]
fn overloads_are_refused_and_failed_runs_flagged() {
    let out = tmp("overload-sweep");
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let sweep = |extra: &[&str]| {
        let mut args = vec![
            "sweep",
            "--speeds",
            "1",
            "--loads",
            "1000",
            "--substeps",
            "2",
        ];
        args.extend_from_slice(extra);
        powertwin(&args)
    };
    // 1000 kg on a 7 kg robot: refused before anything runs.
    let (code, _, err) = sweep(&["--out", &s(&out)]);
    assert_eq!(code, 1);
    assert!(
        err.contains("1001.32 kg") && err.contains("rated payload of 7 kg"),
        "{err}"
    );
    assert!(err.contains("--allow-overload") && !out.exists(), "{err}");
    // Allowed: it runs, and the cell is flagged in the table and in sweep.json.
    let (code, table, err) = sweep(&["--out", &s(&out), "--allow-overload"]);
    assert_eq!(code, 0, "{err}");
    assert!(table.contains("FLAGGED: torque saturated"), "{table}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    let cell = &json["cells"][0];
    assert_eq!(cell["flagged"], true);
    assert!(cell["max_tracking_error_rad"].as_f64().unwrap() > 0.01);
    assert!(!cell["torque_limit_hits"].as_array().unwrap().is_empty());
    // A drive rated for the load lets the sweep run, but the failed cell makes it exit 3
    // (results flagged) after writing its outputs.
    let drive = tmp("heavy.drive.toml");
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/irb1200_7_70.drive.toml"),
    )
    .unwrap();
    std::fs::write(
        &drive,
        text.replace("rated_payload_kg = 7.0", "rated_payload_kg = 2000.0"),
    )
    .unwrap();
    let flagged_out = tmp("overload-sweep-2");
    let (code, _, err) = sweep(&["--out", &s(&flagged_out), "--drive", &s(&drive)]);
    assert_eq!(code, 3, "a flagged sweep exits 3: {err}");
    assert!(
        err.contains("1 of 1 sweep cells are flagged") && err.contains("torque saturated"),
        "{err}"
    );
    assert!(!err.contains("error:"), "flagged is not an error: {err}");
    assert!(
        flagged_out.join("sweep.json").exists(),
        "outputs are written"
    );
    // simulate checks --payload the same way (before reading the trajectory), repeated or
    // joined with '+' as identify and predict take them.
    let never = s(&tmp("never"));
    for payloads in [
        &["--payload", "load_4kg", "--payload", "load_4kg"][..],
        &["--payload", "load_4kg+load_4kg"][..],
    ] {
        let mut args = vec!["simulate", "--trajectory", "unused.csv", "--out", &never];
        args.extend_from_slice(payloads);
        let (code, _, err) = powertwin(&args);
        assert_eq!(code, 1);
        assert!(
            err.contains("8 kg") && err.contains("rated payload of 7 kg"),
            "{err}"
        );
    }
}

#[test]
fn exit_codes_distinguish_usage_errors_and_flagged_results() {
    // 2: the command line is wrong (clap's usage error).
    let (code, _, err) = powertwin(&["sweep", "--no-such-option"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--no-such-option"), "{err}");
    let (code, _, _) = powertwin(&["no-such-command"]);
    assert_eq!(code, 2);
    // --help and --version are not errors.
    let (code, out, _) = powertwin(&["--help"]);
    assert_eq!(code, 0);
    assert!(out.contains("Usage"), "{out}");
    let (code, out, _) = powertwin(&["--version"]);
    assert_eq!(code, 0);
    assert!(out.contains(env!("CARGO_PKG_VERSION")), "{out}");
    // 1: a bad file.
    let bad = tmp("not-a-model.json");
    std::fs::write(&bad, "{ not json").unwrap();
    let (code, _, err) = powertwin(&[
        "predict",
        "--model",
        bad.to_str().unwrap(),
        "--data",
        "unused",
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.starts_with("error:") && err.contains("not valid JSON"),
        "{err}"
    );
    // 3 (a flagged sweep) is checked in overloads_are_refused_and_failed_runs_flagged.
}

#[test]
fn model_files_of_an_unknown_schema_version_are_refused() {
    let file = tmp("future-model.json");
    std::fs::write(
        &file,
        r#"{"method": "x", "model": {"schema_version": 99, "robot": "abb_irb1200_7_70"}}"#,
    )
    .unwrap();
    let (code, _, err) = powertwin(&[
        "predict",
        "--model",
        file.to_str().unwrap(),
        "--data",
        "unused",
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(file.to_str().unwrap()),
        "names the file: {err}"
    );
    assert!(
        err.contains("schema_version 99 is not supported") && err.contains("version 1"),
        "names the version: {err}"
    );
}

#[test]
fn builtin_payloads_warn_on_another_robot() {
    let ur5 = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ur5.urdf");
    let simulate = |robot: Option<&str>, payload: &str| {
        let mut args = vec!["simulate", "--payload", payload];
        if let Some(r) = robot {
            args.extend_from_slice(&["--robot", r]);
        }
        args.extend_from_slice(&["--trajectory", "unused.csv", "--out", "unused-simulate-out"]);
        powertwin(&args)
    };
    // The old name is an alias; on the UR5 the IRB 1200's tool is warned about.
    for name in ["liu2018_tool", "tool"] {
        let (code, _, err) = simulate(Some(ur5.to_str().unwrap()), name);
        assert_eq!(code, 1, "the trajectory is missing: {err}");
        assert!(
            err.contains(&format!("warning: built-in payload '{name}'"))
                && err.contains("IRB 1200")
                && err.contains("ur5"),
            "{err}"
        );
    }
    // On the IRB 1200 it is the robot's own: no warning.
    let (code, _, err) = simulate(None, "liu2018_load_1kg");
    assert_eq!(code, 1);
    assert!(!err.contains("warning"), "{err}");
}
