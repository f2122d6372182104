//! The measured stream: what a data logger records from the twin.
//!
//! Samples are taken every `1 / rate_hz` s (default 10 Hz, as the paper) from the truth rows:
//! - joint positions from encoders: quantised to `encoder_resolution_rad`, plus Gaussian
//!   noise `encoder_sigma_rad`;
//! - per-motor electrical power plus Gaussian noise `joint_power_sigma_W`;
//! - the arm's power from a power meter (the motor sum, or the DC bus clipped at zero:
//!   `power_signal`): Gaussian noise `power_sigma_W` plus a constant
//!   offset `power_offset_W`.
//!
//! Truth row `k` holds the power over `[t_k, t_k + dt)`. Power is sampled instantaneously at
//! the sample time `t_k` (the mean of the two physics steps around it, a second-order
//! estimate centred on `t_k`), as RobotStudio's signal analyser does, or averaged over the
//! sample period `[t_k - T, t_k)` when `power_averaging` is on (an integrating power meter;
//! window energies are then exact; before the recording the robot stood at its first state,
//! [`crate::twin::TwinConfig::settle_s`], so a window reaching back before `t = 0` holds row
//! 0's power there). A meter on its own
//! clock may log the power `power_lag_s` late, and the logger may stamp each sample up to
//! `stamp_jitter_s` off its sampling instant (both 0 by default). Noise and jitter are
//! seeded, so a seed reproduces a dataset bit for bit.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::measurement::PowerSignal;
use crate::twin::record::{Measured, Recording};

/// Sensor noise. All zero means ideal sensors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSettings {
    /// Encoder quantisation step, rad (0 = none).
    pub encoder_resolution_rad: f64,
    /// Encoder noise standard deviation, rad.
    pub encoder_sigma_rad: f64,
    /// Per-motor power noise standard deviation, W.
    #[serde(rename = "joint_power_sigma_W")]
    pub joint_power_sigma_w: f64,
    /// Total-power meter noise standard deviation, W.
    #[serde(rename = "power_sigma_W")]
    pub power_sigma_w: f64,
    /// Total-power meter offset, W.
    #[serde(rename = "power_offset_W")]
    pub power_offset_w: f64,
}

impl NoiseSettings {
    /// Ideal sensors.
    pub const NONE: NoiseSettings = NoiseSettings {
        encoder_resolution_rad: 0.0,
        encoder_sigma_rad: 0.0,
        joint_power_sigma_w: 0.0,
        power_sigma_w: 0.0,
        power_offset_w: 0.0,
    };

    /// Parse a noise TOML file's text (keys as the field names, units in the names).
    pub fn from_toml_str(text: &str, label: &str) -> Result<Self> {
        let n: NoiseSettings = toml::from_str(text).map_err(|e| Error::Toml {
            file: label.to_string(),
            message: e.to_string(),
        })?;
        let vals = [
            n.encoder_resolution_rad,
            n.encoder_sigma_rad,
            n.joint_power_sigma_w,
            n.power_sigma_w,
        ];
        if vals.iter().any(|v| !v.is_finite() || *v < 0.0) || !n.power_offset_w.is_finite() {
            return Err(Error::Toml {
                file: label.to_string(),
                message:
                    "noise values must be finite and non-negative (the offset may be negative)"
                        .into(),
            });
        }
        Ok(n)
    }
}

impl Default for NoiseSettings {
    /// A 20-bit-per-turn class encoder at the link (6e-6 rad steps) with 1e-5 rad noise, 0.5 W
    /// noise per motor, and a calibrated power meter with 1 W noise (no offset: an offset is
    /// indistinguishable from standby power and would be identified as such).
    fn default() -> Self {
        NoiseSettings {
            encoder_resolution_rad: std::f64::consts::TAU / (1u64 << 20) as f64,
            encoder_sigma_rad: 1e-5,
            joint_power_sigma_w: 0.5,
            power_sigma_w: 1.0,
            power_offset_w: 0.0,
        }
    }
}

/// Logger settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSettings {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Average power over each sample period instead of sampling it instantaneously.
    pub power_averaging: bool,
    /// What the power meter measures: the motor sum (`total`, RobotStudio's signal) or the
    /// DC bus (`bus`: the sum clipped at zero, braking energy burnt in the brake resistor).
    #[serde(default)]
    pub power_signal: PowerSignal,
    /// Sensor noise.
    pub noise: NoiseSettings,
    /// Seed of the noise.
    pub seed: u64,
    /// Delay of the power stream behind the joint stream, s (a meter on its own clock, or
    /// its filter): the power logged at `t` is the power at `t - lag`. Rounded to whole
    /// physics steps; >= 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub power_lag_s: f64,
    /// Time-stamp jitter, s: each logged stamp is off its sampling instant by a uniform
    /// error in `[-jitter, jitter]` (host receive time, clock quantisation). Below 0.45
    /// sample periods, so the stamps stay in order.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub stamp_jitter_s: f64,
}

