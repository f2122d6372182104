//! The library chain on the UR5 and the Panda: excite, simulate, identify, predict held-out
//! motions and sweep, with the figures checked against bounds.

use super::*;

/// Bounds a chain must meet.
struct Bounds {
    /// Condition number of each excitation design (its identifiable columns).
    cond: f64,
    /// Condition number of the stacked identification regressor (PMSM, all designs).
    ident_cond: f64,
    /// RMS of the identification residual, W (the power meter's noise is 1 W).
    residual_w: f64,
    /// |error| of the predicted energy of the held-out motion, % of the simulated energy.
    heldout_pct: f64,
    /// |error| of every sweep cell's energy predicted from the plan, %.
    sweep_pct: f64,
}

/// Run the twin along `traj` (noise seed offset `run`) and check that it tracked the
/// reference without hitting a torque limit.
fn run(rig: &Rig, traj: &dyn Trajectory, run: u64) -> Dataset {
    let (data, report) = simulate(&RunSpec {
        robot: rig.robot,
        urdf: rig.urdf.clone(),
        drive: rig.drive,
        events: &[],
        brakes: &[],
        twin: rig.twin.clone(),
        sensor: SensorSettings {
            seed: run,
            ..rig.sensor
        },
        trajectory: traj,
        trajectory_description: serde_json::json!({"run": run}),
        trajectory_seed: None,
        family: None,
    })
    .unwrap();
    assert!(
        report.torque_limit_hits.is_empty() && report.max_tracking_error_rad < 1e-3,
        "{}: run {run}: {report:?}",
        rig.robot.name()
    );
    data
}

/// The arm's true standby power, W (for scoring only).
fn standby_w(drive: &Drive) -> f64 {
    drive.joints().iter().map(|j| j.standby_power).sum()
}

