//! The pieces behind Table 2 and Table 4, checked exactly against models built from the
//! truth: adding a known payload through the base relations, re-identifying the last link,
//! the parameter table and the physical-consistency check.

use crate::common;

use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
use powertwin::dynamics::{DriveTerms, ParamLayout};
use powertwin::identification::consistency::consistency;
use powertwin::identification::last_link::{affected, reidentify};
use powertwin::identification::model::PowerModel;
use powertwin::identification::states::from_fourier;
use powertwin::model::Robot;
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::payload::PayloadEvent;
use powertwin::model::payload::attach;
use powertwin::trajectory::random::{RandomFourierOptions, random_fourier};
use powertwin::validation::score::table;

fn drive(robot: &Robot) -> Drive {
    Drive::from_toml_str(builtin::IRB1200_DRIVE, "drive", robot).unwrap()
}

/// The exact power model of `robot` with `drive` (SI, copper and standby from the drive).
fn true_model(robot: &Robot, drive: &Drive) -> PowerModel {
    let layout = ParamLayout::new(robot, true, true);
    let mut model = PowerModel::new(robot, layout, false).unwrap();
    let base = BaseParams::compute(robot, layout, &SamplingOptions::default()).unwrap();
    model.theta = base
        .base_values(&layout.theta(robot, &DriveTerms::from(drive)))
        .unwrap();
    model.copper = drive.joints().iter().map(|j| j.copper_loss).collect();
    model.constant = drive.joints().iter().map(|j| j.standby_power).collect();
    model
}

fn tool_and_load() -> powertwin::model::payload::Payload {
    builtin::payload("tool")
        .unwrap()
        .combined(&builtin::payload("load_4kg").unwrap())
}

#[test]
fn a_known_payload_maps_onto_the_base_parameters_exactly() {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let payload = tool_and_load();
    let predicted = true_model(&robot, &drive)
        .with_payload(&robot, &payload, 1.0)
        .unwrap();
    let truth = true_model(&attach(&robot, &payload).unwrap(), &drive);
    for ((name, a), b) in predicted
        .names
        .iter()
        .zip(&predicted.theta)
        .zip(&truth.theta)
    {
        assert!(
            (a - b).abs() < 1e-12 * (1.0 + b.abs()),
            "{name}: {a} vs {b}"
        );
    }
    // An efficiency-scaled model gets the change divided by the efficiency.
    let mut scaled = true_model(&robot, &drive);
    scaled.efficiency_scaled = true;
    let base = scaled.theta.clone();
    let plus = scaled.with_payload(&robot, &payload, 0.8).unwrap();
    for ((b, t), p) in base.iter().zip(&truth.theta).zip(&plus.theta) {
        let expected = b + (t - b) / 0.8;
        assert!((p - expected).abs() < 1e-12 * (1.0 + expected.abs()));
    }
    // Bad efficiency and a model of another robot are errors.
    assert!(scaled.with_payload(&robot, &payload, 0.0).is_err());
    assert!(scaled.with_payload(&robot, &payload, f64::NAN).is_err());
    let other = common::irb1200()
        .with_link_inertia(5, payload.inertia)
        .unwrap();
    let mut foreign = true_model(&robot, &drive);
    foreign.robot = "another_robot".into();
    assert!(foreign.with_payload(&other, &payload, 1.0).is_err());
}

#[test]
fn energy_with_payload_events_switches_models_at_the_event_times() {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let model = true_model(&robot, &drive);
    let traj = random_fourier(
        &robot,
        &mut common::rng(3),
        &RandomFourierOptions::default(),
    )
    .unwrap();
    let payload = tool_and_load();
    let plain = model.energy(&robot, &traj, 1e-3).unwrap();
    let carried = model
        .with_payload(&robot, &payload, 1.0)
        .unwrap()
        .energy(&robot, &traj, 1e-3)
        .unwrap();
    let always = model
        .energy_with_payloads(
            &robot,
            &traj,
            &[PayloadEvent {
                t_s: 0.0,
                payload: Some(payload.clone()),
            }],
            1.0,
            1e-3,
        )
        .unwrap();
    assert!((always.motor_j - carried).abs() < 1e-9 * carried.abs());
    assert!(always.grid_j >= always.motor_j - 1e-9);
    // Released at t = 0 again: back to the bare model.
    let released = model
        .energy_with_payloads(
            &robot,
            &traj,
            &[
                PayloadEvent {
                    t_s: 0.0,
                    payload: Some(payload),
                },
                PayloadEvent {
                    t_s: 0.0,
                    payload: None,
                },
            ],
            1.0,
            1e-3,
        )
        .unwrap();
    assert!((released.motor_j - plain).abs() < 1e-9 * plain.abs());
    assert!(carried > plain, "the payload costs copper loss");
}

