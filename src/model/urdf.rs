//! Loading a fixed-base serial chain of revolute joints from URDF.
//!
//! - Revolute joints move; continuous joints are revolute without position limits.
//! - Fixed joints, and joints named in [`LoadOptions::lock`] (frozen at 0), merge their child
//!   link into the parent body; mass properties are combined about the common frame.
//! - Anything else (prismatic, floating, planar, spherical, mimic joints) must be locked.
//! - The moving joints must form one chain from the root: a branching tree, several roots,
//!   a floating base, a moving link without `<inertial>`, a non-positive mass or a
//!   non-positive-definite inertia give an [`Error::Model`] naming the link or joint.
//! - The flange is the fixed descendant of the last link named `tool0`, else `flange`, else
//!   the last link itself.
//!
//! Link frames are re-chosen by MDH rules ([`crate::model::frames`]); the URDF frames are
//! kept as [`crate::model::Link::urdf_pose`]. Joint coordinates are the URDF's.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};

use crate::error::{Error, Result};
use crate::model::frames::{AxisLine, canonical_frames};
use crate::model::{Friction, Geometry, Joint, JointLimits, Link, RigidInertia, Robot, Shape};

/// Options for loading a URDF.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Names of joints to freeze at position 0 (e.g. gripper fingers).
    pub lock: Vec<String>,
}

/// Load a robot from a URDF file.
pub fn load_file(path: &Path, opts: &LoadOptions) -> Result<Robot> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    load_str(&text, opts).map_err(|e| match e {
        Error::UrdfSyntax(m) => Error::UrdfSyntax(format!("{}: {m}", path.display())),
        Error::Model(m) => Error::Model(format!("{}: {m}", path.display())),
        other => other,
    })
}

/// Load a robot from URDF text.
pub fn load_str(text: &str, opts: &LoadOptions) -> Result<Robot> {
    let urdf = urdf_rs::read_from_string(text).map_err(|e| Error::UrdfSyntax(e.to_string()))?;
    build(&urdf, opts)
}

fn pose(p: &urdf_rs::Pose) -> Result<Isometry3<f64>> {
    let (xyz, rpy) = (p.xyz.0, p.rpy.0);
    if xyz.iter().chain(&rpy).any(|v| !v.is_finite()) {
        return Err(Error::Model("an <origin> has a non-finite value".into()));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    ))
}

/// Mass properties of one URDF link in its own frame; `None` when it has no inertial at all.
fn link_inertia(link: &urdf_rs::Link) -> Result<Option<RigidInertia>> {
    let inl = &link.inertial;
    let i = &inl.inertia;
    let vals = [i.ixx, i.iyy, i.izz, i.ixy, i.ixz, i.iyz];
    if inl.mass.value == 0.0 && vals.iter().all(|v| *v == 0.0) {
        return Ok(None);
    }
    let origin =
        pose(&inl.origin).map_err(|e| Error::Model(format!("link '{}': {e}", link.name)))?;
    let body = RigidInertia::new(inl.mass.value, Vector3::zeros(), vals).transformed(&origin);
    body.validate(&format!("link '{}'", link.name))?;
    Ok(Some(body))
}

fn shapes<'a>(
    items: impl Iterator<Item = (&'a urdf_rs::Pose, &'a urdf_rs::Geometry, Option<[f32; 4]>)>,
    link_to_frame: &Isometry3<f64>,
    link: &str,
) -> Result<Vec<Shape>> {
    items
        .map(|(origin, geom, rgba)| {
            let geometry = match geom {
                urdf_rs::Geometry::Box { size } => Geometry::Box { size: size.0 },
                urdf_rs::Geometry::Cylinder { radius, length } => Geometry::Cylinder {
                    radius: *radius,
                    length: *length,
                },
                urdf_rs::Geometry::Capsule { radius, length } => Geometry::Capsule {
                    radius: *radius,
                    length: *length,
                },
                urdf_rs::Geometry::Sphere { radius } => Geometry::Sphere { radius: *radius },
                urdf_rs::Geometry::Mesh { filename, scale } => Geometry::Mesh {
                    filename: filename.clone(),
                    scale: scale.map(|s| s.0).unwrap_or([1.0; 3]),
                },
            };
            let p = pose(origin).map_err(|e| Error::Model(format!("link '{link}': {e}")))?;
            Ok(Shape {
                pose: link_to_frame * p,
                geometry,
                rgba,
            })
        })
        .collect()
}

