//! Scene files: the virtual objects a rig touches, in its task frame (metres), read once for
//! every tool that renders them (docs/scenes.md): `hapticgen simulate --scene` and `hapticgen
//! connect --scene` on the host, and the firmware images whose `variants.txt` line names a
//! scene, for which [`emit`] writes the objects as Rust source (meshes as `static` arrays).
//!
//! ```yaml
//! objects:
//!   - half_space: {point: [0, 0, -0.05], normal: [0, 0, 1], stiffness: 800, damping: 2,
//!                  friction: {static: 0.4, dynamic: 0.3}}
//!   - sphere: {centre: [0.03, 0, -0.02], radius: 0.015, stiffness: 600, damping: 1}
//!   - box: {centre: [-0.03, 0, -0.04], half_extents: [0.01, 0.02, 0.01], stiffness: 700, damping: 2}
//!   - mesh: {file: meshes/knob.obj, offset: [0, 0.03, -0.04], stiffness: 500, damping: 1}
//! ```
//!
//! Each object is a map of one key, its kind: `sphere` (`cavity: true` keeps the point inside
//! instead), `box` (axis-aligned, or turned by `rotation`: `[angle]` in 2-D, `[roll, pitch,
//! yaw]` in 3-D), `half_space` (behind the plane; the normal points to free
//! space and is normalised here), `polytope` (`planes`: a list of `{point, normal}`, the solid
//! behind every one), `capsule` and `cylinder` (`a`, `b`: the axis's ends, the
//! cylinder's cap centres; `radius`) or `mesh` (a closed triangle mesh from an OBJ or STL file,
//! named relative to the scene file, placed at `offset`; 3-D tasks only). Every object has a
//! surface `stiffness` (N/m) and `damping` (N·s/m), and optionally `friction` with `static`
//! and `dynamic` coefficients (0 ≤ dynamic ≤ static), and optionally `motion` (`velocity`,
//! `angular_velocity` and the `pivot` it turns about: [`SceneMotion`]; the simulator moves it,
//! firmware images refuse it). A file may name one free-space `effect` (`spring: {anchor,
//! stiffness}`, `viscous: {damping}`, `force: {force}` or `vibration: {direction, amplitude,
//! frequency}`: `hapticgen_runtime::effects`), which the simulator and the firmware images render.
//! Vectors hold one coordinate per task axis ([`Scene::check_task_dim`]). Every error names the
//! file, line and column of the value.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;
use serde::Deserialize;

use crate::mesh::TriangleMesh;
use crate::model::positions::{display_path, PositionIndex, Segment};
use crate::Scalar;

/// A scene file's objects.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The objects, in the file's order.
    pub objects: Vec<SceneObject>,
    /// What the operator feels away from every object (`hapticgen_runtime::effects`), if the
    /// file names an effect.
    pub effect: Option<SceneEffect>,
}

/// A free-space effect (`hapticgen_runtime::effects::Effect`), in task coordinates.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneEffect {
    /// A spring pulling towards `anchor`, N/m.
    Spring {
        /// The point it pulls towards.
        anchor: Vec<f64>,
        /// Stiffness, N/m.
        stiffness: f64,
    },
    /// A viscous field, N·s/m.
    Viscous {
        /// Damping, N·s/m.
        damping: f64,
    },
    /// A constant force, N.
    Force {
        /// The force.
        force: Vec<f64>,
    },
    /// A sinusoidal force along a unit direction.
    Vibration {
        /// Unit direction (normalised when read).
        direction: Vec<f64>,
        /// Amplitude, N.
        amplitude: f64,
        /// Frequency, Hz.
        frequency: f64,
    },
}