#[test]
fn reidentifying_the_last_link_recovers_the_payload_exactly() {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let mut bare = true_model(&robot, &drive);
    bare.copper.fill(0.0);
    let payload = tool_and_load();
    let mut loaded = bare.with_payload(&robot, &payload, 1.0).unwrap();
    loaded.constant = vec![3.0; 6];
    let traj = random_fourier(
        &robot,
        &mut common::rng(5),
        &RandomFourierOptions::default(),
    )
    .unwrap();
    let t: Vec<f64> = (0..200).map(|k| k as f64 * 0.05).collect();
    let states = from_fourier(&traj, &t);
    let p: Vec<f64> = loaded
        .power_with_payloads(&robot, &traj, &[], 1.0, &t)
        .unwrap();
    let (found, est) = reidentify(&robot, &bare, &states, &p).unwrap();
    let unknown = affected(&robot, &bare).unwrap();
    assert!(unknown.len() >= 10, "{unknown:?}");
    // Mass and first moments of link 6 regroup into links 4 and 5 (e.g. M6 into MY5R).
    assert!(unknown.iter().any(|&k| !bare.names[k].ends_with('6')));
    for k in 0..found.theta.len() {
        let scale = 1.0 + loaded.theta[k].abs();
        assert!(
            (found.theta[k] - loaded.theta[k]).abs() < 1e-6 * scale,
            "{}: {} vs {}",
            found.names[k],
            found.theta[k],
            loaded.theta[k]
        );
    }
    assert!((found.constant[0] - 18.0).abs() < 1e-6);
    assert!(est.residual_rms < 1e-6);
    // A model with copper-loss terms cannot be re-identified linearly.
    let with_copper = true_model(&robot, &drive);
    let err = reidentify(&robot, &with_copper, &states, &p).unwrap_err();
    assert!(err.to_string().contains("linear"), "{err}");
    // Mismatched lengths are errors.
    assert!(reidentify(&robot, &bare, &states, &p[1..]).is_err());
}

#[test]
fn table2_and_consistency_judge_models_against_the_truth() {
    let robot = common::irb1200();
    let drive = drive(&robot);
    let model = true_model(&robot, &drive);
    let rows = table(&robot, &drive, &model, &[]).unwrap();
    assert_eq!(rows.len(), 52);
    for r in &rows {
        assert!(r.error_pct.is_none_or(|e| e.abs() < 1e-9), "{r:?}");
        assert!(r.rel_std_pct.is_none());
    }
    // Efficiency-scaled models are compared with the truth divided by the nominal efficiency.
    let mut scaled = model.clone();
    scaled.efficiency_scaled = true;
    let eta = drive.nominal_efficiency();
    for t in &mut scaled.theta {
        *t /= eta;
    }
    for r in table(&robot, &drive, &scaled, &[]).unwrap() {
        assert!(r.error_pct.is_none_or(|e| e.abs() < 1e-9), "{r:?}");
    }
    let ok = consistency(&robot, &model, 1.0, 50, 7).unwrap();
    assert!(ok.consistent && ok.min_eigenvalue > 0.0, "{ok:?}");
    // A negative viscous friction and a negated inertia are caught.
    let mut bad = model.clone();
    let fv = bad.names.iter().position(|n| n == "fv2").unwrap();
    bad.theta[fv] = -1.0;
    let zz = bad.names.iter().position(|n| n.starts_with("ZZ1")).unwrap();
    bad.theta[zz] = -10.0;
    let c = consistency(&robot, &bad, 1.0, 50, 7).unwrap();
    assert!(!c.consistent && c.min_eigenvalue < 0.0, "{c:?}");
    assert_eq!(c.negative_drive_terms, vec!["fv2".to_string()]);
}

#[test]
fn a_joint_the_plan_leaves_still_costs_no_coulomb_friction() {
    // The pick-and-place keeps the tool pointing down: joint 4 stays still throughout and the
    // base for whole legs, with reference speeds of 1e-17 rad/s from the inverse kinematics.
    // Their sign switched the full Coulomb torque on in the prediction (not in the twin,
    // whose stiction holds them): +0.36 % on this cell at the test rig's 3 substeps
    // (-0.07 % with them at rest), +0.22 W on every cell of the sweep.
    use powertwin::trajectory::task::Scenario;
    use powertwin::twin::Fidelity;
    use powertwin::twin::sensor::NoiseSettings;
    let robot = common::irb1200();
    let drive = drive(&robot);
    let rig = common::irb1200_rig(&robot, &drive, Fidelity::Exact, NoiseSettings::NONE);
    let plan = Scenario::builtin().unwrap().plan(&robot, 1.0, 0.0).unwrap();
    let (ds, _) = rig
        .run_reported(
            &plan.motion.trajectory,
            &plan.events,
            &[],
            1,
            serde_json::json!({}),
        )
        .unwrap();
    let simulated = ds.meta.summary.energy_total_j;
    let predicted = true_model(&robot, &drive)
        .energy_with_payloads(&robot, &plan.motion.trajectory, &plan.events, 1.0, 1e-3)
        .unwrap()
        .motor_j;
    let error = 100.0 * (predicted - simulated) / simulated;
    assert!(
        error.abs() < 0.15,
        "{error:+.3} % ({predicted} vs {simulated} J)"
    );
}
