//! Identification from power: signal processing and estimators against the twin's truth.

mod common;

use powertwin::identification::fourier_fit::fit_fourier;
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::random::{RandomFourierOptions, random_fourier};

#[test]
fn fourier_fit_recovers_the_series_from_10_hz_samples() {
    let robot = common::irb1200();
    let mut rng = common::rng(4);
    let truth = random_fourier(&robot, &mut rng, &RandomFourierOptions::default()).unwrap();
    let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
    let n = robot.dof();
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut samples = vec![Vec::new(); n];
    for &tk in &t {
        truth.sample(tk, &mut q, &mut dq, &mut ddq);
        for i in 0..n {
            samples[i].push(q[i]);
        }
    }
    let fit = fit_fourier(&t, &samples, 0.1, 5).unwrap();
    assert!(
        fit.rms_residual_rad.iter().all(|r| *r < 1e-12),
        "{:?}",
        fit.rms_residual_rad
    );
    let (mut q2, mut dq2, mut ddq2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..200 {
        let tk = k as f64 * 0.0497;
        truth.sample(tk, &mut q, &mut dq, &mut ddq);
        fit.series.sample(tk, &mut q2, &mut dq2, &mut ddq2);
        for i in 0..n {
            assert!(
                (q[i] - q2[i]).abs() < 1e-10
                    && (dq[i] - dq2[i]).abs() < 1e-9
                    && (ddq[i] - ddq2[i]).abs() < 1e-8
            );
        }
    }
    // Noise of 1e-4 rad leaves a residual of that size and a smooth fit.
    let mut noisy = samples.clone();
    for (i, col) in noisy.iter_mut().enumerate() {
        for (k, v) in col.iter_mut().enumerate() {
            *v += 1e-4 * ((k * 7 + i * 3) as f64).sin();
        }
    }
    let fit = fit_fourier(&t, &noisy, 0.1, 5).unwrap();
    assert!(
        fit.rms_residual_rad.iter().all(|r| *r < 1e-4 && *r > 1e-5),
        "{:?}",
        fit.rms_residual_rad
    );
    // Too few samples or a degenerate time base are errors.
    assert!(fit_fourier(&t[..5], &[samples[0][..5].to_vec()], 0.1, 5).is_err());
    let same_t = vec![1.0; 20];
    assert!(fit_fourier(&same_t, &[vec![0.0; 20]], 0.1, 5).is_err());
}
