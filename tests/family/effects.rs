//! The effects a family robot adds to the twin (direction-dependent gear friction, power lag,
//! stamp jitter, cabinet load, an averaging meter) and the lag identification finds.

use super::*;

#[test]
fn gear_friction_follows_the_direction_of_power_flow() {
    let robot = common::irb1200();
    let text = powertwin::model::builtin::IRB1200_DRIVE.replacen(
        "gear_friction_per_Nm = ",
        "gear_friction_braking_per_Nm = 0.05\ngear_friction_per_Nm = ",
        1,
    );
    let drive = Drive::from_toml_str(&text, "drive.toml", &robot).unwrap();
    let u = drive.joints()[0].unmodelled;
    assert_eq!(u.gear_friction_braking, 0.05);
    let base = u.friction(10.0, 1.0, 0.0);
    // Motoring (torque along the motion) and braking (against it).
    assert!((u.friction(10.0, 1.0, 100.0) - base - 100.0 * u.gear_friction).abs() < 1e-9);
    assert!((u.friction(10.0, 1.0, -100.0) - base - 5.0).abs() < 1e-9);
    // Without the key, braking is as motoring.
    let plain = common::irb1200_drive(&robot).joints()[0].unmodelled;
    assert_eq!(plain.gear_friction_braking, plain.gear_friction);
    let bad = powertwin::model::builtin::IRB1200_DRIVE.replacen(
        "gear_friction_per_Nm = ",
        "gear_friction_braking_per_Nm = -0.1\ngear_friction_per_Nm = ",
        1,
    );
    let e = Drive::from_toml_str(&bad, "drive.toml", &robot)
        .unwrap_err()
        .to_string();
    assert!(e.contains("gear_friction_braking_per_Nm"), "{e}");
}

#[test]
fn the_logger_lags_jitters_and_sees_the_cabinet() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let base = common::irb1200_rig(&robot, &drive, Fidelity::Realistic, NoiseSettings::NONE);
    let traj = excitation(&robot);
    let with = |sensor: SensorSettings, cabinet: f64| {
        let rig = Rig {
            sensor,
            twin: powertwin::twin::TwinConfig {
                cabinet_power_w: cabinet,
                ..base.twin.clone()
            },
            ..base.clone()
        };
        rig.run(&traj, &[], 0, serde_json::json!({})).unwrap()
    };
    let plain = with(base.sensor, 0.0);
    let lagged = with(
        SensorSettings {
            power_lag_s: 0.03,
            ..base.sensor
        },
        0.0,
    );
    // Sample k (10 Hz, 100 steps apart) logs the power 30 steps earlier.
    let k = 57;
    let at = 100 * k - 30;
    let expected = 0.5 * (plain.truth.p_grid[at - 1] + plain.truth.p_grid[at]);
    assert!((lagged.measured.p_total[k] - expected).abs() < 1e-9);
    assert_eq!(lagged.measured.t, plain.measured.t);
    let jittered = with(
        SensorSettings {
            stamp_jitter_s: 0.02,
            ..base.sensor
        },
        0.0,
    );
    let dev = jittered
        .measured
        .t
        .iter()
        .zip(&plain.measured.t)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(dev > 0.005 && dev <= 0.02 + 1e-12, "{dev}");
    // What a user has: the stamps back on their uniform grid.
    let log = jittered.log("jittered").unwrap();
    assert!(log.t_s.windows(2).all(|w| (w[1] - w[0] - 0.1).abs() < 1e-3));
    let cabinet = with(base.sensor, 40.0);
    assert!((cabinet.truth.energy_grid() - plain.truth.energy_grid() - 40.0 * 20.0).abs() < 0.5);
    // Jitter of half a period is refused.
    let e = SensorSettings {
        stamp_jitter_s: 0.05,
        ..base.sensor
    }
    .stride(1e-3)
    .unwrap_err()
    .to_string();
    assert!(e.contains("jitter"), "{e}");
}

