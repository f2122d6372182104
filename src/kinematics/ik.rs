//! Closed-form inverse kinematics of 6R arms with parallel shoulder axes and a spherical
//! wrist: the "ortho-parallel basis with spherical wrist" (OPW) family of Brandstötter,
//! Angerer and Hofbaur (2014), which includes the ABB IRB 1200 (7/0.7 and 5/0.9).
//!
//! # Class
//! [`Opw::from_robot`] reads the geometry from the model instead of hard-coding numbers. A
//! robot belongs to the class when it has 6 joints and, at any `q`,
//! - axis 2 is perpendicular to axis 1 (it may be offset from it, OPW `a1` and `b`);
//! - axes 2 and 3 are parallel (same or opposite direction; axis 3 offset as OPW `c2`, `a2`);
//! - axes 4, 5 and 6 meet in one point, the wrist centre, with axis 5 perpendicular to axes
//!   4 and 6.
//!
//! Base-frame placement and tilt of axis 1, the flange pose in the last link frame and the
//! joint zero angles are arbitrary. Tolerances: 1e-10 (direction cosines) and 1e-10 m.
//!
//! # Derivation (in our frames, q = the model's joint angles, no sign flips)
//! Let frame B be link frame 1 at `q1 = 0` (z = axis 1), `u` the direction of axis 2 and
//! `e = u x z_B`. The wrist centre `W` is fixed in link 3, so it depends on `q1..q3` only:
//! rotations about axes 2 and 3 keep its `u` coordinate `b` and move it in the `(e, z_B)`
//! plane, as a planar two-link arm from axis 2 (link vectors `l2`, `l3` read at `q = 0`).
//! Given the target `W` in B: `q1` from its horizontal direction (two choices of the sign of
//! the in-plane radius `r = +-sqrt(W_x^2 + W_y^2 - b^2)`), `q3` from the law of cosines (two
//! elbows), `q2` from the direction of `W` seen from axis 2. With `M` the rotation of frame 6
//! in frame 3 rotated by `origin_4`, `M = Rz(q4) A5 Rz(q5) A6 Rz(q6)`: the angle between axes
//! 4 and 6 gives `q5` (two signs), the direction of axis 6 about axis 4 gives `q4`, and the
//! remaining z rotation gives `q6`. Up to 8 solutions.
//!
//! # Singularities
//! - Wrist (axes 4 and 6 aligned, `|sin| < 1e-10`; `q5 = 0` on the IRB 1200): only
//!   `q4 + q6` (or `q4 - q6`) is fixed. [`Opw::solve_all`] sets `q4 = 0` and returns one wrist
//!   solution per arm configuration; [`Opw::solve_nearest`] takes `q4` from the seed (clamped
//!   into its limits), and if that puts `q6` outside its limits it moves `q4` just enough to
//!   bring `q6` onto its nearest limit. Only when no `q4` in its limits works is the pose
//!   reported as blocked ([`Error::JointLimit`], naming the wrist singularity).
//! - Shoulder (wrist centre on axis 1, only possible with `b = 0`): `q1` is free; `q1 = 0`
//!   in `solve_all`, the seed's `q1` in `solve_nearest`.
//! - Elbow (arm stretched or folded): the two elbow solutions coincide and are returned once.
//!
//! Units: m and rad; poses are in the base frame (frame 0 of the model).

use std::f64::consts::{PI, TAU};

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};

use crate::error::{Error, Result};
use crate::kinematics::dls::{self, DlsOptions, ensure_pose_finite};
use crate::model::Robot;

/// Tolerance on direction cosines when classifying the axes.
const DIRECTION_TOL: f64 = 1e-10;
/// Tolerance on distances when classifying the axes, m.
const LENGTH_TOL: f64 = 1e-10;
/// Wrist singular when the sine of the angle between axes 4 and 6 is below this.
const WRIST_SINGULAR: f64 = 1e-10;
/// Shoulder singular when the wrist centre is closer than this to axis 1, m.
const SHOULDER_SINGULAR: f64 = 1e-12;
/// Slack for rounding at the boundary of the workspace (cosine of the elbow angle, and m for
/// the lateral offset).
const REACH_SLACK: f64 = 1e-12;
/// Slack on the position limits for angles recovered by IK, rad.
const LIMIT_SLACK: f64 = 1e-12;

