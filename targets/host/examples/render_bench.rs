//! Time per god-object proxy update on triangle meshes of about 1k, 10k and 100k triangles
//! (UV spheres from the build-time mesh helper, `TriangleMesh::uv_sphere`, with their BVH), the HIP circling 2 mm
//! deep into the surface; and, as the reference the BVH is for, the same closest-point query
//! by brute force over every triangle. Ratios, not asserted timings:
//!
//! ```sh
//! cargo run --release -p hapticgen --example render_bench
//! ```

use std::time::Instant;

use hapticgen_codegen::mesh::TriangleMesh;
use hapticgen_runtime::proxy::GodObject;
use hapticgen_runtime::render::ObjectKind;
use hapticgen_runtime::shape::{BvhNode, Material, Mesh, Object, Shape};

fn main() {
    println!("| triangles | BVH nodes | proxy update (ns) | closest point, BVH (ns) | closest point, every triangle (ns) | brute force / BVH |");
    println!("| --- | --- | --- | --- | --- | --- |");
    for (rings, segments) in [(16, 32), (50, 100), (158, 316)] {
        let built = TriangleMesh::uv_sphere(0.05, rings, segments).expect("a valid sphere").with_bvh(4);
        let nodes: Vec<BvhNode<f64, 3>> = built
            .nodes
            .iter()
            .map(|n| BvhNode { min: n.min, max: n.max, first: n.first, count: n.count })
            .collect();
        let mesh = Mesh {
            vertices: &built.vertices,
            faces: &built.faces,
            face_normals: &built.face_normals,
            vertex_normals: &built.vertex_normals,
            nodes: &nodes,
        };
        let flat = Mesh { nodes: &[], ..mesh };
        let mut scene: GodObject<f64, 1, 3> = GodObject::new(0.0, 0.0, 1e-3, 1e-9);
        scene
            .add(Object {
                shape: Shape::Mesh(&mesh),
                kind: ObjectKind::Solid,
                material: Material::frictionless(1500.0, 5.0),
            })
            .expect("one slot");
        scene.reset([0.0, 0.0, 0.06]);
        let updates = 20_000;
        let hip = |k: usize| {
            let a = k as f64 * 1e-3;
            [0.02 * a.cos(), 0.02 * a.sin(), (0.048f64.powi(2) - 0.0004).sqrt()]
        };
        let start = Instant::now();
        let mut sink = 0.0;
        for k in 0..updates {
            sink += scene.render(&hip(k)).proxy[2];
        }
        let update = start.elapsed().as_nanos() as f64 / updates as f64;
        let queries = 2_000;
        let time = |m: &Mesh<f64, 3>| {
            let start = Instant::now();
            let mut sink = 0.0;
            for k in 0..queries {
                sink += m.closest(&hip(k * 10)).map_or(0.0, |f| f.point[0]);
            }
            (start.elapsed().as_nanos() as f64 / queries as f64, sink)
        };
        let ((bvh, a), (brute, b)) = (time(&mesh), time(&flat));
        assert!((a - b).abs() < 1e-9 && sink.is_finite(), "the BVH changes the answer");
        println!(
            "| {} | {} | {update:.0} | {bvh:.0} | {brute:.0} | {:.0}× |",
            built.faces.len(),
            nodes.len(),
            brute / bvh
        );
    }
}
