//! What a twin run records.
//!
//! [`Recording`] is the ground truth at the physics rate: row `k` holds the state Rapier
//! produced at `t_k = k dt` and the torque applied (held constant, zero-order hold) over
//! `[t_k, t_k + dt)`. Mechanical power of row `k` is the work of that torque over the step
//! divided by `dt`: `p_mech_i = tau_i (q_i(t_k + dt) - q_i(t_k)) / dt`, so summing power
//! times `dt` gives exactly the applied work. [`Measured`] is what a data logger would see:
//! joint positions and powers at a lower rate with seeded sensor noise.
//!
//! Per-joint series are stored joint-major: `q[i][k]` is joint `i` at row `k`.

/// Ground truth at the physics rate.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Recording {
    /// Physics step, s.
    pub dt: f64,
    /// Time of each row, s.
    pub t: Vec<f64>,
    /// Joint positions Rapier produced, rad.
    pub q: Vec<Vec<f64>>,
    /// Joint velocities Rapier produced, rad/s.
    pub dq: Vec<Vec<f64>>,
    /// Reference positions, rad.
    pub q_ref: Vec<Vec<f64>>,
    /// Reference velocities, rad/s.
    pub dq_ref: Vec<Vec<f64>>,
    /// Reference accelerations, rad/s^2.
    pub ddq_ref: Vec<Vec<f64>>,
    /// Joint torque applied to Rapier over the step (motor side of the joint, i.e. including
    /// what friction and rotor inertia consume), N m.
    pub tau: Vec<Vec<f64>>,
    /// Mechanical power per joint over the step, W.
    pub p_mech: Vec<Vec<f64>>,
    /// Electrical power per motor over the step (motor model), W.
    pub p_elec: Vec<Vec<f64>>,
    /// Total motor power, sum of `p_elec`, W (what RobotStudio reports), plus the cabinet
    /// power the meter sees ([`crate::twin::TwinConfig::cabinet_power_w`], usually 0).
    pub p_total: Vec<f64>,
    /// Grid-side power with a DC bus that cannot return energy: the motor sum clipped at 0,
    /// plus the cabinet power the meter sees, W.
    pub p_grid: Vec<f64>,
    /// Payload mass attached to the flange, kg.
    pub payload_mass: Vec<f64>,
}

/// Logged measurements at a lower rate, with sensor noise.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Measured {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Sample times, s.
    pub t: Vec<f64>,
    /// Encoder joint positions (quantised, noisy), rad.
    pub q: Vec<Vec<f64>>,
    /// Per-motor electrical power (noisy), W.
    pub p_joint: Vec<Vec<f64>>,
    /// Total motor power from the power meter (noisy, with offset), W.
    pub p_total: Vec<f64>,
}

impl Recording {
    /// An empty recording of `n` joints at step `dt` (s), with room for `rows` rows.
    pub fn with_capacity(n: usize, rows: usize, dt: f64) -> Recording {
        let per_joint = || vec![Vec::with_capacity(rows); n];
        let series = || Vec::with_capacity(rows);
        Recording {
            dt,
            t: series(),
            q: per_joint(),
            dq: per_joint(),
            q_ref: per_joint(),
            dq_ref: per_joint(),
            ddq_ref: per_joint(),
            tau: per_joint(),
            p_mech: per_joint(),
            p_elec: per_joint(),
            p_total: series(),
            p_grid: series(),
            payload_mass: series(),
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Total motor energy, J (sum of `p_total dt`).
    pub fn energy_total(&self) -> f64 {
        self.p_total.iter().sum::<f64>() * self.dt
    }

    /// Grid-side energy, J (sum of `p_grid dt`).
    pub fn energy_grid(&self) -> f64 {
        self.p_grid.iter().sum::<f64>() * self.dt
    }

    /// Energy, J, of the motor sum (or of the grid-side power when `grid`) over the rows
    /// whose time lies in `[t0, t1)` (s): the span a log sampled from `t0` to `t1` covers.
    /// The run goes on after its last logged sample (up to one sample period), so the whole
    /// run's energy is more than that log's.
    pub fn energy_between(&self, t0: f64, t1: f64, grid: bool) -> f64 {
        let p = if grid { &self.p_grid } else { &self.p_total };
        self.t
            .iter()
            .zip(p)
            .filter(|(t, _)| **t >= t0 - 1e-9 && **t < t1 - 1e-9)
            .map(|(_, p)| p)
            .sum::<f64>()
            * self.dt
    }
}