/// Is this joint moving (revolute/continuous, not locked)? Errors for unsupported types.
fn is_moving(j: &urdf_rs::Joint, locked: &HashSet<&str>) -> Result<bool> {
    use urdf_rs::JointType as T;
    if locked.contains(j.name.as_str()) || j.joint_type == T::Fixed {
        return Ok(false);
    }
    if j.mimic.is_some() {
        return Err(Error::Model(format!(
            "joint '{}' mimics another joint; lock it with --lock {}",
            j.name, j.name
        )));
    }
    match j.joint_type {
        T::Revolute | T::Continuous => Ok(true),
        T::Floating | T::Planar => Err(Error::Model(format!(
            "joint '{}' is {:?}: floating or planar bases are not supported (fixed-base chains only)",
            j.name, j.joint_type
        ))),
        _ => Err(Error::Model(format!(
            "joint '{}' is {:?}; only revolute and continuous joints can move; lock it with --lock {}",
            j.name, j.joint_type, j.name
        ))),
    }
}

fn build(urdf: &urdf_rs::Robot, opts: &LoadOptions) -> Result<Robot> {
    let tree = Tree::index(urdf, opts)?;
    let walk = walk(&tree)?;
    let frames = mdh_frames(&walk)?;
    let merged = merge_bodies(&tree, &walk, &frames)?;
    let joints = joints(&walk, &frames)?;
    let mut bodies = merged.bodies;
    let base = bodies.remove(0);
    Robot::new(
        urdf.name.clone(),
        base,
        joints,
        bodies,
        merged.flange.pose,
        merged.flange.name,
    )
}

/// The URDF's links and joints indexed by name, checked to form one tree.
struct Tree<'a> {
    /// Links by name.
    links: HashMap<&'a str, &'a urdf_rs::Link>,
    /// The joints leaving each link.
    children: HashMap<&'a str, Vec<&'a urdf_rs::Joint>>,
    /// Joints locked at zero ([`LoadOptions::lock`]).
    locked: HashSet<&'a str>,
    /// The root link.
    root: &'a str,
}

impl<'a> Tree<'a> {
    /// Index the links and joints; refuse duplicates, unknown links, a link with two parents,
    /// an unknown locked joint, and anything but one root.
    fn index(urdf: &'a urdf_rs::Robot, opts: &'a LoadOptions) -> Result<Tree<'a>> {
        let mut links: HashMap<&str, &urdf_rs::Link> = HashMap::new();
        for l in &urdf.links {
            if links.insert(l.name.as_str(), l).is_some() {
                return Err(Error::Model(format!("link '{}' is defined twice", l.name)));
            }
        }
        let mut joint_names = HashSet::new();
        let mut parent_of: HashMap<&str, &urdf_rs::Joint> = HashMap::new();
        let mut children: HashMap<&str, Vec<&urdf_rs::Joint>> = HashMap::new();
        for j in &urdf.joints {
            if !joint_names.insert(j.name.as_str()) {
                return Err(Error::Model(format!("joint '{}' is defined twice", j.name)));
            }
            for end in [&j.parent.link, &j.child.link] {
                if !links.contains_key(end.as_str()) {
                    return Err(Error::Model(format!(
                        "joint '{}' refers to unknown link '{end}'",
                        j.name
                    )));
                }
            }
            if let Some(other) = parent_of.insert(j.child.link.as_str(), j) {
                return Err(Error::Model(format!(
                    "link '{}' has two parent joints ('{}' and '{}')",
                    j.child.link, other.name, j.name
                )));
            }
            children.entry(j.parent.link.as_str()).or_default().push(j);
        }
        let locked: HashSet<&str> = opts.lock.iter().map(String::as_str).collect();
        for name in &locked {
            if !joint_names.contains(name) {
                return Err(Error::Model(format!("--lock names unknown joint '{name}'")));
            }
        }
        let roots: Vec<&str> = urdf
            .links
            .iter()
            .map(|l| l.name.as_str())
            .filter(|n| !parent_of.contains_key(n))
            .collect();
        let root = match roots.as_slice() {
            [r] => *r,
            [] => return Err(Error::Model("the link tree has no root (cycle?)".into())),
            many => {
                return Err(Error::Model(format!(
                    "the URDF has {} root links ({}); a robot is one connected tree",
                    many.len(),
                    many.join(", ")
                )));
            }
        };

        Ok(Tree {
            links,
            children,
            locked,
            root,
        })
    }
}