#[test]
fn identification_finds_the_power_lag() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let base = common::irb1200_rig(
        &robot,
        &drive,
        Fidelity::Realistic,
        NoiseSettings::default(),
    );
    let traj = excitation(&robot);
    let route = [Route::Fourier {
        base_freq_hz: 0.2,
        harmonics: 5,
    }];
    // (rate, averaging meter, true lag, how close the found lag must be). At 10 Hz with an
    // averaging meter this excitation's power hardly depends on the lag: the fit may keep
    // none, but must not invent a wrong one. At 20 Hz the refinement on the residual's root
    // mean square found 26.1 ms for 30 ms; on its mean square, 31.9 ms.
    let cases = [
        (20.0, false, 0.03, 0.003),
        (20.0, false, 0.0, 0.006),
        (10.0, true, 0.04, 0.04),
    ];
    for (rate_hz, averaging, lag, tolerance) in cases {
        let rig = Rig {
            sensor: SensorSettings {
                rate_hz,
                power_averaging: averaging,
                power_lag_s: lag,
                ..base.sensor
            },
            ..base.clone()
        };
        let logs = two_logs(&rig, &traj);
        let sel = identify_logs(&robot, &logs, &route, &FitOptions::default()).unwrap();
        let found = sel.fit.model.power_lag_s;
        assert!(
            (found - lag).abs() <= tolerance,
            "{rate_hz} Hz (averaging {averaging}): lag {lag} s found as {found} s"
        );
    }
}

/// A meter that averages over its 10 Hz period logs the period's mean power, which a fast
/// motion's convex copper loss makes more than the power at the period's middle. Fitted at
/// the middle, that gap went into the copper coefficients and a slow motion holding the arm
/// against gravity was mispredicted (here -1.5 %, on a family robot +2 to +3 %); fitted on
/// the period's mean, the averaging meter's model predicts it about as the instantaneous
/// meter's does (here -0.4 % and -0.0 %; the rest is the 10 Hz averaged logs' spread, which
/// moves with the nodes per period, -0.4, +0.2 and -0.2 % at 4, 8 and 16).
#[test]
fn an_averaging_meter_is_fitted_on_its_periods_mean() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let base = common::irb1200_rig(&robot, &drive, Fidelity::Exact, NoiseSettings::NONE);
    let traj = excitation(&robot);
    let n = robot.dof();
    // Slow and near a pose where gravity loads joints 2 and 3: mostly holding.
    let slow = Fourier::new(
        0.05,
        vec![0.3, 0.7, 0.4, 0.0, 0.6, 0.0],
        vec![vec![0.05]; n],
        vec![vec![0.0]; n],
        1.0,
    )
    .unwrap();
    let truth = base.run(&slow, &[], 9, serde_json::json!({})).unwrap();
    let true_j = truth.truth.energy_total();
    let route = [Route::Fourier {
        base_freq_hz: 0.2,
        harmonics: 5,
    }];
    let error_pct = |averaging: bool| -> f64 {
        let rig = Rig {
            sensor: SensorSettings {
                rate_hz: 10.0,
                power_averaging: averaging,
                power_lag_s: 0.0,
                ..base.sensor
            },
            ..base.clone()
        };
        let logs = two_logs(&rig, &traj);
        let opts = FitOptions {
            max_power_lag_s: 0.0,
            ..FitOptions::default()
        };
        let model = identify_logs(&robot, &logs, &route, &opts)
            .unwrap()
            .fit
            .model;
        let predicted = model.energy(&robot, &slow, 1e-3).unwrap();
        100.0 * (predicted / true_j - 1.0)
    };
    let (instant, averaging) = (error_pct(false), error_pct(true));
    assert!(
        (averaging - instant).abs() < 0.7 && averaging.abs() < 0.7,
        "slow holding motion of {true_j:.1} J: {instant:+.2} % from the instantaneous \
         meter's model, {averaging:+.2} % from the averaging meter's"
    );
}
