//! Seeded random trajectories for bulk datasets.
//!
//! Both generators draw everything from the RNG they are given, so a seeded RNG (e.g.
//! `rand_chacha::ChaCha8Rng::seed_from_u64`) makes the result reproducible. Both stay inside
//! the position limits less a margin, below a fraction of the URDF velocity limits and of the
//! given acceleration limits, so [`check_limits`](super::limits::check_limits) passes with the
//! full limits. A joint without position limits (continuous) is kept within `[-pi, pi]`.

use std::f64::consts::PI;

use rand::{Rng, RngExt};

use crate::Robot;
use crate::error::{Error, Result};
use crate::model::Joint;

use super::fourier::{Fourier, solve_rest_harmonic};
use super::limits::IRB1200_ACCEL_LIMITS;
use super::point_to_point::{PointToPoint, PointToPointOptions};

/// Options of [`random_fourier`].
#[derive(Debug, Clone, PartialEq)]
pub struct RandomFourierOptions {
    /// Number of harmonics `N` (>= 2 when `rest` is set, else >= 1). Default 5 (paper).
    pub harmonics: usize,
    /// Base frequency, Hz. Default 0.1 (paper: period 10 s).
    pub base_freq_hz: f64,
    /// Number of periods (a whole number when `rest` is set). Default 1.
    pub periods: f64,
    /// Start and end at rest (zero velocity and acceleration) through
    /// [`Fourier::rest_constrained`]'s parametrisation. Default true.
    pub rest: bool,
    /// Distance kept from each position limit, rad (>= 0). Default 0.05.
    pub position_margin: f64,
    /// Fraction of the velocity and acceleration limits the trajectory may reach, in
    /// `(0, 1]`. Default 0.9.
    pub limit_fraction: f64,
    /// Per-joint acceleration limits, rad/s^2. Default [`IRB1200_ACCEL_LIMITS`].
    pub accel_limits: Vec<f64>,
    /// Smallest fraction of the largest admissible amplitude drawn per joint, in `[0, 1]`;
    /// each joint's amplitude scale is uniform in `[min_amplitude, 1]`. Default 0.25.
    pub min_amplitude: f64,
}

impl Default for RandomFourierOptions {
    fn default() -> Self {
        RandomFourierOptions {
            harmonics: 5,
            base_freq_hz: 0.1,
            periods: 1.0,
            rest: true,
            position_margin: 0.05,
            limit_fraction: 0.9,
            accel_limits: IRB1200_ACCEL_LIMITS.to_vec(),
            min_amplitude: 0.25,
        }
    }
}

/// Options of [`random_point_to_point`].
#[derive(Debug, Clone, PartialEq)]
pub struct RandomPointToPointOptions {
    /// Number of via points including start and end (>= 2). Default 5.
    pub points: usize,
    /// Distance kept from each position limit, rad (>= 0). Default 0.05.
    pub position_margin: f64,
    /// Fraction of the velocity and acceleration limits used as `vmax`, `amax`, in `(0, 1]`.
    /// Default 0.9.
    pub limit_fraction: f64,
    /// Per-joint acceleration limits, rad/s^2. Default [`IRB1200_ACCEL_LIMITS`].
    pub accel_limits: Vec<f64>,
    /// Largest slow-down factor (>= 1); the motion's factor is uniform in
    /// `[1, max_slowdown]`. Default 2.
    pub max_slowdown: f64,
    /// Dwell at every via point, s (>= 0). Default 0.
    pub dwell_s: f64,
}

impl Default for RandomPointToPointOptions {
    fn default() -> Self {
        RandomPointToPointOptions {
            points: 5,
            position_margin: 0.05,
            limit_fraction: 0.9,
            accel_limits: IRB1200_ACCEL_LIMITS.to_vec(),
            max_slowdown: 2.0,
            dwell_s: 0.0,
        }
    }
}

