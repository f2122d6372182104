//! Trajectories: Fourier series, point-to-point motions, random generators and the limit
//! check, against their definitions and finite differences (interpolated samples:
//! `sampled.rs`).

use crate::common;

use std::f64::consts::PI;

use powertwin::Error;
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::fourier::Fourier;
use powertwin::trajectory::limits::{IRB1200_ACCEL_LIMITS, check_limits};
use powertwin::trajectory::point_to_point::{PointToPoint, PointToPointOptions};
use powertwin::trajectory::random::{
    RandomFourierOptions, RandomPointToPointOptions, random_fourier, random_point_to_point,
};
use proptest::prelude::*;

/// Position, velocity and acceleration at `t`.
pub(crate) fn at(traj: &dyn Trajectory, t: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = traj.dof();
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    traj.sample(t, &mut q, &mut dq, &mut ddq);
    (q, dq, ddq)
}

/// Largest deviation of `dq` from the central difference of `q` and of `ddq` from that of
/// `dq` at `t` (step `h`), relative to `scale_v` and `scale_a`.
pub(crate) fn fd_error(traj: &dyn Trajectory, t: f64, h: f64) -> (f64, f64) {
    let (_, dq, ddq) = at(traj, t);
    let (qp, dqp, _) = at(traj, t + h);
    let (qm, dqm, _) = at(traj, t - h);
    let mut ev: f64 = 0.0;
    let mut ea: f64 = 0.0;
    for i in 0..traj.dof() {
        ev = ev.max(((qp[i] - qm[i]) / (2.0 * h) - dq[i]).abs());
        ea = ea.max(((dqp[i] - dqm[i]) / (2.0 * h) - ddq[i]).abs());
    }
    (ev, ea)
}

/// Largest absolute difference of two series.
pub(crate) fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn example_fourier() -> Fourier {
    Fourier::new(
        0.2,
        vec![0.1, -0.4],
        vec![vec![0.3, -0.1, 0.05], vec![0.0, 0.2, -0.02]],
        vec![vec![-0.2, 0.1, 0.01], vec![0.4, 0.0, 0.03]],
        2.0,
    )
    .unwrap()
}

#[test]
fn fourier_matches_its_definition_and_finite_differences() {
    let f = example_fourier();
    assert_eq!(f.duration(), 10.0);
    assert_eq!(f.dof(), 2);
    assert_eq!(f.harmonics(), 3);
    let w = 2.0 * PI * 0.2;
    for k in 0..=100 {
        let t = 0.1 * k as f64;
        let (q, _, _) = at(&f, t);
        for (i, qi) in q.iter().enumerate() {
            let mut expected = f.q0()[i];
            for j in 0..3 {
                let x = (j + 1) as f64 * w * t;
                expected += f.a()[i][j] * x.sin() + f.b()[i][j] * x.cos();
            }
            assert!((qi - expected).abs() < 1e-14);
        }
        if k > 0 && k < 100 {
            let (ev, ea) = fd_error(&f, t, 1e-5);
            assert!(ev < 1e-8 && ea < 1e-7, "t = {t}: {ev} {ea}");
        }
    }
    assert_eq!(at(&f, 1e6), at(&f, 10.0));
}

#[test]
fn fourier_vector_round_trip() {
    let f = example_fourier();
    assert_eq!(f.coefficient_count(), 2 * 7);
    let v = f.to_vector();
    assert_eq!(v.len(), f.coefficient_count());
    assert_eq!(&v[..2], f.q0());
    assert_eq!(&v[2..5], f.a()[0].as_slice());
    assert_eq!(&v[5..8], f.b()[0].as_slice());
    let g = Fourier::from_vector(0.2, 2.0, 2, 3, &v).unwrap();
    assert_eq!(f, g);
    let e = Fourier::from_vector(0.2, 2.0, 2, 2, &v).unwrap_err();
    assert!(e.to_string().contains("14 values"), "{e}");
    assert!(Fourier::from_vector(0.2, 2.0, usize::MAX, usize::MAX, &v).is_err());
    assert!(Fourier::from_vector(0.2, 2.0, 1, 0, &[0.0]).is_err());
}

