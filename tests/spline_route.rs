//! The spline route through a log's samples: quintic splines, rests held still, Coulomb signs
//! near rests, encoder noise, and the states of an averaging logger's periods and payloads.

use powertwin::identification::spline::{End, quintic};
use powertwin::identification::states::{from_spline, rest_intervals};
use rand::RngExt;

use crate::common;

/// Knot times from 0 s at about `h` s apart, jittered by up to 20 % (seeded).
fn knots(count: usize, h: f64, seed: u64) -> Vec<f64> {
    let mut rng = common::rng(seed);
    let mut t = vec![0.0];
    for _ in 1..count {
        let last = *t.last().unwrap();
        t.push(last + h * rng.random_range(0.8..1.2));
    }
    t
}

/// A fast, noisy log of a rest: 500 Hz with 1.5e-5 rad of encoder noise, one sample
/// 4.5 standard deviations off (noise, not motion). Every 0.1 s window through that sample
/// spans more than the rest test's 1e-4 rad, so the test alone breaks the rest around it.
/// The route holds the whole rest still, with no motion, and no acceleration, invented
/// through that sample, and still starts the motion after the rest.
#[test]
fn a_noisy_fast_log_keeps_a_rest_still() {
    use rand_distr::{Distribution, StandardNormal};
    let mut rng = common::rng(7);
    let (rate, rest_s, sigma, blip) = (500.0, 2.0, 1.5e-5, 500);
    let t: Vec<f64> = (0..1250).map(|k| k as f64 / rate).collect();
    let q: Vec<Vec<f64>> = [0.4, -1.1, 0.7]
        .iter()
        .map(|&q0| {
            (0..t.len())
                .map(|k| {
                    let u = (t[k] - rest_s).max(0.0);
                    let z: f64 = StandardNormal.sample(&mut rng);
                    let off = if k == blip { 4.5 * sigma } else { 0.0 };
                    q0 + 0.2 * u * u * u + sigma * z + off
                })
                .collect()
        })
        .collect();
    let rest = rest_intervals(&t, &q);
    let still_end = (rest_s * rate) as usize - 60;
    assert!(!rest[blip], "the rest test alone keeps the rest whole");
    let s = from_spline(&t, &q).unwrap().states;
    for i in 0..3 {
        let worst = (0..still_end)
            .map(|k| s.ddq[i][k].abs())
            .fold(0.0, f64::max);
        assert_eq!(worst, 0.0, "joint {}: acceleration at rest", i + 1);
        assert!(s.dq[i][1240] > 0.1, "joint {} moves after the rest", i + 1);
    }
}

#[test]
fn quintic_spline_reproduces_polynomials_it_can_represent() {
    let t = knots(12, 0.1, 1);
    // A quartic with free ends: the end conditions come from the quartic through the five
    // samples nearest each end, i.e. the quartic itself, so the spline is the quartic.
    let p = |x: f64| 0.3 - 1.2 * x + 0.8 * x * x - 0.5 * x.powi(3) + 0.7 * x.powi(4);
    let dp = |x: f64| -1.2 + 1.6 * x - 1.5 * x * x + 2.8 * x.powi(3);
    let ddp = |x: f64| 1.6 - 3.0 * x + 8.4 * x * x;
    let x: Vec<f64> = t.iter().map(|&s| p(s)).collect();
    let (v, a) = quintic(&t, &x, End::Free, End::Free).unwrap();
    for k in 0..t.len() {
        assert!((v[k] - dp(t[k])).abs() < 1e-9, "v at {}: {}", t[k], v[k]);
        assert!((a[k] - ddp(t[k])).abs() < 1e-7, "a at {}: {}", t[k], a[k]);
    }
    // Rest to rest: the minimum-jerk profile 10 s^3 - 15 s^4 + 6 s^5 (s = t / T) is a
    // quintic with zero velocity and acceleration at both ends, so it is the spline.
    let big_t = *t.last().unwrap();
    let x: Vec<f64> = t
        .iter()
        .map(|&s| {
            let u = s / big_t;
            2.0 * (10.0 * u.powi(3) - 15.0 * u.powi(4) + 6.0 * u.powi(5))
        })
        .collect();
    let (v, a) = quintic(&t, &x, End::Rest, End::Rest).unwrap();
    for k in 0..t.len() {
        let u = t[k] / big_t;
        let dv = 2.0 * 30.0 * u * u * (1.0 - u).powi(2) / big_t;
        let da = 2.0 * 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u) / (big_t * big_t);
        assert!((v[k] - dv).abs() < 1e-9 && (a[k] - da).abs() < 1e-7, "{k}");
    }
    // Rest ends are exactly zero (a Coulomb term switches on any non-zero speed).
    assert_eq!((v[0], a[0], v[11], a[11]), (0.0, 0.0, 0.0, 0.0));
    // Two samples, free ends: the line.
    let (v, a) = quintic(&[0.0, 0.5], &[1.0, 2.0], End::Free, End::Free).unwrap();
    assert_eq!((v, a), (vec![2.0, 2.0], vec![0.0, 0.0]));
}

