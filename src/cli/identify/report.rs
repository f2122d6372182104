//! The summary `identify` prints on stderr: what the data determined, and what the logs leave
//! undetermined (the meter below its lowest level, the friction law).

use powertwin::identification::model::PowerModel;
use powertwin::identification::prior::Determination;

/// Print what the logs leave undetermined of the friction law: below the least speed fitted
/// (the share of the drive file's Stribeck rise the model takes there), and, for the
/// cross-validated estimators (`cross_validated`), the other friction structure.
pub(super) fn report_friction(model: &PowerModel, cross_validated: bool) {
    use powertwin::identification::tuning::STRIBECK_SHARE;
    if let Some(v) = model.min_speed {
        let stribeck = if model.stribeck.iter().any(Option::is_some) {
            format!(
                ": the model takes {} % of the drive file's Stribeck rise there, predictions' \
                 intervals the rest",
                100.0 * STRIBECK_SHARE
            )
        } else {
            String::new()
        };
        eprintln!(
            "least joint speed fitted: {v:.3} rad/s; how the friction changes below it is \
             undetermined{stribeck}"
        );
    }
    let with = if model.gear_friction.is_empty() {
        "with"
    } else {
        "without"
    };
    match (cross_validated, &model.alternative) {
        (false, _) => {}
        (true, Some(_)) => eprintln!(
            "the friction law is partly undetermined: predictions take the mean of this model \
             and the same logs' model {with} load-dependent gear friction, with half their \
             difference in the interval"
        ),
        (true, None) => eprintln!(
            "the model {with} load-dependent gear friction could not be fitted on these logs: \
             predictions' intervals do not hold how the friction law might differ"
        ),
    }
}

/// Print what the data determined and what would determine the rest.
pub(super) fn report_determination(d: &Determination) {
    eprintln!(
        "determined by the data: {} of {} directions of the base-parameter space",
        d.directions, d.of
    );
    let prior = d.mostly_prior();
    if prior.is_empty() {
        eprintln!(
            "every base parameter is determined by the data (posterior std <= 0.5 x prior std)"
        );
        return;
    }
    eprintln!(
        "mostly from the prior (URDF and drive file; posterior std > 0.5 x prior std): {}",
        prior.join(", ")
    );
    if let Some(advice) = d.advice() {
        eprintln!("to determine them: {advice}; the intervals carry the prior's width meanwhile");
    }
}

/// Print the lowest level the logs show a clipped meter at, the floor under its reading
/// (`floor_w`, W: [`PowerModel::bus_floor`], `None` without the drive file's standby), and how to see it lower when it stays above zero by more than the fit's residual
/// (`residual_w`, W).
pub(super) fn report_lowest_seen(low: f64, floor_w: Option<f64>, residual_w: f64) {
    eprintln!(
        "lowest power the logs show the meter at: {low:.1} W; below it what the meter reads is \
         undetermined (a cabinet load after the bus clip would hold it up): predictions' \
         intervals hold half the energy spent below it"
    );
    match floor_w {
        Some(f) => eprintln!(
            "floor under the meter's reading: {f:.1} W (where the logs brake down to it, what \
             they read there, else the fitted standby less the drive file's): predictions read \
             the power no lower"
        ),
        None => eprintln!(
            "floor under the meter's reading: 0 W (the drive file gives no standby power to \
             tell a cabinet load after the bus clip from the drives' own)"
        ),
    }
    if low > 2.0 * residual_w {
        eprintln!(
            "to determine it: add a run that brakes hard enough for the meter to reach 0 W \
             (fast stops carrying a load)"
        );
    }
}
