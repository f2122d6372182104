//! Demo report charts with made-up numbers: energy vs TCP speed (with the optimum marked),
//! motor power vs time, and identification error per sweep cell as grouped bars. Writes
//! `energy_vs_speed`, `power_vs_time` and `error_per_cell` (`.svg` and `.png`) into DIR.
//!
//! `cargo run --release --example plot_demo -- DIR`

use std::path::PathBuf;

use powertwin::report::plot::{Annotation, Chart, Series, Style, XAxis, write_chart};

fn main() -> powertwin::Result<()> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    std::fs::create_dir_all(&dir).map_err(|e| powertwin::Error::io(&dir, e))?;

    // Task energy E(v) = standby power * path / v + losses growing with v^2 (J), per payload.
    let speeds: Vec<f64> = (2..=40).map(|i| 0.05 * i as f64).collect();
    let energy = |v: f64, m: f64| 180.0 * 0.8 / v + (40.0 + 12.0 * m) * v * v + 60.0 + 9.0 * m;
    let mut chart = Chart::new("Task energy vs TCP speed", "TCP speed (m/s)", "Energy (J)");
    for m in [0.0, 3.5, 7.0] {
        let pts = speeds.iter().map(|&v| (v, energy(v, m))).collect();
        chart = chart.with_series(Series::new(format!("payload {m} kg"), pts, Style::Line));
    }
    let measured = [0.2, 0.5, 0.8, 1.2, 1.6]
        .iter()
        .map(|&v| (v, energy(v, 3.5) * 1.04))
        .collect();
    chart = chart.with_series(Series::new("measured, 3.5 kg", measured, Style::Markers));
    let (v_opt, e_opt) = speeds
        .iter()
        .map(|&v| (v, energy(v, 3.5)))
        .fold((0.0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
    chart = chart.with_annotation(Annotation::Point {
        x: v_opt,
        y: e_opt,
        label: format!("optimum {v_opt:.2} m/s, {e_opt:.0} J"),
    });
    write_chart(&chart, &dir, "energy_vs_speed", 900, 560)?;

    // Motor power of joint 2 over a 4 s motion (W), measured and twin.
    let t: Vec<f64> = (0..=800).map(|k| k as f64 * 0.005).collect();
    let p =
        |t: f64| 350.0 * (2.0 * std::f64::consts::PI * 0.5 * t).sin() * (1.0 - (-t).exp()) + 40.0;
    let meas = t
        .iter()
        .map(|&t| (t, p(t) + 15.0 * (37.0 * t).sin()))
        .collect();
    let twin = t.iter().map(|&t| (t, p(t))).collect();
    let chart = Chart::new("Joint 2 motor power", "Time (s)", "Power (W)")
        .with_series(Series::new("measured", meas, Style::Line))
        .with_series(Series::new("twin", twin, Style::Line).dashed())
        .with_annotation(Annotation::HLine {
            y: 0.0,
            label: "regeneration below".into(),
        });
    write_chart(&chart, &dir, "power_vs_time", 900, 560)?;

    // Energy prediction error per sweep cell (%), two models.
    let cells: Vec<String> = ["0.2 m/s", "0.5 m/s", "1.0 m/s", "1.5 m/s", "2.0 m/s"]
        .iter()
        .flat_map(|v| ["0 kg", "7 kg"].map(|m| format!("{v}, {m}")))
        .collect();
    let identified: Vec<f64> = (0..cells.len())
        .map(|i| 1.5 + 0.8 * (i as f64 * 1.3).sin())
        .collect();
    let nominal: Vec<f64> = (0..cells.len())
        .map(|i| 6.0 - 3.0 * (i as f64 * 0.7).cos())
        .collect();
    let chart = Chart::new(
        "Energy prediction error per sweep cell",
        "Sweep cell",
        "Error (%)",
    )
    .with_x_axis(XAxis::Categories(cells))
    .with_series(Series::bars("identified model", &identified))
    .with_series(Series::bars("nominal model", &nominal))
    .with_annotation(Annotation::HLine {
        y: 5.0,
        label: "5 % target".into(),
    });
    write_chart(&chart, &dir, "error_per_cell", 900, 560)?;
    println!(
        "wrote energy_vs_speed, power_vs_time, error_per_cell (.svg, .png) to {}",
        dir.display()
    );
    Ok(())
}
