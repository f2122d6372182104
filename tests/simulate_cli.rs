//! `powertwin simulate` and `powertwin dataset` as a user runs them: datasets on disk,
//! byte-identical reruns, shard union, and clear errors for bad input.

use crate::common;

use common::{run as powertwin, tmp};

use std::path::Path;

use powertwin::dataset::{Dataset, Format};

/// A 2 s trajectory CSV: joint i moves `a_i (1 - cos(pi t))`.
fn trajectory(path: &Path, scale: f64, nan_row: Option<usize>) {
    let mut text = String::from("t,q1,q2,q3,q4,q5,q6\n");
    for k in 0..=40 {
        let t = k as f64 * 0.05;
        let vals: Vec<String> = (0..6)
            .map(|i| {
                if nan_row == Some(k) && i == 2 {
                    "NaN".into()
                } else {
                    format!(
                        "{}",
                        scale * (0.2 + 0.1 * i as f64) * (1.0 - (std::f64::consts::PI * t).cos())
                    )
                }
            })
            .collect();
        text.push_str(&format!("{t},{}\n", vals.join(",")));
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn simulate_writes_a_dataset_and_reruns_are_byte_identical() {
    let traj = tmp("traj.csv");
    trajectory(&traj, 1.0, None);
    let (a, b) = (tmp("run_a"), tmp("run_b"));
    for dir in [&a, &b] {
        let (code, _, err) = powertwin(&[
            "simulate",
            "--trajectory",
            traj.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
            "--payload",
            "tool",
            "--noise-seed",
            "5",
        ]);
        assert_eq!(code, 0, "{err}");
        assert!(err.contains("real time"), "{err}");
    }
    assert_eq!(common::dir_files(&a), common::dir_files(&b));
    let ds = Dataset::read(&a).unwrap();
    assert_eq!(ds.truth.len(), 2000);
    assert_eq!(ds.measured.t.len(), 20);
    assert_eq!(ds.meta.payloads[0].mass_kg, 1.32);
    assert_eq!(ds.meta.base_params.values.len(), 52);
    assert_eq!(Format::detect(&a).unwrap(), Format::Parquet);
    // CSV works too and holds the same numbers.
    let c = tmp("run_csv");
    let (code, _, err) = powertwin(&[
        "simulate",
        "--trajectory",
        traj.to_str().unwrap(),
        "--out",
        c.to_str().unwrap(),
        "--payload",
        "tool",
        "--noise-seed",
        "5",
        "--format",
        "csv",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(Dataset::read(&c).unwrap(), ds);
}

#[test]
fn bad_simulation_inputs_are_clear_errors() {
    let traj = tmp("fast.csv");
    trajectory(&traj, 8.0, None);
    let out = tmp("never");
    // `simulate` of `traj` into `out` with extra arguments: exit code and stderr.
    let simulate = |extra: &[&str]| {
        let mut args = vec![
            "simulate",
            "--trajectory",
            traj.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let (code, _, err) = powertwin(&args);
        (code, err)
    };
    let (code, err) = simulate(&[]);
    assert_eq!(code, 1);
    assert!(
        err.contains("joint limit violated") && err.contains("at t = "),
        "{err}"
    );
    assert!(!out.exists());
    trajectory(&traj, 1.0, Some(7));
    let (code, err) = simulate(&[]);
    assert_eq!(code, 1);
    assert!(err.contains("row 9") && err.contains("q3"), "{err}");
    std::fs::write(&traj, "t,q1,q2\n0,0,0\n1,0,0\n").unwrap();
    let (code, err) = simulate(&[]);
    assert_eq!(code, 1);
    assert!(err.contains("missing column 'q3_rad' or 'q3'"), "{err}");
    trajectory(&traj, 1.0, None);
    let drive = tmp("bad.drive.toml");
    let text =
        powertwin::model::builtin::IRB1200_DRIVE.replacen("\nefficiency =", "\nefficency =", 1);
    std::fs::write(&drive, text).unwrap();
    let (code, err) = simulate(&["--drive", drive.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(err.contains("unknown field `efficency`"), "{err}");
    let (code, err) = simulate(&["--payload", "anvil"]);
    assert_eq!(code, 1);
    assert!(err.contains("anvil") && err.contains("tool"), "{err}");
    let (code, err) = simulate(&["--dt", "0.0015"]);
    assert_eq!(code, 1);
    assert!(err.contains("whole number of physics steps"), "{err}");
    assert!(!out.exists());
}

#[test]
fn shards_union_to_the_unsharded_set() {
    let (all, a, b) = (tmp("all"), tmp("shard0"), tmp("shard1"));
    for (dir, shard) in [(&all, "0/1"), (&a, "0/2"), (&b, "1/2")] {
        let (code, _, err) = powertwin(&[
            "dataset",
            "--count",
            "3",
            "--seed",
            "11",
            "--shard",
            shard,
            "--out",
            dir.to_str().unwrap(),
            "--format",
            "csv",
        ]);
        assert_eq!(code, 0, "{err}");
    }
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    assert_eq!(names(&all), ["item_000000", "item_000001", "item_000002"]);
    assert_eq!(names(&a), ["item_000000", "item_000002"]);
    assert_eq!(names(&b), ["item_000001"]);
    for (item, shard) in [
        ("item_000000", &a),
        ("item_000001", &b),
        ("item_000002", &a),
    ] {
        assert_eq!(
            common::dir_files(&all.join(item)),
            common::dir_files(&shard.join(item)),
            "{item}"
        );
    }
    // Items differ from each other, and a rerun skips what exists.
    assert_ne!(
        common::dir_files(&all.join("item_000000")),
        common::dir_files(&all.join("item_000001"))
    );
    let (code, _, err) = powertwin(&[
        "dataset",
        "--count",
        "3",
        "--seed",
        "11",
        "--out",
        all.to_str().unwrap(),
        "--format",
        "csv",
    ]);
    assert_eq!(code, 0);
    assert!(err.contains("0 items written, 3 already present"), "{err}");
    let (code, _, err) = powertwin(&[
        "dataset",
        "--count",
        "3",
        "--shard",
        "2/2",
        "--out",
        all.to_str().unwrap(),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("must be K/N"), "{err}");
}
