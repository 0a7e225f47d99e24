//! What the simulator needs of a scene's objects beyond their definition: [`ContactGeometry`],
//! implemented for codegen's [`SceneObject`] (the one definition of a scene object; a contact
//! scenario's solids and a scene file's are both such objects), gives
//!
//! * the runtime's [`Object`] for the god object, which owns what the runtime's shapes borrow
//!   (a polytope's planes, a mesh's arrays);
//! * an inside test of its own that shares no code with the runtime's renderer, for the
//!   contact scenarios' checks (the proxy must never be inside a solid): codegen's closed
//!   forms for the analytic shapes, and for a mesh ray parity over every face with the
//!   distance to the nearest one, written here;
//! * the outward normal at a surface point, for the checks on the rendered force's direction.
//!
//! A trait on codegen's type, not a host copy of it: the host adds behaviour, no data.

use hapticgen_codegen::mesh::TriangleMesh;
use hapticgen_runtime::render::ObjectKind;
use hapticgen_runtime::shape::{BvhNode, Material, Mesh, Object, Plane, RigidMotion, Shape};

use crate::scene::{SceneObject, ScenePlane, SceneShape};
use crate::vector::{cross, dot, norm, sub};

fn array<const M: usize>(values: &[f64], what: &str) -> Result<[f64; M], String> {
    if values.len() != M {
        return Err(format!("error: {what} needs {M} coordinates, got {}", values.len()));
    }
    Ok(std::array::from_fn(|k| values[k]))
}

/// The simulator's geometry on a scene object (module docs).
pub trait ContactGeometry {
    /// The runtime's object for an `M`-dimensional task. A mesh's arrays are leaked to give
    /// them the `'static` lifetime a long-lived scene needs: a few hundred kilobytes once per
    /// simulated run.
    fn runtime_object<const M: usize>(&self) -> Result<Object<'static, f64, M>, String>;

    /// How deep `p` is inside the object, m: positive inside, negative outside (for a mesh: its
    /// parity along a ray decides inside, and the depth is the distance to the nearest face;
    /// for a cavity, inside its wall: beyond the shape's boundary). Apart from the runtime's
    /// closest-point code, the reference the renderer is checked against; unlike
    /// [`SceneObject::depth`], it measures meshes too. A moving object is taken where it is at
    /// time 0.
    fn reference_depth(&self, p: &[f64]) -> f64;

    /// [`ContactGeometry::reference_depth`] of the object where its motion has taken it at
    /// `time`, s (where it is at time 0 for an object that does not move).
    fn reference_depth_at(&self, p: &[f64], time: f64) -> f64;

    /// The object's outward unit normal at (or nearest to) surface point `p`; `None` for a
    /// capsule, a cylinder or a mesh.
    fn outward_normal(&self, p: &[f64]) -> Option<Vec<f64>>;
}

