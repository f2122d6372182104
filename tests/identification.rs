//! Identification from power: signal processing and estimators against the twin's truth.

use crate::common;

use powertwin::identification::fourier_fit::fit_fourier;
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::random::{RandomFourierOptions, random_fourier};

#[test]
fn fourier_fit_recovers_the_series_from_10_hz_samples() {
    let robot = common::irb1200();
    let mut rng = common::rng(4);
    let truth = random_fourier(&robot, &mut rng, &RandomFourierOptions::default()).unwrap();
    let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
    let n = robot.dof();
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut samples = vec![Vec::new(); n];
    for &tk in &t {
        truth.sample(tk, &mut q, &mut dq, &mut ddq);
        for i in 0..n {
            samples[i].push(q[i]);
        }
    }
    let fit = fit_fourier(&t, &samples, 0.1, 5).unwrap();
    assert!(
        fit.rms_residual_rad.iter().all(|r| *r < 1e-12),
        "{:?}",
        fit.rms_residual_rad
    );
    let (mut q2, mut dq2, mut ddq2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..200 {
        let tk = k as f64 * 0.0497;
        truth.sample(tk, &mut q, &mut dq, &mut ddq);
        fit.series.sample(tk, &mut q2, &mut dq2, &mut ddq2);
        for i in 0..n {
            assert!(
                (q[i] - q2[i]).abs() < 1e-10
                    && (dq[i] - dq2[i]).abs() < 1e-9
                    && (ddq[i] - ddq2[i]).abs() < 1e-8
            );
        }
    }
    // Noise of 1e-4 rad leaves a residual of that size and a smooth fit.
    let mut noisy = samples.clone();
    for (i, col) in noisy.iter_mut().enumerate() {
        for (k, v) in col.iter_mut().enumerate() {
            *v += 1e-4 * ((k * 7 + i * 3) as f64).sin();
        }
    }
    let fit = fit_fourier(&t, &noisy, 0.1, 5).unwrap();
    assert!(
        fit.rms_residual_rad.iter().all(|r| *r < 1e-4 && *r > 1e-5),
        "{:?}",
        fit.rms_residual_rad
    );
    // Too few samples or a degenerate time base are errors.
    assert!(fit_fourier(&t[..5], &[samples[0][..5].to_vec()], 0.1, 5).is_err());
    let same_t = vec![1.0; 20];
    assert!(fit_fourier(&same_t, &[vec![0.0; 20]], 0.1, 5).is_err());
}

#[test]
fn least_squares_statistics_and_rank_errors() {
    use nalgebra::{DMatrix, DVector};
    use powertwin::identification::lsq::solve;
    let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
    // y = 2 x0 - 3 x1 + 0.5 x2 exactly, with very different column scales.
    let a = DMatrix::from_fn(50, 3, |r, c| {
        let t = r as f64 * 0.1;
        [t.sin(), 1000.0 * (2.0 * t).cos(), 1e-3 * t][c]
    });
    let y = &a * DVector::from_vec(vec![2.0, -3.0, 0.5]);
    let e = solve(&a, &y, &names).unwrap();
    for (v, t) in e.values.iter().zip([2.0, -3.0, 0.5]) {
        assert!((v - t).abs() < 1e-7 * t.abs(), "{v} vs {t}");
    }
    assert!(e.residual_rms < 1e-9 && e.cond < 100.0);
    // Noise gives standard deviations that cover the error.
    let noisy = &y + DVector::from_fn(50, |r, _| 0.01 * ((r * 13) as f64).sin());
    let e = solve(&a, &noisy, &names).unwrap();
    for k in 0..3 {
        assert!(
            (e.values[k] - [2.0, -3.0, 0.5][k]).abs() < 5.0 * e.std[k],
            "{e:?}"
        );
        assert!(e.rel_std[k] > 0.0 && e.rel_std[k].is_finite());
    }
    // A column that duplicates another is named.
    let mut dup = a.clone();
    let c0 = dup.column(0).clone_owned();
    dup.column_mut(2).copy_from(&(c0 * 3.0));
    let err = solve(&dup, &y, &names).unwrap_err().to_string();
    assert!(
        err.contains("rank-deficient")
            && (err.contains("cannot identify a") || err.contains("cannot identify c")),
        "{err}"
    );
    let mut zero = a.clone();
    zero.column_mut(1).fill(0.0);
    let err = solve(&zero, &y, &names).unwrap_err().to_string();
    assert!(err.contains("b (not excited at all)"), "{err}");
    let mut nan = a.clone();
    nan[(3, 1)] = f64::NAN;
    assert!(
        solve(&nan, &y, &names)
            .unwrap_err()
            .to_string()
            .contains("NaN")
    );
}

#[test]
fn smoothing_route_differentiates_10_hz_samples() {
    use powertwin::identification::states::from_smoothing;
    // q = sin(w t) with w = 2 pi 0.3 Hz, sampled at 10 Hz.
    let w = std::f64::consts::TAU * 0.3;
    let t: Vec<f64> = (0..80).map(|k| k as f64 * 0.1).collect();
    let q = vec![t.iter().map(|x| (w * x).sin()).collect::<Vec<_>>()];
    let s = from_smoothing(&t, &q, 9, 4).unwrap();
    for (k, &x) in t.iter().enumerate() {
        let edge = !(4..76).contains(&k);
        let tol = if edge { 5e-3 } else { 1e-3 };
        assert!((s.q[0][k] - (w * x).sin()).abs() < tol * 0.1);
        assert!(
            (s.dq[0][k] - w * (w * x).cos()).abs() < tol * w,
            "dq at {x}"
        );
        assert!(
            (s.ddq[0][k] + w * w * (w * x).sin()).abs() < 10.0 * tol * w * w,
            "ddq at {x}"
        );
    }
    assert!(from_smoothing(&t, &q, 8, 4).is_err());
    assert!(from_smoothing(&t[..5], &[q[0][..5].to_vec()], 9, 4).is_err());
}

mod excitation {
    use super::common;
    use powertwin::identification::excitation::{ExcitationOptions, design};
    use powertwin::trajectory::Trajectory;
    use powertwin::trajectory::limits::{IRB1200_ACCEL_LIMITS, check_limits};

    fn options(joints: Vec<usize>) -> ExcitationOptions {
        let robot = common::irb1200();
        let mut o = ExcitationOptions::new(
            &robot,
            joints,
            vec![0.0, 0.2, 0.2, 0.0, 0.8, 0.0],
            IRB1200_ACCEL_LIMITS.to_vec(),
        );
        o.max_evals = 600;
        o.starts = 1;
        o
    }

    #[test]
    fn wrist_excitation_is_well_conditioned_and_within_limits() {
        let robot = common::irb1200();
        let ex = design(&robot, &options(vec![3, 4, 5])).unwrap();
        assert!(
            ex.cond_final < ex.cond_initial / 10.0,
            "{} -> {}",
            ex.cond_initial,
            ex.cond_final
        );
        assert!(ex.cond_final < 1e3, "{}", ex.cond_final);
        // Links 1-3 cannot be seen by moving the wrist only.
        assert!(
            ex.parameters
                .iter()
                .all(|p| p.ends_with('4') || p.ends_with('5') || p.ends_with('6')),
            "{:?}",
            ex.parameters
        );
        check_limits(&robot, &ex.trajectory, 1e-3, Some(&IRB1200_ACCEL_LIMITS)).unwrap();
        // Rest at start and end; the joints that are not excited stay at the rest pose.
        let (mut q, mut dq, mut ddq) = ([0.0; 6], [0.0; 6], [0.0; 6]);
        for t in [0.0, ex.trajectory.duration()] {
            ex.trajectory.sample(t, &mut q, &mut dq, &mut ddq);
            assert!(dq.iter().chain(&ddq).all(|v| v.abs() < 1e-9));
        }
        assert_eq!(&q[..3], &[0.0, 0.2, 0.2]);
        // Same seed, same design.
        let again = design(&robot, &options(vec![3, 4, 5])).unwrap();
        assert_eq!(again.trajectory, ex.trajectory);
    }

    #[test]
    fn bad_excitation_settings_are_errors() {
        let robot = common::irb1200();
        let mut o = options(vec![7]);
        assert!(design(&robot, &o).is_err());
        o = options(vec![1]);
        o.rest_pose[1] = 3.0;
        assert!(
            design(&robot, &o)
                .unwrap_err()
                .to_string()
                .contains("joint_2")
        );
        o = options(vec![1]);
        o.harmonics = 1;
        assert!(design(&robot, &o).is_err());
    }
}

#[test]
fn window_energy_estimator_recovers_a_known_model_exactly() {
    use powertwin::dynamics::ParamLayout;
    use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
    use powertwin::identification::{energy, model::PowerModel};
    let robot = common::irb1200();
    let d = common::drive_terms(6);
    let layout = ParamLayout::new(&robot, true, true);
    let mut truth = PowerModel::new(&robot, layout, false).unwrap();
    let bp = BaseParams::compute(&robot, layout, &SamplingOptions::default()).unwrap();
    truth.theta = bp.base_values(&layout.theta(&robot, &d)).unwrap();
    truth.constant[0] = 42.0;
    let mut rng = common::rng(6);
    let opts = RandomFourierOptions {
        periods: 4.0,
        ..RandomFourierOptions::default()
    };
    let traj = random_fourier(&robot, &mut rng, &opts).unwrap();
    let t: Vec<f64> = (0..=400).map(|k| k as f64 * 0.1).collect();
    // Window energies by fine integration of the model's power.
    let e: Vec<f64> = t
        .windows(2)
        .map(|w| {
            struct Window<'a>(&'a dyn Trajectory, f64, f64);
            impl Trajectory for Window<'_> {
                fn dof(&self) -> usize {
                    6
                }
                fn duration(&self) -> f64 {
                    self.2 - self.1
                }
                fn sample(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
                    self.0.sample(self.1 + t, q, dq, ddq)
                }
            }
            truth
                .energy(&robot, &Window(&traj, w[0], w[1]), 1e-4)
                .unwrap()
        })
        .collect();
    let mut est_model = PowerModel::new(&robot, layout, false).unwrap();
    let est = energy::identify(
        &robot,
        &mut est_model,
        &[energy::Windows {
            motion: &traj,
            t: &t,
            energy: &e,
        }],
    )
    .unwrap();
    // Limited by Simpson on |dq| at velocity reversals and the trapezoidal reference.
    assert!(est.residual_rms < 1e-4, "{}", est.residual_rms);
    for (k, (a, b)) in est_model.theta.iter().zip(&truth.theta).enumerate() {
        assert!(
            (a - b).abs() < 1e-4 * (1.0 + b.abs()),
            "{}: {a} vs {b}, cond {}, rel std {}",
            est_model.names[k],
            est.cond,
            est.rel_std[k]
        );
    }
    assert!((est_model.constant[0] - 42.0).abs() < 1e-4);
    assert!(
        energy::identify(
            &robot,
            &mut est_model,
            &[energy::Windows {
                motion: &traj,
                t: &t,
                energy: &e[1..]
            }]
        )
        .is_err()
    );
}