#[test]
fn fourier_rejects_bad_input() {
    let bad = [
        Fourier::new(0.0, vec![0.0], vec![vec![0.0]], vec![vec![0.0]], 1.0),
        Fourier::new(0.1, vec![0.0], vec![vec![0.0]], vec![vec![0.0]], f64::NAN),
        Fourier::new(0.1, vec![], vec![], vec![], 1.0),
        Fourier::new(0.1, vec![0.0], vec![vec![]], vec![vec![]], 1.0),
        Fourier::new(0.1, vec![0.0], vec![vec![0.0]], vec![vec![0.0, 1.0]], 1.0),
        Fourier::new(0.1, vec![0.0, 0.0], vec![vec![0.0]], vec![vec![0.0]], 1.0),
        Fourier::new(
            0.1,
            vec![0.0],
            vec![vec![f64::INFINITY]],
            vec![vec![0.0]],
            1.0,
        ),
        Fourier::rest_constrained(0.1, vec![0.0], vec![vec![0.1]], vec![vec![0.1]], 1.5),
        Fourier::rest_constrained(0.1, vec![0.0], vec![vec![]], vec![vec![]], 1.0),
        Fourier::rest_constrained(0.1, vec![0.0], vec![vec![0.1]], vec![vec![0.1, 0.2]], 1.0),
    ];
    for (k, r) in bad.into_iter().enumerate() {
        assert!(matches!(r, Err(Error::InvalidInput(_))), "case {k}: {r:?}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// The rest parametrisation gives zero velocity and acceleration at the start and at the
    /// end of every whole number of periods, and starts at q0 + sum b.
    #[test]
    fn rest_constrained_fourier_starts_and_ends_at_rest(
        free in proptest::collection::vec(-1.0f64..1.0, 8),
        freq in 0.05f64..2.0,
        periods in 1u32..4,
    ) {
        let (a, b) = free.split_at(4);
        let f = Fourier::rest_constrained(
            freq,
            vec![0.2, -0.3],
            vec![a[..2].to_vec(), a[2..].to_vec()],
            vec![b[..2].to_vec(), b[2..].to_vec()],
            f64::from(periods),
        )
        .unwrap();
        prop_assert_eq!(f.harmonics(), 3);
        let (q0, dq0, ddq0) = at(&f, 0.0);
        let (q1, dq1, ddq1) = at(&f, f.duration());
        let w = 2.0 * PI * freq;
        for i in 0..2 {
            let start = f.q0()[i] + f.b()[i].iter().sum::<f64>();
            prop_assert!((q0[i] - start).abs() < 1e-12);
            prop_assert!((q1[i] - start).abs() < 1e-9);
            prop_assert!(dq0[i].abs() < 1e-12 * w && ddq0[i].abs() < 1e-12 * w * w);
            prop_assert!(dq1[i].abs() < 1e-9 * w && ddq1[i].abs() < 1e-9 * w * w);
        }
    }
}

#[test]
fn point_to_point_hits_via_points_at_rest_within_limits() {
    let points = vec![
        vec![0.0, 0.0, 0.0],
        vec![1.0, -0.5, 0.0],
        vec![1.0, 0.5, 2.0],
        vec![-0.3, 0.5, 2.0],
    ];
    let vmax = [1.5, 0.8, 3.0];
    let amax = [4.0, 2.0, 10.0];
    for options in [
        PointToPointOptions::default(),
        PointToPointOptions {
            slowdown: 1.7,
            dwell_s: 0.4,
        },
    ] {
        let p = PointToPoint::new(points.clone(), &vmax, &amax, &options).unwrap();
        assert_eq!(p.points(), points.as_slice());
        let arrivals = p.arrival_times().to_vec();
        assert_eq!(arrivals.len(), 4);
        assert_eq!(arrivals[0], 0.0);
        assert!((p.duration() - (arrivals[3] + options.dwell_s)).abs() < 1e-12);
        for (k, &ta) in arrivals.iter().enumerate() {
            for t in [ta, ta + options.dwell_s] {
                let (q, dq, ddq) = at(&p, t);
                assert!(max_abs_diff(&q, &points[k]) < 1e-12, "point {k} at {t}");
                assert!(
                    dq.iter().chain(&ddq).all(|v| v.abs() < 1e-12),
                    "{dq:?} {ddq:?}"
                );
            }
        }
        // Sampled peaks: within the limits; without slow-down each segment reaches one of
        // them (the duration is the smallest feasible one).
        for seg in 0..3 {
            let (t0, t1) = (arrivals[seg] + options.dwell_s, arrivals[seg + 1]);
            let mut peak: f64 = 0.0;
            for k in 0..=4000 {
                let t = t0 + (t1 - t0) * k as f64 / 4000.0;
                let (_, dq, ddq) = at(&p, t);
                for i in 0..3 {
                    peak = peak.max(dq[i].abs() / vmax[i]).max(ddq[i].abs() / amax[i]);
                }
            }
            assert!(peak <= 1.0 + 1e-12, "segment {seg}: {peak}");
            let expected = 1.0 / options.slowdown;
            assert!(
                peak >= expected * (1.0 - 1e-5) - 1e-12 && peak <= expected * (1.0 + 1e-12),
                "segment {seg}: peak {peak}, expected {expected}"
            );
        }
        for k in 1..200 {
            let (ev, ea) = fd_error(&p, p.duration() * k as f64 / 200.0, 1e-6);
            assert!(ev < 1e-6 && ea < 1e-4, "{ev} {ea}");
        }
    }
}

#[test]
fn point_to_point_duration_is_closed_form() {
    // One joint moving 2 rad: velocity-bound duration 15/8 * 2 / 1 = 3.75 s; acceleration
    // bound sqrt(10/sqrt(3) * 2 / 100) = 0.34 s.
    let p = PointToPoint::new(
        vec![vec![0.0], vec![2.0]],
        &[1.0],
        &[100.0],
        &PointToPointOptions::default(),
    )
    .unwrap();
    assert!((p.duration() - 3.75).abs() < 1e-12);
    // Acceleration bound: sqrt(10/sqrt(3) * 2 / 1) s.
    let p = PointToPoint::new(
        vec![vec![0.0], vec![2.0]],
        &[100.0],
        &[1.0],
        &PointToPointOptions::default(),
    )
    .unwrap();
    assert!((p.duration() - (20.0 / 3f64.sqrt()).sqrt()).abs() < 1e-12);
}

#[test]
fn point_to_point_rejects_bad_input() {
    let o = PointToPointOptions::default();
    let two = vec![vec![0.0, 0.0], vec![1.0, 1.0]];
    let cases = [
        PointToPoint::new(vec![vec![0.0, 0.0]], &[1.0; 2], &[1.0; 2], &o),
        PointToPoint::new(vec![vec![0.0], vec![1.0, 1.0]], &[1.0; 2], &[1.0; 2], &o),
        PointToPoint::new(
            vec![vec![0.0, f64::NAN], vec![1.0, 1.0]],
            &[1.0; 2],
            &[1.0; 2],
            &o,
        ),
        PointToPoint::new(two.clone(), &[1.0], &[1.0; 2], &o),
        PointToPoint::new(two.clone(), &[1.0, 0.0], &[1.0; 2], &o),
        PointToPoint::new(two.clone(), &[1.0; 2], &[1.0, -1.0], &o),
        PointToPoint::new(
            two.clone(),
            &[1.0; 2],
            &[1.0; 2],
            &PointToPointOptions {
                slowdown: 0.5,
                dwell_s: 0.0,
            },
        ),
        PointToPoint::new(
            two,
            &[1.0; 2],
            &[1.0; 2],
            &PointToPointOptions {
                slowdown: 1.0,
                dwell_s: -1.0,
            },
        ),
        PointToPoint::new(vec![vec![0.5; 2]; 3], &[1.0; 2], &[1.0; 2], &o),
    ];
    for (k, r) in cases.into_iter().enumerate() {
        assert!(matches!(r, Err(Error::InvalidInput(_))), "case {k}: {r:?}");
    }
    // Coinciding points with a dwell are a valid hold.
    let hold = PointToPoint::new(
        vec![vec![0.5; 2]; 2],
        &[1.0; 2],
        &[1.0; 2],
        &PointToPointOptions {
            slowdown: 1.0,
            dwell_s: 1.0,
        },
    )
    .unwrap();
    assert_eq!(hold.duration(), 2.0);
    assert_eq!(at(&hold, 1.3).0, vec![0.5; 2]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Arbitrary via points and limits: sampled velocity and acceleration stay within them.
    #[test]
    fn point_to_point_respects_limits(
        coords in proptest::collection::vec(-3.0f64..3.0, 8),
        limits in proptest::collection::vec(0.1f64..20.0, 4),
        slowdown in 1.0f64..3.0,
    ) {
        let points: Vec<Vec<f64>> = coords.chunks(2).map(<[f64]>::to_vec).collect();
        let (vmax, amax) = limits.split_at(2);
        let options = PointToPointOptions { slowdown, dwell_s: 0.1 };
        let p = PointToPoint::new(points, vmax, amax, &options).unwrap();
        for k in 0..=2000 {
            let (_, dq, ddq) = at(&p, p.duration() * k as f64 / 2000.0);
            for i in 0..2 {
                prop_assert!(dq[i].abs() <= vmax[i] * (1.0 + 1e-12));
                prop_assert!(ddq[i].abs() <= amax[i] * (1.0 + 1e-12));
            }
        }
    }
}

#[test]
fn random_generators_are_deterministic_per_seed() {
    let robot = common::irb1200();
    let fo = RandomFourierOptions::default();
    let po = RandomPointToPointOptions::default();
    let f1 = random_fourier(&robot, &mut common::rng(7), &fo).unwrap();
    let f2 = random_fourier(&robot, &mut common::rng(7), &fo).unwrap();
    let f3 = random_fourier(&robot, &mut common::rng(8), &fo).unwrap();
    assert_eq!(f1, f2);
    assert_ne!(f1, f3);
    let p1 = random_point_to_point(&robot, &mut common::rng(7), &po).unwrap();
    let p2 = random_point_to_point(&robot, &mut common::rng(7), &po).unwrap();
    let p3 = random_point_to_point(&robot, &mut common::rng(8), &po).unwrap();
    assert_eq!(p1, p2);
    assert_ne!(p1, p3);
    assert_eq!(p1.points().len(), 5);
}

#[test]
fn random_fourier_stays_within_irb1200_limits_and_rests() {
    let robot = common::irb1200();
    let options = RandomFourierOptions::default();
    let mut rng = common::rng(11);
    for seed in 0..100 {
        let f = random_fourier(&robot, &mut rng, &options).unwrap();
        assert_eq!((f.harmonics(), f.duration()), (5, 10.0));
        check_limits(&robot, &f, 0.005, Some(&IRB1200_ACCEL_LIMITS))
            .unwrap_or_else(|e| panic!("trajectory {seed}: {e}"));
        for t in [0.0, f.duration()] {
            let (q, dq, ddq) = at(&f, t);
            robot.check_position_limits(&q).unwrap();
            assert!(
                dq.iter().chain(&ddq).all(|v| v.abs() < 1e-9),
                "{t}: {dq:?} {ddq:?}"
            );
        }
    }
    // Without the rest constraint and over several periods, limits still hold.
    let free = RandomFourierOptions {
        rest: false,
        harmonics: 3,
        periods: 2.5,
        base_freq_hz: 0.3,
        ..RandomFourierOptions::default()
    };
    for _ in 0..50 {
        let f = random_fourier(&robot, &mut rng, &free).unwrap();
        check_limits(&robot, &f, 0.005, Some(&IRB1200_ACCEL_LIMITS)).unwrap();
    }
}

#[test]
fn random_point_to_point_stays_within_irb1200_limits() {
    let robot = common::irb1200();
    let options = RandomPointToPointOptions {
        dwell_s: 0.2,
        ..RandomPointToPointOptions::default()
    };
    let mut rng = common::rng(12);
    for seed in 0..100 {
        let p = random_point_to_point(&robot, &mut rng, &options).unwrap();
        check_limits(&robot, &p, 0.005, Some(&IRB1200_ACCEL_LIMITS))
            .unwrap_or_else(|e| panic!("trajectory {seed}: {e}"));
        for q in p.points() {
            for (j, qi) in robot.joints().iter().zip(q) {
                assert!(*qi >= j.limits.lower + 0.05 && *qi <= j.limits.upper - 0.05);
            }
        }
    }
}

#[test]
fn random_generators_reject_bad_options() {
    let robot = common::irb1200();
    let mut rng = common::rng(0);
    let fourier_cases = [
        RandomFourierOptions {
            harmonics: 1,
            ..Default::default()
        },
        RandomFourierOptions {
            periods: 1.5,
            ..Default::default()
        },
        RandomFourierOptions {
            accel_limits: vec![1.0; 5],
            ..Default::default()
        },
        RandomFourierOptions {
            limit_fraction: 1.5,
            ..Default::default()
        },
        RandomFourierOptions {
            position_margin: 2.5,
            ..Default::default()
        },
        RandomFourierOptions {
            min_amplitude: -0.1,
            ..Default::default()
        },
        RandomFourierOptions {
            base_freq_hz: 0.0,
            ..Default::default()
        },
    ];
    for (k, o) in fourier_cases.iter().enumerate() {
        let r = random_fourier(&robot, &mut rng, o);
        assert!(matches!(r, Err(Error::InvalidInput(_))), "case {k}: {r:?}");
    }
    let ptp_cases = [
        RandomPointToPointOptions {
            points: 1,
            ..Default::default()
        },
        RandomPointToPointOptions {
            max_slowdown: 0.9,
            ..Default::default()
        },
        RandomPointToPointOptions {
            accel_limits: vec![1.0, 1.0, 1.0, 1.0, 1.0, 0.0],
            ..Default::default()
        },
    ];
    for (k, o) in ptp_cases.iter().enumerate() {
        let r = random_point_to_point(&robot, &mut rng, o);
        assert!(matches!(r, Err(Error::InvalidInput(_))), "case {k}: {r:?}");
    }
}

#[test]
fn check_limits_names_joint_time_value_and_limit() {
    let robot = common::irb1200();
    let home = vec![0.0; 6];
    let mut target = home.clone();
    target[1] = 1.0;
    // Joint 2 allowed 8 rad/s by the motion, 4.189 rad/s by the robot.
    let fast = PointToPoint::new(
        vec![home.clone(), target.clone()],
        &[8.0; 6],
        &[1000.0; 6],
        &PointToPointOptions::default(),
    )
    .unwrap();
    let e = check_limits(&robot, &fast, 0.001, None).unwrap_err();
    let m = e.to_string();
    assert!(matches!(e, Error::JointLimit(_)), "{m}");
    assert!(
        m.contains("joint 2") && m.contains("t = 0.") && m.contains("velocity"),
        "{m}"
    );
    assert!(m.contains("rad/s exceeds the limit 4.18879"), "{m}");

    // Slow enough for velocity, but accelerations above a tight bound on joint 2.
    let slow = PointToPoint::new(
        vec![home.clone(), target],
        &[1.0; 6],
        &[10.0; 6],
        &PointToPointOptions::default(),
    )
    .unwrap();
    check_limits(&robot, &slow, 0.001, None).unwrap();
    let mut acc = IRB1200_ACCEL_LIMITS;
    acc[1] = 0.5;
    let m = check_limits(&robot, &slow, 0.001, Some(&acc))
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("joint 2") && m.contains("acceleration") && m.contains("0.500000 rad/s^2"),
        "{m}"
    );

    // Position: joint 5 driven past its upper limit (2.269 rad) at t = 0 already.
    let mut beyond = home.clone();
    beyond[4] = 2.5;
    let outside = PointToPoint::new(
        vec![beyond, home],
        &[1.0; 6],
        &[1.0; 6],
        &PointToPointOptions::default(),
    )
    .unwrap();
    let m = check_limits(&robot, &outside, 0.01, None)
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("joint 5")
            && m.contains("t = 0.000000 s")
            && m.contains("position 2.500000 rad"),
        "{m}"
    );

    // Wrong dof, bad step, bad acceleration limits.
    let two = PointToPoint::new(
        vec![vec![0.0; 2], vec![0.1; 2]],
        &[1.0; 2],
        &[1.0; 2],
        &PointToPointOptions::default(),
    )
    .unwrap();
    let invalid = |r: powertwin::Result<()>| matches!(r, Err(Error::InvalidInput(_)));
    assert!(invalid(check_limits(&robot, &two, 0.01, None)));
    assert!(invalid(check_limits(&robot, &slow, 0.0, None)));
    assert!(invalid(check_limits(&robot, &slow, 0.01, Some(&[1.0; 5]))));
    assert!(invalid(check_limits(&robot, &slow, 0.01, Some(&[-1.0; 6]))));
}
