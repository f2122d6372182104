//! A family of truths: robots we did not build.
//!
//! A user's robot differs from the files they have: its CAD inertias are off, its drives have
//! their own friction laws and losses, its controller tracks with its own gains and model,
//! and its logger has its own rate, clock and noise. [`FamilyTable`] gives the size (and,
//! where real drives differ, the form) of each such difference; [`FamilyTable::draw`] draws
//! one robot of the family from a seed: the [`Plant`] the twin simulates, built from the
//! user's nominal URDF and drive file. Identification only ever sees the nominal files and
//! the logs; the plant's [`Draw`] goes into the dataset's `meta.json` to score with.
//!
//! # The table (defaults)
//! Relative sizes `r` draw a factor `1 + U(-r, r)`; ranges `[lo, hi]` draw `U(lo, hi)` (log
//! uniform where marked); every draw is independent per link or joint.
//!
//! | key | default | what |
//! |---|---|---|
//! | `mass_rel` | 0.2 | link masses |
//! | `com_m` | 0.02 | link centres of mass, per axis, m |
//! | `inertia_rel` | 0.25 | link inertia tensors about the centre of mass |
//! | `rotor_rel` | 0.4 | reflected rotor inertias |
//! | `coulomb_rel`, `viscous_rel` | 0.5 | Coulomb and viscous friction |
//! | `stribeck_peak` | [1.1, 1.6] | static friction over Coulomb friction |
//! | `stribeck_speed_rad_s` | [0.01, 0.08] | Stribeck velocity |
//! | `gear_friction` | [0, 0.04] | load-dependent friction per N m transmitted, drawn apart for motoring and braking |
//! | `copper_rel` | 0.5 | copper loss |
//! | `iron_rel` | 0.5 | iron loss (hysteresis and eddy; of the drive file's, none without) |
//! | `standby_rel` | 0.2 | standby power per drive |
//! | `cabinet_W` | [15, 60] | cabinet load, W ... |
//! | `cabinet_seen` | 0.5 | ... inside the meter with this probability (else outside) |
//! | `bandwidth_rad_s` | [60, 200] log | controller bandwidth: `kp = w^2`, `kd = 2 w` |
//! | `nominal_error` | [0, 0.2] | controller's nominal-model error |
//! | `rate_hz` | [10, 500] log | log rate, snapped to a whole number of physics steps |
//! | `averaging` | 0.5 | probability of an averaging (integrating) meter |
//! | `stamp_jitter_periods` | [0, 0.2] | time-stamp jitter, sample periods |
//! | `power_lag_s` | [0, 0.04] | power lag behind the joints, s |
//! | `noise_decades` | 1 | encoder and meter noise: the logger's settings times `10^U(-d/2, d/2)` each |

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::model::drive::{Drive, JointDrive};
use crate::model::{RigidInertia, Robot};
use crate::twin::controller::Gains;
use crate::twin::sensor::SensorSettings;
use crate::twin::{Fidelity, TwinConfig};

/// Sizes of the differences between a user's files and their robot (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FamilyTable {
    /// Link mass error, relative.
    pub mass_rel: f64,
    /// Centre-of-mass error per axis, m.
    pub com_m: f64,
    /// Inertia tensor error, relative.
    pub inertia_rel: f64,
    /// Rotor inertia error, relative.
    pub rotor_rel: f64,
    /// Coulomb friction error, relative.
    pub coulomb_rel: f64,
    /// Viscous friction error, relative.
    pub viscous_rel: f64,
    /// Static over Coulomb friction.
    pub stribeck_peak: [f64; 2],
    /// Stribeck velocity, rad/s.
    pub stribeck_speed_rad_s: [f64; 2],
    /// Load-dependent gear friction per N m, for motoring and (apart) braking.
    pub gear_friction: [f64; 2],
    /// Copper loss error, relative.
    pub copper_rel: f64,
    /// Iron loss error, relative.
    pub iron_rel: f64,
    /// Standby power error, relative.
    pub standby_rel: f64,
    /// Cabinet load, W.
    #[serde(rename = "cabinet_W")]
    pub cabinet_w: [f64; 2],
    /// Probability that the meter sees the cabinet load.
    pub cabinet_seen: f64,
    /// Controller bandwidth, rad/s (log uniform).
    pub bandwidth_rad_s: [f64; 2],
    /// Controller's nominal-model error, relative.
    pub nominal_error: [f64; 2],
    /// Log rate, Hz (log uniform, snapped to whole physics steps).
    pub rate_hz: [f64; 2],
    /// Probability of an averaging meter.
    pub averaging: f64,
    /// Time-stamp jitter, sample periods.
    pub stamp_jitter_periods: [f64; 2],
    /// Power lag, s.
    pub power_lag_s: [f64; 2],
    /// Decades over which the encoder and meter noise vary.
    pub noise_decades: f64,
}

