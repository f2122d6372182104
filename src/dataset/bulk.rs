//! Bulk ground truth: a global set of randomised twin runs, defined item by item by
//! `(seed, index)` alone, so any process can produce any item and shards of the set never
//! overlap (see `docs/guide/bulk-datasets.md`).
//!
//! Item `j` draws, from an RNG seeded with `splitmix64(seed ^ splitmix64(j))`:
//! - the trajectory: with probability 1/2 a rest-to-rest Fourier excitation (0.1 Hz, 5
//!   harmonics, one 10 s period), else a point-to-point motion through 5 random via points
//!   (quintic segments at up to 90 % of the velocity and acceleration limits, slowed down
//!   by a random factor in [1, 2]);
//! - the payload, attached throughout: none, the 1.32 kg tool, or the tool plus a steel cube
//!   of 0.5–4 kg at the tool centre point (1/3 each);
//! - the drive parameters: Coulomb and viscous friction, rotor inertia, copper-loss
//!   coefficient and standby power each scaled by a factor in [0.7, 1.3] from the base drive
//!   file; efficiency uniform in [0.83, 0.92] (the paper's range).
//! - the sensor-noise seed.
//!
//! The physics, controller, motor model and noise levels are the caller's. With a family of
//! truths ([`BulkSpec::family`]) item `j` instead runs robot `j` of the family
//! ([`family_seed`]`(seed, j, 0)`, the robot `validate --family` draws first for that
//! index): its own inertias, friction laws, losses, controller and logger, recorded in its
//! `meta.json`; the trajectory and payload draws are the same. A robot the twin cannot track
//! along the item's motion (a joint's torque saturates) is redrawn
//! ([`family_seed`]`(seed, j, 1)`, ...), and the redraws are recorded in the draw.

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::json;

use crate::dataset::Dataset;
use crate::dataset::generate::{RunSpec, simulate};
use crate::dataset::meta::Urdf;
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::model::drive::{Drive, JointDrive};
use crate::model::payload::Payload;
use crate::model::payload::PayloadEvent;
use crate::trajectory::Trajectory;
use crate::trajectory::limits::default_accel_limits;
use crate::trajectory::random::{
    RandomFourierOptions, RandomPointToPointOptions, random_fourier, random_point_to_point,
};
use crate::twin::family::{FamilyTable, MAX_REDRAWS, Redraw, family_seed};
use crate::twin::sensor::SensorSettings;
use crate::twin::{RunReport, TwinConfig};

/// Which items of the global set a process produces: those with `index % count == shard`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = Error;

    /// Parse `K/N` with `0 <= K < N`.
    fn from_str(s: &str) -> Result<Shard> {
        let bad = || {
            Error::InvalidInput(format!(
                "shard '{s}' must be K/N with 0 <= K < N (e.g. 3/16)"
            ))
        };
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl Shard {
    /// The whole set.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// The item indices of this shard among `total` items.
    pub fn items(&self, total: usize) -> impl Iterator<Item = usize> + '_ {
        (self.index..total).step_by(self.count)
    }
}

/// What stays the same for every item.
pub struct BulkSpec<'a> {
    /// The robot.
    pub robot: &'a Robot,
    /// Its URDF for `meta.json`.
    pub urdf: Urdf,
    /// Base drive parameters that items vary around.
    pub drive: &'a Drive,
    /// The 1.32 kg tool (and TCP) used by items with a payload.
    pub tool: &'a Payload,
    /// Physics, controller and motor settings.
    pub twin: TwinConfig,
    /// Logger settings (the noise seed is drawn per item).
    pub sensor: SensorSettings,
    /// Global seed.
    pub seed: u64,
    /// Run each item on a robot of this family instead of scaling the drives.
    pub family: Option<BulkFamily>,
}

/// The family of truths a set's items are drawn from.
#[derive(Debug, Clone)]
pub struct BulkFamily {
    /// Sizes of the differences.
    pub table: FamilyTable,
    /// Family seed: item `j` runs robot [`family_seed`]`(seed, j, 0)`.
    pub seed: u64,
}

fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Mass range of the steel cube items carry beside the tool, kg.
const CUBE_KG: (f64, f64) = (0.5, 4.0);

