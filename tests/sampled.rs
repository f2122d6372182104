//! Sampled trajectories: interpolation through samples (cubic spline, cubic and quintic
//! Hermite), their tables, and the Coulomb signs of a motion estimated from a log.

use crate::common;
use crate::trajectory::{at, fd_error, max_abs_diff};

use std::f64::consts::PI;

use powertwin::Error;
use powertwin::io::table::Table;
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::sampled::{Interpolation, Sampled};
use rand::RngExt;

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
