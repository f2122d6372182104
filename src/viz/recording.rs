//! Twin runs as time series: the simulated truth ([`Recording`]), the logged measurements
//! ([`Measured`]) and a model's predicted power, on the `sim_time` timeline.

use nalgebra::Isometry3;
use rerun::{LineStrips3D, TimeColumn};

use super::{TIMELINE, Viz, entity, viz_err};
use crate::error::{Error, Result, ensure_finite};
use crate::kinematics::fk::{flange_pose, link_poses};
use crate::measurement::Log;
use crate::model::Robot;
use crate::twin::record::{Measured, Recording};

/// Radius of the flange path line, m.
const PATH_RADIUS_M: f32 = 0.002;

impl Viz {
    /// Log a twin run under `prefix`, decimated to `display_hz` (Hz, e.g.
    /// [`super::DEFAULT_DISPLAY_HZ`]; every `round(1 / (dt display_hz))`-th row from the
    /// first): the robot's shapes and moving links (forward kinematics of `rec.q`), the
    /// flange path, `q`, `dq`, `tau` per joint, electrical power per motor, total and grid
    /// power, cumulative motor and grid energy (J, integrated at the full rate up to each
    /// displayed row) and the payload mass.
    ///
    /// Fails with [`Error::InvalidInput`] when the recording is empty, its series do not
    /// match the robot's joint count or its own length, or `display_hz` or `rec.dt` is not
    /// positive and finite.
    pub fn log_recording(
        &self,
        robot: &Robot,
        rec: &Recording,
        prefix: &str,
        display_hz: f64,
    ) -> Result<()> {
        check_recording(robot, rec)?;
        let rows = decimated_rows(rec.len(), rec.dt, display_hz)?;
        let t: Vec<f64> = rows.iter().map(|&k| rec.t[k]).collect();

        self.log_geometry(robot, prefix)?;
        let n = robot.dof();
        let mut q = vec![0.0; n];
        let mut frame = vec![Isometry3::identity(); n];
        let mut links = vec![Vec::with_capacity(rows.len()); n];
        let mut flange = Vec::with_capacity(rows.len());
        for &k in &rows {
            for (qi, series) in q.iter_mut().zip(&rec.q) {
                *qi = series[k];
            }
            link_poses(robot, &q, &mut frame);
            for (l, p) in links.iter_mut().zip(&frame) {
                l.push(*p);
            }
            flange.push(super::robot::translation(&flange_pose(robot, &q)));
        }
        self.log_link_poses(prefix, &t, &links)?;
        let path = entity(prefix, "robot/flange_path");
        self.rec
            .log_static(
                path.as_str(),
                &LineStrips3D::new([flange]).with_radii([PATH_RADIUS_M]),
            )
            .map_err(|e| viz_err(&format!("logging {path} failed"), e))?;

        let pick = |series: &[f64]| rows.iter().map(|&k| series[k]).collect::<Vec<f64>>();
        for i in 0..n {
            let j = i + 1;
            let per_joint = [
                (format!("joints/q/q{j}_rad"), &rec.q[i]),
                (format!("joints/dq/dq{j}_rad_s"), &rec.dq[i]),
                (format!("joints/tau/tau{j}_Nm"), &rec.tau[i]),
                (format!("power/joint{j}/simulated_W"), &rec.p_elec[i]),
            ];
            for (name, series) in per_joint {
                self.log_scalars(&entity(prefix, &name), &t, &pick(series))?;
            }
        }
        let energy = |p: &[f64]| {
            let mut e = 0.0;
            let cumulative: Vec<f64> = p
                .iter()
                .map(|pk| {
                    let before = e;
                    e += pk * rec.dt;
                    before
                })
                .collect();
            pick(&cumulative)
        };
        let totals = [
            ("power/total/simulated_W", pick(&rec.p_total)),
            ("power/total/grid_W", pick(&rec.p_grid)),
            ("energy/simulated_J", energy(&rec.p_total)),
            ("energy/grid_J", energy(&rec.p_grid)),
            ("payload/mass_kg", pick(&rec.payload_mass)),
        ];
        for (name, values) in totals {
            self.log_scalars(&entity(prefix, name), &t, &values)?;
        }
        Ok(())
    }

