//! Task planning and energy prediction (`cargo bench --bench task`): the pick-and-place path
//! of the built-in scenario planned at 0.5 m/s with a 4 kg load (linear moves, IK per 2 ms
//! sample), and the energy an identified model predicts for it with its five payload events
//! (1 ms integration step). These two run once per sweep cell and 25 times per load in the
//! optimum search of `reproduce`. The same task logged at 10 Hz and 100 Hz (positions with
//! 1e-5 rad of encoder noise) is predicted along the log route (rests held still, the
//! least-jerk spline smoothed for the log's noise), as `predict` does with a held-out log.
//! And a whole `optimize` of the task at 2 kg (every segment priced at the timing grid, the
//! dynamic programme, the least-energy curve; no twin runs), whose target is under 20 s.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use powertwin::dynamics::ParamLayout;
use powertwin::identification::data::prepare;
use powertwin::identification::model::PowerModel;
use powertwin::measurement::{Log, PowerSignal};
use powertwin::model::builtin;
use powertwin::model::urdf::{LoadOptions, load_str};
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::task::Scenario;
use powertwin::validation::heldout::LOG_ROUTE;
use rand::{RngExt, SeedableRng};

/// `traj` logged at `rate_hz` with uniform encoder noise of 1e-5 rad standard deviation.
fn logged(traj: &dyn Trajectory, rate_hz: f64) -> Log {
    let n = traj.dof();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let count = (traj.duration() * rate_hz).floor() as usize + 1;
    let t_s: Vec<f64> = (0..count).map(|k| k as f64 / rate_hz).collect();
    let mut q_rad = vec![Vec::with_capacity(count); n];
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for &t in &t_s {
        traj.sample(t, &mut q, &mut dq, &mut ddq);
        for (series, v) in q_rad.iter_mut().zip(&q) {
            series.push(v + 1e-5 * 3f64.sqrt() * rng.random_range(-1.0..1.0f64));
        }
    }
    Log {
        source: format!("pick and place at {rate_hz} Hz"),
        robot: None,
        power_w: vec![0.0; count],
        t_s,
        q_rad,
        dq_rad_s: None,
        signal: PowerSignal::Total,
        motor_power_w: None,
        power_averaged: false,
        payloads: Vec::new(),
    }
}

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
    for rate_hz in [10.0, 100.0] {
        let log = Log {
            payloads: plan.events.clone(),
            ..logged(&plan.motion, rate_hz)
        };
        group.bench_function(format!("predict_from_{rate_hz}hz_log_0.5mps_4kg"), |b| {
            b.iter(|| {
                let p = prepare(black_box(&log), LOG_ROUTE).expect("prepares");
                model
                    .energy_with_payloads(&robot, p.motion.as_ref(), &p.motion_events(), 1.0, 1e-3)
                    .expect("predicts")
            })
        });
    }
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
    plan_file(c);
}

/// The Rust side of `benches/python_bench.py`: the plan `POWERTWIN_BENCH_PLAN` (CSV) priced
/// by the model file `POWERTWIN_BENCH_MODEL` as `Model.predict_trajectory` prices arrays
/// (interpolation, joint-limit check, energy and power at the samples). Skipped without them.
fn plan_file(c: &mut Criterion) {
    use powertwin::identification::model::DATASHEET_EFFICIENCY;
    use powertwin::identification::plan::{LIMIT_CHECK_DT_S, price};
    use powertwin::trajectory::sampled::Sampled;
    let (Ok(plan), Ok(model)) = (
        std::env::var("POWERTWIN_BENCH_PLAN"),
        std::env::var("POWERTWIN_BENCH_MODEL"),
    ) else {
        return;
    };
    let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).expect("built-in model");
    let text = std::fs::read_to_string(&model).expect("model file");
    let doc: serde_json::Value = serde_json::from_str(&text).expect("model JSON");
    let model: PowerModel = serde_json::from_value(doc["model"].clone()).expect("a model");
    let table = powertwin::io::table::Table::read(std::path::Path::new(&plan)).expect("plan");
    let t = table.column(&["t_s"]).expect("t_s").to_vec();
    let q: Vec<Vec<f64>> = table
        .joint_columns("q", "rad", robot.dof())
        .expect("q columns")
        .iter()
        .map(|c| c.to_vec())
        .collect();
    c.bench_function("predict_trajectory_plan_file", |b| {
        b.iter(|| {
            let traj = Sampled::new(t.clone(), q.clone(), None, None).expect("samples");
            powertwin::trajectory::limits::check_limits(&robot, &traj, LIMIT_CHECK_DT_S, None)
                .expect("within limits");
            price(
                &model,
                &robot,
                &traj,
                &[],
                DATASHEET_EFFICIENCY,
                traj.sample_times(),
            )
            .expect("prices")
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
