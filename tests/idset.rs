//! The identification set as a whole: joint design of the excitations, the parameters a
//! noise-free set determines, intervals calibrated on cross-validation, weighted and
//! physically consistent fits.

use crate::common;

use powertwin::dynamics::{DriveTerms, ParamLayout};
use powertwin::identification::consistency::consistency;
use powertwin::identification::data::Route;
use powertwin::identification::excitation_set::{Member, SetCriterion, SetOptions, design_set};
use powertwin::identification::fit::{
    Estimator, FitOptions, Samples, Weighting, fit, identify_logs,
};
use powertwin::identification::model::PowerModel;
use powertwin::identification::states::States;
use powertwin::model::payload::Payload;
use powertwin::trajectory::limits::{IRB1200_ACCEL_LIMITS, check_limits};
use powertwin::twin::Fidelity;
use powertwin::twin::sensor::NoiseSettings;
use powertwin::validation::heldout::{self, HeldoutOptions};
use powertwin::validation::idset::{self, IdSetOptions};
use powertwin::validation::rig::Silent;
use powertwin::validation::score;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

use common::{irb1200_drive as drive, irb1200_rig as rig};

/// Two excitations (nothing and 7 kg on the flange) of the IRB 1200.
fn two_members(criterion: SetCriterion) -> SetOptions {
    let centres = IdSetOptions::irb1200(true).centres;
    SetOptions {
        members: vec![
            Member {
                centre: centres[0].clone(),
                base_freq_hz: 0.1,
                periods: 2,
                payload: None,
            },
            Member {
                centre: centres[3].clone(),
                base_freq_hz: 0.2,
                periods: 4,
                payload: Some(Payload::cube("load 7 kg", 7.0, [0.0, 0.0, 0.05].into()).unwrap()),
            },
        ],
        harmonics: 5,
        sample_rate_hz: 10.0,
        min_speed: 0.05,
        criterion,
        accel_limits: IRB1200_ACCEL_LIMITS.to_vec(),
        position_margin: 0.05,
        limit_fraction: 0.9,
        floor_z: 0.05,
        base_radius: 0.15,
        rounds: 2,
        max_evals: 150,
        seed: 3,
    }
}

#[test]
fn a_joint_design_conditions_the_stacked_regressor_within_the_limits() {
    let robot = common::irb1200();
    for criterion in [SetCriterion::DOptimal, SetCriterion::Cond] {
        let opts = two_members(criterion);
        let d = design_set(&robot, &opts).unwrap();
        eprintln!(
            "{criterion:?}: cond {:.1} -> {:.1}, by round {:?}, members {:?}",
            d.cond_initial, d.cond_final, d.criterion_by_round, d.member_conds
        );
        assert_eq!(d.trajectories.len(), 2);
        // Measured: 1.2e5 at the start guesses, 246 (D-optimal) and 174 (cond) designed.
        assert!(d.cond_initial > 1e5, "{}", d.cond_initial);
        assert!(d.cond_final < 300.0, "{}", d.cond_final);
        // Later rounds only accept improvements of the whole set's criterion.
        assert!(d.criterion_by_round[1] <= d.criterion_by_round[0]);
        for t in &d.trajectories {
            check_limits(&robot, t, 1e-3, Some(&IRB1200_ACCEL_LIMITS)).unwrap();
        }
        // The same seed gives the same set.
        let again = design_set(&robot, &opts).unwrap();
        for (a, b) in d.trajectories.iter().zip(&again.trajectories) {
            assert_eq!(a.to_vector(), b.to_vector());
        }
    }
    // Clear errors.
    let mut o = two_members(SetCriterion::DOptimal);
    o.members.clear();
    assert!(design_set(&robot, &o).is_err());
    let mut o = two_members(SetCriterion::DOptimal);
    o.members[1].centre[1] = 3.0;
    let err = design_set(&robot, &o).unwrap_err().to_string();
    assert!(err.contains("excitation 2"), "{err}");
    let mut o = two_members(SetCriterion::DOptimal);
    o.rounds = 0;
    assert!(design_set(&robot, &o).is_err());
    let mut o = two_members(SetCriterion::DOptimal);
    o.members[0].base_freq_hz = 0.0;
    assert!(design_set(&robot, &o).is_err());
}

