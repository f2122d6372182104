//! The model files of `models/`, embedded in the library so that the binary works from any
//! directory.
//!
//! - [`IRB1200_URDF`]: ABB IRB 1200-7/0.7 (robot `abb_irb1200_7_70`), ROS-Industrial link
//!   frames, SI units; mass properties and friction are estimates (see the file's comments).
//! - [`IRB1200_DRIVE`], [`IDEAL_DRIVE`]: drive files for it (see [`crate::model::drive`]).
//! - [`payload`]: the tool and the three loads of Liu et al. 2018, Table 4, in the flange
//!   frame `tool0`.
//! - [`PICK_AND_PLACE`]: the pick-and-place scenario of the paper's Figure 12
//!   (`scenarios/pick_and_place.toml`, see [`crate::trajectory::task`]).

use crate::error::{Error, Result};
use crate::model::payload::Payload;

/// Robot name of the ABB IRB 1200-7/0.7 in [`IRB1200_URDF`]: the defaults made for it
/// (acceleration bounds, rest and start poses) apply to a robot of this name.
pub const IRB1200_NAME: &str = "abb_irb1200_7_70";

/// URDF of the ABB IRB 1200-7/0.7 (`models/irb1200_7_70.urdf`).
pub const IRB1200_URDF: &str = include_str!("../../models/irb1200_7_70.urdf");

/// Estimated drive data of the IRB 1200-7/0.7 (`models/irb1200_7_70.drive.toml`).
pub const IRB1200_DRIVE: &str = include_str!("../../models/irb1200_7_70.drive.toml");

/// Ideal drives for the IRB 1200-7/0.7 (`models/ideal.drive.toml`): no friction, no rotor
/// inertia, efficiency 1, no losses.
pub const IDEAL_DRIVE: &str = include_str!("../../models/ideal.drive.toml");

/// The pick-and-place scenario (`scenarios/pick_and_place.toml`); its tool is the built-in
/// `"tool"`, so it needs no other file.
pub const PICK_AND_PLACE: &str = include_str!("../../scenarios/pick_and_place.toml");

/// Names accepted by [`payload`], with their embedded files.
const PAYLOADS: [(&str, &str); 4] = [
    (
        "tool",
        include_str!("../../models/tool_1p32kg.payload.toml"),
    ),
    (
        "load_1kg",
        include_str!("../../models/load_1kg.payload.toml"),
    ),
    (
        "load_2kg",
        include_str!("../../models/load_2kg.payload.toml"),
    ),
    (
        "load_4kg",
        include_str!("../../models/load_4kg.payload.toml"),
    ),
];

/// Names of the built-in payloads: the 1.32 kg tool and the 1, 2 and 4 kg steel loads (whose
/// COM is at the tool's TCP; combine them with the tool, see [`Payload::combined`]).
pub const PAYLOAD_NAMES: [&str; 4] = [PAYLOADS[0].0, PAYLOADS[1].0, PAYLOADS[2].0, PAYLOADS[3].0];

/// A built-in payload by name (one of [`PAYLOAD_NAMES`]), in the flange frame `tool0`.
/// Unknown names give [`Error::InvalidInput`] listing the valid ones.
pub fn payload(name: &str) -> Result<Payload> {
    let (_, text) = PAYLOADS.iter().find(|(n, _)| *n == name).ok_or_else(|| {
        Error::InvalidInput(format!(
            "unknown built-in payload '{name}' (valid: {})",
            PAYLOAD_NAMES.join(", ")
        ))
    })?;
    Payload::from_toml_str(text, &format!("built-in payload '{name}'"))
}
