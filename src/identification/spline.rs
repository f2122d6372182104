//! Least-jerk quintic splines through sampled positions.
//!
//! [`quintic`]: the interpolating spline, the C4 piecewise quintic that passes through every
//! sample and, among all interpolants, has the least `∫ q'''(t)^2 dt` (squared jerk). Its
//! knot velocities and accelerations define it completely: a quintic Hermite piece per
//! interval ([`crate::trajectory::sampled::Sampled`] with positions, velocities and
//! accelerations) reproduces it exactly. Interior knots join with continuous third and
//! fourth derivatives, a block-tridiagonal system in the knot (velocity, acceleration) pairs
//! solved in O(samples).
//!
//! [`smooth`]: the smoothing spline for noisy samples, the positions that minimise
//! `sum (x_k - y_k)^2 + mu ∫ q'''^2 dt` with `mu` chosen so that the residual's RMS is the
//! noise level (Morozov's discrepancy principle): interpolation when the noise is far below
//! what the sampling resolves (10 Hz encoders), smoothing when differentiation would amplify
//! it (100 Hz). A block-tridiagonal system in the knot (position, velocity, acceleration)
//! triples, O(samples) per trial `mu`.
//!
//! Each end is either a [`End::Rest`] (velocity and acceleration zero, as where a robot stands
//! still) or [`End::Free`] (for the interpolating spline: third and fourth derivatives those
//! of the quartic through the samples nearest the end, for a motion that runs on beyond the
//! log; for the smoothing spline: the natural end of the least-jerk fit).

use nalgebra::{DMatrix, DVector, Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};

use crate::error::{Error, Result, ensure_finite};

/// Samples nearest a [`End::Free`] end whose interpolating polynomial (a quartic) gives the
/// end's third and fourth derivatives: the local fit the smoothing route used at the ends.
/// It follows a motion that runs on beyond the log better than the natural end of the
/// least-jerk interpolant (third and fourth derivatives zero), which bends the accelerations
/// of the last samples (docs/experiments.md#free-spline-ends).
pub const END_SAMPLES: usize = 5;

/// Condition at an end of the spline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// Standing still: velocity and acceleration exactly zero.
    Rest,
    /// The motion runs on beyond the samples: third and fourth derivatives those of the
    /// polynomial through the [`END_SAMPLES`] samples nearest the end.
    Free,
}

/// Scaled third and fourth derivatives at both ends of a quintic Hermite piece of length `h`
/// (s) as linear functions of the scaled end values: with `V = v h`, `A = a h^2` and
/// `dx = x1 - x0`, row `r` gives `[dx, V0, A0, V1, A1]` coefficients of
/// `h^3 q'''(0)`, `h^3 q'''(h)`, `h^4 q''''(0)`, `h^4 q''''(h)`.
const JOINS: [[f64; 5]; 4] = [
    [60.0, -36.0, -9.0, -24.0, 3.0],
    [60.0, -24.0, -3.0, -36.0, 9.0],
    [-360.0, 192.0, 36.0, 168.0, -24.0],
    [360.0, -168.0, -24.0, -192.0, 36.0],
];

/// One piece's contribution to a derivative condition (row `r` of [`JOINS`], divided by
/// `h^p` with `p` = 3 or 4 so that it is in rad/s^p): the coefficients of `(v0, a0)`,
/// `(v1, a1)` (physical units) and the constant from the position step `dx` (rad).
fn piece_row(r: usize, h: f64, dx: f64) -> ([f64; 2], [f64; 2], f64) {
    let c = JOINS[r];
    let p = if r < 2 { 3 } else { 4 };
    let s = h.powi(p);
    (
        [c[1] * h / s, c[2] * h * h / s],
        [c[3] * h / s, c[4] * h * h / s],
        c[0] * dx / s,
    )
}