#[test]
fn slow_samples_are_dropped_from_states_and_powers_alike() {
    use powertwin::identification::data::Prepared;
    use powertwin::identification::states::from_fourier;
    let robot = common::irb1200();
    let traj = random_fourier(
        &robot,
        &mut common::rng(11),
        &RandomFourierOptions::default(),
    )
    .unwrap();
    let t: Vec<f64> = (0..101).map(|k| k as f64 * 0.1).collect();
    let states = from_fourier(&traj, &t);
    let n = robot.dof();
    let p_total: Vec<f64> = (0..t.len()).map(|m| m as f64).collect();
    let p_joint: Vec<f64> = (0..t.len() * n).map(|k| k as f64).collect();
    // An averaging meter's nodes: PERIOD_NODES per sample across the period before it.
    let k = powertwin::identification::data::PERIOD_NODES;
    let t_nodes: Vec<f64> = t
        .iter()
        .flat_map(|&tm| (0..k).map(move |j| tm - 0.1 + (j as f64 + 0.5) / k as f64 * 0.1))
        .collect();
    let nodes = from_fourier(&traj, &t_nodes);
    let mut p = Prepared {
        period_nodes: Some(nodes),
        states: states.clone(),
        motion: Box::new(traj),
        motion_t0_s: 0.0,
        p_total,
        signal: powertwin::measurement::PowerSignal::Total,
        p_joint,
        payloads: Vec::new(),
        excited: vec![1, 4],
        power_averaged: false,
    };
    let min = 0.05;
    let dropped = p.drop_slow_samples(min).unwrap();
    // Rest-to-rest: at least the first and last samples go.
    assert!(dropped >= 2 && dropped < t.len() / 2, "{dropped}");
    assert_eq!(p.states.len(), t.len() - dropped);
    assert_eq!(p.p_total.len(), p.states.len());
    assert_eq!(p.p_joint.len(), p.states.len() * n);
    for (j, &tj) in p.states.t.iter().enumerate() {
        let m = t.iter().position(|&x| x == tj).unwrap();
        assert_eq!(p.p_total[j], m as f64);
        assert_eq!(p.p_joint[j * n + 3], (m * n + 3) as f64);
        assert_eq!(p.states.dq[4][j], states.dq[4][m]);
        assert!(p.states.dq[1][j].abs() >= min && p.states.dq[4][j].abs() >= min);
        // The kept sample's nodes went with it.
        let nodes = p.period_nodes.as_ref().unwrap();
        assert!((nodes.t[j * k + k - 1] - (tj - 0.05 / k as f64)).abs() < 1e-12);
    }
    assert_eq!(p.period_nodes.as_ref().unwrap().len(), p.states.len() * k);
    assert_eq!(p.drop_slow_samples(0.0).unwrap(), 0);
    assert!(p.drop_slow_samples(-1.0).is_err());
    assert!(p.drop_slow_samples(f64::NAN).is_err());
    let err = p.drop_slow_samples(1e6).unwrap_err();
    assert!(err.to_string().contains("no sample"), "{err}");
}

