//! Base parameters: counts for the IRB 1200, exact reproduction of the torques with the
//! base set at fresh states, and the known regroupings.

use crate::common;

use nalgebra::{DMatrix, DVector};
use powertwin::dynamics::base_params::{BaseParams, SamplingOptions, random_stack};
use powertwin::dynamics::regressor::regressor;
use powertwin::dynamics::{ParamLayout, Workspace};

#[test]
fn irb1200_counts_are_36_48_52() {
    let robot = common::irb1200();
    for ((friction, armature), expect) in [
        ((false, false), 36),
        ((true, false), 48),
        ((true, true), 52),
    ] {
        let layout = ParamLayout::new(&robot, friction, armature);
        let bp = BaseParams::compute(&robot, layout, &SamplingOptions::default()).unwrap();
        assert_eq!(
            bp.rank(),
            expect,
            "friction {friction} armature {armature}: {:?}",
            bp.base_names()
        );
    }
}

#[test]
fn base_regressor_reproduces_torques_at_fresh_states() {
    let robot = common::irb1200();
    let n = robot.dof();
    let layout = ParamLayout::new(&robot, true, true);
    let bp = BaseParams::compute(&robot, layout, &SamplingOptions::default()).unwrap();
    let theta = layout.theta(&robot, &common::drive_terms(n));
    let theta_b = DVector::from_vec(bp.base_values(&theta).unwrap());
    let theta = DVector::from_vec(theta);
    let mut ws = Workspace::new(&robot);
    let mut w = DMatrix::zeros(n, layout.len());
    let mut rng = common::rng(99);
    for _ in 0..300 {
        let (q, dq, ddq) = common::random_state(&robot, &mut rng);
        regressor(&robot, &mut ws, &layout, &q, &dq, &ddq, &mut w);
        let full = &w * &theta;
        let base = bp.base_regressor(&w) * &theta_b;
        for i in 0..n {
            assert!(
                (full[i] - base[i]).abs() < 1e-9 * (1.0 + full[i].abs()),
                "{} vs {}",
                full[i],
                base[i]
            );
        }
    }
}

#[test]
fn known_regroupings_of_the_irb1200() {
    let robot = common::irb1200();
    let layout = ParamLayout::new(&robot, true, true);
    let bp = BaseParams::compute(&robot, layout, &SamplingOptions::default()).unwrap();
    let names = bp.base_names();
    // Link 1 is seen only through ZZ1, which absorbs Ia1 and terms of later links.
    assert!(names.contains(&"ZZ1R".to_string()), "{names:?}");
    assert!(
        !names
            .iter()
            .any(|n| n.starts_with("Ia1") || n.starts_with("Ia2")),
        "{names:?}"
    );
    assert!(names.iter().any(|n| n.starts_with("Ia3")));
    for p in ["XX1", "YY1", "MX1", "M1", "YY2", "M2", "M6", "MZ6"] {
        assert!(
            !names.iter().any(|n| n.trim_end_matches('R') == p),
            "{p} should be dropped: {names:?}"
        );
    }
    // Khalil: XXR_j = XX_j - YY_j; MR_{j-1} = M_{j-1} + M_j ... here M5 is dropped too and
    // MX2R = MX2 + a3 (M3 + M4 + M5 + M6) with a3 = L2 = 0.35 m.
    let rel = bp.relations();
    let xx6 = rel.iter().find(|r| r.standard == "XX6").unwrap();
    assert!(
        xx6.terms
            .iter()
            .any(|(n, c)| n == "YY6" && (c + 1.0).abs() < 1e-9),
        "{xx6:?}"
    );
    let zz1 = rel.iter().find(|r| r.standard == "ZZ1").unwrap();
    assert!(
        zz1.terms
            .iter()
            .any(|(n, c)| n == "Ia1" && (c - 1.0).abs() < 1e-9),
        "{zz1:?}"
    );
    let mx2 = rel.iter().find(|r| r.standard == "MX2").unwrap();
    for m in ["M3", "M4", "M5", "M6"] {
        assert!(
            mx2.terms
                .iter()
                .any(|(n, c)| n == m && (c - 0.35).abs() < 1e-9),
            "{m} in {mx2:?}"
        );
    }
}

#[test]
fn nan_is_rejected_and_parameters_without_effect_are_named() {
    let robot = common::irb1200();
    let layout = ParamLayout::new(&robot, false, false);
    let stack = random_stack(
        &robot,
        &layout,
        &SamplingOptions {
            samples: 50,
            seed: 3,
        },
    )
    .unwrap();
    // NaN input is an error.
    let mut bad = stack.clone();
    bad[(3, 4)] = f64::NAN;
    let e = BaseParams::from_stack(&bad, layout).unwrap_err();
    assert!(e.to_string().contains("NaN"), "{e}");
    let bp = BaseParams::from_stack(&stack, layout).unwrap();
    let none = bp.without_effect();
    for p in ["XX1", "YY1", "XY1", "MX1", "MY1", "MZ1", "M1"] {
        assert!(none.contains(&p.to_string()), "{p} has no effect: {none:?}");
    }
}

/// `BaseParams::compute` remembers its last results: asking again for a robot gives that
/// robot's set, also after a robot of the same name with another geometry (joint 3 moved
/// from 0.35 to 0.40 m along the upper arm) was asked for in between.
#[test]
fn remembered_base_parameters_follow_the_geometry() {
    let robot = common::irb1200();
    let mut joints = robot.joints().to_vec();
    joints[2].origin.translation.vector *= 0.40 / 0.35;
    let longer = powertwin::model::Robot::new(
        robot.name(),
        robot.base().clone(),
        joints,
        robot.links().to_vec(),
        *robot.flange(),
        robot.flange_name(),
    )
    .unwrap();
    let layout = ParamLayout::new(&robot, true, true);
    let a3 = |r: &powertwin::model::Robot| {
        let bp = BaseParams::compute(r, layout, &SamplingOptions::default()).unwrap();
        let rel = bp.relations();
        let mx2 = rel.iter().find(|r| r.standard == "MX2").unwrap().clone();
        mx2.terms.iter().find(|(n, _)| n == "M3").unwrap().1
    };
    for (r, expect) in [
        (&robot, 0.35),
        (&longer, 0.40),
        (&robot, 0.35),
        (&longer, 0.40),
    ] {
        let got = a3(r);
        assert!((got - expect).abs() < 1e-9, "a3 {got}, expected {expect}");
    }
}
