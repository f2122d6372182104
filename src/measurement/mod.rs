//! What a user has of a run: a [`Log`] of time stamps, joint positions (optionally joint
//! velocities) and power, plus the payload timeline the user knows. Nothing here can reach a
//! twin's true parameters: identification, model selection and prediction take a [`Log`],
//! never a [`crate::dataset::Dataset`], so truth is used only to score.
//!
//! A twin dataset gives its log with [`crate::dataset::Dataset::log`]; a user's own recording
//! (CSV or Parquet, any column names and units) is read into one by [`crate::measurement`]'s
//! readers: [`read::read_log`] reads CSV or Parquet with a [`columns::ColumnMap`] (or
//! powertwin's own column names, or the `ur-rtde` preset), repairs the time base
//! ([`clean`]), estimates the lag of the power behind the joints ([`lag`]) and reports all
//! it did in a [`read::ReadReport`]; [`segments`] cuts logs into time ranges or
//! rest-to-rest moves; a [`manifest::Manifest`] lists several logs, each with its own payload.
//! The column map format is documented in [`columns`] and `docs/guide/log-columns.md`.

pub mod clean;
pub mod columns;
pub mod lag;
pub mod manifest;
pub mod read;
pub mod segments;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, ensure_finite};
use crate::model::Robot;
use crate::model::payload::PayloadEvent;

/// Where the logged power was measured, which decides the structure of the power model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PowerSignal {
    /// Sum of the motors' electrical power (what ABB RobotStudio reports); negative while the
    /// motors regenerate more than they draw.
    #[default]
    Total,
    /// DC bus of the arm (`V x I`): the motor sum clipped at zero, since braking energy is
    /// burnt in the brake resistor and never returned.
    Bus,
    /// Grid side: the bus plus a constant cabinet load (the model's constant absorbs it).
    Grid,
}

impl PowerSignal {
    /// Whether the signal cannot go negative (braking energy burnt, not returned).
    pub fn clipped(self) -> bool {
        matches!(self, PowerSignal::Bus | PowerSignal::Grid)
    }

    /// Lower-case name as used on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            PowerSignal::Total => "total",
            PowerSignal::Bus => "bus",
            PowerSignal::Grid => "grid",
        }
    }
}

impl std::str::FromStr for PowerSignal {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "total" => Ok(PowerSignal::Total),
            "bus" => Ok(PowerSignal::Bus),
            "grid" => Ok(PowerSignal::Grid),
            other => Err(Error::InvalidInput(format!(
                "unknown power signal '{other}' (expected total, bus or grid)"
            ))),
        }
    }
}

/// A measured log: uniform or not, at any rate. Series are joint-major (`q_rad[i][k]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Log {
    /// Where the log came from (a file or dataset path), for messages.
    pub source: String,
    /// Robot name, when the log says (twin datasets do; user logs may not).
    pub robot: Option<String>,
    /// Sample times, s, strictly increasing.
    pub t_s: Vec<f64>,
    /// Joint positions, rad.
    pub q_rad: Vec<Vec<f64>>,
    /// Joint velocities, rad/s, when logged.
    pub dq_rad_s: Option<Vec<Vec<f64>>>,
    /// Measured power of the arm, W, of the kind `signal`.
    pub power_w: Vec<f64>,
    /// What `power_w` is.
    pub signal: PowerSignal,
    /// Electrical power of each motor, W, when logged.
    pub motor_power_w: Option<Vec<Vec<f64>>>,
    /// Whether each power sample is the mean over the preceding sample period (an
    /// integrating meter) rather than an instantaneous value.
    pub power_averaged: bool,
    /// Payloads at the flange the user knows of, sorted by time (empty: none throughout).
    pub payloads: Vec<PayloadEvent>,
}

impl Log {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Number of joints.
    pub fn dof(&self) -> usize {
        self.q_rad.len()
    }

