//! `identify --runs` and `predict --runs`: several logs, each with its own payload, listed in
//! a manifest with paths relative to it; `identify --holdout`, the out-of-sample check on the
//! user's own logs.

use crate::common;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{run as powertwin, run_ok, tmp};

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

/// Rest pose of the IRB 1200, rad.
const REST: [f64; 6] = [0.0, 0.2, 0.2, 0.0, 0.8, 0.0];

/// A trajectory CSV (t_s, q1_rad..q6_rad at 100 Hz): four quintic rest-to-rest moves of 1.5 s
/// between poses near the rest pose (offsets up to 0.5 rad, different for each `seed`), with
/// rests of 0.6 s before, between and after them.
fn moves_csv(seed: usize) -> String {
    let pose = |m: usize| -> Vec<f64> {
        (0..6)
            .map(|i| match m {
                0 => REST[i],
                _ => REST[i] + 0.5 * (seed as f64 * 7.1 + i as f64 * 3.3 + m as f64 * 1.7).sin(),
            })
            .collect()
    };
    let mut csv = String::from("t_s,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n");
    let mut k = 0;
    let mut row = |q: &[f64]| {
        let cells: Vec<String> = q.iter().map(|v| format!("{v:.6}")).collect();
        let _ = writeln!(csv, "{:.2},{}", k as f64 * 0.01, cells.join(","));
        k += 1;
    };
    for m in 0..4 {
        let (a, b) = (pose(m), pose(m + 1));
        (0..60).for_each(|_| row(&a));
        for j in 0..150 {
            let x = j as f64 / 150.0;
            let smooth = x * x * x * (10.0 - 15.0 * x + 6.0 * x * x);
            let q: Vec<f64> = a
                .iter()
                .zip(&b)
                .map(|(p, r)| p + (r - p) * smooth)
                .collect();
            row(&q);
        }
    }
    (0..61).for_each(|_| row(&pose(4)));
    csv
}

/// The manifest directory: four twin runs' logs under `logs/run1..4/measured.csv`, runs 3
/// and 4 carrying the 2 kg load, and `load.toml`, a copy of the built-in 2 kg load.
fn fixture() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tmp("runs");
        std::fs::create_dir_all(dir.join("logs")).unwrap();
        for k in 1..=4 {
            let traj = dir.join(format!("traj{k}.csv"));
            std::fs::write(&traj, moves_csv(k)).unwrap();
            let out = dir.join(format!("logs/run{k}"));
            let mut args = vec!["simulate", "--trajectory", traj.to_str().unwrap()];
            args.extend(["--out", out.to_str().unwrap(), "--format", "csv"]);
            if k >= 3 {
                args.extend(["--payload", "liu2018_load_2kg"]);
            }
            run_ok(&args);
        }
        let load = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/load_2kg.payload.toml");
        std::fs::copy(load, dir.join("load.toml")).unwrap();
        dir
    })
}

/// The log of run `k` (1-based) of the fixture.
fn log(k: usize) -> PathBuf {
    fixture().join(format!("logs/run{k}/measured.csv"))
}

