//! Physically consistent standard parameters from base-parameter estimates, and the identified
//! robot as a twin: twin A -> logs -> identify -> consistent export -> twin B.

use crate::common;

use nalgebra::{DMatrix, DVector};
use powertwin::Robot;
use powertwin::dataset::meta::Urdf;
use powertwin::dynamics::base_params::{BaseParams, SamplingOptions, random_stack};
use powertwin::dynamics::crba::mass_matrix;
use powertwin::dynamics::{DriveTerms, ParamLayout};
use powertwin::identification::consistent::{
    Consistent, IdentifiedTwin, Options, project, pseudo_inertia,
};
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::export::with_standard_params;

fn drive(robot: &Robot) -> Drive {
    Drive::from_toml_str(builtin::IRB1200_DRIVE, "drive", robot).unwrap()
}

struct Setup {
    robot: Robot,
    layout: ParamLayout,
    base: BaseParams,
    truth: Vec<f64>,
    theta: Vec<f64>,
    /// Covariance of a torque least squares on 100 random states with 0.5 N m noise.
    cov: DMatrix<f64>,
    /// A wrong prior: masses +30 %, first moments -20 %, inertias +50 %, no rotor inertia,
    /// friction doubled.
    prior: Vec<f64>,
}

fn setup() -> Setup {
    let robot = common::irb1200();
    let layout = ParamLayout::new(&robot, true, true);
    let base = BaseParams::compute(&robot, layout, &SamplingOptions::default()).unwrap();
    let truth = layout.theta(&robot, &DriveTerms::from(&drive(&robot)));
    let theta = base.base_values(&truth).unwrap();
    let stack = random_stack(
        &robot,
        &layout,
        &SamplingOptions {
            samples: 100,
            seed: 7,
        },
    )
    .unwrap();
    let a = base.base_regressor(&stack);
    let cov = (a.transpose() * &a).try_inverse().unwrap() * 0.25;
    let mut prior = truth.clone();
    for (c, v) in prior.iter_mut().enumerate() {
        let k = c % layout.per_link();
        *v *= match k {
            0..=5 => 1.5,
            6..=8 => 0.8,
            9 => 1.3,
            10 | 11 => 2.0,
            _ => 0.0,
        };
    }
    Setup {
        robot,
        layout,
        base,
        truth,
        theta,
        cov,
        prior,
    }
}

/// Every link's pseudo-inertia is positive definite (eigenvalues), its body passes the
/// loader's checks (mass, PD inertia, triangle inequality), drive terms are >= 0, and the mass
/// matrix with the rotor inertias is positive definite at 200 random poses. Returns the
/// smallest pseudo-inertia eigenvalue relative to the link's largest.
fn assert_consistent(s: &Setup, c: &Consistent) -> f64 {
    let l = &s.layout;
    let mut worst = f64::INFINITY;
    for j in 0..l.dof {
        let p = &c.phi[l.link_start(j)..l.link_start(j) + 10];
        let e = pseudo_inertia(p).symmetric_eigenvalues();
        assert!(
            e.min() > 0.0,
            "link {}: pseudo-inertia eigenvalues {e}",
            j + 1
        );
        worst = worst.min(e.min() / e.max());
        for col in [l.coulomb_col(j), l.viscous_col(j), l.armature_col(j)] {
            let v = c.phi[col.unwrap()];
            assert!(v >= 0.0, "{}: {v}", c.names[col.unwrap()]);
        }
    }
    let robot = with_standard_params(&s.robot, l, &c.phi).unwrap();
    let ia: Vec<f64> = (0..l.dof)
        .map(|j| c.phi[l.armature_col(j).unwrap()])
        .collect();
    let mut rng = common::rng(9);
    for _ in 0..200 {
        let (q, _, _) = common::random_state(&robot, &mut rng);
        let e = mass_matrix(&robot, &q, Some(&ia)).symmetric_eigenvalues();
        assert!(e.min() > 0.0, "mass matrix at {q:?}: {e}");
    }
    worst
}

