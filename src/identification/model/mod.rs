//! The identified power model (paper eqs. 9–14): base parameters plus motor-loss terms.
//!
//! Predicted total motor power at a state is
//! `P = sum_i [ dq_i tau_i + c_i tau_i^2 + P0_i ]` with `tau_i = W_base,i(q, dq, ddq) theta`.
//! For the paper's efficiency model `c = 0` and `theta` is the base-parameter vector divided
//! by the motor efficiency (eq. 12: the method cannot separate them); for the PMSM model
//! `theta` is in SI units and `c_i` (W/(N m)^2), `P0_i` (W) are identified too.
//! Energy over a trajectory (eq. 14) integrates that power in time.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::dynamics::base_params::{BaseParams, SamplingOptions};
use crate::dynamics::regressor::regressor;
use crate::dynamics::{ParamLayout, Workspace};
use crate::error::{Error, Result};
use crate::identification::tuning;
use crate::measurement::PowerSignal;
use crate::model::Robot;
use crate::model::payload::PayloadEvent;
use crate::model::payload::{Payload, attach};
use crate::trajectory::Trajectory;

mod predict;
mod states;
mod stribeck;

pub use predict::{EnergyPrediction, Prediction};
use states::StateEval;
pub use stribeck::Stribeck;

/// The motor efficiency a user takes from a data sheet when nothing better is known: the
/// middle of the paper's 83–92 % (Liu et al. 2018). Used to add a known payload to an
/// efficiency-scaled model (the paper's method cannot separate the efficiency) and by the
/// no-identification baseline; never read from a twin's drives.
pub const DATASHEET_EFFICIENCY: f64 = 0.87;

/// Version of the model file schema (the `model` object of `model.json`) that this library
/// writes and reads; see docs/design/model-schema.md. A file without `schema_version` is
/// version 1.
pub const SCHEMA_VERSION: u32 = 1;

/// The schema version of a file that does not state one.
fn unversioned_schema() -> u32 {
    1
}

/// Check the `schema_version` of a serialised [`PowerModel`] (a JSON object) before reading
/// it: absent means version 1; any version other than [`SCHEMA_VERSION`] is an
/// [`Error::InvalidInput`] naming it (the caller adds the file name).
pub fn check_schema_version(model: &serde_json::Value) -> Result<()> {
    match model.get("schema_version") {
        None => Ok(()),
        Some(v) if v.as_u64() == Some(u64::from(SCHEMA_VERSION)) => Ok(()),
        Some(v) => Err(Error::InvalidInput(format!(
            "model schema_version {v} is not supported: this powertwin ({}) reads schema \
             version {SCHEMA_VERSION} (see docs/design/model-schema.md)",
            env!("CARGO_PKG_VERSION")
        ))),
    }
}

