//! The shared random-state sampler on URDF limits wider than, or lying outside, +-pi (these
//! drew from an empty range and panicked), and inverted limits (an error, not a panic).

use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
use powertwin::dynamics::{DriveTerms, ParamLayout};
use powertwin::identification::consistency::consistency;
use powertwin::identification::excitation::{Observation, identifiable_columns};
use powertwin::identification::model::PowerModel;
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::sampling::StateSampler;
use powertwin::model::urdf::{LoadOptions, load_str};

const URDF: &str = include_str!("../models/irb1200_7_70.urdf");
const J1_LIMITS: &str = r#"lower="-2.967059728" upper="2.967059728""#;
const J3_LIMITS: &str = r#"lower="-3.490658504" upper="1.221730476""#;

/// The IRB 1200 with joint 1 limited to [-10, 10] rad and joint 3 to [3.5, 6] rad (entirely
/// above pi).
fn wide_limits() -> powertwin::Robot {
    let text = URDF
        .replace(J1_LIMITS, r#"lower="-10" upper="10""#)
        .replace(J3_LIMITS, r#"lower="3.5" upper="6""#);
    assert_ne!(text, URDF);
    load_str(&text, &LoadOptions::default()).unwrap()
}

#[test]
fn limits_beyond_pi_sample_within_a_full_turn_of_the_limits() {
    let robot = wide_limits();
    let n = robot.dof();
    let mut s = StateSampler::new(&robot, 3.0, 10.0, 1).unwrap();
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let pi = std::f64::consts::PI;
    for _ in 0..2000 {
        s.state(&mut q, &mut dq, &mut ddq);
        assert!((-pi..pi).contains(&q[0]), "q1 = {}", q[0]);
        assert!((3.5..6.0).contains(&q[2]), "q3 = {}", q[2]);
        for (j, joint) in robot.joints().iter().enumerate() {
            assert!(dq[j].abs() <= joint.limits.velocity.min(3.0), "dq{}", j + 1);
            assert!(ddq[j].abs() <= 10.0, "ddq{}", j + 1);
        }
    }
    // Same seed, same draws.
    let mut a = StateSampler::new(&robot, 3.0, 10.0, 9).unwrap();
    let mut b = StateSampler::new(&robot, 3.0, 10.0, 9).unwrap();
    assert_eq!(a.pose(), b.pose());
    // Bounds that are not finite and positive are errors.
    for (v, a) in [
        (0.0, 1.0),
        (1.0, f64::NAN),
        (f64::INFINITY, 1.0),
        (1.0, -1.0),
    ] {
        assert!(StateSampler::new(&robot, v, a, 1).is_err(), "{v} {a}");
    }
}

#[test]
fn base_parameters_design_scan_and_consistency_run_with_wide_limits() {
    let robot = wide_limits();
    let layout = ParamLayout::new(&robot, true, true);
    let base = BaseParams::compute(&robot, layout, &SamplingOptions::default()).unwrap();
    assert_eq!(base.rank(), 52);
    let wrist = identifiable_columns(
        &robot,
        layout,
        &[3, 4, 5],
        &[0.0, 0.0, 4.0, 0.0, 0.5, 0.0],
        Observation::TotalPower,
        3,
    )
    .unwrap();
    assert!(!wrist.is_empty());
    let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "drive", &robot).unwrap();
    let mut model = PowerModel::new(&robot, layout, false).unwrap();
    model.theta = base
        .base_values(&layout.theta(&robot, &DriveTerms::from(&drive)))
        .unwrap();
    let c = consistency(&robot, &model, 1.0, 50, 7).unwrap();
    assert!(c.consistent && c.min_eigenvalue > 0.0, "{c:?}");
}

#[test]
fn inverted_or_empty_limits_are_errors_naming_the_joint() {
    for limits in [r#"lower="2" upper="-2""#, r#"lower="1" upper="1""#] {
        let text = URDF.replace(J3_LIMITS, limits);
        let err = load_str(&text, &LoadOptions::default()).unwrap_err();
        assert!(err.to_string().contains("joint_3"), "{err}");
    }
}
