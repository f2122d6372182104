//! Jerk-limited rest-to-rest motion profile ("S-curve", double S) of a path parameter.
//!
//! The parameter goes from 0 to a distance `D` starting and ending at rest (zero speed and
//! acceleration) with speed at most `v`, |acceleration| at most `a` and |jerk| at most `j`.
//! The jerk is `+j, 0, -j` while accelerating (durations `Tj, Ta - 2 Tj, Tj`), zero while
//! cruising (`Tv`), and `-j, 0, +j` while decelerating, which mirrors the acceleration; speed
//! and acceleration are continuous. Following the double-S profile of Biagiotti and
//! Melchiorri (*Trajectory Planning for Automatic Machines and Robots*, 2008, section 3.4)
//! with zero end speeds:
//!
//! - `v j >= a^2`: the acceleration reaches `a` (`Tj = a / j`, `Ta = Tj + v / a`); otherwise
//!   it peaks at `sqrt(v j)` (`Tj = sqrt(v / j)`, `Ta = 2 Tj`).
//! - `D >= v Ta`: the speed `v` is reached and held for `Tv = D / v - Ta`.
//! - Shorter moves never reach `v` (`Tv = 0`): if `D >= 2 a^3 / j^2` the acceleration still
//!   reaches `a` (`Tj = a / j`, `Ta = Tj / 2 + sqrt(Tj^2 / 4 + D / a)`), else the profile is
//!   pure jerk (`Tj = (D / (2 j))^(1/3)`, `Ta = 2 Tj`).
//!
//! Every case takes the least time the three bounds allow for this jerk pattern. Units
//! follow the distance: with `D` in m, speeds are m/s, accelerations m/s^2, jerks m/s^3.

use crate::error::{Error, Result};

/// A rest-to-rest jerk-limited profile (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SCurve {
    /// Distance `D`.
    distance: f64,
    /// Jerk magnitude used, `j`.
    jerk: f64,
    /// Duration of each constant-jerk phase at the ends of the acceleration, `Tj`, s.
    tj: f64,
    /// Duration of the acceleration (and of the deceleration), `Ta`, s.
    ta: f64,
    /// Duration of the cruise, `Tv`, s.
    tv: f64,
    /// Highest speed, reached at the end of the acceleration.
    peak_speed: f64,
}

impl SCurve {
    /// The fastest profile over `distance` (>= 0) within `max_speed`, `max_accel` and
    /// `max_jerk` (each finite and > 0). A zero distance gives a profile of zero duration.
    ///
    /// Errors ([`Error::InvalidInput`]): a negative or non-finite distance, or a bound that
    /// is not finite and positive.
    pub fn new(distance: f64, max_speed: f64, max_accel: f64, max_jerk: f64) -> Result<SCurve> {
        if !(distance.is_finite() && distance >= 0.0) {
            return Err(Error::InvalidInput(format!(
                "profile distance {distance} must be finite and non-negative"
            )));
        }
        for (name, value) in [
            ("speed", max_speed),
            ("acceleration", max_accel),
            ("jerk", max_jerk),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::InvalidInput(format!(
                    "profile {name} bound {value} must be finite and positive"
                )));
            }
        }
        let (v, a, j) = (max_speed, max_accel, max_jerk);
        let (mut tj, mut ta) = if v * j >= a * a {
            (a / j, a / j + v / a)
        } else {
            let tj = (v / j).sqrt();
            (tj, 2.0 * tj)
        };
        let mut tv = distance / v - ta;
        if tv < 0.0 {
            tv = 0.0;
            if distance >= 2.0 * a * a * a / (j * j) {
                tj = a / j;
                ta = 0.5 * tj + (0.25 * tj * tj + distance / a).sqrt();
            } else {
                tj = (distance / (2.0 * j)).cbrt();
                ta = 2.0 * tj;
            }
        }
        Ok(SCurve {
            distance,
            jerk: j,
            tj,
            ta,
            tv,
            peak_speed: j * tj * (ta - tj),
        })
    }

    /// Total duration `2 Ta + Tv`, s.
    pub fn duration(&self) -> f64 {
        2.0 * self.ta + self.tv
    }

    /// Highest speed of the profile (the bound `v` when the move is long enough to cruise).
    pub fn peak_speed(&self) -> f64 {
        self.peak_speed
    }

    /// Highest |acceleration| of the profile, `j Tj`.
    pub fn peak_acceleration(&self) -> f64 {
        self.jerk * self.tj
    }

    /// Whether the profile cruises at its speed bound (`Tv > 0`).
    pub fn cruises(&self) -> bool {
        self.tv > 0.0
    }

    /// Position, speed and acceleration at time `t` (s), clamped to `[0, duration]`. Exactly
    /// `[0, 0, 0]` at the start and `[D, 0, 0]` at the end.
    pub fn sample(&self, t: f64) -> [f64; 3] {
        let total = self.duration();
        if t.is_nan() || t <= 0.0 || total <= 0.0 {
            return [0.0, 0.0, 0.0];
        }
        if t >= total {
            return [self.distance, 0.0, 0.0];
        }
        if t <= self.ta {
            return self.accelerating(t);
        }
        if t <= self.ta + self.tv {
            let s_a = 0.5 * self.peak_speed * self.ta;
            return [s_a + self.peak_speed * (t - self.ta), self.peak_speed, 0.0];
        }
        let [s, v, a] = self.accelerating(total - t);
        [self.distance - s, v, -a]
    }

    /// State at time `t` in `[0, Ta]` of the acceleration phase.
    fn accelerating(&self, t: f64) -> [f64; 3] {
        let (j, tj, ta, vp) = (self.jerk, self.tj, self.ta, self.peak_speed);
        if t <= tj {
            return [j * t * t * t / 6.0, 0.5 * j * t * t, j * t];
        }
        if t <= ta - tj {
            let a = j * tj;
            let (s1, v1, d) = (j * tj * tj * tj / 6.0, 0.5 * j * tj * tj, t - tj);
            return [s1 + v1 * d + 0.5 * a * d * d, v1 + a * d, a];
        }
        // Mirror of the first phase about the end of the acceleration (s = vp Ta / 2).
        let r = ta - t;
        [
            0.5 * vp * ta - vp * r + j * r * r * r / 6.0,
            vp - 0.5 * j * r * r,
            j * r,
        ]
    }
}
