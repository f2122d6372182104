//! The pipeline from measured logs to a selected, physically consistent power model:
//! prepare the logs, pool the samples, cross-validate the estimators, project the chosen fit
//! onto consistent parameters and refit its loss terms.

use nalgebra::DMatrix;

use super::refit::refit_losses;
use super::{Estimator, Fit, FitOptions, Selection, samples::Samples, select};
use crate::error::{Error, Result};
use crate::identification::lsq::Estimate;
use crate::identification::model::PowerModel;
use crate::model::Robot;

/// Identify the power model of `robot` from measured logs: states along `routes` (one for
/// all logs, or one per log), known payloads through the base relations, the estimator
/// chosen by cross-validation, the power's lag behind the joints found by the fit
/// ([`FitOptions::max_power_lag_s`]). Reads nothing but the logs. Errors: logs of another robot or
/// joint count, rank-deficient data without [`FitOptions::prior`] (naming the parameters),
/// too little data.
pub fn identify_logs(
    robot: &Robot,
    logs: &[crate::measurement::Log],
    routes: &[crate::identification::data::Route],
    opts: &FitOptions,
) -> Result<Selection> {
    check_inputs(robot, logs, routes, opts)?;
    let template = template(robot, opts)?;
    let lag = super::lag::find_lag(robot, &template, logs, routes, opts)?;
    let samples = pooled_samples(robot, &template, logs, routes, lag, opts)?;
    let mut selection = select(&template, &samples, &opts.candidates, opts.weighting)?;
    if opts.consistent {
        let (model, consistent) =
            consistent_model(robot, &samples, &selection.fit, selection.chosen, opts)?;
        selection.fit.model = model;
        selection.consistent = Some(consistent);
        if let Some((estimator, alt)) = &mut selection.alternative {
            alt.model = consistent_model(robot, &samples, alt, *estimator, opts)?.0;
        }
    }
    annotate(&mut selection, &samples, logs, lag, opts);
    Ok(selection)
}

/// Refuse what [`identify_logs`] cannot identify from: a route count other than one or one
/// per log, a negative or non-finite minimum speed (rad/s), fit rate (Hz) or largest power
/// lag (s), and logs of another robot.
fn check_inputs(
    robot: &Robot,
    logs: &[crate::measurement::Log],
    routes: &[crate::identification::data::Route],
    opts: &FitOptions,
) -> Result<()> {
    if routes.len() != 1 && routes.len() != logs.len() {
        return Err(Error::InvalidInput(format!(
            "{} routes for {} logs: give one for all or one per log",
            routes.len(),
            logs.len()
        )));
    }
    if !(opts.min_speed.is_finite() && opts.min_speed >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "minimum speed {} rad/s must be finite and >= 0",
            opts.min_speed
        )));
    }
    if !(opts.max_fit_rate_hz.is_finite() && opts.max_fit_rate_hz >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "fit rate {} Hz must be finite and >= 0 (0: every state)",
            opts.max_fit_rate_hz
        )));
    }
    if !(opts.max_power_lag_s.is_finite() && opts.max_power_lag_s >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "largest power lag {} s must be finite and >= 0 (0: none)",
            opts.max_power_lag_s
        )));
    }
    for log in logs {
        log.check_robot(robot)?;
    }
    Ok(())
}

/// The model every fit of `robot` starts from: the layout with friction and rotor-inertia
/// columns, and the drive file's Stribeck law from [`FitOptions::prior`] when it has one.
fn template(robot: &Robot, opts: &FitOptions) -> Result<PowerModel> {
    let layout = crate::dynamics::ParamLayout::new(robot, true, true);
    let mut template = PowerModel::new(robot, layout, false)?;
    // The drive file's Stribeck law, which the logs barely show: every fit takes it.
    if let Some(prior) = opts.prior.as_ref()
        && prior.stribeck.iter().any(Option::is_some)
    {
        template.stribeck = prior.stribeck.clone();
    }
    Ok(template)
}