impl ContactGeometry for SceneObject {
    fn runtime_object<const M: usize>(&self) -> Result<Object<'static, f64, M>, String> {
        let shape = match &self.shape {
            SceneShape::HalfSpace { point, normal } => Shape::half_space(
                array::<M>(point, "a wall's point")?,
                array::<M>(normal, "a wall's normal")?,
            )
            .ok_or_else(|| "error: a wall's normal must be a finite, non-zero vector".to_string())?,
            SceneShape::Sphere { center, radius } => {
                Shape::Sphere { center: array::<M>(center, "a sphere's centre")?, radius: *radius }
            }
            SceneShape::Box { center, axes, half_extents } => {
                if axes.len() != M {
                    return Err(format!("error: a box needs {M} axes, got {}", axes.len()));
                }
                let mut rows = [[0.0; M]; M];
                for (row, axis) in rows.iter_mut().zip(axes) {
                    *row = array::<M>(axis, "a box's axis")?;
                }
                Shape::Box {
                    center: array::<M>(center, "a box's centre")?,
                    axes: rows,
                    half_extents: array::<M>(half_extents, "a box's half extents")?,
                }
            }
            SceneShape::Capsule { a, b, radius } => Shape::Capsule {
                a: array::<M>(a, "a capsule's end")?,
                b: array::<M>(b, "a capsule's end")?,
                radius: *radius,
            },
            SceneShape::Cylinder { a, b, radius } => Shape::Cylinder {
                a: array::<M>(a, "a cylinder's cap centre")?,
                b: array::<M>(b, "a cylinder's cap centre")?,
                radius: *radius,
            },
            SceneShape::Polytope { planes } => {
                let mut bounding = Vec::with_capacity(planes.len());
                for plane in planes {
                    bounding.push(Plane {
                        normal: array::<M>(&plane.normal, "a plane's normal")?,
                        offset: plane.offset,
                    });
                }
                // Leaked like a mesh's arrays: the runtime's shape borrows its planes.
                Shape::Polytope { planes: Box::leak(bounding.into_boxed_slice()) }
            }
            SceneShape::Mesh { mesh, offset } => {
                if M != 3 {
                    return Err(format!("error: a mesh needs a 3-D task; this one has {M} coordinates"));
                }
                let point = |p: &[f64; 3]| -> [f64; M] { std::array::from_fn(|k| p[k]) };
                let leak = |points: &[[f64; 3]]| -> &'static [[f64; M]] {
                    Box::leak(points.iter().map(point).collect::<Vec<_>>().into_boxed_slice())
                };
                let nodes: Vec<BvhNode<f64, M>> = mesh
                    .nodes
                    .iter()
                    .map(|n| BvhNode {
                        min: point(&n.min),
                        max: point(&n.max),
                        first: n.first,
                        count: n.count,
                    })
                    .collect();
                let runtime_mesh: &'static Mesh<'static, f64, M> = Box::leak(Box::new(Mesh {
                    vertices: leak(&mesh.vertices),
                    faces: Box::leak(mesh.faces.clone().into_boxed_slice()),
                    face_normals: leak(&mesh.face_normals),
                    vertex_normals: leak(&mesh.vertex_normals),
                    nodes: Box::leak(nodes.into_boxed_slice()),
                }));
                Shape::MeshAt {
                    mesh: runtime_mesh,
                    placement: RigidMotion::translation(array::<M>(offset, "a mesh's offset")?),
                }
            }
        };
        Ok(Object {
            shape,
            kind: if self.cavity { ObjectKind::Cavity } else { ObjectKind::Solid },
            material: Material {
                stiffness: self.stiffness,
                damping: self.damping,
                static_friction: self.static_friction,
                dynamic_friction: self.dynamic_friction,
            },
        })
    }

    fn reference_depth(&self, p: &[f64]) -> f64 {
        let depth_in_shape = shape_depth(&self.shape, p);
        if self.cavity {
            -depth_in_shape
        } else {
            depth_in_shape
        }
    }

    fn reference_depth_at(&self, p: &[f64], time: f64) -> f64 {
        match &self.motion {
            Some(motion) => self.reference_depth(&motion.carried_back(time, p)),
            None => self.reference_depth(p),
        }
    }

    fn outward_normal(&self, p: &[f64]) -> Option<Vec<f64>> {
        let unit = |v: Vec<f64>| {
            let length = norm(&v);
            (length > 0.0).then(|| v.iter().map(|x| x / length).collect())
        };
        match &self.shape {
            SceneShape::HalfSpace { normal, .. } => unit(normal.clone()),
            SceneShape::Sphere { center, .. } => unit(p.iter().zip(center).map(|(p, c)| p - c).collect()),
            SceneShape::Box { center, axes, half_extents } => {
                // In the box's axes: outside, towards the point from its closest point; on a
                // face, that face's normal. Then back to task coordinates.
                let world: Vec<f64> = p.iter().zip(center).map(|(p, c)| p - c).collect();
                let offsets: Vec<f64> = axes.iter().map(|axis| dot(axis, &world)).collect();
                let beyond: Vec<f64> = offsets
                    .iter()
                    .zip(half_extents)
                    .map(|(d, h)| if d.abs() > *h { d - h * d.signum() } else { 0.0 })
                    .collect();
                let local = if beyond.iter().any(|&b| b != 0.0) {
                    beyond
                } else {
                    let axis = (0..offsets.len())
                        .min_by(|&a, &b| {
                            (half_extents[a] - offsets[a].abs())
                                .total_cmp(&(half_extents[b] - offsets[b].abs()))
                        })
                        .unwrap_or(0);
                    (0..offsets.len()).map(|k| if k == axis { offsets[k].signum() } else { 0.0 }).collect()
                };
                // Σ_i local_i · axis_i: the axes are the rows.
                unit(
                    (0..p.len())
                        .map(|k| axes.iter().zip(&local).map(|(axis, l)| axis[k] * l).sum())
                        .collect(),
                )
            }
            // The plane the point is farthest beyond (on the surface: the face it is on).
            SceneShape::Polytope { planes } => planes
                .iter()
                .max_by(|a, b| {
                    let beyond = |plane: &ScenePlane| dot(&plane.normal, p) - plane.offset;
                    beyond(a).total_cmp(&beyond(b))
                })
                .map(|plane| plane.normal.clone()),
            SceneShape::Capsule { .. } | SceneShape::Cylinder { .. } | SceneShape::Mesh { .. } => None,
        }
    }
}

