//! Per-sample cost of the core algorithms on the 6-joint IRB 1200 (`cargo bench --bench core`).
//! Targets (issue 2): RNEA <= 0.6 us, regressor <= 1.2 us on the 2-core reference machine.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::DMatrix;
use powertwin::dynamics::regressor::regressor;
use powertwin::dynamics::rnea::rnea;
use powertwin::dynamics::{DriveTerms, ParamLayout, Workspace};
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
    c.bench_function("rnea", |b| {
        b.iter(|| {
            rnea(
                &robot,
                &mut ws,
                black_box(&q),
                black_box(&dq),
                black_box(&ddq),
                None,
                &mut tau,
            )
        })
    });
    let drive = DriveTerms::from_urdf(&robot);
    c.bench_function("rnea_with_friction", |b| {
        b.iter(|| {
            rnea(
                &robot,
                &mut ws,
                black_box(&q),
                black_box(&dq),
                black_box(&ddq),
                Some(&drive),
                &mut tau,
            )
        })
    });
    let layout = ParamLayout::new(&robot, false, false);
    let mut w = DMatrix::zeros(n, layout.len());
    c.bench_function("regressor", |b| {
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
    let layout = ParamLayout::new(&robot, true, true);
    let mut w = DMatrix::zeros(n, layout.len());
    c.bench_function("regressor_friction_armature", |b| {
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

criterion_group!(benches, bench);
criterion_main!(benches);
