//! Annotations and results: event text log, labelled points, bar charts, generic series,
//! identified parameters (Table 2) and sweep energies (Figure 14).

use rerun::{BarChart, Points3D, TextDocument, TextLog, TimeColumn};

use super::{EVENTS_ENTITY, SPEED_TIMELINE, TIMELINE, Viz, entity, path_part, viz_err};
use crate::error::{Error, Result, ensure_finite};
use crate::validation::score::ParamRow;
use crate::validation::sweep::{Cell, distinct};

/// Display radius of labelled points, m.
const POINT_RADIUS_M: f32 = 0.01;

impl Viz {
    /// Log events `(t_s, text)` (e.g. payload pick and release) as entries of the text log
    /// `{prefix}/events` ([`EVENTS_ENTITY`]) at their times `t_s` (s) on `sim_time`.
    ///
    /// Fails with [`Error::InvalidInput`] when a time is not finite.
    pub fn log_events(&self, events: &[(f64, String)], prefix: &str) -> Result<()> {
        if events.is_empty() {
            return Ok(());
        }
        let t: Vec<f64> = events.iter().map(|e| e.0).collect();
        ensure_finite(&t, "event time")?;
        let ctx = "logging events failed";
        let columns = TextLog::update_fields()
            .with_many_text(events.iter().map(|e| e.1.clone()))
            .with_many_level(events.iter().map(|_| rerun::TextLogLevel::INFO))
            .columns_of_unit_batches()
            .map_err(|e| viz_err(ctx, e))?;
        let time = TimeColumn::new_duration_secs(TIMELINE, t);
        self.rec
            .send_columns(entity(prefix, EVENTS_ENTITY), [time], columns)
            .map_err(|e| viz_err(ctx, e))
    }

    /// Log labelled points (positions in m, base frame; e.g. the via points A-F of a task)
    /// as static entity `name` (an entity path such as `"run/robot/via_points"`; put it under
    /// `{prefix}/robot` to see it in the robot's 3-D view).
    ///
    /// Fails with [`Error::InvalidInput`] when a coordinate is not finite.
    pub fn log_points(&self, name: &str, points: &[(String, [f64; 3])]) -> Result<()> {
        let coords: Vec<f64> = points.iter().flat_map(|p| p.1).collect();
        ensure_finite(&coords, &format!("{name} coordinates"))?;
        let archetype = Points3D::new(points.iter().map(|p| p.1.map(|v| v as f32)))
            .with_labels(points.iter().map(|p| p.0.clone()))
            .with_radii([POINT_RADIUS_M]);
        self.rec
            .log_static(name, &archetype)
            .map_err(|e| viz_err(&format!("logging {name} failed"), e))
    }

    /// Log `values` as a static bar chart at entity `name`, bars in the given order (e.g.
    /// relative parameter errors in %, in the order of a parameter table; put the unit in the
    /// name, e.g. `"identification/error_pct"`).
    pub fn log_bar_chart(&self, name: &str, values: &[f64]) -> Result<()> {
        self.rec
            .log_static(name, &BarChart::new(values.to_vec()))
            .map_err(|e| viz_err(&format!("logging {name} failed"), e))
    }

    /// Log `y[k]` against integer `x[k]` on the sequence timeline `axis` as a line series at
    /// entity `name` (e.g. the energy in J against the speed in % per load:
    /// `log_series("sweep/energy_J/load_2kg", "speed_pct", ..)`; series with a common parent
    /// share a plot in the default view). The last part of `name` is the series name.
    ///
    /// Fails with [`Error::InvalidInput`] when the lengths differ or `axis` is empty.
    pub fn log_series(&self, name: &str, axis: &str, x: &[i64], y: &[f64]) -> Result<()> {
        if x.len() != y.len() {
            return Err(Error::InvalidInput(format!(
                "series {name}: {} x values but {} y values",
                x.len(),
                y.len()
            )));
        }
        let axis = rerun::TimelineName::try_new(axis).map_err(|e| {
            Error::InvalidInput(format!(
                "series {name}: '{axis}' is not a timeline name: {e}"
            ))
        })?;
        self.send_scalars(name, TimeColumn::new_sequence(axis, x.iter().copied()), y)
    }

