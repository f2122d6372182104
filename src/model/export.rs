//! Writing a robot out as URDF and its drives as a drive TOML, e.g. the identified robot so
//! that it can be simulated (`simulate --robot OUT.urdf --drive OUT.drive.toml`) or loaded by
//! other tools.
//!
//! The URDF has one link per body of the [`Robot`] (fixed children were merged when it was
//! loaded; locked joints are gone), in the input URDF's own link frames
//! ([`crate::model::Link::urdf_pose`]): the inertial (mass, COM, inertia about the COM), the
//! visual and collision shapes, the joints with their axes, limits and friction
//! (`<dynamics damping friction>`), and the flange frame as a massless link on a fixed joint.
//! [`crate::model::urdf::load_str`] reads it back to the same model.

use std::fmt::Write as _;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};

use crate::dynamics::ParamLayout;
use crate::error::{Error, Result};
use crate::model::drive::Drive;
use crate::model::inertia::tensor_elements;
use crate::model::{Friction, Geometry, Link, RigidInertia, Robot, Shape};

/// `robot` with the standard parameters `phi` (layout `layout`, MDH link frames; see
/// [`ParamLayout`]): every link's mass properties, and the joints' Coulomb (N m) and viscous
/// (N m s/rad) friction when the layout has them. Rotor inertia is not part of a [`Robot`]
/// (it goes into the drive file).
///
/// Errors: a `phi` of the wrong length or a link that is not physically consistent (names the
/// link).
pub fn with_standard_params(robot: &Robot, layout: &ParamLayout, phi: &[f64]) -> Result<Robot> {
    if layout.dof != robot.dof() || phi.len() != layout.len() {
        return Err(Error::InvalidInput(format!(
            "{} standard parameters (layout of {} joints) for a robot with {} joints",
            phi.len(),
            layout.dof,
            robot.dof()
        )));
    }
    let mut links = robot.links().to_vec();
    let mut joints = robot.joints().to_vec();
    for (j, (link, joint)) in links.iter_mut().zip(&mut joints).enumerate() {
        let start = layout.link_start(j);
        let mut p = [0.0; 10];
        p.copy_from_slice(&phi[start..start + 10]);
        link.inertia = RigidInertia::from_standard_params(&p);
        if let (Some(c), Some(v)) = (layout.coulomb_col(j), layout.viscous_col(j)) {
            joint.friction = Friction {
                coulomb: phi[c],
                viscous: phi[v],
            };
        }
    }
    Robot::new(
        robot.name(),
        robot.base().clone(),
        joints,
        links,
        *robot.flange(),
        robot.flange_name(),
    )
}

/// Escape text for an XML attribute value.
fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// Text inside an XML comment: `--` is not allowed there.
fn comment(s: &str) -> String {
    s.replace("--", "- -")
}

/// URDF roll, pitch, yaw (rad) of a rotation, `R = Rz(yaw) Ry(pitch) Rx(roll)`, accurate to
/// roundoff even at pitch = +-pi/2 (where the usual `asin` extraction loses half the digits):
/// yaw from the first column, then roll from `Rz(-yaw) R`, which is `Ry(pitch) Rx(roll)`
/// whatever the pitch.
fn rpy(rotation: &UnitQuaternion<f64>) -> (f64, f64, f64) {
    let r = rotation.to_rotation_matrix().into_inner();
    let yaw = r[(1, 0)].atan2(r[(0, 0)]);
    let pitch = (-r[(2, 0)]).atan2(r[(0, 0)].hypot(r[(1, 0)]));
    let (sy, cy) = yaw.sin_cos();
    // Row 1 of Rz(-yaw) R: [0, cos(roll), -sin(roll)].
    let r11 = -sy * r[(0, 1)] + cy * r[(1, 1)];
    let r12 = -sy * r[(0, 2)] + cy * r[(1, 2)];
    ((-r12).atan2(r11), pitch, yaw)
}

/// `xyz="..." rpy="..."` of a pose (full precision: the numbers read back to the same bits).
fn origin(pose: &Isometry3<f64>) -> String {
    let t = pose.translation.vector;
    let (r, p, y) = rpy(&pose.rotation);
    format!(
        "<origin xyz=\"{:?} {:?} {:?}\" rpy=\"{r:?} {p:?} {y:?}\"/>",
        t.x, t.y, t.z
    )
}