#[test]
fn true_base_parameters_are_reproduced_by_consistent_standard_ones() {
    let s = setup();
    let c = project(&s.base, &s.theta, &s.cov, &s.prior, &Options::default()).unwrap();
    // Relative to the value, or to 1e-4 of the largest base parameter (12 N m) for the tiny
    // ones (ZZ6, 2.7e-5 kg m^2: its error 3e-13 is at the conditioning limit).
    let largest = s.theta.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mut worst = 0.0_f64;
    for (k, (a, b)) in c.theta.iter().zip(&s.theta).enumerate() {
        let rel = (a - b).abs() / b.abs().max(1e-4 * largest);
        worst = worst.max(rel);
        assert!(rel < 1e-8, "{}: {a} vs {b}", c.base_names[k]);
    }
    println!(
        "exact estimate: worst relative base error {worst:.2e}, Mahalanobis {:.2e}, {} iterations",
        c.mahalanobis, c.iterations
    );
    assert!(c.mahalanobis < 1e-6 && c.max_change_sigma < 1e-6, "{c:?}");
    let margin = assert_consistent(&s, &c);
    println!("smallest relative pseudo-inertia eigenvalue {margin:.2e}");
    // What the data cannot reveal is listed and came from the prior: M1 has no effect at
    // all, YY2 only in combinations; fc and fv are base parameters on their own.
    for name in ["M1", "YY2", "Ia1"] {
        assert!(c.from_prior.iter().any(|n| n == name), "{:?}", c.from_prior);
    }
    for name in ["fc3", "fv6", "Ia4"] {
        assert!(
            !c.from_prior.iter().any(|n| n == name),
            "{:?}",
            c.from_prior
        );
    }
    // The parameters that are functions of the base parameters are the truth.
    for (k, name) in c.names.iter().enumerate() {
        if !c.from_prior.contains(name) {
            let t = s.truth[k];
            assert!(
                (c.phi[k] - t).abs() < 1e-7 * t.abs().max(1e-3),
                "{name}: {} vs {t}",
                c.phi[k]
            );
        }
    }
    // Bad input is an error, not a panic.
    let o = Options::default();
    assert!(project(&s.base, &s.theta[1..], &s.cov, &s.prior, &o).is_err());
    assert!(project(&s.base, &s.theta, &(-&s.cov), &s.prior, &o).is_err());
    let mut nan = s.prior.clone();
    nan[3] = f64::NAN;
    assert!(project(&s.base, &s.theta, &s.cov, &nan, &o).is_err());
}