/// The geometry of a robot of the OPW class (see the module docs), extracted from the model,
/// plus its joint limits and names. Build it once with [`Opw::from_robot`] to solve many poses.
#[derive(Debug, Clone, PartialEq)]
pub struct Opw {
    /// Pose of frame B (link frame 1 at `q1 = 0`) in the base frame.
    frame_b: Isometry3<f64>,
    /// Rotations `A_i` of the joint origins (frame i at `q_i = 0` in frame i-1).
    rot: [Matrix3<f64>; 6],
    /// Unit vectors `e` and `u` in frame B (x, y components; both are horizontal in B).
    e: [f64; 2],
    u: [f64; 2],
    /// Axis 2 in the `(e, z_B)` plane, m.
    shoulder: [f64; 2],
    /// Axis 2 -> axis 3 and axis 3 -> wrist centre in the `(e, z_B)` plane at `q = 0`, m.
    upper: [f64; 2],
    fore: [f64; 2],
    /// Lateral offset: `u` coordinate of the wrist centre in B, m.
    lateral: f64,
    /// +1 if axis 3 points along axis 2, -1 if opposite.
    s3: f64,
    /// Wrist centre in link frame 6, m.
    wrist_in_6: Vector3<f64>,
    /// Inverse of the flange pose in link frame 6.
    flange_inv: Isometry3<f64>,
    /// Axis 6 in frame 5 (`A6 z`).
    z6_in_5: Vector3<f64>,
    /// `q5 + beta5` is the angle from axis 4 to axis 6 about axis 5, rad.
    beta5: f64,
    /// Position limits (lower, upper), rad.
    limits: [(f64, f64); 6],
    /// Joint names, for error messages.
    names: [String; 6],
}

/// One analytic solution before limit handling.
struct Branch {
    /// Joint angles in [-pi, pi], rad.
    q: [f64; 6],
    /// Rotation of frame 6 in frame 3 rotated by `origin_4` (`Rz(q4) A5 Rz(q5) A6 Rz(q6)`).
    m: Matrix3<f64>,
    /// At a wrist singularity: `k` (+1 or -1) such that only `q4 + k q6` is fixed.
    wrist_singular: Option<f64>,
}

impl Opw {
    /// The OPW geometry of `robot`, or `None` if it is not of the class (see the module docs;
    /// [`solve_all`] reports the reason).
    pub fn from_robot(robot: &Robot) -> Option<Opw> {
        classify(robot).ok()
    }

    /// All analytic joint solutions (rad, each in [-pi, pi], not filtered by the joint
    /// limits; up to 8) that put the flange at `flange` (pose in the base frame, m). Each
    /// reproduces the pose to rounding (about 1e-15 m / rad) except at a wrist singularity,
    /// where the error is below 1e-9.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a non-finite pose; [`Error::Unreachable`] when the wrist
    /// centre is out of the arm's reach (the message compares its distance from axis 2 with
    /// the reachable range).
    pub fn solve_all(&self, flange: &Isometry3<f64>) -> Result<Vec<[f64; 6]>> {
        ensure_pose_finite(flange, "flange pose")?;
        Ok(self
            .branches(flange, None)?
            .into_iter()
            .map(|b| b.q)
            .collect())
    }