fn geometry(g: &Geometry) -> String {
    match g {
        Geometry::Box { size } => {
            format!("<box size=\"{:?} {:?} {:?}\"/>", size[0], size[1], size[2])
        }
        Geometry::Cylinder { radius, length } => {
            format!("<cylinder radius=\"{radius:?}\" length=\"{length:?}\"/>")
        }
        Geometry::Capsule { radius, length } => {
            format!("<capsule radius=\"{radius:?}\" length=\"{length:?}\"/>")
        }
        Geometry::Sphere { radius } => format!("<sphere radius=\"{radius:?}\"/>"),
        Geometry::Mesh { filename, scale } => format!(
            "<mesh filename=\"{}\" scale=\"{:?} {:?} {:?}\"/>",
            xml(filename),
            scale[0],
            scale[1],
            scale[2]
        ),
    }
}

/// One `<link>` element: the body `link` written in its URDF frame.
fn link_xml(out: &mut String, link: &Link, note: &str) {
    let to_urdf = link.urdf_pose.inverse();
    let _ = writeln!(out, "  <link name=\"{}\">", xml(&link.name));
    if link.inertia.mass > 0.0 {
        let b = link.inertia.transformed(&to_urdf);
        let [xx, yy, zz, xy, xz, yz] = tensor_elements(&b.inertia_com);
        if !note.is_empty() {
            let _ = writeln!(out, "    <!-- {} -->", comment(note));
        }
        let _ = writeln!(out, "    <inertial>");
        let _ = writeln!(
            out,
            "      {}",
            origin(&Isometry3::translation(b.com.x, b.com.y, b.com.z))
        );
        let _ = writeln!(out, "      <mass value=\"{:?}\"/>", b.mass);
        let _ = writeln!(
            out,
            "      <inertia ixx=\"{xx:?}\" ixy=\"{xy:?}\" ixz=\"{xz:?}\" iyy=\"{yy:?}\" iyz=\"{yz:?}\" izz=\"{zz:?}\"/>"
        );
        let _ = writeln!(out, "    </inertial>");
    }
    let shape = |out: &mut String, kind: &str, k: usize, s: &Shape| {
        let _ = writeln!(out, "    <{kind}>");
        let _ = writeln!(out, "      {}", origin(&(to_urdf * s.pose)));
        let _ = writeln!(out, "      <geometry>{}</geometry>", geometry(&s.geometry));
        if let Some(c) = s.rgba {
            let _ = writeln!(
                out,
                "      <material name=\"{}_{k}\"><color rgba=\"{} {} {} {}\"/></material>",
                xml(&link.name),
                c[0],
                c[1],
                c[2],
                c[3]
            );
        }
        let _ = writeln!(out, "    </{kind}>");
    };
    for (k, s) in link.visuals.iter().enumerate() {
        shape(out, "visual", k, s);
    }
    for (k, s) in link.collisions.iter().enumerate() {
        shape(out, "collision", k, s);
    }
    let _ = writeln!(out, "  </link>");
}

