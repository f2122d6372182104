//! Shared helpers for the integration tests.
#![allow(dead_code)]

#[cfg(feature = "viz")]
pub mod rrd;

use powertwin::Robot;
use powertwin::dynamics::DriveTerms;
use powertwin::model::urdf::{LoadOptions, load_file};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The default IRB 1200-7/0.7 model from `models/`.
pub fn irb1200() -> Robot {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/irb1200_7_70.urdf");
    load_file(&path, &LoadOptions::default()).expect("models/irb1200_7_70.urdf loads")
}

/// Deterministic RNG for tests.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// A random state inside the position limits (continuous joints in [-pi, pi]) with
/// velocities up to 2 rad/s and accelerations up to 5 rad/s^2.
pub fn random_state(robot: &Robot, rng: &mut ChaCha8Rng) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let q = robot
        .joints()
        .iter()
        .map(|j| {
            let lo = j.limits.lower.max(-std::f64::consts::PI);
            let hi = j.limits.upper.min(std::f64::consts::PI);
            rng.random_range(lo..hi)
        })
        .collect();
    let dq = (0..robot.dof())
        .map(|_| rng.random_range(-2.0..2.0))
        .collect();
    let ddq = (0..robot.dof())
        .map(|_| rng.random_range(-5.0..5.0))
        .collect();
    (q, dq, ddq)
}

/// Made-up drive terms of the right size: rotor inertia 0.3/i kg m^2, viscous 5/i N m s/rad,
/// Coulomb 8/i N m for joint i (1-based).
pub fn drive_terms(n: usize) -> DriveTerms {
    let scaled = |v: f64| (1..=n).map(|i| v / i as f64).collect();
    DriveTerms {
        rotor_inertia: scaled(0.3),
        viscous: scaled(5.0),
        coulomb: scaled(8.0),
    }
}

/// Run the `powertwin` binary from the temporary directory (so nothing depends on the
/// working directory); returns exit code, stdout and stderr.
pub fn run(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_powertwin"))
        .args(args)
        .current_dir(std::env::temp_dir())
        .output()
        .expect("the powertwin binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Run `powertwin` with `args`, which must succeed (exit 0; the assertion shows stderr);
/// returns stdout.
pub fn run_ok(args: &[&str]) -> String {
    let (code, out, err) = run(args);
    assert_eq!(code, 0, "powertwin {}: {err}", args.join(" "));
    out
}

/// A path `name` in the scratch directory of this test binary: `powertwin-<binary>` under
/// Every file of directory `dir` (not its subdirectories' contents) as name and bytes,
/// sorted by name.
pub fn dir_files(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

/// A path `name` in this test process's scratch directory, `powertwin-<binary>-<pid>` under
/// Cargo's `CARGO_TARGET_TMPDIR` (inside the target directory, so `cargo clean` removes it).
/// Tests of one binary share it, so names must differ between them. When a process first asks
/// for it, the scratch directories of earlier runs of the binary are removed (the reproduce
/// tests write hundreds of MB), but not those of runs still going: two test runs at once no
/// longer empty each other's files. Which runs are going is read from `/proc` (Linux);
/// without it every earlier directory is removed.
pub fn tmp(name: &str) -> std::path::PathBuf {
    static DIR: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let root = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
        let prefix = format!("powertwin-{}", env!("CARGO_CRATE_NAME"));
        let own = format!("{prefix}-{}", std::process::id());
        let running = |pid: &str| std::path::Path::new("/proc").join(pid).exists();
        for entry in std::fs::read_dir(root).into_iter().flatten().flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let stale = name == own
                || match name.strip_prefix(&prefix) {
                    // The one directory all runs shared before.
                    Some("") => true,
                    Some(rest) => rest.strip_prefix('-').is_some_and(|pid| {
                        !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()) && !running(pid)
                    }),
                    None => false,
                };
            // Another run starting at the same time may be removing it too.
            if stale
                && let Err(e) = std::fs::remove_dir_all(entry.path())
                && e.kind() != std::io::ErrorKind::NotFound
            {
                panic!("removing {}: {e}", entry.path().display());
            }
        }
        let dir = root.join(own);
        std::fs::create_dir_all(&dir).expect("scratch directory");
        dir
    })
    .join(name)
}

/// The built-in IRB 1200 drive file for `robot`.
pub fn irb1200_drive(robot: &Robot) -> powertwin::model::drive::Drive {
    powertwin::model::drive::Drive::from_toml_str(
        powertwin::model::builtin::IRB1200_DRIVE,
        "built-in",
        robot,
    )
    .expect("the built-in drive file reads")
}