    /// The solution nearest to `seed` (rad; unweighted Euclidean distance) that puts the TCP at
    /// `target_tcp` (TCP pose in the base frame) and lies within the position limits. `tcp` is
    /// the TCP pose in the flange frame (m). Every joint may take `q +- 2 pi k` where its
    /// limits allow it (e.g. joints 4 and 6 of the IRB 1200); singularities are handled as
    /// described in the module docs.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a seed of the wrong length or non-finite inputs;
    /// [`Error::Unreachable`] when no solution exists; [`Error::JointLimit`] when every
    /// solution violates a limit (names the joint that blocks the solution nearest the seed).
    pub fn solve_nearest(
        &self,
        target_tcp: &Isometry3<f64>,
        tcp: &Isometry3<f64>,
        seed: &[f64],
    ) -> Result<[f64; 6]> {
        ensure_pose_finite(target_tcp, "target TCP pose")?;
        ensure_pose_finite(tcp, "TCP offset")?;
        let seed: [f64; 6] = seed.try_into().map_err(|_| {
            Error::InvalidInput(format!(
                "seed has {} values, the robot has 6 joints",
                seed.len()
            ))
        })?;
        crate::error::ensure_finite(&seed, "seed")?;
        let branches = self.branches(&(target_tcp * tcp.inverse()), Some(&seed))?;
        let mut best: Option<(f64, [f64; 6])> = None;
        // Nearest solution ignoring limits, with its blocking joint and value.
        let mut blocked: Option<(f64, [f64; 6], usize, bool)> = None;
        for b in &branches {
            match self.within_limits(b, &seed) {
                Ok(q) => {
                    let d = distance2(&q, &seed);
                    if best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, q));
                    }
                }
                Err(joint) => {
                    let q: [f64; 6] = std::array::from_fn(|i| nearest_turn(b.q[i], seed[i]));
                    let d = distance2(&q, &seed);
                    if blocked.is_none_or(|(bd, ..)| d < bd) {
                        blocked = Some((d, q, joint, b.wrist_singular.is_some()));
                    }
                }
            }
        }
        if let Some((_, q)) = best {
            return Ok(q);
        }
        let Some((_, q, j, singular)) = blocked else {
            return Err(Error::Unreachable("no inverse kinematics solution".into()));
        };
        let (lo, hi) = self.limits[j];
        Err(Error::JointLimit(format!(
            "none of the {} inverse kinematics solutions is within the joint limits; the one \
             nearest the seed, q = {q:.4?} rad, needs joint '{}' at {:.4} rad (mod 2 pi), \
             outside [{lo:.4}, {hi:.4}] rad{}",
            branches.len(),
            self.names[j],
            q[j],
            if singular {
                " (wrist singular: no q4 within its limits puts q6 within its limits)"
            } else {
                ""
            }
        )))
    }

    /// The analytic solutions for a flange pose; `hint` supplies `q1` at a shoulder and `q4`
    /// at a wrist singularity (0 without it).
    fn branches(&self, flange: &Isometry3<f64>, hint: Option<&[f64; 6]>) -> Result<Vec<Branch>> {
        let t6 = flange * self.flange_inv;
        let r6 = t6.rotation.to_rotation_matrix().into_inner();
        let w_base = t6 * Point3::from(self.wrist_in_6);
        let w = self.frame_b.inverse_transform_point(&w_base);
        let horizontal = w.x.hypot(w.y);
        let b = self.lateral;
        if horizontal < b.abs() - REACH_SLACK {
            return Err(Error::Unreachable(format!(
                "the wrist centre ({:.4}, {:.4}, {:.4}) m is {horizontal:.4} m from axis 1, \
                 inside the arm's lateral offset of {:.4} m",
                w_base.x,
                w_base.y,
                w_base.z,
                b.abs()
            )));
        }
        let rho = ((horizontal - b.abs()) * (horizontal + b.abs()))
            .max(0.0)
            .sqrt();
        let l2 = self.upper[0].hypot(self.upper[1]);
        let l3 = self.fore[0].hypot(self.fore[1]);
        let alpha = self.fore[1].atan2(self.fore[0]) - self.upper[1].atan2(self.upper[0]);
        let mut out = Vec::with_capacity(8);
        // (How far outside the reachable range, distance from axis 2) of the nearest miss, m.
        let mut miss: Option<(f64, f64)> = None;
        let radii: &[f64] = if rho > 0.0 { &[1.0, -1.0] } else { &[1.0] };
        for &sign in radii {
            let r = sign * rho;
            let q1 = if horizontal < SHOULDER_SINGULAR {
                hint.map_or(0.0, |h| h[0])
            } else {
                let g = [r * self.e[0] + b * self.u[0], r * self.e[1] + b * self.u[1]];
                w.y.atan2(w.x) - g[1].atan2(g[0])
            };
            let d = [r - self.shoulder[0], w.z - self.shoulder[1]];
            let dist = d[0].hypot(d[1]);
            let cos_psi = (dist * dist - l2 * l2 - l3 * l3) / (2.0 * l2 * l3);
            if cos_psi.abs() > 1.0 + REACH_SLACK {
                let off = (dist - (l2 + l3)).max((l2 - l3).abs() - dist);
                if miss.is_none_or(|(m, _)| off < m) {
                    miss = Some((off, dist));
                }
                continue;
            }
            let cos_psi = cos_psi.clamp(-1.0, 1.0);
            let sin_psi = ((1.0 - cos_psi) * (1.0 + cos_psi)).sqrt();
            let elbows: &[f64] = if sin_psi > 0.0 { &[1.0, -1.0] } else { &[1.0] };
            for &s in elbows {
                let phi = alpha - (s * sin_psi).atan2(cos_psi);
                let (sp, cp) = phi.sin_cos();
                let f = &self.fore;
                let v = [
                    self.upper[0] + f[0] * cp + f[1] * sp,
                    self.upper[1] - f[0] * sp + f[1] * cp,
                ];
                let q2 = v[1].atan2(v[0]) - d[1].atan2(d[0]);
                let q3 = self.s3 * phi;
                let r3 = self.rot[0] * rz(q1) * self.rot[1] * rz(q2) * self.rot[2] * rz(q3);
                let m = (r3 * self.rot[3]).transpose() * r6;
                self.wrist([q1, q2, q3], m, hint, &mut out);
            }
        }
        if out.is_empty() {
            let dist = miss.map_or(0.0, |(_, d)| d);
            return Err(Error::Unreachable(format!(
                "the wrist centre ({:.4}, {:.4}, {:.4}) m is {dist:.4} m from axis 2; the arm \
                 reaches {:.4} to {:.4} m",
                w_base.x,
                w_base.y,
                w_base.z,
                (l2 - l3).abs(),
                l2 + l3
            )));
        }
        Ok(out)
    }

    /// Wrist solutions for one arm configuration `q1..q3`; `m` as in [`Branch::m`].
    fn wrist(
        &self,
        arm: [f64; 3],
        m: Matrix3<f64>,
        hint: Option<&[f64; 6]>,
        out: &mut Vec<Branch>,
    ) {
        // Axis 6 in frame 4 rotated back by q4: t = Rz(q4) A5 Rz(q5) z6_in_5.
        let t = m.column(2);
        let (c, s) = (t.z, t.x.hypot(t.y));
        let push = |q4: f64, q5: f64, singular: Option<f64>, out: &mut Vec<Branch>| {
            let q6 = self.q6(&m, q4, q5);
            out.push(Branch {
                q: [arm[0], arm[1], arm[2], q4, q5, q6].map(wrap),
                m,
                wrist_singular: singular,
            });
        };
        if s < WRIST_SINGULAR {
            let q5 = s.atan2(c) - self.beta5;
            push(hint.map_or(0.0, |h| h[3]), q5, Some(c.signum()), out);
            return;
        }
        for sign in [1.0, -1.0] {
            let q5 = (sign * s).atan2(c) - self.beta5;
            let v = self.rot[4] * rz(q5) * self.z6_in_5;
            push(t.y.atan2(t.x) - v.y.atan2(v.x), q5, None, out);
        }
    }

    /// `q6` given `q4`, `q5` and `m = Rz(q4) A5 Rz(q5) A6 Rz(q6)`, rad.
    fn q6(&self, m: &Matrix3<f64>, q4: f64, q5: f64) -> f64 {
        let z = self.rot[5].transpose() * rz(-q5) * self.rot[4].transpose() * rz(-q4) * m;
        z[(1, 0)].atan2(z[(0, 0)])
    }

    /// The representative of `b` nearest `seed` within the limits (each joint shifted by
    /// whole turns), or the index of a joint that cannot be brought within its limits.
    fn within_limits(&self, b: &Branch, seed: &[f64; 6]) -> std::result::Result<[f64; 6], usize> {
        let mut q = b.q;
        if let Some(k) = b.wrist_singular {
            // q4 is free: the seed's, clamped; then q6 follows.
            let (lo4, hi4) = self.limits[3];
            let (lo6, hi6) = self.limits[5];
            q[3] = seed[3].clamp(lo4, hi4);
            let q6 = self.q6(&b.m, q[3], q[4]);
            q[5] = match in_limits(q6, seed[5], self.limits[5]) {
                Some(v) => v,
                None => {
                    // Move q4 by -k dq6 so that q6 reaches its nearest limit (q4 + k q6 fixed).
                    let turns = ((0.5 * (lo6 + hi6) - q6) / TAU).round();
                    let shifted = [turns - 1.0, turns, turns + 1.0].map(|n| {
                        let y = q6 + n * TAU;
                        let target = y.clamp(lo6, hi6);
                        (target, q[3] - k * (target - y))
                    });
                    let (q6, q4) = shifted
                        .into_iter()
                        .filter(|&(_, q4)| (lo4..=hi4).contains(&q4))
                        .min_by(|a, b| (a.1 - q[3]).abs().total_cmp(&(b.1 - q[3]).abs()))
                        .ok_or(5usize)?;
                    q[3] = q4;
                    q6
                }
            };
            for i in [0, 1, 2, 4] {
                q[i] = in_limits(q[i], seed[i], self.limits[i]).ok_or(i)?;
            }
            return Ok(q);
        }
        for i in 0..6 {
            q[i] = in_limits(q[i], seed[i], self.limits[i]).ok_or(i)?;
        }
        Ok(q)
    }
}

