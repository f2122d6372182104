//! The charts of `powertwin reproduce`, built from its outcome, and of `powertwin optimize`.

use crate::dataset::Dataset;
use crate::error::Result;
use crate::model::Robot;
use crate::optimize::Optimized;
use crate::report::plot::{Annotation, Chart, Series, Style, XAxis};
use crate::validation::reproduce::Outcome;
use crate::validation::sweep::{Sweep, distinct};

/// Charts with their file stem and caption.
pub struct Figure {
    /// File stem (`stem.svg`, `stem.png`).
    pub stem: String,
    /// One-line caption.
    pub caption: String,
    /// The chart.
    pub chart: Chart,
}

/// Every chart of the report: energy against speed per load, the prediction error per sweep
/// cell, Table 3's errors, and power traces (simulated against predicted) of the last
/// identification step and of one sweep cell. `efficiency`: the drives' nominal efficiency.
pub fn figures(robot: &Robot, outcome: &Outcome, efficiency: f64) -> Result<Vec<Figure>> {
    let mut out = vec![
        heldout(outcome),
        energy_vs_speed(outcome),
        error_per_cell(outcome),
        table3(outcome),
    ];
    out.extend(step_trace(robot, outcome)?);
    out.extend(sweep_trace(robot, outcome, efficiency)?);
    Ok(out)
}

fn energy_vs_speed(outcome: &Outcome) -> Figure {
    Figure {
        stem: "energy_vs_speed".into(),
        caption: "Energy per cycle against TCP speed per load: twin (solid) and identified \
                  model (dashed), with the model's optimum speed"
            .into(),
        chart: energy_chart(&outcome.sweep),
    }
}

/// Energy per cycle against TCP speed (log axis) per load: the twin's (solid) and, where
/// predicted, the model's (dashed), with the model's optimum speeds marked.
pub fn energy_chart(sweep: &Sweep) -> Chart {
    let mut chart = Chart::new(
        "Energy per cycle against TCP speed",
        "TCP speed (m/s)",
        "Motor energy per cycle (J)",
    )
    .with_x_axis(XAxis::Log);
    for load in distinct(&sweep.cells, |c| c.load_kg) {
        let cells: Vec<_> = sweep.cells.iter().filter(|c| c.load_kg == load).collect();
        chart = chart.with_series(Series::new(
            format!("twin, load {load} kg"),
            cells.iter().map(|c| (c.speed_m_s, c.simulated_j)).collect(),
            Style::LineMarkers,
        ));
        let predicted: Vec<(f64, f64)> = cells
            .iter()
            .filter_map(|c| c.predicted_j.map(|e| (c.speed_m_s, e)))
            .collect();
        if !predicted.is_empty() {
            chart = chart.with_series(
                Series::new(format!("model, load {load} kg"), predicted, Style::Line).dashed(),
            );
        }
    }
    for o in &sweep.optima {
        if let (Some(x), Some(y)) = (o.predicted_m_s, o.predicted_j) {
            chart = chart.with_annotation(Annotation::Point {
                x,
                y,
                label: format!("{x:.2} m/s"),
            });
        }
    }
    chart
}

fn error_per_cell(outcome: &Outcome) -> Figure {
    let speeds = distinct(&outcome.sweep.cells, |c| c.speed_m_s);
    let mut chart = Chart::new(
        "Prediction error per sweep cell",
        "TCP speed (m/s)",
        "Energy error (%)",
    )
    .with_x_axis(XAxis::Categories(
        speeds.iter().map(|v| format!("{v}")).collect(),
    ));
    for load in distinct(&outcome.sweep.cells, |c| c.load_kg) {
        let values: Vec<f64> = speeds
            .iter()
            .map(|&v| {
                outcome
                    .sweep
                    .cells
                    .iter()
                    .find(|c| c.load_kg == load && c.speed_m_s == v)
                    .and_then(|c| c.error_pct)
                    .unwrap_or(0.0)
            })
            .collect();
        chart = chart.with_series(Series::bars(format!("load {load} kg"), &values));
    }
    Figure {
        stem: "error_per_cell".into(),
        caption: "Predicted against simulated energy per sweep cell, %".into(),
        chart,
    }
}

