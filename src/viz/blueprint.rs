//! The default viewer layout: the robot in 3-D beside plots of power and joint signals.

use rerun::blueprint::{
    Blueprint, BlueprintActivation, ContainerLike, Horizontal, Spatial3DView, Tabs, TextLogView,
    TimeSeriesView, Vertical,
};

use super::{EVENTS_ENTITY, Viz, entity, viz_err};
use crate::error::Result;

impl Viz {
    /// Send the default layout for the run logged under `prefix` and make it active: left the
    /// 3-D view of `{prefix}/robot`; right the total power (simulated, grid, measured,
    /// predicted), the power per motor, and tabs with `q`, `dq`, `tau`, energy, payload mass
    /// and the event log. Views of entities that were not logged stay empty.
    pub fn send_blueprint(&self, prefix: &str) -> Result<()> {
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
            TextLogView::new("events").with_origin(EVENTS_ENTITY).into(),
        ]);
        let plots = Vertical::new([
            plot("total power (W)", "power/total"),
            plot("motor power (W)", "power/joint"),
            signals.into(),
        ]);
        let robot = Spatial3DView::new("robot").with_origin(entity(prefix, "robot"));
        let root = Horizontal::new([robot.into(), plots.into()]).with_column_shares([0.45, 0.55]);
        Blueprint::new(root)
            .send(&self.rec, BlueprintActivation::default())
            .map_err(|e| viz_err("sending the blueprint failed", e))
    }
}