/// Base-parameter power model of one robot. Serialised as the `model` object of
/// `model.json` (schema: docs/design/model-schema.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PowerModel {
    /// Version of the file schema ([`SCHEMA_VERSION`] when written by this library; 1 when a
    /// file does not state it).
    #[serde(default = "unversioned_schema")]
    pub schema_version: u32,
    /// Robot name (a model only applies to its robot).
    pub robot: String,
    /// Parameter layout of the underlying standard vector.
    pub layout: ParamLayout,
    /// Base-parameter names, in `theta` order.
    pub names: Vec<String>,
    /// Columns of the standard regressor that form the base regressor.
    pub columns: Vec<usize>,
    /// Base-parameter values (divided by the efficiency when `efficiency_scaled`).
    pub theta: Vec<f64>,
    /// Whether `theta` is scaled by 1/eta (efficiency motor model).
    pub efficiency_scaled: bool,
    /// Copper-loss coefficient per joint, W/(N m)^2 (0 for the efficiency model).
    #[serde(rename = "copper_W_per_Nm2")]
    pub copper: Vec<f64>,
    /// Load-dependent gear friction per joint: power lost per W transmitted, `g_i |tau_i
    /// dq_i|`, dimensionless; empty when the model has no such term (an estimator without it,
    /// or an older file).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gear_friction: Vec<f64>,
    /// Constant power per joint, W (standby, auxiliaries, meter offset; only their sum is
    /// identifiable from total power, stored on joint 1).
    #[serde(rename = "constant_W")]
    pub constant: Vec<f64>,
    /// The power signal modelled: a clipped one (DC bus, grid) is `max(P, 0)` of the motor
    /// sum `P`.
    #[serde(default)]
    pub signal: PowerSignal,
    /// Covariance of `z = [theta, copper, gear_friction, P0]` from the fit, row-major,
    /// [`PowerModel::params`] squared entries (units: squares of the parameters'); empty when
    /// unknown.
    #[serde(default)]
    pub covariance: Vec<f64>,
    /// Standard deviation of the mean-power error on motions the model was not fitted on
    /// that its parameter covariance does not explain (cross-validated), W.
    #[serde(default, rename = "structure_sigma_W")]
    pub structure_sigma: f64,
    /// Relative standard deviation of the mean active power `|P - P0|` on motions the model
    /// was not fitted on that its parameter covariance does not explain (cross-validated),
    /// dimensionless: the part of the structure error that grows with how hard the robot
    /// works.
    #[serde(default)]
    pub structure_rel: f64,
    /// Standard deviation of the mean-power error the cross-validation pieces of one fold
    /// share, W: what leaving a whole log out of the fit costs. `structure_sigma_W` and
    /// `structure_rel` are a piece's own error beyond it. A prediction takes it in proportion
    /// to the time the motion rests, where no log was fitted
    /// ([`crate::identification::tuning::FOLD_ERROR_REST_SHARE`]). Default 0 (a model file
    /// from before it, whose two parts above hold it).
    #[serde(default, rename = "structure_fold_W")]
    pub structure_fold: f64,
    /// Least mean active power at which a prediction takes the relative part of its structure
    /// error, W: the cross-validation pieces' mean active power `|P - P0|`. The pieces cannot
    /// tell a constant error from a proportional one below the activity they cover, so a
    /// motion less active than them takes the watts they missed by
    /// (docs/experiments.md#intervals-for-motions-unlike-the-identification-data,
    /// docs/experiments.md#the-mean-of-the-two-structures-cross-validated).
    #[serde(default, rename = "structure_active_W")]
    pub structure_active: f64,
    /// For a clipped signal (DC bus, grid): the lowest power the identification logs
    /// measured (their 1st percentile), W. Below it the meter was never seen: a cabinet load
    /// after the bus clip puts a floor under the reading that the fit cannot find from logs
    /// that never reach it. A prediction adds half the energy its signal spends below this
    /// level to its standard deviation (`None`: no such term, an unclipped signal or an older
    /// file).
    #[serde(
        default,
        rename = "lowest_seen_W",
        skip_serializing_if = "Option::is_none"
    )]
    pub lowest_seen: Option<f64>,
    /// For a clipped signal (DC bus, grid): the floor under the reading, W. A meter that sees
    /// a load the bus clip does not (a cabinet after the clip) reads `max(P, F)` of the
    /// modelled power `P`, whose constant has absorbed that load. Read from the logs where
    /// the arm brakes them down to it, else the fitted constant less the drive file's standby
    /// powers within `[0, lowest_seen_W]` (`None`: 0, no drive file's standby, an unclipped
    /// signal or an older file).
    #[serde(
        default,
        rename = "bus_floor_W",
        skip_serializing_if = "Option::is_none"
    )]
    pub bus_floor: Option<f64>,
    /// The heaviest payload the identification logs carried (tool and load at the flange),
    /// kg. A prediction with a heavier payload adds
    /// [`crate::identification::tuning::UNSEEN_LOAD_LOSS`] of the mechanical energy the excess
    /// moves through the joints to its standard deviation: losses that grow with the
    /// transmitted torque (gear friction) cannot be told from logs that never carried it
    /// (`None`: no such term, an older file).
    #[serde(
        default,
        rename = "payload_seen_kg",
        skip_serializing_if = "Option::is_none"
    )]
    pub payload_seen: Option<f64>,
    /// The least joint speed identification fitted, rad/s: every sample fitted had each
    /// excited joint at least this fast, so how the friction changes below it is not in the
    /// logs (`None`: a model not fitted by speed, or an older file).
    #[serde(
        default,
        rename = "min_speed_rad_s",
        skip_serializing_if = "Option::is_none"
    )]
    pub min_speed: Option<f64>,
    /// Lag of the logged power behind the logged joints found in the identification logs, s
    /// (positive: the power is late; a meter on its own clock or with a filter). Predicting
    /// the power at a log's samples shifts by it; energies of motions do not depend on it.
    #[serde(default, skip_serializing_if = "zero_lag")]
    pub power_lag_s: f64,
    /// The same robot's model of the other friction structure, fitted on the same logs: with
    /// load-dependent gear friction (`gear`) when this model has none, without it (`pmsm`)
    /// when it has. The excitations show how large the friction is where they move, not its
    /// law where other motions go (how it grows with the transmitted torque and differs with
    /// the direction of the power flow, which periodic motions that return to their start
    /// barely weigh), so the two are taken as equally likely: a prediction's power is the
    /// mean of the two models' and half their difference on the motion is in its standard
    /// deviation (`alternative_J`). `None`: the other structure could not be fitted,
    /// or an older file. Read from `without_gear` in files of earlier versions.
    #[serde(
        default,
        alias = "without_gear",
        skip_serializing_if = "Option::is_none"
    )]
    pub alternative: Option<Box<PowerModel>>,
    /// Per joint, the drive file's Stribeck law ([`Stribeck`]; `None` where it gives none):
    /// how far the dry friction rises below the speeds the logs were fitted at, which they
    /// barely show. The model's Coulomb friction follows it at
    /// [`crate::identification::tuning::STRIBECK_SHARE`] of its rise, in the fit and in
    /// predictions ([`PowerModel::coulomb_factor`]); a prediction adds the energy the whole
    /// rise would cost beyond that to its standard deviation (`stribeck_J`). Empty: the plain
    /// Coulomb law (no drive file, or an older file).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stribeck: Vec<Option<Stribeck>>,
}

