//! Seeded mutation fuzzing of every reader of user files, on stable Rust (no cargo-fuzz).
//!
//! Each target mutates real inputs (the files under `models/` and `scenarios/`, a trajectory
//! table, a dataset written by the twin, measured logs in CSV and Parquet read with and
//! without a column map, column maps, a `model.json`) with bit flips, byte changes,
//! truncation, deleted and repeated ranges, swapped tokens, and numbers replaced by huge, tiny,
//! negative, NaN or infinite ones, and checks that the reader never panics. A second set of
//! mutations makes inputs that are certainly invalid (negative masses, inverted limits, NaN
//! values, truncated binaries) and checks that the reader returns `Err` instead of accepting
//! them silently.
//!
//! CI runs a short run (the default case counts below, a few thousand cases in all). A long
//! run sets the count per target, e.g.
//! `POWERTWIN_FUZZ_CASES=1000000 cargo test --release --test integration fuzz::`; see docs/design/fuzzing.md.
//! `POWERTWIN_FUZZ_SEED` changes the seed (default 0). A panic names the target, the case and
//! the file holding the input that caused it.

use crate::common;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use arrow_array::{
    ArrayRef, Float32Array, Float64Array, Int64Array, RecordBatch, StringArray,
    TimestampNanosecondArray,
};
use arrow_schema::{Field, Schema};
use powertwin::dataset::generate::{RunSpec, simulate};
use powertwin::dataset::meta::Urdf;
use powertwin::dataset::{Dataset, Format};
use powertwin::dynamics::ParamLayout;
use powertwin::identification::model::PowerModel;
use powertwin::io::table::{Table, to_csv};
use powertwin::measurement::columns::ColumnMap;
use powertwin::measurement::read::{LagOption, ReadOptions, read_log};
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::payload::Payload;
use powertwin::model::sampling::StateSampler;
use powertwin::model::urdf::{LoadOptions, load_str};
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::sampled::Sampled;
use powertwin::trajectory::task::Scenario;
use powertwin::twin::TwinConfig;
use powertwin::twin::physics::PhysicsSettings;
use powertwin::twin::sensor::{NoiseSettings, SensorSettings};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Numbers a mutation writes in place of a number token.
const NUMBERS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "+inf",
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "-1",
    "-7.5",
    "4294967297",
    "18446744073709551617",
    "-9223372036854775809",
    "1e999",
    "0x10",
    "1_0",
    ".",
    "-",
    "1e",
    "",
];
/// Fragments a mutation inserts: syntax of the formats read here.
const FRAGMENTS: &[&str] = &[
    "<",
    ">",
    "/>",
    "\"",
    "'",
    "=",
    "[",
    "]",
    "[[joint]]",
    "{",
    "}",
    ",",
    "\n",
    "\r\n",
    "\0",
    "<joint name=\"x\" type=\"revolute\">",
    "<link name=\"x\"/>",
    "lower=\"4\" upper=\"-4\"",
    "<mass value=\"-1\"/>",
    "mass_kg = -1\n",
    "name = \"joint_1\"\n",
    "\"theta\": [1e400]",
    "null",
    "true",
    "#",
    "\u{feff}",
    "é",
    "∞",
];

