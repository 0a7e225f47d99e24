//! Reading a scene file: its YAML schema (one map of one key per object), the validation of
//! every value (finite vectors of the task's dimension, unit directions, non-negative
//! stiffness and damping, friction with `0 ≤ dynamic ≤ static`, meshes that load and close),
//! and errors at the file, line and column of the value.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Deserialize;

use super::objects::{dot, Scene, SceneEffect, SceneMotion, SceneObject, ScenePlane, SceneShape};
use crate::model::positions::{display_path, PositionIndex, Segment};

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
pub(super) fn box_axes(dim: usize, rotation: Option<&[f64]>) -> Result<Vec<Vec<f64>>, String> {
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