#[test]
fn quintic_spline_differentiates_a_10_hz_sine_and_refuses_bad_input() {
    // q = sin(w t), w = 2 pi 0.3 Hz, at 10 Hz with jittered stamps.
    let w = std::f64::consts::TAU * 0.3;
    let t = knots(80, 0.1, 2);
    let x: Vec<f64> = t.iter().map(|s| (w * s).sin()).collect();
    let (v, a) = quintic(&t, &x, End::Free, End::Free).unwrap();
    let (mut ev, mut ea) = ([0.0f64; 2], [0.0f64; 2]);
    for k in 0..t.len() {
        let (dv, da) = (w * (w * t[k]).cos(), -w * w * (w * t[k]).sin());
        let end = usize::from(k < 4 || k + 4 >= t.len());
        ev[end] = ev[end].max((v[k] - dv).abs() / w);
        ea[end] = ea[end].max((a[k] - da).abs() / (w * w));
    }
    eprintln!("relative errors inside / near the ends: v {ev:?}, a {ea:?}");
    assert!(
        ev[0] < 1e-5 && ea[0] < 1e-4,
        "inside: v {}, a {}",
        ev[0],
        ea[0]
    );
    assert!(
        ev[1] < 1e-3 && ea[1] < 1e-2,
        "near the ends: v {}, a {}",
        ev[1],
        ea[1]
    );
    let err = |t: &[f64], x: &[f64]| quintic(t, x, End::Free, End::Free).unwrap_err().to_string();
    assert!(err(&[0.0], &[1.0]).contains("at least 2 samples"));
    assert!(err(&[0.0, 0.1], &[1.0]).contains("1 positions"));
    assert!(err(&[0.0, 0.1, 0.1], &[1.0, 2.0, 3.0]).contains("increase (sample 3)"));
    assert!(err(&[0.0, 0.1, 0.2], &[1.0, f64::NAN, 3.0]).contains("q[2] is NaN"));
}

/// Rest (1 s), a 1 s minimum-jerk move of 0.8 rad on joint 1 and 0.3 rad on joint 2,
/// rest (1 s), sampled at `rate` Hz with 1e-5 rad of encoder noise.
fn rest_move_rest(rate: f64) -> (Vec<f64>, Vec<Vec<f64>>, impl Fn(f64) -> [f64; 2]) {
    let mut rng = common::rng(3);
    let count = (3.0 * rate).round() as usize + 1;
    let t: Vec<f64> = (0..count).map(|k| k as f64 / rate).collect();
    let speed = |s: f64| {
        let u = (s - 1.0).clamp(0.0, 1.0);
        30.0 * u * u * (1.0 - u).powi(2)
    };
    let pos = |s: f64| {
        let u = (s - 1.0).clamp(0.0, 1.0);
        10.0 * u.powi(3) - 15.0 * u.powi(4) + 6.0 * u.powi(5)
    };
    let q = [0.8, 0.3]
        .iter()
        .map(|amp| {
            t.iter()
                .map(|&s| amp * pos(s) + 1e-5 * (rng.random_range(-1.0..1.0f64) * 3f64.sqrt()))
                .collect()
        })
        .collect();
    (t, q, move |s: f64| [0.8 * speed(s), 0.3 * speed(s)])
}

