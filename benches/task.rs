//! Task planning and energy prediction (`cargo bench --bench task`): the pick-and-place path
//! of the built-in scenario planned at 0.5 m/s with a 4 kg load (linear moves, IK per 2 ms
//! sample), and the energy an identified model predicts for it with its five payload events
//! (1 ms integration step). These two run once per sweep cell and 25 times per load in the
//! optimum search of `reproduce`. And a whole `optimize` of the task at 2 kg (every segment
//! priced at the timing grid, the dynamic programme, the least-energy curve; no twin runs),
//! whose target is under 20 s.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use powertwin::dynamics::ParamLayout;
use powertwin::identification::model::PowerModel;
use powertwin::model::builtin;
use powertwin::model::urdf::{LoadOptions, load_str};
use powertwin::trajectory::task::Scenario;

fn bench(c: &mut Criterion) {
    let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).expect("built-in model");
    let scenario = Scenario::builtin().expect("built-in scenario");
    let mut group = c.benchmark_group("pick_and_place");
    group.sample_size(20);
    group.bench_function("plan_0.5mps_4kg", |b| {
        b.iter(|| scenario.plan(&robot, black_box(0.5), 4.0).expect("plans"))
    });
    let plan = scenario.plan(&robot, 0.5, 4.0).expect("plans");
    let layout = ParamLayout::new(&robot, true, true);
    let mut model = PowerModel::new(&robot, layout, false).expect("model");
    model.theta.fill(0.1);
    group.bench_function("predict_energy_0.5mps_4kg", |b| {
        b.iter(|| {
            model
                .energy_with_payloads(&robot, &plan.motion, black_box(&plan.events), 1.0, 1e-3)
                .expect("predicts")
        })
    });
    group.finish();
    let mut group = c.benchmark_group("optimize");
    group.sample_size(10);
    let drive =
        powertwin::model::drive::Drive::from_toml_str(builtin::IRB1200_DRIVE, "built-in", &robot)
            .expect("built-in drive");
    let task = powertwin::optimize::segment::Task {
        robot: &robot,
        scenario: &scenario,
        load_kg: 2.0,
        model: &model,
        efficiency: 1.0,
    };
    group.bench_function("pick_and_place_2kg_at_0.5mps_cycle", |b| {
        b.iter(|| {
            powertwin::optimize::optimize(
                &task,
                black_box(0.5),
                powertwin::optimize::CycleBound::SlowdownPct(0.0),
                drive.brakes(),
                &powertwin::optimize::Options::default(),
            )
            .expect("optimises")
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
