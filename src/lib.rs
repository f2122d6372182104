//! # powertwin
//!
//! A digital twin of an industrial robot (by default the ABB IRB 1200-7/0.7) that identifies
//! dynamic and drive parameters from motor power and predicts the energy of a task, after
//! Liu et al., "Energy consumption modeling of industrial robot based on simulated power data
//! and parameter identification", Adv. Mech. Eng. 10(5), 2018.
//!
//! Data flows one way through the modules:
//! [`model`] (URDF, drives, payloads) -> [`kinematics`] -> [`dynamics`] (RNEA, regressor,
//! mass matrix, base parameters) -> [`trajectory`] -> [`twin`] (Rapier, controller, motor
//! and sensor models) -> [`dataset`] -> later stages (identification, energy, validation).
//! `viz` (cargo feature `viz`, on by default; opt out with `default-features = false`) logs
//! the robot, runs and results to the Rerun viewer after the fact.
//! [`report`] writes the charts of the reproduction report as SVG and PNG.
//!
//! Units are SI everywhere (m, rad, kg, s, N m, W, J); frames are described in [`model`].

pub mod dataset;
pub mod dynamics;
pub mod error;
pub mod identification;
pub mod io;
pub mod kinematics;
pub mod measurement;
pub mod model;
pub mod report;
pub mod trajectory;
pub mod twin;
pub mod validation;
#[cfg(feature = "viz")]
pub mod viz;

pub use error::{Error, Result};
pub use model::Robot;
