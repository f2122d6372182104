//! Twin speed (`cargo bench --bench twin`): wall time of one simulated second of tracking at
//! dt = 1 ms for several substep counts. Real-time factor = 1 s / reported time.
//! Goal (issue 33): >= 100x real time per core at <= 0.02 % torque residual.
//!
//! Before timing, each substep count's fidelity is printed: the worst joint's RMS residual of
//! the applied torque against exact inverse dynamics on the motion Rapier produced, as a
//! fraction of that joint's RMS torque (the measure of `tests/twin.rs`: its 10 s swing,
//! unloaded and with the rated 7 kg, mid-step state, samples with |dq| >= 0.02 rad/s).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use powertwin::Robot;
use powertwin::dynamics::rnea::rnea;
use powertwin::dynamics::{DriveTerms, Workspace};
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::payload::{Payload, PayloadEvent, attach};
use powertwin::model::urdf::{LoadOptions, load_str};
use powertwin::trajectory::Trajectory;
use powertwin::twin::physics::PhysicsSettings;
use powertwin::twin::{Twin, TwinConfig};

/// One second of a smooth multi-joint swing.
struct Swing;

impl Trajectory for Swing {
    fn dof(&self) -> usize {
        6
    }
    fn duration(&self) -> f64 {
        1.0
    }
    fn sample(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        for i in 0..6 {
            let w = std::f64::consts::TAU * (0.3 + 0.1 * i as f64);
            q[i] = 0.3 + 0.5 * (1.0 - (w * t).cos());
            dq[i] = 0.5 * w * (w * t).sin();
            ddq[i] = 0.5 * w * w * (w * t).cos();
        }
    }
}

/// The swing of `tests/twin.rs` (10 s): each joint `a (1 - cos w t)` around a bent arm.
struct FidelitySwing;

impl Trajectory for FidelitySwing {
    fn dof(&self) -> usize {
        6
    }
    fn duration(&self) -> f64 {
        10.0
    }
    fn sample(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        for i in 0..6 {
            let q0 = [0.1, 0.4, -0.3, 0.2, 0.9, 0.0][i];
            let a = [0.8, 0.4, 0.5, 1.2, 0.6, 1.5][i];
            let w = std::f64::consts::TAU * [0.1, 0.2, 0.3, 0.2, 0.3, 0.4][i];
            q[i] = q0 + a * (1.0 - (w * t).cos());
            dq[i] = a * w * (w * t).sin();
            ddq[i] = a * w * w * (w * t).cos();
        }
    }
}

/// Worst joint's relative RMS torque residual (fraction) of `cfg` on the fidelity swing,
/// unloaded and with the rated 7 kg cube 5 cm beyond the flange.
fn worst_residual(robot: &Robot, drive: &Drive, cfg: &TwinConfig) -> f64 {
    let terms = DriveTerms::from(drive);
    let twin = Twin::new(robot, drive, cfg.clone()).expect("valid settings");
    let payload = Payload::cube("rated load", 7.0, [0.0, 0.0, 0.05].into()).expect("cube");
    let mut worst: f64 = 0.0;
    for loaded in [false, true] {
        let (events, model) = if loaded {
            let e = PayloadEvent {
                t_s: 0.0,
                payload: Some(payload.clone()),
            };
            (vec![e], attach(robot, &payload).expect("attaches"))
        } else {
            (Vec::new(), robot.clone())
        };
        let (rec, _) = twin.run(&FidelitySwing, &events, &[]).expect("runs");
        let mut ws = Workspace::new(&model);
        let (mut sq, mut sr, mut tau) = ([0.0; 6], [0.0; 6], [0.0; 6]);
        let (mut qm, mut vm, mut am) = ([0.0; 6], [0.0; 6], [0.0; 6]);
        for k in 0..rec.len() - 1 {
            for i in 0..6 {
                qm[i] = 0.5 * (rec.q[i][k] + rec.q[i][k + 1]);
                vm[i] = 0.5 * (rec.dq[i][k] + rec.dq[i][k + 1]);
                am[i] = (rec.dq[i][k + 1] - rec.dq[i][k]) / rec.dt;
            }
            rnea(&model, &mut ws, &qm, &vm, &am, Some(&terms), &mut tau);
            for i in 0..6 {
                if vm[i].abs() >= 0.02 {
                    sq[i] += rec.tau[i][k].powi(2);
                    sr[i] += (rec.tau[i][k] - tau[i]).powi(2);
                }
            }
        }
        for i in 0..6 {
            worst = worst.max((sr[i] / sq[i]).sqrt());
        }
        if std::env::var_os("TWIN_BENCH_PER_JOINT").is_some() {
            let per: Vec<String> = (0..6)
                .map(|i| format!("{:.4}", 100.0 * (sr[i] / sq[i]).sqrt()))
                .collect();
            eprintln!("  loaded {loaded}: per joint % {}", per.join(" "));
        }
    }
    worst
}

fn bench(c: &mut Criterion) {
    let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).expect("built-in model");
    let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "built-in drive", &robot)
        .expect("built-in drive");
    let mut group = c.benchmark_group("twin_1s_at_1ms");
    group.sample_size(20);
    for substeps in [1, 2, 3, 4, 6, 8] {
        // The step rate alone: no settling before the run.
        let cfg = TwinConfig {
            physics: PhysicsSettings { dt: 1e-3, substeps },
            settle_s: 0.0,
            ..TwinConfig::default()
        };
        eprintln!(
            "twin_1s_at_1ms/substeps_{substeps}: torque residual (worst joint) {:.4} %",
            100.0 * worst_residual(&robot, &drive, &cfg)
        );
        let twin = Twin::new(&robot, &drive, cfg).expect("valid settings");
        group.bench_function(format!("substeps_{substeps}"), |b| {
            b.iter(|| twin.run(black_box(&Swing), &[], &[]).expect("runs"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