/// Whether a model has no power lag (then left out of the file, as before there was one).
fn zero_lag(v: &f64) -> bool {
    *v == 0.0
}

impl PowerModel {
    /// A zero model over the base parameters of `robot` for `layout`.
    pub fn new(robot: &Robot, layout: ParamLayout, efficiency_scaled: bool) -> Result<PowerModel> {
        let base = BaseParams::compute(robot, layout, &SamplingOptions::default())?;
        Ok(PowerModel {
            schema_version: SCHEMA_VERSION,
            robot: robot.name().to_string(),
            layout,
            names: base.base_names(),
            columns: base.independent().to_vec(),
            theta: vec![0.0; base.rank()],
            efficiency_scaled,
            copper: vec![0.0; robot.dof()],
            gear_friction: Vec::new(),
            constant: vec![0.0; robot.dof()],
            signal: PowerSignal::Total,
            covariance: Vec::new(),
            structure_sigma: 0.0,
            structure_rel: 0.0,
            structure_fold: 0.0,
            structure_active: 0.0,
            lowest_seen: None,
            bus_floor: None,
            payload_seen: None,
            min_speed: None,
            power_lag_s: 0.0,
            alternative: None,
            stribeck: Vec::new(),
        })
    }

    /// Check a model read from a file against `robot`: the schema version, the robot, the vector lengths, finite
    /// values, and a covariance of the right size. Errors name the field.
    pub fn validate(&self, robot: &Robot) -> Result<()> {
        if self.schema_version != SCHEMA_VERSION {
            return Err(Error::InvalidInput(format!(
                "model file: schema_version {} is not supported (this powertwin reads version \
                 {SCHEMA_VERSION})",
                self.schema_version
            )));
        }
        self.check_robot(robot)?;
        let bad = |m: String| Error::InvalidInput(format!("model file: {m}"));
        self.check_base_shape(robot).map_err(bad)?;
        self.check_joint_shapes(robot.dof()).map_err(bad)?;
        self.check_values().map_err(bad)?;
        self.check_alternative(robot).map_err(bad)
    }