#[test]
fn spline_route_holds_rests_exactly_still_at_10_and_100_hz() {
    for rate in [10.0, 100.0] {
        let (t, q, speed) = rest_move_rest(rate);
        let s = from_spline(&t, &q).unwrap().states;
        let rest = rest_intervals(&t, &q);
        for (k, &tk) in t.iter().enumerate() {
            let in_rest = (k > 0 && rest[k - 1]) || (k + 1 < t.len() && rest[k]);
            // Well inside a rest (the noise must not pass for motion) and well inside the
            // move (its samples must not pass for rest).
            if !(0.9..=2.1).contains(&tk) {
                assert!(in_rest, "{rate} Hz: sample at {tk} s not at rest");
                for i in 0..2 {
                    assert_eq!((s.dq[i][k], s.ddq[i][k]), (0.0, 0.0));
                    let first = if tk < 1.0 { 0 } else { t.len() - 1 };
                    assert_eq!(s.q[i][k], s.q[i][first], "held still");
                }
            }
            if (1.1..=1.9).contains(&tk) {
                assert!(!in_rest, "{rate} Hz: sample at {tk} s at rest");
                for i in 0..2 {
                    let want = speed(tk)[i];
                    // 10 Hz: the rest-to-rest spline follows the minimum-jerk move; 100 Hz:
                    // the interpolating spline differentiates the noise too.
                    let tol = if rate < 20.0 { 0.01 } else { 0.02 };
                    assert!(
                        (s.dq[i][k] - want).abs() < tol * 1.875 * [0.8, 0.3][i],
                        "{rate} Hz, joint {}, {tk} s: {} vs {want}",
                        i + 1,
                        s.dq[i][k]
                    );
                }
            }
        }
    }
    let err = from_spline(&[0.0], &[vec![1.0]]).unwrap_err().to_string();
    assert!(err.contains("at least 2 samples"), "{err}");
    let err = from_spline(&[0.0, 0.1], &[vec![1.0, f64::INFINITY]])
        .unwrap_err()
        .to_string();
    assert!(err.contains("q1[2] is inf"), "{err}");
}
#[test]
fn spline_route_log_ends_run_on_or_start_at_rest_as_the_samples_show() {
    use powertwin::identification::states::unsupported_end_speed;
    // A log that begins in mid-motion: the free end follows the motion on (speed 1.2 rad/s
    // at the first sample, 0.7 at the last).
    let t: Vec<f64> = (0..30).map(|k| k as f64 * 0.1).collect();
    let q0 = |s: f64| 1.2 * s - 0.25 * s * s + 0.05 * s.powi(3);
    let dq = |s: f64| 1.2 - 0.5 * s + 0.15 * s * s;
    let s = from_spline(&t, &[t.iter().map(|&s| q0(s)).collect()])
        .unwrap()
        .states;
    for k in [0, t.len() - 1] {
        assert!(
            (s.dq[0][k] - dq(t[k])).abs() < 1e-3,
            "{}: {}",
            t[k],
            s.dq[0][k]
        );
    }
    // A log that begins as the motion starts from rest, a joint held by stiction for the
    // first 60 ms: its first interval moves far less than the quartic through the first
    // samples extrapolates, so the route starts at rest instead of backwards.
    let start = |s: f64| {
        let u = (s - 0.06).max(0.0);
        2.0 * u.powi(3) - 0.8 * u.powi(4)
    };
    let x: Vec<f64> = t.iter().map(|&s| start(s)).collect();
    let free = quintic(&t, &x, End::Free, End::Free).unwrap().0[0];
    assert!(
        unsupported_end_speed(free, x[1] - x[0], 0.1),
        "free end {free}"
    );
    let s = from_spline(&t, &[x]).unwrap().states;
    assert_eq!((s.dq[0][0], s.ddq[0][0]), (0.0, 0.0));
    // A log that begins as the robot starts from rest at its first sample, jerk-limited
    // on one joint (20 rad/s^3 for 0.2 s, then constant acceleration) and at constant
    // acceleration on another: the free end's quartic through the first samples would
    // start it moving, but the second interval moving the joints several times as far
    // as the first shows the start, so the route starts at rest. Already moving at a
    // quarter of the speed gained per sample, the robot is not taken for starting from
    // rest.
    use powertwin::identification::states::{START_FROM_REST_RATIO, starts_from_rest};
    let (j, ramp) = (20.0, 0.2);
    let jerk: Vec<f64> = t
        .iter()
        .map(|&s| match s {
            s if s < ramp => j * s.powi(3) / 6.0,
            s => {
                let u = s - ramp;
                j * (ramp.powi(3) / 6.0 + ramp * ramp * u / 2.0 + ramp * u * u / 2.0)
            }
        })
        .collect();
    let accel: Vec<f64> = t.iter().map(|&s| 0.3 * s * s).collect();
    let free = quintic(&t, &jerk, End::Free, End::Free).unwrap().0[0];
    assert!(free > 0.02, "free end {free}");
    assert!(!unsupported_end_speed(free, jerk[1] - jerk[0], 0.1));
    let q = vec![jerk, accel];
    assert!(starts_from_rest(&t, &q));
    let s = from_spline(&t, &q).unwrap().states;
    for i in 0..2 {
        assert_eq!((s.dq[i][0], s.ddq[i][0]), (0.0, 0.0), "joint {}", i + 1);
        assert!(s.dq[i][3] > 0.0, "joint {} moves on", i + 1);
    }
    let a = 0.6;
    let moving: Vec<f64> = t
        .iter()
        .map(|&s| 0.25 * a * 0.1 * s + 0.5 * a * s * s)
        .collect();
    let ratio = (moving[2] - moving[1]) / (moving[1] - moving[0]);
    assert!(ratio < START_FROM_REST_RATIO && ratio > 2.0, "{ratio}");
    assert!(!starts_from_rest(&t, &[moving]));
    assert!(!starts_from_rest(&t, &[t.iter().map(|&s| q0(s)).collect()]));
    assert!(!starts_from_rest(&t[..2], &[vec![0.0, 0.0]]));
    // Uneven sampling: a robot at constant speed logged at 0, 0.05 and 0.2 s.
    assert!(!starts_from_rest(
        &[0.0, 0.05, 0.2],
        &[vec![0.0, 0.05, 0.2]]
    ));
    // Supported: moving on at the free end's speed, or reversing within the interval.
    assert!(!unsupported_end_speed(1.0, 0.1, 0.1));
    assert!(!unsupported_end_speed(-1.0, -0.06, 0.1));
    assert!(unsupported_end_speed(1.0, 0.04, 0.1));
    assert!(unsupported_end_speed(-0.3, 0.001, 0.1));
    assert!(!unsupported_end_speed(0.0, 0.0, 0.1));
}