/// All analytic IK solutions for the flange pose `flange` (base frame, m): up to 8 joint
/// vectors (rad, each angle in [-pi, pi]), not filtered by the joint limits. See
/// [`Opw::solve_all`]; builds the [`Opw`] geometry on every call.
///
/// # Errors
/// [`Error::Model`] if the robot is not of the OPW class (with the reason);
/// [`Error::Unreachable`] when the pose is out of reach; [`Error::InvalidInput`] for a
/// non-finite pose.
pub fn solve_all(robot: &Robot, flange: &Isometry3<f64>) -> Result<Vec<[f64; 6]>> {
    let opw = classify(robot).map_err(|why| {
        Error::Model(format!(
            "robot '{}' is not of the OPW class (parallel shoulder axes, spherical wrist) that \
             the closed-form IK solves: {why}; use kinematics::dls",
            robot.name()
        ))
    })?;
    opw.solve_all(flange)
}

/// Joint angles (rad, within the position limits) nearest to `seed` that put the TCP at
/// `target_tcp` (base frame); `tcp` is the TCP pose in the flange frame (m).
///
/// OPW robots use the closed form ([`Opw::solve_nearest`], including the singularity policy
/// of the module docs); any other chain falls back to damped least squares started at `seed`
/// ([`dls::solve`] with default options), which finds a local solution.
///
/// # Errors
/// [`Error::InvalidInput`] for a seed of the wrong length or non-finite inputs;
/// [`Error::Unreachable`] when the pose is out of reach (or DLS does not converge);
/// [`Error::JointLimit`] when every solution violates a limit, naming the blocking joint.
pub fn solve_nearest(
    robot: &Robot,
    target_tcp: &Isometry3<f64>,
    tcp: &Isometry3<f64>,
    seed: &[f64],
) -> Result<Vec<f64>> {
    robot.check_len(seed, "seed")?;
    match Opw::from_robot(robot) {
        Some(opw) => opw.solve_nearest(target_tcp, tcp, seed).map(|q| q.to_vec()),
        None => dls::solve(robot, target_tcp, tcp, seed, &DlsOptions::default()),
    }
}

