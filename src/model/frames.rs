//! Link frames by modified Denavit–Hartenberg rules, and the MDH table.
//!
//! Given every joint axis as a line in the base frame (at `q = 0`), [`canonical_frames`]
//! places frame `i` with z along axis `i` and x along the common normal from axis `i` to axis
//! `i+1` (Craig's convention). Where that leaves a choice it takes the one that keeps the MDH
//! parameters small:
//! - intersecting axes: x = ±(z_i × z_{i+1}), the sign closer to x_{i-1} (|θ offset| ≤ π/2);
//! - parallel axes: the origin where x_{i-1} meets axis `i` (d_i = 0);
//! - last joint: x_n = x_{n-1}, origin where x_{n-1} meets axis `n`.
//!
//! For the IRB 1200 this reproduces the paper's Table 1 exactly. Any chain gets valid frames;
//! [`mdh_table`] then reports whether each joint transform has the MDH form
//! `Rx(α) Tx(a) Rz(θ) Tz(d)` (it may not if the first axis is not placed as MDH expects
//! relative to the base frame).

use nalgebra::{
    Isometry3, Matrix3, Point3, Rotation3, Translation3, Unit, UnitQuaternion, Vector3,
};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::model::Robot;

const PARALLEL_TOL: f64 = 1e-9;
const LENGTH_TOL: f64 = 1e-12;

/// One row of a modified DH table (Craig): frame i-1 -> i is `Rx(alpha) Tx(a) Rz(theta + q) Tz(d)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MdhRow {
    /// Link length `a_i`, m.
    pub a: f64,
    /// Link twist `alpha_i`, rad.
    pub alpha: f64,
    /// Link offset `d_i`, m.
    pub d: f64,
    /// Joint angle offset `theta_i` at `q_i = 0`, rad.
    pub theta: f64,
}

impl MdhRow {
    /// The transform `Rx(alpha) Tx(a) Rz(theta + q) Tz(d)`.
    pub fn transform(&self, q: f64) -> Isometry3<f64> {
        let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), self.alpha);
        let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), self.theta + q);
        Isometry3::from_parts(Translation3::identity(), rx)
            * Translation3::new(self.a, 0.0, 0.0)
            * Isometry3::from_parts(Translation3::identity(), rz)
            * Translation3::new(0.0, 0.0, self.d)
    }

    /// Decompose `t` into MDH parameters, or `None` if it is not of the MDH form.
    pub fn from_transform(t: &Isometry3<f64>) -> Option<MdhRow> {
        let r = t.rotation.to_rotation_matrix();
        let r = r.matrix();
        let p = t.translation.vector;
        let alpha = f64::atan2(-r[(1, 2)], r[(2, 2)]);
        let theta = f64::atan2(-r[(0, 1)], r[(0, 0)]);
        let d = p.y * -alpha.sin() + p.z * alpha.cos();
        let row = MdhRow {
            a: p.x,
            alpha,
            d,
            theta,
        };
        let back = row.transform(0.0);
        let dp = (back.translation.vector - p).norm();
        let dr = back.rotation.angle_to(&t.rotation);
        (dp < 1e-9 && dr < 1e-9).then_some(row.cleaned())
    }

    /// Snap values within 1e-12 of 0 and angles within 1e-12 of multiples of pi/2.
    fn cleaned(self) -> MdhRow {
        let snap_len = |v: f64| if v.abs() < 1e-12 { 0.0 } else { v };
        let snap_ang = |v: f64| {
            let k = (v / std::f64::consts::FRAC_PI_2).round();
            let s = k * std::f64::consts::FRAC_PI_2;
            let s = if (v - s).abs() < 1e-12 { s } else { v };
            if (s + std::f64::consts::PI).abs() < 1e-12 {
                std::f64::consts::PI
            } else {
                s + 0.0 // no negative zero
            }
        };
        MdhRow {
            a: snap_len(self.a),
            alpha: snap_ang(self.alpha),
            d: snap_len(self.d),
            theta: snap_ang(self.theta),
        }
    }
}

/// A joint axis in the base frame at `q = 0`: a point on it and its positive direction.
#[derive(Debug, Clone, Copy)]
pub struct AxisLine {
    /// A point on the axis, m.
    pub point: Point3<f64>,
    /// Unit direction (positive joint rotation is right-handed about it).
    pub dir: Unit<Vector3<f64>>,
}

/// Poses of the MDH link frames in the base frame at `q = 0`, one per axis (see module docs).
pub fn canonical_frames(axes: &[AxisLine]) -> Vec<Isometry3<f64>> {
    let mut frames = Vec::with_capacity(axes.len());
    let mut prev_o = Point3::origin();
    let mut prev_x = Vector3::x();
    for (i, ax) in axes.iter().enumerate() {
        let z = ax.dir.into_inner();
        let (o, x) = match axes.get(i + 1) {
            Some(next) => {
                let zn = next.dir.into_inner();
                let cross = z.cross(&zn);
                if cross.norm() > PARALLEL_TOL {
                    let (s, t) = closest_params(&ax.point, &z, &next.point, &zn);
                    let o = ax.point + z * s;
                    let foot = next.point + zn * t;
                    let dvec = foot - o;
                    let x = if dvec.norm() > LENGTH_TOL {
                        dvec.normalize()
                    } else {
                        let c = cross.normalize();
                        if c.dot(&prev_x) < -LENGTH_TOL { -c } else { c }
                    };
                    (o, x)
                } else {
                    let o = meet_point(&ax.point, &z, &prev_o, &prev_x);
                    let to_next = next.point - o;
                    let perp = to_next - z * z.dot(&to_next);
                    let x = if perp.norm() > LENGTH_TOL {
                        perp.normalize()
                    } else {
                        perpendicular_towards(&z, &prev_x)
                    };
                    (o, x)
                }
            }
            None => (
                meet_point(&ax.point, &z, &prev_o, &prev_x),
                perpendicular_towards(&z, &prev_x),
            ),
        };
        let y = z.cross(&x);
        let rot = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
        frames.push(Isometry3::from_parts(
            Translation3::from(o.coords),
            UnitQuaternion::from_rotation_matrix(&rot),
        ));
        prev_o = o;
        prev_x = x;
    }
    frames
}