#[test]
fn spline_route_weighs_down_the_coulomb_sign_of_a_joint_standing_still() {
    // 10 Hz, 1e-5 rad of encoder noise (uniform), 12 s. Joint 1 swings throughout; joint 2
    // swings for 6 s and then stands still (held by stiction); joint 3 creeps at 2e-3
    // rad/s throughout; the robot rests for the last 2 s.
    let mut rng = common::rng(5);
    let mut noise = || 1e-5 * 3f64.sqrt() * rng.random_range(-1.0..1.0f64);
    let t: Vec<f64> = (0..=120).map(|k| k as f64 * 0.1).collect();
    let moving = |s: f64| s.min(10.0);
    let q: Vec<Vec<f64>> = vec![
        t.iter()
            .map(|&s| 0.5 * (1.0 - (0.6 * moving(s)).cos()) + noise())
            .collect(),
        t.iter()
            .map(|&s| 0.3 * (1.0 - (0.5 * s.min(2.0 * std::f64::consts::PI)).cos()) + noise())
            .collect(),
        t.iter().map(|&s| 2e-3 * moving(s) + noise()).collect(),
    ];
    let route = from_spline(&t, &q).unwrap();
    let w = &route.move_weights;
    assert_eq!(route.knots.t.len(), w[0].len());
    let at = |i: usize, time: f64| {
        let k = route
            .knots
            .t
            .iter()
            .position(|&x| (x - time).abs() < 1e-9)
            .unwrap();
        w[i][k]
    };
    let samples = |from: f64, to: f64| t.iter().copied().filter(move |&s| s >= from && s <= to);
    // Moving joints, the creeping one included, count fully: the slope over three
    // samples is many standard deviations of the noise's.
    for s in samples(0.3, 9.7) {
        assert_eq!(at(0, s), 1.0, "joint 1 at {s} s");
        assert_eq!(at(2, s), 1.0, "joint 3 at {s} s");
    }
    // The joint standing still among moving ones: weight 0 at most of its samples (noise
    // alone stays within 2 standard deviations 95 % of the time).
    let still: Vec<f64> = samples(6.8, 9.7).map(|s| at(1, s)).collect();
    let mean = still.iter().sum::<f64>() / still.len() as f64;
    assert!(mean < 0.15, "mean weight {mean} over {still:?}");
    assert!(still.iter().filter(|&&x| x == 0.0).count() * 4 >= still.len() * 3);
    // While it swings it counts fully.
    assert!(samples(0.5, 2.5).all(|s| at(1, s) == 1.0));
    // At the rest the route's speed is 0 and the weight 1 (no weight falling across the
    // interval next to a rest).
    for s in samples(10.5, 12.0) {
        assert_eq!(
            route.knots.dq[0][route.knots.t.iter().position(|&x| x == s).unwrap()],
            0.0
        );
        assert_eq!(at(0, s), 1.0);
    }
    // Without noise (the rests show none): any slope but 0 is a motion, even 1e-5 rad/s.
    let exact: Vec<Vec<f64>> = vec![
        t.iter()
            .map(|&s| 0.5 * (1.0 - (0.6 * moving(s)).cos()))
            .collect(),
        t.iter().map(|&s| 0.3 + 1e-5 * moving(s)).collect(),
        t.iter()
            .map(|&s| if s < 6.0 { 0.2 * s } else { 1.2 })
            .collect(),
    ];
    let route = from_spline(&t, &exact).unwrap();
    let k = |time: f64| {
        route
            .knots
            .t
            .iter()
            .position(|&x| (x - time).abs() < 1e-9)
            .unwrap()
    };
    for s in samples(0.3, 9.7) {
        assert_eq!(route.move_weights[1][k(s)], 1.0, "creeping joint at {s} s");
    }
    for s in samples(6.3, 9.7) {
        assert_eq!(route.move_weights[2][k(s)], 0.0, "still joint at {s} s");
    }
}

