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

/// A 6-joint trajectory table at rest near the home pose, `rows` samples 0.1 s apart.
fn trajectory_csv(rows: usize) -> String {
    let mut headers = vec!["t_s".to_string()];
    headers.extend((1..=6).map(|i| format!("q{i}_rad")));
    let mut cols = vec![(0..rows).map(|k| k as f64 * 0.1).collect::<Vec<_>>()];
    cols.extend((0..6).map(|j| (0..rows).map(|k| 0.01 * (j + k) as f64).collect()));
    to_csv(&headers, &cols)
}

mod datasets;
mod files;
mod logs;

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