/// A PMSM model of the IRB 1200 with the test drives' true base parameters, copper
/// coefficients of 0.01 W/(N m)^2 and no standby.
fn true_pmsm_model(robot: &powertwin::Robot) -> powertwin::identification::model::PowerModel {
    use powertwin::dynamics::ParamLayout;
    use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
    use powertwin::identification::model::PowerModel;
    let layout = ParamLayout::new(robot, true, true);
    let mut model = PowerModel::new(robot, layout, false).unwrap();
    let bp = BaseParams::compute(robot, layout, &SamplingOptions::default()).unwrap();
    model.theta = bp
        .base_values(&layout.theta(robot, &common::drive_terms(6)))
        .unwrap();
    model.copper = vec![0.01; 6];
    model
}

#[test]
fn per_motor_predicted_power_sums_to_the_total_with_payloads() {
    use powertwin::model::builtin;
    use powertwin::model::payload::PayloadEvent;
    let robot = common::irb1200();
    let mut model = true_pmsm_model(&robot);
    model.constant[0] = 42.0;
    let traj = random_fourier(
        &robot,
        &mut common::rng(3),
        &RandomFourierOptions::default(),
    )
    .unwrap();
    let events = [PayloadEvent {
        t_s: 1.0,
        payload: Some(builtin::payload("load_2kg").unwrap()),
    }];
    let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.04).collect();
    let total = model
        .power_with_payloads(&robot, &traj, &events, 0.9, &t)
        .unwrap();
    let joints = model
        .joint_powers_with_payloads(&robot, &traj, &events, 0.9, &t)
        .unwrap();
    assert_eq!(joints.len(), 6);
    for (k, p) in total.iter().enumerate() {
        // The same terms added in the same order: the same bits.
        let sum = joints.iter().fold(0.0, |s, j| s + j[k]);
        assert_eq!(sum.to_bits(), p.to_bits(), "sample {k}");
    }
    // The constant power sits on joint 1; the payload from 1 s on changes the prediction.
    let still = model
        .joint_powers_with_payloads(&robot, &traj, &[], 0.9, &t)
        .unwrap();
    assert_eq!(still[0].len(), t.len());
    assert!((0..25).all(|k| (0..6).all(|i| still[i][k] == joints[i][k])));
    assert!((25..50).any(|k| (1..6).any(|i| still[i][k] != joints[i][k])));
}

