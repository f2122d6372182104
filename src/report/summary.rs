//! `results.md`: the headline figures of a `reproduce` run, rendered from its `results.json`
//! alone. `reproduce` writes it beside `report.md`; `docs/results.md` is this rendering of
//! the default run's `results.json` (`docs/results.json`), and `tests/results_doc.rs` checks
//! that the two agree, so the figures the documentation quotes cannot drift from the code.
//!
//! The input is the JSON value rather than [`crate::report::results::Results`] so that a
//! committed `results.json` renders without running anything. Timings are left out: they
//! depend on the machine, not on the code. A field the file lacks renders as `–`.

use std::fmt::Write;

use serde_json::Value;

/// The command line of the default run, as [`results_markdown`] names it.
pub const DEFAULT_RUN: &str = "powertwin reproduce";

/// Placeholder for a figure the results do not have.
const MISSING: &str = "–";

/// The headline tables of `results` (a parsed `results.json`), naming `run`, the command
/// line that produced it (e.g. [`DEFAULT_RUN`]). Pure: the same input gives the same text.
pub fn results_markdown(results: &Value, run: &str) -> String {
    let mut w = String::new();
    provenance(&mut w, results, run);
    heldout(&mut w, results);
    family(&mut w, results);
    paper(&mut w, results);
    table3(&mut w, results);
    table4(&mut w, results);
    figure14(&mut w, results);
    w
}

/// The number at JSON pointer `path` (e.g. `/heldout/from_log/coverage_pct`).
fn num(v: &Value, path: &str) -> Option<f64> {
    v.pointer(path).and_then(Value::as_f64)
}

/// `x` with `digits` decimals, or [`MISSING`].
fn fixed(x: Option<f64>, digits: usize) -> String {
    x.map_or(MISSING.to_string(), |x| format!("{x:.digits$}"))
}

/// A percentage with two decimals and its unit, or [`MISSING`].
fn pct(x: Option<f64>) -> String {
    x.map_or(MISSING.to_string(), |x| format!("{x:.2} %"))
}

/// A signed percentage with two decimals and its unit, or [`MISSING`].
fn signed_pct(x: Option<f64>) -> String {
    x.map_or(MISSING.to_string(), |x| format!("{x:+.2} %"))
}

/// The array at `path`, empty when absent.
fn list<'a>(v: &'a Value, path: &str) -> &'a [Value] {
    v.pointer(path)
        .and_then(Value::as_array)
        .map_or(&[], Vec::as_slice)
}

/// The string at `path`, or [`MISSING`].
fn text<'a>(v: &'a Value, path: &str) -> &'a str {
    v.pointer(path).and_then(Value::as_str).unwrap_or(MISSING)
}

/// Largest absolute value of the numbers at `field` of each element of the array at `path`.
fn worst_abs(v: &Value, path: &str, field: &str) -> Option<f64> {
    list(v, path)
        .iter()
        .filter_map(|e| e.pointer(field).and_then(Value::as_f64))
        .map(f64::abs)
        .reduce(f64::max)
}

/// Title and the run the figures come from.
fn provenance(w: &mut String, r: &Value, run: &str) {
    let _ = writeln!(w, "# Results\n");
    let default = if run == DEFAULT_RUN {
        " (the default run: no options)"
    } else {
        ""
    };
    let _ = writeln!(w, "Run: `{run}`{default}.\n");
    let noise = match r.pointer("/settings/noise").and_then(Value::as_bool) {
        Some(true) => format!(
            "sensor noise on (seed {})",
            fixed(num(r, "/settings/noise_seed"), 0)
        ),
        Some(false) => "no sensor noise".to_string(),
        None => MISSING.to_string(),
    };
    let _ = writeln!(
        w,
        "Robot `{}`, twin truth `{}`, motor model `{}`, logged power `{}` at {} Hz, {}, \
         {} Rapier substeps per {} ms step; `results.json` schema {}, written by powertwin {}.\n",
        text(r, "/settings/robot"),
        text(r, "/settings/truth"),
        text(r, "/settings/motor_model"),
        text(r, "/settings/power_signal"),
        fixed(num(r, "/settings/sample_rate_hz"), 0),
        noise,
        fixed(num(r, "/settings/substeps"), 0),
        fixed(num(r, "/settings/dt_s").map(|dt| 1e3 * dt), 0),
        fixed(num(r, "/schema_version"), 0),
        text(r, "/program/version"),
    );
    let _ = writeln!(
        w,
        "This file is generated: `reproduce` writes it as `out/results.md` from the \
         `results.json` it writes beside it. Errors are `100 (predicted - simulated) / \
         simulated` of the energy, in % of the twin's value.\n"
    );
}