/// Draw an item's trajectory (the first draws of its RNG) and its description.
fn draw_trajectory(
    robot: &Robot,
    rng: &mut ChaCha8Rng,
) -> Result<(Box<dyn Trajectory>, serde_json::Value)> {
    Ok(if rng.random_bool(0.5) {
        let o = RandomFourierOptions {
            accel_limits: default_accel_limits(robot),
            ..RandomFourierOptions::default()
        };
        let f = random_fourier(robot, rng, &o)?;
        let d = json!({"kind": "random fourier", "base_freq_hz": o.base_freq_hz, "harmonics": o.harmonics, "periods": o.periods,
            "q0_rad": f.q0(), "a_rad": f.a(), "b_rad": f.b()});
        (Box::new(f), d)
    } else {
        let o = RandomPointToPointOptions {
            accel_limits: default_accel_limits(robot),
            ..RandomPointToPointOptions::default()
        };
        let p = random_point_to_point(robot, rng, &o)?;
        let d = json!({"kind": "random point to point", "points_rad": p.points(), "arrival_times_s": p.arrival_times()});
        (Box::new(p), d)
    })
}

/// Simulated duration of item `index` (s), without running it: how long its run will take,
/// for scheduling the longest items first. Errors: as [`item`]'s trajectory draw.
pub fn item_duration(spec: &BulkSpec, index: usize) -> Result<f64> {
    let item_seed = splitmix64(spec.seed ^ splitmix64(index as u64));
    let mut rng = ChaCha8Rng::seed_from_u64(item_seed);
    Ok(draw_trajectory(spec.robot, &mut rng)?.0.duration())
}

/// Generate item `index` of the global set: a random Fourier or point-to-point motion within
/// the robot's acceleration bounds ([`default_accel_limits`]), with no payload, the tool, or
/// the tool and a steel cube of 0.5-4 kg (at most what the drive file's rated payload leaves
/// beside the tool; the tool alone where it leaves under 0.5 kg).
///
/// Errors: the tool alone above the rated payload; a motion or twin run that fails.
pub fn item(spec: &BulkSpec, index: usize) -> Result<(Dataset, RunReport)> {
    crate::model::payload::check_rated(
        spec.tool.inertia.mass,
        spec.drive.rated_payload_kg(),
        "the items' tool",
    )?;
    let item_seed = splitmix64(spec.seed ^ splitmix64(index as u64));
    let mut rng = ChaCha8Rng::seed_from_u64(item_seed);
    let robot = spec.robot;
    let (traj, description) = draw_trajectory(robot, &mut rng)?;
    let payload = draw_payload(spec, &mut rng)?;
    let events: Vec<PayloadEvent> = payload
        .map(|p| PayloadEvent {
            t_s: 0.0,
            payload: Some(p),
        })
        .into_iter()
        .collect();
    let description = json!({"item": index, "global_seed": spec.seed, "trajectory": description});
    if let Some(family) = &spec.family {
        let item = FamilyItem {
            index,
            item_seed,
            sensor_seed: rng.random(),
            events: &events,
            trajectory: traj.as_ref(),
            description,
        };
        return family_item(spec, family, &item);
    }
    let drive = scaled_drive(spec, &mut rng)?;
    let sensor = SensorSettings {
        seed: rng.random(),
        ..spec.sensor
    };
    simulate(&RunSpec {
        robot,
        urdf: spec.urdf.clone(),
        drive: &drive,
        events: &events,
        brakes: &[],
        twin: spec.twin.clone(),
        sensor,
        trajectory: traj.as_ref(),
        trajectory_description: description,
        trajectory_seed: Some(item_seed),
        family: None,
    })
}

/// What an item drew before its robot: the motion, payloads and seeds.
struct FamilyItem<'a> {
    index: usize,
    item_seed: u64,
    sensor_seed: u64,
    events: &'a [PayloadEvent],
    trajectory: &'a dyn Trajectory,
    description: serde_json::Value,
}

