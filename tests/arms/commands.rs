//! The CLI on the UR5 and the Panda: every command takes `--robot`, `--drive` (and `--lock`),
//! and `validate --family` identifies a family of UR5s.

use super::*;

/// The CLI commands take `--robot`, `--drive` and `--lock` for another arm.
fn cli(arm: &Arm, tag: &str) {
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (urdf, drive, scenario) = (repo(arm.urdf), repo(arm.drive), repo(arm.scenario));
    let lock = arm.lock.join(",");
    let mut robot = vec!["--robot".to_string(), s(&urdf)];
    if !lock.is_empty() {
        robot.extend(["--lock".to_string(), lock]);
    }
    let with_drive = |mut v: Vec<String>| {
        v.extend(["--drive".to_string(), s(&drive)]);
        v
    };
    let call = |cmd: &str, extra: &[String]| {
        let mut args: Vec<&str> = vec![cmd];
        args.extend(extra.iter().map(String::as_str));
        let (code, out, err) = powertwin(&args);
        assert_eq!(code, 0, "{tag} {cmd}: {err}");
        out
    };
    let (model, sw) = (tmp(&format!("{tag}.json")), tmp(&format!("{tag}_sweep")));
    // Three excitations (optimiser seeds 1-3), each run on the twin.
    let mut datasets = Vec::new();
    for seed in 1..=EXCITATIONS {
        let (traj, data) = (
            tmp(&format!("{tag}_{seed}.csv")),
            tmp(&format!("{tag}_{seed}_data")),
        );
        let mut a = robot.clone();
        a.extend(
            [
                "--periods",
                "4",
                "--starts",
                "1",
                "--evals",
                "300",
                "--json",
            ]
            .map(String::from),
        );
        a.extend(["--seed".into(), seed.to_string(), "--out".into(), s(&traj)]);
        let report: serde_json::Value = serde_json::from_str(&call("excite", &a)).unwrap();
        // An infinite condition number (rank-deficient start) is written as null.
        let cond = |k: &str| report[k].as_f64().unwrap_or(f64::INFINITY);
        assert!(
            cond("cond_final") < cond("cond_initial") / 1000.0,
            "{tag}: {report}"
        );
        let mut a = with_drive(robot.clone());
        a.extend(["--trajectory".into(), s(&traj), "--out".into(), s(&data)]);
        a.extend(["--noise-seed".into(), seed.to_string()]);
        a.extend(["--substeps".into(), SUBSTEPS.to_string()]);
        a.extend(["--truth".into(), "exact".into()]);
        call("simulate", &a);
        datasets.push(s(&data));
    }
    let data = datasets[0].clone();
    let mut a = robot.clone();
    a.extend(
        [
            "--method",
            "pmsm",
            "--base-freq",
            "0.1",
            "--min-speed",
            "0.05",
        ]
        .map(String::from),
    );
    a.push("--data".into());
    a.extend(datasets);
    a.extend(["--out".into(), s(&model)]);
    let mut args = vec!["identify"];
    args.extend(a.iter().map(String::as_str));
    let (code, _, err) = powertwin(&args);
    assert_eq!(code, 0, "{tag} identify: {err}");
    // Three excitations along the Fourier route: by default the third is left out and
    // predicted from the other two.
    assert!(err.contains("every 3rd run left out (1)"), "{tag}: {err}");
    let mut a = robot.clone();
    a.extend(["--model".into(), s(&model), "--data".into(), data]);
    a.extend(["--base-freq", "0.1", "--json"].map(String::from));
    let v: serde_json::Value = serde_json::from_str(&call("predict", &a)).unwrap();
    // In-sample (the first excitation was fitted on): a smoke check of the command, not of
    // accuracy; the library test above and the sweep below are held out.
    let e = v["error_vs_simulated_pct"].as_f64().unwrap();
    assert!(
        e.is_finite() && v["interval_95_J"].as_f64().unwrap() > 0.0,
        "{tag}: {v}"
    );
    // The held-out benchmark on this arm: its own acceleration bounds, start poses and rated
    // payload (from the drive file).
    let mut a = with_drive(robot.clone());
    a.extend(["--model".into(), s(&model)]);
    a.extend(["--count", "3", "--truth", "exact", "--json"].map(String::from));
    let v: serde_json::Value = serde_json::from_str(&call("validate", &a)).unwrap();
    let motions = v["motions"].as_array().unwrap();
    assert_eq!(motions.len(), 3, "{tag}: {v}");
    assert_eq!(motions[2]["kind"], "linear", "{tag}: {v}");
    // The excitations carried no payload, so the wrists' copper losses are held at zero; the
    // loaded motions' intervals keep those coefficients' spread and must cover the truth.
    // Every interval must stay a few per cent of the energy: one taken at a free fit whose
    // held coefficient had run off covers whatever the error
    // (docs/experiments.md#copper-losses-without-a-drive-file). The unloaded Fourier motion,
    // mostly standby, must be covered too: it was missed while the lag search took a lag the
    // twin does not log from a jump between two branches of its fits
    // (docs/experiments.md#a-spurious-power-lag).
    for m in motions {
        let e = m["from_log"]["energy_error_pct"].as_f64().unwrap();
        assert!(e.abs() < 5.0, "{tag} held-out motion: {m}");
        let half_width = m["from_log"]["interval_95_J"].as_f64().unwrap();
        let true_j = m["true_J"].as_f64().unwrap();
        assert!(
            half_width.is_finite() && half_width < 0.05 * true_j,
            "{tag} held-out motion: {m}"
        );
        assert_eq!(m["from_log"]["covered"], true, "{tag} held-out motion: {m}");
    }
    // The optimised timing at the uniform plan's own cycle time is never dearer than that
    // plan, as one motion (it was 0.3 % dearer on the Panda when the segments' summed
    // durations passed the plan's by a rounding error and the uniform plan was excluded).
    let opt = tmp(&format!("{tag}_opt"));
    let mut a = with_drive(robot.clone());
    a.extend([
        "--model".into(),
        s(&model),
        "--scenario".into(),
        s(&scenario),
        "--out".into(),
        s(&opt),
    ]);
    a.extend(["--load", "1", "--speed", "0.5", "--json"].map(String::from));
    let v: serde_json::Value = serde_json::from_str(&call("optimize", &a)).unwrap();
    let saving = v["predicted_saving_pct"].as_f64().unwrap();
    assert!(saving >= -1e-9, "{tag}: optimised plan {saving} % dearer");
    // Bulk ground truth on this arm: its acceleration bounds, payloads within its rating.
    let bulk = tmp(&format!("{tag}_bulk"));
    let mut a = with_drive(robot.clone());
    a.extend(["--count", "6", "--seed", "3", "--out"].map(String::from));
    a.push(s(&bulk));
    call("dataset", &a);
    let rated = load(arm).1.rated_payload_kg().unwrap();
    for k in 0..6 {
        let meta = std::fs::read_to_string(bulk.join(format!("item_{k:06}/meta.json"))).unwrap();
        let meta: serde_json::Value = serde_json::from_str(&meta).unwrap();
        for p in meta["payloads"].as_array().unwrap() {
            let kg = p["mass_kg"].as_f64().unwrap();
            assert!(kg <= rated, "{tag} item {k}: {kg} kg");
        }
    }
    // Without a rated payload in the drive file, the largest payload must be given.
    let unrated = tmp(&format!("{tag}_unrated.drive.toml"));
    let text = std::fs::read_to_string(&drive).unwrap();
    assert!(
        text.contains("\nrated_payload_kg"),
        "{tag}: the drive file rates a payload"
    );
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| !l.starts_with("rated_payload_kg"))
        .collect();
    std::fs::write(&unrated, kept.join("\n")).unwrap();
    let mut a = robot.clone();
    a.extend(["--drive".into(), s(&unrated), "--model".into(), s(&model)]);
    a.extend(["--count", "3"].map(String::from));
    let mut args: Vec<&str> = vec!["validate"];
    args.extend(a.iter().map(String::as_str));
    let (code, _, err) = powertwin(&args);
    assert!(code != 0 && err.contains("--max-payload"), "{tag}: {err}");
    // So must it for a family, whose identification loads go up to it.
    let unrated_path = s(&unrated);
    let mut args: Vec<&str> = vec!["validate", "--family", "1", "--drive", &unrated_path];
    args.extend(robot.iter().map(String::as_str));
    let (code, _, err) = powertwin(&args);
    assert!(
        code != 0 && err.contains("--max-payload"),
        "{tag} family: {err}"
    );
    let mut a = with_drive(robot);
    a.extend([
        "--scenario".into(),
        s(&scenario),
        "--model".into(),
        s(&model),
    ]);
    a.extend(["--substeps".into(), SUBSTEPS.to_string()]);
    a.extend(["--truth".into(), "exact".into()]);
    a.extend(["--speeds", "0.3", "--loads", "1", "--json", "--out"].map(String::from));
    a.push(s(&sw));
    let v: serde_json::Value = serde_json::from_str(&call("sweep", &a)).unwrap();
    let cell = &v["cells"][0];
    eprintln!(
        "{tag} CLI: in-sample prediction {e:+.3} %, sweep cell at 0.3 m/s with 1 kg {:+.3} %",
        cell["error_pct"].as_f64().unwrap_or(f64::NAN)
    );
    assert!(cell["simulated_J"].as_f64().unwrap() > 0.0, "{tag}: {v}");
    assert!(
        cell["error_pct"].as_f64().unwrap().abs() < 3.0,
        "{tag}: {v}"
    );
}

