//! Predictions beyond what identification saw: a meter level never seen, a quiet motion's
//! structure error, and a payload the unloaded logs did not carry.

use super::*;

/// A cabinet load the meter sees after the bus clip puts a floor under the reading. Gentle
/// identification logs never reach it, so the fit cannot find it (the standby absorbs the
/// cabinet). The model records the lowest level its logs showed the meter at, and a motion
/// that brakes below that level gets an interval that holds what the meter might read there.
#[test]
fn a_meter_never_seen_low_widens_the_interval_of_a_motion_that_brakes() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let rig = common::irb1200_cabinet_rig(&robot, &drive);
    let traj = excitation(&robot);
    let logs = two_logs(&rig, &traj);
    let route = [Route::Fourier {
        base_freq_hz: 0.2,
        harmonics: 5,
    }];
    let opts = FitOptions {
        max_power_lag_s: 0.0,
        ..FitOptions::default()
    };
    let model = identify_logs(&robot, &logs, &route, &opts)
        .unwrap()
        .fit
        .model;
    let lowest = model
        .lowest_seen
        .expect("a bus signal has a lowest seen level");
    assert!(lowest > 45.0, "lowest seen {lowest} W with a 50 W cabinet");
    // The same excitation twice as fast and wider: the arm regenerates hard.
    let n = robot.dof();
    let fast = Fourier::new(
        0.4,
        vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0],
        vec![vec![0.45, -0.2]; n],
        vec![vec![0.3, 0.15]; n],
        2.0,
    )
    .unwrap();
    let truth = rig.run(&fast, &[], 7, serde_json::json!({})).unwrap();
    let true_j = truth.truth.energy_grid();
    let with = model.predict(&robot, &fast, &[], 1.0, 1e-3).unwrap();
    let without = |alternative| {
        PowerModel {
            lowest_seen: None,
            alternative,
            ..model.clone()
        }
        .predict(&robot, &fast, &[], 1.0, 1e-3)
        .unwrap()
        .interval_j
    };
    // The level never seen widens the interval, which then holds the truth (the other
    // friction structure's disagreement, which this motion's braking also shows, widens it
    // besides). The parameters and the structure error alone hold the miss only at their
    // edge here: the structure error is the mean's, taken at the pieces' activity.
    let (bare, no_level) = (without(None), without(model.alternative.clone()));
    let miss = (with.energy_j - true_j).abs();
    assert!(
        bare < no_level && 2.0 * no_level < with.interval_j && miss <= with.interval_j,
        "{true_j:.1} J true, {:.1} J predicted: interval +-{bare:.1} J without the unseen \
         level and the other friction structure, +-{no_level:.1} J without the level, \
         +-{:.1} J with both",
        with.energy_j,
        with.interval_j
    );
}

/// The relative part of the structure error is taken at no less than the model's
/// `structure_active_W`: a motion less active than the cross-validation pieces (here a model
/// that predicts only its standby, so no activity at all) keeps the error they showed.
#[test]
fn a_quiet_motion_keeps_the_structure_error_of_the_pieces() {
    let robot = common::irb1200();
    let layout = powertwin::dynamics::ParamLayout::new(&robot, true, true);
    let mut model = PowerModel::new(&robot, layout, false).unwrap();
    model.constant = vec![10.0; robot.dof()];
    model.structure_rel = 0.01;
    let traj = excitation(&robot);
    let interval = |active_w: f64| {
        let m = PowerModel {
            structure_active: active_w,
            ..model.clone()
        };
        m.predict(&robot, &traj, &[], 1.0, 1e-2).unwrap().interval_j
    };
    assert_eq!(interval(0.0), 0.0);
    let expected = 1.96 * 0.01 * 80.0 * traj.duration();
    assert!(
        (interval(80.0) - expected).abs() < 1e-9 * expected,
        "{}",
        interval(80.0)
    );
}

