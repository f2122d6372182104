//! Logs written by the twin: the UR RTDE preset round trip, the power lag, rest-to-rest
//! segments, identification from such logs, and unevenly sampled logs.

use super::*;

/// Via points (the moves are the legs between them) and the dwell at each, s.
const POINTS: usize = 41;
const DWELL_S: f64 = 1.0;
/// The arm's DC bus, V.
const BUS_V: f64 = 48.0;
/// Cabinet electronics on the bus, W: with the drives' 18.5 W standby the arm draws 37 W at
/// rest. They hang on the same DC bus as the motors, so braking power feeds them first and
/// only the rest is burnt: the bus carries `max(motors + drives + cabinet, 0)`, the structure
/// of the clipped model (a meter offset on top of the clip would be another structure).
const CABINET_W: f64 = 18.5;

/// A twin run of random point-to-point moves with dwells, logged at 25 Hz on the DC bus.
fn twin_run() -> &'static (Dataset, Vec<f64>) {
    static RUN: OnceLock<(Dataset, Vec<f64>)> = OnceLock::new();
    RUN.get_or_init(|| {
        let robot = common::irb1200();
        let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "drive", &robot).unwrap();
        let mut joints = drive.joints().to_vec();
        joints[0].standby_power += CABINET_W;
        let drive = Drive::new(&robot, joints).unwrap();
        let rig = Rig {
            plant: None,
            robot: &robot,
            urdf: Urdf::inline(builtin::IRB1200_URDF),
            drive: &drive,
            twin: TwinConfig::default(),
            sensor: SensorSettings {
                rate_hz: 25.0,
                power_signal: PowerSignal::Bus,
                ..SensorSettings::default()
            },
        };
        let traj = random_point_to_point(
            &robot,
            &mut common::rng(11),
            &RandomPointToPointOptions {
                points: POINTS,
                dwell_s: DWELL_S,
                ..RandomPointToPointOptions::default()
            },
        )
        .unwrap();
        let ds = rig.run(&traj, &[], 0, serde_json::json!({})).unwrap();
        // RTDE time stamps: controller time from 1234.5 s, +-3 ms jitter.
        let mut rng = common::rng(12);
        let stamps = ds
            .measured
            .t
            .iter()
            .map(|t| 1234.5 + t + rng.random_range(-0.003..0.003))
            .collect();
        (ds, stamps)
    })
}

/// Write the twin's measured stream as a UR RTDE recording (space-delimited, as RTDE's
/// `record.py` writes), the power shifted late by `lag_s` (from the 1 kHz truth).
fn write_rtde(name: &str, lag_s: f64) -> PathBuf {
    let (ds, stamps) = twin_run();
    let n = 6;
    let stride = ds.meta.measurement.stride(ds.truth.dt).unwrap();
    let shift = (lag_s / ds.truth.dt).round() as usize;
    let mut s = String::from("timestamp");
    for i in 0..n {
        s += &format!(" actual_q_{i}");
    }
    for i in 0..n {
        s += &format!(" actual_qd_{i}");
    }
    s += " actual_robot_voltage actual_robot_current target_q_0\n";
    let m = &ds.measured;
    for (k, stamp) in stamps.iter().enumerate() {
        if k * stride < shift {
            continue;
        }
        s += &format!("{stamp}");
        for i in 0..n {
            s += &format!(" {}", m.q[i][k]);
        }
        for i in 0..n {
            s += &format!(" {}", ds.truth.dq[i][k * stride]);
        }
        let p = if shift == 0 {
            m.p_total[k]
        } else {
            ds.truth.p_grid[k * stride - shift]
        };
        s += &format!(" {BUS_V} {} 0\n", p / BUS_V);
    }
    write(name, &s)
}

fn rtde(path: &Path, lag: LagOption) -> (Vec<Log>, ReadReport) {
    read_log(
        path,
        Some(&ColumnMap::load("ur-rtde").unwrap()),
        &ReadOptions { power: None, lag },
    )
    .unwrap()
}

#[test]
fn ur_rtde_preset_round_trips_a_twin_log() {
    let (ds, stamps) = twin_run();
    let (logs, rep) = rtde(&write_rtde("rtde.csv", 0.0), LagOption::Report);
    eprintln!("{rep}");
    assert_eq!(logs.len(), 1);
    let l = &logs[0];
    let m = &ds.measured;
    assert_eq!(
        (l.len(), l.dof(), rep.gaps, rep.decimation),
        (m.t.len(), 6, 0, 1)
    );
    assert_eq!(l.signal, PowerSignal::Bus);
    assert_eq!(rep.t0_s, stamps[0]);
    // The stamps' +-3 ms jitter is the logger's: the samples come back on the 25 Hz grid.
    assert_eq!(rep.regularized_pieces, 1);
    for (k, stamp) in stamps.iter().enumerate() {
        assert!((l.t_s[k] - (stamp - stamps[0])).abs() < 0.0035);
        assert!((l.t_s[k] - (l.t_s[0] + 0.04 * k as f64)).abs() < 1e-3);
        assert!((l.power_w[k] - m.p_total[k]).abs() <= 1e-12 * m.p_total[k].abs().max(1.0));
        for i in 0..6 {
            assert_eq!(l.q_rad[i][k], m.q[i][k]);
        }
    }
    // The bus never goes negative: braking phases read zero, give or take the meter's 1 W.
    assert!(l.power_w.iter().all(|p| *p > -5.0));
    assert!(l.power_w.iter().any(|p| p.abs() < 3.0), "no clipped sample");
    let lag = rep.lag.expect("lag estimated");
    assert!(lag.lag_s.abs() < 0.03, "{lag:?}");
}