/// The held-out benchmark: motions no identification saw.
fn heldout(w: &mut String, r: &Value) {
    let _ = writeln!(w, "## Held-out benchmark (out of sample)\n");
    let _ = writeln!(
        w,
        "{} motions drawn from seed {} that no identification saw, predicted by the model \
         `{}` (identified from {} excitations carrying known loads of {} kg) from the 10 Hz \
         log of each and from its commanded plan; the baseline is the URDF's rigid bodies and \
         friction with the data-sheet efficiency.\n",
        list(r, "/heldout/motions").len(),
        fixed(num(r, "/heldout/seed"), 0),
        text(r, "/model/name"),
        list(r, "/model/excitation_conds").len(),
        list(r, "/model/loads_kg")
            .iter()
            .filter_map(Value::as_f64)
            .map(|l| format!("{l}"))
            .collect::<Vec<_>>()
            .join(", "),
    );
    route_table(
        w,
        r,
        "prediction",
        "/heldout",
        &[
            ("from the log", "from_log"),
            ("from the plan", "from_plan"),
            ("baseline (URDF + data sheet), from the log", "baseline"),
        ],
    );
    let _ = writeln!(
        w,
        "\nPower RMSE at the logged samples, worst motion: {} W from the log, {} W from the \
         plan (baseline {} W). Base parameters with relative standard deviation under 1 %: \
         {} of {}{}.\n",
        fixed(num(r, "/heldout/power_rmse_W/worst"), 2),
        fixed(num(r, "/heldout/plan_power_rmse_W/worst"), 2),
        fixed(num(r, "/heldout/baseline_power_rmse_W/worst"), 1),
        fixed(num(r, "/model/well_determined"), 0),
        fixed(num(r, "/model/parameters"), 0),
        num(r, "/model/well_determined_max_error_pct").map_or(String::new(), |e| format!(
            ", at most {e:.2} % from the truth"
        )),
    );
}

/// A table of route summaries (`RouteSummary` under `{at}/{key}`), one row per `(name, key)`;
/// `first` heads the first column.
fn route_table(w: &mut String, r: &Value, first: &str, at: &str, rows: &[(&str, &str)]) {
    let _ = writeln!(
        w,
        "| {first} | energy error, median | p95 | worst | above standby, worst | \
         95 % interval coverage | median error / sigma (calibrated 0.67) |"
    );
    let _ = writeln!(w, "|---|---|---|---|---|---|---|");
    for (name, key) in rows {
        let s = |f: &str| num(r, &format!("{at}/{key}/{f}"));
        let _ = writeln!(
            w,
            "| {name} | {} | {} | {} | {} | {} | {} |",
            pct(s("energy_error_pct/median")),
            pct(s("energy_error_pct/p95")),
            pct(s("energy_error_pct/worst")),
            pct(s("above_standby_error_pct/worst")),
            s("coverage_pct").map_or(MISSING.to_string(), |c| format!("{c:.0} %")),
            fixed(s("median_z"), 2),
        );
    }
}

