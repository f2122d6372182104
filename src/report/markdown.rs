//! `report.md`: the human-readable outcome of `powertwin reproduce`, rendered from the same
//! [`Results`] as `results.json` so the two never disagree.

use std::fmt::Write;

use crate::report::results::{ModelInfo, Results};

/// Energy errors of the paper's Table 3 (steps 1..6), %: the reference the twin is compared
/// with (Liu et al. 2018; `docs/design/irb1200-data.md` 5.1).
const PAPER_TABLE3_PCT: [f64; 6] = [10.4, 5.4, 2.5, 1.5, 1.4, 1.8];
/// Energy errors of the paper's Table 4 (no tool, tool, tool + 1, 2, 4 kg), %.
const PAPER_TABLE4_PCT: [f64; 5] = [0.25, 0.91, 1.35, 1.1, 0.24];
/// Relative standard deviation (%) below which a base parameter counts as well excited.
pub const WELL_EXCITED_REL_STD_PCT: f64 = 1.0;

/// Durations of runs, s: `30 s each` when they are alike, else each.
fn durations(d: &[f64]) -> String {
    match d.first() {
        Some(&first) if d.iter().all(|&v| (v - first).abs() < 0.05) => format!("{first:.0} s each"),
        _ => d
            .iter()
            .map(|v| format!("{v:.0} s"))
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// The held-out benchmark: the accuracy a user can expect on motions the model never saw.
fn heldout(w: &mut String, r: &Results) {
    heldout_intro(w, r);
    heldout_summary(w, r);
    heldout_motions(w, r);
}

/// How the held-out model was identified and what the benchmark predicts.
fn heldout_intro(w: &mut String, r: &Results) {
    let h = &r.heldout;
    let m = &r.model;
    let _ = writeln!(w, "## Held-out benchmark (out of sample)\n");
    let _ = writeln!(
        w,
        "The model `{}` was identified from {} excitations ({}) over the workspace carrying \
         known loads of {} kg, designed together ({} of their stacked 10 Hz power regressor, {} \
         rounds, condition number {:.0}, {:.1} s){}, with the estimator chosen by \
         cross-validation (leave one run out; mean-power error per candidate: {}; fitted on \
         {}; weighting `{}`{}; residual {:.3} W; {} of {} base parameters with relative std < 1 %{}). Its \
         95 % intervals add to the parameter covariance a structure error averaged over what \
         the cross-validation pieces allow ({:.3} W plus {:.2} % of the active power, taken at no \
         less than {:.1} W, and {:.3} W that the pieces of a left-out run share, taken in \
         proportion to the time a motion rests){}. It then predicts \
         {} motions drawn from seed {} that no identification saw (random Fourier motions, \
         point-to-point moves, linear TCP moves at 0.05–1 m/s, payloads 0–7 kg), from the \
         10 Hz log of each (rests held still, the least-jerk spline through the positions \
         between them, leaving and reaching each rest where the displacements place it inside \
         a sample interval; the Coulomb sign of a joint not seen to move weighed down) and from \
         the commanded trajectory. The baseline is what a user has \
         without identification: the URDF's rigid bodies and friction with the data-sheet \
         efficiency. The twin's truth only scores.\n",
        m.name,
        m.excitation_conds.len(),
        durations(&m.excitation_duration_s),
        m.loads_kg
            .iter()
            .take(m.excitation_conds.len())
            .map(|l| format!("{l}"))
            .collect::<Vec<_>>()
            .join(", "),
        m.design.criterion.describe(),
        m.design.rounds,
        m.design.stacked_cond,
        m.design.wall_s,
        standby_clause(m),
        m.cv.iter()
            .map(|c| format!("{} {:.3} W", c.estimator.name(), c.mean_power_rms_w))
            .collect::<Vec<_>>()
            .join(", "),
        if m.motor_power {
            "the arm's power and each motor's"
        } else {
            "the arm's power"
        },
        m.weighting.name(),
        if m.consistent {
            ", made physically consistent"
        } else {
            ""
        },
        m.residual_rms_w,
        m.well_determined,
        m.parameters,
        m.well_determined_max_error_pct
            .map_or(String::new(), |e| format!(
                ", at most {e:.2} % from the truth"
            )),
        m.structure_sigma_w,
        100.0 * m.structure_rel,
        m.structure_active_w,
        m.structure_fold_w,
        m.lowest_seen_w.map_or(String::new(), |w| format!(
            ", and half the energy a motion's power spends below {w:.1} W, the lowest the \
             identification logs show the meter at (what it reads there is undetermined)"
        )),
        h.motions.len(),
        h.seed
    );
}

/// The identification set's standby rest, when it has one, as a clause of the intro.
fn standby_clause(m: &ModelInfo) -> String {
    m.standby.as_ref().map_or(String::new(), |s| {
        format!(
            ", and a rest of the unloaded robot at the pose of least gravity torque ({} rad; \
             the URDF's gravity torques at most {:.2} N m), whose power pins the standby",
            s.pose_rad
                .iter()
                .map(|q| format!("{q:.2}"))
                .collect::<Vec<_>>()
                .join(", "),
            s.gravity_torque_nm
                .iter()
                .fold(0.0_f64, |a, t| a.max(t.abs()))
        )
    })
}

/// The benchmark's error statistics per prediction, and the power RMSE.
fn heldout_summary(w: &mut String, r: &Results) {
    let h = &r.heldout;
    header(
        w,
        &[
            "prediction",
            "energy error % median / p95 / worst",
            "above standby % worst",
            "mean power W worst",
            "95 % interval coverage %",
            "median error / interval sigma (calibrated: 0.67)",
        ],
    );
    for (name, s) in [
        ("identified, from the log", &h.from_log),
        ("identified, from the plan", &h.from_plan),
        ("baseline (URDF + data sheet), from the log", &h.baseline),
    ] {
        let _ = writeln!(
            w,
            "| {name} | {:.3} / {:.3} / {:.3} | {:.3} | {:.3} | {:.0} | {} |",
            s.energy_error_pct.median,
            s.energy_error_pct.p95,
            s.energy_error_pct.worst,
            s.above_standby_error_pct.worst,
            s.mean_power_error_w.worst,
            s.coverage_pct,
            s.median_z.map_or("–".to_string(), |z| format!("{z:.2}"))
        );
    }
    let _ = writeln!(
        w,
        "\nPower RMSE at the logged samples (meter noise included), median / p95 / worst: \
         {:.2} / {:.2} / {:.2} W from the log, {:.2} / {:.2} / {:.2} W from the plan \
         (baseline {:.1} / {:.1} / {:.1} W).\n",
        h.power_rmse_w.median,
        h.power_rmse_w.p95,
        h.power_rmse_w.worst,
        h.plan_power_rmse_w.median,
        h.plan_power_rmse_w.p95,
        h.plan_power_rmse_w.worst,
        h.baseline_power_rmse_w.median,
        h.baseline_power_rmse_w.p95,
        h.baseline_power_rmse_w.worst
    );
}

/// One row per held-out motion.
fn heldout_motions(w: &mut String, r: &Results) {
    let h = &r.heldout;
    header(
        w,
        &[
            "#",
            "motion",
            "payload kg",
            "s",
            "true J",
            "log error %",
            "± 95 % J",
            "plan error %",
            "above standby %",
            "RMSE W log / plan",
            "baseline %",
        ],
    );
    for mo in &h.motions {
        let _ = writeln!(
            w,
            "| {} | {}{} | {:.2} | {:.1} | {:.1} | {:+.3} | {:.1} | {:+.3} | {:+.3} | {:.2} / {:.2} | {:+.1} |",
            mo.index,
            mo.kind,
            mo.tcp_speed_m_s
                .map_or(String::new(), |v| format!(" {v:.2} m/s")),
            mo.payload_kg,
            mo.duration_s,
            mo.true_j,
            mo.from_log.energy_error_pct,
            mo.from_log.interval_j,
            mo.from_plan.energy_error_pct,
            mo.from_log.above_standby_error_pct,
            mo.power_rmse_w,
            mo.plan_power_rmse_w,
            mo.baseline.energy_error_pct
        );
    }
    let _ = writeln!(w);
}

/// The held-out model's base parameters against the twin's truth.
fn model_parameters(w: &mut String, r: &Results) {
    let m = &r.model;
    let _ = writeln!(
        w,
        "## The held-out model's base parameters against the truth\n\n{} of {} base \
         parameters have a relative standard deviation below {} %{}. Truth: the twin's base \
         parameters (SI; scoring only).\n",
        m.well_determined,
        m.parameters,
        WELL_EXCITED_REL_STD_PCT,
        m.well_determined_max_error_pct
            .map_or(String::new(), |e| format!(
                "; their largest error is {e:.3} %"
            ))
    );
    header(
        w,
        &["parameter", "identified", "true", "error %", "rel. std %"],
    );
    for p in &m.table2 {
        let _ = writeln!(
            w,
            "| {} | {:.6} | {:.6} | {} | {} |",
            p.name,
            p.identified,
            p.truth,
            opt(p.error_pct, |x| format!("{x:+.3}")),
            opt(p.rel_std_pct, |x| format!("{x:.3}"))
        );
    }
    let _ = writeln!(w);
}

/// Render the report. `plots` are the stems of the charts written beside it (`stem.svg`,
/// `stem.png`) with a caption each.
pub fn render(r: &Results, plots: &[(String, String)]) -> String {
    let mut s = String::new();
    let w = &mut s;
    intro(w, r);
    heldout(w, r);
    if let Ok(value) = serde_json::to_value(r) {
        super::summary::family(w, &value);
    }
    model_parameters(w, r);
    table3(w, r);
    estimators(w, r);
    table2(w, r);
    table4(w, r);
    figure14(w, r);
    plots_section(w, plots);
    timings(w, r);
    s
}

/// The title, the run's settings and how the errors are defined.
fn intro(w: &mut String, r: &Results) {
    let st = &r.settings;
    let _ = writeln!(w, "# powertwin reproduce: Liu et al. 2018 on the twin\n");
    let _ = writeln!(
        w,
        "Robot `{}`; twin motor model `{}`, physics step {} ms with {} substeps; logger {} Hz, \
         noise {} (seed {}){}; truth `{}`, logged power `{}`. Written by {} {} in {:.1} s.\n",
        st.robot,
        st.motor_model,
        st.dt_s * 1e3,
        st.substeps,
        st.sample_rate_hz,
        if st.noise { "on" } else { "off" },
        st.noise_seed,
        if st.quick { "; `--quick` run" } else { "" },
        st.truth,
        st.power_signal,
        r.program.name,
        r.program.version,
        r.total_wall_s
    );
    let _ = writeln!(
        w,
        "Simulated energies come from the Rapier twin (commanded torques times the motion \
         Rapier produced, through the motor model, with the unmodelled losses of the realistic \
         truth); predicted energies from models identified from the logged joint positions and \
         power only (the twin's truth only scores). Errors are \
         `100 (predicted - simulated) / simulated`.\n"
    );
}

/// The in-sample tables' caveat and Table 3: the six identification steps.
fn table3(w: &mut String, r: &Results) {
    let _ = writeln!(
        w,
        "## In-sample tables (the paper's experiments)\n\nEvery table below predicts the \
         energy of data the model was fitted on. A fit with a constant-power column predicts \
         its own data's energy almost whatever its parameters are, so these errors show \
         consistency with the paper, not accuracy: the held-out benchmark above does.\n"
    );
    let _ = writeln!(
        w,
        "## Table 3: six identification steps (paper's method, in-sample)\n"
    );
    header(
        w,
        &[
            "step",
            "excited joints",
            "cond before -> after",
            "identified",
            "residual W",
            "simulated J",
            "predicted J",
            "error %",
            "paper error %",
        ],
    );
    for (k, row) in r.table3.iter().enumerate() {
        let _ = writeln!(
            w,
            "| {} | {} | {:.3e} -> {:.1} | {} | {:.3} | {:.2} | {:.2} | {:+.3} | {} |",
            row.step,
            join(&row.joints),
            row.design_cond_initial,
            row.design_cond_final,
            row.identified.len().saturating_sub(1),
            row.residual_rms_w,
            row.simulated_j,
            row.predicted_j,
            row.error_pct,
            PAPER_TABLE3_PCT
                .get(k)
                .map_or("".into(), |p| format!("{p}"))
        );
    }
}

/// Every estimator on the steps' data (in-sample), with its consistency.
fn estimators(w: &mut String, r: &Results) {
    let _ = writeln!(w, "\n## Estimators on the same data (in-sample)\n");
    let _ = writeln!(
        w,
        "Each model predicts every step's trajectory (errors %). `paper-steps` is the model \
         after step 6; `total` identifies all base parameters at once from the pooled total \
         power; `pmsm` adds the copper-loss terms (Levenberg–Marquardt). Consistency: the \
         model's mass matrix is positive definite at 200 random poses and no friction or rotor \
         inertia is negative.\n"
    );
    let n = r.table3.len();
    let steps: Vec<String> = (1..=n).map(|k| format!("step {k}")).collect();
    let cols: Vec<&str> = ["method"]
        .into_iter()
        .chain(steps.iter().map(String::as_str))
        .chain(["max abs %", "min eig M kg m^2", "consistent"])
        .collect();
    header(w, &cols);
    for e in &r.estimators {
        let errs: Vec<String> = e.error_pct.iter().map(|x| format!("{x:+.3}")).collect();
        let _ = writeln!(
            w,
            "| {} | {} | {:.3} | {:.4} | {} |",
            e.method,
            errs.join(" | "),
            e.max_abs_error_pct,
            e.consistency.min_eigenvalue,
            if e.consistency.consistent {
                "yes".to_string()
            } else {
                format!("no {}", e.consistency.negative_drive_terms.join(" "))
            }
        );
    }
}

/// Table 2 per estimator: identified vs true base parameters.
fn table2(w: &mut String, r: &Results) {
    let st = &r.settings;
    for e in &r.estimators {
        let rows = &e.table2;
        let well: Vec<_> = rows
            .iter()
            .filter(|p| p.rel_std_pct.is_some_and(|s| s < WELL_EXCITED_REL_STD_PCT))
            .collect();
        let worst_well = well
            .iter()
            .filter_map(|p| p.error_pct)
            .fold(0.0_f64, |m, x| m.max(x.abs()));
        let _ = writeln!(
            w,
            "\n## Table 2 ({}): identified vs true base parameters\n",
            e.method
        );
        let truth_note = if e.method == "pmsm" {
            " (SI)"
        } else if st.motor_model == "efficiency" {
            ", divided by the nominal efficiency"
        } else {
            " (SI; the linear model also absorbs the copper losses it does not represent)"
        };
        let _ = writeln!(
            w,
            "{} of {} parameters are well excited (relative standard deviation < {} %){}. \
             Truth: the twin's base parameters{truth_note}.\n",
            well.len(),
            rows.len(),
            WELL_EXCITED_REL_STD_PCT,
            if well.is_empty() {
                String::new()
            } else {
                format!("; their largest error is {worst_well:.3} %")
            }
        );
        header(
            w,
            &["parameter", "identified", "true", "error %", "rel. std %"],
        );
        for p in rows {
            let _ = writeln!(
                w,
                "| {} | {:.6} | {:.6} | {} | {} |",
                p.name,
                p.identified,
                p.truth,
                opt(p.error_pct, |x| format!("{x:+.3}")),
                opt(p.rel_std_pct, |x| format!("{x:.3}"))
            );
        }
    }
}

/// Table 4: tool and loads on step 6's trajectory.
fn table4(w: &mut String, r: &Results) {
    let _ = writeln!(w, "\n## Table 4: tool and loads on step 6's trajectory\n");
    let _ = writeln!(
        w,
        "Re-identified: the base parameters that carry link 6 identified again from the case's \
         data (paper). Known payload: the `{}` model plus the payload's mass properties, no \
         new data.\n",
        r.model.name
    );
    header(
        w,
        &[
            "case",
            "payload kg",
            "simulated J",
            "re-identified J",
            "error %",
            "known payload J",
            "error %",
            "paper error %",
        ],
    );
    for (k, c) in r.table4.iter().enumerate() {
        let _ = writeln!(
            w,
            "| {} | {:.2} | {:.2} | {:.2} | {:+.3} | {:.2} | {:+.3} | {} |",
            c.case,
            c.payload_kg,
            c.simulated_j,
            c.reidentified_j,
            c.reidentified_error_pct,
            c.known_payload_j,
            c.known_payload_error_pct,
            PAPER_TABLE4_PCT
                .get(k)
                .map_or("".into(), |p| format!("{p}"))
        );
    }
}

/// Figure 14: the pick-and-place sweep, its optima and the Pareto front.
fn figure14(w: &mut String, r: &Results) {
    let _ = writeln!(w, "\n## Figure 14: pick-and-place speed x load sweep\n");
    let _ = writeln!(
        w,
        "Predicted: the `{}` model on the planned motion with the known tool and loads.\n",
        r.model.name
    );
    header(
        w,
        &[
            "speed m/s",
            "load kg",
            "cycle s",
            "simulated J",
            "grid J",
            "predicted J",
            "error %",
            "slowed segments",
            "flag",
        ],
    );
    figure14_cells(w, r);
    let _ = writeln!(w);
    figure14_optima(w, r);
    let front: Vec<String> = r
        .sweep
        .pareto
        .iter()
        .map(|&k| {
            let c = &r.sweep.cells[k];
            format!("{} kg @ {} m/s", c.load_kg, c.speed_m_s)
        })
        .collect();
    let _ = writeln!(
        w,
        "\nEnergy / cycle-time Pareto front per load: {}.",
        front.join(", ")
    );
}

/// Figure 14's rows, one per sweep cell.
fn figure14_cells(w: &mut String, r: &Results) {
    for c in &r.sweep.cells {
        let _ = writeln!(
            w,
            "| {} | {} | {:.2} | {:.1} | {:.1} | {} | {} | {} | {} |",
            c.speed_m_s,
            c.load_kg,
            c.cycle_time_s,
            c.simulated_j,
            c.simulated_grid_j,
            opt(c.predicted_j, |x| format!("{x:.1}")),
            opt(c.error_pct, |x| format!("{x:+.3}")),
            c.slowed.len(),
            c.flag_reason()
                .map_or("-".into(), |why| format!("**flagged**: {why}"))
        );
    }
}

/// The optimal speed per load: the sweep's and the model's.
fn figure14_optima(w: &mut String, r: &Results) {
    header(
        w,
        &[
            "load kg",
            "optimal cell m/s",
            "interpolated m/s",
            "model's optimum m/s",
            "its energy J",
            "model's optimum on a planner limit",
            "interior",
        ],
    );
    for o in &r.sweep.optima {
        let _ = writeln!(
            w,
            "| {} | {} | {:.3} | {} | {} | {} | {} |",
            o.load_kg,
            o.simulated_cell_m_s,
            o.simulated_interpolated_m_s,
            opt(o.predicted_m_s, |x| format!("{x:.3}")),
            opt(o.predicted_j, |x| format!("{x:.1}")),
            match o.predicted {
                Some(p) if p.on_planner_limit => {
                    format!("yes ({} segments slowed)", p.slowed_segments)
                }
                Some(_) => "no".into(),
                None => "-".into(),
            },
            if o.interior { "yes" } else { "no" }
        );
    }
}

/// The wall time of every stage.
fn timings(w: &mut String, r: &Results) {
    let _ = writeln!(w, "## Timings\n");
    header(w, &["stage", "wall s"]);
    for t in &r.timings {
        let _ = writeln!(w, "| {} | {:.2} |", t.stage, t.wall_s);
    }
    let _ = writeln!(w, "| total | {:.2} |", r.total_wall_s);
}

/// The charts, with their captions (`plots`: file stem and caption).
fn plots_section(w: &mut String, plots: &[(String, String)]) {
    if !plots.is_empty() {
        let _ = writeln!(w, "\n## Plots\n");
        for (stem, caption) in plots {
            let _ = writeln!(
                w,
                "![{caption}]({stem}.svg) ({caption}; also `{stem}.png`)\n"
            );
        }
    }
}

/// A Markdown table header: the column names and the separator line.
fn header(w: &mut String, cols: &[&str]) {
    let _ = writeln!(w, "| {} |", cols.join(" | "));
    let _ = writeln!(w, "|{}", "---|".repeat(cols.len()));
}

/// A formatted optional value, `-` when absent.
fn opt(v: Option<f64>, f: impl Fn(f64) -> String) -> String {
    v.map_or("-".into(), f)
}

fn join(v: &[usize]) -> String {
    v.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}