#[test]
fn spline_route_leaves_and_reaches_rests_inside_sample_intervals() {
    // A 1 s minimum-jerk move (it leaves and reaches rest as (t - t0)^3, like a
    // jerk-limited plan) of 1.2 and 0.4 rad, logged at 10 Hz with 1e-5 rad of encoder
    // noise. (start, stop) = (1.08, 2.08): the start 20 ms before a sample (which has
    // moved 1e-4 rad, within the rest test), the stop 20 ms before the next rest sample;
    // (1.12, 2.12): the start 20 ms after a sample, the stop 20 ms after one (which is
    // 1e-4 rad short of the rest).
    let mut rng = common::rng(11);
    for (start, stop) in [(1.08, 2.08), (1.12, 2.12)] {
        let t: Vec<f64> = (0..=32).map(|k| k as f64 * 0.1).collect();
        let pos = |s: f64| {
            let u = ((s - start) / (stop - start)).clamp(0.0, 1.0);
            10.0 * u.powi(3) - 15.0 * u.powi(4) + 6.0 * u.powi(5)
        };
        let q: Vec<Vec<f64>> = [1.2, 0.4]
            .iter()
            .map(|amp| {
                t.iter()
                    .map(|&s| amp * pos(s) + 1e-5 * 3f64.sqrt() * rng.random_range(-1.0..1.0f64))
                    .collect()
            })
            .collect();
        let route = from_spline(&t, &q).unwrap();
        // The route leaves and reaches the rests within 10 ms of the move (the law is exact
        // for a cubic; the minimum-jerk move departs from it by 80-180 ms from its ends),
        // at rest there;
        // the knots are the samples and those two instants.
        let k = &route.knots;
        assert_eq!(k.len(), t.len() + 2, "{start} s: knots {:?}", k.t);
        let extra: Vec<usize> = (0..k.len())
            .filter(|&j| !t.iter().any(|&s| s == k.t[j]))
            .collect();
        assert_eq!(extra.len(), 2);
        for (&j, want) in extra.iter().zip([start, stop]) {
            assert!(
                (k.t[j] - want).abs() < 1e-2,
                "{start} s move: knot at {} s, the move at {want} s",
                k.t[j]
            );
            assert_eq!((k.dq[0][j], k.ddq[0][j]), (0.0, 0.0));
        }
        // Every sample inside the move moves forward; every sample outside stands still,
        // held at its rest.
        let s = &route.states;
        for (m, &tm) in t.iter().enumerate() {
            if tm > start && tm < stop {
                assert!(s.dq[0][m] > 0.0, "{start} s move, {tm} s: {}", s.dq[0][m]);
            } else {
                assert_eq!(s.dq[0][m], 0.0, "{start} s move, {tm} s");
                let held = if tm < start { s.q[0][0] } else { s.q[0][32] };
                assert_eq!(s.q[0][m], held, "{start} s move, {tm} s");
            }
        }
    }
    // Joints that do not start together: joint 1 creeps off the rest from 1.0 s, joint 2
    // (the larger motion) starts at 1.15 s. Joint 1, clearly moved at 1.1 s, keeps the
    // route from leaving the rest inside (1.0, 1.1) s, where the joints' pooled ratio
    // would put it (at 1.05 s, hurrying joint 1).
    let t: Vec<f64> = (0..=20).map(|k| k as f64 * 0.1).collect();
    let q = vec![
        t.iter()
            .map(|&s| 5e-3 * (s - 1.0).max(0.0))
            .collect::<Vec<_>>(),
        t.iter()
            .map(|&s| 20.0 * (s - 1.15).max(0.0).powi(3))
            .collect(),
    ];
    let route = from_spline(&t, &q).unwrap();
    assert_eq!(route.knots.t, t, "no knot inside a sample interval");
}