/// Knot velocities (rad/s) and accelerations (rad/s^2) of the quintic interpolating spline
/// through positions `x` (rad) at times `t` (s, strictly increasing, at least 2), with the
/// end conditions `start` and `end`. A [`End::Rest`] end gets exactly zero velocity and
/// acceleration.
///
/// Errors ([`Error::InvalidInput`]): fewer than 2 samples, lengths that differ, non-finite
/// values, times that do not increase, or a system that cannot be solved (knots far too
/// close for the arithmetic).
pub fn quintic(t: &[f64], x: &[f64], start: End, end: End) -> Result<(Vec<f64>, Vec<f64>)> {
    check_samples(t, x)?;
    let n = t.len();
    if n == 2 && start == End::Free && end == End::Free {
        // Two samples give no third or fourth derivative, and every quadratic through them
        // meets both ends' conditions: the least-acceleration one is the line.
        let v = (x[1] - x[0]) / (t[1] - t[0]);
        return Ok((vec![v; 2], vec![0.0; 2]));
    }
    let mut system = interior_joins(t, x);
    start_condition(&mut system, t, x, start)?;
    end_condition(&mut system, t, x, end)?;
    let u = system.solve(|| {
        Error::InvalidInput(
            "the spline's equations are singular (sample times too close together?)".into(),
        )
    })?;
    let last = n - 1;
    let mut v: Vec<f64> = u.iter().map(|p| p[0]).collect();
    let mut a: Vec<f64> = u.iter().map(|p| p[1]).collect();
    // Exact zeros at rest (the solve leaves round-off there, and a Coulomb term switches on
    // any non-zero speed).
    for (k, e) in [(0, start), (last, end)] {
        if e == End::Rest {
            v[k] = 0.0;
            a[k] = 0.0;
        }
    }
    if let Some(bad) = v.iter().chain(&a).find(|c| !c.is_finite()) {
        return Err(Error::InvalidInput(format!(
            "the spline overflowed ({bad}); are the sample times too close?"
        )));
    }
    Ok((v, a))
}

/// Refuse samples no spline can pass through: fewer than 2, a position count other than the
/// time count, non-finite times (s) or positions (rad), or times that do not increase.
fn check_samples(t: &[f64], x: &[f64]) -> Result<()> {
    let n = t.len();
    if n < 2 || x.len() != n {
        return Err(Error::InvalidInput(format!(
            "a spline needs at least 2 samples and one position per time ({} times, {} positions)",
            n,
            x.len()
        )));
    }
    ensure_finite(t, "t")?;
    ensure_finite(x, "q")?;
    if let Some(k) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(Error::InvalidInput(format!(
            "spline times must increase (sample {})",
            k + 2
        )));
    }
    Ok(())
}

/// A block-tridiagonal system in `D`-vectors, one block row per knot:
/// `lower[k] u[k-1] + diag[k] u[k] + upper[k] u[k+1] = rhs[k]`.
struct Blocks<const D: usize> {
    lower: Vec<SMatrix<f64, D, D>>,
    diag: Vec<SMatrix<f64, D, D>>,
    upper: Vec<SMatrix<f64, D, D>>,
    rhs: Vec<SVector<f64, D>>,
}

impl<const D: usize> Blocks<D> {
    /// `n` block rows, all zero.
    fn zeros(n: usize) -> Self {
        Blocks {
            lower: vec![SMatrix::zeros(); n],
            diag: vec![SMatrix::zeros(); n],
            upper: vec![SMatrix::zeros(); n],
            rhs: vec![SVector::zeros(); n],
        }
    }

    /// The solution `u`, one block per knot, by the block Thomas algorithm (elimination
    /// forward, substitution back); `singular` is the error when a diagonal block cannot be
    /// inverted.
    fn solve(mut self, singular: impl Fn() -> Error) -> Result<Vec<SVector<f64, D>>> {
        let n = self.diag.len();
        for k in 1..n {
            let inv = self.diag[k - 1].try_inverse().ok_or_else(&singular)?;
            let w = self.lower[k] * inv;
            self.diag[k] -= w * self.upper[k - 1];
            let carried = w * self.rhs[k - 1];
            self.rhs[k] -= carried;
        }
        let last = n - 1;
        let mut u = vec![SVector::zeros(); n];
        u[last] = self.diag[last].try_inverse().ok_or_else(&singular)? * self.rhs[last];
        for k in (0..last).rev() {
            u[k] = self.diag[k].try_inverse().ok_or_else(&singular)?
                * (self.rhs[k] - self.upper[k] * u[k + 1]);
        }
        Ok(u)
    }
}

/// The interpolating spline's system in the knot (velocity, acceleration) pairs (rad/s,
/// rad/s^2) with the interior knots' rows filled: `q'''` and `q''''` continuous, the left
/// piece `k-1` at its end (rows 1, 3 of [`JOINS`]) equal to the right piece `k` at its start
/// (rows 0, 2). The end rows are left zero.
fn interior_joins(t: &[f64], x: &[f64]) -> Blocks<2> {
    let n = t.len();
    let mut s = Blocks::<2>::zeros(n);
    for k in 1..n - 1 {
        let (hl, hr) = (t[k] - t[k - 1], t[k + 1] - t[k]);
        let (dl, dr) = (x[k] - x[k - 1], x[k + 1] - x[k]);
        for (row, (left, right)) in [(1, 0), (3, 2)].into_iter().enumerate() {
            let (l0, l1, lc) = piece_row(left, hl, dl);
            let (r0, r1, rc) = piece_row(right, hr, dr);
            // left(end) - right(start) = 0
            for c in 0..2 {
                s.lower[k][(row, c)] = l0[c];
                s.diag[k][(row, c)] = l1[c] - r0[c];
                s.upper[k][(row, c)] = -r1[c];
            }
            s.rhs[k][row] = rc - lc;
        }
    }
    s
}