/// The URDF text of `robot` (see the module docs). `header` goes into a comment at the top
/// (e.g. which parameters were identified and which came from a prior); `link_notes[i]`, when
/// given, into a comment at moving link `i`'s inertial.
pub fn urdf_string(robot: &Robot, header: &str, link_notes: &[String]) -> String {
    let mut out = String::from("<?xml version=\"1.0\"?>\n");
    let _ = writeln!(out, "<!--\n{}\n-->", comment(header.trim_end()));
    let _ = writeln!(out, "<robot name=\"{}\">", xml(robot.name()));
    link_xml(&mut out, robot.base(), "");
    let mut parent = robot.base();
    for (i, (joint, link)) in robot.joints().iter().zip(robot.links()).enumerate() {
        let note = link_notes.get(i).map_or("", String::as_str);
        link_xml(&mut out, link, note);
        let pose = parent.urdf_pose.inverse() * joint.origin * link.urdf_pose;
        let axis = link.urdf_pose.rotation.inverse() * Vector3::z();
        let lim = &joint.limits;
        let continuous = !(lim.lower.is_finite() && lim.upper.is_finite());
        let kind = if continuous { "continuous" } else { "revolute" };
        let _ = writeln!(
            out,
            "  <joint name=\"{}\" type=\"{kind}\">",
            xml(&joint.name)
        );
        let _ = writeln!(out, "    <parent link=\"{}\"/>", xml(&parent.name));
        let _ = writeln!(out, "    <child link=\"{}\"/>", xml(&link.name));
        let _ = writeln!(out, "    {}", origin(&pose));
        let _ = writeln!(
            out,
            "    <axis xyz=\"{:?} {:?} {:?}\"/>",
            axis.x, axis.y, axis.z
        );
        // Velocity 0 reads back as "no limit"; effort 0 as "none given".
        let velocity = if lim.velocity.is_finite() {
            lim.velocity
        } else {
            0.0
        };
        let effort = lim.effort.unwrap_or(0.0);
        if continuous {
            let _ = writeln!(
                out,
                "    <limit effort=\"{effort:?}\" velocity=\"{velocity:?}\"/>"
            );
        } else {
            let _ = writeln!(
                out,
                "    <limit lower=\"{:?}\" upper=\"{:?}\" effort=\"{effort:?}\" velocity=\"{velocity:?}\"/>",
                lim.lower, lim.upper
            );
        }
        let _ = writeln!(
            out,
            "    <dynamics damping=\"{:?}\" friction=\"{:?}\"/>",
            joint.friction.viscous, joint.friction.coulomb
        );
        let _ = writeln!(out, "  </joint>");
        parent = link;
    }
    if robot.flange_name() != parent.name {
        let _ = writeln!(out, "  <link name=\"{}\"/>", xml(robot.flange_name()));
        let _ = writeln!(
            out,
            "  <joint name=\"{}-{}\" type=\"fixed\">",
            xml(&parent.name),
            xml(robot.flange_name())
        );
        let _ = writeln!(out, "    <parent link=\"{}\"/>", xml(&parent.name));
        let _ = writeln!(out, "    <child link=\"{}\"/>", xml(robot.flange_name()));
        let _ = writeln!(
            out,
            "    {}",
            origin(&(parent.urdf_pose.inverse() * robot.flange()))
        );
        let _ = writeln!(out, "  </joint>");
    }
    out.push_str("</robot>\n");
    out
}

/// The drive TOML of `drive` for `robot` (the format of [`crate::model::drive`], friction
/// written out), with `header` as comment lines at the top and `joint_notes[i]`, when given,
/// as a comment above joint `i`'s entry.
pub fn drive_string(robot: &Robot, drive: &Drive, header: &str, joint_notes: &[String]) -> String {
    let mut out = String::new();
    for line in header.lines() {
        let _ = writeln!(out, "# {line}");
    }
    let quote = |s: &str| s.replace('\\', "\\\\").replace('"', "\\\"");
    let _ = writeln!(out, "\nrobot = \"{}\"", quote(robot.name()));
    for (i, (j, d)) in robot.joints().iter().zip(drive.joints()).enumerate() {
        out.push('\n');
        if let Some(note) = joint_notes.get(i) {
            for line in note.lines() {
                let _ = writeln!(out, "# {line}");
            }
        }
        let _ = writeln!(out, "[[joint]]");
        let _ = writeln!(out, "name = \"{}\"", quote(&j.name));
        let _ = writeln!(out, "rotor_inertia_kgm2 = {:?}", d.rotor_inertia);
        let _ = writeln!(out, "efficiency = {:?}", d.efficiency);
        let _ = writeln!(out, "copper_loss_W_per_Nm2 = {:?}", d.copper_loss);
        let _ = writeln!(out, "standby_W = {:?}", d.standby_power);
        let _ = writeln!(out, "coulomb_Nm = {:?}", d.friction.coulomb);
        let _ = writeln!(out, "viscous_Nms_per_rad = {:?}", d.friction.viscous);
        // Load-dependent gear friction, the one unmodelled effect an identified model can
        // carry (written only when present, as the input files have it).
        let gear = &d.unmodelled;
        if gear.gear_friction != 0.0 || gear.gear_friction_braking != 0.0 {
            let _ = writeln!(out, "gear_friction_per_Nm = {:?}", gear.gear_friction);
            let _ = writeln!(
                out,
                "gear_friction_braking_per_Nm = {:?}",
                gear.gear_friction_braking
            );
        }
    }
    out
}
