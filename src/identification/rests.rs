//! Where a log stands still, and how noisy its encoders are: the rests the spline route
//! ([`super::states::from_spline`]) holds exactly still, and the encoder noise its smoothing
//! and its edge tests are weighed by.

use crate::identification::tuning::{AGREED_NOISE_RATIO, EDGE_Z, WHITE_RATIO};
use crate::numerics::scaled_divided_differences;

/// Joint speed (rad/s) below which the robot counts as standing still: ten times the
/// velocity noise that 1e-5 rad of encoder noise gives at 10 Hz.
pub const REST_SPEED: f64 = 1e-3;

/// Shortest span (s) over which rest is judged: every joint moves less than
/// `REST_SPEED x REST_WINDOW_S` (1e-4 rad, seven standard deviations of the difference of two
/// samples with 1e-5 rad of encoder noise) within it. At 10 Hz that is one sample period; a
/// faster log is judged over as many samples, so the noise never passes for motion.
pub const REST_WINDOW_S: f64 = 0.1;

/// Which sample intervals `[t_k, t_k+1]` the robot stands still in: those inside a span of
/// at least [`REST_WINDOW_S`] (or one sample period, if longer) over which every joint's
/// positions stay within [`REST_SPEED`] times the span.
pub fn rest_intervals(t: &[f64], q: &[Vec<f64>]) -> Vec<bool> {
    let m = t.len();
    let mut rest = vec![false; m.saturating_sub(1)];
    for a in 0..m.saturating_sub(1) {
        let b = (a + 1..m)
            .find(|&b| t[b] - t[a] >= REST_WINDOW_S * (1.0 - 1e-9))
            .unwrap_or(m - 1);
        let bound = REST_SPEED * (t[b] - t[a]).max(REST_WINDOW_S);
        let still = q.iter().all(|qi| {
            let w = &qi[a..=b];
            let (lo, hi) = w
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(*v), hi.max(*v))
                });
            hi - lo <= bound
        });
        if still {
            rest[a..b].fill(true);
        }
    }
    rest
}

/// Least encoder noise (rad) assumed when weighing an edge's shift: a noise-free log (the
/// twin without sensor noise) holds its rests to rounding.
pub(super) const EDGE_SIGMA_FLOOR: f64 = 1e-9;

/// Encoder noise of each joint (rad) judged from the rests' sample-to-sample steps, robustly:
/// `1.4826 median |x_k+1 - x_k| / sqrt(2)` over the intervals at rest. Unlike the pooled
/// scatter of [`noise_levels`], it ignores the few steps at a rest's edges where the robot
/// still (or already) moves, which inflate the pooled scatter of short rests
/// (docs/experiments.md#encoder-noise-levels). Zero without rests.
pub(super) fn rest_jitter(q: &[Vec<f64>], rest: &[bool]) -> Vec<f64> {
    q.iter()
        .map(|x| {
            let mut steps: Vec<f64> = rest
                .iter()
                .enumerate()
                .filter(|r| *r.1)
                .map(|(k, _)| (x[k + 1] - x[k]).abs())
                .collect();
            if steps.is_empty() {
                return 0.0;
            }
            steps.sort_by(f64::total_cmp);
            1.4826 * steps[steps.len() / 2] / std::f64::consts::SQRT_2
        })
        .collect()
}

/// Join to the rests next to it every stretch between two rests, or between a rest and the
/// log's end ([`rest_intervals`]), in which no joint is seen to move: each of its samples, and
/// each rest's mean, within [`EDGE_Z`] standard deviations of the encoder noise
/// ([`rest_jitter`]) of the rests' mean. A fast log's noise can span the rest test's bound
/// over [`REST_WINDOW_S`] and break a long rest in pieces; a spline through the pieces invents
/// a motion, and accelerations, that the samples do not show.
pub(super) fn join_still_gaps(q: &[Vec<f64>], rest: &mut [bool]) {
    let sigma = rest_jitter(q, rest);
    let parts = stretches(rest);
    for (p, &(still, g0, g1)) in parts.iter().enumerate() {
        // The rests next to the stretch (samples `a..=b`) and the stretch's own samples.
        let before = p.checked_sub(1).map(|k| (parts[k].1, parts[k].2));
        let after = parts.get(p + 1).map(|r| (r.1, r.2));
        if still || (before.is_none() && after.is_none()) {
            continue;
        }
        let own = before.map_or(g0, |_| g0 + 1)..after.map_or(g1 + 1, |_| g1);
        let joined = q.iter().zip(&sigma).all(|(x, s)| {
            let means: Vec<(f64, f64)> = [before, after]
                .iter()
                .flatten()
                .map(|&(a, b)| {
                    let w = &x[a..=b];
                    (w.iter().sum::<f64>(), w.len() as f64)
                })
                .collect();
            let (sum, count) = means
                .iter()
                .fold((0.0, 0.0), |(s, c), m| (s + m.0, c + m.1));
            let mean = sum / count;
            let bound = EDGE_Z * s.max(EDGE_SIGMA_FLOOR);
            means
                .iter()
                .map(|m| m.0 / m.1)
                .chain(x[own.clone()].iter().copied())
                .all(|v| (v - mean).abs() <= bound)
        });
        if joined {
            rest[g0..g1].fill(true);
        }
    }
}

