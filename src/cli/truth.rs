//! `--truth`: how close the twin is to the identified model's structure, or a robot of the
//! family of truths.

use std::path::PathBuf;
use std::str::FromStr;

use anyhow::{Context, Result};
use clap::Args;
use powertwin::Robot;
use powertwin::measurement::PowerSignal;
use powertwin::model::drive::Drive;
use powertwin::twin::family::{FamilyTable, Plant};
use powertwin::twin::sensor::SensorSettings;
use powertwin::twin::{Fidelity, TwinConfig};

/// The twin's truth as given on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Truth {
    /// [`Fidelity::Exact`].
    Exact,
    /// [`Fidelity::Realistic`] with the files' values.
    Realistic,
    /// A robot drawn from the family of truths around the files, by its seed.
    Family(u64),
}

impl FromStr for Truth {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "exact" => Ok(Truth::Exact),
            "realistic" => Ok(Truth::Realistic),
            other => match other.strip_prefix("family:") {
                Some(seed) => seed.trim().parse::<u64>().map(Truth::Family).map_err(|_| {
                    format!("family seed '{seed}' must be a whole number >= 0 (family:SEED)")
                }),
                None => Err(format!(
                    "unknown truth '{other}' (expected exact, realistic or family:SEED)"
                )),
            },
        }
    }
}

impl std::fmt::Display for Truth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Truth::Exact => write!(f, "exact"),
            Truth::Realistic => write!(f, "realistic"),
            Truth::Family(seed) => write!(f, "family:{seed}"),
        }
    }
}

/// How close the twin is to the identified model's structure.
#[derive(Debug, Args)]
pub struct TruthArgs {
    /// Twin truth. `realistic`: the drives' unmodelled effects (Stribeck and load-dependent
    /// gear friction in the physics, iron loss; see the drive file), a controller whose
    /// nominal model is 10 % wrong, and DC-bus power (braking energy burnt in the brake
    /// resistor). `exact`: the structure an identified model has, the controller knows the
    /// true model, the motor sum is measured. `family:SEED`: a robot we did not build, drawn
    /// around the URDF and drive file: inertias off by what CAD gives, its own friction laws
    /// and losses, cabinet load, controller and logger (rate, meter, clock, noise); see
    /// --family-table and docs/design/family.md. Identification only sees the files.
    #[arg(
        long,
        default_value = "realistic",
        value_name = "exact|realistic|family:SEED"
    )]
    pub truth: Truth,
    /// The sizes of the family's differences, for --truth family:SEED and validate --family
    /// (TOML; keys as in docs/design/family.md; missing keys keep the defaults) [default: the
    /// built-in table].
    #[arg(long, value_name = "PATH")]
    pub family_table: Option<PathBuf>,
    /// Relative error of the controller's nominal model [default: 0.1 realistic, 0 exact,
    /// drawn for a family robot].
    #[arg(long, value_name = "REL")]
    pub nominal_error: Option<f64>,
    /// What the power meter measures: `total` (motor sum, RobotStudio's signal) or `bus`
    /// (DC bus, never negative) [default: bus realistic and family, total exact].
    #[arg(long, value_name = "total|bus")]
    pub power_signal: Option<PowerSignal>,
}

impl TruthArgs {
    /// The twin's fidelity (a family robot is realistic).
    pub fn fidelity(&self) -> Fidelity {
        match self.truth {
            Truth::Exact => Fidelity::Exact,
            Truth::Realistic | Truth::Family(_) => Fidelity::Realistic,
        }
    }

    /// The controller's nominal-model error.
    pub fn nominal_error(&self) -> f64 {
        self.nominal_error.unwrap_or(match self.fidelity() {
            Fidelity::Realistic => 0.1,
            Fidelity::Exact => 0.0,
        })
    }

    /// The logged power signal.
    pub fn power_signal(&self) -> PowerSignal {
        self.power_signal.unwrap_or(match self.fidelity() {
            Fidelity::Realistic => PowerSignal::Bus,
            Fidelity::Exact => PowerSignal::Total,
        })
    }

    /// The family seed of `--truth family:SEED`; `None` for another truth.
    pub fn family_seed(&self) -> Option<u64> {
        match self.truth {
            Truth::Family(seed) => Some(seed),
            _ => None,
        }
    }

    /// The family table: the file's, or the built-in one.
    pub fn family_table(&self) -> Result<FamilyTable> {
        match &self.family_table {
            None => Ok(FamilyTable::default()),
            Some(p) => {
                let text = std::fs::read_to_string(p)
                    .with_context(|| format!("reading {}", p.display()))?;
                Ok(FamilyTable::from_toml_str(&text, &p.display().to_string())?)
            }
        }
    }

    /// The robot of the family the twin simulates (`--truth family:SEED`), drawn around the
    /// user's `robot` and `drive` on top of `twin` and `sensor`; `None` for another truth.
    /// An explicit --nominal-error replaces the drawn one.
    pub fn plant(
        &self,
        robot: &Robot,
        drive: &Drive,
        twin: &TwinConfig,
        sensor: &SensorSettings,
    ) -> Result<Option<Plant>> {
        let Truth::Family(seed) = self.truth else {
            return Ok(None);
        };
        let mut plant = self
            .family_table()?
            .draw(robot, drive, twin, sensor, seed)?;
        if let Some(e) = self.nominal_error {
            plant.twin.nominal_error = e;
            plant.draw.nominal_error = e;
        }
        Ok(Some(plant))
    }
}
