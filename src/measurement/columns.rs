//! Column maps: which columns of a user's log hold time, joint positions, joint velocities
//! and power, and in which units.
//!
//! A map is a small TOML file (`--columns MAP.toml`); every key but the column names has a
//! default. Units are converted to SI on reading (s, rad, rad/s, W).
//!
//! ```toml
//! # Optional: the CSV field delimiter (default: sniffed from the header, one of , ; tab space).
//! delimiter = ","
//!
//! [time]
//! column = "stamp"
//! unit = "ms"            # s | ms | us | ns (numbers, any origin, e.g. Unix time) | iso8601
//!
//! [joints]
//! position = ["j1", "j2", "j3", "j4", "j5", "j6"]
//! position_unit = "deg"  # rad | deg
//! velocity = ["v1", "v2", "v3", "v4", "v5", "v6"]   # optional
//! velocity_unit = "deg/s"                           # rad/s | deg/s
//! wrapped = [6]          # joints (1-based) logged modulo 2 pi: jumps of ~2 pi are unwrapped
//!
//! [power]
//! signal = "bus"         # per-motor | total | bus | grid (overridden by --power)
//! column = "P_kW"        # one column ...
//! unit = "kW"            # W | kW
//! # motors = ["p1", "p2", "p3", "p4", "p5", "p6"]   # ... or one per motor (total = sum) ...
//! # voltage = "U_V"                                  # ... or voltage x current
//! # current = "I_A"
//!
//! [clean]                # all optional; the defaults are shown
//! drop_missing = false   # rows with an empty or NaN cell: error (false) or dropped, counted
//! max_gap_periods = 5.0  # a step longer than this times the median period is a gap
//! on_gap = "split"       # split | error
//! min_piece_samples = 20 # pieces between gaps shorter than this are dropped, counted
//! working_rate_hz = 100.0 # faster logs are block-averaged down to at most this rate
//! max_lag_s = 2.0        # search range of the power-vs-joint lag estimate, s
//! rest_speed_rad_s = 0.02 # every joint slower than this: at rest
//! long_rest_s = 5.0      # rests at least this long are reported
//! ```
//!
//! Without a map, a log in powertwin's own names is read as is: `t_s`, `q1_rad..qn_rad`,
//! optional `dq1_rad_s..`, and `P_total_W` (or `p_total_W`) and/or `p_elec1_W..p_elecn_W`
//! (per motor; total = their sum). The built-in preset [`UR_RTDE`] (`--columns ur-rtde`)
//! reads Universal Robots RTDE recordings.

use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::measurement::PowerSignal;

/// Name of the Universal Robots RTDE preset: `timestamp` (s), `actual_q_0..5` (rad),
/// `actual_qd_0..5` (rad/s), power = `actual_robot_voltage` (V) x `actual_robot_current` (A),
/// the arm's 48 V DC bus (signal `bus`).
pub const UR_RTDE: &str = "ur-rtde";

/// Unit of the time column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub enum TimeUnit {
    /// Seconds (any origin, Unix time included).
    #[serde(rename = "s")]
    S,
    /// Milliseconds.
    #[serde(rename = "ms")]
    Ms,
    /// Microseconds.
    #[serde(rename = "us")]
    Us,
    /// Nanoseconds (e.g. int64 Unix timestamps).
    #[serde(rename = "ns")]
    Ns,
    /// ISO-8601 date-time text, `YYYY-MM-DD[T ]hh:mm:ss[.fff][Z|+hh:mm|-hh:mm]` (no zone: UTC).
    #[serde(rename = "iso8601")]
    Iso8601,
}

impl TimeUnit {
    /// Seconds per unit of a numeric time column (1 for ISO-8601, parsed to seconds).
    pub fn seconds(self) -> f64 {
        match self {
            TimeUnit::S | TimeUnit::Iso8601 => 1.0,
            TimeUnit::Ms => 1e-3,
            TimeUnit::Us => 1e-6,
            TimeUnit::Ns => 1e-9,
        }
    }
}

/// Unit of joint positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
pub enum AngleUnit {
    /// Radians.
    #[default]
    #[serde(rename = "rad")]
    Rad,
    /// Degrees.
    #[serde(rename = "deg")]
    Deg,
}

/// Unit of joint velocities.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
pub enum RateUnit {
    /// Radians per second.
    #[default]
    #[serde(rename = "rad/s")]
    RadS,
    /// Degrees per second.
    #[serde(rename = "deg/s")]
    DegS,
}

/// Unit of a power column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
pub enum PowerUnit {
    /// Watts.
    #[default]
    W,
    /// Kilowatts.
    #[serde(rename = "kW")]
    KW,
}