/// A random Fourier series (paper eq. 7) for `robot`.
///
/// Raw coefficients are uniform in `[-1/j, 1/j]` for harmonic `j` (harmonic `N` solved for
/// rest when `options.rest`). With `r_ij = hypot(a_ij, b_ij)` and `w = 2 pi f`, each joint's
/// coefficients are then scaled by the largest factor for which the rigorous bounds
/// `|q - q0| <= sum_j r_ij`, `|dq| <= w sum_j j r_ij`, `|ddq| <= w^2 sum_j j^2 r_ij` fit the
/// position range less the margin (half of it), `limit_fraction` of the velocity limit and of
/// the acceleration limit, times a random amplitude scale in `[min_amplitude, 1]`. `q0` is
/// then uniform over the offsets that keep the whole motion inside the margins.
///
/// Errors ([`Error::InvalidInput`]): options out of range, `accel_limits` of the wrong
/// length, or a joint whose range is not wider than twice the margin.
pub fn random_fourier<R: Rng + ?Sized>(
    robot: &Robot,
    rng: &mut R,
    options: &RandomFourierOptions,
) -> Result<Fourier> {
    let o = options;
    check_common(robot, o.position_margin, o.limit_fraction, &o.accel_limits)?;
    if !(0.0..=1.0).contains(&o.min_amplitude) {
        return Err(Error::InvalidInput(format!(
            "min_amplitude {} must be in [0, 1]",
            o.min_amplitude
        )));
    }
    let min_harmonics = if o.rest { 2 } else { 1 };
    if o.harmonics < min_harmonics {
        return Err(Error::InvalidInput(format!(
            "random Fourier series need at least {min_harmonics} harmonics, got {}",
            o.harmonics
        )));
    }
    if !(o.base_freq_hz.is_finite() && o.base_freq_hz > 0.0) {
        return Err(Error::InvalidInput(format!(
            "base frequency {} Hz must be finite and positive",
            o.base_freq_hz
        )));
    }
    if o.rest && o.periods.fract() != 0.0 {
        return Err(Error::InvalidInput(format!(
            "rest at the end needs a whole number of periods, got {}",
            o.periods
        )));
    }
    let w = 2.0 * PI * o.base_freq_hz;
    let n = robot.dof();
    let mut q0 = Vec::with_capacity(n);
    let mut a = Vec::with_capacity(n);
    let mut b = Vec::with_capacity(n);
    for (joint, &acc) in robot.joints().iter().zip(&o.accel_limits) {
        let (lo, hi) = position_range(robot, joint, o.position_margin)?;
        let mut ai = Vec::with_capacity(o.harmonics);
        let mut bi = Vec::with_capacity(o.harmonics);
        for j in 1..=o.harmonics {
            let r = 1.0 / j as f64;
            ai.push(rng.random_range(-r..=r));
            bi.push(rng.random_range(-r..=r));
        }
        if o.rest {
            solve_rest_harmonic(&mut ai, &mut bi);
        }
        let (mut pos, mut vel, mut accel) = (0.0, 0.0, 0.0);
        for (j, (x, y)) in ai.iter().zip(&bi).enumerate() {
            let r = x.hypot(*y);
            let jw = (j + 1) as f64 * w;
            pos += r;
            vel += jw * r;
            accel += jw * jw * r;
        }
        let bound = [
            (0.5 * (hi - lo), pos),
            (o.limit_fraction * joint.limits.velocity, vel),
            (o.limit_fraction * acc, accel),
        ];
        let largest = bound
            .iter()
            .map(|&(limit, reach)| limit / reach)
            .fold(f64::INFINITY, f64::min);
        // All-zero raw coefficients (probability zero) give a constant joint.
        let scale = if largest.is_finite() {
            largest * rng.random_range(o.min_amplitude..=1.0)
        } else {
            0.0
        };
        ai.iter_mut().chain(bi.iter_mut()).for_each(|c| *c *= scale);
        let slack = (0.5 * (hi - lo) - scale * pos).max(0.0);
        q0.push(0.5 * (lo + hi) + rng.random_range(-slack..=slack));
        a.push(ai);
        b.push(bi);
    }
    Fourier::new(o.base_freq_hz, q0, a, b, o.periods)
}

/// A random rest-to-rest motion for `robot`: `options.points` via points uniform inside the
/// position limits less the margin, `vmax`/`amax` = `limit_fraction` times the URDF velocity
/// limits and `accel_limits`, a slow-down factor uniform in `[1, max_slowdown]`.
///
/// Errors ([`Error::InvalidInput`]): options out of range, `accel_limits` of the wrong
/// length, or a joint whose range is not wider than twice the margin.
pub fn random_point_to_point<R: Rng + ?Sized>(
    robot: &Robot,
    rng: &mut R,
    options: &RandomPointToPointOptions,
) -> Result<PointToPoint> {
    let o = options;
    check_common(robot, o.position_margin, o.limit_fraction, &o.accel_limits)?;
    if !(o.max_slowdown.is_finite() && o.max_slowdown >= 1.0) {
        return Err(Error::InvalidInput(format!(
            "max_slowdown {} must be finite and at least 1",
            o.max_slowdown
        )));
    }
    let ranges = robot
        .joints()
        .iter()
        .map(|j| position_range(robot, j, o.position_margin))
        .collect::<Result<Vec<_>>>()?;
    let points = (0..o.points)
        .map(|_| {
            ranges
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..=hi))
                .collect()
        })
        .collect();
    let vmax: Vec<f64> = robot
        .joints()
        .iter()
        .map(|j| o.limit_fraction * j.limits.velocity)
        .collect();
    let amax: Vec<f64> = o
        .accel_limits
        .iter()
        .map(|a| o.limit_fraction * a)
        .collect();
    let timing = PointToPointOptions {
        slowdown: rng.random_range(1.0..=o.max_slowdown),
        dwell_s: o.dwell_s,
    };
    PointToPoint::new(points, &vmax, &amax, &timing)
}

/// Validate the options both generators share.
fn check_common(
    robot: &Robot,
    margin: f64,
    limit_fraction: f64,
    accel_limits: &[f64],
) -> Result<()> {
    if !(margin.is_finite() && margin >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "position margin {margin} rad must be finite and non-negative"
        )));
    }
    if !(limit_fraction > 0.0 && limit_fraction <= 1.0) {
        return Err(Error::InvalidInput(format!(
            "limit_fraction {limit_fraction} must be in (0, 1]"
        )));
    }
    robot.check_len(accel_limits, "accel_limits")?;
    match accel_limits.iter().position(|v| *v <= 0.0) {
        Some(i) => Err(Error::InvalidInput(format!(
            "accel_limits[{}] is {} rad/s^2 (must be positive)",
            i + 1,
            accel_limits[i]
        ))),
        None => Ok(()),
    }
}

/// Admissible positions of a joint, rad: its limits (`[-pi, pi]` where unlimited) less the
/// margin.
pub(crate) fn position_range(robot: &Robot, joint: &Joint, margin: f64) -> Result<(f64, f64)> {
    let lo = if joint.limits.lower.is_finite() {
        joint.limits.lower
    } else {
        -PI
    } + margin;
    let hi = if joint.limits.upper.is_finite() {
        joint.limits.upper
    } else {
        PI
    } - margin;
    if lo < hi {
        Ok((lo, hi))
    } else {
        Err(Error::InvalidInput(format!(
            "joint '{}' of {}: range [{}, {}] rad leaves nothing inside a {margin} rad margin",
            joint.name,
            robot.name(),
            joint.limits.lower,
            joint.limits.upper
        )))
    }
}
