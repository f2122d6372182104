//! Fuzzing the measured-log readers (CSV and Parquet, with and without a column map) and
//! the column-map files.

use super::*;

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