/// A robot holds the payload it starts a motion with before the motion too: the power the
/// power lag and an averaging meter's first period read before time 0 is the loaded arm's,
/// while a payload picked up later leaves the arm bare before it.
#[test]
fn a_payload_the_motion_starts_with_is_held_before_it() {
    use powertwin::model::builtin;
    use powertwin::model::payload::PayloadEvent;
    use powertwin::trajectory::Trajectory;
    /// The arm standing still at one pose.
    struct Still;
    impl Trajectory for Still {
        fn dof(&self) -> usize {
            6
        }
        fn duration(&self) -> f64 {
            2.0
        }
        fn sample(&self, _t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
            q.copy_from_slice(&[0.1, 0.5, -0.4, 0.3, 0.8, 0.2]);
            dq.fill(0.0);
            ddq.fill(0.0);
        }
    }
    let robot = common::irb1200();
    let model = true_pmsm_model(&robot);
    let load = builtin::payload("load_2kg").unwrap();
    let power = |from_s: f64, t: f64| {
        let events = [PayloadEvent {
            t_s: from_s,
            payload: Some(load.clone()),
        }];
        model
            .power_with_payloads(&robot, &Still, &events, 1.0, &[t])
            .unwrap()[0]
    };
    let bare = model
        .power_with_payloads(&robot, &Still, &[], 1.0, &[-0.05])
        .unwrap()[0];
    let loaded = power(0.0, 0.05);
    assert!(loaded - bare > 1.0, "{loaded} {bare}");
    assert_eq!(power(0.0, -0.05), loaded);
    assert_eq!(power(1.0, 0.5), bare);
}

