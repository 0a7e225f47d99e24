//! A scene's objects, their shapes and motions, and each shape's penetration depth: the
//! geometry oracle the contact checks and the firmware's reference tests measure against.

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::mesh::TriangleMesh;

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

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
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
///
/// Serialized with the scene file's names (`velocity`, `angular_velocity`, `pivot`, every one
/// present): the host records it beside a run for the report's replay (`scene.json`). Scene
/// files themselves are read by [`super::parse`], which fills in the absent rates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
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
