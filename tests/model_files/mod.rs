//! The shipped model files (`models/`), the drive and payload parsers, and the third-party
//! robot fixtures (`tests/data/`).

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use powertwin::model::builtin::{self, IDEAL_DRIVE, IRB1200_DRIVE, IRB1200_URDF};
use powertwin::model::drive::Drive;
use powertwin::model::payload::{Payload, attach};
use powertwin::model::urdf::{LoadOptions, load_file, load_str};
use powertwin::model::{RigidInertia, Robot};
use powertwin::{Error, Result};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// The IRB 1200 from the embedded URDF.
fn irb1200() -> Robot {
    load_str(IRB1200_URDF, &LoadOptions::default()).expect("IRB 1200 URDF loads")
}

fn toml_message(e: Error) -> String {
    match e {
        Error::Toml { file, message } => format!("{file}: {message}"),
        other => panic!("expected a TOML error, got {other:?}"),
    }
}

mod drives;
mod model_json;
mod payloads;
mod urdf;