/// The OPW geometry of `robot`, or why it is not of the class.
fn classify(robot: &Robot) -> std::result::Result<Opw, String> {
    let joints = robot.joints();
    if joints.len() != 6 {
        return Err(format!("it has {} joints, not 6", joints.len()));
    }
    // Link frames 1..6 at q = 0, in frame B (= frame 1).
    let mut frames = [Isometry3::identity(); 6];
    for i in 1..6 {
        frames[i] = frames[i - 1] * joints[i].origin;
    }
    let z = frames.map(|f| f.rotation * Vector3::z());
    let o = frames.map(|f| f.translation.vector);
    if z[1].z.abs() > DIRECTION_TOL {
        return Err("axis 2 is not perpendicular to axis 1".into());
    }
    if z[1].cross(&z[2]).norm() > DIRECTION_TOL {
        return Err("axes 2 and 3 are not parallel".into());
    }
    if z[3].dot(&z[4]).abs() > DIRECTION_TOL || z[4].dot(&z[5]).abs() > DIRECTION_TOL {
        return Err("axis 5 is not perpendicular to axes 4 and 6".into());
    }
    // Axes 4 and 5 are perpendicular, so they have a unique common normal.
    let (p4, p5) = closest_points(&o[3], &z[3], &o[4], &z[4]);
    let gap = (p4 - p5).norm();
    if gap > LENGTH_TOL {
        return Err(format!(
            "axes 4 and 5 do not intersect (they pass {gap:.3e} m apart)"
        ));
    }
    let wc = 0.5 * (p4 + p5);
    let to_w = wc - o[5];
    let miss6 = (to_w - z[5] * z[5].dot(&to_w)).norm();
    if miss6 > LENGTH_TOL {
        return Err(format!(
            "axis 6 misses the intersection of axes 4 and 5 by {miss6:.3e} m (no spherical wrist)"
        ));
    }
    let u = Vector3::new(z[1].x, z[1].y, 0.0).normalize();
    let e = u.cross(&Vector3::z());
    let plane = |p: &Vector3<f64>| [p.dot(&e), p.z];
    let (shoulder, elbow, wrist) = (plane(&o[1]), plane(&o[2]), plane(&wc));
    let upper = [elbow[0] - shoulder[0], elbow[1] - shoulder[1]];
    let fore = [wrist[0] - elbow[0], wrist[1] - elbow[1]];
    if upper[0].hypot(upper[1]) < LENGTH_TOL {
        return Err("axes 2 and 3 coincide".into());
    }
    if fore[0].hypot(fore[1]) < LENGTH_TOL {
        return Err("the wrist centre lies on axis 3".into());
    }
    let rot: [Matrix3<f64>; 6] = std::array::from_fn(|i| robot.chain()[i].rot);
    let z4_in_5 = rot[4].transpose() * Vector3::z();
    let z6_in_5 = rot[5] * Vector3::z();
    Ok(Opw {
        frame_b: joints[0].origin,
        rot,
        e: [e.x, e.y],
        u: [u.x, u.y],
        shoulder,
        upper,
        fore,
        lateral: wc.dot(&u),
        s3: z[1].dot(&z[2]).signum(),
        wrist_in_6: frames[5].inverse_transform_point(&Point3::from(wc)).coords,
        flange_inv: robot.flange().inverse(),
        z6_in_5,
        beta5: z6_in_5.y.atan2(z6_in_5.x) - z4_in_5.y.atan2(z4_in_5.x),
        limits: std::array::from_fn(|i| (joints[i].limits.lower, joints[i].limits.upper)),
        names: std::array::from_fn(|i| joints[i].name.clone()),
    })
}