/// Degrees of freedom (samples in rests less one per rest) from which [`noise_levels`] takes
/// the encoder noise from the rests.
pub const MIN_REST_DOF: usize = 2;

/// Orders of the differences [`noise_levels`] estimates white noise from when the log has too
/// little rest. White noise gives the same estimate at every order; a motion the sampling
/// resolves gives estimates that fall with the order.
pub const DIFFERENCE_ORDERS: [usize; 3] = [4, 6, 8];

/// Largest spread of a log's sample intervals, relative to their mean, for which
/// [`noise_levels`] takes its differences as those of equally spaced samples (the plain
/// `p`-th differences); beyond it, the divided differences at the logged times. Stamps
/// printed to the microsecond at 1 kHz stay well within it.
pub const EVEN_STEP_TOLERANCE: f64 = 1e-6;

/// Whether the sample times `t` (s, increasing) are equally spaced to within
/// [`EVEN_STEP_TOLERANCE`] of their mean interval.
fn evenly_spaced(t: &[f64]) -> bool {
    if t.len() < 3 {
        return true;
    }
    let h = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    t.windows(2)
        .all(|w| ((w[1] - w[0]) - h).abs() <= EVEN_STEP_TOLERANCE * h)
}

/// Robust standard deviation of white noise from the `p`-th differences of the samples `x`
/// (rad) at times `t` (s, increasing): `1.4826 median|d_k|`, where `d_k` is the `p`-th
/// difference over the samples `k..=k+p` scaled to unit variance under white noise of unit
/// standard deviation. Evenly spaced samples ([`evenly_spaced`]): `Δ^p x / sqrt(C(2p, p))`.
/// Otherwise the divided differences at the logged times ([`scaled_divided_differences`]),
/// which, like `Δ^p`, are blind to polynomials of degree below `p`: a smooth motion sampled
/// at uneven times but taken as evenly spaced has large differences that look like white
/// noise, and the smoothing spline would flatten the motion to that level
/// (docs/experiments.md#logs-sampled-at-uneven-times). `None` for too few samples.
fn difference_sigma(t: &[f64], x: &[f64], p: usize) -> Option<f64> {
    if x.len() <= p + 2 {
        return None;
    }
    if evenly_spaced(t) {
        let mut d = x.to_vec();
        for _ in 0..p {
            d = d.windows(2).map(|w| w[1] - w[0]).collect();
        }
        let mut a: Vec<f64> = d.iter().map(|v| v.abs()).collect();
        a.sort_by(f64::total_cmp);
        let binom = (1..=p).fold(1.0, |c, k| c * (p + k) as f64 / k as f64);
        return Some(1.4826 * a[a.len() / 2] / binom.sqrt());
    }
    let mut a: Vec<f64> = scaled_divided_differences(t, x, p)
        .iter()
        .map(|d| d.abs())
        .collect();
    a.sort_by(f64::total_cmp);
    Some(1.4826 * a[a.len() / 2])
}

/// Maximal stretches of equal `rest` flags (one per sample interval) as `(at rest, first,
/// last)` with the sample range `first..=last`.
pub(super) fn stretches(rest: &[bool]) -> Vec<(bool, usize, usize)> {
    let mut out = Vec::new();
    let mut k = 0;
    while k < rest.len() {
        let (still, first) = (rest[k], k);
        while k < rest.len() && rest[k] == still {
            k += 1;
        }
        out.push((still, first, k));
    }
    out
}

