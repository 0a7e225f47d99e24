//! The god-object renderer side by side with parry3d on the same triangle meshes
//! ("Performance"): UV spheres of about 1k, 10k and 100k triangles, built with hapticgen's
//! build-time mesh helper (with its BVH) and handed to parry3d as the same vertices and faces.
//!
//! First the answers are checked equal: for 2,000 points around each sphere (inside and
//! outside, near and far), hapticgen's closest point on the mesh and parry3d's point
//! projection are at the same distance to 1e-12 m. Then, in alternating rounds (best of 5, so
//! both see the same machine load), the time of
//!
//! * one god-object proxy update (`GodObject::render`), the HIP circling 2 mm deep, and
//! * one closest-point query on the mesh (`Mesh::closest`), against
//! * one parry3d point projection (`TriMesh::project_point`, its own BVH) at the same points.
//!
//! `bench/render-vs-parry.sh` runs it; the table goes to docs/rendering.md.

use std::hint::black_box;
use std::time::Instant;

use hapticgen_codegen::mesh::TriangleMesh;
use hapticgen_runtime::proxy::GodObject;
use hapticgen_runtime::render::ObjectKind;
use hapticgen_runtime::shape::{BvhNode, Material, Mesh, Object, Shape};
use parry3d_f64::math::{Pose, Vector};
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::TriMesh;

const RADIUS: f64 = 0.05;

/// The HIP's path: a circle 2 mm inside the sphere's surface.
fn hip(k: usize) -> [f64; 3] {
    let a = k as f64 * 1e-3;
    let depth = RADIUS - 0.002;
    [0.02 * a.cos(), 0.02 * a.sin(), (depth * depth - 0.0004).sqrt()]
}

/// Deterministic test points in a cube of ±1.5 radii (a fixed linear congruential sequence).
fn test_points(count: usize) -> Vec<[f64; 3]> {
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = move || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * 1.5 * RADIUS
    };
    (0..count).map(|_| [next(), next(), next()]).collect()
}

fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Best of five rounds of `f`, ns per call (`calls` calls per round).
fn best_ns(rounds: &mut [f64], round: usize, calls: usize, f: impl FnOnce() -> f64) {
    let start = Instant::now();
    black_box(f());
    let ns = start.elapsed().as_nanos() as f64 / calls as f64;
    rounds[round] = ns;
}

/// The mesh of size `index` (0, 1, 2: about 1k, 10k and 100k triangles) as hapticgen builds it,
/// with its BVH in the runtime's node type.
struct Sphere {
    built: TriangleMesh,
    nodes: Vec<BvhNode<f64, 3>>,
}

impl Sphere {
    fn new(index: usize) -> Self {
        let [(rings, segments), ..] = &SIZES[index..] else { panic!("size index {index} out of 0..3") };
        let built = TriangleMesh::uv_sphere(RADIUS, *rings, *segments).expect("a valid sphere").with_bvh(4);
        let nodes = built
            .nodes
            .iter()
            .map(|n| BvhNode { min: n.min, max: n.max, first: n.first, count: n.count })
            .collect();
        Self { built, nodes }
    }

    /// The runtime's mesh over these arrays.
    fn mesh(&self) -> Mesh<'_, f64, 3> {
        Mesh {
            vertices: &self.built.vertices,
            faces: &self.built.faces,
            face_normals: &self.built.face_normals,
            vertex_normals: &self.built.vertex_normals,
            nodes: &self.nodes,
        }
    }

    /// The same vertices and faces handed to parry3d.
    fn parry(&self) -> TriMesh {
        let vertices: Vec<Vector> =
            self.built.vertices.iter().map(|v| Vector::new(v[0], v[1], v[2])).collect();
        TriMesh::new(vertices, self.built.faces.clone()).expect("a valid mesh for parry3d")
    }
}

/// A god object with `mesh` as its one solid (proxy radius 1 mm, skin 1 nm).
fn scene_of<'a>(mesh: &'a Mesh<'a, f64, 3>) -> GodObject<'a, f64, 1, 3> {
    let mut scene: GodObject<f64, 1, 3> = GodObject::new(0.0, 0.0, 1e-3, 1e-9);
    scene
        .add(Object {
            shape: Shape::Mesh(mesh),
            kind: ObjectKind::Solid,
            material: Material::frictionless(1500.0, 5.0),
        })
        .expect("one slot");
    scene
}