/// Cases per target: `POWERTWIN_FUZZ_CASES` when set, else `default`.
fn cases(default: usize) -> usize {
    std::env::var("POWERTWIN_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn base_seed() -> u64 {
    std::env::var("POWERTWIN_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// Byte ranges of number-like tokens (digits with sign, dot, exponent).
fn number_spans(b: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            || ((b[i] == b'-' || b[i] == b'.') && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        if starts && (i == 0 || !b[i - 1].is_ascii_alphanumeric() && b[i - 1] != b'_') {
            let s = i;
            i += 1;
            while i < b.len()
                && (b[i].is_ascii_digit() || matches!(b[i], b'.' | b'e' | b'E' | b'-' | b'+'))
            {
                i += 1;
            }
            spans.push((s, i));
        } else {
            i += 1;
        }
    }
    spans
}

/// Byte ranges of tokens: runs of alphanumerics or of other non-space characters.
fn token_spans(b: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_whitespace() {
            i += 1;
            continue;
        }
        let word = b[i].is_ascii_alphanumeric();
        let s = i;
        while i < b.len() && !b[i].is_ascii_whitespace() && b[i].is_ascii_alphanumeric() == word {
            i += 1;
        }
        spans.push((s, i));
    }
    spans
}

/// Apply one to four random mutations to `input`.
fn mutate(rng: &mut ChaCha8Rng, input: &[u8]) -> Vec<u8> {
    let mut b = input.to_vec();
    for _ in 0..rng.random_range(1..=4) {
        let n = b.len();
        match rng.random_range(0..9) {
            0 if n > 0 => {
                let i = rng.random_range(0..n);
                b[i] ^= 1 << rng.random_range(0..8);
            }
            1 if n > 0 => {
                let i = rng.random_range(0..n);
                b[i] = rng.random();
            }
            2 => b.truncate(rng.random_range(0..=n)),
            3 if n > 0 => {
                let s = rng.random_range(0..n);
                let e = (s + rng.random_range(1..=64)).min(n);
                b.drain(s..e);
            }
            4 if n > 0 => {
                let s = rng.random_range(0..n);
                let e = (s + rng.random_range(1..=256)).min(n);
                let copy = b[s..e].to_vec();
                let at = rng.random_range(0..=n);
                b.splice(at..at, copy);
            }
            5 | 6 => {
                let spans = number_spans(&b);
                if !spans.is_empty() {
                    let (s, e) = spans[rng.random_range(0..spans.len())];
                    let v = NUMBERS[rng.random_range(0..NUMBERS.len())];
                    b.splice(s..e, v.bytes());
                }
            }
            7 => {
                let spans = token_spans(&b);
                if spans.len() >= 2 {
                    let mut i = rng.random_range(0..spans.len());
                    let mut j = rng.random_range(0..spans.len());
                    if i > j {
                        std::mem::swap(&mut i, &mut j);
                    }
                    if i != j {
                        let ((s1, e1), (s2, e2)) = (spans[i], spans[j]);
                        let mut out = b[..s1].to_vec();
                        out.extend_from_slice(&b[s2..e2]);
                        out.extend_from_slice(&b[e1..s2]);
                        out.extend_from_slice(&b[s1..e1]);
                        out.extend_from_slice(&b[e2..]);
                        b = out;
                    }
                }
            }
            _ => {
                let f = FRAGMENTS[rng.random_range(0..FRAGMENTS.len())];
                let at = rng.random_range(0..=n);
                b.splice(at..at, f.bytes());
            }
        }
    }
    b
}

/// Run `cases` mutated inputs through `read` (in parallel, each case seeded by the target
/// name, the base seed and its index) and fail with every panic found; the inputs that
/// panicked are written next to the test's temporary files.
fn fuzz(target: &str, seeds: &[Vec<u8>], cases: usize, read: impl Fn(&[u8]) + Sync) {
    assert!(!seeds.is_empty());
    quiet_panics();
    let name_seed = target.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, c| {
        (h ^ c as u64).wrapping_mul(0x100_0000_01b3)
    });
    let seed = name_seed ^ base_seed();
    let start = Instant::now();
    let panics = Mutex::new(Vec::new());
    (0..cases).into_par_iter().for_each(|k| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(k as u64));
        let input = mutate(&mut rng, &seeds[k % seeds.len()]);
        if let Err(p) = catch_unwind(AssertUnwindSafe(|| read(&input))) {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            let file = common::tmp(&format!("fuzz-{target}-case{k}.bin"));
            let _ = std::fs::write(&file, &input);
            panics
                .lock()
                .unwrap()
                .push(format!("case {k}: {msg} (input: {})", file.display()));
        }
    });
    let panics = panics.into_inner().unwrap();
    eprintln!(
        "fuzz {target}: {cases} cases in {:.2} s, {} panics",
        start.elapsed().as_secs_f64(),
        panics.len()
    );
    // The quiet panic hook would swallow the assertion's message: print the panics first.
    for p in &panics {
        eprintln!("fuzz {target}: PANIC {p}");
    }
    assert!(panics.is_empty(), "{target}: {}", panics.join("\n"));
}

/// Whether `e` is a panic of the Parquet decoder that the reader caught.
fn decoder_failed(e: &powertwin::Error) -> bool {
    e.to_string().contains("the decoder failed")
}

/// Decoder panics that a reader caught and returned as errors, counted by cause (the panic
/// message with every number written `N`, so that one kind is one line).
#[derive(Default)]
struct Caught(Mutex<std::collections::BTreeMap<String, usize>>);

impl Caught {
    /// Count `e` if it is a caught decoder panic ([`decoder_failed`]).
    fn note(&self, e: &powertwin::Error) {
        let text = e.to_string();
        let Some(at) = text.find("the decoder failed (") else {
            return;
        };
        let message = &text[at + "the decoder failed (".len()..];
        let message = message.strip_suffix(')').unwrap_or(message);
        let mut cause = String::new();
        let mut in_number = false;
        for c in message.chars() {
            if !c.is_ascii_digit() {
                cause.push(c);
            } else if !in_number {
                cause.push('N');
            }
            in_number = c.is_ascii_digit();
        }
        *self.0.lock().unwrap().entry(cause).or_default() += 1;
    }

    /// Print the count and each cause of `target` to stderr.
    fn report(self, target: &str) {
        let causes = self.0.into_inner().unwrap();
        let total: usize = causes.values().sum();
        eprintln!("fuzz {target}: {total} decoder panics caught as errors");
        for (cause, n) in causes {
            eprintln!("fuzz {target}:   {n} x {cause}");
        }
    }
}

/// Silence the default panic message of caught panics (they are collected and reported).
fn quiet_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| std::panic::set_hook(Box::new(|_| {})));
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn model_file(name: &str) -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join(name)).unwrap()
}