/// What the logged power is (`--power`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PowerKind {
    /// One column per motor (electrical power, W); the total is their sum.
    PerMotor,
    /// Sum of the motors' electrical power (may go negative while braking).
    Total,
    /// DC bus of the arm (`V x I`, never negative: braking energy is burnt).
    Bus,
    /// Grid side (the bus plus a constant cabinet load).
    Grid,
}

impl PowerKind {
    /// The signal of the total power this kind gives (`per-motor` sums to `total`).
    pub fn signal(self) -> PowerSignal {
        match self {
            PowerKind::PerMotor | PowerKind::Total => PowerSignal::Total,
            PowerKind::Bus => PowerSignal::Bus,
            PowerKind::Grid => PowerSignal::Grid,
        }
    }
}

impl std::str::FromStr for PowerKind {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "per-motor" => Ok(PowerKind::PerMotor),
            "total" => Ok(PowerKind::Total),
            "bus" => Ok(PowerKind::Bus),
            "grid" => Ok(PowerKind::Grid),
            other => Err(Error::InvalidInput(format!(
                "unknown power kind '{other}' (expected per-motor, total, bus or grid)"
            ))),
        }
    }
}

/// What to do at a gap (a step longer than `max_gap_periods` median periods).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GapPolicy {
    /// Split the log into gap-free pieces, each its own [`crate::measurement::Log`].
    #[default]
    Split,
    /// Refuse the log, naming the row after the gap.
    Error,
}

/// `[time]`: the time column.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeSpec {
    /// Column name.
    pub column: String,
    /// Unit (default s).
    #[serde(default = "default_time_unit")]
    pub unit: TimeUnit,
}

fn default_time_unit() -> TimeUnit {
    TimeUnit::S
}

/// `[joints]`: joint position (and optionally velocity) columns, joint 1 first.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// Position columns, one per joint.
    pub position: Vec<String>,
    /// Unit of the positions (default rad).
    #[serde(default)]
    pub position_unit: AngleUnit,
    /// Velocity columns, one per joint (optional).
    #[serde(default)]
    pub velocity: Option<Vec<String>>,
    /// Unit of the velocities (default rad/s).
    #[serde(default)]
    pub velocity_unit: RateUnit,
    /// Joints (1-based) whose positions are logged modulo 2 pi: jumps of more than pi
    /// between samples are unwrapped (counted in the report).
    #[serde(default)]
    pub wrapped: Vec<usize>,
}

/// `[power]`: one column, one column per motor, or voltage x current.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PowerSpec {
    /// What the power is (default: `per-motor` with only motor columns, else `total`).
    #[serde(default)]
    pub signal: Option<PowerKind>,
    /// One power column.
    #[serde(default)]
    pub column: Option<String>,
    /// One electrical power column per motor, joint 1 first.
    #[serde(default)]
    pub motors: Option<Vec<String>>,
    /// Unit of `column` and `motors` (default W).
    #[serde(default)]
    pub unit: PowerUnit,
    /// Voltage column, V (power = voltage x current).
    #[serde(default)]
    pub voltage: Option<String>,
    /// Current column, A.
    #[serde(default)]
    pub current: Option<String>,
}

/// `[clean]`: how a messy log is repaired (see [`crate::measurement::clean`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CleanOptions {
    /// Drop rows with an empty or NaN cell (counted) instead of refusing the log.
    pub drop_missing: bool,
    /// A time step longer than this many median periods is a gap (> 1).
    pub max_gap_periods: f64,
    /// What to do at a gap.
    pub on_gap: GapPolicy,
    /// Gap-free pieces with fewer samples are dropped (counted).
    pub min_piece_samples: usize,
    /// Logs faster than this, Hz, are block-averaged down to at most this rate.
    pub working_rate_hz: f64,
    /// Largest lag searched between the power and joint streams, s.
    pub max_lag_s: f64,
    /// Every joint slower than this, rad/s: at rest.
    pub rest_speed_rad_s: f64,
    /// Rests at least this long, s, are reported.
    pub long_rest_s: f64,
    /// Replace jittered stamps of a fixed-rate logger by their uniform grid, unless the
    /// positions are clearly smoother against the stamps as logged (a logger that samples
    /// at the uneven times it stamps; see [`crate::measurement::clean::regularize`]).
    pub regularize_jitter: bool,
    /// Largest stamp deviation from the grid, in sample periods, for that.
    pub max_jitter_periods: f64,
}

impl Default for CleanOptions {
    fn default() -> Self {
        CleanOptions {
            drop_missing: false,
            max_gap_periods: 5.0,
            on_gap: GapPolicy::Split,
            min_piece_samples: 20,
            working_rate_hz: 100.0,
            max_lag_s: 2.0,
            rest_speed_rad_s: 0.02,
            long_rest_s: 5.0,
            regularize_jitter: true,
            max_jitter_periods: 0.25,
        }
    }
}