    /// Log measurements under `prefix` at their own rate: encoder positions
    /// (`measured/q/q{i}_rad`), per-motor power next to the simulated one
    /// (`power/joint{i}/measured_W`) and the meter's total power (`power/total/measured_W`).
    ///
    /// Fails with [`Error::InvalidInput`] when a series does not have one value per sample
    /// time or the times are not finite.
    pub fn log_measured(&self, m: &Measured, prefix: &str) -> Result<()> {
        ensure_finite(&m.t, "measured t")?;
        let len = m.t.len();
        let bad =
            m.q.iter()
                .chain(&m.p_joint)
                .chain([&m.p_total])
                .any(|s| s.len() != len);
        if bad || m.q.len() != m.p_joint.len() {
            return Err(Error::InvalidInput(format!(
                "measured series must all have {len} samples and one per joint ({} q, {} power)",
                m.q.len(),
                m.p_joint.len()
            )));
        }
        for (j, (q, p)) in (1..).zip(m.q.iter().zip(&m.p_joint)) {
            self.log_scalars(&entity(prefix, &format!("measured/q/q{j}_rad")), &m.t, q)?;
            self.log_scalars(
                &entity(prefix, &format!("power/joint{j}/measured_W")),
                &m.t,
                p,
            )?;
        }
        self.log_scalars(&entity(prefix, "power/total/measured_W"), &m.t, &m.p_total)
    }

    /// Log a measured log (a user's robot or a twin dataset read as one) under `prefix` at its
    /// own rate, on the log's clock: the robot's shapes and moving links (forward kinematics
    /// of the logged positions), the positions (`measured/q/q{i}_rad`), the logged power of
    /// its signal (`power/total/measured_W`: motor sum, DC bus or grid, as the log says) and,
    /// when logged, each motor's (`power/joint{i}/measured_W`).
    ///
    /// Fails with [`Error::InvalidInput`] when the log is not valid ([`Log::validate`]) or
    /// not of the robot ([`Log::check_robot`]).
    pub fn log_measurement(&self, robot: &Robot, log: &Log, prefix: &str) -> Result<()> {
        log.validate()?;
        log.check_robot(robot)?;
        self.log_geometry(robot, prefix)?;
        let n = robot.dof();
        let mut q = vec![0.0; n];
        let mut frame = vec![Isometry3::identity(); n];
        let mut links = vec![Vec::with_capacity(log.len()); n];
        for k in 0..log.len() {
            for (qi, series) in q.iter_mut().zip(&log.q_rad) {
                *qi = series[k];
            }
            link_poses(robot, &q, &mut frame);
            for (l, p) in links.iter_mut().zip(&frame) {
                l.push(*p);
            }
        }
        self.log_link_poses(prefix, &log.t_s, &links)?;
        for (j, series) in (1..).zip(&log.q_rad) {
            self.log_scalars(
                &entity(prefix, &format!("measured/q/q{j}_rad")),
                &log.t_s,
                series,
            )?;
        }
        for (j, series) in (1..).zip(log.motor_power_w.iter().flatten()) {
            self.log_scalars(
                &entity(prefix, &format!("power/joint{j}/measured_W")),
                &log.t_s,
                series,
            )?;
        }
        self.log_scalars(
            &entity(prefix, "power/total/measured_W"),
            &log.t_s,
            &log.power_w,
        )
    }

