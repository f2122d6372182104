//! Finite Fourier series excitation trajectories (paper eq. 7).
//!
//! Joint `i` follows
//!
//! ```text
//! q_i(t) = q0_i + sum_{j=1..N} [ a_ij sin(j w t) + b_ij cos(j w t) ],   w = 2 pi f
//! ```
//!
//! with base frequency `f` (Hz) and `N` harmonics; velocity and acceleration are the exact
//! derivatives. The series is periodic with period `1/f`; a trajectory runs a given number of
//! periods.
//!
//! # Rest at start and end
//! At `t = 0` the velocity is `w sum_j j a_ij` and the acceleration `-w^2 sum_j j^2 b_ij`.
//! [`Fourier::rest_constrained`] takes the harmonics `1..N-1` freely and solves the highest
//! one so that both vanish:
//!
//! ```text
//! a_iN = -sum_{j<N} (j/N) a_ij,      b_iN = -sum_{j<N} (j/N)^2 b_ij
//! ```
//!
//! By periodicity the robot is then also at rest at every whole period, in particular at the
//! end. The constraints are linear and homogeneous in `(a, b)`, so scaling the coefficients
//! of a joint keeps them. The start position is `q_i(0) = q0_i + sum_j b_ij`.

use std::f64::consts::PI;

use crate::error::{Error, Result, ensure_finite};

use super::Trajectory;

/// A finite Fourier series trajectory (paper eq. 7). Fields are validated on construction.
#[derive(Debug, Clone, PartialEq)]
pub struct Fourier {
    base_freq_hz: f64,
    q0: Vec<f64>,
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    periods: f64,
}

impl Fourier {
    /// A series with base frequency `base_freq_hz` (Hz, > 0), offsets `q0` (rad, one per
    /// joint), sine and cosine coefficients `a[i][j-1]`, `b[i][j-1]` (rad) of harmonic `j` of
    /// joint `i`, every joint with the same number `N >= 1` of harmonics, running `periods`
    /// (> 0) periods. Errors: [`Error::InvalidInput`] on empty, ragged or non-finite input.
    pub fn new(
        base_freq_hz: f64,
        q0: Vec<f64>,
        a: Vec<Vec<f64>>,
        b: Vec<Vec<f64>>,
        periods: f64,
    ) -> Result<Fourier> {
        if !(base_freq_hz.is_finite() && base_freq_hz > 0.0) {
            return Err(Error::InvalidInput(format!(
                "Fourier base frequency {base_freq_hz} Hz must be finite and positive"
            )));
        }
        if !(periods.is_finite() && periods > 0.0) {
            return Err(Error::InvalidInput(format!(
                "Fourier period count {periods} must be finite and positive"
            )));
        }
        let dof = q0.len();
        if dof == 0 {
            return Err(Error::InvalidInput("Fourier series without joints".into()));
        }
        ensure_finite(&q0, "q0")?;
        let harmonics = a.first().map_or(0, Vec::len);
        if harmonics == 0 {
            return Err(Error::InvalidInput(
                "Fourier series needs at least one harmonic".into(),
            ));
        }
        for (name, coef) in [("a", &a), ("b", &b)] {
            if coef.len() != dof {
                return Err(Error::InvalidInput(format!(
                    "Fourier {name} has {} joints, q0 has {dof}",
                    coef.len()
                )));
            }
            for (i, row) in coef.iter().enumerate() {
                if row.len() != harmonics {
                    return Err(Error::InvalidInput(format!(
                        "Fourier {name} of joint {} has {} harmonics, expected {harmonics}",
                        i + 1,
                        row.len()
                    )));
                }
                ensure_finite(row, &format!("Fourier {name} of joint {}", i + 1))?;
            }
        }
        Ok(Fourier {
            base_freq_hz,
            q0,
            a,
            b,
            periods,
        })
    }

    /// A series at rest (zero velocity and acceleration) at `t = 0` and at every whole period.
    ///
    /// `a_free[i]`, `b_free[i]` hold the coefficients (rad) of harmonics `1..N-1` of joint `i`
    /// (`N - 1 >= 1` of them); harmonic `N` is solved as in the [module docs](self).
    /// `periods` must be a whole number so that the trajectory also ends at rest. Errors:
    /// as [`Fourier::new`], plus a non-integer period count.
    pub fn rest_constrained(
        base_freq_hz: f64,
        q0: Vec<f64>,
        a_free: Vec<Vec<f64>>,
        b_free: Vec<Vec<f64>>,
        periods: f64,
    ) -> Result<Fourier> {
        if periods.fract() != 0.0 {
            return Err(Error::InvalidInput(format!(
                "a rest-constrained Fourier series must run a whole number of periods, got {periods}"
            )));
        }
        let extend = |rows: Vec<Vec<f64>>| -> Vec<Vec<f64>> {
            rows.into_iter()
                .map(|mut r| {
                    r.push(0.0);
                    r
                })
                .collect()
        };
        let mut f = Fourier::new(base_freq_hz, q0, extend(a_free), extend(b_free), periods)?;
        if f.harmonics() < 2 {
            return Err(Error::InvalidInput(
                "a rest-constrained Fourier series needs at least one free harmonic".into(),
            ));
        }
        for (i, (ai, bi)) in f.a.iter_mut().zip(f.b.iter_mut()).enumerate() {
            solve_rest_harmonic(ai, bi);
            ensure_finite(
                &ai[ai.len() - 1..],
                &format!("solved Fourier a of joint {}", i + 1),
            )?;
            ensure_finite(
                &bi[bi.len() - 1..],
                &format!("solved Fourier b of joint {}", i + 1),
            )?;
        }
        Ok(f)
    }