#[test]
fn a_noise_free_identification_set_determines_the_drive_and_arm_parameters() {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let rig = rig(&robot, &drive, Fidelity::Exact, NoiseSettings::NONE);
    let set = idset::run(&rig, &IdSetOptions::irb1200(true), &Silent).unwrap();
    let model = &set.selection.fit.model;
    let rows = score::table(&robot, &drive, model, &[&set.selection.fit.estimate]).unwrap();
    let well: Vec<_> = rows
        .iter()
        .filter(|r| r.rel_std_pct.is_some_and(|s| s < 1.0))
        .collect();
    let worst = well
        .iter()
        .filter_map(|r| r.error_pct)
        .fold(0.0_f64, |m, e| m.max(e.abs()));
    let within = well
        .iter()
        .filter(|r| r.error_pct.is_some_and(|e| e.abs() < 2.0))
        .count();
    eprintln!(
        "well determined {} of {}, {within} within 2 %, worst {worst:.3} %, stacked cond {:.1}, P0 {:.3}, copper {:?}",
        well.len(),
        rows.len(),
        set.set_cond,
        model.constant[0],
        model.copper
    );
    // Measured on this quick set: 24 of 52 with relative std < 1 %, all within 2 % of the
    // truth, the worst 1.83 % off; standby 18.45 W (true 18.5 W).
    assert!(well.len() >= 22, "{}", well.len());
    assert!(within >= 22, "{within}");
    assert!(worst < 2.5, "{worst}");
    assert!(
        (model.constant[0] - 18.5).abs() < 0.1,
        "{}",
        model.constant[0]
    );
    for (c, d) in model.copper.iter().zip(drive.joints()).take(3) {
        assert!(
            (c / d.copper_loss - 1.0).abs() < 0.05,
            "{c} vs {}",
            d.copper_loss
        );
    }
}

/// A model identified from a set of `fidelity` with default noise (each motor's power fitted
/// too, or the arm's alone), judged on 12 held-out motions: `(plan coverage %, log coverage
/// %, mean half-width of the plan intervals in % of the true energy, structure sigma W,
/// structure rel, worst energy error from the plan %)`.
fn coverage(fidelity: Fidelity, motor_power: bool) -> (f64, f64, f64, f64, f64, f64) {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let rig = rig(&robot, &drive, fidelity, NoiseSettings::default());
    let mut opts = IdSetOptions::irb1200(true);
    opts.fit.motor_power = motor_power;
    let set = idset::run(&rig, &opts, &Silent).unwrap();
    let model = &set.selection.fit.model;
    let (h, _) = heldout::run(&rig, model, &HeldoutOptions::irb1200(12), &Silent).unwrap();
    let width = h
        .motions
        .iter()
        .map(|m| 100.0 * m.from_plan.interval_j / m.true_j)
        .sum::<f64>()
        / h.motions.len() as f64;
    (
        h.from_plan.coverage_pct,
        h.from_log.coverage_pct,
        width,
        model.structure_sigma,
        model.structure_rel,
        h.from_plan.energy_error_pct.worst,
    )
}