/// The geometry of an object, in task coordinates.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneShape {
    /// The half-space behind the plane through `point` with outward `normal`.
    HalfSpace {
        /// A point of the plane.
        point: Vec<f64>,
        /// The outward normal (towards free space).
        normal: Vec<f64>,
    },
    /// A ball.
    Sphere {
        /// Centre.
        center: Vec<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// A box, turned by the entry's `rotation` (axis-aligned without one).
    Box {
        /// Centre.
        center: Vec<f64>,
        /// The box's axes in task coordinates, one unit row per axis (orthonormal; the
        /// identity for an axis-aligned box).
        axes: Vec<Vec<f64>>,
        /// Half the edge lengths along its axes, m.
        half_extents: Vec<f64>,
    },
    /// The points within `radius` of the segment `ab`.
    Capsule {
        /// One end of the axis.
        a: Vec<f64>,
        /// The other end.
        b: Vec<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// The points within `radius` of the line `ab` between the planes through `a` and `b`
    /// perpendicular to it (flat caps).
    Cylinder {
        /// Centre of one cap.
        a: Vec<f64>,
        /// Centre of the other.
        b: Vec<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// The convex polytope inside every plane, `{x : n_i · x ≤ d_i}`.
    Polytope {
        /// The bounding planes.
        planes: Vec<ScenePlane>,
    },
    /// A closed triangle mesh (with its BVH) placed at `offset`; 3-D tasks only.
    Mesh {
        /// The mesh in its own frame, BVH built.
        mesh: Arc<TriangleMesh>,
        /// Where the mesh's origin is.
        offset: Vec<f64>,
    },
}

/// One bounding plane of a polytope: `n · x = d`, the polytope behind it (`n · x ≤ d`).
#[derive(Clone, Debug, PartialEq)]
pub struct ScenePlane {
    /// Unit outward normal `n`.
    pub normal: Vec<f64>,
    /// Offset `d`, m.
    pub offset: f64,
}

impl SceneShape {
    /// The number of coordinates of the shape's vectors (a mesh's offset's).
    pub fn dimension(&self) -> usize {
        match self {
            SceneShape::HalfSpace { point, .. } => point.len(),
            SceneShape::Sphere { center, .. } | SceneShape::Box { center, .. } => center.len(),
            SceneShape::Capsule { a, .. } | SceneShape::Cylinder { a, .. } => a.len(),
            SceneShape::Polytope { planes } => planes.first().map_or(0, |plane| plane.normal.len()),
            SceneShape::Mesh { offset, .. } => offset.len(),
        }
    }

    /// An axis-aligned box.
    pub fn axis_aligned_box(center: Vec<f64>, half_extents: Vec<f64>) -> Self {
        let dim = center.len();
        let axes = (0..dim).map(|i| (0..dim).map(|k| f64::from(u8::from(i == k))).collect()).collect();
        SceneShape::Box { center, axes, half_extents }
    }

    /// `true` unless the shape is a box turned off the task axes.
    pub fn is_axis_aligned(&self) -> bool {
        match self {
            SceneShape::Box { axes, .. } => axes
                .iter()
                .enumerate()
                .all(|(i, axis)| axis.iter().enumerate().all(|(k, &a)| a == f64::from(u8::from(i == k)))),
            _ => true,
        }
    }

    /// How deep `p` is inside the shape, m: positive inside, negative outside (minus the
    /// distance to the surface); `None` for a mesh. Closed forms written from the shapes'
    /// definitions, apart from the runtime's closest-point code, so that the host's simulator
    /// and the firmware's physics tests can check the renderer against them.
    pub fn depth(&self, p: &[f64]) -> Option<f64> {
        Some(match self {
            SceneShape::HalfSpace { point, normal } => {
                -dot(&difference(p, point), normal) / dot(normal, normal).sqrt()
            }
            SceneShape::Sphere { center, radius } => radius - distance(p, center),
            SceneShape::Box { center, axes, half_extents } => {
                // In the box's axes; inside: the nearest face; outside: the distance to the box,
                // through its edges and corners (the gaps beyond each face make the offset).
                let offset = difference(p, center);
                let gaps: Vec<f64> =
                    axes.iter().zip(half_extents).map(|(axis, h)| h - dot(&offset, axis).abs()).collect();
                if gaps.iter().all(|&gap| gap > 0.0) {
                    gaps.iter().copied().fold(f64::INFINITY, f64::min)
                } else {
                    -gaps.iter().map(|gap| gap.min(0.0).powi(2)).sum::<f64>().sqrt()
                }
            }
            SceneShape::Capsule { a, b, radius } => {
                let (along, across) = axial_and_radial(p, a, b);
                let beyond_ends = if along < 0.0 { -along } else { (along - distance(a, b)).max(0.0) };
                radius - across.hypot(beyond_ends)
            }
            SceneShape::Cylinder { a, b, radius } => {
                let (along, across) = axial_and_radial(p, a, b);
                let length = distance(a, b);
                if along > 0.0 && along < length && across < *radius {
                    (radius - across).min(along).min(length - along)
                } else {
                    let beyond_side = (across - radius).max(0.0);
                    let beyond_caps = (-along).max(along - length).max(0.0);
                    -beyond_side.hypot(beyond_caps)
                }
            }
            // Inside: the nearest plane; outside: the farthest plane's distance, a lower bound
            // of the distance (the distance itself is a projection onto the polytope).
            SceneShape::Polytope { planes } => {
                let beyond = planes.iter().map(|plane| dot(p, &plane.normal) - plane.offset);
                -beyond.fold(f64::NEG_INFINITY, f64::max)
            }
            SceneShape::Mesh { .. } => return None,
        })
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

fn difference(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(a, b)| a - b).collect()
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    let offset = difference(a, b);
    dot(&offset, &offset).sqrt()
}

/// `p`'s coordinate along the axis from `a` towards `b` (0 at `a`), and its distance from the
/// axis's line.
fn axial_and_radial(p: &[f64], a: &[f64], b: &[f64]) -> (f64, f64) {
    let offset = difference(p, a);
    let along = dot(&offset, &difference(b, a)) / distance(a, b);
    (along, (dot(&offset, &offset) - along * along).max(0.0).sqrt())
}

/// One object of a scene file: its shape, its surface, and where it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneObject {
    /// Geometry.
    pub shape: SceneShape,
    /// `true`: a cavity, which keeps the point inside the shape instead of outside.
    pub cavity: bool,
    /// Surface stiffness, N/m.
    pub stiffness: f64,
    /// Surface damping, N·s/m.
    pub damping: f64,
    /// Static friction coefficient (0: none).
    pub static_friction: f64,
    /// Dynamic friction coefficient, at most the static one.
    pub dynamic_friction: f64,
    /// How it moves, if it does (the shape is its pose at time 0).
    pub motion: Option<SceneMotion>,
    /// Where it is written, for errors about it later (`FILE:LINE:COLUMN: objects[K].KIND`).
    pub location: String,
}

impl SceneObject {
    /// How deep `p` is in the object, m, positive where the object pushes the point out: inside
    /// a solid, or beyond a cavity's wall ([`SceneShape::depth`], negated for a cavity); `None`
    /// for a mesh. A moving object is taken where it is at time 0.
    pub fn depth(&self, p: &[f64]) -> Option<f64> {
        self.shape.depth(p).map(|depth| if self.cavity { -depth } else { depth })
    }
}

/// How a scene object moves: it turns at the constant `angular_velocity` about `pivot` while
/// the pivot moves at the constant `velocity`, so that at time `t` a point `x` of the object
/// (where it is at time 0) is at `P(t) x = R(ω t) (x − c) + c + v t`.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneMotion {
    /// `v`, m/s; one coordinate per task axis.
    pub velocity: Vec<f64>,
    /// `ω`, rad/s: `[ω]` in a 2-D task (counter-clockwise), `[ω_x, ω_y, ω_z]` in 3-D (about
    /// that axis, right-handed, by its length).
    pub angular_velocity: Vec<f64>,
    /// `c`, the point it turns about at time 0, m.
    pub pivot: Vec<f64>,
}

impl SceneMotion {
    /// The rotation `R(ω t)`, by rows, in a `dim`-dimensional task (2 or 3; the identity for
    /// any other or for no turn).
    pub fn rotation_at(&self, time: f64, dim: usize) -> Vec<Vec<f64>> {
        let identity: Vec<Vec<f64>> =
            (0..dim).map(|i| (0..dim).map(|k| f64::from(u8::from(i == k))).collect()).collect();
        match (dim, self.angular_velocity.as_slice()) {
            (2, &[rate]) => {
                let (sin, cos) = (rate * time).sin_cos();
                vec![vec![cos, -sin], vec![sin, cos]]
            }
            (3, &[wx, wy, wz]) => {
                let rate = (wx * wx + wy * wy + wz * wz).sqrt();
                if rate == 0.0 {
                    return identity;
                }
                // Rodrigues: R = I + sin θ [u]× + (1 − cos θ) [u]×², θ = |ω| t, u = ω/|ω|.
                let (x, y, z) = (wx / rate, wy / rate, wz / rate);
                let (sin, cos) = (rate * time).sin_cos();
                let one_minus_cos = 1.0 - cos;
                vec![
                    vec![
                        cos + x * x * one_minus_cos,
                        x * y * one_minus_cos - z * sin,
                        x * z * one_minus_cos + y * sin,
                    ],
                    vec![
                        y * x * one_minus_cos + z * sin,
                        cos + y * y * one_minus_cos,
                        y * z * one_minus_cos - x * sin,
                    ],
                    vec![
                        z * x * one_minus_cos - y * sin,
                        z * y * one_minus_cos + x * sin,
                        cos + z * z * one_minus_cos,
                    ],
                ]
            }
            _ => identity,
        }
    }

    /// Where the pivot is at `time`: `c + v t`.
    pub fn pivot_at(&self, time: f64) -> Vec<f64> {
        self.pivot.iter().zip(&self.velocity).map(|(c, v)| c + v * time).collect()
    }

    /// Where the point `x` of the object (as it is at time 0) is at `time`: `P(t) x =
    /// R(ω t) (x − c) + c + v t`.
    pub fn carried(&self, time: f64, x: &[f64]) -> Vec<f64> {
        let offset = difference(x, &self.pivot);
        let turned = self.turned(time, &offset);
        turned.iter().zip(self.pivot_at(time)).map(|(o, c)| o + c).collect()
    }

    /// A direction of the object (as it is at time 0), such as a face's normal, at `time`:
    /// `R(ω t) n`.
    pub fn turned(&self, time: f64, n: &[f64]) -> Vec<f64> {
        let rotation = self.rotation_at(time, n.len());
        rotation.iter().map(|row| row.iter().zip(n).map(|(r, v)| r * v).sum()).collect()
    }

    /// Whether the object turns (a non-zero angular velocity).
    pub fn turns(&self) -> bool {
        self.angular_velocity.iter().any(|w| *w != 0.0)
    }

    /// The point of the object (as it is at time 0) that is at `p` at `time`: `P(t)⁻¹ p =
    /// R(ω t)ᵀ (p − c − v t) + c`. Depths and inside tests of the moving object at `time` are the
    /// unmoved object's at this point (a rigid motion keeps distances).
    pub fn carried_back(&self, time: f64, p: &[f64]) -> Vec<f64> {
        let rotation = self.rotation_at(time, p.len());
        let offset = difference(p, &self.pivot_at(time));
        (0..p.len())
            .map(|k| rotation.iter().zip(&offset).map(|(row, o)| row[k] * o).sum::<f64>() + self.pivot[k])
            .collect()
    }
}

impl Scene {
    /// Checks that every vector has `task_dim` coordinates (a mesh needs 3); the error names
    /// the object in the file.
    pub fn check_task_dim(&self, task_dim: usize) -> Result<(), String> {
        for object in &self.objects {
            let lengths: Vec<(&str, usize)> = match &object.shape {
                SceneShape::HalfSpace { point, normal } => {
                    vec![("point", point.len()), ("normal", normal.len())]
                }
                SceneShape::Sphere { center, .. } => vec![("centre", center.len())],
                SceneShape::Box { center, half_extents, .. } => {
                    vec![("centre", center.len()), ("half_extents", half_extents.len())]
                }
                SceneShape::Capsule { a, b, .. } | SceneShape::Cylinder { a, b, .. } => {
                    vec![("a", a.len()), ("b", b.len())]
                }
                SceneShape::Polytope { planes } => {
                    planes.iter().map(|plane| ("a plane's normal", plane.normal.len())).collect()
                }
                SceneShape::Mesh { offset, .. } => vec![("offset", offset.len()), ("the mesh's vertices", 3)],
            };
            if let Some((field, n)) = lengths.into_iter().find(|&(_, n)| n != task_dim) {
                return Err(format!(
                    "error: {}: {field} has {n} coordinates; this rig's task has {task_dim}",
                    object.location
                ));
            }
            if let Some(motion) = &object.motion {
                let turn_rates = match task_dim {
                    2 => 1,
                    3 => 3,
                    _ => 0,
                };
                let lengths = [
                    ("motion.velocity", motion.velocity.len(), task_dim),
                    ("motion.pivot", motion.pivot.len(), task_dim),
                    ("motion.angular_velocity", motion.angular_velocity.len(), turn_rates),
                ];
                if let Some((field, n, expected)) =
                    lengths.into_iter().find(|&(_, n, expected)| n != expected)
                {
                    return Err(format!(
                        "error: {}: {field} has {n} values; a {task_dim}-D task needs {expected}",
                        object.location
                    ));
                }
            }
        }
        let effect_lengths: Vec<(&str, usize)> = match &self.effect {
            Some(SceneEffect::Spring { anchor, .. }) => vec![("spring.anchor", anchor.len())],
            Some(SceneEffect::Force { force }) => vec![("force.force", force.len())],
            Some(SceneEffect::Vibration { direction, .. }) => vec![("vibration.direction", direction.len())],
            Some(SceneEffect::Viscous { .. }) | None => Vec::new(),
        };
        if let Some((field, n)) = effect_lengths.into_iter().find(|&(_, n)| n != task_dim) {
            return Err(format!(
                "error: the scene's effect: {field} has {n} coordinates; this rig's task has {task_dim}"
            ));
        }
        Ok(())
    }
}

/// Leaf size of a scene mesh's BVH (triangles per leaf).
const MESH_LEAF_SIZE: usize = 4;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    // `- sphere: {…}`: each object a map of one key, its kind (serde_yaml's default for an
    // enum is a YAML tag, `!sphere`).
    #[serde(with = "serde_yaml::with::singleton_map_recursive")]
    objects: Vec<ObjectEntry>,
    #[serde(default, with = "serde_yaml::with::singleton_map_recursive")]
    effect: Option<EffectEntry>,
}