/// How deep `p` is inside `shape`, m: positive inside, negative outside; NaN for a mesh in a
/// task other than 3-D.
fn shape_depth(shape: &SceneShape, p: &[f64]) -> f64 {
    match shape {
        SceneShape::Mesh { mesh, offset } => {
            if p.len() != 3 || offset.len() != 3 {
                return f64::NAN;
            }
            let local = [p[0] - offset[0], p[1] - offset[1], p[2] - offset[2]];
            let distance = mesh_distance(mesh, &local);
            if inside_by_parity(mesh, &local) {
                distance
            } else {
                -distance
            }
        }
        analytic => analytic.depth(p).unwrap_or(f64::NAN),
    }
}

fn triangle(mesh: &TriangleMesh, face: &[u32; 3]) -> Option<[[f64; 3]; 3]> {
    let vertex = |k: usize| mesh.vertices.get(face[k] as usize).copied();
    Some([vertex(0)?, vertex(1)?, vertex(2)?])
}

/// Odd crossings of a ray from `p` with the mesh's triangles (Möller–Trumbore, every face): `p`
/// is inside a closed mesh. The ray's direction is irrational-looking so that it passes through
/// no vertex or edge of a mesh built on round numbers.
fn inside_by_parity(mesh: &TriangleMesh, p: &[f64; 3]) -> bool {
    let direction = [0.5366563145999495, 0.6708203932499369, 0.5118906230018497];
    let mut crossings = 0;
    for face in &mesh.faces {
        let Some([a, b, c]) = triangle(mesh, face) else { continue };
        let (edge1, edge2) = (sub(&b, &a), sub(&c, &a));
        let h = cross(&direction, &edge2);
        let det = dot(&edge1, &h);
        if det.abs() < 1e-18 {
            continue;
        }
        let s = sub(p, &a);
        let u = dot(&s, &h) / det;
        let q = cross(&s, &edge1);
        let v = dot(&direction, &q) / det;
        let t = dot(&edge2, &q) / det;
        if (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

/// Distance from `p` to the nearest triangle of the mesh (every face; Ericson's regions).
fn mesh_distance(mesh: &TriangleMesh, p: &[f64; 3]) -> f64 {
    mesh.faces
        .iter()
        .filter_map(|face| triangle(mesh, face))
        .map(|[a, b, c]| {
            let closest = closest_point_on_triangle(p, &a, &b, &c);
            norm(&sub(p, &closest))
        })
        .fold(f64::INFINITY, f64::min)
}

fn closest_point_on_triangle(p: &[f64; 3], a: &[f64; 3], b: &[f64; 3], c: &[f64; 3]) -> [f64; 3] {
    let at = |origin: &[f64; 3], s: f64, u: &[f64; 3], t: f64, w: &[f64; 3]| {
        [origin[0] + s * u[0] + t * w[0], origin[1] + s * u[1] + t * w[1], origin[2] + s * u[2] + t * w[2]]
    };
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(&ab, &ap), dot(&ac, &ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(&ab, &bp), dot(&ac, &bp));
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return at(a, d1 / (d1 - d3), &ab, 0.0, &ac);
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(&ab, &cp), dot(&ac, &cp));
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return at(a, 0.0, &ab, d2 / (d2 - d6), &ac);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        let bc = sub(c, b);
        return at(b, w, &bc, 0.0, &bc);
    }
    let denominator = 1.0 / (va + vb + vc);
    at(a, vb * denominator, &ab, vc * denominator, &ac)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    fn solid(shape: SceneShape) -> SceneObject {
        SceneObject {
            shape,
            cavity: false,
            stiffness: 1.0,
            damping: 0.0,
            static_friction: 0.0,
            dynamic_friction: 0.0,
            motion: None,
            location: "a test's solid".into(),
        }
    }

    /// The inside tests against values worked out by hand, and a mesh sphere against the
    /// exact sphere it approximates (inside the inscribed ball, outside the circumscribed one).
    #[test]
    fn depths_by_hand() {
        let floor = solid(SceneShape::HalfSpace { point: vec![0.0, 0.0, 1.0], normal: vec![0.0, 0.0, 2.0] });
        assert_eq!(floor.reference_depth(&[5.0, -3.0, 0.25]), 0.75);
        assert_eq!(floor.reference_depth(&[0.0, 0.0, 1.5]), -0.5);
        let ball = solid(SceneShape::Sphere { center: vec![1.0, 0.0, 0.0], radius: 2.0 });
        assert_eq!(ball.reference_depth(&[1.0, 0.0, 1.5]), 0.5);
        assert_eq!(ball.reference_depth(&[4.0, 0.0, 0.0]), -1.0);
        // A cavity's wall is beyond its sphere: the centre is free, a point outside is in it.
        let cavity = SceneObject { cavity: true, ..ball.clone() };
        assert_eq!(cavity.reference_depth(&[1.0, 0.0, 1.5]), -0.5);
        assert_eq!(cavity.reference_depth(&[4.0, 0.0, 0.0]), 1.0);
        let cube = solid(SceneShape::axis_aligned_box(vec![0.0; 3], vec![1.0, 2.0, 3.0]));
        assert_eq!(cube.reference_depth(&[0.5, 0.0, 0.0]), 0.5);
        assert_eq!(cube.reference_depth(&[0.0, 1.75, 0.0]), 0.25);
        // Outside beyond an edge: √(1² + 1²).
        assert!((cube.reference_depth(&[2.0, 3.0, 0.0]) + 2f64.sqrt()).abs() < 1e-15);
        assert_eq!(cube.outward_normal(&[2.0, 0.0, 0.0]), Some(vec![1.0, 0.0, 0.0]));
        let sphere = TriangleMesh::uv_sphere(1.0, 16, 32).expect("a sphere").with_bvh(4);
        let mesh = solid(SceneShape::Mesh { mesh: Arc::new(sphere), offset: vec![0.0, 0.0, 2.0] });
        for (p, inside) in [
            ([0.0, 0.0, 2.9], true),
            ([0.3, 0.2, 1.2], true),
            ([0.0, 0.0, 3.01], false),
            ([1.1, 0.0, 2.0], false),
        ] {
            let depth = mesh.reference_depth(&p);
            assert_eq!(depth > 0.0, inside, "{p:?}: depth {depth}");
        }
        let depth = mesh.reference_depth(&[0.0, 0.0, 2.0]);
        assert!(depth > 0.95 && depth <= 1.0, "the centre is about a radius deep: {depth}");
    }
}