impl Default for FamilyTable {
    fn default() -> Self {
        FamilyTable {
            mass_rel: 0.2,
            com_m: 0.02,
            inertia_rel: 0.25,
            rotor_rel: 0.4,
            coulomb_rel: 0.5,
            viscous_rel: 0.5,
            stribeck_peak: [1.1, 1.6],
            stribeck_speed_rad_s: [0.01, 0.08],
            gear_friction: [0.0, 0.04],
            copper_rel: 0.5,
            iron_rel: 0.5,
            standby_rel: 0.2,
            cabinet_w: [15.0, 60.0],
            cabinet_seen: 0.5,
            bandwidth_rad_s: [60.0, 200.0],
            nominal_error: [0.0, 0.2],
            rate_hz: [10.0, 500.0],
            averaging: 0.5,
            stamp_jitter_periods: [0.0, 0.2],
            power_lag_s: [0.0, 0.04],
            noise_decades: 1.0,
        }
    }
}

/// What was drawn for one joint (true values, link side).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointDraw {
    /// Reflected rotor inertia, kg m^2.
    pub rotor_inertia_kgm2: f64,
    /// Coulomb friction, N m.
    #[serde(rename = "coulomb_Nm")]
    pub coulomb_nm: f64,
    /// Viscous friction, N m s/rad.
    #[serde(rename = "viscous_Nms_per_rad")]
    pub viscous_nms_per_rad: f64,
    /// Static friction, N m.
    #[serde(rename = "stribeck_static_Nm")]
    pub stribeck_static_nm: f64,
    /// Stribeck velocity, rad/s.
    pub stribeck_speed_rad_s: f64,
    /// Gear friction per N m while motoring.
    pub gear_friction_per_nm: f64,
    /// Gear friction per N m while braking.
    pub gear_friction_braking_per_nm: f64,
    /// Copper loss, W/(N m)^2.
    #[serde(rename = "copper_loss_W_per_Nm2")]
    pub copper_loss: f64,
    /// Hysteresis iron loss, W/(rad/s).
    #[serde(rename = "iron_hysteresis_W_per_rad_s")]
    pub iron_hysteresis: f64,
    /// Eddy-current iron loss, W/(rad/s)^2.
    #[serde(rename = "iron_eddy_W_s2_per_rad2")]
    pub iron_eddy: f64,
    /// Standby power, W.
    #[serde(rename = "standby_W")]
    pub standby_w: f64,
}

/// Redraws of one robot before the family is given up as untrackable (the table too wide
/// for the robot).
pub const MAX_REDRAWS: u64 = 5;

/// A drawn robot that could not be used, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Redraw {
    /// Its family seed.
    pub family_seed: u64,
    /// Why it was redrawn.
    pub reason: String,
}