/// The MDH table of a robot: one row per joint, then the flange row (frame n -> flange).
/// Errors name the first joint whose transform is not MDH-expressible.
pub fn mdh_table(robot: &Robot) -> Result<Vec<MdhRow>> {
    let mut rows = Vec::with_capacity(robot.dof() + 1);
    for j in robot.joints() {
        rows.push(MdhRow::from_transform(&j.origin).ok_or_else(|| {
            Error::Model(format!(
                "joint '{}' is not MDH-expressible relative to the previous frame",
                j.name
            ))
        })?);
    }
    rows.push(MdhRow::from_transform(robot.flange()).ok_or_else(|| {
        Error::Model(format!(
            "flange frame '{}' is not MDH-expressible relative to the last link frame",
            robot.flange_name()
        ))
    })?);
    Ok(rows)
}

/// Parameters (s, t) of the closest points p1 + s d1, p2 + t d2 of two non-parallel lines.
fn closest_params(
    p1: &Point3<f64>,
    d1: &Vector3<f64>,
    p2: &Point3<f64>,
    d2: &Vector3<f64>,
) -> (f64, f64) {
    let w0 = p1 - p2;
    let b = d1.dot(d2);
    let d = d1.dot(&w0);
    let e = d2.dot(&w0);
    let denom = 1.0 - b * b;
    ((b * e - d) / denom, (e - b * d) / denom)
}

/// Point of the line (p, z) where the line (o, x) meets it (closest point), or the projection
/// of `o` when the lines are parallel.
fn meet_point(p: &Point3<f64>, z: &Vector3<f64>, o: &Point3<f64>, x: &Vector3<f64>) -> Point3<f64> {
    if z.cross(x).norm() > PARALLEL_TOL {
        let (s, _) = closest_params(p, z, o, x);
        p + z * s
    } else {
        p + z * z.dot(&(o - p))
    }
}

/// Unit vector perpendicular to `z`, as close as possible to `hint`.
fn perpendicular_towards(z: &Vector3<f64>, hint: &Vector3<f64>) -> Vector3<f64> {
    let v = hint - z * z.dot(hint);
    if v.norm() > PARALLEL_TOL {
        return v.normalize();
    }
    let other = if z.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    (other - z * z.dot(&other)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn mdh_row_round_trip() {
        let row = MdhRow {
            a: 0.3,
            alpha: -0.7,
            d: 0.2,
            theta: 1.1,
        };
        let back = MdhRow::from_transform(&row.transform(0.0)).unwrap();
        assert!((back.a - row.a).abs() < 1e-12 && (back.d - row.d).abs() < 1e-12);
        assert!((back.alpha - row.alpha).abs() < 1e-12 && (back.theta - row.theta).abs() < 1e-12);
    }

    #[test]
    fn non_mdh_transform_is_detected() {
        let t = Isometry3::translation(0.0, 0.1, 0.0);
        assert!(MdhRow::from_transform(&t).is_none());
    }

    #[test]
    fn irb1200_axes_give_table_1() {
        let line = |p: [f64; 3], d: Vector3<f64>| AxisLine {
            point: Point3::from(p),
            dir: Unit::new_normalize(d),
        };
        let (x, y, z) = (Vector3::x(), Vector3::y(), Vector3::z());
        let axes = [
            line([0.0, 0.0, 0.3991], z),
            line([0.0, 0.0, 0.3991], y),
            line([0.0, 0.0, 0.7491], y),
            line([0.0, 0.0, 0.7911], x),
            line([0.351, 0.0, 0.7911], y),
            line([0.433, 0.0, 0.7911], x),
        ];
        let f = canonical_frames(&axes);
        let mut prev = Isometry3::identity();
        let expect = [
            (0.0, 0.0, 0.3991, 0.0),
            (0.0, -FRAC_PI_2, 0.0, -FRAC_PI_2),
            (0.35, 0.0, 0.0, 0.0),
            (0.042, -FRAC_PI_2, 0.351, 0.0),
            (0.0, FRAC_PI_2, 0.0, 0.0),
            (0.0, -FRAC_PI_2, 0.0, 0.0),
        ];
        for (fi, e) in f.iter().zip(expect) {
            let row = MdhRow::from_transform(&(prev.inverse() * fi)).unwrap();
            assert!((row.a - e.0).abs() < 1e-12, "{row:?} vs {e:?}");
            assert!((row.alpha - e.1).abs() < 1e-12, "{row:?} vs {e:?}");
            assert!((row.d - e.2).abs() < 1e-12, "{row:?} vs {e:?}");
            assert!((row.theta - e.3).abs() < 1e-12, "{row:?} vs {e:?}");
            prev = *fi;
        }
    }
}
