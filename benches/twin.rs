//! Twin speed (`cargo bench --bench twin`): wall time of one simulated second of tracking at
//! dt = 1 ms for several substep counts. Real-time factor = 1 s / reported time.
//! Goal (issue 3): >= 100x real time per core at <= 0.02 % torque residual.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
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

fn bench(c: &mut Criterion) {
    let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).expect("built-in model");
    let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "built-in drive", &robot)
        .expect("built-in drive");
    let mut group = c.benchmark_group("twin_1s_at_1ms");
    group.sample_size(20);
    for substeps in [1, 2, 4, 6, 8] {
        let cfg = TwinConfig {
            physics: PhysicsSettings { dt: 1e-3, substeps },
            ..TwinConfig::default()
        };
        let twin = Twin::new(&robot, &drive, cfg).expect("valid settings");
        group.bench_function(format!("substeps_{substeps}"), |b| {
            b.iter(|| twin.run(black_box(&Swing), &[], &[]).expect("runs"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