/// Encoder noise of each joint's positions `q[i][m]`, rad, sampled at times `t` (s,
/// increasing; the differences are taken at them), given the [`rest_intervals`] `rest`.
/// With rests holding at least [`MIN_REST_DOF`] degrees of freedom: the scatter of
/// each joint's samples about each rest's mean, pooled over the rests, and where the joint's
/// differences also look like white noise no larger than [`AGREED_NOISE_RATIO`] times that
/// (or than the rests' sampling error allows, for rests of few samples:
/// `rest_sampling_ratio`), both pooled by their degrees of freedom (`white_sigma`). Otherwise from the differences
/// alone, joint by joint: where a joint's samples look like white noise, that estimate;
/// where they do not, zero (the sampling resolves the motion above the noise, and the spline
/// interpolates). Each joint keeps its own: a 10 Hz log whose wrist sticks and slips looks
/// white on that joint only, and handing that level to every joint smooths the others' ends
/// away (docs/experiments.md#encoder-noise-levels).
///
/// The smoothing spline brings its residual to this level ([`super::spline::smooth`]), so an
/// estimate a little low leaves the accelerations rough.
pub fn noise_levels(t: &[f64], q: &[Vec<f64>], rest: &[bool]) -> Vec<f64> {
    let rests = rest_spans(rest);
    let in_rests: usize = rests.iter().map(|(a, b)| b - a + 1).sum();
    if !rests_show_noise(rest) {
        // No rest to watch the encoders alone: each joint by its own differences.
        return q
            .iter()
            .map(|x| white_sigma(t, x).map_or(0.0, |w| w.0))
            .collect();
    }
    let rest_dof = (in_rests - rests.len()) as f64;
    q.iter()
        .map(|x| {
            let ss: f64 = rests
                .iter()
                .map(|&(a, b)| {
                    let w = &x[a..=b];
                    let mean = w.iter().sum::<f64>() / w.len() as f64;
                    w.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
                })
                .sum();
            let at_rest = (ss / rest_dof).sqrt();
            let agreed = AGREED_NOISE_RATIO.max(rest_sampling_ratio(rest_dof));
            match white_sigma(t, x) {
                Some((sigma, dof)) if sigma <= agreed * at_rest => {
                    ((rest_dof * at_rest * at_rest + dof * sigma * sigma) / (rest_dof + dof)).sqrt()
                }
                _ => at_rest,
            }
        })
        .collect()
}

/// Largest ratio of a noise level to its estimate from the scatter at rest, with `dof`
/// degrees of freedom, that the rests' sampling error allows at 1 %: `sqrt(dof / q)`, `q` the
/// chi-square distribution's 1 % quantile with `dof` degrees of freedom (tabulated up to 9,
/// the Wilson-Hilferty approximation above). A rest of three samples (2 degrees of freedom)
/// scatters by less than half the noise one time in five, and by a tenth one time in a
/// hundred; from 10 degrees of freedom the bound is below [`AGREED_NOISE_RATIO`].
fn rest_sampling_ratio(dof: f64) -> f64 {
    const QUANTILE_1PCT: [f64; 9] = [
        1.571e-4, 0.0201, 0.1148, 0.2971, 0.5543, 0.8721, 1.2390, 1.6465, 2.0879,
    ];
    let k = dof.max(1.0);
    let q = if k < 9.5 {
        QUANTILE_1PCT[k.round() as usize - 1]
    } else {
        // Wilson-Hilferty: (q / k)^(1/3) is about normal, mean 1 - 2 / (9 k), variance 2 / (9 k).
        let v = 2.0 / (9.0 * k);
        k * (1.0 - v - 2.3263 * v.sqrt()).powi(3)
    };
    (k / q).sqrt()
}

/// A joint's encoder noise (rad) from the differences of its samples `x` at times `t` (s;
/// [`difference_sigma`]), with the degrees of
/// freedom it stands for, where they look like white noise (the fourth order's estimate within
/// [`WHITE_RATIO`] of the eighth's): the least estimate over [`DIFFERENCE_ORDERS`]. The
/// degrees of freedom are those of the median absolute deviation (37 % efficient) of about
/// `len / 4` independent fourth differences. `None` for too few samples or a motion the
/// sampling resolves.
fn white_sigma(t: &[f64], x: &[f64]) -> Option<(f64, f64)> {
    let s: Vec<f64> = DIFFERENCE_ORDERS
        .iter()
        .map(|&p| difference_sigma(t, x, p))
        .collect::<Option<_>>()?;
    (s[0] <= WHITE_RATIO * s[2]).then(|| {
        (
            s.iter().copied().fold(f64::INFINITY, f64::min),
            0.37 * x.len() as f64 / DIFFERENCE_ORDERS[0] as f64,
        )
    })
}

/// The rests' first and last samples.
fn rest_spans(rest: &[bool]) -> Vec<(usize, usize)> {
    stretches(rest)
        .into_iter()
        .filter(|r| r.0)
        .map(|r| (r.1, r.2))
        .collect()
}

/// Whether the rests hold at least [`MIN_REST_DOF`] degrees of freedom, so that
/// [`noise_levels`] measures the encoders there.
pub(super) fn rests_show_noise(rest: &[bool]) -> bool {
    let rests = rest_spans(rest);
    rests.iter().map(|(a, b)| b - a + 1).sum::<usize>() >= rests.len() + MIN_REST_DOF
}
