//! The CLI with the family: bad input refused, and `dataset --truth family:SEED` items.

use super::*;

#[test]
fn the_cli_refuses_bad_family_input() {
    for (args, needle) in [
        (vec!["validate", "--family", "0"], "at least 1"),
        (
            vec![
                "simulate",
                "--truth",
                "family:-1",
                "--trajectory",
                "x.csv",
                "--out",
                "o",
            ],
            "whole number",
        ),
        (
            vec![
                "simulate",
                "--truth",
                "family",
                "--trajectory",
                "x.csv",
                "--out",
                "o",
            ],
            "family:SEED",
        ),
        (
            vec![
                "dataset", "--truth", "family:x", "--count", "1", "--out", "o",
            ],
            "whole number",
        ),
    ] {
        let (code, _, err) = common::run(&args);
        assert_ne!(code, 0, "{args:?}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    let table = common::tmp("bad_family.toml");
    std::fs::write(&table, "stribeck_peak = [1.6, 1.1]\n").unwrap();
    let (code, _, err) = common::run(&[
        "validate",
        "--family",
        "1",
        "--family-table",
        table.to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("stribeck_peak"), "{err}");
}

/// `dataset --truth family:SEED`: item `j` runs robot `j` of the family (the one `validate
/// --family N --seed SEED` draws `j`-th), recorded in its `meta.json`, along the same motion
/// as item `j` of the set without the family.
#[test]
fn dataset_items_run_robots_of_the_family() {
    let (fam, plain) = (common::tmp("dataset_family"), common::tmp("dataset_plain"));
    for (dir, truth) in [(&fam, "family:2"), (&plain, "realistic")] {
        let (code, _, err) = common::run(&[
            "dataset",
            "--truth",
            truth,
            "--count",
            "2",
            "--seed",
            "5",
            "--format",
            "csv",
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
    }
    let meta = |d: &std::path::Path, j: usize| -> serde_json::Value {
        let text = std::fs::read_to_string(d.join(format!("item_{j:06}/meta.json"))).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    for j in 0..2 {
        let (f, p) = (meta(&fam, j), meta(&plain, j));
        assert_eq!(f["family"]["seed"], 2_000_000 + 10 * j as u64);
        assert!(p.get("family").is_none());
        assert_eq!(f["trajectory"], p["trajectory"]);
    }
}

/// A family robot the twin cannot track along an item's motion is redrawn, and the redraws
/// are recorded in the item's `meta.json`; an item whose every draw saturates is refused.
/// (Joint 2's effort limit is cut to 110 N m, about the torque item 0 needs.)
#[test]
fn dataset_items_redraw_robots_that_saturate() {
    let urdf = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/irb1200_7_70.urdf"),
    )
    .unwrap();
    let weak = |limit: &str| -> std::path::PathBuf {
        let cut = urdf.replace(
            r#"velocity="4.188790205" effort="250""#,
            &format!(r#"velocity="4.188790205" effort="{limit}""#),
        );
        assert_ne!(cut, urdf);
        let path = common::tmp(&format!("weak_joint_2_{limit}.urdf"));
        std::fs::write(&path, cut).unwrap();
        path
    };
    let dataset = |limit: &str| {
        let (urdf, out) = (weak(limit), common::tmp(&format!("dataset_redraw_{limit}")));
        let (code, _, err) = common::run(&[
            "dataset",
            "--robot",
            urdf.to_str().unwrap(),
            "--truth",
            "family:2",
            "--count",
            "1",
            "--seed",
            "5",
            "--format",
            "csv",
            "--out",
            out.to_str().unwrap(),
        ]);
        (code, err, out)
    };
    let (code, err, out) = dataset("110");
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(out.join("item_000000/meta.json")).unwrap();
    let meta: serde_json::Value = serde_json::from_str(&text).unwrap();
    let family = &meta["family"];
    let redraws = family["redraws"].as_array().expect("redraws recorded");
    assert!(!redraws.is_empty(), "{family}");
    for (k, r) in redraws.iter().enumerate() {
        assert_eq!(r["family_seed"], 2_000_000 + k as u64);
        assert!(r["reason"].as_str().unwrap().contains("joint_2"), "{r}");
    }
    assert_eq!(family["seed"], 2_000_000 + redraws.len() as u64);
    let (code, err, _) = dataset("60");
    assert_ne!(code, 0);
    assert!(
        err.contains("saturated") && err.contains("too wide"),
        "{err}"
    );
}