/// A link reached in the walk at q = 0: its world pose and the body (0 = base) it belongs to.
struct Visit<'a> {
    link: &'a str,
    world: Isometry3<f64>,
    body: usize,
}

/// The tree walked at q = 0.
struct Walk<'a> {
    /// Every link, with its world pose and body.
    visits: Vec<Visit<'a>>,
    /// The moving joints from the base out.
    moving: Vec<&'a urdf_rs::Joint>,
    /// World pose of every moving joint's frame at q = 0.
    moving_joint_world: Vec<Isometry3<f64>>,
}

/// Walk the tree at q = 0 from the root; refuse a cycle, a branching chain of moving joints
/// and a robot without one.
fn walk<'a>(tree: &Tree<'a>) -> Result<Walk<'a>> {
    let (children, locked, root) = (&tree.children, &tree.locked, tree.root);
    let mut visits: Vec<Visit> = Vec::new();
    let mut moving: Vec<&urdf_rs::Joint> = Vec::new();
    let mut moving_joint_world: Vec<Isometry3<f64>> = Vec::new();
    let mut stack = vec![Visit {
        link: root,
        world: Isometry3::identity(),
        body: 0,
    }];
    let mut seen = HashSet::new();
    while let Some(v) = stack.pop() {
        if !seen.insert(v.link) {
            return Err(Error::Model(format!(
                "link '{}' is reached twice (cycle)",
                v.link
            )));
        }
        for j in children.get(v.link).map(Vec::as_slice).unwrap_or(&[]) {
            let origin =
                pose(&j.origin).map_err(|e| Error::Model(format!("joint '{}': {e}", j.name)))?;
            let world = v.world * origin;
            let body = if is_moving(j, locked)? {
                if moving.len() != v.body {
                    let sibling = moving[v.body].name.as_str();
                    return Err(Error::Model(format!(
                        "the chain branches: joints '{sibling}' and '{}' both move from the same body; only serial chains are supported (lock one branch with --lock)",
                        j.name
                    )));
                }
                moving.push(j);
                moving_joint_world.push(world);
                moving.len()
            } else {
                v.body
            };
            stack.push(Visit {
                link: j.child.link.as_str(),
                world,
                body,
            });
        }
        visits.push(v);
    }
    if moving.is_empty() {
        return Err(Error::Model(
            "the URDF has no revolute or continuous joint".into(),
        ));
    }

    Ok(Walk {
        visits,
        moving,
        moving_joint_world,
    })
}

/// The MDH link frames of the moving joints (base frame) from their axes at q = 0; refuse a
/// zero or invalid axis.
fn mdh_frames(walk: &Walk) -> Result<Vec<Isometry3<f64>>> {
    let (moving, moving_joint_world) = (&walk.moving, &walk.moving_joint_world);
    let mut axes = Vec::with_capacity(moving.len());
    for (j, w) in moving.iter().zip(moving_joint_world) {
        let a = Vector3::from(j.axis.xyz.0);
        if !a.iter().all(|v| v.is_finite()) || a.norm() < 1e-9 {
            return Err(Error::Model(format!(
                "joint '{}' has a zero or invalid <axis>",
                j.name
            )));
        }
        axes.push(AxisLine {
            point: Point3::from(w.translation.vector),
            dir: Unit::new_normalize(w.rotation * a),
        });
    }
    Ok(canonical_frames(&axes))
}

/// The MDH frame of body `body` (0 = base: the base frame).
fn frame_of(frames: &[Isometry3<f64>], body: usize) -> Isometry3<f64> {
    if body == 0 {
        Isometry3::identity()
    } else {
        frames[body - 1]
    }
}

/// The link that carries the flange frame, chosen as `tool0`, else `flange`, else the last
/// moving link.
struct Flange {
    /// Pose in the last body's MDH frame.
    pose: Isometry3<f64>,
    /// Link name.
    name: String,
}

/// The merged bodies (0 = base) and the flange.
struct Merged {
    bodies: Vec<Link>,
    flange: Flange,
}

