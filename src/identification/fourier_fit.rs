//! The paper's signal route: fit logged joint positions with the finite Fourier series of the
//! excitation (eq. 7, known base frequency and harmonic count) by linear least squares, then
//! take velocity and acceleration from the fitted series analytically. The fit removes
//! encoder noise and quantisation, and everything not periodic in the base frequency.

use nalgebra::DMatrix;

use crate::error::{Error, Result, ensure_finite};
use crate::trajectory::fourier::Fourier;

/// Result of a Fourier fit.
#[derive(Debug, Clone)]
pub struct FourierFit {
    /// The fitted series (time origin as the samples'; covers `[0, max t]`).
    pub series: Fourier,
    /// RMS of the position residual per joint, rad.
    pub rms_residual_rad: Vec<f64>,
}

/// Fit positions `q[i][m]` (rad) of joint `i` sampled at times `t[m]` (s, >= 0) with a
/// Fourier series of base frequency `base_freq_hz` and `harmonics` harmonics.
///
/// Errors: fewer samples than `2 harmonics + 1`, samples that do not determine the
/// coefficients (e.g. all within one short interval), non-finite values, ragged input.
pub fn fit_fourier(
    t: &[f64],
    q: &[Vec<f64>],
    base_freq_hz: f64,
    harmonics: usize,
) -> Result<FourierFit> {
    let m = t.len();
    let cols = 2 * harmonics + 1;
    if harmonics == 0 || m < cols {
        return Err(Error::InvalidInput(format!(
            "a {harmonics}-harmonic Fourier fit needs at least {cols} samples, got {m}"
        )));
    }
    ensure_finite(t, "t")?;
    if t.iter().any(|v| *v < 0.0) {
        return Err(Error::InvalidInput("sample times must be >= 0 s".into()));
    }
    if q.is_empty() || q.iter().any(|c| c.len() != m) {
        return Err(Error::InvalidInput(format!(
            "every joint needs {m} position samples"
        )));
    }
    for (i, c) in q.iter().enumerate() {
        ensure_finite(c, &format!("q{}", i + 1))?;
    }
    let w = std::f64::consts::TAU * base_freq_hz;
    let x = DMatrix::from_fn(m, cols, |r, c| match c {
        0 => 1.0,
        c if c % 2 == 1 => ((c.div_ceil(2)) as f64 * w * t[r]).sin(),
        c => ((c / 2) as f64 * w * t[r]).cos(),
    });
    let y = DMatrix::from_fn(m, q.len(), |r, c| q[c][r]);
    let svd = x.clone().svd(true, true);
    let smax = svd.singular_values.max();
    if svd.singular_values.min() <= 1e-10 * smax {
        return Err(Error::InvalidInput(
            "the sample times do not determine the Fourier coefficients (too short or too sparse)"
                .into(),
        ));
    }
    let coef = svd
        .solve(&y, 0.0)
        .map_err(|e| Error::Numerical(format!("Fourier fit failed: {e}")))?;
    let resid = &x * &coef - &y;
    let rms = (0..q.len())
        .map(|i| (resid.column(i).norm_squared() / m as f64).sqrt())
        .collect();
    let q0 = (0..q.len()).map(|i| coef[(0, i)]).collect();
    let a = (0..q.len())
        .map(|i| (1..=harmonics).map(|j| coef[(2 * j - 1, i)]).collect())
        .collect();
    let b = (0..q.len())
        .map(|i| (1..=harmonics).map(|j| coef[(2 * j, i)]).collect())
        .collect();
    let t_max = t.iter().cloned().fold(0.0, f64::max);
    let series = Fourier::new(base_freq_hz, q0, a, b, (t_max * base_freq_hz).max(1e-9))?;
    Ok(FourierFit {
        series,
        rms_residual_rad: rms,
    })
}
