//! Centre poses of an identification set for any arm, spread over the joint space the cell
//! leaves: the excitations of [`super::design_set`] start about them, so that together they
//! see the arm in different configurations (gravity and inertia in different directions).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::error::{Error, Result};
use crate::identification::excitation::{
    REST_CANDIDATES, clear_of_workspace, random_pose, rest_ranges,
};
use crate::model::Robot;

/// Extra clearance a centre keeps from the floor and the base column, m, on top of the
/// workspace's: the excitation moves about it.
const CENTRE_CLEARANCE_M: f64 = 0.1;

/// `count` centre poses (rad) of `robot` within its position limits less `margin` (rad;
/// each joint within [-pi, pi]), the flange and the wrist (the origin of the second-to-last
/// link frame) above `floor_z` (m) and `base_radius` (m) from the base z axis.
///
/// Seeded random candidates are drawn in the middle half of each joint's range, clear of
/// the workspace by 0.1 m more (or, when none is, anywhere in the ranges
/// and just clear of it). The first centre is the candidate nearest the middle of the
/// ranges; each next one the candidate farthest from those chosen (distances in joint space,
/// each joint scaled by its range). With fewer candidates than `count`, they repeat.
///
/// Errors ([`Error::InvalidInput`]): `count` is 0, a joint's range is not wider than
/// `2 margin`, or no drawn pose keeps the flange and wrist clear: the robot cannot stand in
/// this workspace, so nothing can be designed.
pub fn spread_centres(
    robot: &Robot,
    count: usize,
    margin: f64,
    floor_z: f64,
    base_radius: f64,
    seed: u64,
) -> Result<Vec<Vec<f64>>> {
    if count == 0 {
        return Err(Error::InvalidInput(
            "an identification set needs at least one excitation".into(),
        ));
    }
    let ranges = rest_ranges(robot, margin)?;
    let middle: Vec<(f64, f64)> = ranges
        .iter()
        .map(|&(lo, hi)| (lo + 0.25 * (hi - lo), hi - 0.25 * (hi - lo)))
        .collect();
    let extra = CENTRE_CLEARANCE_M;
    let mut candidates = draw(robot, &middle, floor_z + extra, base_radius + extra, seed);
    if candidates.is_empty() {
        candidates = draw(robot, &ranges, floor_z, base_radius, seed);
    }
    if candidates.is_empty() {
        return Err(Error::InvalidInput(format!(
            "nothing can be designed: no pose of {REST_CANDIDATES} drawn within the joint ranges \
             keeps the flange and wrist above z = {floor_z} m and {base_radius} m from the base \
             axis (the robot cannot stand in this cell: lower the floor, widen the joint ranges)"
        )));
    }
    let scale: Vec<f64> = ranges.iter().map(|&(lo, hi)| 1.0 / (hi - lo)).collect();
    let dist = |a: &[f64], b: &[f64]| -> f64 {
        a.iter()
            .zip(b)
            .zip(&scale)
            .map(|((x, y), s)| ((x - y) * s).powi(2))
            .sum()
    };
    let mid: Vec<f64> = ranges.iter().map(|&(lo, hi)| 0.5 * (lo + hi)).collect();
    let first = argmin(candidates.iter().map(|c| dist(c, &mid)));
    let mut chosen = vec![candidates.swap_remove(first)];
    // Distance of each candidate to the nearest chosen centre.
    let mut gap: Vec<f64> = candidates.iter().map(|c| dist(c, &chosen[0])).collect();
    while chosen.len() < count && !candidates.is_empty() {
        let far = argmin(gap.iter().map(|g| -g));
        let next = candidates.swap_remove(far);
        gap.swap_remove(far);
        for (g, c) in gap.iter_mut().zip(&candidates) {
            *g = g.min(dist(c, &next));
        }
        chosen.push(next);
    }
    let distinct = chosen.len();
    for k in distinct..count {
        chosen.push(chosen[k % distinct].clone());
    }
    Ok(chosen)
}

/// [`REST_CANDIDATES`] seeded poses within `ranges` (rad), those clear of the workspace
/// (`floor_z`, `base_radius`, m).
fn draw(
    robot: &Robot,
    ranges: &[(f64, f64)],
    floor_z: f64,
    base_radius: f64,
    seed: u64,
) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut poses = vec![nalgebra::Isometry3::identity(); robot.dof()];
    (0..REST_CANDIDATES)
        .map(|_| random_pose(&mut rng, ranges))
        .filter(|q| clear_of_workspace(robot, q, floor_z, base_radius, None, &mut poses))
        .collect()
}

/// Index of the least of `values` (0 when empty).
fn argmin(values: impl Iterator<Item = f64>) -> usize {
    values
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0, |(i, _)| i)
}
