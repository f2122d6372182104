//! Weights of iterated weighted least squares: each sample by the inverse of a residual
//! variance estimated from the previous fit's residuals ([`Weighting`]).

use nalgebra::DVector;

use super::Weighting;
use super::samples::Samples;

/// Smallest residual variance a weight may assume, as a fraction of the mean squared residual
/// (so no sample dominates).
const VARIANCE_FLOOR: f64 = 0.05;

/// Weights `1 / sigma_m^2` of the samples `rows` under `weighting`, from the residuals of the
/// parameters `z` (normalised to mean 1).
pub(super) fn variance_weights(
    s: &Samples,
    rows: &[usize],
    z: &DVector<f64>,
    weighting: Weighting,
) -> Vec<f64> {
    let (r2, u): (Vec<f64>, Vec<f64>) = rows
        .iter()
        .map(|&m| {
            let p = s.power(m, z, None);
            ((p - s.y[m]).powi(2), (p - z[s.constant(m)]).powi(2))
        })
        .unzip();
    // Each signal (the arm's power, each motor's) has a noise of its own.
    let group = |m: usize| -> usize {
        match weighting {
            Weighting::PerLog => s.series[m],
            _ => s.motor[m].map_or(0, |i| i + 1),
        }
    };
    let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (k, &m) in rows.iter().enumerate() {
        groups.entry(group(m)).or_default().push(k);
    }
    let mut variance = vec![1.0; rows.len()];
    let mut w = vec![0.0; rows.len()];
    for members in groups.values() {
        let c = members.len() as f64;
        let mean_r2 = members.iter().map(|&k| r2[k]).sum::<f64>() / c;
        let floor = (VARIANCE_FLOOR * mean_r2).max(1e-300);
        match weighting {
            Weighting::None => {}
            Weighting::PerLog => members.iter().for_each(|&k| variance[k] = mean_r2),
            Weighting::PowerLevel => {
                // Least squares of r^2 on [1, u], the slope kept >= 0.
                let mu = members.iter().map(|&k| u[k]).sum::<f64>() / c;
                let (mut suu, mut sur) = (0.0, 0.0);
                for &k in members {
                    suu += (u[k] - mu) * (u[k] - mu);
                    sur += (u[k] - mu) * (r2[k] - mean_r2);
                }
                let b = if suu > 0.0 { (sur / suu).max(0.0) } else { 0.0 };
                let a = mean_r2 - b * mu;
                members.iter().for_each(|&k| variance[k] = a + b * u[k]);
            }
        }
        for &k in members {
            w[k] = 1.0 / variance[k].max(floor);
        }
    }
    let mean = w.iter().sum::<f64>() / w.len().max(1) as f64;
    w.iter().map(|v| v / mean).collect()
}