    /// Check the layout against `robot`'s and the base parameters: as many names and values
    /// as columns, each column within the layout; or why not.
    fn check_base_shape(&self, robot: &Robot) -> std::result::Result<(), String> {
        let nb = self.columns.len();
        if self.layout.len()
            != ParamLayout::new(robot, self.layout.friction, self.layout.armature).len()
        {
            return Err("the parameter layout does not match the robot".into());
        }
        if self.names.len() != nb || self.theta.len() != nb {
            return Err(format!(
                "{} names and {} values for {nb} base parameters",
                self.names.len(),
                self.theta.len()
            ));
        }
        if let Some(c) = self.columns.iter().find(|&&c| c >= self.layout.len()) {
            return Err(format!(
                "column {c} is outside the {}-column layout",
                self.layout.len()
            ));
        }
        Ok(())
    }

    /// Check the per-joint vectors for `n` joints (the optional ones empty or of length `n`,
    /// each Stribeck law valid) and the covariance (empty or parameters squared); or why not.
    fn check_joint_shapes(&self, n: usize) -> std::result::Result<(), String> {
        for (what, v, len) in [
            ("copper_W_per_Nm2", &self.copper, n),
            ("constant_W", &self.constant, n),
        ] {
            if v.len() != len {
                return Err(format!("{what} has {} entries for {len} joints", v.len()));
            }
        }
        if !(self.stribeck.is_empty() || self.stribeck.len() == n) {
            return Err(format!(
                "stribeck has {} entries for {n} joints",
                self.stribeck.len()
            ));
        }
        if let Some(j) = self
            .stribeck
            .iter()
            .position(|s| s.is_some_and(|s| !s.is_valid()))
        {
            return Err(format!(
                "stribeck of joint {}: rise must be finite and >= 0, speed_rad_s finite and > 0",
                j + 1
            ));
        }
        if !(self.gear_friction.is_empty() || self.gear_friction.len() == n) {
            return Err(format!(
                "gear_friction has {} entries for {n} joints",
                self.gear_friction.len()
            ));
        }
        let np = self.params();
        if !self.covariance.is_empty() && self.covariance.len() != np * np {
            return Err(format!(
                "covariance has {} entries, expected {np}^2 = {}",
                self.covariance.len(),
                np * np
            ));
        }
        Ok(())
    }