#[test]
fn spline_route_knots_are_a_valid_route_for_any_log() {
    // Random logs of 1-3 joints: rests and minimum-jerk moves of random lengths and
    // amplitudes (some below the noise), logged at 10-1000 Hz with jittered clocks and
    // 0-3e-5 rad of noise. The route's knots must hold every sample time, increase
    // strictly, be finite and at rest wherever they are not samples, and interpolate.
    use powertwin::trajectory::sampled::Sampled;
    let mut rng = common::rng(21);
    let mut inside = 0;
    for case in 0..300 {
        let rate = [10.0, 10.0, 25.0, 100.0, 1000.0][case % 5];
        let n = 1 + case % 3;
        let noise = [0.0, 1e-5, 3e-5][case % 3];
        // Segments: (duration s, moves?).
        let mut segments = Vec::new();
        let mut total = 0.0;
        while total < 3.0 {
            let d: f64 = rng.random_range(0.05..1.2);
            segments.push((total, d, rng.random_range(0.0..1.0) < 0.5));
            total += d;
        }
        let amps: Vec<Vec<f64>> = segments
            .iter()
            .map(|_| {
                (0..n)
                    .map(|_| rng.random_range(-0.5..0.5f64).powi(3))
                    .collect()
            })
            .collect();
        let pos = |s: f64, i: usize| {
            let mut x = 0.0;
            for ((t0, d, moves), amp) in segments.iter().zip(&amps) {
                if *moves && s > *t0 {
                    let u = ((s - t0) / d).min(1.0);
                    x += amp[i] * (10.0 * u.powi(3) - 15.0 * u.powi(4) + 6.0 * u.powi(5));
                }
            }
            x
        };
        let mut t = vec![0.0];
        while *t.last().unwrap() < total {
            let h = (1.0 + rng.random_range(-0.3..0.3)) / rate;
            t.push(t.last().unwrap() + h);
        }
        let q: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                t.iter()
                    .map(|&s| pos(s, i) + noise * rng.random_range(-1.7..1.7))
                    .collect()
            })
            .collect();
        let route = from_spline(&t, &q).unwrap_or_else(|e| panic!("case {case}: {e}"));
        let k = &route.knots;
        assert_eq!(route.states.t, t, "case {case}");
        assert!(
            k.t.windows(2).all(|w| w[1] > w[0]),
            "case {case}: {:?}",
            k.t
        );
        let mut samples = 0;
        for (j, &at) in k.t.iter().enumerate() {
            let on_sample = t.get(samples) == Some(&at);
            for i in 0..n {
                assert!(
                    k.q[i][j].is_finite() && k.dq[i][j].is_finite(),
                    "case {case}"
                );
                if !on_sample {
                    assert_eq!((k.dq[i][j], k.ddq[i][j]), (0.0, 0.0), "case {case}");
                }
            }
            samples += usize::from(on_sample);
        }
        assert_eq!(samples, t.len(), "case {case}: every sample time is a knot");
        inside += k.len() - t.len();
        Sampled::new(
            k.t.clone(),
            k.q.clone(),
            Some(k.dq.clone()),
            Some(k.ddq.clone()),
        )
        .unwrap_or_else(|e| panic!("case {case}: {e}"));
    }
    assert!(
        inside >= 100,
        "{inside} starts and stops inside sample intervals"
    );
}

