//! # powertwin
//!
//! A digital twin of an industrial robot (by default the ABB IRB 1200-7/0.7) that identifies
//! dynamic and drive parameters from motor power and predicts the energy of a task, after
//! Liu et al., "Energy consumption modeling of industrial robot based on simulated power data
//! and parameter identification", Adv. Mech. Eng. 10(5), 2018.
//!
//! ## Data flow
//!
//! ```text
//!  model ──> kinematics ──> dynamics ──> trajectory ──> twin ──> dataset ──> measurement
//!  URDF,      FK, IK,        RNEA,        references,    Rapier,   Parquet/   what a user
//!  drives,    Jacobian       regressor,   excitation     motors,   CSV +      has: times,
//!  payloads                  base params  input, tasks   sensors   meta.json  q, power
//!                                                                                │
//!        report <── validation <── optimize <── identification <─────────────────┘
//!        report.md,  experiments,   cheapest     power model from the log (never the
//!        charts      scoring vs     timing and   truth), excitation design, energy
//!                    the truth      placement    prediction
//!
//!  viz (cargo feature `viz`) observes every stage and logs it to the Rerun viewer.
//! ```
//!
//! [`model`] (URDF, drives, payloads) → [`kinematics`] → [`dynamics`] (RNEA, regressor, mass
//! matrix, base parameters) → [`trajectory`] → [`twin`] (Rapier, controller, motor and sensor
//! models) → [`dataset`] → [`measurement`] (the log a user has of a run) →
//! [`identification`] (power models, excitation design) → [`optimize`] (the cheapest timing
//! and placement of a task under a cycle-time bound, priced by an identified model) →
//! [`validation`] (the paper's experiments and the optimised plans, scored against the
//! twin's truth) → [`report`] (report.md, SVG and PNG
//! charts). `viz` (cargo feature `viz`, on by default; opt out with
//! `default-features = false`) logs the robot, runs and results to the Rerun viewer after
//! the fact.
//!
//! Units are SI everywhere (m, rad, kg, s, N m, W, J); frames are described in [`model`].
//!
//! ## Example
//!
//! Gravity torques of the built-in robot at its zero pose, and with a 4 kg load at the
//! flange:
//!
//! ```
//! use powertwin::dynamics::{Workspace, rnea::rnea_checked};
//! use powertwin::model::{builtin, payload::attach, urdf::{LoadOptions, load_str}};
//!
//! let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default())?;
//! let zero = vec![0.0; robot.dof()];
//! let tau = rnea_checked(&robot, &mut Workspace::new(&robot), &zero, &zero, &zero, None)?;
//! let loaded = attach(&robot, &builtin::payload("liu2018_load_4kg")?)?;
//! let tau4 = rnea_checked(&loaded, &mut Workspace::new(&loaded), &zero, &zero, &zero, None)?;
//! assert!(tau4[1].abs() > tau[1].abs(), "joint 2 holds the load: {tau4:?} vs {tau:?}");
//! # Ok::<(), powertwin::Error>(())
//! ```

pub mod dataset;
pub mod dynamics;
pub mod error;
pub mod identification;
pub mod io;
pub mod kinematics;
pub mod measurement;
pub mod model;
pub mod numerics;
pub mod optimize;
pub mod report;
pub mod trajectory;
pub mod twin;
pub mod validation;
#[cfg(feature = "viz")]
pub mod viz;

pub use error::{Error, Result};
pub use model::Robot;