impl CleanOptions {
    /// Check the values are usable.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::InvalidInput(format!("[clean] {m}")));
        if !(self.max_gap_periods.is_finite() && self.max_gap_periods > 1.0) {
            return bad(format!(
                "max_gap_periods = {} must be finite and > 1",
                self.max_gap_periods
            ));
        }
        if !(self.working_rate_hz.is_finite() && self.working_rate_hz > 0.0) {
            return bad(format!(
                "working_rate_hz = {} must be finite and > 0",
                self.working_rate_hz
            ));
        }
        for (name, v) in [
            ("max_lag_s", self.max_lag_s),
            ("rest_speed_rad_s", self.rest_speed_rad_s),
            ("long_rest_s", self.long_rest_s),
            ("max_jitter_periods", self.max_jitter_periods),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} = {v} must be finite and >= 0"));
            }
        }
        if self.min_piece_samples < 2 {
            return bad("min_piece_samples must be at least 2".into());
        }
        Ok(())
    }
}

/// A column map (see the module docs for the TOML format).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnMap {
    /// CSV field delimiter (default: sniffed from the header line).
    #[serde(default)]
    pub delimiter: Option<char>,
    /// Time column.
    pub time: TimeSpec,
    /// Joint columns.
    pub joints: JointSpec,
    /// Power columns.
    pub power: PowerSpec,
    /// Cleaning options.
    #[serde(default)]
    pub clean: CleanOptions,
}

/// How the power is formed from the columns, resolved from a [`PowerSpec`].
#[derive(Debug, Clone, PartialEq)]
pub enum PowerSource {
    /// One column times `scale` (W per unit).
    Column {
        /// Column name.
        name: String,
        /// W per unit of the column.
        scale: f64,
    },
    /// Voltage (V) times current (A).
    VoltageCurrent {
        /// Voltage column.
        voltage: String,
        /// Current column.
        current: String,
    },
    /// Sum of the motor columns.
    MotorSum,
}

impl ColumnMap {
    /// Parse a map from TOML text; `label` names it in errors.
    pub fn from_toml_str(text: &str, label: &str) -> Result<ColumnMap> {
        let map: ColumnMap = toml::from_str(text).map_err(|e| Error::Toml {
            file: label.to_string(),
            message: e.to_string(),
        })?;
        map.validate()
            .map_err(|e| Error::InvalidInput(format!("{label}: {e}")))?;
        Ok(map)
    }

    /// Read a map from a TOML file, or the built-in preset of that name ([`UR_RTDE`]).
    pub fn load(name_or_path: &str) -> Result<ColumnMap> {
        if name_or_path == UR_RTDE {
            return Ok(ColumnMap::ur_rtde());
        }
        let path = Path::new(name_or_path);
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        ColumnMap::from_toml_str(&text, name_or_path)
    }

    /// The Universal Robots RTDE preset ([`UR_RTDE`]).
    pub fn ur_rtde() -> ColumnMap {
        let cols = |stem: &str| (0..6).map(|i| format!("{stem}_{i}")).collect::<Vec<_>>();
        ColumnMap {
            delimiter: None,
            time: TimeSpec {
                column: "timestamp".into(),
                unit: TimeUnit::S,
            },
            joints: JointSpec {
                position: cols("actual_q"),
                position_unit: AngleUnit::Rad,
                velocity: Some(cols("actual_qd")),
                velocity_unit: RateUnit::RadS,
                wrapped: Vec::new(),
            },
            power: PowerSpec {
                signal: Some(PowerKind::Bus),
                voltage: Some("actual_robot_voltage".into()),
                current: Some("actual_robot_current".into()),
                ..PowerSpec::default()
            },
            clean: CleanOptions::default(),
        }
    }

