//! The robot's 3-D geometry from its own visual shapes, and link poses as Rerun transforms.

use nalgebra::Isometry3;
use rerun::{
    Boxes3D, Capsules3D, Color, Cylinders3D, Ellipsoids3D, FillMode, Points3D, Quaternion,
    TimeColumn, Transform3D, ViewCoordinates,
};

use super::{TIMELINE, Viz, entity, viz_err};
use crate::error::Result;
use crate::kinematics::fk::link_poses;
use crate::model::{Geometry, Robot, Shape};

/// Colour of shapes whose URDF gives none (light grey).
const DEFAULT_RGBA: [f32; 4] = [0.75, 0.75, 0.75, 1.0];

/// Radius of the point that stands in for a mesh, m.
const MESH_PLACEHOLDER_RADIUS_M: f32 = 0.01;

impl Viz {
    /// Log the robot under `{prefix}/robot`: its shapes (static; boxes, cylinders, capsules
    /// and spheres as Rerun primitives, meshes as labelled points) and the link poses at
    /// `q = 0` at `sim_time = 0`. A recording logged later at the same prefix moves the links
    /// (it replaces this pose at `t = 0`).
    pub fn log_robot(&self, robot: &Robot, prefix: &str) -> Result<()> {
        self.log_geometry(robot, prefix)?;
        let n = robot.dof();
        let mut poses = vec![Isometry3::identity(); n];
        link_poses(robot, &vec![0.0; n], &mut poses);
        let per_link: Vec<Vec<Isometry3<f64>>> = poses.into_iter().map(|p| vec![p]).collect();
        self.log_link_poses(prefix, &[0.0], &per_link)
    }

    /// Static part of the robot: view coordinates and every visual shape.
    pub(super) fn log_geometry(&self, robot: &Robot, prefix: &str) -> Result<()> {
        let root = entity(prefix, "robot");
        self.rec
            .log_static(root.as_str(), &ViewCoordinates::RIGHT_HAND_Z_UP())
            .map_err(|e| viz_err("logging the robot failed", e))?;
        let base = std::iter::once(("base".to_owned(), robot.base()));
        let links = (1..)
            .zip(robot.links())
            .map(|(i, l)| (format!("link_{i}"), l));
        for (name, link) in base.chain(links) {
            for (k, shape) in link.visuals.iter().enumerate() {
                self.log_shape(&format!("{root}/{name}/visual_{k}"), shape)?;
            }
        }
        Ok(())
    }

    /// One shape at `path`: its pose in the link frame and the primitive (static).
    fn log_shape(&self, path: &str, shape: &Shape) -> Result<()> {
        let ctx = format!("logging {path} failed");
        self.rec
            .log_static(path, &transform(&shape.pose))
            .map_err(|e| viz_err(&ctx, e))?;
        let rgba = shape.rgba.unwrap_or(DEFAULT_RGBA);
        let c = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        let color = Color::from_unmultiplied_rgba(c(rgba[0]), c(rgba[1]), c(rgba[2]), c(rgba[3]));
        let res = match &shape.geometry {
            Geometry::Box { size } => self.rec.log_static(
                path,
                &Boxes3D::from_sizes([size.map(|v| v as f32)])
                    .with_colors([color])
                    .with_fill_mode(FillMode::Solid),
            ),
            Geometry::Cylinder { radius, length } => self.rec.log_static(
                path,
                &Cylinders3D::from_lengths_and_radii([*length as f32], [*radius as f32])
                    .with_colors([color])
                    .with_fill_mode(FillMode::Solid),
            ),
            // Rerun's capsule runs from z = 0 to z = length; powertwin's is centred.
            Geometry::Capsule { radius, length } => self.rec.log_static(
                path,
                &Capsules3D::from_lengths_and_radii([*length as f32], [*radius as f32])
                    .with_translations([[0.0, 0.0, -0.5 * *length as f32]])
                    .with_colors([color])
                    .with_fill_mode(FillMode::Solid),
            ),
            Geometry::Sphere { radius } => self.rec.log_static(
                path,
                &Ellipsoids3D::from_radii([*radius as f32])
                    .with_colors([color])
                    .with_fill_mode(FillMode::Solid),
            ),
            Geometry::Mesh { filename, .. } => self.rec.log_static(
                path,
                &Points3D::new([[0.0_f32; 3]])
                    .with_radii([MESH_PLACEHOLDER_RADIUS_M])
                    .with_labels([format!("mesh {filename} (not loaded)")])
                    .with_colors([color]),
            ),
        };
        res.map_err(|e| viz_err(&ctx, e))
    }

    /// Poses of the link frames in the base frame at times `t_s` (s): `poses[i][k]` is link
    /// `i+1` at `t_s[k]`. One column per link.
    pub(super) fn log_link_poses(
        &self,
        prefix: &str,
        t_s: &[f64],
        poses: &[Vec<Isometry3<f64>>],
    ) -> Result<()> {
        for (i, link) in (1..).zip(poses) {
            let path = entity(prefix, &format!("robot/link_{i}"));
            let ctx = format!("logging {path} failed");
            let columns = Transform3D::update_fields()
                .with_many_translation(link.iter().map(translation))
                .with_many_quaternion(link.iter().map(quaternion))
                .columns_of_unit_batches()
                .map_err(|e| viz_err(&ctx, e))?;
            let time = TimeColumn::new_duration_secs(TIMELINE, t_s.iter().copied());
            self.rec
                .send_columns(path.as_str(), [time], columns)
                .map_err(|e| viz_err(&ctx, e))?;
        }
        Ok(())
    }
}

/// Translation of a pose, m, as Rerun's f32 triple.
pub(super) fn translation(p: &Isometry3<f64>) -> [f32; 3] {
    let v = p.translation.vector;
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Rotation of a pose as a Rerun quaternion.
fn quaternion(p: &Isometry3<f64>) -> Quaternion {
    let q = p.rotation.coords;
    Quaternion::from_xyzw([q.x as f32, q.y as f32, q.z as f32, q.w as f32])
}

/// A pose as a Rerun transform (child frame to parent frame).
fn transform(p: &Isometry3<f64>) -> Transform3D {
    Transform3D::from_translation_rotation(translation(p), quaternion(p))
}
