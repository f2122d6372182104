//! Annotations and results: event text log, labelled points, bar charts and generic series
//! (identification errors, sweeps).

use rerun::{BarChart, Points3D, TextLog, TimeColumn};

use super::{EVENTS_ENTITY, TIMELINE, Viz, viz_err};
use crate::error::{Error, Result, ensure_finite};

/// Display radius of labelled points, m.
const POINT_RADIUS_M: f32 = 0.01;

impl Viz {
    /// Log events (e.g. payload pick and release) as text entries of the [`EVENTS_ENTITY`]
    /// log at their times `t_s` (s) on `sim_time`.
    ///
    /// Fails with [`Error::InvalidInput`] when a time is not finite.
    pub fn log_events(&self, events: &[(f64, String)]) -> Result<()> {
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
            .send_columns(EVENTS_ENTITY, [time], columns)
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
}
