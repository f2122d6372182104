//! The default viewer layout: one tab per run (the robot in 3-D beside its power and joint
//! plots) or per result (parameter errors, energy against speed).

use rerun::blueprint::{
    BarChartView, Blueprint, BlueprintActivation, ContainerLike, Grid, Horizontal, Spatial3DView,
    Tabs, TextDocumentView, TextLogView, TimePanel, TimeSeriesView, Vertical,
};

use super::{EVENTS_ENTITY, TIMELINE, Viz, entity, viz_err};
use crate::error::{Error, Result};

/// Plots per row in the grid of per-motor power plots.
const MOTOR_PLOT_COLUMNS: u32 = 3;

/// One tab of the default layout ([`Viz::send_blueprint`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Tab {
    /// A twin run logged under `prefix` ([`Viz::log_recording`] and what goes with it): the
    /// 3-D view of `{prefix}/robot` on the left; on the right the total power (simulated,
    /// grid, measured, predicted), a grid of per-motor power plots (simulated, measured,
    /// predicted), and tabs with `q`, `dq`, `tau`, energy, payload mass and the event log.
    Run {
        /// Tab title.
        title: String,
        /// Entity prefix of the run.
        prefix: String,
        /// Number of joints (one motor power plot each).
        joints: usize,
    },
    /// Parameter errors logged with [`Viz::log_parameters`] under each of `roots` (one row
    /// each: error bars beside the table that names them).
    Parameters {
        /// Tab title.
        title: String,
        /// Entity roots, one per identified model.
        roots: Vec<String>,
    },
    /// Runs of the same task compared (e.g. the uniform and the optimised plan), each logged
    /// under one of `prefixes`: their 3-D views side by side above one plot of every run's
    /// total power and one of their energies, on the shared `sim_time` timeline.
    Compare {
        /// Tab title.
        title: String,
        /// Entity prefixes of the runs, one 3-D view each.
        prefixes: Vec<String>,
    },
    /// A sweep logged with [`Viz::log_sweep_cells`] under `root`: energy against speed
    /// beside the table of cells.
    Sweep {
        /// Tab title.
        title: String,
        /// Entity root.
        root: String,
    },
}

impl Viz {
    /// Send a layout with `tabs` (the first one shown) on the `sim_time` timeline and make it
    /// active. Views of entities that were not logged stay empty.
    ///
    /// Fails with [`Error::InvalidInput`] when `tabs` is empty.
    pub fn send_blueprint(&self, tabs: &[Tab]) -> Result<()> {
        if tabs.is_empty() {
            return Err(Error::InvalidInput(
                "a layout needs at least one tab".into(),
            ));
        }
        let root = Tabs::new(tabs.iter().map(tab));
        Blueprint::new(root)
            .with_time_panel(TimePanel::new().with_timeline(TIMELINE))
            .send(&self.rec, BlueprintActivation::default())
            .map_err(|e| viz_err("sending the blueprint failed", e))
    }
}

/// The container of one tab.
fn tab(tab: &Tab) -> ContainerLike {
    match tab {
        Tab::Run {
            title,
            prefix,
            joints,
        } => run(title, prefix, *joints),
        Tab::Parameters { title, roots } => {
            Vertical::new(roots.iter().map(String::as_str).map(parameters))
                .with_name(title.as_str())
                .into()
        }
        Tab::Compare { title, prefixes } => {
            let robots = Horizontal::new(prefixes.iter().map(|p| -> ContainerLike {
                Spatial3DView::new(p.as_str())
                    .with_origin(entity(p, "robot"))
                    .into()
            }));
            let series = |name: &str, rest: &str| -> ContainerLike {
                TimeSeriesView::new(name)
                    .with_origin("/")
                    .with_contents(
                        prefixes
                            .iter()
                            .map(|p| format!("+ /{}/**", entity(p, rest))),
                    )
                    .into()
            };
            Vertical::new([
                robots.into(),
                series("total power (W)", "power/total"),
                series("energy (J)", "energy"),
            ])
            .with_row_shares([1.4, 1.0, 1.0])
            .with_name(title.as_str())
            .into()
        }
        Tab::Sweep { title, root } => {
            let views: [ContainerLike; 2] = [
                TimeSeriesView::new("energy per cycle (J) against TCP speed (mm/s)")
                    .with_origin(entity(root, "energy_J"))
                    .into(),
                TextDocumentView::new("sweep cells")
                    .with_origin(entity(root, "table"))
                    .into(),
            ];
            Horizontal::new(views)
                .with_column_shares([0.6, 0.4])
                .with_name(title.as_str())
                .into()
        }
    }
}

/// One identified model's error bars beside its table.
fn parameters(root: &str) -> ContainerLike {
    let views: [ContainerLike; 2] = [
        BarChartView::new(format!("{root}: error (%)"))
            .with_origin(entity(root, "error_pct"))
            .into(),
        TextDocumentView::new(format!("{root}: parameters"))
            .with_origin(entity(root, "table"))
            .into(),
    ];
    Horizontal::new(views).with_column_shares([0.5, 0.5]).into()
}

/// The layout of one run.
fn run(title: &str, prefix: &str, joints: usize) -> ContainerLike {
    let plot = |title: &str, rest: &str| -> ContainerLike {
        TimeSeriesView::new(title)
            .with_origin(entity(prefix, rest))
            .into()
    };
    let signals = Tabs::new([
        plot("q (rad)", "joints/q"),
        plot("dq (rad/s)", "joints/dq"),
        plot("tau (N m)", "joints/tau"),
        plot("energy (J)", "energy"),
        plot("payload (kg)", "payload"),
        TextLogView::new("events")
            .with_origin(entity(prefix, EVENTS_ENTITY))
            .into(),
    ]);
    let motors = Grid::new(
        (1..=joints).map(|j| plot(&format!("motor {j} power (W)"), &format!("power/joint{j}"))),
    )
    .with_grid_columns(MOTOR_PLOT_COLUMNS);
    let plots = Vertical::new([
        plot("total power (W)", "power/total"),
        motors.into(),
        signals.into(),
    ])
    .with_row_shares([1.0, 1.4, 1.0]);
    let robot = Spatial3DView::new("robot").with_origin(entity(prefix, "robot"));
    Horizontal::new([robot.into(), plots.into()])
        .with_column_shares([0.4, 0.6])
        .with_name(title)
        .into()
}