#[derive(Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
enum EffectEntry {
    Spring { anchor: Vec<f64>, stiffness: f64 },
    Viscous { damping: f64 },
    Force { force: Vec<f64> },
    Vibration { direction: Vec<f64>, amplitude: f64, frequency: f64 },
}

#[derive(Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
enum ObjectEntry {
    Sphere {
        centre: Vec<f64>,
        radius: f64,
        #[serde(default)]
        cavity: bool,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
        #[serde(default)]
        motion: Option<MotionEntry>,
    },
    Box {
        centre: Vec<f64>,
        half_extents: Vec<f64>,
        #[serde(default)]
        rotation: Option<Vec<f64>>,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
        #[serde(default)]
        motion: Option<MotionEntry>,
    },
    HalfSpace {
        point: Vec<f64>,
        normal: Vec<f64>,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
        #[serde(default)]
        motion: Option<MotionEntry>,
    },
    Capsule {
        a: Vec<f64>,
        b: Vec<f64>,
        radius: f64,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
        #[serde(default)]
        motion: Option<MotionEntry>,
    },
    Cylinder {
        a: Vec<f64>,
        b: Vec<f64>,
        radius: f64,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
        #[serde(default)]
        motion: Option<MotionEntry>,
    },
    Polytope {
        planes: Vec<PlaneEntry>,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
        #[serde(default)]
        motion: Option<MotionEntry>,
    },
    Mesh {
        file: PathBuf,
        #[serde(default)]
        offset: Option<Vec<f64>>,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
        #[serde(default)]
        motion: Option<MotionEntry>,
    },
}