/// What was drawn for one robot of the family: recorded in `meta.json` (truth only, for
/// scoring). The true link inertias are the dataset's `standard_params`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Draw {
    /// The family seed (`--truth family:SEED`).
    pub seed: u64,
    /// Relative link mass errors of the user's URDF, per link (`true / nominal - 1`).
    pub link_mass_error_rel: Vec<f64>,
    /// Per joint.
    pub joints: Vec<JointDraw>,
    /// Cabinet load, W, and whether the meter sees it.
    #[serde(rename = "cabinet_W")]
    pub cabinet_w: f64,
    /// Whether the meter sees the cabinet load.
    pub cabinet_seen: bool,
    /// Controller bandwidth, rad/s.
    pub bandwidth_rad_s: f64,
    /// Controller's nominal-model error, relative.
    pub nominal_error: f64,
    /// Log rate, Hz.
    pub rate_hz: f64,
    /// Averaging meter.
    pub power_averaging: bool,
    /// Time-stamp jitter, s.
    pub stamp_jitter_s: f64,
    /// Power lag, s.
    pub power_lag_s: f64,
    /// Encoder noise, rad.
    pub encoder_sigma_rad: f64,
    /// Meter noise, W.
    #[serde(rename = "power_sigma_W")]
    pub power_sigma_w: f64,
    /// Robots drawn for the same place before this one and refused (the twin could not
    /// track them: a joint's torque saturated), in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub redraws: Vec<Redraw>,
}

/// One robot of the family: what the twin simulates. Built by [`FamilyTable::draw`]; not
/// reachable from anything identification takes.
#[derive(Debug, Clone)]
pub struct Plant {
    /// The true robot (the user's URDF geometry with the true inertias).
    pub robot: Robot,
    /// The true drives.
    pub drive: Drive,
    /// The twin settings (realistic fidelity, the drawn controller and cabinet).
    pub twin: TwinConfig,
    /// The drawn logger.
    pub sensor: SensorSettings,
    /// What was drawn.
    pub draw: Draw,
}

/// The family seed of robot `robot`, attempt `attempt` (0, or a redraw), of the family
/// `seed`: what `--truth family:SEED` takes to run that robot alone.
pub fn family_seed(seed: u64, robot: usize, attempt: u64) -> u64 {
    seed.wrapping_mul(1_000_000)
        .wrapping_add(robot as u64 * 10)
        .wrapping_add(attempt)
}

/// A uniform draw in `[lo, hi]` (`lo` when the range has no width). A range without width
/// takes its draw from `rng` all the same, so a table that pins one effect draws every other
/// effect as a table without the pin does: an ablation compares the same robots.
fn uniform(rng: &mut ChaCha8Rng, [lo, hi]: [f64; 2]) -> f64 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        let _: f64 = rng.random_range(0.0..=1.0);
        lo
    }
}

/// A log-uniform draw in `[lo, hi]` (both > 0).
fn log_uniform(rng: &mut ChaCha8Rng, [lo, hi]: [f64; 2]) -> f64 {
    uniform(rng, [lo.ln(), hi.ln()]).exp()
}

/// A factor `1 + U(-rel, rel)`.
fn factor(rng: &mut ChaCha8Rng, rel: f64) -> f64 {
    1.0 + uniform(rng, [-rel, rel])
}

impl FamilyTable {
    /// Read a family table from TOML text (keys as the field names; missing keys keep their
    /// defaults). `label` names the file in errors.
    pub fn from_toml_str(text: &str, label: &str) -> Result<FamilyTable> {
        let t: FamilyTable = toml::from_str(text).map_err(|e| Error::Toml {
            file: label.to_string(),
            message: e.to_string().trim_end().to_string(),
        })?;
        t.validate().map_err(|message| Error::Toml {
            file: label.to_string(),
            message,
        })?;
        Ok(t)
    }

