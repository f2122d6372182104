//! Inverse dynamics, regressor and mass matrix: checked against each other and against an
//! independent Lagrangian route (CRBA mass matrix, Christoffel symbols and the gradient of
//! the potential energy by finite differences).

use crate::common;

use nalgebra::{DMatrix, DVector};
use powertwin::dynamics::crba::{forward_dynamics, kinetic_energy, mass_matrix, potential_energy};
use powertwin::dynamics::regressor::{regressor, to_power_rows, total_power_row};
use powertwin::dynamics::rnea::{rnea, rnea_checked};
use powertwin::dynamics::{DriveTerms, GRAVITY, ParamLayout, Workspace};

#[test]
fn regressor_times_theta_equals_rnea() {
    let robot = common::irb1200();
    let n = robot.dof();
    let d = common::drive_terms(n);
    let mut ws = Workspace::new(&robot);
    let mut rng = common::rng(1);
    for (friction, armature) in [(false, false), (true, false), (true, true)] {
        let layout = ParamLayout::new(&robot, friction, armature);
        let theta = DVector::from_vec(layout.theta(&robot, &d));
        let mut w = DMatrix::zeros(n, layout.len());
        for _ in 0..500 {
            let (q, dq, ddq) = common::random_state(&robot, &mut rng);
            let terms = DriveTerms {
                rotor_inertia: if armature {
                    d.rotor_inertia.clone()
                } else {
                    vec![0.0; n]
                },
                viscous: if friction {
                    d.viscous.clone()
                } else {
                    vec![0.0; n]
                },
                coulomb: if friction {
                    d.coulomb.clone()
                } else {
                    vec![0.0; n]
                },
            };
            let tau = rnea_checked(&robot, &mut ws, &q, &dq, &ddq, Some(&terms)).unwrap();
            regressor(&robot, &mut ws, &layout, &q, &dq, &ddq, &mut w);
            let wt = &w * &theta;
            for i in 0..n {
                assert!(
                    (wt[i] - tau[i]).abs() < 1e-10,
                    "joint {i}: W theta {} vs RNEA {}",
                    wt[i],
                    tau[i]
                );
            }
            // Power rows (eq. 11) and the total-power row.
            let mut wp = w.clone();
            to_power_rows(&mut wp, &dq);
            let p = &wp * &theta;
            let mut row = vec![0.0; layout.len()];
            total_power_row(&w, &dq, &mut row);
            let total: f64 = row.iter().zip(theta.iter()).map(|(a, b)| a * b).sum();
            let expect: f64 = tau.iter().zip(&dq).map(|(t, v)| t * v).sum();
            assert!((total - expect).abs() < 1e-9 * (1.0 + expect.abs()));
            for i in 0..n {
                assert!((p[i] - tau[i] * dq[i]).abs() < 1e-9);
            }
        }
    }
}

/// `dM/dq_k` by central differences.
fn dm_dq(robot: &powertwin::Robot, q: &[f64], k: usize) -> DMatrix<f64> {
    let h = 1e-6;
    let mut qp = q.to_vec();
    let mut qm = q.to_vec();
    qp[k] += h;
    qm[k] -= h;
    (mass_matrix(robot, &qp, None) - mass_matrix(robot, &qm, None)) / (2.0 * h)
}

#[test]
fn rnea_matches_lagrangian_route() {
    let robot = common::irb1200();
    let n = robot.dof();
    let mut ws = Workspace::new(&robot);
    let mut rng = common::rng(2);
    for _ in 0..50 {
        let (q, dq, ddq) = common::random_state(&robot, &mut rng);
        let m = mass_matrix(&robot, &q, None);
        let dms: Vec<DMatrix<f64>> = (0..n).map(|k| dm_dq(&robot, &q, k)).collect();
        let h = 1e-6;
        for k in 0..n {
            // Christoffel form of C(q, dq) dq.
            let mut c = 0.0;
            for i in 0..n {
                for j in 0..n {
                    c += (dms[i][(k, j)] - 0.5 * dms[k][(i, j)]) * dq[i] * dq[j];
                }
            }
            let mut qp = q.clone();
            let mut qm = q.clone();
            qp[k] += h;
            qm[k] -= h;
            let g = (potential_energy(&robot, &qp, &GRAVITY)
                - potential_energy(&robot, &qm, &GRAVITY))
                / (2.0 * h);
            let mddq: f64 = (0..n).map(|j| m[(k, j)] * ddq[j]).sum();
            let lagrange = mddq + c + g;
            let tau = rnea_checked(&robot, &mut ws, &q, &dq, &ddq, None).unwrap();
            assert!(
                (lagrange - tau[k]).abs() < 1e-6 * (1.0 + tau[k].abs()),
                "joint {k}: Lagrange {lagrange} vs RNEA {}",
                tau[k]
            );
        }
    }
}