/// Replace the first occurrence of `from` (which must occur) by `to`.
fn with(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

#[test]
fn urdf_loader() {
    let seeds = vec![
        model_file("models/irb1200_7_70.urdf"),
        model_file("tests/data/ur5.urdf"),
        model_file("tests/data/panda.urdf"),
    ];
    fuzz("urdf", &seeds, cases(400), |b| {
        if let Ok(robot) = load_str(&text(b), &LoadOptions::default())
            && let Ok(mut s) = StateSampler::new(&robot, 3.0, 10.0, 1)
        {
            let _ = s.pose();
        }
    });
    // Certainly invalid: each is an error, not a robot.
    let urdf = builtin::IRB1200_URDF;
    let mass = urdf.find("<mass value=\"").unwrap() + "<mass value=\"".len();
    let end = mass + urdf[mass..].find('"').unwrap();
    for bad_mass in ["-1", "nan", "inf", "0"] {
        let t = format!("{}{bad_mass}{}", &urdf[..mass], &urdf[end..]);
        assert!(
            load_str(&t, &LoadOptions::default()).is_err(),
            "mass {bad_mass}"
        );
    }
    for (lim, why) in [
        (r#"lower="2" upper="-2""#, "inverted limits"),
        (r#"lower="nan" upper="2""#, "NaN limit"),
    ] {
        let t = with(urdf, r#"lower="-2.967059728" upper="2.967059728""#, lim);
        assert!(load_str(&t, &LoadOptions::default()).is_err(), "{why}");
    }
    let t = with(urdf, r#"velocity="5.026548246""#, r#"velocity="-1""#);
    assert!(
        load_str(&t, &LoadOptions::default()).is_err(),
        "negative velocity"
    );
}

#[test]
fn drive_payload_scenario_and_noise_readers() {
    let robot = common::irb1200();
    let drives = vec![
        model_file("models/irb1200_7_70.drive.toml"),
        model_file("models/ideal.drive.toml"),
    ];
    fuzz("drive", &drives, cases(500), |b| {
        let _ = Drive::from_toml_str(&text(b), "fuzz", &robot);
    });
    let payloads: Vec<Vec<u8>> = ["tool_1p32kg", "load_1kg", "load_2kg", "load_4kg"]
        .iter()
        .map(|n| model_file(&format!("models/{n}.payload.toml")))
        .collect();
    fuzz("payload", &payloads, cases(500), |b| {
        let _ = Payload::from_toml_str(&text(b), "fuzz");
    });
    let scenario = vec![model_file("scenarios/pick_and_place.toml")];
    fuzz("scenario", &scenario, cases(500), |b| {
        let _ = Scenario::from_toml_str(&text(b), "fuzz");
    });
    let noise = "encoder_resolution_rad = 6e-6\nencoder_sigma_rad = 1e-5\n\
                 joint_power_sigma_W = 0.5\npower_sigma_W = 1.0\npower_offset_W = 0.0\n";
    assert!(NoiseSettings::from_toml_str(noise, "noise").is_ok());
    fuzz("noise", &[noise.as_bytes().to_vec()], cases(500), |b| {
        let _ = NoiseSettings::from_toml_str(&text(b), "fuzz");
    });

    // Certainly invalid values are errors.
    let drive = builtin::IRB1200_DRIVE;
    for bad in ["nan", "inf", "1.5", "-0.87", "0"] {
        let t = with(drive, "efficiency = 0.87", &format!("efficiency = {bad}"));
        assert!(
            Drive::from_toml_str(&t, "d", &robot).is_err(),
            "efficiency {bad}"
        );
    }
    for bad in ["-7.0", "nan", "0.0"] {
        let t = with(
            drive,
            "rated_payload_kg = 7.0",
            &format!("rated_payload_kg = {bad}"),
        );
        assert!(
            Drive::from_toml_str(&t, "d", &robot).is_err(),
            "rated payload {bad}"
        );
    }
    let tool = text(&payloads[0]);
    for bad in ["-1.32", "nan", "inf", "0.0"] {
        let t = with(&tool, "mass_kg = 1.32", &format!("mass_kg = {bad}"));
        assert!(Payload::from_toml_str(&t, "p").is_err(), "mass {bad}");
    }
    let sc = text(&scenario[0]);
    let t = with(&sc, "A = [0.40, 0.00, 0.40]", "A = [nan, 0.00, 0.40]");
    assert!(Scenario::from_toml_str(&t, "s").is_err(), "NaN via point");
    for bad in ["-1.0", "nan"] {
        let t = with(
            noise,
            "power_sigma_W = 1.0",
            &format!("power_sigma_W = {bad}"),
        );
        assert!(
            NoiseSettings::from_toml_str(&t, "n").is_err(),
            "noise {bad}"
        );
    }
}

/// A 6-joint trajectory table at rest near the home pose, `rows` samples 0.1 s apart.
fn trajectory_csv(rows: usize) -> String {
    let mut headers = vec!["t_s".to_string()];
    headers.extend((1..=6).map(|i| format!("q{i}_rad")));
    let mut cols = vec![(0..rows).map(|k| k as f64 * 0.1).collect::<Vec<_>>()];
    cols.extend((0..6).map(|j| (0..rows).map(|k| 0.01 * (j + k) as f64).collect()));
    to_csv(&headers, &cols)
}

#[test]
fn trajectory_table_reader() {
    let seeds = vec![
        trajectory_csv(12).into_bytes(),
        trajectory_csv(3).into_bytes(),
    ];
    fuzz("trajectory", &seeds, cases(800), |b| {
        if let Ok(table) = Table::parse(&text(b), "fuzz.csv")
            && let Ok(traj) = Sampled::from_table(&table, 6)
        {
            let (mut q, mut dq, mut ddq) = ([0.0; 6], [0.0; 6], [0.0; 6]);
            for f in [0.0, 0.37, 1.0] {
                traj.sample(f * traj.duration(), &mut q, &mut dq, &mut ddq);
            }
        }
    });
    let good = trajectory_csv(12);
    assert!(Sampled::from_table(&Table::parse(&good, "t").unwrap(), 6).is_ok());
    for (from, to, why) in [
        ("0.01,0.02", "nan,0.02", "NaN position"),
        ("0.01,0.02", "inf,0.02", "infinite position"),
        ("\n0.1,", "\n-5,", "times not increasing"),
    ] {
        let bad = with(&good, from, to);
        let r = Table::parse(&bad, "t").and_then(|t| Sampled::from_table(&t, 6));
        assert!(r.is_err(), "{why}");
    }
}

/// A small dataset of the twin (0.2 s at 5 ms, 50 Hz logging) written in `format` under a
/// fresh directory; returns the directory and its files' names and bytes.
fn written_dataset(format: Format, name: &str) -> (PathBuf, Vec<(String, Vec<u8>)>) {
    let robot = common::irb1200();
    let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "drive", &robot).unwrap();
    let table = Table::parse(&trajectory_csv(3), "traj.csv").unwrap();
    let traj = Sampled::from_table(&table, 6).unwrap();
    let twin = TwinConfig {
        physics: PhysicsSettings {
            dt: 0.005,
            substeps: 2,
        },
        ..TwinConfig::default()
    };
    let (ds, _) = simulate(&RunSpec {
        robot: &robot,
        urdf: Urdf::inline(builtin::IRB1200_URDF),
        drive: &drive,
        events: &[],
        brakes: &[],
        twin,
        sensor: SensorSettings {
            rate_hz: 50.0,
            ..SensorSettings::default()
        },
        trajectory: &traj,
        trajectory_description: serde_json::json!({"kind": "fuzz seed"}),
        trajectory_seed: None,
        family: None,
    })
    .unwrap();
    let dir = common::tmp(name);
    ds.write(&dir, format).unwrap();
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    files.sort();
    assert!(Dataset::read(&dir).is_ok());
    (dir, files)
}

/// Fuzz one file of a written dataset: each case writes the dataset's files into a case
/// directory with `file` mutated, then reads it.
fn fuzz_dataset(format: Format, label: &str, default_cases: usize) {
    let (dir, files) = written_dataset(format, &format!("fuzz-{label}-seed"));
    for (k, (file, bytes)) in files.iter().enumerate() {
        let others: Vec<(String, Vec<u8>)> =
            files.iter().filter(|(f, _)| f != file).cloned().collect();
        let target = format!("{label}-{file}");
        let count = cases(default_cases);
        let caught = Caught::default();
        fuzz(&target, std::slice::from_ref(bytes), count, |b| {
            let case = common::tmp(&format!(
                "fuzz-{label}-{k}-{:?}",
                std::thread::current().id()
            ));
            std::fs::create_dir_all(&case).unwrap();
            for (f, other) in &others {
                std::fs::write(case.join(f), other).unwrap();
            }
            std::fs::write(case.join(file), b).unwrap();
            if let Err(e) = Dataset::read(&case) {
                caught.note(&e);
            }
        });
        caught.report(&target);
        // A truncated file is an error, never a dataset.
        let case = common::tmp(&format!("fuzz-{label}-{k}-truncated"));
        std::fs::create_dir_all(&case).unwrap();
        for (f, b) in &files {
            let b = if f == file { &b[..b.len() / 2] } else { &b[..] };
            std::fs::write(case.join(f), b).unwrap();
        }
        assert!(Dataset::read(&case).is_err(), "{target} truncated");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn dataset_csv_reader() {
    fuzz_dataset(Format::Csv, "csv", 300);
    // A non-finite cell is an error naming its row.
    let (dir, files) = written_dataset(Format::Csv, "fuzz-csv-nan");
    let (name, bytes) = files
        .iter()
        .find(|(f, _)| f.starts_with("measured"))
        .unwrap();
    let t = text(bytes);
    let second_line = t.lines().nth(1).unwrap();
    let first_cell = second_line.split(',').next().unwrap();
    let bad = t.replacen(second_line, &second_line.replacen(first_cell, "NaN", 1), 1);
    std::fs::write(dir.join(name), bad).unwrap();
    let err = Dataset::read(&dir).unwrap_err().to_string();
    assert!(err.contains("row 2"), "{err}");
}

#[test]
fn dataset_parquet_reader() {
    fuzz_dataset(Format::Parquet, "parquet", 300);
    // Two mutated measured.parquet files of the long run on which the parquet 58.4.1 decoder
    // panics (a negative column range; an index out of bounds in the byte-stream-split
    // decoder): a clear error now.
    let (dir, _) = written_dataset(Format::Parquet, "fuzz-parquet-panics");
    for file in [
        "fuzz_measured_negative_column.parquet",
        "fuzz_measured_split_stream.parquet",
    ] {
        std::fs::copy(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data")
                .join(file),
            dir.join("measured.parquet"),
        )
        .unwrap();
        quiet_panics();
        let err = Dataset::read(&dir).unwrap_err().to_string();
        assert!(err.contains("corrupt Parquet file"), "{file}: {err}");
    }
}

/// One sample of a synthetic log.
struct Sample {
    /// Time, s.
    t_s: f64,
    /// Joint positions, rad.
    q_rad: Vec<f64>,
    /// Joint velocities, rad/s.
    dq_rad_s: Vec<f64>,
    /// Total power, W.
    power_w: f64,
}

/// `rows` samples `period_s` apart of `joints` joints moving as sines of different periods;
/// the power is 150 W plus a friction-like and a copper-loss-like term.
fn samples(joints: usize, rows: usize, period_s: f64) -> Vec<Sample> {
    (0..rows)
        .map(|k| {
            let t = k as f64 * period_s;
            let w: Vec<f64> = (0..joints).map(|i| 0.7 + 0.3 * i as f64).collect();
            let q_rad: Vec<f64> = w.iter().map(|w| 0.8 * (w * t).sin()).collect();
            let dq_rad_s: Vec<f64> = w.iter().map(|w| 0.8 * w * (w * t).cos()).collect();
            let power_w = 150.0
                + dq_rad_s
                    .iter()
                    .map(|v| 20.0 * v.abs() + 15.0 * v * v)
                    .sum::<f64>();
            Sample {
                t_s: t,
                q_rad,
                dq_rad_s,
                power_w,
            }
        })
        .collect()
}

/// Rows of the 3-joint logs: 14 s at 10 Hz, enough for the power-lag estimate (92 samples
/// inside the +-2 s search).
const LOG_ROWS: usize = 140;

/// A 3-joint CSV log in powertwin's own names (`t_s`, `q*_rad`, `dq*_rad_s`, `P_total_W`,
/// `p_elec*_W`), [`LOG_ROWS`] rows at 10 Hz; `motors_only` leaves out the velocities and the
/// total.
fn own_log_csv(motors_only: bool) -> String {
    let mut s = String::from("t_s,q1_rad,q2_rad,q3_rad");
    if !motors_only {
        s += ",dq1_rad_s,dq2_rad_s,dq3_rad_s,P_total_W";
    }
    s += ",p_elec1_W,p_elec2_W,p_elec3_W\n";
    for x in samples(3, LOG_ROWS, 0.1) {
        let mut row = vec![format!("{:.1}", x.t_s)];
        row.extend(x.q_rad.iter().map(|v| format!("{v:.6}")));
        if !motors_only {
            row.extend(x.dq_rad_s.iter().map(|v| format!("{v:.6}")));
            row.push(format!("{:.3}", x.power_w));
        }
        row.extend((0..3).map(|_| format!("{:.3}", x.power_w / 3.0)));
        s += &(row.join(",") + "\n");
    }
    s
}

/// A UR RTDE recording as `record.py` writes it (space-delimited, Unix time stamps with
/// 1 ms jitter, 125 Hz, 100 rows): the `ur-rtde` preset's columns and two it ignores.
fn rtde_log_csv() -> String {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut s = String::from("timestamp");
    for stem in ["actual_q", "actual_qd"] {
        for i in 0..6 {
            s += &format!(" {stem}_{i}");
        }
    }
    s += " actual_robot_voltage actual_robot_current target_q_0 safety_mode\n";
    for x in samples(6, 100, 0.008) {
        let stamp = 1_795_924_800.0 + x.t_s + rng.random_range(-1e-3..1e-3);
        s += &format!("{stamp:.4}");
        for v in x.q_rad.iter().chain(&x.dq_rad_s) {
            s += &format!(" {v:.6}");
        }
        s += &format!(" 48.0 {:.5} {:.6} 1\n", x.power_w / 48.0, x.q_rad[0]);
    }
    s
}

/// A semicolon-delimited log with every column [`COLUMN_MAPS`] name: `stamp` (ms, Unix
/// time), `time` (ISO 8601), `j1..j3` (deg; joint 3 turning 4 deg a sample more and logged
/// modulo 360 deg), `v1..v3` (deg/s), `P_kW`, `U_dc` (V), `I_dc` (A), `p1..p3` (W);
/// [`LOG_ROWS`] rows at 10 Hz.
fn mapped_log_csv() -> String {
    let mut s = String::from("stamp;time;j1;j2;j3;v1;v2;v3;P_kW;U_dc;I_dc;p1;p2;p3\n");
    for (k, x) in samples(3, LOG_ROWS, 0.1).iter().enumerate() {
        let q: Vec<f64> = x.q_rad.iter().map(|v| v.to_degrees()).collect();
        let dq: Vec<f64> = x.dq_rad_s.iter().map(|v| v.to_degrees()).collect();
        let j3 = (q[2] + 4.0 * k as f64 + 180.0).rem_euclid(360.0) - 180.0;
        let p = x.power_w;
        s += &format!(
            "{:.0};2026-11-23T10:{:02}:{:06.3}Z;{:.5};{:.5};{j3:.5};{:.5};{:.5};{:.5};{:.6};48.0;{:.5};{:.3};{:.3};{:.3}\n",
            1_795_924_800_000.0 + 1e3 * x.t_s,
            (x.t_s / 60.0).floor(),
            x.t_s % 60.0,
            q[0],
            q[1],
            dq[0],
            dq[1],
            dq[2] + 4.0 / 0.1,
            p / 1e3,
            p / 48.0,
            p / 3.0,
            p / 3.0,
            p / 3.0
        );
    }
    s
}

/// Column maps of [`mapped_log_csv`]: every key (milliseconds, degrees, a wrapped joint,
/// kW, all of `[clean]`); ISO 8601 stamps with voltage x current; per-motor columns.
const COLUMN_MAPS: [&str; 3] = [
    r#"delimiter = ";"

[time]
column = "stamp"
unit = "ms"

[joints]
position = ["j1", "j2", "j3"]
position_unit = "deg"
velocity = ["v1", "v2", "v3"]
velocity_unit = "deg/s"
wrapped = [3]

[power]
signal = "grid"
column = "P_kW"
unit = "kW"

[clean]
drop_missing = false
max_gap_periods = 5.0
on_gap = "split"
min_piece_samples = 20
working_rate_hz = 100.0
max_lag_s = 2.0
rest_speed_rad_s = 0.02
long_rest_s = 5.0
regularize_jitter = true
max_jitter_periods = 0.25
"#,
    r#"[time]
column = "time"
unit = "iso8601"

[joints]
position = ["j1", "j2", "j3"]
position_unit = "deg"
wrapped = [3]

[power]
signal = "bus"
voltage = "U_dc"
current = "I_dc"

[clean]
drop_missing = true
on_gap = "error"
"#,
    r#"[time]
column = "stamp"
unit = "ms"

[joints]
position = ["j1", "j2", "j3"]
position_unit = "deg"

[power]
signal = "per-motor"
motors = ["p1", "p2", "p3"]
"#,
];

/// A Parquet file of the Arrow `columns` (name and array; nullable) in one row group.
fn parquet_log(columns: Vec<(String, ArrayRef)>) -> Vec<u8> {
    let fields: Vec<Field> = columns
        .iter()
        .map(|(name, a)| Field::new(name, a.data_type().clone(), true))
        .collect();
    let schema = Arc::new(Schema::new(fields));
    let arrays = columns.into_iter().map(|(_, a)| a).collect();
    let batch = RecordBatch::try_new(schema.clone(), arrays).unwrap();
    let mut out = Vec::new();
    let mut w = parquet::arrow::ArrowWriter::try_new(&mut out, schema, None).unwrap();
    w.write(&batch).unwrap();
    w.close().unwrap();
    out
}

/// [`own_log_csv`] (with velocities and total power, no motors) as Parquet: `Float64`
/// columns, as a dataset's `measured.parquet`.
fn own_log_parquet() -> Vec<u8> {
    let x = samples(3, LOG_ROWS, 0.1);
    let col = |f: &dyn Fn(&Sample) -> f64| -> ArrayRef {
        Arc::new(Float64Array::from(x.iter().map(f).collect::<Vec<_>>()))
    };
    let mut columns = vec![("t_s".to_string(), col(&|s| s.t_s))];
    for i in 0..3 {
        columns.push((format!("q{}_rad", i + 1), col(&|s| s.q_rad[i])));
        columns.push((format!("dq{}_rad_s", i + 1), col(&|s| s.dq_rad_s[i])));
    }
    columns.push(("P_total_W".to_string(), col(&|s| s.power_w)));
    parquet_log(columns)
}

/// A Parquet log for [`PARQUET_MAP`]: a nanosecond timestamp column `stamp`, an ISO 8601
/// text column `time`, `Float32` positions in degrees and an `Int64` power in W;
/// [`LOG_ROWS`] rows at 10 Hz.
fn mapped_log_parquet() -> Vec<u8> {
    let x = samples(3, LOG_ROWS, 0.1);
    let ns = |t: f64| 1_795_924_800_000_000_000 + (t * 1e9).round() as i64;
    let mut columns: Vec<(String, ArrayRef)> = vec![
        (
            "stamp".into(),
            Arc::new(TimestampNanosecondArray::from(
                x.iter().map(|s| ns(s.t_s)).collect::<Vec<_>>(),
            )),
        ),
        (
            "time".into(),
            Arc::new(StringArray::from(
                x.iter()
                    .map(|s| format!("2026-11-23 10:00:{:06.3}+01:00", s.t_s))
                    .collect::<Vec<_>>(),
            )),
        ),
    ];
    for i in 0..3 {
        columns.push((
            format!("j{}", i + 1),
            Arc::new(Float32Array::from(
                x.iter()
                    .map(|s| s.q_rad[i].to_degrees() as f32)
                    .collect::<Vec<_>>(),
            )),
        ));
    }
    columns.push((
        "P_W".into(),
        Arc::new(Int64Array::from(
            x.iter()
                .map(|s| s.power_w.round() as i64)
                .collect::<Vec<_>>(),
        )),
    ));
    parquet_log(columns)
}

/// Column map of [`mapped_log_parquet`].
const PARQUET_MAP: &str = r#"[time]
column = "stamp"
unit = "ns"

[joints]
position = ["j1", "j2", "j3"]
position_unit = "deg"

[power]
column = "P_W"
"#;

/// Fuzz `read_log` on a log file: each case writes the mutated bytes to a file of the case's
/// thread (extension `ext`) and reads it with `map` (`None`: powertwin's own names) and the
/// power lag option `lag`. Prints how many mutated logs were still read.
fn fuzz_log(
    target: &str,
    seeds: &[Vec<u8>],
    ext: &str,
    map: Option<&ColumnMap>,
    lag: LagOption,
    count: usize,
) {
    let opts = ReadOptions { power: None, lag };
    let (read, caught) = (AtomicUsize::new(0), Caught::default());
    for seed in seeds {
        let path = common::tmp(&format!("fuzz-{target}-seed.{ext}"));
        std::fs::write(&path, seed).unwrap();
        if let Err(e) = read_log(&path, map, &opts) {
            panic!("{target}: the seed is not read: {e}");
        }
    }
    fuzz(target, seeds, count, |b| {
        let path = common::tmp(&format!(
            "fuzz-{target}-{:?}.{ext}",
            std::thread::current().id()
        ));
        std::fs::write(&path, b).unwrap();
        match read_log(&path, map, &opts) {
            Ok(_) => {
                read.fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => caught.note(&e),
        }
    });
    eprintln!(
        "fuzz {target}: {} of {count} mutated logs read",
        read.into_inner()
    );
    caught.report(target);
}

#[test]
fn log_csv_reader() {
    let own = vec![
        own_log_csv(false).into_bytes(),
        own_log_csv(true).into_bytes(),
    ];
    fuzz_log("log-csv", &own, "csv", None, LagOption::Auto, cases(150));
    // The RTDE log's power is shifted by a given lag (one working sample), not estimated: a
    // 6-joint lag estimate costs milliseconds a case, and the 3-joint logs fuzz it.
    let rtde = ColumnMap::ur_rtde();
    let seeds = vec![rtde_log_csv().into_bytes()];
    let lag = LagOption::Fixed(0.016);
    fuzz_log(
        "log-csv-ur-rtde",
        &seeds,
        "csv",
        Some(&rtde),
        lag,
        cases(150),
    );
    let mapped = vec![mapped_log_csv().into_bytes()];
    for (k, text) in COLUMN_MAPS.iter().enumerate() {
        let map = ColumnMap::from_toml_str(text, "map").unwrap();
        fuzz_log(
            &format!("log-csv-map{}", k + 1),
            &mapped,
            "csv",
            Some(&map),
            LagOption::Auto,
            cases(100),
        );
    }

    // Certainly invalid: each is an error, not a log.
    let good = own_log_csv(false);
    let lines: Vec<&str> = good.lines().collect();
    let second = lines[2].split(',').next().unwrap();
    for (from, to, why) in [
        (
            lines[2].to_string(),
            lines[2].replacen(second, "-5", 1),
            "time going backwards",
        ),
        (
            lines[3].to_string(),
            lines[3].replacen(',', ",inf,", 1),
            "an infinite cell",
        ),
        (
            lines[3].to_string(),
            lines[3].replacen(',', ",x,", 1),
            "a cell that is no number",
        ),
        (
            lines[3].to_string(),
            lines[3].replacen(',', ",NaN,", 1),
            "a NaN cell",
        ),
    ] {
        let path = common::tmp("fuzz-log-invalid.csv");
        std::fs::write(&path, with(&good, &from, &to)).unwrap();
        assert!(
            read_log(&path, None, &ReadOptions::default()).is_err(),
            "{why}"
        );
    }
    let path = common::tmp("fuzz-log-short.csv");
    std::fs::write(&path, lines[..2].join("\n")).unwrap();
    assert!(
        read_log(&path, None, &ReadOptions::default()).is_err(),
        "one data row"
    );
    let path = common::tmp("fuzz-log-lag.csv");
    std::fs::write(&path, &good).unwrap();
    let lag = ReadOptions {
        power: None,
        lag: LagOption::Fixed(1e3),
    };
    assert!(
        read_log(&path, None, &lag).is_err(),
        "a lag longer than the log"
    );
    // A mutated log of the long run whose two data rows are short (missing cells): with
    // `drop_missing` no row was left and the reader indexed the empty time column.
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz_log_missing_cells_only.csv");
    let map = ColumnMap::from_toml_str(COLUMN_MAPS[1], "map").unwrap();
    let err = read_log(&path, Some(&map), &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("2 of 2 data rows have missing cells"), "{err}");
}

#[test]
fn log_parquet_reader() {
    fuzz_log(
        "log-parquet",
        &[own_log_parquet()],
        "parquet",
        None,
        LagOption::Auto,
        cases(100),
    );
    let map = ColumnMap::from_toml_str(PARQUET_MAP, "map").unwrap();
    let seeds = vec![mapped_log_parquet()];
    let lag = LagOption::Auto;
    fuzz_log(
        "log-parquet-map",
        &seeds,
        "parquet",
        Some(&map),
        lag,
        cases(100),
    );
    let iso = with(
        PARQUET_MAP,
        "column = \"stamp\"\nunit = \"ns\"",
        "column = \"time\"\nunit = \"iso8601\"",
    );
    let iso = ColumnMap::from_toml_str(&iso, "map").unwrap();
    assert!(
        read_log(
            &parquet_file("iso", &seeds[0]),
            Some(&iso),
            &ReadOptions::default()
        )
        .is_ok()
    );
    // A truncated Parquet log is an error.
    let own = own_log_parquet();
    let path = parquet_file("truncated", &own[..own.len() / 2]);
    assert!(read_log(&path, None, &ReadOptions::default()).is_err());
    // Mutated Parquet files on which the parquet 58.4.1 decoder panics: a mutated log of the
    // short run ("offset + len out of bounds") and the two dataset files of the dataset
    // target (in powertwin's own names, so also a log): a clear error now.
    quiet_panics();
    for file in [
        "fuzz_log_offset_len.parquet",
        "fuzz_measured_negative_column.parquet",
        "fuzz_measured_split_stream.parquet",
    ] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(file);
        let err = read_log(&path, None, &ReadOptions::default()).unwrap_err();
        assert!(decoder_failed(&err), "{file}: {err}");
    }
}

/// `bytes` written to a temporary `.parquet` file named after `name`.
fn parquet_file(name: &str, bytes: &[u8]) -> PathBuf {
    let path = common::tmp(&format!("fuzz-log-{name}.parquet"));
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn column_map_toml() {
    let log = common::tmp("fuzz-column-map-log.csv");
    std::fs::write(&log, mapped_log_csv()).unwrap();
    for text in COLUMN_MAPS {
        let map = ColumnMap::from_toml_str(text, "map").unwrap();
        assert!(
            read_log(&log, Some(&map), &ReadOptions::default()).is_ok(),
            "{text}"
        );
    }
    let opts = ReadOptions {
        power: None,
        lag: LagOption::Auto,
    };
    // Each map that parses reads the log it was written for: odd but accepted values
    // (delimiters, units, cleaning settings) reach the reader.
    let seeds: Vec<Vec<u8>> = COLUMN_MAPS.iter().map(|m| m.as_bytes().to_vec()).collect();
    let count = cases(500);
    let (parsed, read) = (AtomicUsize::new(0), AtomicUsize::new(0));
    fuzz("column-map", &seeds, count, |b| {
        if let Ok(map) = ColumnMap::from_toml_str(&text(b), "fuzz") {
            parsed.fetch_add(1, Ordering::Relaxed);
            if read_log(&log, Some(&map), &opts).is_ok() {
                read.fetch_add(1, Ordering::Relaxed);
            }
        }
    });
    eprintln!(
        "fuzz column-map: {} of {count} mutated maps parsed, {} read the log",
        parsed.into_inner(),
        read.into_inner()
    );

    // Certainly invalid values are errors.
    let full = COLUMN_MAPS[0];
    for (from, to) in [
        ("working_rate_hz = 100.0", "working_rate_hz = 0.0"),
        ("working_rate_hz = 100.0", "working_rate_hz = nan"),
        ("max_gap_periods = 5.0", "max_gap_periods = 1.0"),
        ("max_lag_s = 2.0", "max_lag_s = -1.0"),
        ("min_piece_samples = 20", "min_piece_samples = 1"),
        ("max_jitter_periods = 0.25", "max_jitter_periods = nan"),
        ("max_jitter_periods = 0.25", "max_jitter_periods = -0.25"),
        ("wrapped = [3]", "wrapped = [0]"),
        ("wrapped = [3]", "wrapped = [4]"),
        ("velocity = [\"v1\", \"v2\", \"v3\"]", "velocity = [\"v1\"]"),
        ("delimiter = \";\"", "delimiter = \"é\""),
        ("unit = \"ms\"", "unit = \"minutes\""),
        (
            "column = \"P_kW\"",
            "column = \"P_kW\"\nvoltage = \"U_dc\"\ncurrent = \"I_dc\"",
        ),
    ] {
        let t = with(full, from, to);
        assert!(ColumnMap::from_toml_str(&t, "map").is_err(), "{to}");
    }
}

#[test]
fn power_model_json() {
    let robot = common::irb1200();
    let layout = ParamLayout::new(&robot, true, true);
    let model = PowerModel::new(&robot, layout, false).unwrap();
    let json = serde_json::to_vec_pretty(&model).unwrap();
    assert!(serde_json::from_slice::<PowerModel>(&json).is_ok());
    fuzz("model.json", std::slice::from_ref(&json), cases(800), |b| {
        let _ = serde_json::from_slice::<PowerModel>(b);
    });
    assert!(serde_json::from_slice::<PowerModel>(&json[..json.len() / 2]).is_err());
}

/// The mutations themselves: deterministic per seed and able to change every kind of input.
#[test]
fn mutations_are_seeded_and_change_the_input() {
    let input = trajectory_csv(5).into_bytes();
    let a = mutate(&mut ChaCha8Rng::seed_from_u64(5), &input);
    let b = mutate(&mut ChaCha8Rng::seed_from_u64(5), &input);
    assert_eq!(a, b);
    let changed = (0..200)
        .filter(|&s| mutate(&mut ChaCha8Rng::seed_from_u64(s), &input) != input)
        .count();
    assert!(
        changed > 180,
        "{changed} of 200 mutations changed the input"
    );
    assert_eq!(number_spans(b"x1 = -2.5e3, y=[4]"), vec![(5, 11), (16, 17)]);
}