    /// Check every size: finite, non-negative, ranges with `lo <= hi`, probabilities in
    /// [0, 1], relative sizes below 1 (a factor stays positive).
    pub fn validate(&self) -> std::result::Result<(), String> {
        let rel = [
            ("mass_rel", self.mass_rel),
            ("inertia_rel", self.inertia_rel),
            ("rotor_rel", self.rotor_rel),
            ("coulomb_rel", self.coulomb_rel),
            ("viscous_rel", self.viscous_rel),
            ("copper_rel", self.copper_rel),
            ("iron_rel", self.iron_rel),
            ("standby_rel", self.standby_rel),
        ];
        for (k, v) in rel {
            if !(v.is_finite() && (0.0..1.0).contains(&v)) {
                return Err(format!("{k} = {v} must be in [0, 1)"));
            }
        }
        for (k, v) in [("com_m", self.com_m), ("noise_decades", self.noise_decades)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{k} = {v} must be finite and >= 0"));
            }
        }
        for (k, v) in [
            ("cabinet_seen", self.cabinet_seen),
            ("averaging", self.averaging),
        ] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return Err(format!("{k} = {v} must be a probability in [0, 1]"));
            }
        }
        let ranges = [
            ("stribeck_peak", self.stribeck_peak, 1.0, f64::INFINITY),
            (
                "stribeck_speed_rad_s",
                self.stribeck_speed_rad_s,
                1e-6,
                10.0,
            ),
            ("gear_friction", self.gear_friction, 0.0, 0.5),
            ("cabinet_W", self.cabinet_w, 0.0, f64::INFINITY),
            ("bandwidth_rad_s", self.bandwidth_rad_s, 1.0, 1000.0),
            ("nominal_error", self.nominal_error, 0.0, 0.9),
            ("rate_hz", self.rate_hz, 1.0, f64::INFINITY),
            ("stamp_jitter_periods", self.stamp_jitter_periods, 0.0, 0.45),
            ("power_lag_s", self.power_lag_s, 0.0, 10.0),
        ];
        for (k, [lo, hi], min, max) in ranges {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi && lo >= min && hi <= max) {
                return Err(format!(
                    "{k} = [{lo}, {hi}] must be a range lo <= hi within [{min}, {max}]"
                ));
            }
        }
        Ok(())
    }

    /// Draw robot `seed` of the family around the user's `robot` (URDF) and `drive` (drive
    /// file): the true inertias and drives, the controller and cabinet on top of `twin`
    /// (whose physics and motor model it keeps) and the logger on top of `sensor` (whose
    /// power signal, noise seed and nominal noise it keeps). Errors: an invalid table, or no
    /// log rate in the table's range that is a whole number of physics steps.
    pub fn draw(
        &self,
        robot: &Robot,
        drive: &Drive,
        twin: &TwinConfig,
        sensor: &SensorSettings,
        seed: u64,
    ) -> Result<Plant> {
        self.validate()
            .map_err(|m| Error::InvalidInput(format!("family table: {m}")))?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7f4a_7c15_9e37_79b9);
        let (true_robot, link_mass_error_rel) = self.draw_links(robot, &mut rng)?;
        let (joints, joint_draws) = self.draw_joints(drive, &mut rng);
        let true_drive = drive.with_joints(robot, joints)?;
        let cabinet_w = uniform(&mut rng, self.cabinet_w);
        let cabinet_seen = rng.random_bool(self.cabinet_seen);
        let bandwidth = log_uniform(&mut rng, self.bandwidth_rad_s);
        let nominal_error = uniform(&mut rng, self.nominal_error);
        let rate_hz = snap_rate(log_uniform(&mut rng, self.rate_hz), self.rate_hz, twin)?;
        let power_averaging = rng.random_bool(self.averaging);
        let stamp_jitter_s = uniform(&mut rng, self.stamp_jitter_periods) / rate_hz;
        let power_lag_s =
            (uniform(&mut rng, self.power_lag_s) / twin.physics.dt).round() * twin.physics.dt;
        let half = 0.5 * self.noise_decades;
        let encoder = 10f64.powf(uniform(&mut rng, [-half, half]));
        let meter = 10f64.powf(uniform(&mut rng, [-half, half]));
        let mut noise = sensor.noise;
        noise.encoder_sigma_rad *= encoder;
        noise.power_sigma_w *= meter;
        noise.joint_power_sigma_w *= meter;
        let draw = Draw {
            seed,
            link_mass_error_rel,
            joints: joint_draws,
            cabinet_w,
            cabinet_seen,
            bandwidth_rad_s: bandwidth,
            nominal_error,
            rate_hz,
            power_averaging,
            stamp_jitter_s,
            power_lag_s,
            encoder_sigma_rad: noise.encoder_sigma_rad,
            power_sigma_w: noise.power_sigma_w,
            redraws: Vec::new(),
        };
        Ok(Plant {
            robot: true_robot,
            drive: true_drive,
            twin: TwinConfig {
                gains: Gains {
                    kp: bandwidth * bandwidth,
                    kd: 2.0 * bandwidth,
                },
                nominal_error,
                nominal_seed: seed,
                fidelity: Fidelity::Realistic,
                cabinet_power_w: if cabinet_seen { cabinet_w } else { 0.0 },
                ..twin.clone()
            },
            sensor: SensorSettings {
                rate_hz,
                power_averaging,
                noise,
                power_lag_s,
                stamp_jitter_s,
                ..*sensor
            },
            draw,
        })
    }

    /// The true links: masses, centres of mass and inertias off the URDF's.
    fn draw_links(&self, robot: &Robot, rng: &mut ChaCha8Rng) -> Result<(Robot, Vec<f64>)> {
        let mut r = robot.clone();
        let mut errors = Vec::with_capacity(robot.dof());
        for i in 0..robot.dof() {
            let l = robot.links()[i].inertia;
            let fm = factor(rng, self.mass_rel);
            let mut com = l.com;
            for c in com.iter_mut() {
                *c += uniform(rng, [-self.com_m, self.com_m]);
            }
            let fi = factor(rng, self.inertia_rel);
            errors.push(fm - 1.0);
            r = r.with_link_inertia(
                i,
                RigidInertia {
                    mass: l.mass * fm,
                    com,
                    inertia_com: l.inertia_com * fi,
                },
            )?;
        }
        Ok((r, errors))
    }

    /// The true drives: friction laws and losses off the drive file's.
    fn draw_joints(
        &self,
        drive: &Drive,
        rng: &mut ChaCha8Rng,
    ) -> (Vec<JointDrive>, Vec<JointDraw>) {
        drive
            .joints()
            .iter()
            .map(|j| {
                let mut d = *j;
                d.rotor_inertia *= factor(rng, self.rotor_rel);
                d.friction.coulomb *= factor(rng, self.coulomb_rel);
                d.friction.viscous *= factor(rng, self.viscous_rel);
                let peak = uniform(rng, self.stribeck_peak);
                let u = &mut d.unmodelled;
                u.stribeck_static = Some(d.friction.coulomb * peak);
                u.stribeck_speed = uniform(rng, self.stribeck_speed_rad_s);
                u.gear_friction = uniform(rng, self.gear_friction);
                u.gear_friction_braking = uniform(rng, self.gear_friction);
                d.copper_loss *= factor(rng, self.copper_rel);
                let iron = factor(rng, self.iron_rel);
                u.iron_hysteresis *= iron;
                u.iron_eddy *= iron;
                d.standby_power *= factor(rng, self.standby_rel);
                let record = JointDraw {
                    rotor_inertia_kgm2: d.rotor_inertia,
                    coulomb_nm: d.friction.coulomb,
                    viscous_nms_per_rad: d.friction.viscous,
                    stribeck_static_nm: d.friction.coulomb * peak,
                    stribeck_speed_rad_s: u.stribeck_speed,
                    gear_friction_per_nm: u.gear_friction,
                    gear_friction_braking_per_nm: u.gear_friction_braking,
                    copper_loss: d.copper_loss,
                    iron_hysteresis: u.iron_hysteresis,
                    iron_eddy: u.iron_eddy,
                    standby_w: d.standby_power,
                };
                (d, record)
            })
            .unzip()
    }
}

/// The whole-hertz log rate nearest `want` (in ratio) within `[lo, hi]` whose period is a
/// whole number of the twin's physics steps.
fn snap_rate(want: f64, [lo, hi]: [f64; 2], twin: &TwinConfig) -> Result<f64> {
    let dt = twin.physics.dt;
    let max_stride = (1.0 / (lo * dt)).floor() as usize;
    (1..=max_stride.max(1))
        .map(|stride| 1.0 / (stride as f64 * dt))
        // Whole hertz only (10, 20, 25, 40, 50, 100, ... at 1 ms), as loggers offer.
        .filter(|r| {
            *r >= lo * (1.0 - 1e-9) && *r <= hi * (1.0 + 1e-9) && (r - r.round()).abs() < 1e-6
        })
        .min_by(|a, b| (a / want).ln().abs().total_cmp(&(b / want).ln().abs()))
        .ok_or_else(|| {
            Error::InvalidInput(format!(
                "no log rate in [{lo}, {hi}] Hz is a whole number of {dt} s physics steps"
            ))
        })
}