/// Item `index` of a family set: run on robot `index` of the family, redrawn (up to
/// [`MAX_REDRAWS`] times, each redraw recorded in the draw) while the twin cannot track it
/// along the item's motion (a joint's torque saturates).
///
/// Errors: every draw saturated; a draw or twin run that fails.
fn family_item(
    spec: &BulkSpec,
    family: &BulkFamily,
    item: &FamilyItem,
) -> Result<(Dataset, RunReport)> {
    let index = item.index;
    let mut redraws = Vec::new();
    for attempt in 0..=MAX_REDRAWS {
        let seed = family_seed(family.seed, index, attempt);
        let mut plant =
            family
                .table
                .draw(spec.robot, spec.drive, &spec.twin, &spec.sensor, seed)?;
        plant.draw.redraws = redraws.clone();
        let (ds, report) = simulate(&RunSpec {
            robot: &plant.robot,
            urdf: spec.urdf.clone(),
            drive: &plant.drive,
            events: item.events,
            brakes: &[],
            twin: plant.twin.clone(),
            sensor: SensorSettings {
                seed: item.sensor_seed,
                ..plant.sensor
            },
            trajectory: item.trajectory,
            trajectory_description: item.description.clone(),
            trajectory_seed: Some(item.item_seed),
            family: Some(&plant.draw),
        })?;
        match report.torque_limit_hits.first() {
            None => return Ok((ds, report)),
            Some(hit) => redraws.push(Redraw {
                family_seed: seed,
                reason: format!(
                    "joint '{}' saturated at t = {:.3} s",
                    hit.joint, hit.first_t_s
                ),
            }),
        }
    }
    Err(Error::InvalidInput(format!(
        "every one of {} family robots drawn for item {index} saturated a joint's torque \
         (last: {}); the family table is too wide for this robot and motion",
        MAX_REDRAWS + 1,
        redraws.last().map_or("", |d| d.reason.as_str())
    )))
}

/// Draw an item's payload (the next draws of its RNG): none, the tool, or the tool and a
/// steel cube of 0.5-4 kg at the tool centre point (at most what the rated payload leaves
/// beside the tool; the tool alone where it leaves under 0.5 kg), 1/3 each.
fn draw_payload(spec: &BulkSpec, rng: &mut ChaCha8Rng) -> Result<Option<Payload>> {
    Ok(match rng.random_range(0..3) {
        0 => None,
        1 => Some(spec.tool.clone()),
        _ => {
            let at = spec.tool.tcp.unwrap_or_else(Vector3::zeros);
            // 0.5-4 kg, less where the rated payload leaves less room beside the tool.
            let room = spec
                .drive
                .rated_payload_kg()
                .map_or(CUBE_KG.1, |r| (r - spec.tool.inertia.mass).min(CUBE_KG.1));
            let drawn = rng.random_range(CUBE_KG.0..CUBE_KG.1);
            if room < CUBE_KG.0 {
                Some(spec.tool.clone())
            } else {
                let mass = if room < CUBE_KG.1 {
                    CUBE_KG.0 + (drawn - CUBE_KG.0) * (room - CUBE_KG.0) / (CUBE_KG.1 - CUBE_KG.0)
                } else {
                    drawn
                };
                let cube = Payload::cube(&format!("steel cube {mass:.3} kg"), mass, at)?;
                Some(spec.tool.combined(&cube))
            }
        }
    })
}

/// The base drive file with friction, rotor inertia and losses scaled by 0.7-1.3 and the
/// efficiency drawn in 0.83-0.92 (the next draws of an item's RNG).
fn scaled_drive(spec: &BulkSpec, rng: &mut ChaCha8Rng) -> Result<Drive> {
    let joints: Vec<JointDrive> = spec
        .drive
        .joints()
        .iter()
        .map(|j| {
            let mut f = || rng.random_range(0.7..1.3);
            let mut d = *j;
            let coulomb = f();
            d.friction.coulomb *= coulomb;
            // Static friction keeps its ratio to the Coulomb level.
            if let Some(fs) = &mut d.unmodelled.stribeck_static {
                *fs *= coulomb;
            }
            d.friction.viscous *= f();
            d.rotor_inertia *= f();
            d.copper_loss *= f();
            d.standby_power *= f();
            d.efficiency = rng.random_range(0.83..0.92);
            d
        })
        .collect();
    Drive::new(spec.robot, joints)
}
