//! A joint trajectory as a standalone URScript program for a Universal Robots controller:
//! `movej` to the first pose, then one `servoj(q, 0, 0, t, lookahead_time, gain)` per
//! controller period along the trajectory, then `stopj`. Positions in rad, in the URDF's
//! joint order (the UR order: base, shoulder, elbow, wrist 1-3).
//!
//! `servoj` blocks for `t` seconds, so the program replays the trajectory in real time when
//! `t` is the controller's period: 0.002 s on an e-Series (500 Hz), 0.008 s on a CB3
//! (125 Hz). Sent to the controller's secondary interface (port 30002) or loaded as a
//! script file, the `def ... end` block runs as a program.

use std::fmt::Write as _;

use crate::error::{Error, Result};

use super::Trajectory;

/// Settings of [`urscript`].
#[derive(Debug, Clone, PartialEq)]
pub struct UrScriptOptions {
    /// Program name, a URScript identifier (`excitation_01`).
    pub name: String,
    /// Controller period, s: each `servoj` step lasts this long.
    pub period_s: f64,
    /// `servoj` look-ahead time, s (UR allows 0.03-0.2; larger smooths, and lags, more).
    pub lookahead_time_s: f64,
    /// `servoj` proportional gain (UR allows 100-2000).
    pub gain: f64,
    /// Joint speed of the `movej` to the first pose, rad/s.
    pub approach_speed_rad_s: f64,
    /// Joint acceleration of that `movej` and deceleration of the final `stopj`, rad/s^2.
    pub approach_accel_rad_s2: f64,
}

impl UrScriptOptions {
    /// UR's usual `servoj` settings (look-ahead 0.1 s, gain 300) at `period_s` (s), and a
    /// slow approach (0.25 rad/s, 0.5 rad/s^2).
    pub fn new(name: &str, period_s: f64) -> Self {
        UrScriptOptions {
            name: name.to_string(),
            period_s,
            lookahead_time_s: 0.1,
            gain: 300.0,
            approach_speed_rad_s: 0.25,
            approach_accel_rad_s2: 0.5,
        }
    }

    /// Refuse what the controller would refuse or misrun.
    fn check(&self) -> Result<()> {
        let mut chars = self.name.chars();
        let identifier = chars
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && chars.all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !identifier {
            return Err(Error::InvalidInput(format!(
                "URScript program name '{}' is not an identifier (letters, digits, '_')",
                self.name
            )));
        }
        let checks = [
            ("controller period (s)", self.period_s, 1e-4, 1.0),
            (
                "servoj lookahead_time (s)",
                self.lookahead_time_s,
                0.03,
                0.2,
            ),
            ("servoj gain", self.gain, 100.0, 2000.0),
            (
                "approach speed (rad/s)",
                self.approach_speed_rad_s,
                1e-3,
                10.0,
            ),
            (
                "approach acceleration (rad/s^2)",
                self.approach_accel_rad_s2,
                1e-3,
                40.0,
            ),
        ];
        for (what, v, lo, hi) in checks {
            if !(v >= lo && v <= hi) {
                return Err(Error::InvalidInput(format!(
                    "{what} = {v} must be in [{lo}, {hi}]"
                )));
            }
        }
        Ok(())
    }
}

/// `traj` as a URScript program (see the module docs): sampled every `opts.period_s` from 0
/// to its duration (rounded to whole periods), positions to 1e-6 rad.
///
/// Errors ([`Error::InvalidInput`]): options out of range ([`UrScriptOptions`]), a duration
/// that is not finite and positive, a non-finite position.
pub fn urscript(traj: &dyn Trajectory, opts: &UrScriptOptions) -> Result<String> {
    opts.check()?;
    let duration = traj.duration();
    if !(duration.is_finite() && duration > 0.0) {
        return Err(Error::InvalidInput(format!(
            "trajectory duration {duration} s must be finite and positive"
        )));
    }
    let n = traj.dof();
    let steps = (duration / opts.period_s).round() as usize;
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut pose = |t: f64| -> Result<String> {
        traj.sample(t, &mut q, &mut dq, &mut ddq);
        if let Some(v) = q.iter().find(|v| !v.is_finite()) {
            return Err(Error::InvalidInput(format!(
                "position {v} rad at t = {t} s is not finite"
            )));
        }
        let list: Vec<String> = q.iter().map(|v| format!("{v:.6}")).collect();
        Ok(format!("[{}]", list.join(", ")))
    };
    let mut out = String::with_capacity(64 * (steps + 8));
    let _ = writeln!(out, "def {}():", opts.name);
    let _ = writeln!(
        out,
        "  # {duration:.3} s joint trajectory (rad), one servoj every {} s; written by powertwin",
        opts.period_s
    );
    let _ = writeln!(
        out,
        "  movej({}, a={}, v={})",
        pose(0.0)?,
        opts.approach_accel_rad_s2,
        opts.approach_speed_rad_s
    );
    for k in 0..=steps {
        let t = (k as f64 * opts.period_s).min(duration);
        let _ = writeln!(
            out,
            "  servoj({}, 0, 0, {}, {}, {})",
            pose(t)?,
            opts.period_s,
            opts.lookahead_time_s,
            opts.gain
        );
    }
    let _ = writeln!(out, "  stopj({})", opts.approach_accel_rad_s2);
    out.push_str("end\n");
    Ok(out)
}