/// Energy error of every held-out motion: from the log, from the plan, with the 95 %
/// interval half-width (in % of the true energy) beside them.
fn heldout(outcome: &Outcome) -> Figure {
    let m = &outcome.heldout.motions;
    let pct = |f: &dyn Fn(&crate::validation::score::MotionResult) -> f64| -> Vec<f64> {
        m.iter().map(f).collect()
    };
    let chart = Chart::new(
        "Held-out motions: energy error of the identified model",
        "Motion (kind, payload kg)",
        "Energy error (%)",
    )
    .with_x_axis(XAxis::Categories(
        m.iter()
            .map(|r| {
                format!(
                    "{} {} {:.1}",
                    r.index,
                    match r.kind.as_str() {
                        "fourier" => "F",
                        "point-to-point" => "P",
                        _ => "L",
                    },
                    r.payload_kg
                )
            })
            .collect(),
    ))
    .with_series(Series::bars(
        "from the 10 Hz log",
        &pct(&|r| r.from_log.energy_error_pct),
    ))
    .with_series(Series::bars(
        "from the plan",
        &pct(&|r| r.from_plan.energy_error_pct),
    ))
    .with_series(Series::bars(
        "95 % interval (+/-)",
        &pct(&|r| 100.0 * r.from_log.interval_j / r.true_j),
    ));
    Figure {
        stem: "heldout_errors".into(),
        caption: "Energy error on motions no identification saw (F Fourier, P point-to-point, \
                  L linear; payload kg), with the 95 % interval half-width"
            .into(),
        chart,
    }
}

fn table3(outcome: &Outcome) -> Figure {
    let rows = &outcome.steps.rows;
    let mut chart = Chart::new(
        "Table 3: energy error per identification step",
        "Step (excited joints)",
        "Energy error (%)",
    )
    .with_x_axis(XAxis::Categories(
        rows.iter()
            .map(|r| {
                format!(
                    "{} ({}-{})",
                    r.step,
                    r.joints[0],
                    r.joints[r.joints.len() - 1]
                )
            })
            .collect(),
    ))
    .with_series(Series::bars(
        "paper's method on the twin",
        &rows.iter().map(|r| r.error_pct).collect::<Vec<_>>(),
    ));
    for e in outcome
        .estimators
        .iter()
        .filter(|e| e.method != "paper-steps")
    {
        chart = chart.with_series(Series::bars(
            format!("{} (final model)", e.method),
            &e.error_pct,
        ));
    }
    Figure {
        stem: "table3_errors".into(),
        caption: "Energy error per identification step (in-sample)".into(),
        chart,
    }
}

/// Simulated (logged, 10 Hz) and predicted total power of the last step.
fn step_trace(robot: &Robot, outcome: &Outcome) -> Result<Option<Figure>> {
    let (Some(ds), Some(traj)) = (
        outcome.steps.datasets.last(),
        outcome.steps.trajectories.last(),
    ) else {
        return Ok(None);
    };
    let name = outcome.model_name();
    let t = &ds.measured.t;
    let predicted = outcome
        .model
        .power_with_payloads(robot, traj, &[], 1.0, t)?;
    let chart = power_chart(
        "Identification step 6: total motor power".into(),
        t,
        ("twin (logged)", &ds.measured.p_total),
        (&name, &predicted),
    );
    Ok(Some(Figure {
        stem: "power_step6".into(),
        caption: "Total motor power during step 6: twin against the identified model".into(),
        chart,
    }))
}

