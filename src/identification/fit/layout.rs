//! The parameter vector of the power model, `z = [theta, c_1..c_n, g_1..g_n, P0_1..P0_n, P0]`: where
//! each parameter sits and what it is called. Indices and names come from here only, so that
//! no caller builds a name and parses it back.

use std::ops::Range;

/// What one entry of the parameter vector `z` is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Param {
    /// Base parameter `k` (0-based, in the model's base-parameter order; SI).
    Base(usize),
    /// Copper-loss coefficient of joint `i` (0-based), W/(N m)^2.
    Copper(usize),
    /// Load-dependent gear friction of joint `i` (0-based): power lost per W transmitted
    /// through the joint, `g_i |tau_i dq_i|`, dimensionless.
    Gear(usize),
    /// Standby power of motor `i` (0-based) alone, W (only when each motor's power is fitted).
    MotorStandby(usize),
    /// Standby power of the arm, W.
    Standby,
}

impl Param {
    /// The parameter's name: base parameters as in `base_names`, then `c<i>_W_per_Nm2`,
    /// `g<i>_gear_friction`, `P0_motor<i>_W` (1-based joints) and `P0_W`.
    pub fn name(self, base_names: &[String]) -> String {
        match self {
            Param::Base(k) => base_names[k].clone(),
            Param::Copper(i) => format!("c{}_W_per_Nm2", i + 1),
            Param::Gear(i) => format!("g{}_gear_friction", i + 1),
            Param::MotorStandby(i) => format!("P0_motor{}_W", i + 1),
            Param::Standby => "P0_W".to_string(),
        }
    }
}

/// Layout of `z = [theta, c_1..c_n, g_1..g_n, P0_1..P0_n, P0]`: `nb` base parameters, a
/// copper-loss coefficient per joint (held at zero by `total`), a gear-friction coefficient
/// per joint for the `gear` estimator, a standby power per motor when each motor's power is
/// fitted, and the arm's standby power last.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Number of base parameters.
    pub base: usize,
    /// Number of joints.
    pub joints: usize,
    /// Whether `z` holds a standby power per motor.
    pub motors: bool,
    /// Whether `z` holds a gear-friction coefficient per joint.
    pub gear: bool,
}

impl Layout {
    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.losses().end + 1 + if self.motors { self.joints } else { 0 }
    }

    /// Always false: `z` holds at least the arm's standby power.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Indices of the base parameters `theta`.
    pub fn theta(&self) -> Range<usize> {
        0..self.base
    }

    /// Indices of the copper-loss coefficients.
    pub fn copper_range(&self) -> Range<usize> {
        self.base..self.base + self.joints
    }

    /// Index of joint `i`'s copper-loss coefficient (0-based).
    pub fn copper(&self, i: usize) -> usize {
        self.base + i
    }

    /// Index of joint `i`'s gear-friction coefficient (0-based; meaningful when `gear`).
    pub fn gear(&self, i: usize) -> usize {
        self.base + self.joints + i
    }

    /// Indices of the loss coefficients (copper, and gear friction when `gear`).
    pub fn losses(&self) -> Range<usize> {
        let per_joint = if self.gear { 2 } else { 1 };
        self.base..self.base + per_joint * self.joints
    }

    /// Whether entry `k` is a loss coefficient ([`Layout::losses`]): kept >= 0, and held at
    /// zero where the data cannot tell it from zero.
    pub fn is_loss(&self, k: usize) -> bool {
        self.losses().contains(&k)
    }

    /// Index of motor `i`'s own standby power (0-based; meaningful when `motors`).
    pub fn motor_standby(&self, i: usize) -> usize {
        self.losses().end + i
    }

    /// Index of the arm's standby power (the last).
    pub fn standby(&self) -> usize {
        self.len() - 1
    }

    /// What entry `k` of `z` is.
    pub fn param(&self, k: usize) -> Param {
        if k < self.base {
            Param::Base(k)
        } else if k < self.base + self.joints {
            Param::Copper(k - self.base)
        } else if k < self.losses().end {
            Param::Gear(k - self.base - self.joints)
        } else if k == self.standby() {
            Param::Standby
        } else {
            Param::MotorStandby(k - self.losses().end)
        }
    }

    /// Every parameter, in order.
    pub fn params(&self) -> impl Iterator<Item = Param> + '_ {
        (0..self.len()).map(|k| self.param(k))
    }

    /// Names of `z`, the base parameters named as in `base_names`.
    pub fn names(&self, base_names: &[String]) -> Vec<String> {
        self.params().map(|p| p.name(base_names)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_layout_names_and_places_every_parameter() {
        let base: Vec<String> = ["a", "b"].iter().map(|s| s.to_string()).collect();
        let with = Layout {
            base: 2,
            joints: 2,
            motors: true,
            gear: true,
        };
        assert_eq!(
            with.names(&base),
            [
                "a",
                "b",
                "c1_W_per_Nm2",
                "c2_W_per_Nm2",
                "g1_gear_friction",
                "g2_gear_friction",
                "P0_motor1_W",
                "P0_motor2_W",
                "P0_W"
            ]
        );
        assert_eq!(with.param(with.copper(1)), Param::Copper(1));
        assert_eq!(with.param(with.gear(1)), Param::Gear(1));
        assert_eq!(with.param(with.motor_standby(0)), Param::MotorStandby(0));
        assert!(with.is_loss(with.gear(1)) && !with.is_loss(with.motor_standby(0)));
        let without = Layout {
            motors: false,
            ..with
        };
        assert_eq!(without.len(), 7);
        assert_eq!(without.param(6), Param::Standby);
        assert_eq!(without.standby(), 6);
        let pmsm = Layout {
            gear: false,
            ..with
        };
        assert_eq!(pmsm.len(), 7);
        assert_eq!(pmsm.param(4), Param::MotorStandby(0));
        assert!(!pmsm.is_loss(4));
    }
}
