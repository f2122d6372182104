//! A planned task in the robot's 3-D view: via points, the tool centre point and its path,
//! and what happens when (payloads mounted, picked and released; via points reached).

use nalgebra::Isometry3;
use rerun::{LineStrips3D, Points3D};

use super::recording::decimated_rows;
use super::{Viz, entity, viz_err};
use crate::error::{Error, Result};
use crate::kinematics::fk::tcp_pose;
use crate::model::Robot;
use crate::model::payload::Payload;
use crate::model::payload::PayloadEvent;
use crate::trajectory::Trajectory;
use crate::trajectory::task::TaskRun;

/// Radius of the planned TCP path line, m.
const TCP_PATH_RADIUS_M: f32 = 0.0015;

/// Display radius of the TCP marker, m.
const TCP_RADIUS_M: f32 = 0.012;

impl Viz {
    /// Log the plan `run` of a task under `prefix`, for a run logged there with
    /// [`Viz::log_recording`]: its via points, labelled by name, at their TCP positions
    /// (`robot/via_points`, base frame, m); the tool centre point as a labelled point moving
    /// with the last link (`robot/link_n/tcp`; `tcp` is its pose in the flange frame, m); the
    /// planned TCP path sampled at `display_hz` (`robot/tcp_path`); and the event log
    /// (`events`): every payload event of the plan (mounted, picked, released, with the
    /// mass at the flange, [`Viz::log_payload_events`]) and every via point reached, at
    /// their times on `sim_time`.
    ///
    /// Fails with [`Error::InvalidInput`] when `display_hz` is not positive and finite or a
    /// position or time is not finite, and with [`Error::Numerical`] when the plan's duration
    /// is not finite and non-negative.
    pub fn log_task(
        &self,
        robot: &Robot,
        run: &TaskRun,
        tcp: &Isometry3<f64>,
        prefix: &str,
        display_hz: f64,
    ) -> Result<()> {
        let mut names: Vec<&str> = Vec::new();
        let mut points = Vec::new();
        for v in &run.via {
            if !names.contains(&v.name.as_str()) {
                names.push(&v.name);
                points.push((v.name.clone(), [v.tcp_m.x, v.tcp_m.y, v.tcp_m.z]));
            }
        }
        self.log_points(&entity(prefix, "robot/via_points"), &points)?;

        let n = robot.dof();
        let marker_path = entity(prefix, &format!("robot/link_{n}/tcp"));
        let marker = super::robot::translation(&(robot.flange() * tcp));
        self.rec
            .log_static(
                marker_path.as_str(),
                &Points3D::new([marker])
                    .with_labels(["TCP"])
                    .with_radii([TCP_RADIUS_M]),
            )
            .map_err(|e| viz_err(&format!("logging {marker_path} failed"), e))?;

        let traj = &run.motion.trajectory;
        let duration = run.motion.duration_s;
        if !(duration.is_finite() && duration >= 0.0) {
            return Err(Error::Numerical(format!(
                "the plan lasts {duration} s; expected a finite, non-negative duration"
            )));
        }
        // Rows of a 1 ms grid shown at the display rate, plus the end of the motion.
        let grid_dt = 1e-3;
        let rows = decimated_rows(
            (duration / grid_dt).floor() as usize + 1,
            grid_dt,
            display_hz,
        )?;
        let mut times: Vec<f64> = rows.iter().map(|&k| k as f64 * grid_dt).collect();
        if times.last().is_some_and(|&t| t < duration) {
            times.push(duration);
        }
        let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let path: Vec<[f32; 3]> = times
            .iter()
            .map(|&t| {
                traj.sample(t, &mut q, &mut dq, &mut ddq);
                super::robot::translation(&tcp_pose(robot, &q, tcp))
            })
            .collect();
        let path_entity = entity(prefix, "robot/tcp_path");
        self.rec
            .log_static(
                path_entity.as_str(),
                &LineStrips3D::new([path]).with_radii([TCP_PATH_RADIUS_M]),
            )
            .map_err(|e| viz_err(&format!("logging {path_entity} failed"), e))?;

        self.log_payload_events(&run.events, prefix)?;
        let reached: Vec<(f64, String)> = run
            .via
            .iter()
            .skip(1)
            .map(|v| (v.arrival_s, format!("reached {}", v.name)))
            .collect();
        self.log_events(&reached, prefix)
    }

    /// Log payload events (what the flange carries from when) as entries of the event log
    /// `{prefix}/events`: the first is the mounting, later ones are picks or releases by
    /// whether the mass at the flange grows or shrinks; each names the payload and its mass.
    ///
    /// Fails with [`Error::InvalidInput`] when a time is not finite.
    pub fn log_payload_events(&self, events: &[PayloadEvent], prefix: &str) -> Result<()> {
        let mass = |p: &Option<Payload>| p.as_ref().map_or(0.0, |p| p.inertia.mass);
        let mut before: Option<f64> = None;
        let text: Vec<(f64, String)> = events
            .iter()
            .map(|e| {
                let m = mass(&e.payload);
                let carried = match &e.payload {
                    Some(p) => format!("{} ({m:.3} kg) at the flange", p.name),
                    None => "nothing at the flange".to_owned(),
                };
                let what = match before {
                    None => "mounted",
                    Some(b) if m > b => "picked",
                    Some(b) if m < b => "released",
                    Some(_) => "changed",
                };
                before = Some(m);
                (e.t_s, format!("payload {what}: {carried}"))
            })
            .collect();
        self.log_events(&text, prefix)
    }
}
