//! Identification for the PMSM motor model from pooled states and total power:
//! `P = sum_i [dq_i tau_i + c_i tau_i^2] + P0` with `tau_i = W_base,i theta`, nonlinear in
//! `(theta, c_1..c_n, P0)`; solved by [`crate::identification::fit`]'s Levenberg–Marquardt
//! from the linear total-power solution (copper coefficients kept >= 0). With copper loss in
//! the model the predicted energy rises again at low speed, as the twin's does.

use crate::error::Result;
use crate::identification::fit::{Estimator, Samples, Weighting, fit};
use crate::identification::lsq::Estimate;
use crate::identification::model::PowerModel;
use crate::identification::states::States;
use crate::model::Robot;

/// Identify `model` (filled in place, not efficiency-scaled) from total power `p` (W) at the
/// samples of `states`. The estimate holds the parameters fitted: base parameters, the
/// copper coefficients the data tell from zero (the others are held at zero), the standby.
pub fn identify(
    robot: &Robot,
    model: &mut PowerModel,
    states: &States,
    p: &[f64],
) -> Result<Estimate> {
    let samples = Samples::from_states(robot, model, states, p)?;
    let f = fit(model, &samples, Estimator::Pmsm, Weighting::None, &|_| true)?;
    let estimate = f.free_estimate();
    *model = f.model;
    Ok(estimate)
}
