//! Scene files: the virtual objects a device renders, in the task frame (metres), written once
//! and used by `hapticgen connect --scene` (loaded into a running device's scene slots) and
//! `hapticgen simulate --scene` (rendered by the runtime's god object in the simulator).
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
//! instead), `box` (axis-aligned), `half_space` (behind the plane; the normal points to free
//! space and is normalised here) or `mesh` (a closed triangle mesh from an OBJ or STL file,
//! named relative to the scene file, placed at `offset`; 3-D tasks only). Every object has a
//! surface `stiffness` (N/m) and `damping` (N·s/m), and optionally `friction` with `static`
//! and `dynamic` coefficients (0 ≤ dynamic ≤ static). Vectors hold one coordinate per task
//! axis; what uses the scene checks that they match its task. Every error names the file,
//! line and column of the value.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use hapticgen_codegen::model::positions::{display_path, PositionIndex, Segment};
use serde::Deserialize;

use crate::solids::{Solid, SolidShape};

/// A scene file's objects.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The objects, in the file's order.
    pub objects: Vec<SceneObject>,
}

/// One object of a scene file, with where it was written.
#[derive(Clone, Debug)]
pub struct SceneObject {
    /// The object as the simulator renders it.
    pub solid: Solid,
    /// Where its vectors are written, for errors about them later (`FILE:LINE:COLUMN: objects[K].KIND`).
    pub location: String,
}

impl Scene {
    /// The objects' solids, after checking that every vector has `task_dim` coordinates;
    /// the error names the object's vector in the file.
    pub fn solids(&self, task_dim: usize) -> Result<Vec<Solid>, String> {
        for object in &self.objects {
            let lengths: Vec<(&str, usize)> = match &object.solid.shape {
                SolidShape::HalfSpace { point, normal } => {
                    vec![("point", point.len()), ("normal", normal.len())]
                }
                SolidShape::Sphere { center, .. } => vec![("centre", center.len())],
                SolidShape::Box { center, half_extents } => {
                    vec![("centre", center.len()), ("half_extents", half_extents.len())]
                }
                SolidShape::Mesh { offset, .. } => vec![("offset", offset.len()), ("the mesh's vertices", 3)],
            };
            if let Some((field, n)) = lengths.into_iter().find(|&(_, n)| n != task_dim) {
                return Err(format!(
                    "error: {}: {field} has {n} coordinates; this rig's task has {task_dim}",
                    object.location
                ));
            }
        }
        Ok(self.objects.iter().map(|object| object.solid.clone()).collect())
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    // `- sphere: {…}`: each object a map of one key, its kind (serde_yaml's default for an
    // enum is a YAML tag, `!sphere`).
    #[serde(with = "serde_yaml::with::singleton_map_recursive")]
    objects: Vec<ObjectEntry>,
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
    },
    Box {
        centre: Vec<f64>,
        half_extents: Vec<f64>,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
    },
    HalfSpace {
        point: Vec<f64>,
        normal: Vec<f64>,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
    },
    Mesh {
        file: PathBuf,
        #[serde(default)]
        offset: Option<Vec<f64>>,
        stiffness: f64,
        damping: f64,
        #[serde(default)]
        friction: Option<FrictionEntry>,
    },
}

impl ObjectEntry {
    fn kind(&self) -> &'static str {
        match self {
            ObjectEntry::Sphere { .. } => "sphere",
            ObjectEntry::Box { .. } => "box",
            ObjectEntry::HalfSpace { .. } => "half_space",
            ObjectEntry::Mesh { .. } => "mesh",
        }
    }

    /// Stiffness, damping and friction, which every kind has (not `#[serde(flatten)]`ed into
    /// a struct of their own: serde cannot refuse unknown keys through a flattened field).
    fn surface(&self) -> (f64, f64, Option<&FrictionEntry>) {
        match self {
            ObjectEntry::Sphere { stiffness, damping, friction, .. }
            | ObjectEntry::Box { stiffness, damping, friction, .. }
            | ObjectEntry::HalfSpace { stiffness, damping, friction, .. }
            | ObjectEntry::Mesh { stiffness, damping, friction, .. } => {
                (*stiffness, *damping, friction.as_ref())
            }
        }
    }
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
        Some(at) => format!("error: {name}:{}:{}: {e}", at.line(), at.column()),
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
        let vector = |field: &str, values: &[f64]| -> Result<Vec<f64>, String> {
            if values.is_empty() || values.len() > MAX_COORDINATES || values.iter().any(|v| !v.is_finite()) {
                return Err(error(
                    field,
                    format!("must be 1 to {MAX_COORDINATES} finite coordinates, got {values:?}"),
                ));
            }
            Ok(values.to_vec())
        };
        let non_negative = |field: &str, value: f64| {
            if value.is_finite() && value >= 0.0 {
                Ok(value)
            } else {
                Err(error(field, format!("must be finite and not negative, got {value}")))
            }
        };
        let positive = |field: &str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(value)
            } else {
                Err(error(field, format!("must be finite and positive, got {value}")))
            }
        };
        let (shape, cavity) = match entry {
            ObjectEntry::Sphere { centre, radius, cavity, .. } => (
                SolidShape::Sphere {
                    center: vector("centre", centre)?,
                    radius: positive("radius", *radius)?,
                },
                *cavity,
            ),
            ObjectEntry::Box { centre, half_extents, .. } => {
                let half = vector("half_extents", half_extents)?;
                if half.iter().any(|h| *h <= 0.0) {
                    return Err(error("half_extents", format!("must be positive, got {half_extents:?}")));
                }
                (SolidShape::Box { center: vector("centre", centre)?, half_extents: half }, false)
            }
            ObjectEntry::HalfSpace { point, normal, .. } => {
                let n = vector("normal", normal)?;
                let length = n.iter().map(|v| v * v).sum::<f64>().sqrt();
                if length.is_nan() || length < 1e-9 {
                    return Err(error("normal", format!("must not be zero, got {normal:?}")));
                }
                (
                    SolidShape::HalfSpace {
                        point: vector("point", point)?,
                        normal: n.iter().map(|v| v / length).collect(),
                    },
                    false,
                )
            }
            ObjectEntry::Mesh { file, offset, .. } => {
                let path = directory.join(file);
                let mesh = crate::contact::mesh_file(&path)
                    .map_err(|e| error("file", e.trim_start_matches("error: ").to_string()))?;
                let offset = match offset {
                    Some(offset) => vector("offset", offset)?,
                    None => vec![0.0; 3],
                };
                (SolidShape::Mesh { mesh: Arc::clone(&mesh), offset }, false)
            }
        };
        let (stiffness, damping, friction) = entry.surface();
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
        let solid = Solid {
            shape,
            cavity,
            stiffness: non_negative("stiffness", stiffness)?,
            damping: non_negative("damping", damping)?,
            static_friction,
            dynamic_friction,
        };
        let location =
            located(&[Segment::Key("objects".into()), Segment::Index(index), Segment::Key(kind.into())]);
        objects.push(SceneObject { solid, location });
    }
    Ok(Scene { objects })
}