impl ObjectEntry {
    fn kind(&self) -> &'static str {
        match self {
            ObjectEntry::Sphere { .. } => "sphere",
            ObjectEntry::Box { .. } => "box",
            ObjectEntry::HalfSpace { .. } => "half_space",
            ObjectEntry::Capsule { .. } => "capsule",
            ObjectEntry::Cylinder { .. } => "cylinder",
            ObjectEntry::Polytope { .. } => "polytope",
            ObjectEntry::Mesh { .. } => "mesh",
        }
    }

    /// Stiffness, damping, friction and motion, which every kind has (not `#[serde(flatten)]`ed
    /// into a struct of their own: serde cannot refuse unknown keys through a flattened field).
    fn surface(&self) -> (f64, f64, Option<&FrictionEntry>, Option<&MotionEntry>) {
        match self {
            ObjectEntry::Sphere { stiffness, damping, friction, motion, .. }
            | ObjectEntry::Box { stiffness, damping, friction, motion, .. }
            | ObjectEntry::HalfSpace { stiffness, damping, friction, motion, .. }
            | ObjectEntry::Capsule { stiffness, damping, friction, motion, .. }
            | ObjectEntry::Cylinder { stiffness, damping, friction, motion, .. }
            | ObjectEntry::Polytope { stiffness, damping, friction, motion, .. }
            | ObjectEntry::Mesh { stiffness, damping, friction, motion, .. } => {
                (*stiffness, *damping, friction.as_ref(), motion.as_ref())
            }
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MotionEntry {
    #[serde(default)]
    velocity: Option<Vec<f64>>,
    #[serde(default)]
    angular_velocity: Option<Vec<f64>>,
    #[serde(default)]
    pivot: Option<Vec<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PlaneEntry {
    point: Vec<f64>,
    normal: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FrictionEntry {
    #[serde(rename = "static")]
    static_coefficient: f64,
    #[serde(rename = "dynamic")]
    dynamic_coefficient: f64,
}

/// The most coordinates a scene's vector may have.
const MAX_COORDINATES: usize = 3;

/// A vector of 1 to [`MAX_COORDINATES`] finite coordinates, or what is wrong with it.
fn checked_vector(values: &[f64]) -> Result<Vec<f64>, String> {
    if values.is_empty() || values.len() > MAX_COORDINATES || values.iter().any(|v| !v.is_finite()) {
        return Err(format!("must be 1 to {MAX_COORDINATES} finite coordinates, got {values:?}"));
    }
    Ok(values.to_vec())
}

/// The unit vector along 1 to [`MAX_COORDINATES`] finite coordinates that are not all (nearly)
/// zero, or what is wrong with them.
fn checked_direction(values: &[f64]) -> Result<Vec<f64>, String> {
    let vector = checked_vector(values)?;
    let length = vector.iter().map(|v| v * v).sum::<f64>().sqrt();
    if length.is_nan() || length < 1e-9 {
        return Err(format!("must not be zero, got {values:?}"));
    }
    Ok(vector.iter().map(|v| v / length).collect())
}

/// A finite value not below zero, or what is wrong with it.
fn checked_non_negative(value: f64) -> Result<f64, String> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(format!("must be finite and not negative, got {value}"))
    }
}

/// A scene file's `effect`, checked; `error(field, message)` names the value.
fn effect(entry: &EffectEntry, error: &dyn Fn(&str, String) -> String) -> Result<SceneEffect, String> {
    let vector =
        |field: &str, values: &[f64]| checked_vector(values).map_err(|message| error(field, message));
    let non_negative =
        |field: &str, value: f64| checked_non_negative(value).map_err(|message| error(field, message));
    Ok(match entry {
        EffectEntry::Spring { anchor, stiffness } => SceneEffect::Spring {
            anchor: vector("spring.anchor", anchor)?,
            stiffness: non_negative("spring.stiffness", *stiffness)?,
        },
        EffectEntry::Viscous { damping } => {
            SceneEffect::Viscous { damping: non_negative("viscous.damping", *damping)? }
        }
        EffectEntry::Force { force } => SceneEffect::Force { force: vector("force.force", force)? },
        EffectEntry::Vibration { direction, amplitude, frequency } => {
            let direction =
                checked_direction(direction).map_err(|message| error("vibration.direction", message))?;
            SceneEffect::Vibration {
                direction,
                amplitude: non_negative("vibration.amplitude", *amplitude)?,
                frequency: non_negative("vibration.frequency", *frequency)?,
            }
        }
    })
}

/// A box's axes (unit rows) from its entry's `rotation`: none, the identity; in 2-D `[angle]`
/// (rad, about the normal of the plane); in 3-D `[roll, pitch, yaw]` (rad, about the fixed x,
/// y, z axes in that order, as URDF and the model's `rpy`): row `i` is the rotated `e_i`.
fn box_axes(dim: usize, rotation: Option<&[f64]>) -> Result<Vec<Vec<f64>>, String> {
    match (dim, rotation) {
        (_, None) => match SceneShape::axis_aligned_box(vec![0.0; dim], vec![1.0; dim]) {
            SceneShape::Box { axes, .. } => Ok(axes),
            _ => Ok(Vec::new()),
        },
        (_, Some(angles)) if angles.iter().any(|a| !a.is_finite()) => {
            Err(format!("must be finite angles, got {angles:?}"))
        }
        (2, Some(&[angle])) => {
            let (sin, cos) = angle.sin_cos();
            Ok(vec![vec![cos, sin], vec![-sin, cos]])
        }
        (3, Some(&[roll, pitch, yaw])) => {
            let r = crate::math::rotation::rotation_rpy([roll, pitch, yaw]);
            Ok((0..3).map(|i| (0..3).map(|k| r[k][i]).collect()).collect())
        }
        (2, Some(angles)) => {
            Err(format!("a 2-D box turns by one angle, `[angle]`; got {} values", angles.len()))
        }
        (3, Some(angles)) => {
            Err(format!("a 3-D box turns by `[roll, pitch, yaw]`; got {} values", angles.len()))
        }
        (_, Some(_)) => Err(format!("a {dim}-D box cannot turn")),
    }
}

/// Reads a scene file (module docs); meshes are read relative to its directory.
pub fn load(path: &Path) -> Result<Scene, String> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("error: cannot read the scene file {name}: {e}"))?;
    parse(&name, &text, path.parent().unwrap_or_else(|| Path::new(".")))
}