#[test]
fn mass_matrix_is_the_rnea_inertia_part_and_forward_dynamics_inverts_rnea() {
    let robot = common::irb1200();
    let n = robot.dof();
    let d = common::drive_terms(n);
    let mut ws = Workspace::new(&robot);
    let mut rng = common::rng(3);
    let zero = vec![0.0; n];
    for _ in 0..100 {
        let (q, dq, ddq) = common::random_state(&robot, &mut rng);
        let m = mass_matrix(&robot, &q, Some(&d.rotor_inertia));
        let no_friction = DriveTerms {
            viscous: zero.clone(),
            coulomb: zero.clone(),
            ..d.clone()
        };
        let mut bias = vec![0.0; n];
        rnea(
            &robot,
            &mut ws,
            &q,
            &zero,
            &zero,
            Some(&no_friction),
            &mut bias,
        );
        for j in 0..n {
            let mut e = zero.clone();
            e[j] = 1.0;
            let mut col = vec![0.0; n];
            rnea(&robot, &mut ws, &q, &zero, &e, Some(&no_friction), &mut col);
            for i in 0..n {
                assert!((col[i] - bias[i] - m[(i, j)]).abs() < 1e-12);
            }
        }
        let tau = rnea_checked(&robot, &mut ws, &q, &dq, &ddq, Some(&d)).unwrap();
        let back = forward_dynamics(&robot, &mut ws, &q, &dq, &tau, Some(&d)).unwrap();
        for i in 0..n {
            assert!(
                (back[i] - ddq[i]).abs() < 1e-9,
                "joint {i}: {} vs {}",
                back[i],
                ddq[i]
            );
        }
    }
}

#[test]
fn power_balance_equals_energy_rate() {
    // d/dt (KE + PE) = tau . dq without friction, along q(t) = q0 + a sin(t), by central
    // differences in time.
    let robot = common::irb1200();
    let n = robot.dof();
    let mut ws = Workspace::new(&robot);
    let ia = common::drive_terms(n).rotor_inertia;
    let terms = DriveTerms {
        rotor_inertia: ia.clone(),
        ..DriveTerms::zero(n)
    };
    let traj = |t: f64| {
        let q: Vec<f64> = (0..n)
            .map(|i| 0.2 * i as f64 + 0.5 * (t * (1.0 + 0.3 * i as f64)).sin())
            .collect();
        let dq: Vec<f64> = (0..n)
            .map(|i| 0.5 * (1.0 + 0.3 * i as f64) * (t * (1.0 + 0.3 * i as f64)).cos())
            .collect();
        let ddq: Vec<f64> = (0..n)
            .map(|i| -0.5 * (1.0 + 0.3 * i as f64).powi(2) * (t * (1.0 + 0.3 * i as f64)).sin())
            .collect();
        (q, dq, ddq)
    };
    let energy = |t: f64| {
        let (q, dq, _) = traj(t);
        kinetic_energy(&robot, &q, &dq, Some(&ia)) + potential_energy(&robot, &q, &GRAVITY)
    };
    for k in 0..20 {
        let t = 0.37 * k as f64;
        let (q, dq, ddq) = traj(t);
        let tau = rnea_checked(&robot, &mut ws, &q, &dq, &ddq, Some(&terms)).unwrap();
        let power: f64 = tau.iter().zip(&dq).map(|(a, b)| a * b).sum();
        let h = 1e-5;
        let rate = (energy(t + h) - energy(t - h)) / (2.0 * h);
        assert!(
            (power - rate).abs() < 1e-6 * (1.0 + power.abs()),
            "t {t}: {power} W vs {rate} W"
        );
    }
}

