//! Per-sample cost of the core algorithms on the 6-joint IRB 1200 (`cargo bench --bench core`).
//! Targets (issue 2): RNEA <= 0.6 us, regressor <= 1.2 us on the 2-core reference machine;
//! FK, Jacobian and IK are reported alongside.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::DMatrix;
use powertwin::dynamics::regressor::regressor;
use powertwin::dynamics::rnea::rnea;
use powertwin::dynamics::{DriveTerms, ParamLayout, Workspace};
use powertwin::kinematics::fk::flange_pose;
use powertwin::kinematics::ik::Opw;
use powertwin::kinematics::jacobian::geometric_into;
use powertwin::model::builtin;
use powertwin::model::urdf::{LoadOptions, load_str};

fn bench(c: &mut Criterion) {
    let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).expect("built-in model");
    let n = robot.dof();
    let mut ws = Workspace::new(&robot);
    let q = [0.3, 0.5, -0.4, 0.7, 0.9, 0.2];
    let dq = [0.5, -0.7, 0.9, 1.1, -1.3, 1.5];
    let ddq = [1.0, -2.0, 3.0, -4.0, 5.0, -6.0];
    let mut tau = vec![0.0; n];
    let drive = DriveTerms::from_urdf(&robot);
    for (name, terms) in [("rnea", None), ("rnea_with_friction", Some(&drive))] {
        c.bench_function(name, |b| {
            b.iter(|| {
                rnea(
                    &robot,
                    &mut ws,
                    black_box(&q),
                    black_box(&dq),
                    black_box(&ddq),
                    terms,
                    &mut tau,
                )
            })
        });
    }
    for (name, friction, armature) in [
        ("regressor", false, false),
        ("regressor_friction_armature", true, true),
    ] {
        let layout = ParamLayout::new(&robot, friction, armature);
        let mut w = DMatrix::zeros(n, layout.len());
        c.bench_function(name, |b| {
            b.iter(|| {
                regressor(
                    &robot,
                    &mut ws,
                    &layout,
                    black_box(&q),
                    black_box(&dq),
                    black_box(&ddq),
                    &mut w,
                )
            })
        });
    }
    c.bench_function("fk_flange", |b| {
        b.iter(|| flange_pose(&robot, black_box(&q)))
    });
    let tcp = nalgebra::Isometry3::translation(0.0, 0.0, 0.12);
    let mut jac = nalgebra::Matrix6xX::zeros(n);
    c.bench_function("jacobian", |b| {
        b.iter(|| geometric_into(&robot, black_box(&q), &tcp, &mut jac))
    });
    let opw = Opw::from_robot(&robot).expect("the IRB 1200 is of the OPW class");
    let target = flange_pose(&robot, &q);
    c.bench_function("ik_all_solutions", |b| {
        b.iter(|| opw.solve_all(black_box(&target)))
    });
    let target_tcp = target * tcp;
    c.bench_function("ik_nearest", |b| {
        b.iter(|| opw.solve_nearest(black_box(&target_tcp), &tcp, black_box(&q)))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