/// [`load`] of `text`, named `name` in the errors, its meshes read relative to `directory`.
pub fn parse(name: &str, text: &str, directory: &Path) -> Result<Scene, String> {
    let file: SceneFile = serde_yaml::from_str(text).map_err(|e| match e.location() {
        Some(at) => {
            format!(
                "error: {name}:{}:{}: {}",
                at.line(),
                at.column(),
                crate::diag::strip_location(&e.to_string())
            )
        }
        None => format!("error: {name}: {e}"),
    })?;
    let positions = PositionIndex::build(text);
    let located = |path: &[Segment]| {
        let (line, column) = positions.value(path);
        format!("{name}:{line}:{column}: {}", display_path(path))
    };
    let mut objects = Vec::with_capacity(file.objects.len());
    for (index, entry) in file.objects.iter().enumerate() {
        let kind = entry.kind();
        let at = |field: &str| {
            let mut path =
                vec![Segment::Key("objects".into()), Segment::Index(index), Segment::Key(kind.into())];
            path.extend(field.split('.').map(|key| Segment::Key(key.into())));
            path
        };
        let error = |field: &str, message: String| format!("error: {}: {message}", located(&at(field)));
        let vector =
            |field: &str, values: &[f64]| checked_vector(values).map_err(|message| error(field, message));
        let non_negative =
            |field: &str, value: f64| checked_non_negative(value).map_err(|message| error(field, message));
        let positive = |field: &str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(value)
            } else {
                Err(error(field, format!("must be finite and positive, got {value}")))
            }
        };
        let (shape, cavity) = match entry {
            ObjectEntry::Sphere { centre, radius, cavity, .. } => (
                SceneShape::Sphere {
                    center: vector("centre", centre)?,
                    radius: positive("radius", *radius)?,
                },
                *cavity,
            ),
            ObjectEntry::Box { centre, half_extents, rotation, .. } => {
                let half = vector("half_extents", half_extents)?;
                if half.iter().any(|h| *h <= 0.0) {
                    return Err(error("half_extents", format!("must be positive, got {half_extents:?}")));
                }
                let center = vector("centre", centre)?;
                let axes = box_axes(center.len(), rotation.as_deref())
                    .map_err(|message| error("rotation", message))?;
                (SceneShape::Box { center, axes, half_extents: half }, false)
            }
            ObjectEntry::HalfSpace { point, normal, .. } => {
                let normal = checked_direction(normal).map_err(|message| error("normal", message))?;
                (SceneShape::HalfSpace { point: vector("point", point)?, normal }, false)
            }
            ObjectEntry::Capsule { a, b, radius, .. } | ObjectEntry::Cylinder { a, b, radius, .. } => {
                let (a, b, radius) = (vector("a", a)?, vector("b", b)?, positive("radius", *radius)?);
                if a.len() == b.len() && a.iter().zip(&b).all(|(x, y)| x == y) {
                    return Err(error("b", format!("must differ from `a`, got {b:?}")));
                }
                let shape = if matches!(entry, ObjectEntry::Capsule { .. }) {
                    SceneShape::Capsule { a, b, radius }
                } else {
                    SceneShape::Cylinder { a, b, radius }
                };
                (shape, false)
            }
            ObjectEntry::Polytope { planes, .. } => {
                if planes.is_empty() {
                    return Err(error("planes", "a polytope needs at least one plane".to_string()));
                }
                let mut bounding = Vec::with_capacity(planes.len());
                for (k, plane) in planes.iter().enumerate() {
                    // `objects[i].polytope.planes[k].normal`.
                    let plane_error = |key: &str, message: String| {
                        let mut path = at("planes");
                        path.extend([Segment::Index(k), Segment::Key(key.into())]);
                        format!("error: {}: {message}", located(&path))
                    };
                    let normal =
                        checked_direction(&plane.normal).map_err(|message| plane_error("normal", message))?;
                    let point =
                        checked_vector(&plane.point).map_err(|message| plane_error("point", message))?;
                    if point.len() != normal.len() {
                        let message = format!("has {} coordinates, its point {}", normal.len(), point.len());
                        return Err(plane_error("normal", message));
                    }
                    bounding.push(ScenePlane { offset: dot(&normal, &point), normal });
                }
                (SceneShape::Polytope { planes: bounding }, false)
            }
            ObjectEntry::Mesh { file, offset, .. } => {
                let path = directory.join(file);
                let mesh = crate::mesh::load(&path)
                    .map_err(|e| error("file", format!("{}: {e}", path.display())))?
                    .with_bvh(MESH_LEAF_SIZE);
                let offset = match offset {
                    Some(offset) => vector("offset", offset)?,
                    None => vec![0.0; 3],
                };
                (SceneShape::Mesh { mesh: Arc::new(mesh), offset }, false)
            }
        };
        let (stiffness, damping, friction, motion) = entry.surface();
        let motion = match motion {
            None => None,
            Some(motion) => {
                // Absent rates are zero, in the object's own dimension (a mesh's is 3).
                let dim = match &shape {
                    SceneShape::Mesh { .. } => 3,
                    other => other.dimension(),
                };
                let zeros = |n: usize| vec![0.0; n];
                let velocity = match &motion.velocity {
                    Some(values) => vector("motion.velocity", values)?,
                    None => zeros(dim),
                };
                let angular_velocity = match &motion.angular_velocity {
                    Some(values) => vector("motion.angular_velocity", values)?,
                    None => zeros(if dim == 2 { 1 } else { 3 }),
                };
                let turns = angular_velocity.iter().any(|w| *w != 0.0);
                let pivot = match (&motion.pivot, turns) {
                    (Some(values), _) => vector("motion.pivot", values)?,
                    (None, false) => zeros(dim),
                    (None, true) => {
                        return Err(error(
                            "motion",
                            "a turning object needs `pivot`, the point it turns about".to_string(),
                        ))
                    }
                };
                Some(SceneMotion { velocity, angular_velocity, pivot })
            }
        };
        let (static_friction, dynamic_friction) = match friction {
            None => (0.0, 0.0),
            Some(friction) => {
                let static_friction = non_negative("friction.static", friction.static_coefficient)?;
                let dynamic_friction = non_negative("friction.dynamic", friction.dynamic_coefficient)?;
                if dynamic_friction > static_friction {
                    return Err(error(
                        "friction.dynamic",
                        format!("must not exceed the static coefficient {static_friction}, got {dynamic_friction}"),
                    ));
                }
                (static_friction, dynamic_friction)
            }
        };
        let location =
            located(&[Segment::Key("objects".into()), Segment::Index(index), Segment::Key(kind.into())]);
        objects.push(SceneObject {
            shape,
            cavity,
            stiffness: non_negative("stiffness", stiffness)?,
            damping: non_negative("damping", damping)?,
            static_friction,
            dynamic_friction,
            motion,
            location,
        });
    }
    let effect = match &file.effect {
        None => None,
        Some(entry) => Some(effect(entry, &|field: &str, message: String| {
            let mut path = vec![Segment::Key("effect".into())];
            path.extend(field.split('.').map(|key| Segment::Key(key.into())));
            format!("error: {}: {message}", located(&path))
        })?),
    };
    Ok(Scene { objects, effect })
}

