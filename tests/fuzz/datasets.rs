//! Fuzzing the dataset readers (CSV and Parquet datasets written by the twin).

use super::*;

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
    let files = common::dir_files(&dir);
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