#[test]
fn the_power_lag_is_estimated_and_applied() {
    let (ds, _) = twin_run();
    let (logs, rep) = rtde(&write_rtde("rtde_lag.csv", 0.2), LagOption::Auto);
    eprintln!("{rep}");
    let lag = rep.lag.expect("lag estimated");
    assert!((lag.lag_s - 0.2).abs() < 0.03, "{lag:?}");
    assert!(lag.r2 > lag.r2_at_zero);
    assert_eq!(rep.lag_applied_s, lag.lag_s);
    assert!(rep.lag_trimmed >= 5);
    // Aligned, the power is the unshifted stream again (less the noise it lacks).
    let l = &logs[0];
    let first = ds.measured.t.len() - l.len() - rep.lag_trimmed;
    let err: f64 = (0..l.len())
        .map(|k| (l.power_w[k] - ds.measured.p_total[k + first]).powi(2))
        .sum::<f64>()
        / l.len() as f64;
    assert!(
        err.sqrt() < 5.0,
        "aligned power RMS difference {} W",
        err.sqrt()
    );
    // The same estimate from the library call on the log itself.
    let direct = estimate_lag(&l.t_s, &l.q_rad, l.dq_rad_s.as_deref(), &l.power_w, 1.0).unwrap();
    assert!(direct.lag_s.abs() < 0.03, "{direct:?}");
}

#[test]
fn auto_segments_find_the_rest_to_rest_moves() {
    let (logs, _) = rtde(&write_rtde("rtde_seg.csv", 0.0), LagOption::Report);
    let moves = auto_moves(&logs[0], &MoveOptions::default());
    assert_eq!(moves.len(), POINTS - 1, "{moves:?}");
    for w in moves.windows(2) {
        assert!(w[1].0 - w[0].1 > 0.5 * DWELL_S, "{moves:?}");
    }
}

#[test]
fn identify_on_half_the_moves_predict_the_rest() {
    let robot = common::irb1200();
    let (logs, report) = rtde(&write_rtde("rtde_id.csv", 0.0), LagOption::Report);
    // The stamps' jitter is the logger's, not the samples': the time base is regularized.
    assert_eq!(report.regularized_pieces, 1, "{report}");
    let moves = select(&logs, &SegmentSpec::Auto, &MoveOptions::default()).unwrap();
    let (fit, held): (Vec<_>, Vec<_>) = moves.iter().enumerate().partition(|(k, _)| k % 2 == 0);
    let fit: Vec<_> = fit.into_iter().map(|(_, m)| m.clone()).collect();
    // The user's route: bus power (never negative), cross-validated estimator, 25 Hz
    // positions differentiated along the log route (rests held still, least-jerk spline).
    let sel = identify_logs(&robot, &fit, &[LOG_ROUTE], &FitOptions::default()).unwrap();
    let model = &sel.fit.model;
    assert_eq!(model.signal, PowerSignal::Bus);
    let standby: f64 = model.constant.iter().sum();
    eprintln!(
        "{:?} on {} moves: residual RMS {:.3} W, standby {standby:.2} W (twin {} W)",
        sel.chosen,
        fit.len(),
        sel.fit.estimate.residual_rms,
        18.5 + CABINET_W
    );
    let mut worst: f64 = 0.0;
    for (k, m) in &held {
        let p = prepare(m, LOG_ROUTE).unwrap();
        let predicted = model
            .predict(&robot, p.motion.as_ref(), &p.motion_events(), 1.0, 1e-3)
            .unwrap()
            .energy_j;
        let measured: f64 = window_energies(&p.states.t, &p.p_total, false).iter().sum();
        let err = 100.0 * (predicted - measured) / measured;
        eprintln!("move {k}: predicted {predicted:.1} J, measured {measured:.1} J, {err:+.2} %");
        worst = worst.max(err.abs());
    }
    eprintln!("worst held-out move: {worst:.2} %");
    // The targets: standby within 0.5 W, every held-out move within 2 %.
    assert!((standby - 37.0).abs() < 0.5, "standby {standby} W");
    assert!(worst < 2.0, "worst held-out energy error {worst} %");
}