/// UV spheres' rings and segments: 960, 9,800 and 99,224 triangles.
const SIZES: [(usize, usize); 3] = [(16, 32), (50, 100), (158, 316)];

/// `count OPERATION SIZE N`: only `N` operations (`update`, `closest` or `project`) on mesh
/// `SIZE` (0, 1, 2), for exact instruction counts under callgrind (`bench/render-vs-parry.sh
/// --instructions`: the difference between `N` and 0 operations, over `N`).
fn count(operation: &str, size: usize, n: usize) {
    let sphere = Sphere::new(size);
    let (mesh, parry) = (sphere.mesh(), sphere.parry());
    let mut scene = scene_of(&mesh);
    scene.reset([0.0, 0.0, RADIUS + 0.01]);
    // Into contact first, so that every counted update slides on the surface.
    for k in 0..100 {
        black_box(scene.render(&hip(k)));
    }
    let sum: f64 = match operation {
        "update" => (100..100 + n).map(|k| scene.render(&hip(k)).proxy[2]).sum(),
        "closest" => (0..n).map(|k| mesh.closest(&hip(k)).map_or(0.0, |f| f.point[2])).sum(),
        "project" => (0..n)
            .map(|k| {
                let p = hip(k);
                parry.project_point(&Pose::IDENTITY, Vector::new(p[0], p[1], p[2]), false).point.z
            })
            .sum(),
        other => panic!("unknown operation {other}: update, closest or project"),
    };
    black_box(sum);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("count") {
        let parse =
            |i: usize| args.get(i).and_then(|v| v.parse::<usize>().ok()).expect("count OPERATION SIZE N");
        count(args.get(2).map_or("", String::as_str), parse(3), parse(4));
        return;
    }
    println!("| triangles | proxy update (ns) | closest point, hapticgen BVH (ns) | point projection, parry3d (ns) | parry3d / proxy update | parry3d / closest point |");
    println!("| --- | --- | --- | --- | --- | --- |");
    for size in 0..SIZES.len() {
        let sphere = Sphere::new(size);
        let (mesh, parry) = (sphere.mesh(), sphere.parry());
        let identity = Pose::IDENTITY;
        let project = |p: &[f64; 3]| {
            let projection = parry.project_point(&identity, Vector::new(p[0], p[1], p[2]), false);
            [projection.point.x, projection.point.y, projection.point.z]
        };

        // The same answers first.
        let mut points = test_points(2_000);
        points.extend((0..500).map(|k| hip(k * 13)));
        for p in &points {
            let ours = mesh.closest(p).expect("a closest point on a non-empty mesh").point;
            let theirs = project(p);
            let (d_ours, d_theirs) = (distance(p, &ours), distance(p, &theirs));
            assert!(
                (d_ours - d_theirs).abs() <= 1e-12,
                "{} triangles, point {p:?}: hapticgen {ours:?} at {d_ours}, parry3d {theirs:?} at {d_theirs}",
                mesh.faces.len()
            );
        }

        let mut scene = scene_of(&mesh);
        let (updates, queries) = (20_000, 5_000);
        let (mut update, mut closest, mut projection) = ([0.0; 5], [0.0; 5], [0.0; 5]);
        for round in 0..5 {
            scene.reset([0.0, 0.0, RADIUS + 0.01]);
            best_ns(&mut update, round, updates, || {
                (0..updates).map(|k| scene.render(&hip(k)).proxy[2]).sum()
            });
            best_ns(&mut closest, round, queries, || {
                (0..queries).map(|k| mesh.closest(&hip(k * 4)).map_or(0.0, |f| f.point[2])).sum()
            });
            best_ns(&mut projection, round, queries, || (0..queries).map(|k| project(&hip(k * 4))[2]).sum());
        }
        let best = |v: [f64; 5]| v.into_iter().fold(f64::INFINITY, f64::min);
        let (update, closest, projection) = (best(update), best(closest), best(projection));
        println!(
            "| {} | {update:.0} | {closest:.0} | {projection:.0} | {:.2} | {:.2} |",
            mesh.faces.len(),
            projection / update,
            projection / closest
        );
    }
}
