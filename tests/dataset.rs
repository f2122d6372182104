//! Datasets: exact round trips in both formats, deterministic bytes, atomic writes and
//! replacement, and clear errors for corrupted inputs. Everything is synthetic (no twin).

use crate::common;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::{ArrayRef, Float64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::file::reader::{FileReader, SerializedFileReader};
use powertwin::dataset::meta::{
    BaseParamsInfo, DriveInfo, PayloadRecord, Program, RobotInfo, StandardParams, Summary, Urdf,
};
use powertwin::dataset::{Dataset, Format, Meta, SCHEMA_VERSION, truth_columns};
use powertwin::dynamics::ParamLayout;
use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::twin::TwinConfig;
use powertwin::twin::physics::PhysicsSettings;
use powertwin::twin::record::{Measured, Recording};
use powertwin::twin::sensor::{NoiseSettings, SensorSettings};
use powertwin::{Error, Robot};
use rand::Rng;

/// A fresh, empty scratch directory for one test (removed when dropped).
struct Scratch(PathBuf);

impl Scratch {
    fn new(test: &str) -> Scratch {
        let dir =
            std::env::temp_dir().join(format!("powertwin-dataset-{test}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    fn join(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// Names of everything in the scratch directory, sorted.
    fn entries(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Values that stress a round trip: signed zeros, subnormals, extremes, inexact decimals.
const SPECIAL: [f64; 9] = [
    0.0,
    -0.0,
    5e-324,
    f64::MIN_POSITIVE,
    f64::MAX,
    f64::MIN,
    0.1,
    1.0 / 3.0,
    -2.5e-17,
];

/// `rows` finite values: the special ones first, then random bit patterns.
fn series(rng: &mut impl Rng, rows: usize) -> Vec<f64> {
    let mut v: Vec<f64> = SPECIAL.iter().copied().take(rows).collect();
    while v.len() < rows {
        let x = f64::from_bits(rng.next_u64());
        if x.is_finite() {
            v.push(x);
        }
    }
    v
}

fn joint_series(rng: &mut impl Rng, dof: usize, rows: usize) -> Vec<Vec<f64>> {
    (0..dof).map(|_| series(rng, rows)).collect()
}

fn recording(rng: &mut impl Rng, dof: usize, rows: usize, dt: f64) -> Recording {
    Recording {
        dt,
        t: (0..rows).map(|k| k as f64 * dt).collect(),
        q: joint_series(rng, dof, rows),
        dq: joint_series(rng, dof, rows),
        q_ref: joint_series(rng, dof, rows),
        dq_ref: joint_series(rng, dof, rows),
        ddq_ref: joint_series(rng, dof, rows),
        tau: joint_series(rng, dof, rows),
        p_mech: joint_series(rng, dof, rows),
        p_elec: joint_series(rng, dof, rows),
        p_total: series(rng, rows),
        p_grid: series(rng, rows),
        payload_mass: vec![1.32; rows],
    }
}

fn measured(rng: &mut impl Rng, dof: usize, rows: usize, rate_hz: f64) -> Measured {
    Measured {
        rate_hz,
        t: (0..rows).map(|k| k as f64 / rate_hz).collect(),
        q: joint_series(rng, dof, rows),
        p_joint: joint_series(rng, dof, rows),
        p_total: series(rng, rows),
    }
}

/// Metadata of the IRB 1200 with its built-in drives and tool, for the given records.
fn meta(robot: &Robot, truth: &Recording, measured: &Measured) -> Meta {
    let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "drive", robot).unwrap();
    let layout = ParamLayout::new(robot, true, true);
    let theta = layout.theta(robot, &(&drive).into());
    let base = BaseParams::compute(robot, layout, &SamplingOptions::default()).unwrap();
    Meta {
        schema_version: SCHEMA_VERSION,
        program: Program::current(),
        robot: RobotInfo::new(robot, Urdf::inline(builtin::IRB1200_URDF)),
        drives: DriveInfo::per_joint(robot, &drive),
        payloads: vec![PayloadRecord::new(0.0, &builtin::payload("tool").unwrap())],
        base_params: BaseParamsInfo::new(&base, &theta).unwrap(),
        standard_params: StandardParams::new(&layout, theta).unwrap(),
        twin: TwinConfig {
            physics: PhysicsSettings {
                dt: truth.dt,
                substeps: 4,
            },
            nominal_error: 0.05,
            nominal_seed: 7,
            ..TwinConfig::default()
        },
        measurement: SensorSettings {
            rate_hz: measured.rate_hz,
            power_averaging: false,
            power_signal: powertwin::measurement::PowerSignal::Total,
            noise: NoiseSettings {
                power_offset_w: 3.0,
                ..NoiseSettings::default()
            },
            seed: u64::MAX,
            ..SensorSettings::default()
        },
        trajectory_seed: None,
        trajectory: serde_json::json!({"kind": "fourier", "harmonics": 5, "period_s": 10.0}),
        summary: Summary::of(truth, measured),
        family: None,
    }
}

/// A dataset of the IRB 1200 with `truth_rows` physics steps and `measured_rows` samples.
fn dataset(seed: u64, truth_rows: usize, measured_rows: usize) -> Dataset {
    let robot = common::irb1200();
    let mut rng = common::rng(seed);
    let truth = recording(&mut rng, robot.dof(), truth_rows, 1e-3);
    let measured = measured(&mut rng, robot.dof(), measured_rows, 250.0);
    Dataset {
        meta: meta(&robot, &truth, &measured),
        truth,
        measured,
    }
}

/// Every value of both records as bits, in column order, plus `dt` and `rate_hz`.
fn bits(d: &Dataset) -> Vec<u64> {
    let t = &d.truth;
    let m = &d.measured;
    let mut out = vec![t.dt.to_bits(), m.rate_hz.to_bits()];
    let scalars = [
        &t.t,
        &t.p_total,
        &t.p_grid,
        &t.payload_mass,
        &m.t,
        &m.p_total,
    ];
    let joints = [
        &t.q, &t.dq, &t.q_ref, &t.dq_ref, &t.ddq_ref, &t.tau, &t.p_mech, &t.p_elec, &m.q,
        &m.p_joint,
    ];
    for s in scalars {
        out.push(s.len() as u64);
        out.extend(s.iter().map(|v| v.to_bits()));
    }
    for j in joints {
        out.push(j.len() as u64);
        for s in j {
            out.push(s.len() as u64);
            out.extend(s.iter().map(|v| v.to_bits()));
        }
    }
    out
}

fn assert_same(read: &Dataset, written: &Dataset) {
    assert_eq!(read.meta, written.meta);
    assert!(bits(read) == bits(written), "values differ in their bits");
}

const FORMATS: [Format; 2] = [Format::Parquet, Format::Csv];

#[test]
fn both_formats_round_trip_bit_for_bit() {
    let scratch = Scratch::new("round-trip");
    let d = dataset(1, 1000, 100);
    for format in FORMATS {
        let dir = scratch.join(format.extension());
        d.write(&dir, format).unwrap();
        assert_eq!(Format::detect(&dir).unwrap(), format);
        let read = Dataset::read(&dir).unwrap();
        assert_same(&read, &d);
        let mut files = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect::<Vec<_>>();
        files.sort();
        let ext = format.extension();
        assert_eq!(
            files,
            [
                "measured.".to_string() + ext,
                "meta.json".into(),
                "truth.".to_string() + ext
            ]
        );
    }
}

#[test]
fn empty_records_round_trip() {
    let scratch = Scratch::new("empty");
    let d = dataset(2, 0, 0);
    for format in FORMATS {
        let dir = scratch.join(format.extension());
        d.write(&dir, format).unwrap();
        assert_same(&Dataset::read(&dir).unwrap(), &d);
    }
}

#[test]
fn long_tables_span_batches_and_row_groups() {
    // Parquet is written and read in batches of 65 536 rows and row groups of 524 288.
    let scratch = Scratch::new("long");
    let robot = common::irb1200();
    let mut rng = common::rng(3);
    let rows = 600_000;
    let dof = robot.dof();
    let smooth =
        |phase: f64| -> Vec<f64> { (0..rows).map(|k| (k as f64 * 1e-3 + phase).sin()).collect() };
    let joints =
        |base: f64| -> Vec<Vec<f64>> { (0..dof).map(|i| smooth(base + i as f64)).collect() };
    let truth = Recording {
        dt: 1e-3,
        t: (0..rows).map(|k| k as f64 * 1e-3).collect(),
        q: joints(0.0),
        dq: joints(10.0),
        q_ref: joints(20.0),
        dq_ref: joints(30.0),
        ddq_ref: joints(40.0),
        tau: joints(50.0),
        p_mech: joints(60.0),
        p_elec: joints(70.0),
        p_total: smooth(80.0),
        p_grid: smooth(90.0),
        payload_mass: vec![0.0; rows],
    };
    let measured = measured(&mut rng, dof, 70_000, 100.0);
    let d = Dataset {
        meta: meta(&robot, &truth, &measured),
        truth,
        measured,
    };
    let dir = scratch.join("ds");
    d.write(&dir, Format::Parquet).unwrap();
    let groups = SerializedFileReader::new(std::fs::File::open(dir.join("truth.parquet")).unwrap())
        .unwrap()
        .metadata()
        .num_row_groups();
    assert_eq!(groups, 2);
    assert_same(&Dataset::read(&dir).unwrap(), &d);
}

#[test]
fn the_same_dataset_gives_the_same_bytes() {
    let scratch = Scratch::new("bytes");
    let d = dataset(4, 300, 40);
    for format in FORMATS {
        let a = scratch.join(&format!("a-{}", format.extension()));
        let b = scratch.join(&format!("b-{}", format.extension()));
        d.write(&a, format).unwrap();
        d.write(&b, format).unwrap();
        for file in std::fs::read_dir(&a).unwrap() {
            let name = file.unwrap().file_name();
            let x = std::fs::read(a.join(&name)).unwrap();
            let y = std::fs::read(b.join(&name)).unwrap();
            assert!(x == y, "{name:?} differs between two writes");
        }
    }
    // Nothing time- or build-dependent in the Parquet footer.
    let reader = SerializedFileReader::new(
        std::fs::File::open(scratch.join("a-parquet/truth.parquet")).unwrap(),
    )
    .unwrap();
    let footer = reader.metadata().file_metadata();
    assert_eq!(
        footer.created_by(),
        Some(concat!("powertwin version ", env!("CARGO_PKG_VERSION")))
    );
    assert!(footer.key_value_metadata().is_none());
}

#[test]
fn a_failed_write_leaves_no_dataset() {
    let scratch = Scratch::new("failed");
    let d = dataset(5, 50, 10);

    // A parent that cannot be a directory (a file is in the way): an I/O error naming it,
    // nothing created. (Missing parents are created, as `mkdir -p` would.)
    std::fs::write(scratch.join("a_file"), b"not a directory").unwrap();
    let dir = scratch.join("a_file/ds");
    let e = d.write(&dir, Format::Parquet).unwrap_err();
    assert!(matches!(e, Error::Io { .. }), "{e}");
    assert!(e.to_string().contains("a_file"), "{e}");
    assert!(!dir.exists());
    let created = scratch.join("missing/parents/ds");
    d.write(&created, Format::Csv).unwrap();
    assert!(created.join("meta.json").exists());
    std::fs::remove_file(scratch.join("a_file")).unwrap();
    std::fs::remove_dir_all(scratch.join("missing")).unwrap();

    // A bad value in the measured table, found after truth.* is already written.
    let mut bad = d.clone();
    bad.measured.p_total[2] = f64::NAN;
    for format in FORMATS {
        let e = bad.write(&scratch.join("ds"), format).unwrap_err();
        assert!(matches!(e, Error::InvalidInput(_)), "{e}");
        let msg = e.to_string();
        assert!(
            msg.contains("measured: column 'p_total_W' is NaN at data row 3"),
            "{msg}"
        );
        assert!(scratch.entries().is_empty(), "{:?}", scratch.entries());
    }

    // The same failure while replacing a dataset keeps the old one intact.
    let dir = scratch.join("ds");
    d.write(&dir, Format::Csv).unwrap();
    bad.write(&dir, Format::Parquet).unwrap_err();
    assert_same(&Dataset::read(&dir).unwrap(), &d);
    assert_eq!(scratch.entries(), ["ds"]);
}

#[test]
fn overwriting_replaces_the_whole_dataset() {
    let scratch = Scratch::new("overwrite");
    let dir = scratch.join("ds");
    let first = dataset(6, 80, 8);
    let second = dataset(7, 120, 12);
    first.write(&dir, Format::Parquet).unwrap();
    second.write(&dir, Format::Csv).unwrap();
    assert!(!dir.join("truth.parquet").exists(), "old files are gone");
    assert_eq!(Format::detect(&dir).unwrap(), Format::Csv);
    assert_same(&Dataset::read(&dir).unwrap(), &second);
    assert_eq!(scratch.entries(), ["ds"], "no temporary or old copies left");

    // An empty directory may be filled; anything else that is not a dataset is refused.
    let empty = scratch.join("empty");
    std::fs::create_dir(&empty).unwrap();
    first.write(&empty, Format::Parquet).unwrap();
    let other = scratch.join("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "keep me").unwrap();
    let e = first
        .write(&other, Format::Parquet)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("refusing to replace") && e.contains("not a dataset"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(other.join("notes.txt")).unwrap(),
        "keep me"
    );
    let file = scratch.join("file");
    std::fs::write(&file, "x").unwrap();
    let e = first.write(&file, Format::Csv).unwrap_err().to_string();
    assert!(e.contains("not a directory"), "{e}");
}

#[test]
fn records_that_disagree_with_meta_are_not_written() {
    let scratch = Scratch::new("disagree");
    let dir = scratch.join("ds");
    let d = dataset(8, 20, 5);
    type Spoil = fn(&mut Dataset);
    let cases: [(Spoil, &str); 5] = [
        (
            |d| {
                d.truth.q.pop();
            },
            "truth: series 'q' has 5 joints, the robot has 6",
        ),
        (
            |d| {
                d.truth.tau[2].push(0.0);
            },
            "truth: column 'tau3_Nm' has 21 values, 't_s' has 20",
        ),
        (
            |d| d.truth.dt = 2e-3,
            "truth.dt = 0.002 s but meta.twin.physics.dt_s = 0.001 s",
        ),
        (
            |d| d.meta.summary.measured_rows = 6,
            "measured has 5 rows but meta.summary.measured_rows = 6",
        ),
        (
            |d| {
                d.meta.drives.pop();
            },
            "drives has 5 entries, robot.dof is 6",
        ),
    ];
    for (spoil, expected) in cases {
        let mut bad = d.clone();
        spoil(&mut bad);
        let e = bad.write(&dir, Format::Csv).unwrap_err();
        assert!(matches!(e, Error::InvalidInput(_)), "{e}");
        assert!(e.to_string().contains(expected), "{e}");
        assert!(!dir.exists());
    }
}

/// Write `cols` under `names` with the stock Arrow writer (nullable columns, Arrow schema in
/// the footer, dictionary encoding: what other tools produce).
fn foreign_parquet(path: &Path, names: &[&str], cols: Vec<Vec<Option<f64>>>) {
    let fields: Vec<Field> = names
        .iter()
        .map(|n| Field::new(*n, DataType::Float64, true))
        .collect();
    let schema = Arc::new(Schema::new(fields));
    let arrays: Vec<ArrayRef> = cols
        .into_iter()
        .map(|c| Arc::new(Float64Array::from(c)) as ArrayRef)
        .collect();
    let batch = RecordBatch::try_new(schema.clone(), arrays).unwrap();
    let mut w = ArrowWriter::try_new(std::fs::File::create(path).unwrap(), schema, None).unwrap();
    w.write(&batch).unwrap();
    w.close().unwrap();
}

/// The message of reading `dir`, which must fail.
fn read_error(dir: &Path) -> String {
    Dataset::read(dir).unwrap_err().to_string()
}

#[test]
fn corrupted_parquet_tables_are_reported() {
    let scratch = Scratch::new("corrupt-parquet");
    let d = dataset(9, 30, 6);
    let dir = scratch.join("ds");
    let reset = || {
        d.write(&dir, Format::Parquet).unwrap();
    };

    // The wrong file: measured.parquet copied over truth.parquet.
    reset();
    std::fs::copy(dir.join("measured.parquet"), dir.join("truth.parquet")).unwrap();
    let e = read_error(&dir);
    assert!(
        e.contains("truth.parquet: missing column(s) 'dq1_rad_s'"),
        "{e}"
    );

    // Truncated.
    reset();
    let path = dir.join("truth.parquet");
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let e = read_error(&dir);
    assert!(
        e.contains("truth.parquet: not a readable Parquet file"),
        "{e}"
    );

    // Another writer's file: readable when complete, NaN and null cells named.
    let names = powertwin::dataset::measured_columns(6);
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let m = &d.measured;
    let in_file_order = std::iter::once(&m.t)
        .chain(&m.q)
        .chain(&m.p_joint)
        .chain(std::iter::once(&m.p_total));
    let mut cols: Vec<Vec<Option<f64>>> = in_file_order
        .map(|c| c.iter().copied().map(Some).collect())
        .collect();
    reset();
    foreign_parquet(&dir.join("measured.parquet"), &names, cols.clone());
    assert_same(&Dataset::read(&dir).unwrap(), &d);
    cols[3][4] = Some(f64::NAN);
    foreign_parquet(&dir.join("measured.parquet"), &names, cols.clone());
    let e = read_error(&dir);
    assert!(
        e.contains("measured.parquet: column 'q3_rad' is NaN at data row 5"),
        "{e}"
    );
    cols[3][4] = None;
    foreign_parquet(&dir.join("measured.parquet"), &names, cols.clone());
    let e = read_error(&dir);
    assert!(e.contains("column 'q3_rad' is null at data row 5"), "{e}");

    // Row counts that disagree with meta.json (tables from different runs).
    let other = dataset(10, 30, 7);
    let other_dir = scratch.join("other");
    other.write(&other_dir, Format::Parquet).unwrap();
    reset();
    std::fs::copy(
        other_dir.join("measured.parquet"),
        dir.join("measured.parquet"),
    )
    .unwrap();
    let e = read_error(&dir);
    assert!(
        e.contains("measured.parquet: 7 rows, but meta.json (summary.measured_rows) says 6"),
        "{e}"
    );

    // Missing table.
    reset();
    std::fs::remove_file(dir.join("measured.parquet")).unwrap();
    let e = read_error(&dir);
    assert!(e.contains("measured.parquet"), "{e}");
}

#[test]
fn corrupted_csv_tables_are_reported() {
    let scratch = Scratch::new("corrupt-csv");
    let d = dataset(11, 30, 6);
    let dir = scratch.join("ds");
    let truth = dir.join("truth.csv");
    let edit = |f: &dyn Fn(String) -> String| {
        d.write(&dir, Format::Csv).unwrap();
        let text = std::fs::read_to_string(&truth).unwrap();
        std::fs::write(&truth, f(text)).unwrap();
    };

    // Missing column: drop the last one (payload_kg) from every line.
    edit(&|text| {
        text.lines()
            .map(|l| &l[..l.rfind(',').unwrap()])
            .collect::<Vec<_>>()
            .join("\n")
    });
    let e = read_error(&dir);
    assert!(
        e.contains("truth.csv: missing column(s) 'payload_kg'"),
        "{e}"
    );

    // Renamed column.
    edit(&|text| text.replacen("q2_rad", "q2", 1));
    let e = read_error(&dir);
    assert!(
        e.contains("missing column(s) 'q2_rad'; unexpected column(s) 'q2'"),
        "{e}"
    );

    // NaN cell on the third data line (row 4 counting the header as row 1).
    edit(&|text| {
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let fields: Vec<&str> = lines[3].split(',').collect();
        let mut fields: Vec<String> = fields.iter().map(|s| s.to_string()).collect();
        fields[1] = "NaN".into();
        lines[3] = fields.join(",");
        lines.join("\n")
    });
    let e = read_error(&dir);
    assert!(
        e.contains("truth.csv: row 4: column 'q1_rad' is NaN (must be finite)"),
        "{e}"
    );

    // Truncated in the middle of a line.
    edit(&|text| text[..text.len() * 3 / 5].to_string());
    let e = read_error(&dir);
    assert!(e.contains("truth.csv"), "{e}");
}

#[test]
fn meta_json_round_trips_and_is_versioned() {
    let scratch = Scratch::new("meta");
    let d = dataset(12, 10, 2);
    let dir = scratch.join("ds");
    d.write(&dir, Format::Csv).unwrap();
    let path = dir.join("meta.json");
    let text = std::fs::read_to_string(&path).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["schema_version"], SCHEMA_VERSION);
    assert_eq!(v["program"]["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(v["robot"]["dof"], 6);
    assert_eq!(v["drives"][0]["joint"], "joint_1");
    assert!(v["drives"][0]["coulomb_Nm"].is_f64());
    assert!(v["summary"]["energy_total_J"].is_f64());
    assert_eq!(v["payloads"][0]["mass_kg"], 1.32);
    assert_eq!(v["measurement"]["seed"], u64::MAX);
    assert_eq!(v["twin"]["physics"]["dt_s"], 0.001);
    assert_eq!(v["twin"]["motor"], "pmsm");
    assert!(v["trajectory"]["kind"] == "fourier");
    assert_eq!(v["standard_params"]["names"][10], "fc1");
    assert_eq!(v["base_params"]["values"].as_array().unwrap().len(), 52);
    let sha = v["robot"]["urdf"]["sha256"].as_str().unwrap();
    assert_eq!(sha.len(), 64);
    assert!(
        v["robot"]["urdf"]["source"]["text"]
            .as_str()
            .unwrap()
            .contains("<robot")
    );
    let parsed: Meta = serde_json::from_str(&text).unwrap();
    assert_eq!(parsed, d.meta);

    let rewrite = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut v = v.clone();
        f(&mut v);
        std::fs::write(&path, serde_json::to_string(&v).unwrap()).unwrap();
        read_error(&dir)
    };
    let e = rewrite(&|v| v["schema_version"] = 99.into());
    assert!(
        e.contains("meta.json: schema_version 99 is not supported"),
        "{e}"
    );
    let e = rewrite(&|v| {
        v.as_object_mut().unwrap().remove("schema_version");
    });
    assert!(e.contains("no schema_version"), "{e}");
    let e = rewrite(&|v| v["twin"]["physics"]["dt_ms"] = 1.into());
    assert!(e.contains("meta.json: unknown field `dt_ms`"), "{e}");
    let e = rewrite(&|v| v["robot"]["dof"] = 1_000_000_000.into());
    assert!(
        e.contains("robot.joint_names has 6 entries, robot.dof is 1000000000"),
        "{e}"
    );
    std::fs::write(&path, &text[..text.len() / 2]).unwrap();
    assert!(read_error(&dir).contains("meta.json: not valid JSON"));
    std::fs::remove_file(&path).unwrap();
    assert!(read_error(&dir).contains("meta.json"));
}

#[test]
fn format_names_and_detection() {
    assert_eq!("parquet".parse::<Format>().unwrap(), Format::Parquet);
    assert_eq!("csv".parse::<Format>().unwrap(), Format::Csv);
    let e = "json".parse::<Format>().unwrap_err().to_string();
    assert!(
        e.contains("unknown dataset format 'json' (valid: parquet, csv)"),
        "{e}"
    );
    let scratch = Scratch::new("detect");
    let e = Format::detect(&scratch.0).unwrap_err().to_string();
    assert!(e.contains("neither truth.parquet nor truth.csv"), "{e}");
    assert_eq!(truth_columns(6).len(), 52);
}
