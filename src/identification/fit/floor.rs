//! The floor under a clipped meter's reading: a meter that sees a load the DC bus's clip does
//! not (the cabinet on a grid meter) reads `max(P, F)` of the modelled power `P`, whose
//! standby has absorbed that load. Read from the logs where they sit on it, else from the
//! drive file's standby.

use nalgebra::DVector;

use super::estimate::fit_free;
use super::samples::Samples;
use super::{Estimator, Weighting};
use crate::error::Result;
use crate::identification::model::PowerModel;

/// Observations the model must put below the floor before the logs' level there is read as
/// the floor: the median of fewer would carry the meter's noise.
const MIN_ON_FLOOR: usize = 10;

/// How far below the floor (in the fit's residual RMS) the model must put an observation for
/// its reading to be taken as the floor's: nearer, the arm's own power may hold the reading up.
const ON_FLOOR_MARGIN: f64 = 3.0;

/// The floor under the clipped arm's signal, W.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Floor {
    /// The arm's fitted standby `P0` less the drive file's standby (`standby_w`, W, summed
    /// over the drives), within `[0, lowest_w]` (the lowest level the logs show the meter at,
    /// [`Samples::lowest_seen`]): the load the clip does not see, with the data sheet's word
    /// on the drives' own.
    Standby { standby_w: f64, lowest_w: f64 },
    /// Read from the logs: the level the meter sits at where the arm regenerates.
    Fixed(f64),
}

impl Floor {
    /// The floor, W, with the arm's fitted standby `p0_w`, and its derivative in `p0_w` (1 or 0).
    pub fn at(&self, p0_w: f64) -> (f64, f64) {
        match *self {
            Floor::Fixed(f) => (f, 0.0),
            Floor::Standby {
                standby_w,
                lowest_w,
            } => {
                let f = p0_w - standby_w;
                if f <= 0.0 {
                    (0.0, 0.0)
                } else if f >= lowest_w {
                    (lowest_w.max(0.0), 0.0)
                } else {
                    (f, 1.0)
                }
            }
        }
    }
}

impl Samples {
    /// The samples with their floor settled before the estimators' fits: a `pmsm` fit with
    /// the floor the drive file's standby gives ([`Floor::Standby`]) finds the arm's
    /// observations it puts well below that floor (by [`ON_FLOOR_MARGIN`] residual RMS); where
    /// there are at least [`MIN_ON_FLOOR`], the floor is the median of their readings, what
    /// the meter showed there, else the drive file's. Either is then held fixed
    /// ([`Floor::Fixed`]), so the readings on the floor do not pull the standby (the data
    /// sheet's standby is off by what the robot's differs). Without a floor: unchanged.
    pub(super) fn with_settled_floor(
        mut self,
        template: &PowerModel,
        weighting: Weighting,
    ) -> Result<Samples> {
        let Some(floor) = self.floor else {
            return Ok(self);
        };
        let fit = fit_free(template, &self, Estimator::Pmsm, weighting)?;
        let z = DVector::from_column_slice(&fit.estimate.values);
        let (guess, _) = floor.at(z[fit.layout.standby()]);
        let below = guess - ON_FLOOR_MARGIN * fit.estimate.residual_rms;
        // The model's power without a floor: a floor below any power never clips.
        self.floor = Some(Floor::Fixed(f64::NEG_INFINITY));
        let mut on_floor: Vec<f64> = (0..self.len())
            .filter(|&m| self.motor[m].is_none() && self.power(m, &z, None) < below)
            .map(|m| self.y[m])
            .collect();
        let settled = if on_floor.len() >= MIN_ON_FLOOR {
            on_floor.sort_by(f64::total_cmp);
            on_floor[on_floor.len() / 2].max(0.0)
        } else {
            guess
        };
        self.floor = Some(Floor::Fixed(settled));
        Ok(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_standby_floor_is_the_standby_beyond_the_files_within_what_was_seen() {
        let floor = Floor::Standby {
            standby_w: 18.5,
            lowest_w: 50.0,
        };
        assert_eq!(floor.at(60.0), (41.5, 1.0));
        assert_eq!(floor.at(15.0), (0.0, 0.0));
        assert_eq!(floor.at(80.0), (50.0, 0.0));
        let never_low = Floor::Standby {
            standby_w: 18.5,
            lowest_w: -1.0,
        };
        assert_eq!(never_low.at(30.0), (0.0, 0.0));
        assert_eq!(Floor::Fixed(52.6).at(80.0), (52.6, 0.0));
    }
}