/// Closest points of the non-parallel lines `p1 + s d1` and `p2 + t d2` (unit directions).
fn closest_points(
    p1: &Vector3<f64>,
    d1: &Vector3<f64>,
    p2: &Vector3<f64>,
    d2: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let w0 = p1 - p2;
    let b = d1.dot(d2);
    let (d, e) = (d1.dot(&w0), d2.dot(&w0));
    let denom = 1.0 - b * b;
    (
        p1 + d1 * ((b * e - d) / denom),
        p2 + d2 * ((e - b * d) / denom),
    )
}

/// Rotation matrix about z by `q` rad.
fn rz(q: f64) -> Matrix3<f64> {
    let (s, c) = q.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// `x` wrapped into [-pi, pi).
fn wrap(x: f64) -> f64 {
    x - TAU * ((x + PI) / TAU).floor()
}

/// `x + 2 pi k` nearest `seed`.
fn nearest_turn(x: f64, seed: f64) -> f64 {
    x + TAU * ((seed - x) / TAU).round()
}

/// `x + 2 pi k` nearest `seed` among those within `(lo, hi)` (with [`LIMIT_SLACK`], then
/// clamped), or `None` if no whole turn brings `x` within the limits.
fn in_limits(x: f64, seed: f64, (lo, hi): (f64, f64)) -> Option<f64> {
    let k_min = ((lo - LIMIT_SLACK - x) / TAU).ceil();
    let k_max = ((hi + LIMIT_SLACK - x) / TAU).floor();
    (k_min <= k_max).then(|| {
        let k = ((seed - x) / TAU).round().clamp(k_min, k_max);
        (x + k * TAU).clamp(lo, hi)
    })
}

/// Squared Euclidean distance of two joint vectors, rad^2.
fn distance2(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}