/// Simulated and predicted total power of the heaviest sweep cell at the speed nearest
/// 0.5 m/s (the speed of the paper's Figure 13).
fn sweep_trace(robot: &Robot, outcome: &Outcome, efficiency: f64) -> Result<Option<Figure>> {
    let cells = &outcome.sweep.cells;
    let Some(k) = outcome.sweep.representative() else {
        return Ok(None);
    };
    let (cell, ds, plan) = (
        &cells[k],
        &outcome.sweep.datasets[k],
        &outcome.sweep.plans[k],
    );
    let name = outcome.model_name();
    let stride = (ds.truth.t.len() / 2000).max(1);
    let t: Vec<f64> = ds.truth.t.iter().step_by(stride).copied().collect();
    let simulated: Vec<f64> = ds.truth.p_total.iter().step_by(stride).copied().collect();
    let predicted = outcome.model.power_with_payloads(
        robot,
        &plan.motion.trajectory,
        &plan.events,
        efficiency,
        &t,
    )?;
    let mut chart = power_chart(
        format!(
            "Pick and place at {} m/s, load {} kg: total motor power",
            cell.speed_m_s, cell.load_kg
        ),
        &t,
        ("twin", &simulated),
        (&name, &predicted),
    );
    for v in &plan.via {
        chart = chart.with_annotation(Annotation::Point {
            x: v.arrival_s,
            y: 0.0,
            label: v.name.clone(),
        });
    }
    Ok(Some(Figure {
        stem: "power_pick_and_place".into(),
        caption: format!(
            "Total motor power of the pick-and-place task at {} m/s with load {} kg",
            cell.speed_m_s, cell.load_kg
        ),
        chart,
    }))
}

/// Total power against time: the twin's (`simulated`: name and values) solid, the model's
/// (`predicted`: method and values) dashed.
fn power_chart(
    title: String,
    t: &[f64],
    simulated: (&str, &[f64]),
    predicted: (&str, &[f64]),
) -> Chart {
    let series = |v: &[f64]| t.iter().copied().zip(v.iter().copied()).collect();
    Chart::new(title, "Time (s)", "Total motor power (W)")
        .with_series(Series::new(simulated.0, series(simulated.1), Style::Line))
        .with_series(
            Series::new(
                format!("{} model", predicted.0),
                series(predicted.1),
                Style::Line,
            )
            .dashed(),
        )
}

/// Least predicted energy per cycle against cycle time for the optimised timing (waits
/// included), beside the uniform-speed plans, with the bound and the two compared plans
/// marked.
pub fn pareto_chart(found: &Optimized) -> Chart {
    let mut chart = Chart::new(
        "Energy per cycle against cycle time (predicted)",
        "Cycle time (s)",
        "Energy per cycle (J)",
    )
    .with_series(Series::new(
        "optimised timing",
        found
            .front
            .iter()
            .map(|p| (p.cycle_time_s, p.predicted_j))
            .collect(),
        Style::Line,
    ))
    .with_series(
        Series::new(
            "uniform speed",
            found
                .uniform_curve
                .iter()
                .map(|p| (p.cycle_time_s, p.predicted_j))
                .collect(),
            Style::LineMarkers,
        )
        .dashed(),
    );
    let u = &found.uniform;
    chart = chart.with_annotation(Annotation::Point {
        x: u.cycle_time_s,
        y: u.predicted_j,
        label: format!("uniform {} m/s", u.speed_m_s),
    });
    let s = &found.schedule;
    chart.with_annotation(Annotation::Point {
        x: s.cycle_time_s,
        y: s.predicted_j,
        label: "optimised".into(),
    })
}

/// Power of the signal the model predicts (DC bus or grid: clipped at zero; else the motor
/// sum) of each named twin run against time.
pub fn plan_power_chart(runs: &[(&str, &Dataset)]) -> Chart {
    let mut chart = Chart::new("Power on the twin", "Time (s)", "Power (W)");
    for (name, ds) in runs {
        let rec = &ds.truth;
        let stride = (0.01 / rec.dt).round().max(1.0) as usize;
        let signal = if ds.meta.measurement.power_signal.clipped() {
            &rec.p_grid
        } else {
            &rec.p_total
        };
        let points = rec
            .t
            .iter()
            .zip(signal)
            .step_by(stride)
            .map(|(t, p)| (*t, *p))
            .collect();
        chart = chart.with_series(Series::new(*name, points, Style::Line));
    }
    chart
}
