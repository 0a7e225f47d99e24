//! The god-object proxy (`hapticgen_runtime::proxy`) never crosses a surface under random,
//! fast device motions (proptest, 10⁴ trajectories): a closed mesh (a cube built by the
//! build-time mesh helper, `hapticgen_codegen::mesh`, with its BVH), a zero-thickness mesh
//! plate and a 2 mm box plate; and the mesh helper's BVH and emitted source.

use hapticgen_codegen::mesh::{parse_obj, TriangleMesh};
use hapticgen_runtime::proxy::GodObject;
use hapticgen_runtime::render::ObjectKind;
use hapticgen_runtime::shape::{BvhNode, Material, Mesh, Object, Shape};
use proptest::prelude::*;

/// A mesh's arrays in the runtime's types.
pub struct Arrays {
    vertices: Vec<[f64; 3]>,
    faces: Vec<[u32; 3]>,
    face_normals: Vec<[f64; 3]>,
    nodes: Vec<BvhNode<f64, 3>>,
}

impl Arrays {
    pub fn new(mesh: &TriangleMesh) -> Self {
        Self {
            vertices: mesh.vertices.clone(),
            faces: mesh.faces.clone(),
            face_normals: mesh.face_normals.clone(),
            nodes: mesh
                .nodes
                .iter()
                .map(|n| BvhNode { min: n.min, max: n.max, first: n.first, count: n.count })
                .collect(),
        }
    }

    /// Flat faces (no force shading), so the normals are the faces' own.
    pub fn mesh(&self) -> Mesh<'_, f64, 3> {
        Mesh {
            vertices: &self.vertices,
            faces: &self.faces,
            face_normals: &self.face_normals,
            vertex_normals: &[],
            nodes: &self.nodes,
        }
    }
}

const CUBE: &str = "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
const PLATE: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n";
/// The distance from a point to the object, computed independently of the runtime.
type Clearance = fn([f64; 3]) -> f64;

const R: f64 = 1e-3;
const H: f64 = 0.05;

fn scaled(text: &str, factor: f64) -> TriangleMesh {
    let mut mesh = parse_obj(text).unwrap();
    for v in mesh.vertices.iter_mut() {
        for x in v.iter_mut() {
            *x *= factor;
        }
    }
    TriangleMesh::new(mesh.vertices, mesh.faces).unwrap().with_bvh(2)
}

fn box_sdf(p: [f64; 3], h: [f64; 3]) -> f64 {
    let d = [p[0].abs() - h[0], p[1].abs() - h[1], p[2].abs() - h[2]];
    let outside = (d[0].max(0.0).powi(2) + d[1].max(0.0).powi(2) + d[2].max(0.0).powi(2)).sqrt();
    outside + d[0].max(d[1]).max(d[2]).min(0.0)
}

fn scene<'a>(shape: Shape<'a, f64, 3>) -> GodObject<'a, f64, 1, 3> {
    let mut scene = GodObject::new(0.0, 0.0, R, 1e-9);
    scene
        .add(Object {
            shape,
            kind: ObjectKind::Solid,
            material: Material {
                stiffness: 2000.0,
                damping: 1.0,
                static_friction: 0.3,
                dynamic_friction: 0.2,
            },
        })
        .unwrap();
    scene
}

fn point() -> impl Strategy<Value = [f64; 3]> {
    [-0.15..0.15f64, -0.15..0.15f64, -0.15..0.15f64]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10_000, ..ProptestConfig::default() })]

    /// Each case is one trajectory: a start in free space, then eight jumps of the HIP
    /// anywhere in a 30 cm cube (through the object, far faster than a hand: up to 26 cm a
    /// tick); after every update the proxy must still be outside the object by its radius
    /// and, for the plates, on the side it started.
    #[test]
    fn the_proxy_never_crosses_a_closed_mesh_or_a_thin_plate(
        which in 0usize..3,
        start in point(),
        hips in proptest::collection::vec(point(), 8),
    ) {
        let cube = Arrays::new(&scaled(CUBE, H));
        // The plates are wider than the HIP's range: the proxy cannot go round them.
        let plate = Arrays::new(&scaled(PLATE, 0.2));
        let (cube_mesh, plate_mesh) = (cube.mesh(), plate.mesh());
        let (shape, clearance): (Shape<f64, 3>, Clearance) = match which {
            0 => (Shape::Mesh(&cube_mesh), |p| box_sdf(p, [H; 3])),
            1 => (Shape::Mesh(&plate_mesh), |p| box_sdf(p, [0.2, 0.2, 0.0])),
            _ => (Shape::aligned_box([0.0; 3], [0.2, 0.2, 0.001]), |p| box_sdf(p, [0.2, 0.2, 0.001])),
        };
        prop_assume!(clearance(start) > R);
        let side = start[2].signum();
        let mut renderer = scene(shape);
        renderer.reset(start);
        for hip in hips {
            let proxy = renderer.render(&hip).proxy;
            prop_assert!(clearance(proxy) >= R - 1e-9, "{which}: the proxy {proxy:?} is within its radius");
            if which > 0 {
                prop_assert!(proxy[2] * side > 0.0, "{which}: the proxy {proxy:?} crossed the plate");
            }
        }
    }
}