/// `validate --family` on an arm other than the IRB 1200: each drawn robot is identified
/// from the identification set derived for the arm (centres spread over its joint space,
/// loads up to its rated payload) with the estimator asked for, and judged on held-out
/// motions it was not fitted on.
#[test]
fn a_family_of_ur5s_is_identified_from_a_set_derived_for_the_arm() {
    let (robot, drive, _) = load(&UR5);
    let rated = drive.rated_payload_kg().unwrap();
    let set = IdSetOptions::for_arm(&robot, rated, false).unwrap();
    assert_eq!(set.centres.len(), 8);
    assert_eq!(set.loads_kg.iter().cloned().fold(0.0, f64::max), rated);
    assert_eq!(set.loads_kg[0], 0.0);
    for centre in &set.centres {
        for (q, j) in centre.iter().zip(robot.joints()) {
            assert!(*q > j.limits.lower && *q < j.limits.upper, "{centre:?}");
        }
    }
    let err = IdSetOptions::for_arm(&robot, 0.0, false).unwrap_err();
    assert!(err.to_string().contains("rated payload"), "{err}");
    let (urdf, drive) = (repo(UR5.urdf), repo(UR5.drive));
    let (urdf, drive) = (urdf.to_str().unwrap(), drive.to_str().unwrap());
    let args = [
        "validate", "--robot", urdf, "--drive", drive, "--family", "1", "--count", "3", "--method",
        "pmsm", "--json",
    ];
    let (code, out, err) = powertwin(&args);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let robot = &v["robots"][0];
    assert_eq!(robot["model"], "cv:pmsm", "{robot}");
    assert_eq!(robot["motions"], 6, "{robot}");
    // The lag identification found is reported beside the drawn one (30 ms, found as 30.1).
    let (drawn, found) = (&robot["power_lag_s"], &robot["fitted_power_lag_s"]);
    let (drawn, found) = (drawn.as_f64().unwrap(), found.as_f64().unwrap());
    assert!(
        (found - drawn).abs() < 0.002,
        "drawn {drawn} s, found {found} s"
    );
    let error = &v["from_log"]["energy_error_pct"];
    eprintln!("a UR5 of the family, 6 held-out motions: energy error from the log {error}");
    assert!(error["worst"].as_f64().unwrap() < 3.0, "{error}");
    // A method that fits no candidates is refused.
    let mut bad = args.to_vec();
    bad[10] = "energy";
    let (code, _, err) = powertwin(&bad);
    assert!(code != 0 && err.contains("cross-validated"), "{err}");
}

#[test]
fn ur5_cli_commands_take_robot_and_drive() {
    cli(&UR5, "ur5");
}

#[test]
fn panda_cli_commands_take_robot_drive_and_lock() {
    cli(&PANDA, "panda");
}
