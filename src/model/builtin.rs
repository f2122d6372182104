//! The model files of `models/`, embedded in the library so that the binary works from any
//! directory.
//!
//! - [`IRB1200_URDF`]: ABB IRB 1200-7/0.7 (robot `abb_irb1200_7_70`), ROS-Industrial link
//!   frames, SI units; mass properties and friction are estimates (see the file's comments).
//! - [`IRB1200_DRIVE`], [`IDEAL_DRIVE`]: drive files for it (see [`crate::model::drive`]).
//! - [`payload`]: the tool and the three loads of Liu et al. 2018, Table 4, in the flange
//!   frame `tool0` ([`PAYLOAD_NAMES`]; they were made for the IRB 1200, see
//!   [`foreign_payload_warning`]).
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
/// tool (`"tool"`, an alias of `"liu2018_tool"`), so it needs no other file.
pub const PICK_AND_PLACE: &str = include_str!("../../scenarios/pick_and_place.toml");

/// One built-in payload: its name, the old name still accepted for it, and its file.
struct BuiltinPayload {
    name: &'static str,
    alias: &'static str,
    toml: &'static str,
}

/// The built-in payloads, in the order of [`PAYLOAD_NAMES`].
const PAYLOADS: [BuiltinPayload; 4] = [
    BuiltinPayload {
        name: "liu2018_tool",
        alias: "tool",
        toml: include_str!("../../models/tool_1p32kg.payload.toml"),
    },
    BuiltinPayload {
        name: "liu2018_load_1kg",
        alias: "load_1kg",
        toml: include_str!("../../models/load_1kg.payload.toml"),
    },
    BuiltinPayload {
        name: "liu2018_load_2kg",
        alias: "load_2kg",
        toml: include_str!("../../models/load_2kg.payload.toml"),
    },
    BuiltinPayload {
        name: "liu2018_load_4kg",
        alias: "load_4kg",
        toml: include_str!("../../models/load_4kg.payload.toml"),
    },
];

/// Names of the built-in payloads of Liu et al. 2018 (Table 4), made for the IRB 1200: the
/// 1.32 kg tool and the 1, 2 and 4 kg steel loads (whose COM is at the tool's TCP; combine
/// them with the tool, see [`Payload::combined`]). The old names (`tool`, `load_1kg`, ...) are
/// accepted too: test a name with [`is_payload_name`].
pub const PAYLOAD_NAMES: [&str; 4] = [
    PAYLOADS[0].name,
    PAYLOADS[1].name,
    PAYLOADS[2].name,
    PAYLOADS[3].name,
];

/// The built-in payload of a current name or an old alias.
fn find(name: &str) -> Option<&'static BuiltinPayload> {
    PAYLOADS.iter().find(|p| p.name == name || p.alias == name)
}

/// Whether `name` is a built-in payload's name or one of the old aliases.
pub fn is_payload_name(name: &str) -> bool {
    find(name).is_some()
}

/// A built-in payload by name (one of [`PAYLOAD_NAMES`] or an old alias such as `tool`), in
/// the flange frame `tool0`. Unknown names give [`Error::InvalidInput`] listing the valid ones.
pub fn payload(name: &str) -> Result<Payload> {
    let p = find(name).ok_or_else(|| {
        Error::InvalidInput(format!(
            "unknown built-in payload '{name}' (valid: {}; old names tool, load_1kg, load_2kg, \
             load_4kg are accepted too)",
            PAYLOAD_NAMES.join(", ")
        ))
    })?;
    Payload::from_toml_str(p.toml, &format!("built-in payload '{name}'"))
}

/// Whether the built-in payload `name` is used on a robot it was not made for: the built-ins
/// are the IRB 1200's tool and loads, so this is true for a built-in name on any robot whose
/// URDF name is not [`IRB1200_NAME`]. False for names that are not built-ins (files).
pub fn is_foreign_payload(name: &str, robot_name: &str) -> bool {
    is_payload_name(name) && robot_name != IRB1200_NAME
}

/// The warning for a built-in payload used on another robot (see [`is_foreign_payload`]),
/// `None` when there is nothing to warn about. For the CLI to print; the library runs the
/// payload as asked.
pub fn foreign_payload_warning(name: &str, robot_name: &str) -> Option<String> {
    is_foreign_payload(name, robot_name).then(|| {
        format!(
            "built-in payload '{name}' is the ABB IRB 1200's (Liu et al. 2018), mounted at its \
             flange frame tool0; robot '{robot_name}' is another robot, so its mass, COM and TCP \
             may not fit (write a payload TOML file for this robot's tool)"
        )
    })
}
