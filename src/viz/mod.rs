//! Rerun views of the robot, of twin runs and of results (cargo feature `viz`, on by default).
//!
//! Everything is logged after a run, in bulk: time series go out as columns
//! (`send_columns`), decimated to a display rate ([`DEFAULT_DISPLAY_HZ`]), so logging costs
//! the twin nothing while it runs. Time is the duration timeline [`TIMELINE`] (`sim_time`, s).
//!
//! # Entity tree
//! A `prefix` (e.g. `"run"`, `"table3/step6"`, `"sweep/0p5mps_4kg"`; may be empty) keeps
//! several runs apart. Names and numbers in paths go through [`path_part`]: the viewer does
//! not resolve a layout's origin with a `.` in it, so `0.5` is written `0p5`. Units are in
//! the leaf names, which are also the series names in the plots; series with a common parent
//! share a plot in the default layout.
//!
//! | entity | what | logged by |
//! |---|---|---|
//! | `{prefix}/robot` | base frame (z up), 3-D view origin | [`Viz::log_robot`], [`Viz::log_recording`] |
//! | `{prefix}/robot/base/visual_k` | base shapes | same |
//! | `{prefix}/robot/link_i/visual_k` | shapes of link `i` (1-based) in its MDH frame | same |
//! | `{prefix}/robot/link_i` | pose of link frame `i` in the base frame, on `sim_time` | same, [`Viz::log_measurement`] (the log's clock) |
//! | `{prefix}/robot/flange_path` | path of the flange origin, m (line strip) | [`Viz::log_recording`] |
//! | `{prefix}/robot/link_n/tcp` | the tool centre point, moving with the last link | [`Viz::log_task`] |
//! | `{prefix}/robot/tcp_path` | planned TCP path, m (line strip) | [`Viz::log_task`] |
//! | `{prefix}/robot/via_points` | via points, labelled (A-F of the pick and place) | [`Viz::log_task`] |
//! | `{prefix}/joints/q/q{i}_rad`, `joints/dq/dq{i}_rad_s`, `joints/tau/tau{i}_Nm` | joint signals | [`Viz::log_recording`] |
//! | `{prefix}/power/joint{i}/{simulated,measured,predicted}_W` | electrical power of motor `i`, one plot per motor | [`Viz::log_recording`], [`Viz::log_measured`], [`Viz::log_measurement`], [`Viz::log_prediction`] |
//! | `{prefix}/power/total/{simulated,grid,measured,predicted}_W` | total power, one plot | same |
//! | `{prefix}/energy/{simulated,grid,predicted}_J` | cumulative energy | [`Viz::log_recording`], [`Viz::log_prediction`] |
//! | `{prefix}/payload/mass_kg` | payload at the flange | [`Viz::log_recording`] |
//! | `{prefix}/measured/q/q{i}_rad` | logged encoder positions | [`Viz::log_measured`], [`Viz::log_measurement`] |
//! | `{prefix}/events` | text log: payload mounted, picked, released; via points reached | [`Viz::log_events`], [`Viz::log_task`] |
//! | `{root}/error_pct`, `{root}/table` | identified against true parameters: error bars (%) and a table | [`Viz::log_parameters`] |
//! | `{root}/energy_J/load_{L}kg_{twin,model}`, `{root}/table` | sweep: energy per cycle against TCP speed (timeline [`SPEED_TIMELINE`], mm/s) per load, and a table | [`Viz::log_sweep_cells`] |
//!
//! [`Viz::log_run`], [`Viz::log_sweep`] and [`Viz::log_reproduce`] log whole experiments with
//! these; [`Viz::send_blueprint`] sends a layout of [`Tab`]s (the last two send their own
//! before the data, so that a viewer opens with it).
//!
//! Mesh shapes are not loaded: each is drawn as a labelled point at its origin.

mod blueprint;
mod experiments;
mod recording;
mod results;
mod robot;
mod sink;
mod task;

use std::fmt::Display;
use std::time::Duration;

pub use blueprint::Tab;
pub use experiments::Prediction;
pub use sink::Sink;

use crate::error::{Error, Result};

/// Name of the duration timeline every time series is logged on (values in s).
pub const TIMELINE: &str = "sim_time";

/// Default display rate for [`Viz::log_recording`], Hz.
pub const DEFAULT_DISPLAY_HZ: f64 = 50.0;

/// Entity of a run's event text log under its prefix ([`Viz::log_events`]).
pub const EVENTS_ENTITY: &str = "events";

