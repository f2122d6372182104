//! Measured logs: column maps, messy time bases, units, the power lag, segments, the UR RTDE
//! preset on a log written by the twin, and identification from such a log.

use crate::common;

use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use powertwin::dataset::Dataset;
use powertwin::dataset::meta::Urdf;
use powertwin::identification::data::prepare;
use powertwin::identification::energy::window_energies;
use powertwin::identification::fit::{FitOptions, identify_logs};
use powertwin::measurement::columns::{ColumnMap, PowerKind};
use powertwin::measurement::lag::estimate_lag;
use powertwin::measurement::read::{LagOption, ReadOptions, ReadReport, parse_iso8601, read_log};
use powertwin::measurement::segments::{MoveOptions, SegmentSpec, auto_moves, select, slice_time};
use powertwin::measurement::{Log, PowerSignal};
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::trajectory::random::{RandomPointToPointOptions, random_point_to_point};
use powertwin::twin::TwinConfig;
use powertwin::twin::sensor::SensorSettings;
use powertwin::validation::heldout::LOG_ROUTE;
use powertwin::validation::rig::Rig;
use rand::RngExt;

fn write(name: &str, text: &str) -> PathBuf {
    let p = common::tmp(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn map(text: &str) -> ColumnMap {
    ColumnMap::from_toml_str(text, "test map").unwrap()
}

fn read(path: &Path, map: Option<&ColumnMap>) -> (Vec<Log>, ReadReport) {
    read_log(path, map, &ReadOptions::default()).unwrap()
}

fn read_err(path: &Path, map: Option<&ColumnMap>) -> String {
    read_log(path, map, &ReadOptions::default())
        .unwrap_err()
        .to_string()
}

/// A CSV in powertwin's names: two joints moving as sines, power 100 + 10 sin t, at the
/// times `t`.
fn own_csv(t: &[f64]) -> String {
    own_csv_sampled(t, t)
}

/// [`own_csv`] stamped `stamps` but sampled at the times `sampled` (a logger whose stamps
/// are not the sampling instants).
fn own_csv_sampled(stamps: &[f64], sampled: &[f64]) -> String {
    let mut s = String::from("t_s,q1_rad,q2_rad,P_total_W\n");
    for (&stamp, &t) in stamps.iter().zip(sampled) {
        s += &format!(
            "{stamp},{},{},{}\n",
            t.sin(),
            0.5 * t.cos(),
            100.0 + 10.0 * t.sin()
        );
    }
    s
}

#[test]
fn powertwin_names_just_work() {
    let t: Vec<f64> = (0..50).map(|k| 0.1 * k as f64).collect();
    let (logs, rep) = read(&write("own.csv", &own_csv(&t)), None);
    assert_eq!(logs.len(), 1);
    let l = &logs[0];
    assert_eq!((l.dof(), l.len(), rep.rows), (2, 50, 50));
    assert_eq!(l.signal, PowerSignal::Total);
    assert_eq!(l.q_rad[0][7], t[7].sin());
    assert_eq!(l.power_w[3], 100.0 + 10.0 * t[3].sin());
    assert!(l.dq_rad_s.is_none() && l.motor_power_w.is_none());
    assert_eq!((rep.duplicates_merged, rep.gaps, rep.decimation), (0, 0, 1));
    // Per-motor columns only: the total is their sum, the signal per-motor -> total.
    let mut s = String::from("t_s,q1_rad,dq1_rad_s,p_elec1_W\n");
    for k in 0..30 {
        s += &format!(
            "{},{},{},{}\n",
            0.1 * k as f64,
            k as f64 * 0.01,
            0.1,
            5.0 + k as f64
        );
    }
    let (logs, _) = read(&write("motors.csv", &s), None);
    assert_eq!(logs[0].power_w[4], 9.0);
    assert_eq!(logs[0].motor_power_w.as_ref().unwrap()[0][4], 9.0);
    assert_eq!(logs[0].dq_rad_s.as_ref().unwrap()[0][2], 0.1);
    // No power column: the error says what the own names are.
    let e = read_err(&write("nopower.csv", "t_s,q1_rad\n0,1\n1,2\n"), None);
    assert!(
        e.contains("no power column") && e.contains("--columns"),
        "{e}"
    );
}

#[test]
fn jittered_time_stamps_are_regularized_or_kept() {
    let mut rng = common::rng(3);
    let grid: Vec<f64> = (0..200).map(|k| 5.0 + 0.04 * k as f64).collect();
    let t: Vec<f64> = grid
        .iter()
        .map(|g| g + rng.random_range(-0.008..0.008))
        .collect();
    // By default the jittered stamps of a fixed-rate logger (samples taken on the grid)
    // become their uniform grid.
    let (logs, rep) = read(&write("jitter.csv", &own_csv_sampled(&t, &grid)), None);
    assert_eq!((logs.len(), logs[0].len(), rep.gaps), (1, 200, 0));
    assert_eq!(rep.regularized_pieces, 1);
    assert!(rep.regularized_max_dev_s > 0.002 && rep.regularized_max_dev_s <= 0.01);
    let steps: Vec<f64> = logs[0].t_s.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(steps.iter().all(|d| (d - 0.04).abs() < 2e-4), "{steps:?}");
    // A logger that samples at the uneven times it stamps: the positions are smoother
    // against the stamps than against the grid, and the stamps are kept.
    let (logs, rep) = read(&write("jitter_true.csv", &own_csv(&t)), None);
    assert_eq!(rep.regularized_pieces, 0, "{rep}");
    for k in 0..200 {
        assert!((logs[0].t_s[k] - (t[k] - t[0])).abs() < 1e-12);
    }
    // Kept as they are when asked.
    let mut m =
        ColumnMap::powertwin(&["t_s".into(), "q1_rad".into(), "P_total_W".into()], "x").unwrap();
    m.clean.regularize_jitter = false;
    let (logs, rep) = read(&write("jitter_kept.csv", &own_csv(&t)), Some(&m));
    assert_eq!(rep.regularized_pieces, 0);
    assert_eq!(rep.t0_s, t[0]);
    for k in 0..200 {
        assert!((logs[0].t_s[k] - (t[k] - t[0])).abs() < 1e-12);
    }
    // Uniform jitter of +-8 ms on both ends of a period: RMS 8 sqrt(2/3) = 6.5 ms.
    assert!(
        (0.0055..0.0075).contains(&rep.period_jitter_s),
        "{}",
        rep.period_jitter_s
    );
}

#[test]
fn duplicated_time_stamps_are_averaged_and_counted() {
    let s = "t_s,q1_rad,P_total_W\n0,0,10\n0.1,1,20\n0.1,3,40\n0.2,2,30\n0.2,2,30\n0.2,2,30\n0.3,3,30\n";
    let m = ColumnMap {
        clean: powertwin::measurement::columns::CleanOptions {
            min_piece_samples: 2,
            ..Default::default()
        },
        ..ColumnMap::powertwin(&["t_s".into(), "q1_rad".into(), "P_total_W".into()], "x").unwrap()
    };
    let (logs, rep) = read(&write("dup.csv", s), Some(&m));
    assert_eq!(rep.duplicates_merged, 3);
    for (a, b) in logs[0].t_s.iter().zip([0.0, 0.1, 0.2, 0.3]) {
        assert!((a - b).abs() < 1e-12, "{:?}", logs[0].t_s);
    }
    assert_eq!(logs[0].q_rad[0], vec![0.0, 2.0, 2.0, 3.0]);
    assert_eq!(logs[0].power_w, vec![10.0, 30.0, 30.0, 30.0]);
}

#[test]
fn time_going_backwards_is_an_error_naming_the_row() {
    let mut t: Vec<f64> = (0..30).map(|k| 0.1 * k as f64).collect();
    t[4] = 0.25; // data row 5 = CSV row 6 goes back from 0.3 s
    let e = read_err(&write("back.csv", &own_csv(&t)), None);
    assert!(e.contains("row 6") && e.contains("backwards"), "{e}");
    assert!(e.contains("back.csv"), "{e}");
    // Unix time: the error quotes the stamps as the file holds them and says what to do.
    let unix: Vec<f64> = t.iter().map(|t| 1.7e9 + t).collect();
    let e = read_err(&write("back_unix.csv", &own_csv(&unix)), None);
    assert!(
        e.contains("1700000000.25 s after 1700000000.3 s") && e.contains("sort"),
        "{e}"
    );
}

#[test]
fn odd_logs_are_read_with_a_warning_or_refused_when_no_robot_log_is_like_them() {
    let t = |rate: f64, n: usize| -> Vec<f64> { (0..n).map(|k| k as f64 / rate).collect() };
    let warned = |rep: &ReadReport, what: &str| rep.warnings.iter().any(|w| w.contains(what));
    // A log powertwin's own twin writes: no warning.
    let (_, rep) = read(&write("plain.csv", &own_csv(&t(10.0, 200))), None);
    assert!(rep.warnings.is_empty(), "{rep}");
    // 5 Hz: read, with a word on the rate.
    let (_, rep) = read(&write("slow.csv", &own_csv(&t(5.0, 100))), None);
    assert!(warned(&rep, "5.00 Hz"), "{rep}");
    // Milliseconds in a seconds column: no robot log is sampled once per 100 s.
    let e = read_err(&write("ms.csv", &own_csv(&t(0.01, 100))), None);
    assert!(
        e.contains("median sample period 100 s") && e.contains("ms"),
        "{e}"
    );
    // Power in kW: read, with a word on the unit.
    let kw = own_csv(&t(10.0, 200));
    let mut kw_lines = String::from("t_s,q1_rad,q2_rad,P_total_W\n");
    for line in kw.lines().skip(1) {
        let f: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        kw_lines += &format!("{},{},{},{}\n", f[0], f[1], f[2], f[3] / 1000.0);
    }
    let (_, rep) = read(&write("kw.csv", &kw_lines), None);
    assert!(warned(&rep, "kW"), "{rep}");
    // A signed motor sum read as DC-bus power.
    let mut signed = String::from("t_s,q1_rad,q2_rad,P_total_W\n");
    for t in t(10.0, 200) {
        signed += &format!("{t},{},{},{}\n", t.sin(), 0.5 * t.cos(), 100.0 * t.sin());
    }
    let p = write("signed.csv", &signed);
    let bus = ReadOptions {
        power: Some(PowerKind::Bus),
        lag: LagOption::Report,
    };
    let (_, rep) = read_log(&p, None, &bus).unwrap();
    assert!(warned(&rep, "--power total"), "{rep}");
    let (_, rep) = read(&p, None);
    assert!(!warned(&rep, "--power total"), "{rep}");
    // A column that does not follow the motion.
    let flat = signed
        .lines()
        .enumerate()
        .map(|(k, l)| match k {
            0 => l.to_string(),
            _ => {
                let f: Vec<&str> = l.split(',').collect();
                format!("{},{},{},200", f[0], f[1], f[2])
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let (_, rep) = read(&write("flat.csv", &flat), None);
    assert!(warned(&rep, "not its power"), "{rep}");
}

#[test]
fn positions_and_power_no_robot_can_have_are_refused_naming_the_sample() {
    let robot = common::irb1200();
    let t: Vec<f64> = (0..50).map(|k| 0.1 * k as f64).collect();
    let log = Log {
        source: "mine.csv".into(),
        robot: None,
        t_s: t.clone(),
        q_rad: (0..6)
            .map(|i| t.iter().map(|t| 0.1 * (t + i as f64).sin()).collect())
            .collect(),
        dq_rad_s: None,
        power_w: vec![300.0; t.len()],
        signal: PowerSignal::Bus,
        motor_power_w: None,
        power_averaged: false,
        payloads: Vec::new(),
    };
    log.check_robot(&robot).unwrap();
    // Positions in degrees: joint 2 at 40 "rad".
    let mut deg = log.clone();
    deg.q_rad[1][7] = 40.0;
    let e = deg.check_robot(&robot).unwrap_err().to_string();
    assert!(
        e.contains("joint 2") && e.contains("t = 0.700 s") && e.contains("degrees"),
        "{e}"
    );
    // A joint logged with a turn added stays readable.
    let mut turned = log.clone();
    turned.q_rad[3].iter_mut().for_each(|q| *q += TAU);
    turned.check_robot(&robot).unwrap();
    // A glitch of a megawatt, and one that would overflow any sum of squares.
    for glitch in [1e6, 1e308] {
        let mut g = log.clone();
        g.power_w[12] = glitch;
        let e = g.check_robot(&robot).unwrap_err().to_string();
        assert!(e.contains("t = 1.200 s") && e.contains("glitch"), "{e}");
    }
    // The bound is the arm's, read from its URDF: well above what it draws.
    let bound = Log::max_power_w(&robot);
    assert!((1e4..1e5).contains(&bound), "{bound} W");
}

#[test]
fn missing_cells_are_errors_naming_row_and_column_unless_dropped() {
    let t: Vec<f64> = (0..30).map(|k| 0.1 * k as f64).collect();
    let text = own_csv(&t);
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines[3] = "0.2,0.19866933079506122,NaN,101.98669330795061".into(); // CSV row 4
    lines[9] = "0.8,0.7173560908995228,,107.17356090899523".into(); // CSV row 10
    let p = write("nan.csv", &(lines.join("\n") + "\n"));
    let e = read_err(&p, None);
    assert!(
        e.contains("row 4") && e.contains("column 'q2_rad'") && e.contains("2 rows"),
        "{e}"
    );
    let m = map(r#"
[time]
column = "t_s"
[joints]
position = ["q1_rad", "q2_rad"]
[power]
column = "P_total_W"
[clean]
drop_missing = true
"#);
    let (logs, rep) = read(&p, Some(&m));
    assert_eq!(rep.missing_rows_dropped, 2);
    assert_eq!(logs[0].len(), 28);
    // A short row: the absent cells are missing too; a trailing delimiter is ignored.
    let short = "t_s,q1_rad,q2_rad,P_total_W\n0,1,2,3,\n0.1,1\n";
    let e = read_err(&write("short.csv", short), None);
    assert!(e.contains("row 3") && e.contains("column 'q2_rad'"), "{e}");
    // Text that is not a number is always an error.
    lines[3] = "0.2,0.19866933079506122,abc,101.98669330795061".into();
    let e = read_err(&write("text.csv", &(lines.join("\n") + "\n")), Some(&m));
    assert!(
        e.contains("row 4") && e.contains("'abc' is not a number"),
        "{e}"
    );
}

#[test]
fn gaps_split_the_log_or_are_refused() {
    let mut t: Vec<f64> = (0..60).map(|k| 0.1 * k as f64).collect();
    for v in &mut t[30..] {
        *v += 2.0; // a 2.1 s step between data rows 30 and 31 (CSV row 32)
    }
    let p = write("gap.csv", &own_csv(&t));
    let (logs, rep) = read(&p, None);
    assert_eq!((rep.gaps, logs.len()), (1, 2));
    assert_eq!((logs[0].len(), logs[1].len()), (30, 30));
    assert!((logs[1].t_s[0] - 5.0).abs() < 1e-12);
    assert_eq!(rep.pieces.len(), 2);
    // A short piece is dropped and counted.
    let mut t2 = t.clone();
    for v in &mut t2[50..] {
        *v += 3.0;
    }
    let (logs, rep) = read(&write("gap2.csv", &own_csv(&t2)), None);
    assert_eq!(
        (rep.gaps, logs.len(), rep.short_piece_samples_dropped),
        (2, 2, 10)
    );
    let m = map(r#"
[time]
column = "t_s"
[joints]
position = ["q1_rad", "q2_rad"]
[power]
column = "P_total_W"
[clean]
on_gap = "error"
"#);
    let e = read_err(&p, Some(&m));
    assert!(e.contains("row 32") && e.contains("gap of 2.100000"), "{e}");
}

#[test]
fn units_are_converted_deg_kw_ms_and_voltage_times_current() {
    let mut s = String::from("stamp;a;b;va;vb;P;U;I\n");
    for k in 0..40 {
        let t = 1000.0 + 20.0 * k as f64; // ms
        s += &format!(
            "{t};{};{};{};{};{};{};{}\n",
            90.0,
            180.0 + k as f64,
            57.0,
            -3.0,
            0.25,
            48.0,
            2.5
        );
    }
    let p = write("units.csv", &s);
    let m = map(r#"
[time]
column = "stamp"
unit = "ms"
[joints]
position = ["a", "b"]
position_unit = "deg"
velocity = ["va", "vb"]
velocity_unit = "deg/s"
[power]
signal = "grid"
column = "P"
unit = "kW"
"#);
    let (logs, rep) = read(&p, Some(&m));
    let l = &logs[0];
    assert_eq!(rep.t0_s, 1.0);
    assert!((l.t_s[39] - 0.78).abs() < 1e-12);
    assert!((l.q_rad[0][0] - PI / 2.0).abs() < 1e-15);
    assert!((l.q_rad[1][10] - 190.0_f64.to_radians()).abs() < 1e-14);
    assert!((l.dq_rad_s.as_ref().unwrap()[1][3] + 3.0_f64.to_radians()).abs() < 1e-15);
    assert_eq!(l.power_w[0], 250.0);
    assert_eq!(l.signal, PowerSignal::Grid);
    // Voltage x current on the same file, the DC bus.
    let m = map(r#"
[time]
column = "stamp"
unit = "ms"
[joints]
position = ["a", "b"]
position_unit = "deg"
[power]
signal = "bus"
voltage = "U"
current = "I"
"#);
    let (logs, _) = read(&p, Some(&m));
    assert_eq!(logs[0].power_w[5], 120.0);
    assert_eq!(logs[0].signal, PowerSignal::Bus);
    // --power overrides the map; per-motor without motor columns is refused.
    let e = read_log(
        &p,
        Some(&m),
        &ReadOptions {
            power: Some(PowerKind::PerMotor),
            ..ReadOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("per-motor") && e.contains("motors"), "{e}");
}

#[test]
fn unix_and_iso8601_time_stamps() {
    assert_eq!(parse_iso8601("1970-01-01T00:00:00Z"), Some(0.0));
    assert_eq!(parse_iso8601("2000-03-01 00:00:00"), Some(951_868_800.0));
    assert_eq!(
        parse_iso8601("2026-11-23T12:00:00.25+02:00"),
        Some(1_795_435_200.25 - 7200.0)
    );
    assert_eq!(parse_iso8601("2026-13-01T00:00:00Z"), None);
    assert_eq!(parse_iso8601("yesterday"), None);
    // ISO-8601 text at 10 Hz with an offset.
    let mut s = String::from("time,q,p\n");
    for k in 0..30 {
        s += &format!(
            "2026-11-23T12:00:{:02}.{}+02:00,{},{}\n",
            k / 10,
            k % 10,
            k,
            50
        );
    }
    let m = map(r#"
[time]
column = "time"
unit = "iso8601"
[joints]
position = ["q"]
[power]
column = "p"
"#);
    let (logs, rep) = read(&write("iso.csv", &s), Some(&m));
    assert_eq!(rep.t0_s, 1_795_435_200.0 - 7200.0);
    assert!((logs[0].t_s[29] - 2.9).abs() < 1e-6); // Unix seconds in f64: 0.2 us steps
    assert!((rep.median_period_s - 0.1).abs() < 1e-6);
    // Unix time in ms, 8 ms jitter-free at 125 Hz (below the working rate: kept).
    let mut s = String::from("unix_ms,q,p\n");
    for k in 0..100 {
        s += &format!("{},{},{}\n", 1_795_924_800_000_u64 + 8 * k, k, 50);
    }
    let m = map(r#"
[time]
column = "unix_ms"
unit = "ms"
[joints]
position = ["q"]
[power]
column = "p"
"#);
    let (logs, rep) = read(&write("unix.csv", &s), Some(&m));
    assert_eq!(rep.t0_s, 1_795_924_800.0);
    assert_eq!(rep.decimation, 2); // 125 Hz > 100 Hz: pairs averaged, 62.5 Hz
    assert_eq!(logs[0].len(), 50);
    assert!((logs[0].t_s[1] - logs[0].t_s[0] - 0.016).abs() < 1e-6);
    // Not a date: the row and column are named.
    let e = read_err(
        &write(
            "baddate.csv",
            "time,q,p\n2026-11-23T12:00:00Z,1,2\nnoon,1,2\n",
        ),
        Some(&map(r#"
[time]
column = "time"
unit = "iso8601"
[joints]
position = ["q"]
[power]
column = "p"
"#)),
    );
    assert!(e.contains("row 3") && e.contains("'time'"), "{e}");
}

#[test]
fn multi_turn_joints_stay_continuous_and_wrapped_columns_are_unwrapped() {
    // Joint 1 turns from 12 to 16.5 rad (multi-turn, logged continuous); joint 2 is the
    // same motion logged modulo 2 pi in (-pi, pi], wrapping once (at 5 pi).
    let t: Vec<f64> = (0..100).map(|k| 0.05 * k as f64).collect();
    let q: Vec<f64> = t.iter().map(|t| 12.0 + 0.9 * t).collect();
    let mut s = String::from("t_s,q1_rad,q2_rad,P_total_W\n");
    for (t, q) in t.iter().zip(&q) {
        let w = q.sin().atan2(q.cos());
        s += &format!("{t},{q},{w},1\n");
    }
    let p = write("turns.csv", &s);
    let (logs, rep) = read(&p, None);
    assert_eq!(logs[0].q_rad[0], q);
    assert_eq!(rep.unwrapped_jumps, 0);
    assert_eq!(rep.suspect_jumps, 1); // the wrap in q2, reported, not changed
    assert!(
        rep.warnings
            .iter()
            .any(|w| w.contains("joint 2") && w.contains("wrapped = [2]")),
        "{rep}"
    );
    let m = map(r#"
[time]
column = "t_s"
[joints]
position = ["q1_rad", "q2_rad"]
wrapped = [2]
[power]
column = "P_total_W"
"#);
    let (logs, rep) = read(&p, Some(&m));
    assert_eq!((rep.unwrapped_jumps, rep.suspect_jumps), (1, 0));
    for (u, q) in logs[0].q_rad[1].iter().zip(&q) {
        assert!((u - (q - 2.0 * TAU)).abs() < 1e-12);
    }
    let bad = ColumnMap::from_toml_str(
        "[time]\ncolumn = \"t\"\n[joints]\nposition = [\"a\"]\nwrapped = [2]\n[power]\ncolumn = \"p\"\n",
        "bad.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(bad.contains("bad.toml") && bad.contains("joint 2"), "{bad}");
}

#[test]
fn a_1khz_log_is_block_averaged_to_100hz_keeping_the_energy() {
    let t: Vec<f64> = (0..3000).map(|k| 1e-3 * k as f64).collect();
    let (logs, rep) = read(&write("fast.csv", &own_csv(&t)), None);
    let l = &logs[0];
    assert_eq!((rep.decimation, l.len()), (10, 300));
    assert!((rep.working_rate_hz - 100.0).abs() < 1e-6);
    assert!((l.t_s[0] - 0.0045).abs() < 1e-12);
    let mean_in: f64 = t.iter().map(|t| 100.0 + 10.0 * t.sin()).sum::<f64>() / 3000.0;
    let mean_out: f64 = l.power_w.iter().sum::<f64>() / 300.0;
    assert!((mean_in - mean_out).abs() < 1e-9, "{mean_in} {mean_out}");
    // Positions: the block mean of sin is within 1e-5 rad of sin at the mean time.
    for k in 0..300 {
        assert!((l.q_rad[0][k] - l.t_s[k].sin()).abs() < 1e-5);
    }
}

#[test]
fn parquet_logs_with_int_timestamps_and_f32_columns() {
    use arrow_array::{ArrayRef, Float32Array, Float64Array, Int64Array, RecordBatch};
    use arrow_schema::{DataType, Field, Schema};
    let n = 40;
    let schema = Arc::new(Schema::new(vec![
        Field::new("ns", DataType::Int64, false),
        Field::new("q", DataType::Float32, true),
        Field::new("p", DataType::Float64, false),
    ]));
    let ns: Vec<i64> = (0..n)
        .map(|k| 1_795_924_800_000_000_000 + 40_000_000 * k)
        .collect();
    let q: Vec<Option<f32>> = (0..n).map(|k| Some(0.5 * k as f32)).collect();
    let p: Vec<f64> = (0..n).map(|k| 10.0 + k as f64).collect();
    let cols: Vec<ArrayRef> = vec![
        Arc::new(Int64Array::from(ns)),
        Arc::new(Float32Array::from(q.clone())),
        Arc::new(Float64Array::from(p)),
    ];
    let batch = RecordBatch::try_new(schema.clone(), cols).unwrap();
    let path = common::tmp("log.parquet");
    let f = std::fs::File::create(&path).unwrap();
    let mut w = parquet::arrow::ArrowWriter::try_new(f, schema.clone(), None).unwrap();
    w.write(&batch).unwrap();
    w.close().unwrap();
    let m = map(
        "[time]\ncolumn = \"ns\"\nunit = \"ns\"\n[joints]\nposition = [\"q\"]\n[power]\ncolumn = \"p\"\n",
    );
    let (logs, rep) = read(&path, Some(&m));
    assert!((rep.t0_s - 1_795_924_800.0).abs() < 1e-6);
    assert!((logs[0].t_s[39] - 1.56).abs() < 1e-6);
    assert_eq!(logs[0].q_rad[0][3], 1.5);
    assert_eq!(logs[0].power_w[2], 12.0);
    // A null cell is named by column and data row.
    let mut q2 = q;
    q2[6] = None;
    let cols: Vec<ArrayRef> = vec![
        Arc::new(Int64Array::from(
            (0..n).map(|k| k * 40_000_000).collect::<Vec<_>>(),
        )),
        Arc::new(Float32Array::from(q2)),
        Arc::new(Float64Array::from(vec![1.0; n as usize])),
    ];
    let path = common::tmp("null.parquet");
    let f = std::fs::File::create(&path).unwrap();
    let mut w = parquet::arrow::ArrowWriter::try_new(f, schema.clone(), None).unwrap();
    w.write(&RecordBatch::try_new(schema, cols).unwrap())
        .unwrap();
    w.close().unwrap();
    let e = read_err(&path, Some(&m));
    assert!(e.contains("data row 7") && e.contains("column 'q'"), "{e}");
}

#[test]
fn segment_ranges_parse_and_slice() {
    assert_eq!(
        "0-12.5, 20-40".parse::<SegmentSpec>().unwrap(),
        SegmentSpec::Ranges(vec![(0.0, 12.5), (20.0, 40.0)])
    );
    assert_eq!("auto".parse::<SegmentSpec>().unwrap(), SegmentSpec::Auto);
    for bad in ["5-2", "a-b", "3", "-1-2"] {
        assert!(bad.parse::<SegmentSpec>().is_err(), "{bad}");
    }
    let t: Vec<f64> = (0..100).map(|k| k as f64 / 10.0).collect();
    let (logs, _) = read(&write("seg.csv", &own_csv(&t)), None);
    let s = slice_time(&logs[0], (2.0, 3.0)).unwrap();
    assert_eq!(s.len(), 11);
    assert!((s.t_s[0] - 2.0).abs() < 1e-12);
    let e = slice_time(&logs[0], (20.0, 30.0)).unwrap_err().to_string();
    assert!(e.contains("0 samples"), "{e}");
    let picked = select(&logs, &"1-2,5-6".parse().unwrap(), &MoveOptions::default()).unwrap();
    assert_eq!(
        picked.iter().map(Log::len).collect::<Vec<_>>(),
        vec![11, 11]
    );
    assert!("all".parse::<LagOption>().is_err());
    assert_eq!("0.25".parse::<LagOption>().unwrap(), LagOption::Fixed(0.25));
}

mod twin;