/// Whether an optional setting is at its default 0 (then left out of `meta.json`, so
/// datasets without it read and write as before).
pub(crate) fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Default for SensorSettings {
    fn default() -> Self {
        SensorSettings {
            rate_hz: 10.0,
            power_averaging: false,
            power_signal: PowerSignal::Total,
            noise: NoiseSettings::default(),
            seed: 0,
            power_lag_s: 0.0,
            stamp_jitter_s: 0.0,
        }
    }
}

/// Standard normal sample (`rand_distr`'s ziggurat).
fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    rng.sample(StandardNormal)
}

impl SensorSettings {
    /// Physics steps per sample for a physics step `dt` (s); an error unless the sample
    /// period is a positive whole number of steps.
    pub fn stride(&self, dt: f64) -> Result<usize> {
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Err(Error::InvalidInput(format!(
                "sample rate {} Hz must be positive",
                self.rate_hz
            )));
        }
        let stride = (1.0 / (self.rate_hz * dt)).round() as usize;
        if stride == 0 || ((stride as f64) * dt * self.rate_hz - 1.0).abs() > 1e-9 {
            return Err(Error::InvalidInput(format!(
                "sample period 1/{} s must be a whole number of physics steps ({} s)",
                self.rate_hz, dt
            )));
        }
        if !(self.power_lag_s.is_finite() && self.power_lag_s >= 0.0) {
            return Err(Error::InvalidInput(format!(
                "power lag {} s must be finite and >= 0",
                self.power_lag_s
            )));
        }
        if !(self.stamp_jitter_s.is_finite()
            && self.stamp_jitter_s >= 0.0
            && self.stamp_jitter_s < 0.45 / self.rate_hz)
        {
            return Err(Error::InvalidInput(format!(
                "time-stamp jitter {} s must be >= 0 and below 0.45 sample periods ({} s)",
                self.stamp_jitter_s,
                0.45 / self.rate_hz
            )));
        }
        Ok(stride)
    }
}

/// The power a sample logs at row `at` (the sample's row, or its lag earlier) from the truth
/// rows `p`: the mean of the two steps around it, or, when averaging, of the `stride` steps
/// before it; row 0 alone at the start. An averaging meter's window that reaches back before
/// the recording sees the robot held at its first state, so row 0 stands for those steps.
fn logged_power(p: &[f64], at: usize, stride: usize, averaging: bool) -> f64 {
    match (averaging, at) {
        (_, 0) => p[0],
        (true, _) => {
            let before = stride.saturating_sub(at) as f64;
            (before * p[0] + p[at.saturating_sub(stride)..at].iter().sum::<f64>()) / stride as f64
        }
        _ => {
            let w = &p[at - 1..(at + 1).min(p.len())];
            w.iter().sum::<f64>() / w.len() as f64
        }
    }
}

/// Sample the recording as the logger would.
pub fn measure(rec: &Recording, s: &SensorSettings) -> Result<Measured> {
    let stride = s.stride(rec.dt)?;
    let n = rec.q.len();
    let mut rng = ChaCha8Rng::seed_from_u64(s.seed);
    let mut m = Measured {
        rate_hz: s.rate_hz,
        q: vec![Vec::new(); n],
        p_joint: vec![Vec::new(); n],
        ..Measured::default()
    };
    let noise = &s.noise;
    let lag = (s.power_lag_s / rec.dt).round() as usize;
    for k in (0..rec.len()).step_by(stride) {
        let mut t = rec.t[k];
        if s.stamp_jitter_s > 0.0 {
            // A log starts at its first stamp: none before 0.
            t = (t + rng.random_range(-s.stamp_jitter_s..=s.stamp_jitter_s)).max(0.0);
        }
        m.t.push(t);
        let at = k.saturating_sub(lag);
        for i in 0..n {
            let mut q = rec.q[i][k];
            if noise.encoder_resolution_rad > 0.0 {
                q = (q / noise.encoder_resolution_rad).round() * noise.encoder_resolution_rad;
            }
            m.q[i].push(q + noise.encoder_sigma_rad * gauss(&mut rng));
            let p = logged_power(&rec.p_elec[i], at, stride, s.power_averaging);
            m.p_joint[i].push(p + noise.joint_power_sigma_w * gauss(&mut rng));
        }
        let signal = if s.power_signal.clipped() {
            &rec.p_grid
        } else {
            &rec.p_total
        };
        let p = logged_power(signal, at, stride, s.power_averaging);
        m.p_total
            .push(p + noise.power_offset_w + noise.power_sigma_w * gauss(&mut rng));
    }
    Ok(m)
}