/// The first knot's rows of `system`: at a [`End::Rest`] zero velocity and acceleration; at
/// a [`End::Free`] start the first piece's third and fourth derivatives at `t[0]` (rows 0
/// and 2 of [`JOINS`]) those of the polynomial through the nearest samples.
fn start_condition(system: &mut Blocks<2>, t: &[f64], x: &[f64], start: End) -> Result<()> {
    match start {
        End::Rest => system.diag[0] = Matrix2::identity(),
        End::Free => {
            let n = t.len();
            let (h, d) = (t[1] - t[0], x[1] - x[0]);
            let near = n.min(END_SAMPLES);
            let want = end_derivatives(&t[..near], &x[..near], t[0])?;
            for (row, r) in [0, 2].into_iter().enumerate() {
                let (p0, p1, pc) = piece_row(r, h, d);
                for c in 0..2 {
                    system.diag[0][(row, c)] = p0[c];
                    system.upper[0][(row, c)] = p1[c];
                }
                system.rhs[0][row] = want[row] - pc;
            }
        }
    }
    Ok(())
}

/// The last knot's rows of `system`: at a [`End::Rest`] zero velocity and acceleration; at a
/// [`End::Free`] end the last piece's third and fourth derivatives at the last time (rows 1
/// and 3 of [`JOINS`]) those of the polynomial through the nearest samples.
fn end_condition(system: &mut Blocks<2>, t: &[f64], x: &[f64], end: End) -> Result<()> {
    let n = t.len();
    let last = n - 1;
    match end {
        End::Rest => {
            system.lower[last] = Matrix2::zeros();
            system.diag[last] = Matrix2::identity();
            system.rhs[last] = Vector2::zeros();
        }
        End::Free => {
            let (h, d) = (t[last] - t[last - 1], x[last] - x[last - 1]);
            let near = n - n.min(END_SAMPLES);
            let want = end_derivatives(&t[near..], &x[near..], t[last])?;
            for (row, r) in [1, 3].into_iter().enumerate() {
                let (p0, p1, pc) = piece_row(r, h, d);
                for c in 0..2 {
                    system.lower[last][(row, c)] = p0[c];
                    system.diag[last][(row, c)] = p1[c];
                }
                system.rhs[last][row] = want[row] - pc;
            }
        }
    }
    Ok(())
}

/// Third (rad/s^3) and fourth (rad/s^4) derivatives at time `at` of the polynomial of
/// degree `len - 1` through the points `(t, x)` (at most [`END_SAMPLES`]); zero where the
/// degree is too low.
fn end_derivatives(t: &[f64], x: &[f64], at: f64) -> Result<[f64; 2]> {
    let m = t.len();
    // Local time scaled by the span keeps the Vandermonde matrix well conditioned.
    let scale = t[m - 1] - t[0];
    let v = DMatrix::from_fn(m, m, |r, c| ((t[r] - at) / scale).powi(c as i32));
    let c = v
        .lu()
        .solve(&DVector::from_column_slice(x))
        .ok_or_else(|| Error::Numerical("the spline's end polynomial is singular".into()))?;
    let d3 = if m > 3 {
        6.0 * c[3] / scale.powi(3)
    } else {
        0.0
    };
    let d4 = if m > 4 {
        24.0 * c[4] / scale.powi(4)
    } else {
        0.0
    };
    Ok([d3, d4])
}

