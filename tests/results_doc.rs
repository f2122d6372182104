//! `docs/results.md` is current: exactly `results_markdown` of the committed `results.json` of
//! the default `powertwin reproduce` run (`docs/results.json`), and that run is the default
//! one. To refresh both after a change that moves a figure:
//!
//! ```sh
//! cargo run --release -- reproduce
//! cp out/results.json docs/results.json && cp out/results.md docs/results.md
//! ```

use std::path::Path;

use powertwin::report::summary::{DEFAULT_RUN, results_markdown};

/// A file of the repository, read as text.
fn read(path: &str) -> String {
    let full = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    std::fs::read_to_string(&full).unwrap_or_else(|e| panic!("reading {}: {e}", full.display()))
}

#[test]
fn docs_results_md_is_the_rendering_of_docs_results_json() {
    let json: serde_json::Value =
        serde_json::from_str(&read("docs/results.json")).expect("docs/results.json parses");
    let expected = results_markdown(&json, DEFAULT_RUN);
    let committed = read("docs/results.md");
    assert!(
        committed == expected,
        "docs/results.md is not results_markdown(docs/results.json): regenerate both with \
         `cargo run --release -- reproduce` and copy out/results.json and out/results.md \
         into docs/ (first differing line: {:?})",
        committed
            .lines()
            .zip(expected.lines())
            .find(|(a, b)| a != b)
    );
}

#[test]
fn readme_results_rows_are_rows_of_docs_results_md() {
    let readme = read("README.md");
    let section = readme
        .split("\n## Results\n")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("README.md has a '## Results' section");
    let results = read("docs/results.md");
    let rows: Vec<&str> = section.lines().filter(|l| l.starts_with('|')).collect();
    assert!(rows.len() >= 4, "README's Results section has no table");
    for row in rows {
        assert!(
            results.lines().any(|l| l == row),
            "README.md's results row is not in docs/results.md: {row}"
        );
    }
}

#[test]
fn docs_results_come_from_the_default_run() {
    let json: serde_json::Value =
        serde_json::from_str(&read("docs/results.json")).expect("docs/results.json parses");
    let settings = &json["settings"];
    assert_eq!(settings["quick"], false, "a --quick run: {settings}");
    assert_eq!(settings["truth"], "realistic", "{settings}");
    assert_eq!(settings["motor_model"], "pmsm", "{settings}");
    assert_eq!(settings["power_signal"], "bus", "{settings}");
    assert_eq!(settings["noise"], true, "{settings}");
    assert_eq!(settings["noise_seed"], 0, "{settings}");
    assert_eq!(settings["substeps"], 1, "{settings}");
    assert_eq!(json["schema_version"], 3);
    let md = read("docs/results.md");
    assert!(
        md.lines()
            .any(|l| l == "Run: `powertwin reproduce` (the default run: no options)."),
        "docs/results.md does not name the default run"
    );
    assert_eq!(
        json["heldout"]["motions"].as_array().map(Vec::len),
        Some(30)
    );
}

/// README's journey 1 shows the held-out benchmark's first lines as `reproduce` prints them:
/// each must be that of `docs/results.json` (a changed figure leaves no stale line behind).
#[test]
fn readme_journey_1_lines_are_those_of_docs_results_json() {
    let json: serde_json::Value =
        serde_json::from_str(&read("docs/results.json")).expect("docs/results.json parses");
    let readme = read("README.md");
    let journey = readme
        .split("\n## Journey 1: reproduce the paper\n")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("README.md has a '## Journey 1: reproduce the paper' section");
    for (name, key) in [
        ("from the log ", "from_log"),
        ("from the plan", "from_plan"),
        ("baseline     ", "baseline"),
    ] {
        let s = &json["heldout"][key];
        let f = |path: [&str; 2]| s[path[0]][path[1]].as_f64().expect("a figure");
        let expected = format!(
            "  {name}: energy error median {:.3} %, worst {:.3} %; above standby worst {:.3} %; 95 % interval coverage {:.0} %",
            f(["energy_error_pct", "median"]),
            f(["energy_error_pct", "worst"]),
            f(["above_standby_error_pct", "worst"]),
            s["coverage_pct"].as_f64().expect("coverage"),
        );
        let line = journey
            .lines()
            .find(|l| l.starts_with(&format!("  {name}:")))
            .unwrap_or_else(|| panic!("README's journey 1 has no '{name}' line"));
        let shown = line.strip_suffix(" [...]").unwrap_or(line);
        assert!(
            expected.starts_with(shown) && shown.len() > name.len() + 40,
            "README's journey 1 line is not what reproduce prints from docs/results.json:\n  \
             README:   {line}\n  expected: {expected}"
        );
    }
}