#[test]
fn bad_state_lengths_and_nan_are_errors() {
    let robot = common::irb1200();
    let mut ws = Workspace::new(&robot);
    let e = rnea_checked(&robot, &mut ws, &[0.0; 5], &[0.0; 6], &[0.0; 6], None).unwrap_err();
    assert!(e.to_string().contains("q has 5 values"), "{e}");
    let e = rnea_checked(
        &robot,
        &mut ws,
        &[0.0; 6],
        &[0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0],
        &[0.0; 6],
        None,
    )
    .unwrap_err();
    assert!(e.to_string().contains("dq[2]"), "{e}");
}

mod properties {
    use super::*;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
    use powertwin::model::RigidInertia;
    use proptest::prelude::*;

    /// A physically valid body: mass, COM, principal moments obeying the triangle
    /// inequality, and a rotation of the principal axes.
    fn body() -> impl Strategy<Value = RigidInertia> {
        (
            0.1f64..20.0,
            prop::array::uniform3(-0.3f64..0.3),
            prop::array::uniform2(0.001f64..0.5),
            0.05f64..0.95,
            prop::array::uniform3(-3.0f64..3.0),
        )
            .prop_map(|(m, c, [a, b], t, rpy)| {
                // Third moment between |a - b| and a + b (triangle inequality).
                let cz = (a - b).abs() + t * (a + b - (a - b).abs());
                let principal = RigidInertia::new(m, Vector3::zeros(), [a, b, cz, 0.0, 0.0, 0.0]);
                principal.transformed(&Isometry3::from_parts(
                    Translation3::new(c[0], c[1], c[2]),
                    UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
                ))
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn regressor_is_exact_for_any_valid_inertias(
            bodies in prop::collection::vec(body(), 6),
            state in prop::array::uniform18(-2.0f64..2.0),
        ) {
            let mut robot = common::irb1200();
            for (i, b) in bodies.iter().enumerate() {
                prop_assume!(b.validate("b").is_ok());
                robot = robot.with_link_inertia(i, *b).unwrap();
            }
            let (q, rest) = state.split_at(6);
            let (dq, ddq) = rest.split_at(6);
            let layout = ParamLayout::new(&robot, false, false);
            let theta = DVector::from_vec(layout.theta(&robot, &DriveTerms::zero(6)));
            let mut ws = Workspace::new(&robot);
            let tau = rnea_checked(&robot, &mut ws, q, dq, ddq, None).unwrap();
            let mut w = DMatrix::zeros(6, layout.len());
            regressor(&robot, &mut ws, &layout, q, dq, ddq, &mut w);
            let wt = &w * &theta;
            for i in 0..6 {
                prop_assert!((wt[i] - tau[i]).abs() < 1e-10 * (1.0 + tau[i].abs()));
            }
        }
    }
}

#[test]
fn energy_regressor_gives_kinetic_plus_potential_energy() {
    use powertwin::dynamics::energy_regressor::energy_regressor;
    let robot = common::irb1200();
    let n = robot.dof();
    let d = common::drive_terms(n);
    let layout = ParamLayout::new(&robot, true, true);
    let theta = layout.theta(&robot, &d);
    let mut h = vec![0.0; layout.len()];
    let mut rng = common::rng(8);
    for _ in 0..200 {
        let (q, dq, _) = common::random_state(&robot, &mut rng);
        energy_regressor(&robot, &layout, &GRAVITY, &q, &dq, &mut h);
        let e: f64 = h.iter().zip(&theta).map(|(a, b)| a * b).sum();
        let expect = kinetic_energy(&robot, &q, &dq, Some(&d.rotor_inertia))
            + potential_energy(&robot, &q, &GRAVITY);
        assert!(
            (e - expect).abs() < 1e-10 * (1.0 + expect.abs()),
            "{e} vs {expect}"
        );
    }
}