/// `∫_0^h q'''(s)^2 ds` of the quintic Hermite piece of length `h` (s) as a quadratic form in
/// its end values `[x0, v0, a0, x1, v1, a1]` (rad, rad/s, rad/s^2): the 6 x 6 Gram matrix.
pub fn jerk_gram(h: f64) -> SMatrix<f64, 6, 6> {
    type Row = nalgebra::RowSVector<f64, 6>;
    // Residuals left after the Taylor part at 0 (the quintic Hermite coefficients'
    // r0, r1, r2), as rows over the end values.
    let r = SMatrix::<f64, 3, 6>::from_rows(&[
        Row::from_row_slice(&[-1.0, -h, -0.5 * h * h, 1.0, 0.0, 0.0]),
        Row::from_row_slice(&[0.0, -h, -h * h, 0.0, h, 0.0]),
        Row::from_row_slice(&[0.0, 0.0, -h * h, 0.0, 0.0, h * h]),
    ]);
    // The jerk q''' = d0 + d1 s + d2 s^2 with d = (6 c3, 24 c4, 60 c5), from the residuals.
    let (h3, h4, h5) = (h.powi(3), h.powi(4), h.powi(5));
    let c = Matrix3::new(
        60.0 / h3,
        -24.0 / h3,
        3.0 / h3,
        -360.0 / h4,
        168.0 / h4,
        -24.0 / h4,
        360.0 / h5,
        -180.0 / h5,
        30.0 / h5,
    );
    let l = c * r;
    let m = Matrix3::from_fn(|i, j| h.powi((i + j + 1) as i32) / (i + j + 1) as f64);
    l.transpose() * m * l
}

/// The least-jerk smoothing spline's positions (rad) at times `t` (s, strictly increasing, at
/// least 2) for samples `y` (rad): minimises `sum (x_k - y_k)^2 + mu ∫ q'''^2 dt` over
/// quintic splines with the residual's RMS (over the samples not held by a [`End::Rest`])
/// brought to `sigma_rad`. A rest end keeps its sample exactly, with zero velocity and
/// acceleration. `sigma_rad <= 0` returns the samples (interpolation).
///
/// Errors: as [`quintic`], and a negative or non-finite `sigma_rad`.
pub fn smooth(t: &[f64], y: &[f64], start: End, end: End, sigma_rad: f64) -> Result<Vec<f64>> {
    quintic(t, y, start, end)?; // the same checks of the input
    if !(sigma_rad.is_finite() && sigma_rad >= 0.0) {
        return Err(Error::InvalidInput(format!(
            "noise level {sigma_rad} rad must be finite and >= 0"
        )));
    }
    let n = t.len();
    let free = n - usize::from(start == End::Rest) - usize::from(end == End::Rest);
    if sigma_rad == 0.0 || free == 0 {
        return Ok(y.to_vec());
    }
    let fit = Smoother {
        y,
        grams: t.windows(2).map(|w| jerk_gram(w[1] - w[0])).collect(),
        start,
        end,
        free,
        h: (t[n - 1] - t[0]) / (n - 1) as f64,
    };
    match fit.search(sigma_rad)? {
        Weight::Interpolate => Ok(y.to_vec()),
        Weight::Largest(e) => fit.solve(fit.mu(e)),
        Weight::Found(e) => {
            let x = fit.solve(fit.mu(e))?;
            if let Some(bad) = x.iter().find(|v| !v.is_finite()) {
                return Err(Error::Numerical(format!(
                    "the smoothing spline overflowed ({bad})"
                )));
            }
            Ok(x)
        }
    }
}

/// The smoothing spline's problem for the samples `y` (rad): the fits for a given weight of
/// the jerk and the residual they leave.
struct Smoother<'a> {
    /// The samples, rad.
    y: &'a [f64],
    /// Each interval's jerk Gram matrix ([`jerk_gram`]).
    grams: Vec<SMatrix<f64, 6, 6>>,
    start: End,
    end: End,
    /// Samples not held by a [`End::Rest`].
    free: usize,
    /// Mean sample interval, s.
    h: f64,
}

/// What the search for the smoothing weight found: the exponent `e = log10(mu / h^5)`.
enum Weight {
    /// Even the least weight leaves a residual at or above the noise: the samples themselves.
    Interpolate,
    /// Even the largest weight leaves a residual below the noise: the fit at that exponent.
    Largest(f64),
    /// The exponent whose residual's RMS is the noise's.
    Found(f64),
}

