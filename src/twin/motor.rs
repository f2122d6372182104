//! Motor models: electrical power of each joint motor from its torque and mechanical power.
//!
//! - [`MotorModel::Efficiency`] (paper eq. 9): `P_elec = P_mech / eta`, signed, so braking
//!   joints report negative power divided by eta.
//! - [`MotorModel::Pmsm`] (default): `P_elec = P_mech + c tau^2 + P0`: copper loss with the
//!   link-side torque (`c` in W/(N m)^2) and the standby power `P0` (W) while the servo is on.
//!   This is the model in which energy grows again at low speed (holding against gravity
//!   costs copper loss for longer), as the paper's Figure 14 shows.
//!
//! The two are alternatives; efficiency is not applied on top of the PMSM losses.

use serde::{Deserialize, Serialize};

use crate::model::drive::JointDrive;

/// Which motor model turns mechanical into electrical power.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MotorModel {
    /// `P_elec = P_mech / eta` (paper eq. 9).
    Efficiency,
    /// `P_elec = P_mech + c tau^2 + P0` (copper and standby losses).
    #[default]
    Pmsm,
}

impl MotorModel {
    /// Electrical power (W) of one motor with link-side torque `tau` (N m) and mechanical
    /// power `p_mech` (W).
    #[inline]
    pub fn electrical_power(self, drive: &JointDrive, tau: f64, p_mech: f64) -> f64 {
        match self {
            MotorModel::Efficiency => p_mech / drive.efficiency,
            MotorModel::Pmsm => p_mech + drive.copper_loss * tau * tau + drive.standby_power,
        }
    }

    /// Lower-case name as used on the command line and in metadata.
    pub fn name(self) -> &'static str {
        match self {
            MotorModel::Efficiency => "efficiency",
            MotorModel::Pmsm => "pmsm",
        }
    }
}

impl std::str::FromStr for MotorModel {
    type Err = crate::error::Error;

    fn from_str(s: &str) -> crate::error::Result<Self> {
        match s {
            "efficiency" => Ok(MotorModel::Efficiency),
            "pmsm" => Ok(MotorModel::Pmsm),
            other => Err(crate::error::Error::InvalidInput(format!(
                "unknown motor model '{other}' (expected 'efficiency' or 'pmsm')"
            ))),
        }
    }
}