/// The library chain on one arm, with the figures printed and checked against `bounds`.
fn chain(arm: &Arm, bounds: &Bounds) {
    let (robot, drive, urdf) = load(arm);
    let n = robot.dof();
    let scenario = Scenario::from_file(&repo(arm.scenario)).expect("the scenario parses");
    let accel = scenario.motion.limits.joint_accel_rad_s2.clone();

    // Excite: all joints, EXCITATIONS designs (optimiser seeds 1, 2, ...) of PERIODS 10 s
    // periods each, a short optimisation.
    let mut designs = Vec::new();
    for k in 0..EXCITATIONS {
        let mut opts =
            ExcitationOptions::new(&robot, (0..n).collect(), vec![0.0; n], accel.clone());
        opts.rest_pose = rest_pose(
            &robot,
            opts.position_margin + 0.05,
            opts.floor_z,
            opts.base_radius,
        )
        .expect("a rest pose exists");
        opts.periods = PERIODS;
        opts.starts = 1;
        opts.max_evals = 2000;
        opts.seed = 1 + k as u64;
        let clock = std::time::Instant::now();
        designs.push(design(&robot, &opts).expect("the excitation design succeeds"));
        eprintln!(
            "{}: design {:.1} s",
            robot.name(),
            clock.elapsed().as_secs_f64()
        );
    }

    // Simulate: the twin with default noise, 10 Hz logging, 3 Rapier substeps per 1 ms step
    // (as `reproduce`).
    let rig = Rig {
        plant: None,
        robot: &robot,
        urdf,
        drive: &drive,
        twin: TwinConfig {
            physics: PhysicsSettings {
                dt: 1e-3,
                substeps: SUBSTEPS,
            },
            ..TwinConfig::default()
        },
        sensor: SensorSettings::default(),
    };

    // Identify: PMSM losses, all base parameters at once, samples near reversals left out.
    let mut states: Option<States> = None;
    let mut y = Vec::new();
    for (k, ex) in designs.iter().enumerate() {
        let data = run(&rig, &ex.trajectory, k as u64);
        let mut prepared = prepare(
            &data.log("excitation").unwrap(),
            Route::Fourier {
                base_freq_hz: 0.1,
                harmonics: 5,
            },
        )
        .unwrap();
        prepared.drop_slow_samples(0.05).unwrap();
        y.extend_from_slice(&prepared.p_total);
        match &mut states {
            None => states = Some(prepared.states),
            Some(s) => s.append(&prepared.states).unwrap(),
        }
    }
    let states = states.unwrap();
    let mut model = PowerModel::new(&robot, ParamLayout::new(&robot, true, true), false).unwrap();
    let est = pmsm::identify(&robot, &mut model, &states, &y).unwrap();
    let consistent = consistency(&robot, &model, 1.0, 200, 1).unwrap();
    let ex = designs
        .iter()
        .max_by(|a, b| a.cond_final.total_cmp(&b.cond_final))
        .unwrap();

    // Predict held-out motions: random Fourier motions from other seeds, differentiated
    // along the spline route as for any logged motion.
    let heldout_opts = RandomFourierOptions {
        accel_limits: accel,
        limit_fraction: 0.6,
        min_amplitude: 0.3,
        ..RandomFourierOptions::default()
    };
    let mut heldout = Vec::new();
    for seed in HELDOUT_SEEDS {
        let traj = random_fourier(&robot, &mut common::rng(seed), &heldout_opts).unwrap();
        let data = run(&rig, &traj, 100 + seed);
        let p = prepare(&data.log("held out").unwrap(), Route::Spline).unwrap();
        let predicted = model.energy(&robot, p.motion.as_ref(), 1e-3).unwrap();
        let simulated = data.meta.summary.energy_total_j;
        // The share above the true standby power (scored with the truth, never fitted on it).
        let above = simulated - standby_w(&drive) * traj.duration();
        heldout.push((
            predicted,
            simulated,
            100.0 * (predicted - simulated) / simulated,
            100.0 * (predicted - simulated) / above,
        ));
    }
    let heldout_pct = heldout
        .iter()
        .map(|h| h.2)
        .fold(0.0f64, |a, b| if b.abs() > a.abs() { b } else { a });

    // Sweep: two speeds, one load, predicted from the plan with the known tool and loads.
    let mut scenario = scenario;
    scenario.sweep.speeds_m_s = vec![0.1, 0.5];
    scenario.sweep.loads_kg = vec![arm.load_kg];
    let planned = sweep::plan(&robot, &scenario).unwrap();
    let result = sweep::run(
        &rig,
        &scenario,
        planned,
        Some((&model, drive.nominal_efficiency())),
        &Silent,
    )
    .unwrap();

    eprintln!(
        "{}: excitation cond {:.1} -> {:.1}; identification residual RMS {:.3} W over {} \
         samples, cond {:.1}, consistent {} (min mass-matrix eigenvalue {:.4} kg m^2, \
         negative drive terms {:?}); held out (predicted J, simulated J, error %, error % of the energy above \
         standby): {heldout:.3?}; identified standby {:.2} W, true {:.2} W",
        robot.name(),
        ex.cond_initial,
        ex.cond_final,
        est.residual_rms,
        est.rows,
        est.cond,
        consistent.consistent,
        consistent.min_eigenvalue,
        consistent.negative_drive_terms,
        model.constant.iter().sum::<f64>(),
        standby_w(&drive),
    );
    for c in &result.cells {
        eprintln!(
            "{}: sweep {} m/s, {} kg: cycle {:.2} s, simulated {:.1} J, predicted {:.1} J ({:+.3} %), {} slowed",
            robot.name(),
            c.speed_m_s,
            c.load_kg,
            c.cycle_time_s,
            c.simulated_j,
            c.predicted_j.unwrap(),
            c.error_pct.unwrap(),
            c.slowed.len()
        );
    }

    assert!(
        ex.cond_final < bounds.cond && ex.cond_final < ex.cond_initial,
        "{}: condition number {} (start {})",
        robot.name(),
        ex.cond_final,
        ex.cond_initial
    );
    assert!(
        est.cond < bounds.ident_cond,
        "{}: identification condition number {}",
        robot.name(),
        est.cond
    );
    assert!(
        est.residual_rms < bounds.residual_w,
        "{}: residual RMS {} W",
        robot.name(),
        est.residual_rms
    );
    assert!(
        heldout_pct.abs() < bounds.heldout_pct,
        "{}: worst held-out energy error {heldout_pct} %",
        robot.name()
    );
    let [slow, fast] = [&result.cells[0], &result.cells[1]];
    assert!(slow.speed_m_s < fast.speed_m_s);
    // Faster is shorter, and at 0.1 m/s the cycle's standby and holding losses outweigh the
    // extra friction and copper losses of 0.5 m/s.
    assert!(fast.cycle_time_s < 0.5 * slow.cycle_time_s);
    assert!(
        slow.simulated_j > fast.simulated_j,
        "{}: {} J at 0.1 m/s, {} J at 0.5 m/s",
        robot.name(),
        slow.simulated_j,
        fast.simulated_j
    );
    for c in &result.cells {
        assert!(
            c.error_pct.unwrap().abs() < bounds.sweep_pct,
            "{}: sweep cell {} m/s: {} %",
            robot.name(),
            c.speed_m_s,
            c.error_pct.unwrap()
        );
    }
}

// Bounds: about twice the figures measured (2026-11-23, this machine) unless stated; the
// residual at the power meter's noise (1 W) plus 30 %. Measured UR5: design condition numbers
// up to 1067, identification 106.1, residual 0.99 W, held out -0.71, -0.94, -0.62 %, sweep
// -0.60 % and -0.33 %. Measured Panda: 4194, 75.2, 0.94 W, -2.47, -1.76, -1.08 %, +0.13 % and
// +0.09 %. The held-out bound is the accuracy issue's "realistic truth" worst case (2 %) for
// the UR5; the Panda's motions spend little above its standby power (about 50 of 330 J), so
// its identified standby (27.46 W against 28 W) dominates the miss and its bound is 4 %.

#[test]
fn ur5_excite_identify_predict_and_sweep() {
    chain(
        &UR5,
        &Bounds {
            cond: 2000.0,
            ident_cond: 300.0,
            residual_w: 1.3,
            heldout_pct: 2.0,
            sweep_pct: 1.5,
        },
    );
}

#[test]
fn panda_excite_identify_predict_and_sweep() {
    chain(
        &PANDA,
        &Bounds {
            cond: 8000.0,
            ident_cond: 300.0,
            residual_w: 1.3,
            heldout_pct: 4.0,
            sweep_pct: 1.0,
        },
    );
}
