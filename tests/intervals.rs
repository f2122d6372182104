//! Prediction intervals: the terms a prediction takes for what the identification logs
//! leave undetermined.

use crate::common;
use powertwin::identification::model::PowerModel;
use powertwin::trajectory::Trajectory;

/// Every joint of the IRB 1200 still at a bent pose for `rest_s`, then each moving at 0.1
/// rad/s until `duration_s`.
struct RestThenRamp {
    rest_s: f64,
    duration_s: f64,
}

impl Trajectory for RestThenRamp {
    fn dof(&self) -> usize {
        6
    }
    fn duration(&self) -> f64 {
        self.duration_s
    }
    fn sample(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        let moving = t >= self.rest_s;
        for i in 0..6 {
            q[i] = [0.0, 0.3, -0.2, 0.0, 0.5, 0.0][i] + 0.1 * (t - self.rest_s).max(0.0);
            dq[i] = if moving { 0.1 } else { 0.0 };
            ddq[i] = 0.0;
        }
    }
}

/// The error a fold's pieces share (`structure_fold_W`, what leaving a whole log out of the
/// fit costs) is taken in proportion to the time a motion rests, where a model fitted above
/// its least speed saw nothing, and whole from `FOLD_ERROR_REST_SHARE` of its duration on; a
/// motion that never rests, or a model without a least speed, does not take it.
#[test]
fn a_resting_motion_takes_the_error_a_folds_pieces_share() {
    use powertwin::identification::tuning::FOLD_ERROR_REST_SHARE;
    let robot = common::irb1200();
    let layout = powertwin::dynamics::ParamLayout::new(&robot, true, true);
    let mut model = PowerModel::new(&robot, layout, false).unwrap();
    model.constant = vec![10.0; robot.dof()];
    model.structure_fold = 0.5;
    model.min_speed = Some(0.05);
    let duration_s = 10.0;
    let interval = |m: &PowerModel, rest_s: f64| {
        let traj = RestThenRamp { rest_s, duration_s };
        let p = m.predict(&robot, &traj, &[], 1.0, 1e-2).unwrap();
        // The prediction reports the time at rest it took.
        let expected_rest = if m.min_speed.is_some() { rest_s } else { 0.0 };
        assert!(
            (p.rest_s - expected_rest).abs() < 0.01,
            "{} s at rest",
            p.rest_s
        );
        p.interval_j
    };
    let whole = 1.96 * 0.5 * duration_s;
    assert_eq!(interval(&model, 0.0), 0.0);
    let part = interval(&model, 2.0);
    let share: f64 = 2.0 / (FOLD_ERROR_REST_SHARE * duration_s);
    assert!(share < 1.0);
    assert!(
        (part - whole * share.sqrt()).abs() < 5e-3 * whole,
        "{part} J against {} J",
        whole * share.sqrt()
    );
    let long = interval(&model, FOLD_ERROR_REST_SHARE * duration_s + 1.0);
    assert!((long - whole).abs() < 1e-9 * whole, "{long} J");
    let without_least_speed = PowerModel {
        min_speed: None,
        ..model.clone()
    };
    assert_eq!(interval(&without_least_speed, 6.0), 0.0);
}