/// The samples of all `logs`, prepared along `routes` with the power lagging the joints by
/// `lag` s, pooled for the fit (each motor's power too when every log has it and
/// [`FitOptions::motor_power`] asks for it), with [`FitOptions::prior`] and its settled
/// floor when given.
fn pooled_samples(
    robot: &Robot,
    template: &PowerModel,
    logs: &[crate::measurement::Log],
    routes: &[crate::identification::data::Route],
    lag: f64,
    opts: &FitOptions,
) -> Result<Samples> {
    let prepared = logs
        .iter()
        .enumerate()
        .map(|(k, l)| {
            crate::identification::data::prepare_lagged(l, routes[k.min(routes.len() - 1)], lag)
        })
        .collect::<Result<Vec<_>>>()?;
    let motor_power = opts.motor_power
        && prepared
            .iter()
            .all(|p| p.p_joint.len() == p.states.len() * robot.dof());
    let samples = Samples::new(
        robot,
        template,
        &prepared,
        opts.min_speed,
        opts.max_fit_rate_hz,
        opts.folds,
        motor_power,
    )?;
    Ok(match &opts.prior {
        Some(prior) => samples
            .with_prior(prior.clone())?
            .with_settled_floor(template, opts.weighting)?,
        None => samples,
    })
}

/// Record on the selected models (the chosen one and its alternative) what the data could
/// not show them: the lowest power the logs show, the meter's floor at each model's standby
/// (W), the least speed fitted (rad/s); and on the chosen one the alternative, the power's
/// lag `lag` (s) and the heaviest payload the `logs` carried (kg).
fn annotate(
    selection: &mut Selection,
    samples: &Samples,
    logs: &[crate::measurement::Log],
    lag: f64,
    opts: &FitOptions,
) {
    let lowest_seen = samples.lowest_seen();
    for model in std::iter::once(&mut selection.fit.model).chain(
        selection
            .alternative
            .as_mut()
            .map(|(_, alt)| &mut alt.model),
    ) {
        model.lowest_seen = lowest_seen;
        // The floor the fit used, at the model's (refitted) standby.
        let standby: f64 = model.constant.iter().sum();
        model.bus_floor = samples.floor.map(|f| f.at(standby).0);
        model.min_speed = (opts.min_speed > 0.0).then_some(opts.min_speed);
    }
    selection.fit.model.alternative = selection
        .alternative
        .as_ref()
        .map(|(_, alt)| Box::new(alt.model.clone()));
    selection.fit.model.power_lag_s = lag;
    selection.fit.model.payload_seen = Some(
        logs.iter()
            .flat_map(|l| &l.payloads)
            .filter_map(|e| e.payload.as_ref())
            .map(|p| p.inertia.mass)
            .fold(0.0, f64::max),
    );
}

/// The model of `fit` (by `estimator`) made physically consistent
/// ([`crate::identification::consistent::constrain`]; the URDF decides what the data cannot
/// see), its loss terms refitted on the samples, with the projection.
fn consistent_model(
    robot: &Robot,
    samples: &Samples,
    fit: &Fit,
    estimator: Estimator,
    opts: &FitOptions,
) -> Result<(PowerModel, crate::identification::consistent::Consistent)> {
    let layout = fit.model.layout;
    let prior = layout.theta(robot, &crate::dynamics::DriveTerms::from_urdf(robot));
    let estimate = regularised(fit.free_estimate());
    let (model, consistent) = crate::identification::consistent::constrain(
        robot,
        &fit.model,
        &estimate,
        &prior,
        &crate::identification::consistent::Options::default(),
    )?;
    let samples = samples.for_estimator(estimator);
    let model = refit_losses(&samples, fit, model, estimator, opts.weighting)?;
    Ok((model, consistent))
}

/// The estimate with its covariance made positive definite for the consistent projection:
/// eigenvalues below `1e-12` of the largest (values the data fix exactly, e.g. a copper
/// coefficient on its bound) raised to it.
fn regularised(mut e: Estimate) -> Estimate {
    let eig = e.covariance.clone().symmetric_eigen();
    let floor = 1e-12 * eig.eigenvalues.max().max(0.0);
    let values = eig.eigenvalues.map(|v| v.max(floor));
    e.covariance =
        &eig.eigenvectors * DMatrix::from_diagonal(&values) * eig.eigenvectors.transpose();
    e
}