#[test]
fn the_bvh_covers_every_face_and_the_emitted_source_names_the_arrays() {
    let mesh = scaled(CUBE, 1.0);
    // Every face is in exactly one leaf, inside the leaf's box.
    let mut seen = vec![0; mesh.faces.len()];
    for node in mesh.nodes.iter().filter(|n| n.count > 0) {
        for face in node.first..node.first + node.count {
            seen[face as usize] += 1;
            for &v in &mesh.faces[face as usize] {
                let p = mesh.vertices[v as usize];
                assert!((0..3).all(|k| node.min[k] <= p[k] && p[k] <= node.max[k]));
            }
        }
    }
    assert!(seen.iter().all(|&n| n == 1), "{seen:?}");
    // The outward normals of a closed mesh average to zero; each points away from the centre.
    for (face, n) in mesh.faces.iter().zip(&mesh.face_normals) {
        let p = mesh.vertices[face[0] as usize];
        assert!(p[0] * n[0] + p[1] * n[1] + p[2] * n[2] > 0.0);
    }
    let text = hapticgen_codegen::mesh::emit(&mesh, "CUBE", hapticgen_codegen::Scalar::F32);
    assert!(text.starts_with("// @generated by hapticgen"));
    for name in
        ["CUBE_VERTICES: [[f32; 3]; 8]", "CUBE_FACES: [[u32; 3]; 12]", "CUBE_NODES", "pub static CUBE:"]
    {
        assert!(text.contains(name), "{name} missing from\n{text}");
    }
}

/// The BVH's nearest-first search finds the closest face: on a soup of 300 random triangles
/// (with the mesh helper's BVH, leaves of 4), the closest point of 2,000 random points is at
/// the distance a scan of every triangle finds.
#[test]
fn the_bvh_search_finds_the_closest_face_of_a_triangle_soup() {
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};
    let mut rng = SmallRng::seed_from_u64(18);
    let mut point = |scale: f64| [0.0; 3].map(|_: f64| rng.gen_range(-scale..scale));
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for t in 0..300u32 {
        let centre = point(1.0);
        for _ in 0..3 {
            let offset = point(0.1);
            vertices.push([centre[0] + offset[0], centre[1] + offset[1], centre[2] + offset[2]]);
        }
        faces.push([3 * t, 3 * t + 1, 3 * t + 2]);
    }
    let soup = Arrays::new(&TriangleMesh::new(vertices, faces).unwrap().with_bvh(4));
    let with_bvh = soup.mesh();
    let every_face = Mesh { nodes: &[], ..with_bvh };
    assert!(!with_bvh.nodes.is_empty());
    let distance = |mesh: &Mesh<'_, f64, 3>, p: &[f64; 3]| {
        let q = mesh.closest(p).expect("a non-empty mesh").point;
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    };
    for _ in 0..2000 {
        let p = point(1.5);
        let (searched, scanned) = (distance(&with_bvh, &p), distance(&every_face, &p));
        assert!((searched - scanned).abs() <= 1e-15, "{p:?}: BVH {searched}, every face {scanned}");
    }
}

/// The mesh helper's UV sphere: every vertex on the sphere, `2 × segments × (rings − 1)`
/// triangles, each face's normal pointing away from the centre, every edge shared by two
/// faces (closed); too few rings or segments refused.
#[test]
fn the_uv_sphere_is_a_closed_outward_sphere() {
    let (radius, rings, segments) = (0.05, 7, 11);
    let sphere = TriangleMesh::uv_sphere(radius, rings, segments).unwrap();
    assert_eq!(sphere.faces.len(), 2 * segments * (rings - 1));
    for v in &sphere.vertices {
        let r = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        assert!((r - radius).abs() < 1e-15, "{v:?}");
    }
    let mut edges = std::collections::HashMap::new();
    for (face, normal) in sphere.faces.iter().zip(&sphere.face_normals) {
        let centroid: Vec<f64> =
            (0..3).map(|k| face.iter().map(|&i| sphere.vertices[i as usize][k]).sum::<f64>() / 3.0).collect();
        assert!(
            normal.iter().zip(&centroid).map(|(n, c)| n * c).sum::<f64>() > 0.0,
            "{face:?} faces inwards"
        );
        for k in 0..3 {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    assert!(edges.values().all(|&n| n == 2), "an edge not shared by exactly two faces");
    assert!(TriangleMesh::uv_sphere(radius, 1, segments).is_err());
    assert!(TriangleMesh::uv_sphere(radius, rings, 2).is_err());
}