/// A model identified without payloads, asked about a 5.3 kg payload: with the drive file's
/// copper-loss coefficients as a prior, the wrist's copper loss (which unloaded torques barely
/// show) is kept, and the payload's losses beyond what the logs carried are in the interval,
/// so the prediction stays inside it; without that prior the unloaded fit holds the wrist's
/// coefficients at zero and predicts the payload's copper loss low
/// (docs/experiments.md#the-drive-files-copper-as-a-prior).
#[test]
fn an_unloaded_identification_keeps_the_copper_loss_a_payload_adds() {
    use powertwin::identification::prior::{Prior, PriorWidths};
    let u = unloaded_1000000();
    let prior = Prior::for_robot(&u.robot, Some(&u.drive), &PriorWidths::default()).unwrap();
    let identify = |prior: Prior| {
        let opts = FitOptions {
            prior: Some(prior),
            ..FitOptions::default()
        };
        identify_logs(&u.robot, &u.logs, &u.route, &opts)
            .unwrap()
            .fit
            .model
    };
    let with = identify(prior.clone());
    // A model without gear friction carries the same logs' model with it beside, and its
    // predictions report what that one predicts.
    assert!(with.gear_friction.is_empty());
    let alt = with.alternative.as_deref().expect("the gear model beside");
    assert!(!alt.gear_friction.is_empty());
    assert_eq!(
        u.predict(&with).alternative_j,
        Some(u.predict(alt).energy_j)
    );
    // Both carry the nominal drive file's Stribeck law (the drawn truth has its own), and a
    // prediction reports the energy with its whole rise, above the model's half.
    assert_eq!(with.stribeck, prior.stribeck);
    assert_eq!(alt.stribeck, prior.stribeck);
    let p = u.predict(&with);
    assert!(
        p.stribeck_j.expect("the whole rise's energy") > p.energy_j,
        "{p:?}"
    );
    let without = identify(Prior {
        copper: vec![None; u.robot.dof()],
        ..prior
    });
    let predict = |m: &PowerModel| {
        let p = u.predict(m);
        (p.energy_j - u.true_j, p.interval_j)
    };
    let ((err_with, int_with), (err_without, int_without)) = (predict(&with), predict(&without));
    // The model knows its logs carried nothing: the payload's losses beyond that are in the
    // interval (`unseen_load_J`), which without that term is narrower.
    assert_eq!(with.payload_seen, Some(0.0));
    let blind = PowerModel {
        payload_seen: None,
        ..with.clone()
    };
    let (_, int_blind) = predict(&blind);
    eprintln!(
        "copper {:?} / {:?}; true {:.1} J: with the copper prior {err_with:+.1} +- \
         {int_with:.1} J (+- {int_blind:.1} J without the unseen load), without it \
         {err_without:+.1} +- {int_without:.1} J",
        with.copper, without.copper, u.true_j
    );
    assert!(err_with.abs() <= int_with, "{err_with} +- {int_with}");
    assert!(err_with.abs() < err_without.abs());
    assert!(int_blind < int_with);
}

/// Family robot `1000000` (gear friction 0.039/0.016 and 0.014/0.018 motoring / braking on
/// joints 2 and 3) identified from two unloaded excitations (`--method gear`):
/// cross-validation prefers the gear-friction model to `pmsm`. It finds those joints' mean
/// friction within 0.01 and predicts a held-out motion with a 5.3 kg payload closer than the
/// model without it; the model's prediction, the mean of the two, is within an interval that
/// holds half their difference.
#[test]
fn gear_friction_is_found_in_unloaded_logs_and_carries_to_a_payload() {
    use powertwin::identification::fit::Estimator;
    use powertwin::identification::prior::{Prior, PriorWidths};
    let u = unloaded_1000000();
    let opts = FitOptions {
        prior: Some(Prior::for_robot(&u.robot, Some(&u.drive), &PriorWidths::default()).unwrap()),
        candidates: vec![Estimator::Pmsm, Estimator::Gear],
        ..FitOptions::default()
    };
    let selection = identify_logs(&u.robot, &u.logs, &u.route, &opts).unwrap();
    assert_eq!(selection.chosen, Estimator::Gear);
    let model = selection.fit.model;
    // Joints 2 and 3 carry gravity, which shows their gear friction in any motion; joint 1's
    // torque is inertia and friction alone, which two logs of one excitation barely separate.
    for (i, j) in u.gear_truth.iter().enumerate().take(3).skip(1) {
        assert!(
            (model.gear_friction[i] - j).abs() < 0.01,
            "joint {}: {} against {j}",
            i + 1,
            model.gear_friction[i]
        );
    }
    let without = model.alternative.as_deref().expect("the pmsm model beside");
    assert!(without.gear_friction.is_empty());
    // Each structure alone, and the model's prediction: their mean.
    let alone = PowerModel {
        alternative: None,
        ..model.clone()
    };
    let (gear, pmsm, mean) = (u.predict(&alone), u.predict(without), u.predict(&model));
    let true_j = u.true_j;
    eprintln!(
        "gear friction {:?}; true {true_j:.1} J: gear {:+.1} J, without {:+.1} J, mean {:+.1} \
         +- {:.1} J",
        model.gear_friction,
        gear.energy_j - true_j,
        pmsm.energy_j - true_j,
        mean.energy_j - true_j,
        mean.interval_j
    );
    assert!((gear.energy_j - true_j).abs() < (pmsm.energy_j - true_j).abs());
    assert_eq!(mean.alternative_j, Some(pmsm.energy_j));
    assert!((mean.energy_j - 0.5 * (gear.energy_j + pmsm.energy_j)).abs() < 1e-6 * true_j);
    assert!((mean.energy_j - true_j).abs() <= mean.interval_j);
    assert!(mean.interval_j >= 1.96 * 0.5 * (gear.energy_j - pmsm.energy_j).abs());
}