#[test]
fn intervals_calibrated_on_cross_validation_cover_held_out_motions() {
    let exact = coverage(Fidelity::Exact, false);
    let exact_motors = coverage(Fidelity::Exact, true);
    let realistic = coverage(Fidelity::Realistic, true);
    eprintln!("exact {exact:?}, with each motor's power {exact_motors:?}, realistic {realistic:?}");
    // Measured (12 motions each, 95 % intervals; the structure error is the posterior
    // average over what the cross-validation pieces allow): exact truth from the arm's
    // power, plan and log 100 %, structure 0.13 W and 0.13 % of the active power; realistic
    // truth with each motor's power, plan 92 %, log 100 %, 0.13 W and 0.11 %. Mean
    // half-widths 1.08 % and 0.65 % of the energy (0.80 % and 0.63 % before the model
    // predicted with the free fit's covariance where a copper coefficient is held at zero:
    // the quick set holds a wrist's, and the exact truth's worst error is 1.10 %). Since the
    // twin reads positions at the step's time (the leapfrog reading, issue 33) the exact
    // truth's structure is 0.155 W and its half-width 1.24 % at this rig's 3 substeps
    // (1.06 % with the viscous change alone, 1.20 % at the new default of 1 substep): the
    // positions used to run h/2 ahead, which partly lined them up with each step's power,
    // the mean over the step, recorded at its start (docs/experiments.md#leapfrog-reading).
    // The other friction structure's disagreement (the gear-friction model of the same logs)
    // widens it: this truth has no gear friction, but its logs cannot say how
    // friction would grow with the torque where the excitations do not go
    // (docs/experiments.md#the-other-friction-structure-in-the-interval).
    assert!(exact.0 >= 80.0 && exact.1 >= 90.0, "{exact:?}");
    assert!(exact.4 < 0.005 && exact.3 < 0.3, "{exact:?}");
    assert!(realistic.0 >= 80.0 && realistic.1 >= 80.0, "{realistic:?}");
    assert!(realistic.3 > 0.1 || realistic.4 > 0.001, "{realistic:?}");
    // ... with intervals that are not vacuous.
    assert!(
        exact.2 < 1.5 && realistic.2 < 1.7,
        "{exact:?} {realistic:?}"
    );
    // With each motor's power the exact truth's errors shrink (worst from the plan 0.67 %
    // for 1.10 %) and so do its intervals (mean half-width 0.47 %). With the structure error
    // taken at its most likely value they shrank more than the errors and covered 75 % of
    // these 12 motions (four excitations' pieces, most likely no structure error); averaged
    // over what the pieces allow (structure 0.07 W), 100 / 100 %. The other friction
    // structure's disagreement widens them.
    assert!(
        exact_motors.0 >= 90.0 && exact_motors.1 >= 90.0 && exact_motors.2 < 0.8,
        "{exact_motors:?}"
    );
    assert!(exact_motors.5 < exact.5, "{exact_motors:?} {exact:?}");
}

/// Random states of the IRB 1200 and their power under the true drives with noise whose
/// standard deviation is `0.2 W + 2 %` of the active power: `(states, power)`.
fn heteroscedastic(robot: &powertwin::Robot, model: &PowerModel) -> (States, Vec<f64>) {
    common::model_power_samples(robot, model, 1500, (11, 12), |active| 0.2 + 0.02 * active)
}