    /// Duration from the first to the last sample, s.
    pub fn duration_s(&self) -> f64 {
        match (self.t_s.first(), self.t_s.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// Errors unless the log is of `robot`: its joint count, its robot name when it states
    /// one, joint positions that `robot` can reach ([`Log::check_positions`]) and power it
    /// can draw ([`Log::check_power`]).
    pub fn check_robot(&self, robot: &Robot) -> Result<()> {
        if self.dof() != robot.dof() {
            return Err(Error::InvalidInput(format!(
                "{}: {} joints, robot '{}' has {}",
                self.source,
                self.dof(),
                robot.name(),
                robot.dof()
            )));
        }
        if let Some(name) = &self.robot
            && name != robot.name()
        {
            return Err(Error::InvalidInput(format!(
                "{} is a log of robot '{name}', not '{}'",
                self.source,
                robot.name()
            )));
        }
        self.check_positions(robot)?;
        self.check_power(robot)
    }

    /// Errors where a joint is more than a full turn beyond its position limits: no joint
    /// angle within the limits, logged with a turn added or taken away, lies there, so the
    /// positions are in another unit (degrees) or of another joint. A continuous joint's
    /// infinite limit admits every position.
    pub fn check_positions(&self, robot: &Robot) -> Result<()> {
        const TURN: f64 = std::f64::consts::TAU;
        for (i, (j, q)) in robot.joints().iter().zip(&self.q_rad).enumerate() {
            let (lo, hi) = (j.limits.lower, j.limits.upper);
            if let Some(k) = q.iter().position(|&v| !j.limits.admits(v, TURN)) {
                return Err(Error::InvalidInput(format!(
                    "{}: joint {} ('{}') at {:.4} rad at t = {:.3} s, more than a turn beyond \
                     its limits [{lo:.4}, {hi:.4}] rad: are the positions in degrees (a column \
                     map's unit = \"deg\") or the columns in another order?",
                    self.source,
                    i + 1,
                    j.name,
                    q[k],
                    self.t_s[k]
                )));
            }
        }
        Ok(())
    }

    /// The largest power (W) `robot` can draw, by any meter: ten times its joints' peak
    /// mechanical power (effort times velocity limits, the losses at peak torque and speed
    /// being of the same order) plus 10 kW of cabinet and grid-side load. Without an effort
    /// limit on every joint, 10 MW, far beyond any serial arm.
    pub fn max_power_w(robot: &Robot) -> f64 {
        let peak: Option<f64> = robot
            .joints()
            .iter()
            .map(|j| j.limits.effort.map(|e| e * j.limits.velocity))
            .sum();
        match peak {
            Some(p) if p.is_finite() && p > 0.0 => 10.0 * p + 1e4,
            _ => 1e7,
        }
    }

    /// Errors where the logged power (the arm's, or a motor's) is beyond what `robot` can
    /// draw ([`Log::max_power_w`]): a logger glitch or a unit error, which would otherwise
    /// dominate a fit or a measured energy.
    pub fn check_power(&self, robot: &Robot) -> Result<()> {
        let bound = Self::max_power_w(robot);
        let series = std::iter::once(("power".to_string(), &self.power_w)).chain(
            self.motor_power_w
                .iter()
                .flatten()
                .enumerate()
                .map(|(i, p)| (format!("motor {} power", i + 1), p)),
        );
        for (name, p) in series {
            if let Some(k) = p.iter().position(|v| v.abs() > bound) {
                return Err(Error::InvalidInput(format!(
                    "{}: {name} {:.4e} W at t = {:.3} s is beyond anything robot '{}' can draw \
                     ({bound:.0} W: ten times its joints' effort x velocity limits, plus 10 kW): \
                     a logger glitch (drop the row) or a unit error (a column map's unit)",
                    self.source,
                    p[k],
                    self.t_s[k],
                    robot.name()
                )));
            }
        }
        Ok(())
    }

    /// Check lengths, finiteness and increasing times; errors name the log and the column.
    pub fn validate(&self) -> Result<()> {
        let m = self.len();
        let bad = |msg: String| Error::InvalidInput(format!("{}: {msg}", self.source));
        if self.q_rad.is_empty() {
            return Err(bad("no joint position columns".into()));
        }
        ensure_finite(&self.t_s, "t_s").map_err(|e| bad(e.to_string()))?;
        if let Some(k) = self.t_s.windows(2).position(|w| w[1] <= w[0]) {
            return Err(bad(format!(
                "time stamps must increase (sample {} at {} s follows {} s)",
                k + 2,
                self.t_s[k + 1],
                self.t_s[k]
            )));
        }
        let mut series: Vec<(String, &Vec<f64>)> = vec![("power_W".into(), &self.power_w)];
        for (i, q) in self.q_rad.iter().enumerate() {
            series.push((format!("q{}_rad", i + 1), q));
        }
        for (i, v) in self.dq_rad_s.iter().flatten().enumerate() {
            series.push((format!("dq{}_rad_s", i + 1), v));
        }
        for (i, p) in self.motor_power_w.iter().flatten().enumerate() {
            series.push((format!("p{}_W", i + 1), p));
        }
        for (name, s) in series {
            if s.len() != m {
                return Err(bad(format!("{name} has {} samples, t_s has {m}", s.len())));
            }
            ensure_finite(s, &name).map_err(|e| bad(e.to_string()))?;
        }
        for name in ["dq_rad_s", "motor_power_w"] {
            let count = match name {
                "dq_rad_s" => self.dq_rad_s.as_ref().map(Vec::len),
                _ => self.motor_power_w.as_ref().map(Vec::len),
            };
            if let Some(c) = count
                && c != self.dof()
            {
                return Err(bad(format!("{name} has {c} joints, q_rad {}", self.dof())));
            }
        }
        if self
            .payloads
            .iter()
            .any(|e| !e.t_s.is_finite() && e.t_s != f64::NEG_INFINITY)
            || self.payloads.windows(2).any(|w| w[1].t_s < w[0].t_s)
        {
            return Err(bad(
                "payload events must be finite and sorted by time".into()
            ));
        }
        Ok(())
    }

    /// The samples with indices `range` (times unchanged; payload events kept).
    pub fn slice(&self, range: std::ops::Range<usize>) -> Log {
        let cut = |v: &Vec<f64>| v[range.clone()].to_vec();
        Log {
            source: format!("{} [{}..{}]", self.source, range.start, range.end),
            robot: self.robot.clone(),
            t_s: cut(&self.t_s),
            q_rad: self.q_rad.iter().map(cut).collect(),
            dq_rad_s: self.dq_rad_s.as_ref().map(|d| d.iter().map(cut).collect()),
            power_w: cut(&self.power_w),
            signal: self.signal,
            motor_power_w: self
                .motor_power_w
                .as_ref()
                .map(|d| d.iter().map(cut).collect()),
            power_averaged: self.power_averaged,
            payloads: self.payloads.clone(),
        }
    }
}