    /// Log identified against true parameters (Table 2 rows) under `root` (e.g.
    /// `"identification/paper-steps"`): a static bar chart of the errors in % in row order
    /// (`{root}/error_pct`; 0 where the truth is zero) and a Markdown table naming each bar
    /// (`{root}/table`).
    pub fn log_parameters(&self, root: &str, rows: &[ParamRow]) -> Result<()> {
        let errors: Vec<f64> = rows.iter().map(|r| r.error_pct.unwrap_or(0.0)).collect();
        self.log_bar_chart(&entity(root, "error_pct"), &errors)?;
        let mut md = String::from(
            "| bar | parameter | identified | truth | error % | rel. std % |\n\
             |---:|---|---:|---:|---:|---:|\n",
        );
        let error = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:+.3}"));
        let std = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.3}"));
        for (k, r) in rows.iter().enumerate() {
            md.push_str(&format!(
                "| {k} | {} | {:.6e} | {:.6e} | {} | {} |\n",
                r.name,
                r.identified,
                r.truth,
                error(r.error_pct),
                std(r.rel_std_pct)
            ));
        }
        self.log_text(&entity(root, "table"), &md)
    }

    /// Log a speed x load sweep under `root` (e.g. `"sweep"`): per load `L`, the energy per cycle
    /// of the twin (`{root}/energy_J/load_{L}kg_twin`, e.g. `load_0p5kg_twin`) and of the model
    /// where predicted (`..._model`), J, against the commanded TCP speed in mm/s on the sequence
    /// timeline [`SPEED_TIMELINE`] (select it in the viewer's time panel to see the plot); and a
    /// Markdown table of the cells (`{root}/table`).
    pub fn log_sweep_cells(&self, root: &str, cells: &[Cell]) -> Result<()> {
        let mm_s = |c: &Cell| (c.speed_m_s * 1000.0).round() as i64;
        for load in distinct(cells, |c| c.load_kg) {
            let mut row: Vec<&Cell> = cells.iter().filter(|c| c.load_kg == load).collect();
            row.sort_by(|a, b| a.speed_m_s.total_cmp(&b.speed_m_s));
            let x: Vec<i64> = row.iter().map(|c| mm_s(c)).collect();
            let twin: Vec<f64> = row.iter().map(|c| c.simulated_j).collect();
            let kg = path_part(&load.to_string());
            let name = |what: &str| entity(root, &format!("energy_J/load_{kg}kg_{what}"));
            self.log_series(&name("twin"), SPEED_TIMELINE, &x, &twin)?;
            let (xp, model): (Vec<i64>, Vec<f64>) = row
                .iter()
                .filter_map(|c| c.predicted_j.map(|e| (mm_s(c), e)))
                .unzip();
            if !model.is_empty() {
                self.log_series(&name("model"), SPEED_TIMELINE, &xp, &model)?;
            }
        }
        let mut md = format!(
            "Energy per cycle against TCP speed: select the timeline `{SPEED_TIMELINE}` in the \
             time panel to see the plot.\n\n\
             | speed m/s | load kg | cycle s | twin J | model J | error % | slowed segments |\n\
             |---:|---:|---:|---:|---:|---:|---:|\n"
        );
        let opt = |v: Option<f64>, f: &dyn Fn(f64) -> String| v.map_or("-".to_owned(), f);
        for c in cells {
            md.push_str(&format!(
                "| {} | {} | {:.3} | {:.2} | {} | {} | {} |\n",
                c.speed_m_s,
                c.load_kg,
                c.cycle_time_s,
                c.simulated_j,
                opt(c.predicted_j, &|e| format!("{e:.2}")),
                opt(c.error_pct, &|e| format!("{e:+.3}")),
                c.slowed.len()
            ));
        }
        self.log_text(&entity(root, "table"), &md)
    }

    /// A static Markdown document at `path`.
    fn log_text(&self, path: &str, markdown: &str) -> Result<()> {
        self.rec
            .log_static(path, &TextDocument::from_markdown(markdown))
            .map_err(|e| viz_err(&format!("logging {path} failed"), e))
    }
}