/// Name of the sequence timeline of sweep results: the commanded TCP speed, mm/s
/// ([`Viz::log_sweep_cells`]).
pub const SPEED_TIMELINE: &str = "tcp_speed_mm_s";

/// Longest time [`Viz::flush`] waits for the sinks to take the data, s.
const FLUSH_TIMEOUT_S: u64 = 60;

/// A Rerun recording stream with powertwin's entity layout (see the [module docs](self)).
#[derive(Debug)]
pub struct Viz {
    rec: rerun::RecordingStream,
}

impl Viz {
    /// Open a recording for application `app_id` (the name the viewer groups recordings by)
    /// that writes to every sink of `sinks` (at least one; e.g. spawn a viewer and save a file).
    ///
    /// Nothing listens on the network: [`Sink::Spawn`] starts a viewer (which listens on
    /// localhost) and [`Sink::Connect`] connects out to one. Fails with [`Error::Viz`] when a
    /// viewer cannot be started (the message says how to install one), a URL is not a Rerun
    /// proxy URL, or a file cannot be created.
    pub fn new(app_id: &str, sinks: &[Sink]) -> Result<Viz> {
        let app = rerun::ApplicationId::try_new(app_id).map_err(|e| {
            Error::InvalidInput(format!("'{app_id}' is not a Rerun application id: {e}"))
        })?;
        if sinks.is_empty() {
            return Err(Error::InvalidInput(
                "no Rerun sink given (spawn, connect or save)".into(),
            ));
        }
        let log_sinks = sinks
            .iter()
            .map(Sink::open)
            .collect::<Result<Vec<Box<dyn rerun::sink::LogSink>>>>()?;
        let rec = rerun::RecordingStreamBuilder::new(app)
            .set_sinks(log_sinks)
            .map_err(|e| viz_err("cannot open the recording", e))?;
        Ok(Viz { rec })
    }

    /// Wait until every sink has taken what was logged (at most 60 s). Dropping a [`Viz`]
    /// also flushes; call this to see errors.
    pub fn flush(&self) -> Result<()> {
        self.rec
            .flush_with_timeout(Duration::from_secs(FLUSH_TIMEOUT_S))
            .map_err(|e| viz_err("flushing the recording failed", e))
    }

    /// A scalar series at `path` as one column against `index`, named after the path's last
    /// part (the name shown in the plot legend).
    fn send_scalars(&self, path: &str, index: rerun::TimeColumn, values: &[f64]) -> Result<()> {
        let ctx = format!("logging {path} failed");
        let name = path.rsplit('/').next().unwrap_or(path);
        self.rec
            .log_static(path, &rerun::SeriesLines::new().with_names([name]))
            .map_err(|e| viz_err(&ctx, e))?;
        let columns = rerun::Scalars::new(values.iter().copied())
            .columns_of_unit_batches()
            .map_err(|e| viz_err(&ctx, e))?;
        self.rec
            .send_columns(path, [index], columns)
            .map_err(|e| viz_err(&ctx, e))
    }
}

/// Entity path `prefix/rest`; an empty prefix (or one of slashes only) gives `rest`.
fn entity(prefix: &str, rest: &str) -> String {
    let p = prefix.trim_matches('/');
    if p.is_empty() {
        rest.to_owned()
    } else {
        format!("{p}/{rest}")
    }
}

/// A name or number as one entity path part: [`crate::io::slug`] with `.` written `p` (e.g.
/// `0.5` gives `0p5`, `"tool + 0.5 kg"` gives `"tool_0p5_kg"`).
pub fn path_part(name: &str) -> String {
    crate::io::slug(name).replace('.', "p")
}

/// An [`Error::Viz`] with context.
fn viz_err(what: &str, e: impl Display) -> Error {
    Error::Viz(format!("{what}: {e}"))
}

#[cfg(test)]
mod tests {
    use super::{entity, path_part};

    #[test]
    fn entity_paths_join_prefixes() {
        assert_eq!(entity("", "robot"), "robot");
        assert_eq!(entity("/", "robot"), "robot");
        assert_eq!(entity("run", "robot"), "run/robot");
        assert_eq!(entity("/sweep/v50/", "power"), "sweep/v50/power");
    }

    #[test]
    fn path_parts_have_no_dots() {
        assert_eq!(path_part("0.5"), "0p5");
        assert_eq!(path_part("tool + 0.5 kg"), "tool_0p5_kg");
        assert_eq!(path_part("paper-steps"), "paper_steps");
    }
}