/// A motion unsure of a joint's Coulomb sign (`coulomb_signs` weighed down to `s`) gets the
/// expected power of a sign that is +1 with chance `(1 + s) / 2`: the mean of the powers
/// with either sign, for the model evaluated at the same state.
#[test]
fn an_unsure_coulomb_sign_gets_the_expected_power() {
    use powertwin::trajectory::Trajectory;
    /// A constant state whose Coulomb signs are `signs` (for speeds of either sign).
    struct Fixed {
        q: Vec<f64>,
        dq: Vec<f64>,
        signs: Option<Vec<f64>>,
    }
    impl Trajectory for Fixed {
        fn dof(&self) -> usize {
            6
        }
        fn duration(&self) -> f64 {
            1.0
        }
        fn sample(&self, _t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
            q.copy_from_slice(&self.q);
            dq.copy_from_slice(&self.dq);
            ddq.fill(0.0);
        }
        fn coulomb_signs(&self, _t: f64, dq: &[f64], s: &mut [f64]) {
            match &self.signs {
                Some(signs) => s.copy_from_slice(signs),
                None => {
                    for (si, v) in s.iter_mut().zip(dq) {
                        *si = v.signum();
                    }
                }
            }
        }
    }
    let robot = common::irb1200();
    let model = true_pmsm_model(&robot);
    let q = vec![0.1, 0.5, -0.4, 0.3, 0.8, 0.2];
    let slow = vec![0.3, 2e-4, -0.2, 0.4, -0.5, 0.6];
    let power = |dq2: f64, signs: Option<Vec<f64>>| {
        let mut dq = slow.clone();
        dq[1] = dq2;
        let traj = Fixed {
            q: q.clone(),
            dq,
            signs,
        };
        model
            .power_with_payloads(&robot, &traj, &[], 1.0, &[0.5])
            .unwrap()[0]
    };
    let mut signs: Vec<f64> = slow.iter().map(|v: &f64| v.signum()).collect();
    // The shoulder's sign as given, and its sign flipped at the same speed (the regressor's
    // other columns hardly see 2e-4 rad/s).
    let plus = power(2e-4, None);
    signs[1] = -1.0;
    let minus = power(2e-4, Some(signs.clone()));
    assert!((plus - minus).abs() > 1.0, "{plus} {minus}");
    for s in [-0.6, 0.0, 0.25, 1.0] {
        signs[1] = s;
        let expected = 0.5 * (1.0 + s) * plus + 0.5 * (1.0 - s) * minus;
        let got = power(2e-4, Some(signs.clone()));
        assert!(
            (got - expected).abs() < 1e-9,
            "s = {s}: {got} W, expected {expected} W"
        );
    }
}