    /// Check that every value is finite and the structure terms (W, or relative), the bus
    /// floor (W) and the payload seen (kg) are non-negative; or why not.
    fn check_values(&self) -> std::result::Result<(), String> {
        for (what, v) in [
            ("theta", &self.theta),
            ("copper_W_per_Nm2", &self.copper),
            ("gear_friction", &self.gear_friction),
            ("constant_W", &self.constant),
            ("covariance", &self.covariance),
        ] {
            crate::error::ensure_finite(v, what).map_err(|e| e.to_string())?;
        }
        for (what, v) in [
            ("structure_sigma_W", self.structure_sigma),
            ("structure_rel", self.structure_rel),
            ("structure_fold_W", self.structure_fold),
            ("structure_active_W", self.structure_active),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{what} = {v} must be finite and >= 0"));
            }
        }
        if let Some(v) = self.lowest_seen
            && !v.is_finite()
        {
            return Err(format!("lowest_seen_W = {v} must be finite"));
        }
        if let Some(v) = self.bus_floor
            && !(v.is_finite() && v >= 0.0)
        {
            return Err(format!("bus_floor_W = {v} must be finite and >= 0"));
        }
        if let Some(v) = self.payload_seen
            && !(v.is_finite() && v >= 0.0)
        {
            return Err(format!("payload_seen_kg = {v} must be finite and >= 0"));
        }
        Ok(())
    }

    /// Check the alternative model, if any: the other friction structure over the same base
    /// parameters, without an alternative of its own, and valid for `robot`; or why not.
    fn check_alternative(&self, robot: &Robot) -> std::result::Result<(), String> {
        let Some(alt) = &self.alternative else {
            return Ok(());
        };
        if self.gear_friction.is_empty() == alt.gear_friction.is_empty() {
            return Err(
                "the alternative model must have gear_friction exactly when this one has none"
                    .into(),
            );
        }
        if alt.alternative.is_some() || alt.columns != self.columns {
            return Err(
                "the alternative model must have this model's base parameters and no \
                 alternative of its own"
                    .into(),
            );
        }
        alt.validate(robot).map_err(|e| format!("alternative: {e}"))
    }

    /// Check that the model belongs to `robot`.
    pub fn check_robot(&self, robot: &Robot) -> Result<()> {
        if self.robot != robot.name() || self.layout.dof != robot.dof() {
            return Err(Error::InvalidInput(format!(
                "the model was identified for robot '{}' ({} joints), not '{}' ({} joints)",
                self.robot,
                self.layout.dof,
                robot.name(),
                robot.dof()
            )));
        }
        Ok(())
    }

    /// Joint torques `tau = W_base theta` (N m, or N m / eta when efficiency-scaled) and the
    /// total power (W) at one state. `w` is scratch of size `n x layout.len()`.
    pub fn power(
        &self,
        robot: &Robot,
        ws: &mut Workspace,
        w: &mut DMatrix<f64>,
        q: &[f64],
        dq: &[f64],
        ddq: &[f64],
    ) -> f64 {
        regressor(robot, ws, &self.layout, q, dq, ddq, w);
        (0..robot.dof()).fold(0.0, |p, i| {
            p + self.joint_power(self.torque(w, i), i, dq[i])
        })
    }

    /// Predicted power of motor `i` (0-based), W: `dq_i tau_i + c_i tau_i^2 + g_i |dq_i
    /// tau_i| + P0_i` at its torque `tau` ([`PowerModel::torque`] of the state).
    fn joint_power(&self, tau: f64, i: usize, dq_i: f64) -> f64 {
        let mech = dq_i * tau;
        mech + self.copper[i] * tau * tau + self.gear(i) * mech.abs() + self.constant[i]
    }

    /// Joint `i`'s gear-friction coefficient (0 without the term).
    fn gear(&self, i: usize) -> f64 {
        self.gear_friction.get(i).copied().unwrap_or(0.0)
    }

    /// Number of parameters the covariance covers, `z = [theta, copper, gear_friction,
    /// P0]`: `nb + n + 1`, and `n` more with gear friction.
    pub fn params(&self) -> usize {
        self.columns.len() + self.copper.len() + self.gear_friction.len() + 1
    }

    /// Predicted energy (J) of following `traj`, integrating the power at step `dt` (s) with
    /// the trapezoidal rule (paper eq. 14).
    pub fn energy(&self, robot: &Robot, traj: &dyn Trajectory, dt: f64) -> Result<f64> {
        Ok(self
            .energy_with_payloads(robot, traj, &[], 1.0, dt)?
            .motor_j)
    }

    /// The model of the same robot carrying `payload` at the flange, predicted from the
    /// payload's known mass properties (no new data): the last link's standard inertial
    /// parameters grow by the payload's (in the last link frame), and that change is mapped
    /// onto the base parameters through the regrouping relations. An efficiency-scaled model
    /// divides the change by `efficiency`, the drives' nominal efficiency (power alone cannot
    /// separate it; the paper's eq. 12); a model in SI units ignores it.
    ///
    /// Errors: a non-physical combined body, an efficiency outside (0, 1], or a model whose
    /// base columns differ from the robot's (a model for another robot or layout).
    pub fn with_payload(
        &self,
        robot: &Robot,
        payload: &Payload,
        efficiency: f64,
    ) -> Result<PowerModel> {
        let base = self.base_params(robot)?;
        self.with_payload_on(&base, robot, payload, efficiency)
    }

    /// The base-parameter set of `robot` this model is written in, with its regrouping
    /// relations. Errors: a model of another robot, or columns that are not that set.
    pub fn base_params(&self, robot: &Robot) -> Result<BaseParams> {
        self.check_robot(robot)?;
        let base = BaseParams::compute(robot, self.layout, &SamplingOptions::default())?;
        if base.independent() != self.columns.as_slice() {
            return Err(Error::InvalidInput(
                "the model's base parameters are not those of this robot".into(),
            ));
        }
        Ok(base)
    }

    /// [`PowerModel::with_payload`] with the base-parameter set already computed.
    fn with_payload_on(
        &self,
        base: &BaseParams,
        robot: &Robot,
        payload: &Payload,
        efficiency: f64,
    ) -> Result<PowerModel> {
        if !(efficiency > 0.0 && efficiency <= 1.0) {
            return Err(Error::InvalidInput(format!(
                "efficiency {efficiency} must be in (0, 1]"
            )));
        }
        let scale = if self.efficiency_scaled {
            1.0 / efficiency
        } else {
            1.0
        };
        let mut model = self.clone();
        for (t, d) in model
            .theta
            .iter_mut()
            .zip(self.payload_delta(base, robot, payload)?)
        {
            *t += scale * d;
        }
        Ok(model)
    }

    /// The change of the base parameters (SI, not scaled by 1/eta) when `payload` is
    /// attached to the flange: the last link's standard parameters grow by the payload's,
    /// mapped through the regrouping relations of `base`.
    pub fn payload_delta(
        &self,
        base: &BaseParams,
        robot: &Robot,
        payload: &Payload,
    ) -> Result<Vec<f64>> {
        let last = robot.dof() - 1;
        let before = robot.standard_params()[last];
        let after = attach(robot, payload)?.standard_params()[last];
        let mut delta = vec![0.0; self.layout.len()];
        let start = self.layout.link_start(last);
        for (k, (a, b)) in after.iter().zip(&before).enumerate() {
            delta[start + k] = a - b;
        }
        base.base_values(&delta)
    }

    /// Predicted energy of following `traj` while the flange carries the payloads of
    /// `events` (each from its time on; none before the first), each added to this model
    /// with [`PowerModel::with_payload`]. `dt`: integration step, s.
    pub fn energy_with_payloads(
        &self,
        robot: &Robot,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        efficiency: f64,
        dt: f64,
    ) -> Result<EnergyPrediction> {
        let p = self.predict(robot, traj, events, efficiency, dt)?;
        Ok(EnergyPrediction {
            motor_j: p.motor_j,
            grid_j: p.grid_j,
        })
    }

    /// What the modelled meter reads, W, when the modelled power is `total_w`: a clipped
    /// signal (DC bus, grid) reads no less than its floor ([`PowerModel::bus_floor`], 0
    /// without one), an unclipped one reads the power.
    pub fn reading(&self, total_w: f64) -> f64 {
        if self.signal.clipped() {
            total_w.max(self.bus_floor.unwrap_or(0.0))
        } else {
            total_w
        }
    }

    /// Predicted total motor power (W) along `traj` at the times `t` (s, within the
    /// trajectory), with the payloads of `events` as in [`PowerModel::energy_with_payloads`].
    pub fn power_with_payloads(
        &self,
        robot: &Robot,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        efficiency: f64,
        t: &[f64],
    ) -> Result<Vec<f64>> {
        let mut total = Vec::with_capacity(t.len());
        self.each_state(robot, traj, events, efficiency, t, |e| {
            total.push(e.p.iter().fold(0.0, |s, pi| s + pi));
        })?;
        Ok(total)
    }

    /// Predicted power of each motor (W), `[joint][sample]`, along `traj` at the times `t`
    /// (s), with the payloads of `events` as in [`PowerModel::energy_with_payloads`]. The
    /// constant power of the model is all on joint 1 (only its sum is identifiable), and an
    /// efficiency-scaled model gives motor powers divided by the efficiency, like its total.
    pub fn joint_powers_with_payloads(
        &self,
        robot: &Robot,
        traj: &dyn Trajectory,
        events: &[PayloadEvent],
        efficiency: f64,
        t: &[f64],
    ) -> Result<Vec<Vec<f64>>> {
        let mut joints = vec![Vec::with_capacity(t.len()); robot.dof()];
        self.each_state(robot, traj, events, efficiency, t, |e| {
            for (series, pi) in joints.iter_mut().zip(e.p) {
                series.push(*pi);
            }
        })?;
        Ok(joints)
    }

    /// The factor on joint `i`'s Coulomb friction at speed `dq` (rad/s) under the model's
    /// law: [`crate::identification::tuning::STRIBECK_SHARE`] of the drive file's Stribeck
    /// rise ([`PowerModel::stribeck`]); 1 without one.
    pub fn coulomb_factor(&self, i: usize, dq: f64) -> f64 {
        self.stribeck
            .get(i)
            .copied()
            .flatten()
            .map_or(1.0, |law| law.factor(dq, tuning::STRIBECK_SHARE))
    }

    /// Scale each joint's Coulomb column of the regressor `w` (evaluated at joint speeds `dq`,
    /// rad/s) by [`PowerModel::coulomb_factor`]: the model's friction law in its rows.
    pub fn apply_coulomb_law(&self, w: &mut DMatrix<f64>, dq: &[f64]) {
        if self.stribeck.is_empty() {
            return;
        }
        for (i, &v) in dq.iter().enumerate() {
            if let Some(c) = self.layout.coulomb_col(i) {
                w[(i, c)] *= self.coulomb_factor(i, v);
            }
        }
    }

    /// Each joint's regressor column of Coulomb friction and the index of its parameter in
    /// `theta` (`None` without friction in the layout or the base parameters).
    fn coulomb_params(&self) -> Vec<Option<(usize, usize)>> {
        (0..self.layout.dof)
            .map(|i| {
                let c = self.layout.coulomb_col(i)?;
                Some((c, self.columns.iter().position(|&k| k == c)?))
            })
            .collect()
    }

    /// Joint torque of motor `i` (N m, or N m / eta when efficiency-scaled) from row `i` of
    /// the regressor `w` already evaluated at the state.
    fn torque(&self, w: &DMatrix<f64>, i: usize) -> f64 {
        // Column-major: entry (i, c) is at `c n + i`. Four partial sums: one running sum is
        // a long chain of dependent additions.
        let (n, w) = (w.nrows(), w.as_slice());
        let (cols, theta) = (self.columns.chunks_exact(4), self.theta.chunks_exact(4));
        let rest: f64 = (cols.remainder().iter().zip(theta.remainder()))
            .map(|(&c, th)| w[c * n + i] * th)
            .sum();
        let mut acc = [0.0; 4];
        for (k, th) in cols.zip(theta) {
            for j in 0..4 {
                acc[j] += w[k[j] * n + i] * th[j];
            }
        }
        (acc[0] + acc[1]) + (acc[2] + acc[3]) + rest
    }
}