/// Rust source (formatted) of a scene for a `task_dim`-dimensional rig in `scalar`: a module
/// body with `pub const OBJECTS: usize`, the meshes as `static` arrays (`MESH_0`, …, in flash
/// on a target; [`crate::mesh::emit`]), `pub fn objects() -> [Object<'static, S, M>; OBJECTS]`,
/// the runtime's objects, `pub fn motions() -> [Option<ObjectMotion<S, M>>; OBJECTS]`, how each
/// moves, and `pub fn effect(impedance_period: S) -> Effect<S, M>`, the free-space effect
/// (`Effect::None` when the file names none).
pub fn emit(scene: &Scene, task_dim: usize, scalar: Scalar) -> Result<String, String> {
    scene.check_task_dim(task_dim)?;
    let ty = match scalar {
        Scalar::F32 => quote!(f32),
        Scalar::F64 => quote!(f64),
    };
    let number = |x: f64| match scalar {
        Scalar::F32 => Literal::f32_unsuffixed(x as f32),
        Scalar::F64 => Literal::f64_unsuffixed(x),
    };
    let vector = |values: &[f64]| {
        let values = values.iter().map(|&x| number(x));
        quote!([#(#values),*])
    };
    let shape = quote!(::hapticgen_runtime::shape::Shape);
    let mut meshes = String::new();
    let mut mesh_count = 0;
    let mut polytopes: Vec<TokenStream> = Vec::new();
    let mut objects: Vec<TokenStream> = Vec::new();
    let mut motions: Vec<TokenStream> = Vec::new();
    // A motion's vectors padded with zeros: `velocity` and `pivot` to the task's dimension,
    // `angular_velocity` to three (the runtime's `ObjectMotion`; a 2-D turn is its first).
    let padded = |values: &[f64], length: usize| {
        let values: Vec<f64> = (0..length).map(|k| values.get(k).copied().unwrap_or(0.0)).collect();
        vector(&values)
    };
    for object in &scene.objects {
        motions.push(match &object.motion {
            None => quote!(None),
            Some(motion) => {
                let velocity = padded(&motion.velocity, task_dim);
                let angular_velocity = padded(&motion.angular_velocity, 3);
                let pivot = padded(&motion.pivot, task_dim);
                quote!(Some(::hapticgen_runtime::motion::ObjectMotion {
                    velocity: #velocity,
                    angular_velocity: #angular_velocity,
                    pivot: #pivot,
                }))
            }
        });
        let geometry = match &object.shape {
            SceneShape::HalfSpace { point, normal } => {
                // The normal was normalised when the file was read.
                let (point, normal) = (vector(point), vector(normal));
                quote!(#shape::HalfSpace { point: #point, normal: #normal })
            }
            SceneShape::Sphere { center, radius } => {
                let (center, radius) = (vector(center), number(*radius));
                quote!(#shape::Sphere { center: #center, radius: #radius })
            }
            SceneShape::Box { center, axes, half_extents } => {
                let (center, half_extents) = (vector(center), vector(half_extents));
                let axes: Vec<TokenStream> = axes.iter().map(|axis| vector(axis)).collect();
                quote!(#shape::Box { center: #center, axes: [#(#axes),*], half_extents: #half_extents })
            }
            SceneShape::Capsule { a, b, radius } => {
                let (a, b, radius) = (vector(a), vector(b), number(*radius));
                quote!(#shape::Capsule { a: #a, b: #b, radius: #radius })
            }
            SceneShape::Cylinder { a, b, radius } => {
                let (a, b, radius) = (vector(a), vector(b), number(*radius));
                quote!(#shape::Cylinder { a: #a, b: #b, radius: #radius })
            }
            SceneShape::Polytope { planes } => {
                let name = Ident::new(&format!("POLYTOPE_{}", polytopes.len()), Span::call_site());
                let count = Literal::usize_unsuffixed(planes.len());
                let m = Literal::usize_unsuffixed(task_dim);
                let entries = planes.iter().map(|plane| {
                    let (normal, offset) = (vector(&plane.normal), number(plane.offset));
                    quote!(::hapticgen_runtime::shape::Plane { normal: #normal, offset: #offset })
                });
                polytopes.push(quote! {
                    static #name: [::hapticgen_runtime::shape::Plane<#ty, #m>; #count] = [#(#entries),*];
                });
                quote!(#shape::Polytope { planes: &#name })
            }
            SceneShape::Mesh { mesh, offset } => {
                let name = format!("MESH_{mesh_count}");
                mesh_count += 1;
                meshes.push_str(&crate::mesh::emit(mesh, &name, scalar));
                let ident = Ident::new(&name, Span::call_site());
                let offset = vector(offset);
                quote!(#shape::MeshAt {
                    mesh: &#ident,
                    placement: ::hapticgen_runtime::shape::RigidMotion::translation(#offset),
                })
            }
        };
        let kind = if object.cavity { quote!(Cavity) } else { quote!(Solid) };
        let [stiffness, damping, static_friction, dynamic_friction] =
            [object.stiffness, object.damping, object.static_friction, object.dynamic_friction].map(number);
        objects.push(quote! {
            ::hapticgen_runtime::shape::Object {
                shape: #geometry,
                kind: ::hapticgen_runtime::render::ObjectKind::#kind,
                material: ::hapticgen_runtime::shape::Material {
                    stiffness: #stiffness,
                    damping: #damping,
                    static_friction: #static_friction,
                    dynamic_friction: #dynamic_friction,
                },
            }
        });
    }
    let count = Literal::usize_unsuffixed(objects.len());
    let m = Literal::usize_unsuffixed(task_dim);
    let effect_type = quote!(::hapticgen_runtime::effects::Effect);
    // Only a vibration advances with the tick; the other effects take the period to keep one
    // signature for every scene.
    let (period, effect) = match &scene.effect {
        None => (quote!(_impedance_period), quote!(#effect_type::None)),
        Some(SceneEffect::Spring { anchor, stiffness }) => {
            let (anchor, stiffness) = (vector(anchor), number(*stiffness));
            (
                quote!(_impedance_period),
                quote!(#effect_type::Spring { anchor: #anchor, stiffness: #stiffness }),
            )
        }
        Some(SceneEffect::Viscous { damping }) => {
            let damping = number(*damping);
            (quote!(_impedance_period), quote!(#effect_type::Viscous { damping: #damping }))
        }
        Some(SceneEffect::Force { force }) => {
            let force = vector(force);
            (quote!(_impedance_period), quote!(#effect_type::Force { force: #force }))
        }
        Some(SceneEffect::Vibration { direction, amplitude, frequency }) => {
            let (direction, amplitude, frequency) =
                (vector(direction), number(*amplitude), number(*frequency));
            (
                quote!(impedance_period),
                quote!(#effect_type::Vibration {
                    direction: #direction,
                    amplitude: #amplitude,
                    frequency: #frequency,
                    period: impedance_period,
                }),
            )
        }
    };
    let tokens = quote! {
        #(#polytopes)*
        /// Objects in the scene.
        pub const OBJECTS: usize = #count;
        /// The scene's objects, as the runtime renders them.
        pub fn objects() -> [::hapticgen_runtime::shape::Object<'static, #ty, #m>; OBJECTS] {
            [#(#objects),*]
        }
        /// Each object's motion (`None`: it stays), as the runtime moves it before each update.
        pub fn motions() -> [Option<::hapticgen_runtime::motion::ObjectMotion<#ty, #m>>; OBJECTS] {
            [#(#motions),*]
        }
        /// The scene's free-space effect, for an impedance loop ticking every
        /// `impedance_period` seconds.
        pub fn effect(#period: #ty) -> #effect_type<#ty, #m> {
            #effect
        }
    };
    Ok(format!(
        "// @generated by hapticgen {} from a scene file. Do not edit.\n{}{}",
        crate::version::VERSION,
        meshes,
        crate::format_tokens(&tokens)
    ))
}

#[cfg(test)]
mod tests {
    use super::SceneShape;

    fn depth(shape: SceneShape, p: [f64; 3]) -> f64 {
        shape.depth(&p).unwrap()
    }

    /// A syntax or shape error says where it is once, at the front, as the model's do.
    #[test]
    fn a_scene_error_names_its_location_once() {
        let text = "objects:\n  - sphere: {center: [0, 0, 0], radius: 0.01}\n    colour: red\n";
        let error = super::parse("bad.yaml", text, std::path::Path::new(".")).err().unwrap();
        assert!(error.starts_with("error: bad.yaml:"), "{error}");
        assert!(!error.contains(" at line "), "{error}");
    }

    #[test]
    fn depths_are_the_shapes_closed_forms() {
        let floor = || SceneShape::HalfSpace { point: vec![0.0, 0.0, 1.0], normal: vec![0.0, 0.0, 2.0] };
        assert_eq!(depth(floor(), [5.0, 5.0, 0.25]), 0.75);
        assert_eq!(depth(floor(), [0.0, 0.0, 3.0]), -2.0);
        let ball = || SceneShape::Sphere { center: vec![1.0, 0.0, 0.0], radius: 0.5 };
        assert_eq!(depth(ball(), [1.0, 0.25, 0.0]), 0.25);
        assert_eq!(depth(ball(), [1.0, 0.0, -2.0]), -1.5);
        let cube = || SceneShape::axis_aligned_box(vec![0.0; 3], vec![1.0, 2.0, 3.0]);
        assert_eq!(depth(cube(), [0.5, 0.0, 0.0]), 0.5);
        assert_eq!(depth(cube(), [0.0, 1.75, 0.0]), 0.25);
        // Outside beyond an edge: √(1² + 1²); beyond a corner: √3.
        assert!((depth(cube(), [2.0, 3.0, 0.0]) + 2f64.sqrt()).abs() < 1e-15);
        assert!((depth(cube(), [-2.0, -3.0, 4.0]) + 3f64.sqrt()).abs() < 1e-15);
        // The same box turned by 90° about z: its x half extent (1) now lies along y, its y
        // (2) along x; and a 2-D square turned by 45°, whose corner reaches √2 along x.
        let turned = SceneShape::Box {
            center: vec![0.0; 3],
            axes: super::box_axes(3, Some(&[0.0, 0.0, std::f64::consts::FRAC_PI_2])).unwrap(),
            half_extents: vec![1.0, 2.0, 3.0],
        };
        assert!((depth(turned.clone(), [1.75, 0.0, 0.0]) - 0.25).abs() < 1e-15);
        assert!((depth(turned, [0.0, 1.5, 0.0]) + 0.5).abs() < 1e-15);
        let diamond = SceneShape::Box {
            center: vec![1.0, 0.0],
            axes: super::box_axes(2, Some(&[std::f64::consts::FRAC_PI_4])).unwrap(),
            half_extents: vec![1.0, 1.0],
        };
        assert!((diamond.depth(&[1.0 + 2f64.sqrt() - 0.1, 0.0]).unwrap() - 0.1 / 2f64.sqrt()).abs() < 1e-15);
        assert!(super::box_axes(3, Some(&[0.1])).is_err() && super::box_axes(1, Some(&[0.1])).is_err());
        // The unit cube as six planes: inside, the nearest face (as the box); outside, the
        // farthest plane's distance (beyond an edge, 1, a lower bound of √2).
        let planes = (0..3)
            .flat_map(|i| {
                [1.0, -1.0].map(|side| super::ScenePlane {
                    normal: (0..3).map(|k| if k == i { side } else { 0.0 }).collect(),
                    offset: 1.0,
                })
            })
            .collect();
        let polytope = SceneShape::Polytope { planes };
        assert_eq!(depth(polytope.clone(), [0.5, 0.25, 0.0]), 0.5);
        assert_eq!(depth(polytope.clone(), [2.0, 0.0, 0.0]), -1.0);
        assert_eq!(depth(polytope, [2.0, 2.0, 0.0]), -1.0);
    }

    /// Each effect kind is emitted as the runtime's, with the file's numbers; only a vibration
    /// uses the tick's period.
    #[test]
    fn a_scene_s_effect_is_emitted_as_the_runtime_s() {
        let emitted = |effect: &str| {
            let text = format!("objects: []\neffect: {effect}\n");
            let scene = super::parse("s.yaml", &text, std::path::Path::new(".")).unwrap();
            let code = super::emit(&scene, 3, crate::Scalar::F64).unwrap();
            let start = code.find("pub fn effect(").unwrap();
            // Whitespace and the formatter's trailing commas aside.
            code[start..].split_whitespace().collect::<Vec<_>>().join(" ").replace(", }", " }")
        };
        let effect = "::hapticgen_runtime::effects::Effect";
        assert_eq!(
            emitted("{viscous: {damping: 2}}"),
            format!("pub fn effect(_impedance_period: f64) -> {effect}<f64, 3> {{ {effect}::Viscous {{ damping: 2.0 }} }}")
        );
        assert!(emitted("{spring: {anchor: [0, 0, -0.1], stiffness: 500}}")
            .contains(&format!("{effect}::Spring {{ anchor: [0.0, 0.0, -0.1], stiffness: 500.0 }}")));
        assert!(emitted("{force: {force: [0, 1, 0]}}")
            .contains(&format!("{effect}::Force {{ force: [0.0, 1.0, 0.0] }}")));
        let vibration = emitted("{vibration: {direction: [0, 0, 2], amplitude: 0.5, frequency: 100}}");
        assert!(vibration.starts_with("pub fn effect(impedance_period: f64)"), "{vibration}");
        assert!(
            vibration.contains(&format!(
                "{effect}::Vibration {{ direction: [0.0, 0.0, 1.0], amplitude: 0.5, frequency: 100.0, period: impedance_period }}"
            )),
            "{vibration}"
        );
        let none =
            super::emit(&super::Scene { objects: vec![], effect: None }, 2, crate::Scalar::F32).unwrap();
        let none = none.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(none.contains(&format!("-> {effect}<f32, 2> {{ {effect}::None }}")), "{none}");
    }

    #[test]
    fn capsule_and_cylinder_depths_are_closed_forms() {
        // A capsule and a cylinder along z from 0 to 2, radius 0.5.
        let capsule = || SceneShape::Capsule { a: vec![0.0; 3], b: vec![0.0, 0.0, 2.0], radius: 0.5 };
        assert!((depth(capsule(), [0.25, 0.0, 1.0]) - 0.25).abs() < 1e-15);
        assert!((depth(capsule(), [0.0, 0.0, 3.0]) + 0.5).abs() < 1e-15);
        assert!((depth(capsule(), [1.5, 0.0, -1.0]) - (0.5 - 3.25f64.sqrt())).abs() < 1e-15);
        let cylinder = || SceneShape::Cylinder { a: vec![0.0; 3], b: vec![0.0, 0.0, 2.0], radius: 0.5 };
        assert!((depth(cylinder(), [0.1, 0.0, 0.05]) - 0.05).abs() < 1e-15);
        assert!((depth(cylinder(), [0.0, 0.3, 1.0]) - 0.2).abs() < 1e-15);
        assert!((depth(cylinder(), [0.0, 0.0, -1.0]) + 1.0).abs() < 1e-15);
        assert!((depth(cylinder(), [1.5, 0.0, 3.0]) + 2f64.sqrt()).abs() < 1e-15);
        assert!((depth(cylinder(), [0.0, 1.5, 1.0]) + 1.0).abs() < 1e-15);
    }
}