#[test]
fn power_level_weighting_fits_heteroscedastic_power_better() {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let layout = ParamLayout::new(&robot, true, true);
    let mut truth = PowerModel::new(&robot, layout, false).unwrap();
    let base = truth.base_params(&robot).unwrap();
    truth.theta = base
        .base_values(&layout.theta(&robot, &DriveTerms::from(&drive)))
        .unwrap();
    truth.copper = drive.joints().iter().map(|j| j.copper_loss).collect();
    truth.constant[0] = drive.joints().iter().map(|j| j.standby_power).sum();
    let (states, y) = heteroscedastic(&robot, &truth);
    let samples = Samples::from_states(&robot, &truth, &states, &y).unwrap();
    // Error of the fitted parameters in units of the truth, over the ten largest.
    let mut largest: Vec<usize> = (0..truth.theta.len()).collect();
    largest.sort_by(|a, b| truth.theta[*b].abs().total_cmp(&truth.theta[*a].abs()));
    let error = |w: Weighting| -> f64 {
        let f = fit(&truth, &samples, Estimator::Pmsm, w, &|_| true).unwrap();
        largest[..10]
            .iter()
            .map(|&k| ((f.model.theta[k] - truth.theta[k]) / truth.theta[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let (ols, wls) = (error(Weighting::None), error(Weighting::PowerLevel));
    eprintln!("relative parameter error: OLS {ols:.5}, power-level WLS {wls:.5}");
    // Measured: 0.428 and 0.097.
    assert!(wls < 0.5 * ols, "OLS {ols}, WLS {wls}");
}

/// The quick identification set of the exact twin with default noise, and the Fourier route
/// of each of its runs.
fn quick_exact_set(
    robot: &powertwin::Robot,
    drive: &powertwin::model::drive::Drive,
) -> (idset::IdSet, Vec<Route>) {
    let rig = rig(robot, drive, Fidelity::Exact, NoiseSettings::default());
    let opts = IdSetOptions::irb1200(true);
    let set = idset::run(&rig, &opts, &Silent).unwrap();
    let routes = opts
        .base_freq_hz
        .iter()
        .map(|&f| Route::Fourier {
            base_freq_hz: f,
            harmonics: 5,
        })
        .collect();
    (set, routes)
}

#[test]
fn per_log_weighting_and_the_consistent_model() {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let (set, routes) = quick_exact_set(&robot, &drive);
    // A meter ten times noisier on the second run.
    let mut logs = set.logs.clone();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for p in &mut logs[1].power_w {
        let z: f64 = StandardNormal.sample(&mut rng);
        *p += 10.0 * z;
    }
    let truth = score::table(&robot, &drive, &set.selection.fit.model, &[]).unwrap();
    let error = |fo: &FitOptions| -> f64 {
        let sel = identify_logs(&robot, &logs, &routes, fo).unwrap();
        let rows = score::table(&robot, &drive, &sel.fit.model, &[]).unwrap();
        rows.iter()
            .zip(&truth)
            .filter(|(_, t)| t.truth.abs() > 0.1)
            .map(|(r, _)| (r.error_pct.unwrap() / 100.0).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    // The arm's power alone: with each motor's power fitted too, the motors' quieter power
    // decides the parameters and the noisy run hardly matters either way.
    let arm = FitOptions {
        motor_power: false,
        ..FitOptions::default()
    };
    let ols = error(&arm);
    let wls = error(&FitOptions {
        weighting: Weighting::PerLog,
        ..arm.clone()
    });
    eprintln!("relative parameter error: OLS {ols:.5}, per-log WLS {wls:.5}");
    // Measured: 1.418 and 0.456.
    assert!(wls < 0.6 * ols, "OLS {ols}, WLS {wls}");
    // The consistent model: positive-definite mass matrix, no negative drive term, close to
    // the estimate in its own standard deviations.
    let sel = identify_logs(&robot, &set.logs, &routes, &FitOptions::default()).unwrap();
    let c = sel.consistent.as_ref().unwrap();
    let check = consistency(&robot, &sel.fit.model, 1.0, 200, 1).unwrap();
    eprintln!(
        "consistent: Mahalanobis {:.3}, largest change {:.3} sigma, min eig {:.4}",
        c.mahalanobis, c.max_change_sigma, check.min_eigenvalue
    );
    // Measured: Mahalanobis 2.82, largest change 1.33 standard deviations.
    assert!(check.consistent);
    assert!(c.max_change_sigma < 3.0, "{}", c.max_change_sigma);
    assert!(sel.fit.model.copper.iter().all(|v| *v >= 0.0));
}

#[test]
fn each_motors_power_determines_the_wrist_better_than_the_arms_alone() {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let (set, routes) = quick_exact_set(&robot, &drive);
    let fitted = |logs: &[powertwin::measurement::Log], motor_power: bool| {
        let fo = FitOptions {
            motor_power,
            ..FitOptions::default()
        };
        identify_logs(&robot, logs, &routes, &fo).unwrap()
    };
    let (arm, motors) = (fitted(&set.logs, false), fitted(&set.logs, true));
    assert!(!arm.motor_power && motors.motor_power);
    // Relative standard deviations of the base parameters of the wrist's links and drives
    // (joints 4-6), and how many base parameters are determined to 1 %.
    let stats = |sel: &powertwin::identification::fit::Selection| -> (Vec<f64>, usize) {
        let e = sel.fit.free_estimate();
        let theta = e
            .names
            .iter()
            .zip(&e.rel_std)
            .take(sel.fit.model.theta.len());
        let wrist: Vec<f64> = theta
            .clone()
            .filter(|(n, _)| ['4', '5', '6'].iter().any(|j| n.contains(*j)))
            .map(|(_, r)| *r)
            .collect();
        (wrist, theta.filter(|(_, r)| **r < 0.01).count())
    };
    let ((wrist_arm, arm_count), (wrist_motors, motor_count)) = (stats(&arm), stats(&motors));
    let smaller = wrist_arm
        .iter()
        .zip(&wrist_motors)
        .filter(|(a, m)| m < a)
        .count();
    eprintln!(
        "well determined: {arm_count} from the arm's power, {motor_count} with each motor's; \
         {smaller} of {} wrist parameters tighter",
        wrist_arm.len()
    );
    // Measured: 5 against 13 well determined, 23 of 30 wrist parameters tighter.
    assert!(motor_count >= arm_count + 4, "{arm_count} {motor_count}");
    assert!(
        3 * smaller >= 2 * wrist_arm.len(),
        "{smaller} of {}",
        wrist_arm.len()
    );
    // Logs without each motor's power fall back to the arm's power; a motor's power is never
    // scored in cross-validation, whose pieces are the arm's.
    let mut bare = set.logs.clone();
    for l in &mut bare {
        l.motor_power_w = None;
    }
    let fallback = fitted(&bare, true);
    assert!(!fallback.motor_power);
    assert_eq!(fallback.scores[0].pieces, arm.scores[0].pieces);
    assert_eq!(motors.scores[0].pieces, arm.scores[0].pieces);
    // Asked for directly, the motors' power of a log without it is refused, naming the log.
    let prepared = [powertwin::identification::data::prepare(&bare[0], routes[0]).unwrap()];
    let template = PowerModel::new(&robot, ParamLayout::new(&robot, true, true), false).unwrap();
    let err = Samples::new(&robot, &template, &prepared, 0.05, 0.0, 5, true)
        .err()
        .expect("no motor power")
        .to_string();
    assert!(err.contains("log 1 has no power of each motor"), "{err}");
    assert!(Samples::new(&robot, &template, &prepared, 0.05, 0.0, 5, false).is_ok());
}

#[test]
fn the_standby_pose_holds_the_arm_with_next_to_no_gravity_torque() {
    use powertwin::dynamics::Workspace;
    use powertwin::dynamics::rnea::rnea;
    use powertwin::identification::excitation::standby_pose;
    let robot = common::irb1200();
    let (q, tau) = standby_pose(&robot, 0.05, 0.05, 0.15).unwrap();
    robot.check_position_limits(&q).unwrap();
    // Its torques are the URDF's gravity torques there.
    let mut ws = Workspace::new(&robot);
    let mut again = vec![0.0; 6];
    rnea(&robot, &mut ws, &q, &[0.0; 6], &[0.0; 6], None, &mut again);
    assert_eq!(tau, again);
    // At the zero pose the shoulder and elbow hold 13 N m each; here (arm upright over the
    // base) at most 0.21 N m, measured.
    let worst = tau.iter().fold(0.0_f64, |m, t| m.max(t.abs()));
    assert!(worst < 0.5, "{q:?}: {tau:?}");
    // Seeded: the same pose every time.
    assert_eq!(standby_pose(&robot, 0.05, 0.05, 0.15).unwrap().0, q);
    // A margin wider than a joint's range is a clear error.
    let err = standby_pose(&robot, 2.5, 0.05, 0.15)
        .unwrap_err()
        .to_string();
    assert!(err.contains("joint_2"), "{err}");
}

#[test]
fn a_log_at_rest_is_read_but_identifies_nothing_alone() {
    use powertwin::identification::data::prepare;
    use powertwin::measurement::{Log, PowerSignal};
    let robot = common::irb1200();
    let m = 100;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
    let rest = Log {
        source: "rest".into(),
        robot: None,
        t_s: (0..m).map(|k| 0.1 * k as f64).collect(),
        q_rad: vec![vec![0.3; m]; 6],
        dq_rad_s: None,
        power_w: (0..m)
            .map(|_| {
                let e: f64 = StandardNormal.sample(&mut rng);
                18.5 + e
            })
            .collect(),
        signal: PowerSignal::Bus,
        motor_power_w: None,
        power_averaged: false,
        payloads: Vec::new(),
    };
    // Prepared: no joint moves, and the spline route holds it exactly still.
    let p = prepare(&rest, Route::Spline).unwrap();
    assert!(p.excited.is_empty());
    assert!(p.states.dq.iter().flatten().all(|v| *v == 0.0));
    // Alone it identifies nothing, and says why.
    let err = identify_logs(&robot, &[rest], &[Route::Spline], &FitOptions::default())
        .err()
        .expect("rests alone are refused")
        .to_string();
    assert!(err.contains("no joint moves in any log"), "{err}");
}

#[test]
fn a_standby_rest_pins_the_identified_standby_power() {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let rig = rig(&robot, &drive, Fidelity::Exact, NoiseSettings::default());
    let standby = |rest_s: f64| {
        // From the arm's power alone (each motor's pins the constant better: 18.23 W without
        // the rest).
        let mut opts = IdSetOptions {
            standby_rest_s: rest_s,
            ..IdSetOptions::irb1200(true)
        };
        opts.fit.motor_power = false;
        let set = idset::run(&rig, &opts, &Silent).unwrap();
        assert_eq!(set.logs.len(), 4 + usize::from(rest_s > 0.0));
        assert_eq!(set.standby.is_some(), rest_s > 0.0);
        set.selection.fit.model.constant[0]
    };
    // The drives draw 18.5 W. Measured: four excitations alone 17.98 W (the copper loss of
    // moving trades against the constant), with a 20 s rest at the standby pose 18.55 W.
    let (without, with) = (standby(0.0), standby(20.0));
    assert!((without - 18.5).abs() > 0.3, "{without}");
    assert!((with - 18.5).abs() < 0.15, "{with}");
}

#[test]
fn a_design_runs_only_with_the_set_it_was_designed_for() {
    // Robots that differ only in what the files do not show (a family's) share one design;
    // a design of another set is an error, not a silently shorter identification set.
    let robot = common::irb1200();
    let drive = drive(&robot);
    let rig = rig(&robot, &drive, Fidelity::Exact, NoiseSettings::NONE);
    let mut opts = IdSetOptions::irb1200(true);
    opts.centres.truncate(2);
    opts.loads_kg.truncate(2);
    opts.base_freq_hz.truncate(2);
    opts.rounds = 1;
    opts.max_evals = 20;
    let design = idset::design(&robot, &opts).unwrap();
    assert_eq!(design.trajectories.len(), 2);
    let mut other = opts.clone();
    other.centres.push(vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0]);
    other.loads_kg.push(7.0);
    other.base_freq_hz.push(0.1);
    match idset::run_designed(&rig, &other, &design, &Silent) {
        Err(powertwin::Error::InvalidInput(m)) => {
            assert!(
                m.contains("a design of 2 excitations for a set of 3"),
                "{m}"
            )
        }
        Err(e) => panic!("expected the mismatch named, got {e}"),
        Ok(_) => panic!("a design of 2 excitations ran a set of 3"),
    }
}