/// The held-out benchmark across the family: pooled, then per robot (also in `report.md`).
pub(crate) fn family(w: &mut String, r: &Value) {
    let robots = list(r, "/family/robots");
    if robots.is_empty() {
        return;
    }
    let _ = writeln!(
        w,
        "## Robots we did not build (out of sample, across a family)\n"
    );
    let _ = writeln!(
        w,
        "{} robots drawn from the family of truths (family seed {}; docs/design/family.md): \
         inertias off the URDF, their own friction laws, losses, cabinet load, controller and \
         logger. Each is identified from its own identification set with the prior of the \
         files, as `identify` does (the files are all identification sees), and judged on {} \
         sets of held-out motions.\n",
        robots.len(),
        fixed(num(r, "/family/seed"), 0),
        fixed(num(r, "/family/heldout_seeds"), 0),
    );
    route_table(
        w,
        r,
        "pooled",
        "/family",
        &[("from the log", "from_log"), ("from the plan", "from_plan")],
    );
    let _ = writeln!(
        w,
        "\nPower RMSE at the logged samples, worst motion: {} W. Lowest coverage of one \
         robot: {} %.\n",
        fixed(num(r, "/family/power_rmse_W/worst"), 2),
        fixed(num(r, "/family/worst_robot_coverage_pct"), 0),
    );
    let _ = writeln!(
        w,
        "| robot | family seed | log rate Hz | averaging meter | cabinet seen W | power lag ms | \
         lag found ms | from the log, median | worst | coverage |"
    );
    let _ = writeln!(w, "|---|---|---|---|---|---|---|---|---|---|");
    for b in robots {
        let n = |f: &str| b.pointer(f).and_then(Value::as_f64);
        let _ = writeln!(
            w,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            fixed(n("/index"), 0),
            fixed(n("/family_seed"), 0),
            fixed(n("/rate_hz"), 0),
            if b.pointer("/power_averaging").and_then(Value::as_bool) == Some(true) {
                "yes"
            } else {
                "no"
            },
            fixed(n("/cabinet_seen_W"), 0),
            fixed(n("/power_lag_s").map(|l| 1e3 * l), 0),
            fixed(n("/fitted_power_lag_s").map(|l| 1e3 * l), 1),
            pct(n("/from_log/energy_error_pct/median")),
            pct(n("/from_log/energy_error_pct/worst")),
            n("/from_log/coverage_pct").map_or(MISSING.to_string(), |c| format!("{c:.0} %")),
        );
    }
    let _ = writeln!(w);
}

/// One line per experiment of the paper.
fn paper(w: &mut String, r: &Value) {
    let _ = writeln!(w, "## The paper's experiments on the twin\n");
    let _ = writeln!(w, "| experiment | result |");
    let _ = writeln!(w, "|---|---|");
    let _ = writeln!(
        w,
        "| Table 3, six identification steps, worst step (in-sample) | {} |",
        pct(worst_abs(r, "/table3", "/error_pct"))
    );
    let estimators = list(r, "/estimators")
        .iter()
        .map(|e| {
            format!(
                "{} {}",
                text(e, "/method"),
                pct(num(e, "/max_abs_error_pct"))
            )
        })
        .collect::<Vec<_>>()
        .join(", ");
    let _ = writeln!(
        w,
        "| estimators on the steps' data, worst step (in-sample) | {estimators} |"
    );
    let _ = writeln!(
        w,
        "| Table 4, last link re-identified, worst case (in-sample) | {} |",
        pct(worst_abs(r, "/table4", "/reidentified_error_pct"))
    );
    let _ = writeln!(
        w,
        "| Table 4, known payload added to the model, worst case | {} |",
        pct(worst_abs(r, "/table4", "/known_payload_error_pct"))
    );
    let _ = writeln!(
        w,
        "| Figure 14, {} pick-and-place cells predicted from the plan, worst cell | {} |\n",
        list(r, "/sweep/cells").len(),
        pct(worst_abs(r, "/sweep/cells", "/error_pct"))
    );
}