/// Family robot `1000000` logged unloaded, and a held-out motion with a payload, for the
/// tests of payloads beyond what identification carried.
struct Unloaded {
    robot: powertwin::Robot,
    drive: Drive,
    /// Two runs of the 20 s excitation, unloaded.
    logs: Vec<powertwin::measurement::Log>,
    route: [Route; 1],
    /// The drawn gear friction per joint, mean of motoring and braking (truth, for scoring).
    gear_truth: Vec<f64>,
    /// A held-out motion carrying the tool and the 4 kg load (5.32 kg).
    held_out: Fourier,
    events: [powertwin::model::payload::PayloadEvent; 1],
    /// Its true energy on the bus, J.
    true_j: f64,
}

impl Unloaded {
    /// `model`'s prediction of the held-out motion.
    fn predict(&self, model: &PowerModel) -> powertwin::identification::model::Prediction {
        model
            .predict(&self.robot, &self.held_out, &self.events, 1.0, 1e-3)
            .unwrap()
    }
}

/// [`Unloaded`] of family robot `1000000` on the realistic IRB 1200 rig.
fn unloaded_1000000() -> Unloaded {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let base = common::irb1200_rig(
        &robot,
        &drive,
        Fidelity::Realistic,
        NoiseSettings::default(),
    );
    let plant = FamilyTable::default()
        .draw(&robot, &drive, &base.twin, &base.sensor, 1_000_000)
        .unwrap();
    let rig = Rig {
        plant: Some(&plant),
        ..base.clone()
    };
    let logs = two_logs(&rig, &excitation(&robot));
    let payload = powertwin::model::builtin::payload("tool")
        .unwrap()
        .combined(&powertwin::model::builtin::payload("load_4kg").unwrap());
    let events = [powertwin::model::payload::PayloadEvent {
        t_s: 0.0,
        payload: Some(payload),
    }];
    let n = robot.dof();
    let held_out = Fourier::new(
        0.1,
        vec![0.3, 0.4, 0.0, 0.5, 1.0, -0.5],
        vec![vec![0.4, -0.2, 0.1]; n],
        vec![vec![-0.3, 0.2, 0.05]; n],
        2.0,
    )
    .unwrap();
    let true_j = rig
        .run(&held_out, &events, 5, serde_json::json!({}))
        .unwrap()
        .truth
        .energy_grid();
    let gear_truth = (plant.draw.joints.iter())
        .map(|j| 0.5 * (j.gear_friction_per_nm + j.gear_friction_braking_per_nm))
        .collect();
    drop(rig);
    Unloaded {
        robot,
        drive,
        logs,
        route: [Route::Fourier {
            base_freq_hz: 0.2,
            harmonics: 5,
        }],
        gear_truth,
        held_out,
        events,
        true_j,
    }
}