    /// Rebuild a series from [`Fourier::to_vector`] output: `dof` joints, `harmonics`
    /// harmonics per joint, base frequency (Hz) and period count as in [`Fourier::new`].
    /// Errors: a vector of the wrong length, and everything [`Fourier::new`] rejects.
    pub fn from_vector(
        base_freq_hz: f64,
        periods: f64,
        dof: usize,
        harmonics: usize,
        v: &[f64],
    ) -> Result<Fourier> {
        let expected = harmonics
            .checked_mul(2)
            .and_then(|h| h.checked_add(1))
            .and_then(|h| h.checked_mul(dof));
        if expected != Some(v.len()) {
            return Err(Error::InvalidInput(format!(
                "Fourier coefficient vector has {} values, {dof} joints with {harmonics} harmonics need dof * (2 N + 1)",
                v.len()
            )));
        }
        let (q0, rest) = v.split_at(dof);
        let (mut a, mut b) = (Vec::with_capacity(dof), Vec::with_capacity(dof));
        for joint in rest.chunks_exact(2 * harmonics.max(1)) {
            let (aj, bj) = joint.split_at(harmonics);
            a.push(aj.to_vec());
            b.push(bj.to_vec());
        }
        Fourier::new(base_freq_hz, q0.to_vec(), a, b, periods)
    }

    /// All coefficients as one vector (rad), layout
    /// `[q0_1..q0_n, a_11..a_1N, b_11..b_1N, a_21..a_2N, b_21..b_2N, ...]`, of length
    /// [`Fourier::coefficient_count`].
    pub fn to_vector(&self) -> Vec<f64> {
        let mut v = Vec::with_capacity(self.coefficient_count());
        v.extend_from_slice(&self.q0);
        for (ai, bi) in self.a.iter().zip(&self.b) {
            v.extend_from_slice(ai);
            v.extend_from_slice(bi);
        }
        v
    }

    /// Number of coefficients, `dof * (2 N + 1)`.
    pub fn coefficient_count(&self) -> usize {
        self.q0.len() * (2 * self.harmonics() + 1)
    }

    /// Base frequency `f`, Hz.
    pub fn base_freq_hz(&self) -> f64 {
        self.base_freq_hz
    }

    /// Number of periods the trajectory runs.
    pub fn periods(&self) -> f64 {
        self.periods
    }

    /// Number of harmonics `N`.
    pub fn harmonics(&self) -> usize {
        self.a[0].len()
    }

    /// Position offsets `q0`, rad.
    pub fn q0(&self) -> &[f64] {
        &self.q0
    }

    /// Sine coefficients `a[i][j-1]` of harmonic `j` of joint `i`, rad.
    pub fn a(&self) -> &[Vec<f64>] {
        &self.a
    }

    /// Cosine coefficients `b[i][j-1]` of harmonic `j` of joint `i`, rad.
    pub fn b(&self) -> &[Vec<f64>] {
        &self.b
    }
}

impl Trajectory for Fourier {
    fn dof(&self) -> usize {
        self.q0.len()
    }

    /// `periods / base_freq_hz`, s.
    fn duration(&self) -> f64 {
        self.periods / self.base_freq_hz
    }

    fn sample(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        let t = t.clamp(0.0, self.duration());
        let w = 2.0 * PI * self.base_freq_hz;
        let dof = self.q0.len();
        q.iter_mut().zip(&self.q0).for_each(|(qi, q0)| *qi = *q0);
        dq.iter_mut().take(dof).for_each(|v| *v = 0.0);
        ddq.iter_mut().take(dof).for_each(|v| *v = 0.0);
        // Harmonic j's phase is (j + 1) w t: its sine and cosine follow from the first's by
        // the angle-addition formulas, one `sin_cos` per sample instead of one per harmonic.
        let (s1, c1) = (w * t).sin_cos();
        let (mut s, mut c) = (s1, c1);
        for j in 0..self.harmonics() {
            let wj = w * (j + 1) as f64;
            if j > 0 {
                (s, c) = (s * c1 + c * s1, c * c1 - s * s1);
            }
            let rows = self.a.iter().zip(&self.b);
            let outputs = q.iter_mut().zip(dq.iter_mut()).zip(ddq.iter_mut());
            for ((ai, bi), ((qi, dqi), ddqi)) in rows.zip(outputs) {
                let (a, b) = (ai[j], bi[j]);
                let x = a * s + b * c;
                *qi += x;
                *dqi += wj * (a * c - b * s);
                *ddqi -= wj * wj * x;
            }
        }
    }
}

/// Overwrite the last harmonic of one joint so that velocity and acceleration vanish at
/// `t = 0` (see the module docs). `a` and `b` have the same length `N >= 1`.
pub(crate) fn solve_rest_harmonic(a: &mut [f64], b: &mut [f64]) {
    let n = a.len();
    let nf = n as f64;
    let (mut sa, mut sb) = (0.0, 0.0);
    for j in 0..n - 1 {
        let r = (j + 1) as f64 / nf;
        sa += r * a[j];
        sb += r * r * b[j];
    }
    a[n - 1] = -sa;
    b[n - 1] = -sb;
}
