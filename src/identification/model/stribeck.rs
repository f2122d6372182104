//! The drive file's Stribeck law carried by a power model: how far the dry friction rises at
//! speeds below those identification fits on. The logs barely show it (a joint spends little
//! time that slow in an excitation), while a slow motion spends much of its time there, where
//! the raised friction also raises the copper loss of a loaded joint. The model takes
//! [`crate::identification::tuning::STRIBECK_SHARE`] of the rise, in its fit and its
//! predictions, and a prediction adds the energy of the rest to its standard deviation.

use serde::{Deserialize, Serialize};

use crate::model::drive::JointDrive;

/// The Stribeck rise of one joint's dry friction from the drive file's data-sheet values:
/// the Coulomb friction `fc` becomes `fc (1 + rise exp(-(dq / speed)^2))` at joint speed `dq`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stribeck {
    /// Static friction over Coulomb friction, less one: `(fs - fc) / fc`, dimensionless.
    pub rise: f64,
    /// Stribeck velocity, rad/s (link side).
    #[serde(rename = "speed_rad_s")]
    pub speed: f64,
}

impl Stribeck {
    /// The law of a drive file's joint: `None` where it gives no static friction above its
    /// Coulomb friction, or no positive Stribeck velocity.
    pub fn of_drive(joint: &JointDrive) -> Option<Stribeck> {
        let fc = joint.friction.coulomb;
        let u = &joint.unmodelled;
        let fs = u.stribeck_static?;
        (fc > 0.0 && fs > fc && u.stribeck_speed > 0.0).then(|| Stribeck {
            rise: (fs - fc) / fc,
            speed: u.stribeck_speed,
        })
    }

    /// The factor on the Coulomb friction at joint speed `dq` (rad/s) with `share` of the
    /// rise (1: the whole law), `>= 1`.
    #[inline]
    pub fn factor(&self, dq: f64, share: f64) -> f64 {
        1.0 + share * self.rise * (-(dq / self.speed).powi(2)).exp()
    }

    /// Whether the values are usable: a finite rise `>= 0` and a finite speed `> 0`.
    pub fn is_valid(&self) -> bool {
        self.rise.is_finite() && self.rise >= 0.0 && self.speed.is_finite() && self.speed > 0.0
    }
}