impl Smoother<'_> {
    /// Whether knot `k` is held by a [`End::Rest`] (its sample kept exactly).
    fn fixed(&self, k: usize) -> bool {
        let n = self.y.len();
        (k == 0 && self.start == End::Rest) || (k == n - 1 && self.end == End::Rest)
    }

    /// The jerk weight `mu` (s^5) at the exponent `e`: `h^5 10^e`.
    fn mu(&self, e: f64) -> f64 {
        self.h.powi(5) * 10f64.powf(e)
    }

    /// The normal equations of the fit with jerk weight `mu`, in the knot (position,
    /// velocity, acceleration) triples (rad, rad/s, rad/s^2).
    fn system(&self, mu: f64) -> Blocks<3> {
        let n = self.y.len();
        let mut s = Blocks::<3>::zeros(n);
        for (k, &y) in self.y.iter().enumerate() {
            if self.fixed(k) {
                s.diag[k] = Matrix3::identity();
                s.rhs[k] = Vector3::new(y, 0.0, 0.0);
                continue;
            }
            s.diag[k][(0, 0)] = 1.0;
            s.rhs[k][0] = y;
            if k > 0 {
                let g = &self.grams[k - 1];
                s.lower[k] = mu * g.fixed_view::<3, 3>(3, 0);
                s.diag[k] += mu * g.fixed_view::<3, 3>(3, 3);
            }
            if k + 1 < n {
                let g = &self.grams[k];
                s.diag[k] += mu * g.fixed_view::<3, 3>(0, 0);
                s.upper[k] = mu * g.fixed_view::<3, 3>(0, 3);
            }
        }
        s
    }

    /// The fitted positions (rad) with jerk weight `mu`.
    fn solve(&self, mu: f64) -> Result<Vec<f64>> {
        let u = self
            .system(mu)
            .solve(|| Error::Numerical("the smoothing spline's equations are singular".into()))?;
        Ok(u.iter().map(|p| p[0]).collect())
    }

    /// RMS (rad) of the residual of the positions `x` over the samples not held by a rest.
    fn rms(&self, x: &[f64]) -> f64 {
        let se: f64 = (0..self.y.len())
            .filter(|&k| !self.fixed(k))
            .map(|k| (x[k] - self.y[k]).powi(2))
            .sum();
        (se / self.free as f64).sqrt()
    }

    /// `ln(RMS / sigma_rad)` of the fit at the exponent `e`.
    fn gap(&self, e: f64, sigma_rad: f64) -> Result<f64> {
        Ok((self.rms(&self.solve(self.mu(e))?) / sigma_rad).ln())
    }

    /// The exponent of the jerk weight whose residual's RMS is `sigma_rad` (rad).
    fn search(&self, sigma_rad: f64) -> Result<Weight> {
        // The residual grows with mu: search e = log10(mu / h^5) (h the mean interval) for
        // the RMS, keeping a bracket [lo, hi] with the RMS at or below the noise at lo and
        // above it at hi, until it is as narrow as MU_BISECTIONS halvings would leave it (or
        // lo's RMS is the noise's to 1e-12). Each step is false position on ln(RMS / noise),
        // a nearly straight function of e, with the Illinois modification (an end kept twice
        // in a row has its value halved); a step that did not halve the bracket is followed
        // by a bisection, so the search never takes more than twice the bisection's solves.
        let (mut lo, mut hi) = (-MU_DECADES, MU_DECADES);
        let mut f_lo = self.gap(lo, sigma_rad)?;
        if f_lo >= 0.0 {
            return Ok(Weight::Interpolate);
        }
        let f_hi = self.gap(hi, sigma_rad)?;
        if f_hi <= 0.0 {
            return Ok(Weight::Largest(hi));
        }
        let width = (hi - lo) / 2f64.powi(MU_BISECTIONS as i32);
        // The ends' values as the false position weighs them (the Illinois halvings).
        let (mut w_lo, mut w_hi) = (f_lo, f_hi);
        let (mut kept, mut bisect) = (0i8, false);
        while hi - lo > width && f_lo < -1e-12 {
            let before = hi - lo;
            let secant = hi - w_hi * (hi - lo) / (w_hi - w_lo);
            let e = if !bisect && secant > lo && secant < hi {
                secant
            } else {
                0.5 * (lo + hi)
            };
            let f = self.gap(e, sigma_rad)?;
            if f > 0.0 {
                (hi, w_hi) = (e, f);
                if kept == 1 {
                    w_lo *= 0.5;
                }
                kept = 1;
            } else {
                (lo, f_lo, w_lo) = (e, f, f);
                if kept == -1 {
                    w_hi *= 0.5;
                }
                kept = -1;
            }
            bisect = !bisect && hi - lo > 0.5 * before;
        }
        Ok(Weight::Found(lo))
    }
}

/// Range of the smoothing weight searched, decades either side of `h^5` (the weight at which
/// one interval's jerk and one sample's residual count alike).
const MU_DECADES: f64 = 12.0;

/// Resolution of the smoothing weight's search: the bracket 30 bisections would leave
/// (24 / 2^30 decades).
const MU_BISECTIONS: usize = 30;
