//! From a logged dataset to regressor inputs: states at the sample times, the observations,
//! and a continuous motion for energy integrals. Only the measured stream is used (joint
//! positions and powers); the dataset's truth and true parameters are never read here.

use crate::dataset::Dataset;
use crate::error::{Error, Result};
use crate::identification::fourier_fit::fit_fourier;
use crate::identification::states::{States, from_fourier, from_smoothing};
use crate::trajectory::Trajectory;
use crate::trajectory::sampled::Sampled;

/// How positions become velocities and accelerations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Route {
    /// Fit the Fourier series of a periodic excitation (the paper's route).
    Fourier {
        /// Base frequency, Hz.
        base_freq_hz: f64,
        /// Harmonics.
        harmonics: usize,
    },
    /// Local polynomial smoothing (any motion).
    Smoothing {
        /// Window, samples (odd).
        window: usize,
        /// Polynomial degree.
        degree: usize,
    },
}

/// A dataset ready for the estimators.
pub struct Prepared {
    /// States at the measured sample times.
    pub states: States,
    /// A continuous motion through them (for energy integrals and predictions).
    pub motion: Box<dyn Trajectory>,
    /// Total motor power at the samples, W.
    pub p_total: Vec<f64>,
    /// Per-motor power, sample-major `[m * n + i]`, W.
    pub p_joint: Vec<f64>,
    /// Joints that move (range of the logged position above 1 mrad), 0-based.
    pub excited: Vec<usize>,
    /// Whether the logger averaged power over each sample period.
    pub power_averaged: bool,
}

/// Prepare the measured stream of `ds` along `route`.
pub fn prepare(ds: &Dataset, route: Route) -> Result<Prepared> {
    let m = &ds.measured;
    let n = m.q.len();
    let states = match route {
        Route::Fourier {
            base_freq_hz,
            harmonics,
        } => from_fourier(
            &fit_fourier(&m.t, &m.q, base_freq_hz, harmonics)?.series,
            &m.t,
        ),
        Route::Smoothing { window, degree } => from_smoothing(&m.t, &m.q, window, degree)?,
    };
    let motion: Box<dyn Trajectory> = match route {
        Route::Fourier {
            base_freq_hz,
            harmonics,
        } => Box::new(fit_fourier(&m.t, &m.q, base_freq_hz, harmonics)?.series),
        Route::Smoothing { .. } => Box::new(Sampled::new(
            states.t.clone(),
            states.q.clone(),
            Some(states.dq.clone()),
            Some(states.ddq.clone()),
        )?),
    };
    let excited: Vec<usize> = (0..n)
        .filter(|&i| {
            let (lo, hi) = m.q[i]
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(*v), b.max(*v))
                });
            hi - lo > 1e-3
        })
        .collect();
    if excited.is_empty() {
        return Err(Error::InvalidInput(
            "no joint moves in this dataset: nothing to identify".into(),
        ));
    }
    let p_joint = (0..m.t.len())
        .flat_map(|k| (0..n).map(move |i| m.p_joint[i][k]))
        .collect();
    Ok(Prepared {
        states,
        motion,
        p_total: m.p_total.clone(),
        p_joint,
        excited,
        power_averaged: ds.meta.measurement.power_averaging,
    })
}
