//! Trajectories: interpolation of samples, Fourier series, point-to-point motions, random
//! generators and the limit check, against their definitions and finite differences.

use crate::common;

use std::f64::consts::PI;

use powertwin::Error;
use powertwin::io::table::Table;
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::fourier::Fourier;
use powertwin::trajectory::limits::{IRB1200_ACCEL_LIMITS, check_limits};
use powertwin::trajectory::point_to_point::{PointToPoint, PointToPointOptions};
use powertwin::trajectory::random::{
    RandomFourierOptions, RandomPointToPointOptions, random_fourier, random_point_to_point,
};
use powertwin::trajectory::sampled::{Interpolation, Sampled};
use proptest::prelude::*;
use rand::RngExt;

/// Position, velocity and acceleration at `t`.
fn at(traj: &dyn Trajectory, t: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = traj.dof();
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    traj.sample(t, &mut q, &mut dq, &mut ddq);
    (q, dq, ddq)
}

/// Largest deviation of `dq` from the central difference of `q` and of `ddq` from that of
/// `dq` at `t` (step `h`), relative to `scale_v` and `scale_a`.
fn fd_error(traj: &dyn Trajectory, t: f64, h: f64) -> (f64, f64) {
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

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Random samples of `dof` joints at `n` irregular times starting at `t0`.
fn random_samples(seed: u64, dof: usize, n: usize, t0: f64) -> (Vec<f64>, [Vec<Vec<f64>>; 3]) {
    let mut rng = common::rng(seed);
    let mut t = vec![t0];
    for _ in 1..n {
        let last = t[t.len() - 1];
        t.push(last + rng.random_range(0.3..0.6));
    }
    let mut series = || -> Vec<Vec<f64>> {
        (0..dof)
            .map(|_| (0..n).map(|_| rng.random_range(-1.0..1.0)).collect())
            .collect()
    };
    let q = series();
    let dq = series();
    let ddq = series();
    (t, [q, dq, ddq])
}

/// Times strictly inside the sample intervals (a quarter and three quarters of each).
fn interior_times(t: &[f64]) -> Vec<f64> {
    t.windows(2)
        .flat_map(|w| [0.25, 0.75].map(|f| w[0] + f * (w[1] - w[0])))
        .collect()
}

#[test]
fn sampled_passes_through_every_sample() {
    let (t, [q, dq, ddq]) = random_samples(1, 3, 12, 2.5);
    let kinds = [
        (
            Some(dq.clone()),
            Some(ddq.clone()),
            Interpolation::QuinticHermite,
        ),
        (Some(dq.clone()), None, Interpolation::CubicHermite),
        (None, None, Interpolation::CubicSpline),
    ];
    for (dqs, ddqs, kind) in kinds {
        let s = Sampled::new(t.clone(), q.clone(), dqs.clone(), ddqs.clone()).unwrap();
        assert_eq!(s.interpolation(), kind);
        assert_eq!(s.start_time(), 2.5);
        assert!((s.duration() - (t[t.len() - 1] - 2.5)).abs() < 1e-15);
        for (k, &tk) in t.iter().enumerate() {
            let (qs, dqs_k, ddqs_k) = at(&s, tk - 2.5);
            for i in 0..3 {
                assert!((qs[i] - q[i][k]).abs() < 1e-12, "{kind:?} q{i} sample {k}");
                if dqs.is_some() {
                    assert!((dqs_k[i] - dq[i][k]).abs() < 1e-9, "{kind:?} dq sample {k}");
                }
                if ddqs.is_some() {
                    assert!(
                        (ddqs_k[i] - ddq[i][k]).abs() < 1e-7,
                        "{kind:?} ddq sample {k}"
                    );
                }
            }
        }
        // Times outside the range are clamped.
        assert_eq!(at(&s, -1.0), at(&s, 0.0));
        assert_eq!(at(&s, 1e9), at(&s, s.duration()));
    }
}

#[test]
fn a_route_leaving_a_rest_takes_the_coulomb_sign_of_its_displacement() {
    // At rest at 0, then barely displaced by the first sample but fast there: the quintic
    // first swings back (a route through a joint that breaks away late).
    let t = vec![0.0, 0.1, 0.2, 0.3];
    let q = vec![vec![0.0, 0.001, 0.03, 0.06]];
    let dq = vec![vec![0.0, 0.3, 0.3, 0.3]];
    let ddq = vec![vec![0.0; 4]];
    let s = Sampled::new(t, q, Some(dq), Some(ddq)).unwrap();
    let at = |s: &Sampled, t: f64| {
        let (mut q, mut dq, mut ddq, mut sign) = ([0.0], [0.0], [0.0], [0.0]);
        s.sample(t, &mut q, &mut dq, &mut ddq);
        s.coulomb_signs(t, &dq, &mut sign);
        (dq[0], sign[0])
    };
    let (back, exact) = at(&s, 0.02);
    assert!(back < 0.0, "the route must swing back: {back} rad/s");
    assert_eq!(exact, -1.0, "a plan's sign is its speed's");
    let s = s.with_move_weights(vec![vec![1.0, 1.0, 0.5, 0.5]]).unwrap();
    // Leaving the rest: the way the joint goes, not the swing back.
    assert_eq!(at(&s, 0.02).1, 1.0);
    // At the rest itself: no sign.
    assert_eq!(at(&s, 0.0).1, 0.0);
    // Away from a rest the route's own speed, weighed.
    let (v, sign) = at(&s, 0.25);
    assert!(v > 0.0 && (sign - 0.5).abs() < 1e-12, "{v} {sign}");
}

#[test]
fn sampled_move_weights_scale_the_coulomb_signs_linearly_between_samples() {
    // Two joints moving in opposite directions through three samples.
    let t = vec![0.0, 0.1, 0.2];
    let q = vec![vec![0.0, 0.01, 0.02], vec![0.0, -0.01, -0.02]];
    let s = Sampled::new(t.clone(), q.clone(), None, None).unwrap();
    let mut signs = [0.0; 2];
    // Without weights: the signs of the speeds.
    s.coulomb_signs(0.05, &[0.1, -0.1], &mut signs);
    assert_eq!(signs, [1.0, -1.0]);
    let s = s
        .with_move_weights(vec![vec![1.0, 0.0, 0.5], vec![0.2, 0.2, 1.0]])
        .unwrap();
    s.coulomb_signs(0.05, &[0.1, -0.1], &mut signs);
    assert!(
        (signs[0] - 0.5).abs() < 1e-12 && (signs[1] + 0.2).abs() < 1e-12,
        "{signs:?}"
    );
    s.coulomb_signs(0.15, &[0.1, -0.1], &mut signs);
    assert!(
        (signs[0] - 0.25).abs() < 1e-12 && (signs[1] + 0.6).abs() < 1e-12,
        "{signs:?}"
    );
    // A joint at rest has no sign to weigh.
    s.coulomb_signs(0.15, &[0.0, -0.1], &mut signs);
    assert_eq!(signs[0], 0.0);
    // Bad weights are errors.
    let base = || Sampled::new(t.clone(), q.clone(), None, None).unwrap();
    for bad in [
        vec![vec![1.0; 3]],
        vec![vec![1.0; 2], vec![1.0; 3]],
        vec![vec![1.0, 1.5, 1.0], vec![1.0; 3]],
        vec![vec![1.0, f64::NAN, 1.0], vec![1.0; 3]],
    ] {
        assert!(base().with_move_weights(bad).is_err());
    }
}

#[test]
fn sampled_reproduces_a_smooth_function() {
    // sin(t) on [0, 2 pi] at 41 samples (h = 0.157 s).
    let n = 41;
    let t: Vec<f64> = (0..n)
        .map(|k| 2.0 * PI * k as f64 / (n - 1) as f64)
        .collect();
    let q = vec![t.iter().map(|x| x.sin()).collect::<Vec<_>>()];
    let dq = vec![t.iter().map(|x| x.cos()).collect::<Vec<_>>()];
    let ddq = vec![t.iter().map(|x| -x.sin()).collect::<Vec<_>>()];
    // Stated accuracies (position, velocity, acceleration) for each interpolant.
    let cases = [
        (Some(dq.clone()), Some(ddq.clone()), [1e-9, 1e-7, 1e-5]),
        (Some(dq), None, [1e-5, 2e-4, 0.08]),
        (None, None, [1e-5, 2e-4, 0.01]),
    ];
    for (dqs, ddqs, tol) in cases {
        let s = Sampled::new(t.clone(), q.clone(), dqs, ddqs).unwrap();
        let mut err = [0.0f64; 3];
        for k in 0..=2000 {
            let x = 2.0 * PI * k as f64 / 2000.0;
            let (qs, dqs, ddqs) = at(&s, x);
            err[0] = err[0].max((qs[0] - x.sin()).abs());
            err[1] = err[1].max((dqs[0] - x.cos()).abs());
            err[2] = err[2].max((ddqs[0] + x.sin()).abs());
        }
        for d in 0..3 {
            assert!(
                err[d] < tol[d],
                "{:?}: derivative {d} error {} > {}",
                s.interpolation(),
                err[d],
                tol[d]
            );
        }
    }
}

#[test]
fn sampled_derivatives_match_finite_differences() {
    let (t, [q, dq, ddq]) = random_samples(2, 2, 9, 0.0);
    for (dqs, ddqs) in [
        (Some(dq.clone()), Some(ddq)),
        (Some(dq), None),
        (None, None),
    ] {
        let s = Sampled::new(t.clone(), q.clone(), dqs, ddqs).unwrap();
        for &x in &interior_times(&t) {
            let (ev, ea) = fd_error(&s, x, 1e-5);
            assert!(
                ev < 1e-7 && ea < 1e-5,
                "{:?} at {x}: {ev} {ea}",
                s.interpolation()
            );
        }
    }
}

#[test]
fn spline_and_quintic_are_c2_at_the_samples() {
    let (t, [q, dq, ddq]) = random_samples(3, 2, 8, 0.0);
    // Largest change of q, dq, ddq across the samples (from 1e-10 s before to 1e-10 s after).
    let jumps = |s: &Sampled| {
        let mut jump = [0.0f64; 3];
        for &tk in &t[1..t.len() - 1] {
            let (ql, dql, ddql) = at(s, tk - 1e-10);
            let (qr, dqr, ddqr) = at(s, tk + 1e-10);
            jump[0] = jump[0].max(max_abs_diff(&ql, &qr));
            jump[1] = jump[1].max(max_abs_diff(&dql, &dqr));
            jump[2] = jump[2].max(max_abs_diff(&ddql, &ddqr));
        }
        jump
    };
    for (dqs, ddqs) in [(Some(dq.clone()), Some(ddq)), (None, None)] {
        let s = Sampled::new(t.clone(), q.clone(), dqs, ddqs).unwrap();
        let jump = jumps(&s);
        assert!(
            jump.iter().all(|j| *j < 1e-6),
            "{:?}: {jump:?}",
            s.interpolation()
        );
    }
    // The cubic Hermite is only C1: its acceleration jumps.
    let s = Sampled::new(t.clone(), q.clone(), Some(dq), None).unwrap();
    let jump = jumps(&s);
    assert!(jump[1] < 1e-6 && jump[2] > 0.1, "{jump:?}");
}

#[test]
fn spline_end_conditions_follow_rest() {
    let t = vec![0.0, 0.5, 1.0, 1.5, 2.0];
    // Joint 1 starts and ends at rest (repeated samples); joint 2 does not.
    let q = vec![
        vec![0.3, 0.3, 1.0, 2.0, 2.0],
        vec![0.0, 0.4, 0.2, -0.5, 0.1],
    ];
    let s = Sampled::new(t, q, None, None).unwrap();
    let (_, dq0, ddq0) = at(&s, 0.0);
    let (_, dq1, ddq1) = at(&s, s.duration());
    assert_eq!(dq0[0], 0.0);
    assert!(dq1[0].abs() < 1e-12);
    assert!(
        ddq0[1].abs() < 1e-12 && ddq1[1].abs() < 1e-12,
        "natural ends"
    );
    assert!(dq0[1].abs() > 0.1 && ddq0[0].abs() > 0.1);
}

#[test]
fn sampled_rejects_bad_input() {
    let msg = |r: powertwin::Result<Sampled>| match r {
        Err(Error::InvalidInput(m)) => m,
        other => panic!("expected InvalidInput, got {other:?}"),
    };
    let m = msg(Sampled::new(vec![0.0], vec![vec![1.0]], None, None));
    assert!(m.contains("at least 2 samples"), "{m}");
    let m = msg(Sampled::new(
        vec![0.0, 1.0, 1.0],
        vec![vec![0.0; 3]],
        None,
        None,
    ));
    assert!(
        m.starts_with("sample 3:") && m.contains("does not increase"),
        "{m}"
    );
    let m = msg(Sampled::new(
        vec![0.0, 1.0],
        vec![vec![0.0, f64::NAN]],
        None,
        None,
    ));
    assert!(m.starts_with("sample 2:") && m.contains("q1"), "{m}");
    let m = msg(Sampled::new(
        vec![0.0, 1.0],
        vec![vec![0.0; 2], vec![0.0; 3]],
        None,
        None,
    ));
    assert!(m.contains("q2 has 3 samples"), "{m}");
    let m = msg(Sampled::new(
        vec![0.0, 1.0],
        vec![vec![0.0; 2]],
        Some(vec![]),
        None,
    ));
    assert!(m.contains("dq has 0 joints"), "{m}");
    let m = msg(Sampled::new(
        vec![0.0, 1.0],
        vec![vec![0.0; 2]],
        None,
        Some(vec![vec![0.0; 2]]),
    ));
    assert!(m.contains("without velocities"), "{m}");
    let m = msg(Sampled::new(vec![0.0, 1.0], vec![], None, None));
    assert!(m.contains("no joint"), "{m}");
}

#[test]
fn sampled_from_table_reads_units_and_optional_kinds() {
    let text = "t_s,q1_rad,q2,dq1_rad_s,dq2,other\n\
                1.0,0.0,1.0,0.0,0.0,9\n\
                1.5,0.5,1.2,1.0,0.1,9\n\
                2.0,1.0,1.0,0.0,0.0,9\n";
    let table = Table::parse(text, "run.csv").unwrap();
    let s = Sampled::from_table(&table, 2).unwrap();
    assert_eq!(s.interpolation(), Interpolation::CubicHermite);
    assert_eq!(s.start_time(), 1.0);
    assert_eq!(s.duration(), 1.0);
    let (q, dq, _) = at(&s, 0.5);
    assert_eq!(q, vec![0.5, 1.2]);
    assert_eq!(dq, vec![1.0, 0.1]);
    let s1 = Sampled::from_table(&table, 1).unwrap();
    assert_eq!(s1.dof(), 1);

    let only_q = Table::parse("t,q1\n0,0\n1,1\n", "x").unwrap();
    assert_eq!(
        Sampled::from_table(&only_q, 1).unwrap().interpolation(),
        Interpolation::CubicSpline
    );
    let all = Table::parse("t,q1,dq1,ddq1_rad_s2\n0,0,0,0\n1,1,0,0\n", "x").unwrap();
    assert_eq!(
        Sampled::from_table(&all, 1).unwrap().interpolation(),
        Interpolation::QuinticHermite
    );
}

#[test]
fn bad_tables_name_the_row() {
    let err = |text: &str, dof: usize| {
        let table = Table::parse(text, "bad.csv").unwrap();
        Sampled::from_table(&table, dof).unwrap_err().to_string()
    };
    assert_eq!(
        err("t,q1\n0,0\n1,1\n1,2\n", 1),
        "bad.csv: row 4: time 1 s does not increase (previous sample at 1 s)"
    );
    assert_eq!(
        err("t,q1\n0,0\n", 1),
        "bad.csv: row 1: a sampled trajectory needs at least 2 samples, got 1"
    );
    let e = err("t,q1,q2,dq1\n0,0,0,0\n1,1,1,1\n", 2);
    assert_eq!(e, "bad.csv: row 1: missing column 'dq2_rad_s' or 'dq2'");
    let e = err("time,q1\n0,0\n1,1\n", 1);
    assert!(e.contains("row 1: missing column 't_s' or 't'"), "{e}");
    let e = err("t,q1\n0,0\n1,1\n", 2);
    assert!(e.contains("missing column 'q2_rad' or 'q2'"), "{e}");
    let e = err("t,q1,ddq1\n0,0,0\n1,1,0\n", 1);
    assert!(
        e.contains("row 1: accelerations given without velocities"),
        "{e}"
    );
    let table = Table::parse("t,q1\n0,0\n1,1\n", "x").unwrap();
    assert!(matches!(
        Sampled::from_table(&table, 0),
        Err(Error::InvalidInput(_))
    ));
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