/// Write the manifest `name` into the fixture directory: the default power `bus`, then one
/// `[[run]]` per entry of `runs` (its lines as given); returns its path.
fn manifest(name: &str, runs: &[&str]) -> PathBuf {
    let mut text = String::from("# runs of the test\npower = \"bus\"\n");
    for r in runs {
        let _ = writeln!(text, "\n[[run]]\n{r}");
    }
    let path = fixture().join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// `[[run]]` lines of run `k` of the fixture with `payload`.
fn run_lines(k: usize, payload: &str) -> String {
    format!("log = \"logs/run{k}/measured.csv\"\npayload = \"{payload}\"")
}

/// `identify --out out` with `args`: exit code, stderr, and the model file's text if written.
fn identify(out: &str, args: &[&str]) -> (i32, String, Option<String>) {
    let out = tmp(out);
    let (code, _, err) = powertwin(&[&["identify", "--out", &s(&out)], args].concat());
    (code, err, std::fs::read_to_string(&out).ok())
}

#[test]
fn a_manifest_identifies_as_the_logs_on_the_command_line_do() {
    // Runs without a payload, and runs with the load (by name and by a file next to the
    // manifest): the manifest gives the model of --log ... --payload, to the digit.
    let bare = manifest("bare.toml", &[&run_lines(1, "none"), &run_lines(2, "none")]);
    let loaded = manifest(
        "loaded.toml",
        &[
            &run_lines(3, "liu2018_load_2kg"),
            &run_lines(4, "load.toml"),
        ],
    );
    let (l1, l2, l3, l4) = (s(&log(1)), s(&log(2)), s(&log(3)), s(&log(4)));
    for (name, runs, logs) in [
        ("bare", &bare, vec!["--log", &l1, &l2]),
        (
            "loaded",
            &loaded,
            vec!["--log", &l3, &l4, "--payload", "liu2018_load_2kg"],
        ),
    ] {
        let (code, err, from_runs) = identify(
            &format!("{name}_runs.json"),
            &["--runs", &s(runs), "--holdout", "0"],
        );
        assert_eq!(code, 0, "{err}");
        assert!(err.contains("run 2 (logs/run"), "{err}");
        let mut args = logs.clone();
        args.extend(["--power", "bus", "--holdout", "0"]);
        let (code, err, from_logs) = identify(&format!("{name}_logs.json"), &args);
        assert_eq!(code, 0, "{err}");
        assert_eq!(from_runs.unwrap(), from_logs.unwrap(), "{name}");
    }
    // A payload makes a difference: the loaded runs declared bare give another model.
    let wrong = manifest(
        "wrong.toml",
        &[&run_lines(3, "none"), &run_lines(4, "none")],
    );
    let (code, err, bare_model) = identify("wrong.json", &["--runs", &s(&wrong), "--holdout", "0"]);
    assert_eq!(code, 0, "{err}");
    let loaded_model = std::fs::read_to_string(tmp("loaded_runs.json")).ok();
    assert!(bare_model.is_some());
    assert_ne!(bare_model, loaded_model);
}

#[test]
fn predict_runs_prices_each_run_with_its_payload() {
    let all = manifest(
        "all.toml",
        &[
            &run_lines(1, "none"),
            &run_lines(2, "none"),
            &run_lines(3, "liu2018_load_2kg"),
            &run_lines(4, "load.toml"),
        ],
    );
    let model = tmp("all.json");
    let (code, err, _) = identify("all.json", &["--runs", &s(&all), "--holdout", "0"]);
    assert_eq!(code, 0, "{err}");
    let predict = |runs: &Path| -> Vec<serde_json::Value> {
        let out = run_ok(&[
            "predict",
            "--model",
            &s(&model),
            "--runs",
            &s(runs),
            "--json",
        ]);
        // One run gives one object, several an array.
        match serde_json::from_str::<serde_json::Value>(&out).unwrap() {
            serde_json::Value::Array(rows) => rows,
            one => vec![one],
        }
    };
    let rows = predict(&all);
    assert_eq!(rows.len(), 4);
    for r in &rows {
        let e = r["error_vs_measured_pct"].as_f64().unwrap();
        assert!(e.abs() < 5.0, "{r}");
        assert_eq!(r["power_signal"], "bus", "{r}");
    }
    // The load from the start as a payload timeline: the same prediction; declared bare
    // instead, run 4 is predicted lower.
    std::fs::write(
        fixture().join("events.toml"),
        "[[event]]\nt_s = 0.0\npayload = \"load.toml\"\n",
    )
    .unwrap();
    let events = manifest(
        "events.toml.runs",
        &["log = \"logs/run4/measured.csv\"\npayload_events = \"events.toml\""],
    );
    let bare = manifest("bare4.toml", &[&run_lines(4, "none")]);
    let energy = |rows: &[serde_json::Value]| rows[0]["predicted_J"].as_f64().unwrap();
    let (with_events, declared_bare) = (predict(&events), predict(&bare));
    let loaded = rows[3]["predicted_J"].as_f64().unwrap();
    assert!(
        (energy(&with_events) - loaded).abs() < 1e-6 * loaded,
        "{with_events:?} vs {loaded}"
    );
    assert!(
        energy(&declared_bare) < loaded - 1.0,
        "{declared_bare:?} vs {loaded}"
    );
}

#[test]
fn bad_manifests_name_the_file_and_the_run() {
    std::fs::write(
        fixture().join("bad.payload.toml"),
        "name = \"bad\"\nmass_kg = 1.0\n",
    )
    .unwrap();
    std::fs::write(fixture().join("garbage.csv"), "a,b\n1,2\n3,4\n").unwrap();
    let good = run_lines(1, "none");
    let cases: [(&str, String, &str); 6] = [
        (
            "missing",
            "log = \"logs/nope.csv\"\npayload = \"none\"".into(),
            "not found",
        ),
        (
            "payload",
            run_lines(2, "bad.payload.toml"),
            "bad.payload.toml",
        ),
        (
            "unknown",
            format!("{}\ncolour = \"red\"", run_lines(2, "none")),
            "colour",
        ),
        (
            "both",
            format!("{}\npayload_events = \"events.toml\"", run_lines(2, "none")),
            "not both",
        ),
        (
            "nopayload",
            "log = \"logs/run2/measured.csv\"".into(),
            "no payload",
        ),
        (
            "unreadable",
            "log = \"garbage.csv\"\npayload = \"none\"".into(),
            "t_s",
        ),
    ];
    for (name, run2, why) in cases {
        let path = manifest(&format!("bad_{name}.toml"), &[&good, &run2]);
        let out = format!("bad_{name}.json");
        let (code, err, written) = identify(&out, &["--runs", &s(&path)]);
        assert_eq!(code, 1, "{name}: {err}");
        assert!(err.contains(&format!("bad_{name}.toml")), "{name}: {err}");
        assert!(err.contains("run 2 ("), "{name}: {err}");
        assert!(err.contains(why), "{name}: {err}");
        assert!(written.is_none(), "{name}");
    }
    let empty = manifest("bad_empty.toml", &[]);
    let (code, err, written) = identify("bad_empty.json", &["--runs", &s(&empty)]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("bad_empty.toml: no [[run]]"), "{err}");
    assert!(written.is_none());
    // --runs replaces --log, --columns, --power, --segments and --payload.
    for extra in [
        ["--log", "x.csv"],
        ["--power", "bus"],
        ["--payload", "tool"],
    ] {
        let (code, _, err) = powertwin(
            &[
                &["identify", "--out", "m.json", "--runs", &s(&empty)],
                &extra[..],
            ]
            .concat(),
        );
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(err.contains("cannot be used with"), "{err}");
    }
}

#[test]
fn holdout_reports_held_out_runs_and_moves() {
    let all = manifest(
        "holdout.toml",
        &[
            &run_lines(1, "none"),
            &run_lines(2, "none"),
            &run_lines(3, "liu2018_load_2kg"),
            &run_lines(4, "load.toml"),
        ],
    );
    // Four runs: the 4th is left out, identified on the other three, and predicted.
    let (code, err, with) = identify("holdout4.json", &["--runs", &s(&all), "--holdout", "4"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("every 4th run left out (1)"), "{err}");
    assert!(err.contains("identified on the other 3"), "{err}");
    let line = err
        .lines()
        .find(|l| l.contains("logs/run4/measured.csv: measured"))
        .unwrap_or_else(|| panic!("{err}"));
    assert!(
        line.contains("predicted") && line.contains("power RMSE"),
        "{line}"
    );
    let summary = err
        .lines()
        .find(|l| l.starts_with("holdout: median"))
        .unwrap();
    let worst: f64 = summary
        .split("worst ")
        .nth(1)
        .and_then(|w| w.split(' ').next())
        .and_then(|w| w.parse().ok())
        .unwrap_or_else(|| panic!("{summary}"));
    assert!(worst < 10.0, "{summary}");
    // The holdout does not change the model fitted on everything; 0 skips it.
    let (code, err, without) = identify("holdout0.json", &["--runs", &s(&all), "--holdout", "0"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        !err.contains("holdout (") && !err.contains("holdout:") && !err.contains("holdout skipped"),
        "{err}"
    );
    assert_eq!(with, without);
    // Two runs of four moves each: by default every 4th move is left out.
    let two = manifest(
        "holdout2.toml",
        &[&run_lines(1, "none"), &run_lines(3, "load.toml")],
    );
    let (code, err, _) = identify("holdout2.json", &["--runs", &s(&two)]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("every 4th move left out (2)"), "{err}");
    // Too few pieces: a note, and the model all the same.
    let (code, err, written) = identify("holdout9.json", &["--runs", &s(&two), "--holdout", "9"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("holdout skipped: ") && err.contains("too few pieces"),
        "{err}"
    );
    assert!(written.is_some());
    let (code, err, _) = identify("holdout1.json", &["--runs", &s(&two), "--holdout", "1"]);
    assert_eq!(code, 1, "{err}");
    // Moves cut from logs do not suit the Fourier route; a paper method takes no holdout.
    let (code, err, _) = identify(
        "holdout_fourier.json",
        &["--runs", &s(&two), "--base-freq", "0.1"],
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("holdout skipped: ") && err.contains("Fourier"),
        "{err}"
    );
    let bare = manifest(
        "holdout_bare.toml",
        &[&run_lines(1, "none"), &run_lines(2, "none")],
    );
    let (code, err, _) = identify(
        "holdout_energy.json",
        &["--runs", &s(&bare), "--method", "energy", "--holdout", "4"],
    );
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("--holdout applies to --method auto"), "{err}");
}