/// A test rig of the IRB 1200 at 3 substeps: the realistic truth with its controller 10 %
/// wrong and a DC-bus meter, or the exact truth with a known controller and the motor sum.
pub fn irb1200_rig<'a>(
    robot: &'a Robot,
    drive: &'a powertwin::model::drive::Drive,
    fidelity: powertwin::twin::Fidelity,
    noise: powertwin::twin::sensor::NoiseSettings,
) -> powertwin::validation::rig::Rig<'a> {
    use powertwin::twin::sensor::SensorSettings;
    use powertwin::twin::{Fidelity, TwinConfig};
    let realistic = fidelity == Fidelity::Realistic;
    powertwin::validation::rig::Rig {
        plant: None,
        robot,
        urdf: powertwin::dataset::meta::Urdf::inline(powertwin::model::builtin::IRB1200_URDF),
        drive,
        twin: TwinConfig {
            physics: powertwin::twin::physics::PhysicsSettings {
                substeps: 3,
                ..Default::default()
            },
            fidelity,
            nominal_error: if realistic { 0.1 } else { 0.0 },
            ..TwinConfig::default()
        },
        sensor: SensorSettings {
            noise,
            power_signal: if realistic {
                powertwin::measurement::PowerSignal::Bus
            } else {
                powertwin::measurement::PowerSignal::Total
            },
            ..SensorSettings::default()
        },
    }
}

/// `count` random states of `robot` (velocities up to 1.5 rad/s, accelerations up to
/// 4 rad/s^2, from state seed `state_seed`) 0.1 s apart, with the power `model` predicts at
/// each plus Gaussian noise (seed `noise_seed`) of standard deviation `sd(active)` W, where
/// `active` is the predicted power above the model's standby: `(states, power)`.
pub fn model_power_samples(
    robot: &Robot,
    model: &powertwin::identification::model::PowerModel,
    count: usize,
    (state_seed, noise_seed): (u64, u64),
    sd: impl Fn(f64) -> f64,
) -> (powertwin::identification::states::States, Vec<f64>) {
    use rand_distr::{Distribution, StandardNormal};
    let n = robot.dof();
    let mut sampler =
        powertwin::model::sampling::StateSampler::new(robot, 1.5, 4.0, state_seed).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(noise_seed);
    let mut s = powertwin::identification::states::States {
        t: (0..count).map(|k| k as f64 * 0.1).collect(),
        q: vec![Vec::new(); n],
        dq: vec![Vec::new(); n],
        ddq: vec![Vec::new(); n],
    };
    let mut ws = powertwin::dynamics::Workspace::new(robot);
    let mut w = nalgebra::DMatrix::zeros(n, model.layout.len());
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let standby: f64 = model.constant.iter().sum();
    let mut y = Vec::with_capacity(count);
    for _ in 0..count {
        sampler.state(&mut q, &mut dq, &mut ddq);
        for i in 0..n {
            s.q[i].push(q[i]);
            s.dq[i].push(dq[i]);
            s.ddq[i].push(ddq[i]);
        }
        let p = model.power(robot, &mut ws, &mut w, &q, &dq, &ddq);
        let z: f64 = StandardNormal.sample(&mut rng);
        y.push(p + sd((p - standby).abs()) * z);
    }
    (s, y)
}

/// An excitation written by `excite` (all columns, 3 periods) and a model identified from its
/// run on the realistic twin with the efficiency motor model and no sensor noise (`identify
/// --method total`, the cheapest route): `(trajectory CSV, model.json)` in this binary's
/// scratch directory, built once per test binary.
pub fn efficiency_model() -> &'static (std::path::PathBuf, std::path::PathBuf) {
    static FIXTURE: std::sync::OnceLock<(std::path::PathBuf, std::path::PathBuf)> =
        std::sync::OnceLock::new();
    FIXTURE.get_or_init(|| {
        let (traj, data, model) = (tmp("ex.csv"), tmp("ds"), tmp("model.json"));
        let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
        run_ok(&[
            "excite",
            "--joints",
            "1-6",
            "--periods",
            "3",
            "--starts",
            "1",
            "--evals",
            "800",
            "--out",
            &s(&traj),
        ]);
        run_ok(&[
            "simulate",
            "--trajectory",
            &s(&traj),
            "--out",
            &s(&data),
            "--motor",
            "efficiency",
            "--noise",
            "none",
        ]);
        run_ok(&[
            "identify",
            "--data",
            &s(&data),
            "--method",
            "total",
            "--base-freq",
            "0.1",
            "--out",
            &s(&model),
        ]);
        (traj, model)
    })
}

/// The realistic IRB 1200 rig of [`irb1200_rig`] (default noise) logged at 20 Hz, with a
/// 50 W cabinet load the DC-bus meter sees after its clip: the meter reads `max(P, 50 W)`.
pub fn irb1200_cabinet_rig<'a>(
    robot: &'a Robot,
    drive: &'a powertwin::model::drive::Drive,
) -> powertwin::validation::rig::Rig<'a> {
    let base = irb1200_rig(
        robot,
        drive,
        powertwin::twin::Fidelity::Realistic,
        powertwin::twin::sensor::NoiseSettings::default(),
    );
    powertwin::validation::rig::Rig {
        sensor: powertwin::twin::sensor::SensorSettings {
            rate_hz: 20.0,
            ..base.sensor
        },
        twin: powertwin::twin::TwinConfig {
            cabinet_power_w: 50.0,
            ..base.twin.clone()
        },
        ..base
    }
}
