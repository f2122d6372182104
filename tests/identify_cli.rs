//! `excite` -> `simulate` -> `identify` -> `predict` as a user runs them.

use crate::common;

use common::{run as powertwin, tmp};

use std::path::PathBuf;

#[test]
fn identified_model_predicts_the_twins_energy() {
    let (traj, data, model) = (tmp("ex.csv"), tmp("ds"), tmp("model.json"));
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();
    let (code, out, err) = powertwin(&[
        "excite",
        "--joints",
        "1-6",
        "--periods",
        "3",
        "--starts",
        "1",
        "--evals",
        "800",
        "--out",
        &s(&traj),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(
        report["cond_final"].as_f64().unwrap() < report["cond_initial"].as_f64().unwrap() / 100.0,
        "{report}"
    );
    let (code, _, err) = powertwin(&[
        "simulate",
        "--trajectory",
        &s(&traj),
        "--out",
        &s(&data),
        "--motor",
        "efficiency",
        "--noise",
        "none",
    ]);
    assert_eq!(code, 0, "{err}");
    for method in ["total", "energy", "per-joint"] {
        let (code, _, err) = powertwin(&[
            "identify",
            "--data",
            &s(&data),
            "--method",
            method,
            "--base-freq",
            "0.1",
            "--out",
            &s(&model),
        ]);
        assert_eq!(code, 0, "{method}: {err}");
        assert!(err.contains("physical consistency"), "{err}");
        let written: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
        assert!(
            written["consistency"]["consistent"].is_boolean(),
            "{written}"
        );
        let (code, out, err) = powertwin(&[
            "predict",
            "--model",
            &s(&model),
            "--data",
            &s(&data),
            "--base-freq",
            "0.1",
            "--json",
        ]);
        assert_eq!(code, 0, "{err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        let e = v["error_vs_simulated_pct"].as_f64().unwrap();
        assert!(e.abs() < 0.3, "{method}: {v}");
    }
    // Weighted least squares and the consistent model (on by default), or not.
    let identify = |extra: &[&str]| {
        let mut args = vec![
            "identify",
            "--data",
            data.to_str().unwrap(),
            "--base-freq",
            "0.1",
            "--out",
            model.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        powertwin(&args)
    };
    let (code, _, err) = identify(&["--method", "pmsm", "--weighting", "power-level"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("consistent: the model moved"), "{err}");
    // The twin logs each motor's power, which is fitted too unless asked not to.
    assert!(
        err.contains("fitted on the arm's power and each motor's"),
        "{err}"
    );
    let (code, _, err) = identify(&["--method", "pmsm", "--unconstrained", "--arm-power-only"]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("consistent: the model moved"), "{err}");
    assert!(err.contains("fitted on the arm's power ("), "{err}");
    let (code, _, err) = identify(&["--method", "energy", "--weighting", "per-log"]);
    assert_eq!(code, 1);
    assert!(
        err.contains(
            "--weighting, --unconstrained, --arm-power-only and the prior's options apply to"
        ),
        "{err}"
    );
}

#[test]
fn identify_refuses_data_from_another_robot_and_bad_input() {
    let ur5 = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ur5.urdf");
    let (traj, data) = (tmp("t.csv"), tmp("irb"));
    let mut text = String::from("t,q1,q2,q3,q4,q5,q6\n");
    for k in 0..=20 {
        let t = k as f64 * 0.1;
        text.push_str(&format!(
            "{t},{},0.2,0.2,0,0.8,0\n",
            0.3 * (1.0 - (std::f64::consts::PI * t).cos())
        ));
    }
    std::fs::write(&traj, text).unwrap();
    let (code, _, err) = powertwin(&[
        "simulate",
        "--trajectory",
        traj.to_str().unwrap(),
        "--out",
        data.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = powertwin(&[
        "identify",
        "--robot",
        ur5.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--out",
        tmp("m.json").to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("is from robot 'abb_irb1200_7_70'"), "{err}");
    // One joint moving for 2 s cannot identify 52 parameters from the data alone: the error
    // names what is missing; with the prior (the default) it gives a model and says what the
    // data determined.
    let m_json = tmp("m.json");
    let one_joint = |extra: &[&str]| {
        let mut args = vec![
            "identify",
            "--data",
            data.to_str().unwrap(),
            "--out",
            m_json.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        powertwin(&args)
    };
    let (code, _, err) = one_joint(&["--no-prior"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("need more data") || err.contains("rank-deficient"),
        "{err}"
    );
    let (code, _, err) = one_joint(&[]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("determined by the data: "), "{err}");
    let (code, _, err) = powertwin(&[
        "identify",
        "--data",
        tmp("nope").to_str().unwrap(),
        "--out",
        tmp("m.json").to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("nope"), "{err}");
}

/// The directory of a CSV twin run (`simulate --noise-seed 1` with `simulate_args`) of the
/// excitation `excite --seed 1` with `excite_args`, named after `name`.
fn excite_and_simulate(name: &str, excite_args: &[&str], simulate_args: &[&str]) -> PathBuf {
    let (traj, data) = (tmp(&format!("{name}-ex.csv")), tmp(&format!("{name}-run")));
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();
    let (traj, out) = (s(&traj), s(&data));
    let mut excite = vec!["excite", "--seed", "1", "--out", &traj];
    excite.extend(excite_args);
    common::run_ok(&excite);
    let mut simulate = vec!["simulate", "--trajectory", &traj, "--format", "csv"];
    simulate.extend(["--noise-seed", "1", "--out", &out]);
    simulate.extend(simulate_args);
    common::run_ok(&simulate);
    data
}

/// Identification gives the same model to the bit on one thread and on four. At 100 Hz,
/// fitted on every state, a log has enough samples for the fit's sums to run in parallel;
/// a parallel sum that splits where the work is stolen gave other last digits from run to
/// run.
#[test]
fn identify_gives_the_same_bits_on_one_thread_and_on_four() {
    let data = excite_and_simulate("threads", &["--periods", "1"], &["--sample-rate", "100"]);
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();
    let model = |threads: &str| {
        let out = tmp(&format!("threads-{threads}.json"));
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_powertwin"))
            .args(["identify", "--log", &s(&data.join("measured.csv"))])
            .args(["--power", "bus", "--fit-rate", "100", "--out", &s(&out)])
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .expect("the powertwin binary runs");
        assert!(
            status.status.success(),
            "{}",
            String::from_utf8_lossy(&status.stderr)
        );
        std::fs::read(out).unwrap()
    };
    assert!(model("1") == model("4"), "the models differ");
}

#[test]
fn a_bus_log_in_kw_is_an_error_to_identify_not_a_panic() {
    let data = excite_and_simulate("kw", &["--periods", "2"], &[]);
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();
    // The same log (time, positions and the bus power) with its power written in kW under
    // the W column's name.
    let text = std::fs::read_to_string(data.join("measured.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&c| header[c] == "t_s" || header[c].ends_with("_rad") || header[c] == "p_total_W")
        .collect();
    let p = header.iter().position(|c| *c == "p_total_W").unwrap();
    let pick = |f: &[&str]| keep.iter().map(|&c| f[c].to_string()).collect::<Vec<_>>();
    let mut kw = pick(&header).join(",") + "\n";
    for line in lines {
        let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
        f[p] = (f[p].parse::<f64>().unwrap() / 1000.0).to_string();
        let f: Vec<&str> = f.iter().map(String::as_str).collect();
        kw += &(pick(&f).join(",") + "\n");
    }
    let log = tmp("kw.csv");
    std::fs::write(&log, kw).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_powertwin"))
        .args(["identify", "--log", &s(&log), "--power", "bus"])
        .args(["--out", &s(&tmp("kw.json"))])
        .output()
        .expect("the powertwin binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("is it logged in kW?"), "{err}");
    assert!(err.contains("no samples left to fit"), "{err}");
}