/// The bodies (0 = base, then one per moving joint) before their links are merged: names,
/// the URDF frame in the body's MDH frame, no mass and no shapes.
fn empty_bodies(tree: &Tree, walk: &Walk, frames: &[Isometry3<f64>]) -> Vec<Link> {
    let moving = &walk.moving;
    (0..=moving.len())
        .map(|b| {
            let (name, joint_world) = if b == 0 {
                (tree.root, Isometry3::identity())
            } else {
                (
                    moving[b - 1].child.link.as_str(),
                    walk.moving_joint_world[b - 1],
                )
            };
            Link {
                name: name.to_string(),
                inertia: RigidInertia::zero(),
                urdf_pose: frame_of(frames, b).inverse() * joint_world,
                visuals: Vec::new(),
                collisions: Vec::new(),
            }
        })
        .collect()
}

/// Merge the links of every body, expressed in the body's MDH frame; refuse a moved link
/// without `<inertial>`.
fn merge_bodies(tree: &Tree, walk: &Walk, frames: &[Isometry3<f64>]) -> Result<Merged> {
    let links = &tree.links;
    let (visits, moving) = (&walk.visits, &walk.moving);
    let frame_of = |body: usize| frame_of(frames, body);
    let n = moving.len();
    let mut bodies = empty_bodies(tree, walk, frames);
    // The best flange candidate so far: rank (lower is better) and the flange.
    let mut flange: Option<(u8, Flange)> = None;
    for v in visits {
        let link = links[v.link];
        let to_frame = frame_of(v.body).inverse() * v.world;
        let inertia = link_inertia(link)?;
        if v.body > 0 && v.link == moving[v.body - 1].child.link && inertia.is_none() {
            return Err(Error::Model(format!(
                "link '{}' (moved by joint '{}') has no <inertial>",
                v.link,
                moving[v.body - 1].name
            )));
        }
        let b = &mut bodies[v.body];
        if let Some(i) = inertia {
            b.inertia = b.inertia.combined(&i.transformed(&to_frame));
        }
        let rgba = |vis: &urdf_rs::Visual| {
            vis.material
                .as_ref()
                .and_then(|m| m.color.as_ref())
                .map(|c| c.rgba.0.map(|x| x as f32))
        };
        b.visuals.extend(shapes(
            link.visual
                .iter()
                .map(|vis| (&vis.origin, &vis.geometry, rgba(vis))),
            &to_frame,
            v.link,
        )?);
        b.collisions.extend(shapes(
            link.collision
                .iter()
                .map(|c| (&c.origin, &c.geometry, None)),
            &to_frame,
            v.link,
        )?);
        if v.body == n {
            let rank = match v.link {
                "tool0" => 0,
                "flange" => 1,
                l if l == moving[n - 1].child.link => 2,
                _ => 3,
            };
            if rank < 3 && flange.as_ref().is_none_or(|(r, _)| rank < *r) {
                let candidate = Flange {
                    pose: to_frame,
                    name: link.name.clone(),
                };
                flange = Some((rank, candidate));
            }
        }
    }
    let (_, flange) = flange.expect("the last moving link is always visited");
    Ok(Merged { bodies, flange })
}

/// The moving joints with their MDH origins, limits and friction; refuse a revolute joint
/// without limits and a negative velocity limit.
fn joints(walk: &Walk, frames: &[Isometry3<f64>]) -> Result<Vec<Joint>> {
    let moving = &walk.moving;
    let n = moving.len();
    let frame_of = |body: usize| frame_of(frames, body);
    let mut joints = Vec::with_capacity(n);
    for (i, j) in moving.iter().enumerate() {
        let continuous = j.joint_type == urdf_rs::JointType::Continuous;
        let lim = &j.limit;
        let (lower, upper) = if continuous {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            if lim.lower == 0.0 && lim.upper == 0.0 {
                return Err(Error::Model(format!(
                    "revolute joint '{}' has no <limit lower upper> (use type=\"continuous\" for an unlimited joint)",
                    j.name
                )));
            }
            (lim.lower, lim.upper)
        };
        let velocity = if lim.velocity > 0.0 {
            lim.velocity
        } else if lim.velocity == 0.0 {
            f64::INFINITY
        } else {
            return Err(Error::Model(format!(
                "joint '{}' has a negative velocity limit",
                j.name
            )));
        };
        let dynamics = j.dynamics.clone().unwrap_or_default();
        joints.push(Joint {
            name: j.name.clone(),
            origin: frame_of(i).inverse() * frames[i],
            limits: JointLimits {
                lower,
                upper,
                velocity,
                effort: (lim.effort > 0.0).then_some(lim.effort),
            },
            friction: Friction {
                coulomb: dynamics.friction,
                viscous: dynamics.damping,
            },
        });
    }
    Ok(joints)
}