#[test]
fn infeasible_estimates_are_projected_onto_consistent_parameters() {
    let s = setup();
    let names = s.base.base_names();
    let sigma = |k: usize| s.cov[(k, k)].sqrt();
    let info = s.cov.clone().try_inverse().unwrap();
    let maha = |d: &DVector<f64>| d.dot(&(&info * d)).sqrt();
    // (1) Joint 6's Coulomb friction estimated at -2 sigma (a base parameter on its own).
    let k = names.iter().position(|n| n == "fc6").unwrap();
    let mut theta = s.theta.clone();
    theta[k] = -2.0 * sigma(k);
    let c = project(&s.base, &theta, &s.cov, &s.prior, &Options::default()).unwrap();
    assert_consistent(&s, &c);
    let fc6 = c.phi[s.layout.coulomb_col(5).unwrap()];
    // Moving fc6 alone to 0 is feasible (the truth with fc6 = 0): the projection is at least
    // as close, and close to 2 sigma.
    let mut d = DVector::zeros(names.len());
    d[k] = 2.0 * sigma(k);
    println!(
        "fc6 at -2 sigma: projected fc6 {fc6:.3e} N m, Mahalanobis {:.3} (fc6 -> 0 alone: {:.3}), largest change {:.3} sigma",
        c.mahalanobis,
        maha(&d),
        c.max_change_sigma
    );
    assert!(c.mahalanobis <= maha(&d) * (1.0 + 1e-6), "{c:?}");
    assert!(c.mahalanobis > 0.5 && fc6 < 0.1 * sigma(k));
    // (2) Link 6 with negative mass: its ten inertial parameters times -0.5, plus a few sigma
    // of joint 5's viscous friction below zero.
    let mut bad = s.truth.clone();
    let start = s.layout.link_start(5);
    for v in &mut bad[start..start + 10] {
        *v *= -0.5;
    }
    let fv5 = s.layout.viscous_col(4).unwrap();
    let kv = names.iter().position(|n| n == "fv5").unwrap();
    bad[fv5] = -3.0 * sigma(kv);
    let theta = s.base.base_values(&bad).unwrap();
    let c = project(&s.base, &theta, &s.cov, &s.prior, &Options::default()).unwrap();
    assert_consistent(&s, &c);
    // The truth is feasible, so the projection is at least as close as it.
    let to_truth = maha(&(DVector::from_vec(theta.clone()) - DVector::from_vec(s.theta.clone())));
    println!(
        "link 6 mass negative: Mahalanobis {:.3} (truth: {to_truth:.3}), largest change {:.3} sigma, {} iterations",
        c.mahalanobis, c.max_change_sigma, c.iterations
    );
    assert!(c.mahalanobis <= to_truth * (1.0 + 1e-6));
    // From this far start, the stall rule (cost down by less than 0.1 % over 10 iterations)
    // stops within 1 % of the distance that 5000 iterations without it reach (0.8 %).
    let long = project(
        &s.base,
        &theta,
        &s.cov,
        &s.prior,
        &Options {
            stall: 0.0,
            max_iterations: 5000,
            ..Options::default()
        },
    )
    .unwrap();
    println!(
        "stall rule: Mahalanobis {:.4} after {} iterations, {:.4} after {}",
        c.mahalanobis, c.iterations, long.mahalanobis, long.iterations
    );
    assert!(c.iterations < long.iterations);
    assert!(c.mahalanobis <= long.mahalanobis * 1.01);
}