#[test]
fn identify_and_predict_take_logs_on_the_command_line() {
    let (ds, _) = twin_run();
    let log = write_rtde("rtde_cli.csv", 0.0);
    let model = common::tmp("cli_model.json");
    let (code, _, err) = common::run(&[
        "identify",
        "--log",
        log.to_str().unwrap(),
        "--columns",
        "ur-rtde",
        "--segments",
        "0-20",
        "--method",
        "pmsm",
        "--out",
        model.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let rows = format!("{} rows", ds.measured.t.len());
    assert!(
        err.contains(&rows) && err.contains("power lag behind joints"),
        "{err}"
    );
    assert!(
        err.contains("segment 1:") && err.contains("observations ->"),
        "{err}"
    );
    let (code, out, err) = common::run(&[
        "predict",
        "--model",
        model.to_str().unwrap(),
        "--log",
        log.to_str().unwrap(),
        "--columns",
        "ur-rtde",
        "--segments",
        "20-30,30-40",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let rows: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2);
    // The measured energy of the two segments is the trapezoid of the logged bus power
    // from 20 to 40 s (one 40 ms window at 30 s and the time-stamp jitter aside).
    let m = &ds.measured;
    let (a, b) = (
        m.t.partition_point(|&t| t < 20.0),
        m.t.partition_point(|&t| t <= 40.0),
    );
    let twin: f64 = window_energies(&m.t[a..b], &m.p_total[a..b], false)
        .iter()
        .sum();
    let measured: f64 = rows.iter().map(|r| r["measured_J"].as_f64().unwrap()).sum();
    assert!(
        (measured - twin).abs() < 0.01 * twin,
        "{measured} J from the CLI, {twin} J from the twin"
    );
    // --data and --log exclude each other; one of them is required.
    let (code, _, err) = common::run(&["identify", "--data", "x", "--log", "y", "--out", "m"]);
    assert!(code != 0 && err.contains("cannot be used with"), "{err}");
    let (code, _, err) = common::run(&["predict", "--model", "m"]);
    assert!(code != 0 && err.contains("--data"), "{err}");
}

/// A logger that samples at uneven times and stamps each sample at the time it was taken:
/// the spline route follows the motion through the actual times, and the predicted energy
/// is that of the evenly sampled log. A 20 s Fourier motion of the realistic twin (encoder
/// noise, no rests) logged at 1 kHz, read at 10 Hz, once on the grid and once at ±40 % of a
/// period off it, as `(t, q)` at the 1 kHz samples nearest the uneven instants. The encoder
/// noise estimate once took the uneven samples' differences as evenly spaced, found 0.02 to
/// 0.07 rad of "white noise", and the smoothing spline flattened the motion: -6 %.
#[test]
fn unevenly_sampled_log_with_true_stamps_predicts_as_the_even_one() {
    use powertwin::dynamics::ParamLayout;
    use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
    use powertwin::identification::model::PowerModel;
    use powertwin::trajectory::random::{RandomFourierOptions, random_fourier};
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let base = common::irb1200_rig(
        &robot,
        &drive,
        powertwin::twin::Fidelity::Realistic,
        powertwin::twin::sensor::NoiseSettings::default(),
    );
    let rig = Rig {
        sensor: SensorSettings {
            rate_hz: 1000.0,
            ..base.sensor
        },
        ..base
    };
    let traj = random_fourier(
        &robot,
        &mut common::rng(21),
        &RandomFourierOptions {
            periods: 2.0,
            rest: false,
            ..RandomFourierOptions::default()
        },
    )
    .unwrap();
    let ds = rig.run(&traj, &[], 0, serde_json::json!({})).unwrap();
    let m = &ds.measured;
    // A known model: the drive's terms on the robot's base parameters.
    let layout = ParamLayout::new(&robot, true, true);
    let mut model = PowerModel::new(&robot, layout, false).unwrap();
    let bp = BaseParams::compute(&robot, layout, &SamplingOptions::default()).unwrap();
    model.theta = bp
        .base_values(&layout.theta(&robot, &common::drive_terms(6)))
        .unwrap();
    let log_at = |rows: &[usize]| Log {
        source: "uneven".into(),
        robot: None,
        t_s: rows.iter().map(|&k| m.t[k] - m.t[0]).collect(),
        q_rad: m
            .q
            .iter()
            .map(|q| rows.iter().map(|&k| q[k]).collect())
            .collect(),
        dq_rad_s: None,
        power_w: rows.iter().map(|&k| m.p_total[k]).collect(),
        signal: PowerSignal::Total,
        motor_power_w: None,
        power_averaged: false,
        payloads: Vec::new(),
    };
    let energy = |log: &Log| {
        let p = prepare(log, LOG_ROUTE).unwrap();
        model
            .predict(&robot, p.motion.as_ref(), &p.motion_events(), 1.0, 1e-3)
            .unwrap()
            .energy_j
    };
    let even: Vec<usize> = (0..200).map(|k| 100 * k).collect();
    let mut rng = common::rng(22);
    let uneven: Vec<usize> = (0..200)
        .map(|k| match k {
            0 => 0,
            _ => (100.0 * k as f64 + rng.random_range(-40.0..40.0)).round() as usize,
        })
        .collect();
    let (e_even, e_uneven) = (energy(&log_at(&even)), energy(&log_at(&uneven)));
    let err = 100.0 * (e_uneven / e_even - 1.0);
    eprintln!("even {e_even:.1} J, uneven {e_uneven:.1} J ({err:+.3} %)");
    assert!(err.abs() < 0.5, "{err} %");
}