/// The PMSM fit with a copper coefficient the data push below its bound of 0 (joint 4's
/// drawn at -0.2 W/(N m)^2) converges to the bounded least-squares optimum: the coefficient
/// sits on the bound, raising it raises the cost, and no fitted parameter lowers the cost to
/// first order (the Newton decrement along each is below 1e-7 of the cost). Coefficients the
/// data cannot tell from zero are held there by the fit and not checked. A projected full
/// Gauss-Newton step crawled here, stopped by the iteration limit.
#[test]
fn pmsm_fit_converges_with_a_copper_coefficient_on_its_bound() {
    use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
    use powertwin::dynamics::{ParamLayout, Workspace};
    use powertwin::identification::model::PowerModel;
    use powertwin::identification::pmsm;
    let robot = common::irb1200();
    let n = robot.dof();
    let layout = ParamLayout::new(&robot, true, true);
    let template = PowerModel::new(&robot, layout, false).unwrap();
    let bp = BaseParams::compute(&robot, layout, &SamplingOptions::default()).unwrap();
    let mut truth = template.clone();
    truth.theta = bp
        .base_values(&layout.theta(&robot, &common::drive_terms(n)))
        .unwrap();
    truth.copper = vec![0.005, 0.002, 0.005, -0.2, 0.2, 1.0];
    truth.constant[0] = 20.0;
    let count = 800;
    let (states, power) = common::model_power_samples(&robot, &truth, count, (7, 8), |_| 0.5);
    let (mut ws, mut w) = (
        Workspace::new(&robot),
        nalgebra::DMatrix::zeros(n, layout.len()),
    );
    let mut model = template.clone();
    pmsm::identify(&robot, &mut model, &states, &power).unwrap();
    println!("copper {:?}", model.copper);
    assert_eq!(model.copper[3], 0.0, "copper {:?}", model.copper);

    // Cost of the parameters z = [theta, copper, P0] over the samples.
    let nb = model.theta.len();
    let mut cost = |z: &[f64]| -> f64 {
        let mut m = model.clone();
        m.theta.copy_from_slice(&z[..nb]);
        m.copper.copy_from_slice(&z[nb..nb + n]);
        m.constant.fill(0.0);
        m.constant[0] = z[nb + n];
        (0..count)
            .map(|k| {
                let at = |v: &Vec<Vec<f64>>| (0..n).map(|i| v[i][k]).collect::<Vec<_>>();
                let p = m.power(
                    &robot,
                    &mut ws,
                    &mut w,
                    &at(&states.q),
                    &at(&states.dq),
                    &at(&states.ddq),
                );
                (p - power[k]).powi(2)
            })
            .sum()
    };
    let z: Vec<f64> = model
        .theta
        .iter()
        .chain(&model.copper)
        .chain([&model.constant.iter().sum::<f64>()])
        .cloned()
        .collect();
    let c0 = cost(&z);
    for k in 0..z.len() {
        let h = 1e-4 * z[k].abs().max(1e-3);
        let mut at = |d: f64| {
            let mut y = z.clone();
            y[k] += d;
            cost(&y)
        };
        let (up, down) = (at(h), at(-h));
        if k == nb + 3 {
            assert!(
                up > c0,
                "raising the bound copper coefficient lowers the cost"
            );
            continue;
        }
        if (nb..nb + n).contains(&k) && z[k] == 0.0 {
            continue;
        }
        let g = (up - down) / (2.0 * h);
        let curvature = (up + down - 2.0 * c0) / (h * h);
        assert!(curvature > 0.0, "parameter {k}: curvature {curvature}");
        let decrement = g * g / curvature;
        assert!(
            decrement < 1e-7 * c0,
            "parameter {k}: a step along it lowers the cost by {decrement} of {c0}"
        );
    }
}
