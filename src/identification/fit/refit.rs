//! The loss terms refitted under fixed base parameters (the consistent projection's).

use nalgebra::DVector;

use super::nonlinear::{levenberg_marquardt, residual_variance};
use super::weighting::variance_weights;
use super::{Estimator, Fit, Weighting, samples::Samples};
use crate::error::Result;
use crate::identification::model::PowerModel;

/// The loss terms refitted on the arm's power with the base parameters of `model` (e.g.
/// physically consistent ones) held, from the values of `fitted` (the fit `model` came
/// from): the loss coefficients `fitted` estimated (copper, and gear friction for
/// [`Estimator::Gear`]; kept >= 0, those it held at zero stay there) and the standby power,
/// by Levenberg–Marquardt with the samples weighted by `weighting` (and the copper
/// coefficients' prior, if any). The projection moves the loss terms only along their correlation with the base parameters;
/// the data decide them once those are fixed. The model predicts the arm's power, so its
/// losses are refitted on the arm's power alone
/// (docs/experiments.md#losses-refitted-on-the-arms-power).
pub(super) fn refit_losses(
    s: &Samples,
    fitted: &Fit,
    mut model: PowerModel,
    estimator: Estimator,
    weighting: Weighting,
) -> Result<PowerModel> {
    let (n, nb, np) = (s.n, s.nb, s.params());
    let rows: Vec<usize> = (0..s.len())
        .filter(|&m| s.fit[m] && s.motor[m].is_none())
        .collect();
    let mut z = DVector::from_column_slice(&fitted.estimate.values);
    z.rows_mut(0, nb).copy_from_slice(&model.theta);
    z.rows_mut(nb, n).copy_from_slice(&model.copper);
    if estimator.fits_gear() {
        z.rows_mut(nb + n, n).copy_from_slice(&model.gear_friction);
    }
    z[np - 1] = model.constant.iter().sum();
    // A loss coefficient held at zero freed here trades against the standby, as in `fit`
    // (docs/experiments.md#copper-coefficients-held-at-zero). The fit's covariance is zero
    // for every coefficient the estimator held or does not fit.
    let layout = s.layout();
    let free: Vec<bool> = (0..np)
        .map(|k| k == np - 1 || (layout.is_loss(k) && fitted.covariance[(k, k)] > 0.0))
        .collect();
    let weights = match weighting {
        Weighting::None => vec![1.0; rows.len()],
        w => variance_weights(s, &rows, &z, w),
    };
    // The copper coefficients' prior, if any, weighed against the rows' residual variance at
    // the start (the base parameters' rows are constant here: those are held).
    let prior = s.z_prior();
    let moved = free.iter().filter(|f| **f).count();
    let s2 = residual_variance(s, &rows, &weights, &z, moved);
    let prior = prior.as_ref().map(|p| (p, s2));
    levenberg_marquardt(s, &rows, &weights, Some(&free), prior, &mut z)?;
    model.copper.copy_from_slice(z.rows(nb, n).as_slice());
    if estimator.fits_gear() {
        model.gear_friction = z.rows(nb + n, n).as_slice().to_vec();
    }
    model.constant.fill(0.0);
    model.constant[0] = z[np - 1];
    Ok(model)
}
