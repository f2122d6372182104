//! Identification from logs (`cargo bench --bench identify`): three random 20 s Fourier
//! motions of the built-in IRB 1200 run on the twin (default settings and sensor noise) and
//! logged at 100 Hz and 1 kHz, then identified as `identify` does with its defaults: the
//! spline route, cross-validation of `total` and `pmsm` (leave one log out), power-level
//! weighting and the consistent projection. A minute of 1 kHz log is 60 000 samples.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use powertwin::dataset::meta::Urdf;
use powertwin::identification::data::Route;
use powertwin::identification::fit::{FitOptions, identify_logs};
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::urdf::{LoadOptions, load_str};
use powertwin::trajectory::random::{RandomFourierOptions, random_fourier};
use powertwin::twin::TwinConfig;
use powertwin::twin::sensor::SensorSettings;
use powertwin::validation::rig::Rig;
use rand::SeedableRng;

fn bench(c: &mut Criterion) {
    let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default()).expect("built-in model");
    let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "built-in", &robot).expect("drive");
    let opts = RandomFourierOptions {
        periods: 2.0,
        ..RandomFourierOptions::default()
    };
    let motions: Vec<_> = (0..3u64)
        .map(|seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            random_fourier(&robot, &mut rng, &opts).expect("random motion")
        })
        .collect();
    let mut group = c.benchmark_group("identify");
    group.sample_size(10);
    for rate_hz in [100.0, 1000.0] {
        let rig = Rig {
            plant: None,
            robot: &robot,
            urdf: Urdf::inline(builtin::IRB1200_URDF),
            drive: &drive,
            twin: TwinConfig::default(),
            sensor: SensorSettings {
                rate_hz,
                ..SensorSettings::default()
            },
        };
        let logs: Vec<_> = motions
            .iter()
            .enumerate()
            .map(|(k, traj)| {
                rig.run(traj, &[], k as u64, serde_json::json!({}))
                    .and_then(|d| d.log("bench"))
                    .expect("twin run")
            })
            .collect();
        group.bench_function(format!("three_20s_logs_at_{rate_hz}hz"), |b| {
            b.iter(|| {
                identify_logs(
                    &robot,
                    black_box(&logs),
                    &[Route::Spline],
                    &FitOptions::default(),
                )
                .expect("identifies")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