#[cfg(test)]
mod tests {
    use super::{load, parse};
    use crate::solids::SolidShape;
    use std::path::Path;

    fn parsed(text: &str) -> Result<super::Scene, String> {
        parse("s.yaml", text, Path::new("."))
    }

    #[test]
    fn every_kind_with_its_surface_and_friction() {
        let text = "objects:\n\
                    \x20 - half_space: {point: [0, 0, -0.05], normal: [0, 0, 2], stiffness: 800, damping: 2,\n\
                    \x20                friction: {static: 0.4, dynamic: 0.3}}\n\
                    \x20 - sphere: {centre: [0.03, 0, 0], radius: 0.015, cavity: true, stiffness: 600, damping: 1}\n\
                    \x20 - box: {centre: [0, 0, 0], half_extents: [0.01, 0.02, 0.03], stiffness: 700, damping: 2}\n";
        let scene = parsed(text).unwrap();
        assert_eq!(scene.objects.len(), 3);
        let floor = &scene.objects[0].solid;
        assert!(matches!(&floor.shape, SolidShape::HalfSpace { normal, .. } if normal == &[0.0, 0.0, 1.0]));
        assert_eq!((floor.static_friction, floor.dynamic_friction), (0.4, 0.3));
        assert_eq!((floor.stiffness, floor.damping), (800.0, 2.0));
        let ball = &scene.objects[1].solid;
        assert!(ball.cavity);
        // A cavity's wall is beyond its sphere: the centre is free, a point outside is inside the wall.
        assert!(ball.depth(&[0.03, 0.0, 0.0]) < 0.0);
        assert!((ball.depth(&[0.03, 0.02, 0.0]) - 0.005).abs() < 1e-12);
        assert!(scene.objects[1].location.starts_with("s.yaml:4:"), "{}", scene.objects[1].location);
        assert_eq!(scene.solids(3).unwrap().len(), 3);
        let error = scene.solids(2).unwrap_err();
        assert!(
            error.starts_with("error: s.yaml:2:") && error.contains("objects[0].half_space: point has 3"),
            "{error}"
        );
    }

    #[test]
    fn errors_name_the_value_where_it_is_written() {
        let cases = [
            ("objects:\n  - box: {centre: [0], half_extents: [-1], stiffness: 1, damping: 0}\n", "s.yaml:2:", "objects[0].box.half_extents: must be positive"),
            ("objects:\n  - sphere: {centre: [0], radius: 1, stiffness: 1, damping: 0,\n      friction: {static: 0.1, dynamic: 0.2}}\n", "s.yaml:3:", "objects[0].sphere.friction.dynamic: must not exceed the static coefficient 0.1"),
            ("objects:\n  - sphere: {centre: [0], radius: 1, stiffness: 1, damping: 0, colour: red}\n", "s.yaml:2:", "unknown field `colour`"),
            ("objects:\n  - half_space: {point: [0, 0], normal: [0, 0], stiffness: 1, damping: 0}\n", "s.yaml:2:", "objects[0].half_space.normal: must not be zero"),
            ("objects:\n  - mesh: {file: no-such.obj, stiffness: 1, damping: 0}\n", "s.yaml:2:", "objects[0].mesh.file:"),
        ];
        for (text, at, message) in cases {
            let error = parsed(text).unwrap_err();
            assert!(error.starts_with(&format!("error: {at}")) && error.contains(message), "{error}");
        }
    }

    /// A mesh is read relative to the scene file: the repository's knob, from scenes/.
    #[test]
    fn a_mesh_is_read_relative_to_the_scene_file() {
        let directory = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        let text = "objects:\n  - mesh: {file: meshes/knob.obj, offset: [0, 0, -0.05], stiffness: 500, damping: 1}\n";
        let scene = parse("s.yaml", text, &directory).unwrap();
        assert!(
            matches!(&scene.objects[0].solid.shape, SolidShape::Mesh { mesh, offset } if !mesh.faces.is_empty() && offset[2] == -0.05)
        );
        // The shipped example loads as a whole.
        let example = load(&directory.join("desk.yaml")).unwrap();
        assert!(example.objects.len() >= 3);
    }
}