    /// The map of a log in powertwin's own column names, found in `headers`: `t_s`,
    /// `q1_rad..` (as many as are numbered from 1), `dq{i}_rad_s` when all are present,
    /// `P_total_W` or `p_total_W`, and `p_elec{i}_W` when all are present. Errors name what
    /// is missing.
    pub fn powertwin(headers: &[String], label: &str) -> Result<ColumnMap> {
        let has = |n: &str| headers.iter().any(|h| h == n);
        let missing = |what: &str| {
            Error::InvalidInput(format!(
                "{label}: no column map given and {what} (powertwin's own names: t_s, q1_rad.., optional dq1_rad_s.., P_total_W or p_elec1_W..; or pass --columns MAP.toml|ur-rtde); columns found: {}",
                headers.join(", ")
            ))
        };
        if !has("t_s") {
            return Err(missing("no column 't_s'"));
        }
        let n = (1..).take_while(|i| has(&format!("q{i}_rad"))).count();
        if n == 0 {
            return Err(missing("no column 'q1_rad'"));
        }
        let all = |f: &dyn Fn(usize) -> String| -> Option<Vec<String>> {
            let v: Vec<String> = (1..=n).map(f).collect();
            v.iter().all(|c| has(c)).then_some(v)
        };
        let velocity = all(&|i| format!("dq{i}_rad_s"));
        let motors = all(&|i| format!("p_elec{i}_W"));
        let column = ["P_total_W", "p_total_W"]
            .into_iter()
            .find(|c| has(c))
            .map(str::to_string);
        if column.is_none() && motors.is_none() {
            return Err(missing("no power column"));
        }
        Ok(ColumnMap {
            delimiter: None,
            time: TimeSpec {
                column: "t_s".into(),
                unit: TimeUnit::S,
            },
            joints: JointSpec {
                position: (1..=n).map(|i| format!("q{i}_rad")).collect(),
                position_unit: AngleUnit::Rad,
                velocity,
                velocity_unit: RateUnit::RadS,
                wrapped: Vec::new(),
            },
            power: PowerSpec {
                signal: None,
                column,
                motors,
                ..PowerSpec::default()
            },
            clean: CleanOptions::default(),
        })
    }

    /// Number of joints.
    pub fn dof(&self) -> usize {
        self.joints.position.len()
    }

    /// The power kind: `over` (from `--power`) if given, else the map's, else `per-motor`
    /// when only motor columns are given and `total` otherwise.
    pub fn kind(&self, over: Option<PowerKind>) -> PowerKind {
        over.or(self.power.signal).unwrap_or(
            if self.power.column.is_none() && self.power.voltage.is_none() {
                PowerKind::PerMotor
            } else {
                PowerKind::Total
            },
        )
    }

    /// How the total power is formed for the power kind `kind`. Errors when the columns
    /// do not fit the kind (e.g. `per-motor` without motor columns).
    pub fn power_source(&self, kind: PowerKind) -> Result<PowerSource> {
        let p = &self.power;
        let scale = match p.unit {
            PowerUnit::W => 1.0,
            PowerUnit::KW => 1e3,
        };
        match kind {
            PowerKind::PerMotor => {
                if p.motors.is_none() {
                    return Err(Error::InvalidInput(
                        "power kind 'per-motor' needs [power] motors = [...] columns".into(),
                    ));
                }
                Ok(PowerSource::MotorSum)
            }
            _ => match (&p.column, &p.voltage, &p.current) {
                (Some(c), None, None) => Ok(PowerSource::Column {
                    name: c.clone(),
                    scale,
                }),
                (None, Some(v), Some(i)) => Ok(PowerSource::VoltageCurrent {
                    voltage: v.clone(),
                    current: i.clone(),
                }),
                (None, None, None) if kind == PowerKind::Total && p.motors.is_some() => {
                    Ok(PowerSource::MotorSum)
                }
                _ => Err(Error::InvalidInput(format!(
                    "power kind '{}' needs [power] column = \"...\" or both voltage and current",
                    kind.signal().name()
                ))),
            },
        }
    }

    /// Check the map on its own: joint counts, wrapped joint numbers, power columns.
    pub fn validate(&self) -> Result<()> {
        let n = self.dof();
        if n == 0 {
            return Err(Error::InvalidInput(
                "[joints] position lists no column".into(),
            ));
        }
        if let Some(v) = &self.joints.velocity
            && v.len() != n
        {
            return Err(Error::InvalidInput(format!(
                "[joints] velocity has {} columns, position {n}",
                v.len()
            )));
        }
        if let Some(m) = &self.power.motors
            && m.len() != n
        {
            return Err(Error::InvalidInput(format!(
                "[power] motors has {} columns, [joints] position {n}",
                m.len()
            )));
        }
        if let Some(&j) = self.joints.wrapped.iter().find(|&&j| j == 0 || j > n) {
            return Err(Error::InvalidInput(format!(
                "[joints] wrapped names joint {j}; joints are numbered 1..{n}"
            )));
        }
        if self.power.voltage.is_some() != self.power.current.is_some() {
            return Err(Error::InvalidInput(
                "[power] voltage and current go together".into(),
            ));
        }
        if self.power.column.is_some() && self.power.voltage.is_some() {
            return Err(Error::InvalidInput(
                "[power] give either column or voltage x current, not both".into(),
            ));
        }
        if self.power.column.is_none()
            && self.power.voltage.is_none()
            && self.power.motors.is_none()
        {
            return Err(Error::InvalidInput(
                "[power] names no column (column, motors, or voltage and current)".into(),
            ));
        }
        if let Some(d) = self.delimiter
            && !d.is_ascii()
        {
            return Err(Error::InvalidInput(format!(
                "delimiter '{d}' must be one ASCII character"
            )));
        }
        self.power_source(self.kind(None))?;
        self.clean.validate()
    }
}