#[test]
fn jerk_gram_and_the_smoothing_spline() {
    use powertwin::identification::spline::{jerk_gram, smooth};
    // Rest to rest over h: the minimum-jerk profile's squared jerk is 720 dx^2 / h^5; a
    // parabola has none.
    let h = 0.3;
    let g = jerk_gram(h);
    let p = nalgebra::SVector::<f64, 6>::from_column_slice(&[0.0, 0.0, 0.0, 2.0, 0.0, 0.0]);
    assert!(((p.transpose() * g * p)[(0, 0)] - 720.0 * 4.0 / h.powi(5)).abs() < 1e-6);
    let p = nalgebra::SVector::<f64, 6>::from_column_slice(&[0.0, 0.0, 2.0, h * h, 2.0 * h, 2.0]);
    assert!((p.transpose() * g * p)[(0, 0)].abs() < 1e-6);
    // A 100 Hz sine with 1e-5 rad of white noise: the smoothed positions leave residuals of
    // the noise level, and their spline's accelerations are far closer to the truth than
    // the interpolating spline's.
    let mut rng = common::rng(4);
    let w = std::f64::consts::TAU * 0.5;
    let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.01).collect();
    let truth: Vec<f64> = t.iter().map(|s| (w * s).sin()).collect();
    let y: Vec<f64> = truth
        .iter()
        .map(|v| v + 1e-5 * 3f64.sqrt() * rng.random_range(-1.0..1.0f64))
        .collect();
    let x = smooth(&t, &y, End::Free, End::Free, 1e-5).unwrap();
    let rms = |a: &[f64], b: &[f64]| {
        (a.iter().zip(b).map(|(p, q)| (p - q).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
    };
    assert!((rms(&x, &y) - 1e-5).abs() < 1e-8, "{}", rms(&x, &y));
    assert!(rms(&x, &truth) < 0.7e-5, "{}", rms(&x, &truth));
    let acc_err = |x: &[f64]| {
        let (_, a) = quintic(&t, x, End::Free, End::Free).unwrap();
        let inner = 20..t.len() - 20;
        let want: Vec<f64> = t[inner.clone()]
            .iter()
            .map(|s| -w * w * (w * s).sin())
            .collect();
        rms(&a[inner], &want)
    };
    let (smoothed, raw) = (acc_err(&x), acc_err(&y));
    eprintln!("acceleration error RMS: smoothed {smoothed:.4}, interpolated {raw:.4} rad/s^2");
    assert!(smoothed < 0.1 * raw, "{smoothed} vs {raw}");
    // No noise, no smoothing; rest ends keep their samples; bad input is refused.
    assert_eq!(smooth(&t, &y, End::Free, End::Free, 0.0).unwrap(), y);
    let x = smooth(&t, &y, End::Rest, End::Rest, 1e-5).unwrap();
    assert_eq!((x[0], x[399]), (y[0], y[399]));
    let e = smooth(&t, &y, End::Free, End::Free, -1.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("noise level -1"), "{e}");
}

#[test]
fn encoder_noise_from_the_rests_or_from_white_differences() {
    use powertwin::identification::states::noise_levels;
    // Rest-move-rest: the rests show the encoders alone (1e-5 rad, uniform noise).
    for rate in [10.0, 100.0] {
        let (t, q, _) = rest_move_rest(rate);
        let s = noise_levels(&t, &q, &rest_intervals(&t, &q));
        assert!(
            s.iter().all(|s| (s / 1e-5 - 1.0).abs() < 0.35),
            "{rate} Hz: {s:?}"
        );
    }
    // No rest: a 10 Hz log resolves a smooth motion far above the noise (interpolate);
    // at 1 kHz the samples are white noise at high orders.
    let wave = |rate: f64| -> Vec<Vec<f64>> {
        let mut rng = common::rng(5);
        let x = (0..(4.0 * rate) as usize)
            .map(|k| {
                let s = k as f64 / rate;
                (1.3 * s).sin() + 1e-5 * 3f64.sqrt() * rng.random_range(-1.0..1.0f64)
            })
            .collect();
        vec![x]
    };
    let none = |q: &[Vec<f64>]| vec![false; q[0].len() - 1];
    // Evenly spaced times (the plain differences; their spacing does not matter).
    let even = |m: usize| -> Vec<f64> { (0..m).map(|k| k as f64).collect() };
    assert_eq!(
        noise_levels(&even(40), &wave(10.0), &none(&wave(10.0))),
        vec![0.0]
    );
    let fast = wave(1000.0);
    let s = noise_levels(&even(4000), &fast, &none(&fast))[0];
    assert!((s / 1e-5 - 1.0).abs() < 0.2, "{s}");
    // Joint by joint: a 10 Hz joint that only jitters (white, 5e-4 rad) beside one that
    // moves smoothly keeps its level to itself; the smooth joint is interpolated.
    let mut rng = common::rng(6);
    let smooth: Vec<f64> = (0..200).map(|k| (0.13 * k as f64).sin()).collect();
    let jitter: Vec<f64> = (0..200)
        .map(|_| 5e-4 * 3f64.sqrt() * rng.random_range(-1.0..1.0f64))
        .collect();
    let both = vec![smooth, jitter];
    let s = noise_levels(&even(200), &both, &none(&both));
    assert_eq!(s[0], 0.0, "{s:?}");
    assert!((s[1] / 5e-4 - 1.0).abs() < 0.5, "{s:?}");
    // A 1 kHz motion with 1e-5 rad of noise that ends in a short rest whose 22 samples
    // happen to scatter by only 0.7e-5: the motion's 4000 samples show the noise far
    // better, and the two are pooled (the rest alone left the spline under-smoothed).
    let mut rng = common::rng(7);
    let mut x: Vec<f64> = (0..4000)
        .map(|k| (1.3e-3 * k as f64).sin() + 1e-5 * 3f64.sqrt() * rng.random_range(-1.0..1.0))
        .collect();
    let held = (5.2f64).sin();
    x.extend((0..22).map(|_| held + 0.7e-5 * 3f64.sqrt() * rng.random_range(-1.0..1.0)));
    let mut rest = vec![false; x.len() - 1];
    rest[4000..].fill(true);
    let s = noise_levels(&even(x.len()), &[x], &rest)[0];
    assert!((s / 1e-5 - 1.0).abs() < 0.08, "{s}");
    // A 250 Hz motion with 2.6e-5 rad of noise that starts from a rest of three samples
    // scattering by only 0.4 of that: 2 degrees of freedom allow a ratio of up to 10 at
    // 1 %, so the motion's samples are pooled with it (the rest alone put a family robot's
    // shoulder at half its noise, and its power RMSE at 9.8 W instead of 2.0 W).
    let mut rng = common::rng(9);
    let sigma = 2.6e-5;
    let mut x = vec![0.3 - 0.4 * sigma, 0.3, 0.3 + 0.4 * sigma];
    x.extend((1..1000).map(|k| {
        let s = k as f64 / 250.0;
        0.3 + 0.5 * (1.0 - (2.0 * s).cos()) + sigma * 3f64.sqrt() * rng.random_range(-1.0..1.0)
    }));
    let mut rest = vec![false; x.len() - 1];
    rest[..2].fill(true);
    let s = noise_levels(&even(x.len()), &[x], &rest)[0];
    assert!((s / sigma - 1.0).abs() < 0.1, "{s}");
    // At 10 Hz, a joint that jitters while the others move (5e-4 rad, white) does not
    // pool with its encoder noise at rest (1e-5 rad): the rest decides.
    let mut rng = common::rng(8);
    let mut x: Vec<f64> = (0..200)
        .map(|_| 5e-4 * 3f64.sqrt() * rng.random_range(-1.0..1.0f64))
        .collect();
    x.extend((0..10).map(|_| 1e-5 * 3f64.sqrt() * rng.random_range(-1.0..1.0f64)));
    let mut rest = vec![false; x.len() - 1];
    rest[200..].fill(true);
    let s = noise_levels(&even(x.len()), &[x], &rest)[0];
    assert!(s < 2e-5, "{s}");
}
#[test]
fn an_averaging_logger_gets_the_states_of_its_windows() {
    use powertwin::identification::data::{Route, prepare};
    use powertwin::measurement::{Log, PowerSignal};
    // q = 0.5 sin(w t) at 10 Hz.
    let w = std::f64::consts::TAU * 0.4;
    let t: Vec<f64> = (0..60).map(|k| k as f64 * 0.1).collect();
    let log = |averaged: bool| Log {
        source: "sine".into(),
        robot: None,
        q_rad: vec![t.iter().map(|s| 0.5 * (w * s).sin()).collect()],
        t_s: t.clone(),
        dq_rad_s: None,
        power_w: vec![0.0; t.len()],
        signal: PowerSignal::Total,
        motor_power_w: None,
        power_averaged: averaged,
        payloads: Vec::new(),
    };
    for averaged in [false, true] {
        let p = prepare(&log(averaged), Route::Spline).unwrap();
        assert_eq!(p.states.t, t);
        // An averaged sample's power belongs to the middle of its period (the first
        // sample's period precedes the log: its own time).
        for (k, &tk) in t.iter().enumerate().skip(1) {
            let at = if averaged { tk - 0.05 } else { tk };
            let (q, dq) = (0.5 * (w * at).sin(), 0.5 * w * (w * at).cos());
            assert!((p.states.q[0][k] - q).abs() < 1e-4, "{averaged} {k}");
            assert!((p.states.dq[0][k] - dq).abs() < 2e-3 * w, "{averaged} {k}");
        }
    }
}

/// The payload a log starts with is the one its identification takes before the first
/// sample (where the power lag and an averaging meter's first period reach); a payload
/// added later is taken from its own time.
#[test]
fn a_log_holds_the_payload_it_starts_with_before_its_first_sample() {
    use powertwin::identification::data::{Route, prepare};
    use powertwin::measurement::{Log, PowerSignal};
    use powertwin::model::builtin;
    use powertwin::model::payload::PayloadEvent;
    let t: Vec<f64> = (0..60).map(|k| 0.002 + k as f64 * 0.1).collect();
    let log = |from_s: f64| Log {
        source: "sine".into(),
        robot: None,
        q_rad: vec![t.iter().map(|s| 0.5 * (2.5 * s).sin()).collect()],
        t_s: t.clone(),
        dq_rad_s: None,
        power_w: vec![0.0; t.len()],
        signal: PowerSignal::Total,
        motor_power_w: None,
        power_averaged: true,
        payloads: vec![PayloadEvent {
            t_s: from_s,
            payload: Some(builtin::payload("load_2kg").unwrap()),
        }],
    };
    let from = |from_s: f64| prepare(&log(from_s), Route::Spline).unwrap().payloads[0].t_s;
    assert_eq!(from(0.0), f64::NEG_INFINITY);
    assert_eq!(from(3.0), 3.0);
}