/// Table 3 per step.
fn table3(w: &mut String, r: &Value) {
    let _ = writeln!(
        w,
        "### Table 3: the paper's six steps (in-sample)\n\n\
         | step | joints | condition number (designed) | simulated energy J | predicted J | error |\n\
         |---|---|---|---|---|---|"
    );
    for row in list(r, "/table3") {
        let joints = list(row, "/joints")
            .iter()
            .filter_map(Value::as_u64)
            .map(|j| j.to_string())
            .collect::<Vec<_>>()
            .join(", ");
        let _ = writeln!(
            w,
            "| {} | {joints} | {} | {} | {} | {} |",
            fixed(num(row, "/step"), 0),
            fixed(num(row, "/design_cond_final"), 0),
            fixed(num(row, "/simulated_J"), 1),
            fixed(num(row, "/predicted_J"), 1),
            signed_pct(num(row, "/error_pct")),
        );
    }
    let _ = writeln!(w);
}

/// Table 4 per case.
fn table4(w: &mut String, r: &Value) {
    let _ = writeln!(
        w,
        "### Table 4: tool and loads\n\n\
         | case | payload kg | simulated energy J | last link re-identified (in-sample) | known payload added |\n\
         |---|---|---|---|---|"
    );
    for row in list(r, "/table4") {
        let _ = writeln!(
            w,
            "| {} | {} | {} | {} | {} |",
            text(row, "/case"),
            fixed(num(row, "/payload_kg"), 2),
            fixed(num(row, "/simulated_J"), 1),
            signed_pct(num(row, "/reidentified_error_pct")),
            signed_pct(num(row, "/known_payload_error_pct")),
        );
    }
    let _ = writeln!(w);
}

/// Figure 14: the energy-optimal speed per load.
fn figure14(w: &mut String, r: &Value) {
    let _ = writeln!(
        w,
        "### Figure 14: energy-optimal speed of the pick and place\n\n\
         | load kg | least energy on the twin's grid, m/s | model's optimum, m/s | model's energy there, J |\n\
         |---|---|---|---|"
    );
    for o in list(r, "/sweep/optima") {
        let _ = writeln!(
            w,
            "| {} | {} | {} | {} |",
            fixed(num(o, "/load_kg"), 0),
            fixed(num(o, "/simulated_cell_m_s"), 2),
            fixed(num(o, "/predicted_m_s"), 2),
            fixed(num(o, "/predicted_J"), 1),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_the_run_and_marks_missing_fields() {
        let md = results_markdown(&serde_json::json!({}), DEFAULT_RUN);
        assert!(md.contains("Run: `powertwin reproduce` (the default run: no options)."));
        assert!(md.contains("| from the log | – | – | – | – | – | – |"));
        let quick = results_markdown(&serde_json::json!({}), "powertwin reproduce --quick");
        assert!(quick.contains("Run: `powertwin reproduce --quick`.\n"));
    }

    #[test]
    fn renders_the_held_out_figures() {
        let r = serde_json::json!({
            "heldout": {
                "seed": 90210,
                "motions": [{}, {}],
                "from_log": {
                    "energy_error_pct": {"median": 0.191, "p95": 0.9, "worst": 1.204},
                    "above_standby_error_pct": {"median": 1.0, "p95": 2.0, "worst": 3.45},
                    "coverage_pct": 96.67,
                    "median_z": 0.62
                }
            },
            "table3": [{"step": 1, "joints": [6], "error_pct": -0.5}, {"error_pct": 0.25}]
        });
        let md = results_markdown(&r, DEFAULT_RUN);
        assert!(md.contains("2 motions drawn from seed 90210"));
        assert!(md.contains("| from the log | 0.19 % | 0.90 % | 1.20 % | 3.45 % | 97 % | 0.62 |"));
        assert!(
            md.contains("| Table 3, six identification steps, worst step (in-sample) | 0.50 % |")
        );
        assert!(md.contains("| 1 | 6 | – | – | – | -0.50 % |"));
    }
}