/// Twin A (the built-in IRB 1200 and drives, default noise) runs four random excitations;
/// PMSM identification from their 10 Hz total power; consistent export (with a wrong prior);
/// twin B from the exported URDF and drive file; both run three held-out motions.
#[test]
fn twin_of_the_identified_robot_uses_the_energy_of_the_original() {
    use powertwin::identification::data::{Route, prepare};
    use powertwin::identification::model::PowerModel;
    use powertwin::identification::pmsm;
    use powertwin::identification::states::States;
    use powertwin::model::urdf::{LoadOptions, load_str};
    use powertwin::trajectory::Trajectory;
    use powertwin::trajectory::random::{
        RandomFourierOptions, RandomPointToPointOptions, random_fourier, random_point_to_point,
    };
    use powertwin::twin::TwinConfig;
    use powertwin::twin::sensor::SensorSettings;
    use powertwin::validation::rig::Rig;

    let s = setup();
    let robot = &s.robot;
    let drive_a = drive(robot);
    let twin_a = Rig {
        plant: None,
        robot,
        urdf: Urdf::inline(builtin::IRB1200_URDF),
        drive: &drive_a,
        twin: TwinConfig::default(),
        sensor: SensorSettings::default(),
    };
    let route = Route::Fourier {
        base_freq_hz: 0.1,
        harmonics: 5,
    };
    let opts = RandomFourierOptions {
        periods: 2.0,
        ..RandomFourierOptions::default()
    };
    let n = robot.dof();
    let mut states = States {
        t: Vec::new(),
        q: vec![Vec::new(); n],
        dq: vec![Vec::new(); n],
        ddq: vec![Vec::new(); n],
    };
    let mut power = Vec::new();
    for seed in 100..104 {
        let traj = random_fourier(robot, &mut common::rng(seed), &opts).unwrap();
        let ds = twin_a.run(&traj, &[], seed, serde_json::json!({})).unwrap();
        let mut p = prepare(&ds.log("twin A").unwrap(), route).unwrap();
        p.drop_slow_samples(0.05).unwrap();
        states.t.extend_from_slice(&p.states.t);
        for i in 0..n {
            states.q[i].extend_from_slice(&p.states.q[i]);
            states.dq[i].extend_from_slice(&p.states.dq[i]);
            states.ddq[i].extend_from_slice(&p.states.ddq[i]);
        }
        power.extend_from_slice(&p.p_total);
    }
    let mut model = PowerModel::new(robot, s.layout, false).unwrap();
    let est = pmsm::identify(robot, &mut model, &states, &power).unwrap();
    let twin = IdentifiedTwin::new(robot, &model, &est, &s.prior, &Options::default()).unwrap();
    let c = &twin.consistent;
    println!(
        "identified: residual RMS {:.3} W; consistent: Mahalanobis {:.3}, largest change {:.3} sigma, {} iterations, {} of {} from the prior",
        est.residual_rms,
        c.mahalanobis,
        c.max_change_sigma,
        c.iterations,
        c.from_prior.len(),
        c.names.len()
    );
    assert_consistent(&s, c);
    // Copper losses are projected with the rest (kept >= 0), so nothing needs clamping.
    assert!(twin.clamped.is_empty(), "{:?}", twin.clamped);
    let copper: Vec<f64> = twin.drive.joints().iter().map(|j| j.copper_loss).collect();
    println!(
        "copper W/(N m)^2: identified {:?}, consistent {copper:?}; standby {:.3} W",
        model.copper,
        twin.drive.joints()[0].standby_power
    );
    // The files say what is identified and what came from the prior.
    let (urdf_text, drive_text) = (twin.urdf(), twin.drive_toml());
    assert!(urdf_text.contains("from the prior: ") && urdf_text.contains("YY2"));
    assert!(drive_text.contains("# from the prior: Ia"), "{drive_text}");
    let robot_b = load_str(&urdf_text, &LoadOptions::default()).unwrap();
    let drive_b = Drive::from_toml_str(&drive_text, "exported", &robot_b).unwrap();
    assert_eq!(drive_b, twin.drive);
    // Loaded back: the same standard parameters.
    let phi_b = s.layout.theta(&robot_b, &DriveTerms::from(&drive_b));
    for (k, (a, b)) in phi_b.iter().zip(&c.phi).enumerate() {
        assert!(
            (a - b).abs() <= 1e-9 * b.abs().max(1e-3),
            "{}: {a} vs {b}",
            c.names[k]
        );
    }
    let twin_b = Rig {
        plant: None,
        robot: &robot_b,
        urdf: Urdf::inline(&urdf_text),
        drive: &drive_b,
        ..twin_a.clone()
    };
    // Held out: seeds no identification run used, other motion kinds.
    let held_out: Vec<Box<dyn Trajectory>> = vec![
        Box::new(
            random_fourier(
                robot,
                &mut common::rng(900),
                &RandomFourierOptions {
                    base_freq_hz: 0.15,
                    ..RandomFourierOptions::default()
                },
            )
            .unwrap(),
        ),
        Box::new(
            random_fourier(
                robot,
                &mut common::rng(901),
                &RandomFourierOptions::default(),
            )
            .unwrap(),
        ),
        Box::new(
            random_point_to_point(
                robot,
                &mut common::rng(902),
                &RandomPointToPointOptions::default(),
            )
            .unwrap(),
        ),
    ];
    let mut worst = 0.0_f64;
    for (k, traj) in held_out.iter().enumerate() {
        let run = |rig: &Rig| {
            rig.run(traj.as_ref(), &[], 50 + k as u64, serde_json::json!({}))
                .unwrap()
                .meta
                .summary
                .energy_total_j
        };
        let (ea, eb) = (run(&twin_a), run(&twin_b));
        let err = 100.0 * (eb - ea) / ea;
        println!(
            "held-out motion {k} ({:.1} s): twin A {ea:.2} J, twin B {eb:.2} J, {err:+.3} %",
            traj.duration()
        );
        worst = worst.max(err.abs());
    }
    println!("worst held-out energy difference {worst:.3} %");
    assert!(worst <= 2.0, "{worst} %");
}