    /// Log a model's predicted power under `prefix` at times `t` (s, increasing), next to the
    /// simulated power: per motor `p_joint[i][k]` (W) as `power/joint{i+1}/predicted_W`, their
    /// sum as `power/total/predicted_W`, and the cumulative predicted energy from `t[0]`
    /// (trapezoidal rule over `t`, J) as `energy/predicted_J`.
    ///
    /// Fails with [`Error::InvalidInput`] when there are no joints, a series does not have
    /// one value per time, or the times are not finite and increasing.
    pub fn log_prediction(&self, t: &[f64], p_joint: &[Vec<f64>], prefix: &str) -> Result<()> {
        ensure_finite(t, "prediction t")?;
        if t.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::InvalidInput("prediction times must increase".into()));
        }
        if p_joint.is_empty() {
            return Err(Error::InvalidInput(
                "a prediction needs at least one joint".into(),
            ));
        }
        if let Some(i) = p_joint.iter().position(|p| p.len() != t.len()) {
            return Err(Error::InvalidInput(format!(
                "{} prediction times but {} powers for joint {}",
                t.len(),
                p_joint[i].len(),
                i + 1
            )));
        }
        let total: Vec<f64> = (0..t.len())
            .map(|k| p_joint.iter().fold(0.0, |s, p| s + p[k]))
            .collect();
        let mut e = 0.0;
        let energy: Vec<f64> = (0..t.len())
            .map(|k| {
                if k > 0 {
                    e += 0.5 * (total[k - 1] + total[k]) * (t[k] - t[k - 1]);
                }
                e
            })
            .collect();
        for (j, p) in (1..).zip(p_joint) {
            self.log_scalars(
                &entity(prefix, &format!("power/joint{j}/predicted_W")),
                t,
                p,
            )?;
        }
        self.log_scalars(&entity(prefix, "power/total/predicted_W"), t, &total)?;
        self.log_scalars(&entity(prefix, "energy/predicted_J"), t, &energy)
    }

    /// One scalar series on `sim_time` (times in s) as a column.
    fn log_scalars(&self, path: &str, t_s: &[f64], values: &[f64]) -> Result<()> {
        let time = TimeColumn::new_duration_secs(TIMELINE, t_s.iter().copied());
        self.send_scalars(path, time, values)
    }
}

/// Rows kept when showing `len` rows `dt` s apart at `display_hz`: every `s`-th from row 0,
/// `s = max(1, round(1 / (dt display_hz)))`.
pub(super) fn decimated_rows(len: usize, dt: f64, display_hz: f64) -> Result<Vec<usize>> {
    if !(display_hz.is_finite() && display_hz > 0.0) {
        return Err(Error::InvalidInput(format!(
            "display rate {display_hz} Hz must be positive and finite"
        )));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::InvalidInput(format!(
            "recording step dt = {dt} s must be positive and finite"
        )));
    }
    let stride = (1.0 / (dt * display_hz)).round().max(1.0);
    let stride = if stride < len as f64 {
        stride as usize
    } else {
        len.max(1)
    };
    Ok((0..len).step_by(stride).collect())
}

/// A recording's series fit the robot and each other.
fn check_recording(robot: &Robot, rec: &Recording) -> Result<()> {
    let (n, len) = (robot.dof(), rec.len());
    if len == 0 {
        return Err(Error::InvalidInput("the recording is empty".into()));
    }
    ensure_finite(&rec.t, "recording t")?;
    let per_joint = [
        ("q", &rec.q),
        ("dq", &rec.dq),
        ("tau", &rec.tau),
        ("p_elec", &rec.p_elec),
    ];
    for (what, series) in per_joint {
        if series.len() != n {
            return Err(Error::InvalidInput(format!(
                "recording {what} has {} joints, the robot {n}",
                series.len()
            )));
        }
        if let Some(i) = series.iter().position(|s| s.len() != len) {
            return Err(Error::InvalidInput(format!(
                "recording {what}{} has {} rows, t has {len}",
                i + 1,
                series[i].len()
            )));
        }
    }
    let totals = [
        ("p_total", &rec.p_total),
        ("p_grid", &rec.p_grid),
        ("payload_mass", &rec.payload_mass),
    ];
    for (what, series) in totals {
        if series.len() != len {
            return Err(Error::InvalidInput(format!(
                "recording {what} has {} rows, t has {len}",
                series.len()
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::decimated_rows;

    #[test]
    fn decimation_keeps_every_stride_th_row_from_the_first() {
        // 1 kHz shown at 50 Hz: every 20th row.
        let rows = decimated_rows(2001, 1e-3, 50.0).unwrap();
        assert_eq!(rows.len(), 101);
        assert_eq!(rows[1], 20);
        // Display faster than the data: every row.
        assert_eq!(decimated_rows(7, 0.1, 50.0).unwrap().len(), 7);
        // Display slower than the whole run: the first row only.
        assert_eq!(decimated_rows(10, 1e-3, 0.01).unwrap(), vec![0]);
        assert!(decimated_rows(10, 1e-3, 0.0).is_err());
        assert!(decimated_rows(10, f64::NAN, 50.0).is_err());
    }
}
