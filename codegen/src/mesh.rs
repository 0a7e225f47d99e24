//! Build-time meshes for haptic rendering: reads a triangle mesh (Wavefront OBJ, ASCII or
//! binary STL), computes face normals, area-weighted vertex normals (for force shading) and
//! an AABB tree (BVH), and emits them as `static` arrays of the runtime's
//! `hapticgen_runtime::shape::{Mesh, BvhNode}`, so firmware holds the mesh in flash and the
//! renderer allocates nothing.
//!
//! ```no_run
//! // build.rs
//! let out = std::path::PathBuf::from(std::env::var("OUT_DIR").unwrap());
//! let mesh = hapticgen_codegen::mesh::load("meshes/bunny.obj").unwrap_or_else(|e| panic!("{e}"));
//! let text = hapticgen_codegen::mesh::emit(&mesh.with_bvh(4), "BUNNY", hapticgen_codegen::Scalar::F32);
//! std::fs::write(out.join("bunny.rs"), text).unwrap();
//! println!("cargo:rerun-if-changed=meshes/bunny.obj");
//! ```
//! and in the crate: `include!(concat!(env!("OUT_DIR"), "/bunny.rs"));` gives `BUNNY`, a
//! `Mesh<'static, f32, 3>`.
//!
//! The BVH: each node bounds its triangles; a node with more than `leaf_size` triangles is
//! split at the median centroid along the longest axis of its centroids' box, its children
//! stored next to each other (`first`, `first + 1`), its triangles reordered so a leaf's are
//! contiguous. Depth is at most `⌈log₂ n⌉ + 1`, well within the runtime's traversal stack.

use std::path::Path;

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;

use crate::math::vector::{cross, norm, sub};
use crate::Scalar;

/// A triangle mesh with its normals and, once built, its BVH.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles (vertex indices, counter-clockwise seen from outside).
    pub faces: Vec<[u32; 3]>,
    /// Unit normal per face.
    pub face_normals: Vec<[f64; 3]>,
    /// Unit, area-weighted normal per vertex.
    pub vertex_normals: Vec<[f64; 3]>,
    /// The BVH (empty until [`TriangleMesh::with_bvh`]).
    pub nodes: Vec<Node>,
}

/// A BVH node, as the runtime's `BvhNode`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
    /// First face of a leaf, first child of an inner node.
    pub first: u32,
    /// Faces of a leaf, 0 for an inner node.
    pub count: u32,
}

fn normalised(a: [f64; 3]) -> [f64; 3] {
    let length = norm(a);
    if length > 0.0 {
        [a[0] / length, a[1] / length, a[2] / length]
    } else {
        [0.0, 0.0, 1.0]
    }
}

impl TriangleMesh {
    /// A mesh from vertices and triangles; computes the normals. Errors name the first face
    /// with an index out of range.
    pub fn new(vertices: Vec<[f64; 3]>, faces: Vec<[u32; 3]>) -> Result<Self, String> {
        let mut face_normals = Vec::with_capacity(faces.len());
        let mut vertex_normals = vec![[0.0; 3]; vertices.len()];
        for (index, face) in faces.iter().enumerate() {
            let corner = |k: usize| {
                vertices
                    .get(face[k] as usize)
                    .copied()
                    .ok_or_else(|| format!("face {index} names vertex {}, of {}", face[k], vertices.len()))
            };
            let (a, b, c) = (corner(0)?, corner(1)?, corner(2)?);
            let area_normal = cross(sub(b, a), sub(c, a)); // Twice the area, along the normal.
            face_normals.push(normalised(area_normal));
            for &v in face {
                let n: &mut [f64; 3] = &mut vertex_normals[v as usize];
                for (x, a) in n.iter_mut().zip(area_normal) {
                    *x += a;
                }
            }
        }
        let vertex_normals = vertex_normals.into_iter().map(normalised).collect();
        Ok(Self { vertices, faces, face_normals, vertex_normals, nodes: Vec::new() })
    }

    /// A UV sphere of `radius` about the origin: `rings` (≥ 2) bands of latitude, `segments`
    /// (≥ 3) of longitude, `2 × segments × (rings − 1)` triangles, outward normals. The test
    /// and benchmark mesh of the renderer (`targets/host/examples/render_bench.rs`,
    /// `bench/parry`); `Err` for too few rings or segments.
    pub fn uv_sphere(radius: f64, rings: usize, segments: usize) -> Result<Self, String> {
        if rings < 2 || segments < 3 {
            return Err(format!("a UV sphere needs ≥ 2 rings and ≥ 3 segments, not {rings} and {segments}"));
        }
        let mut vertices = vec![[0.0, 0.0, radius], [0.0, 0.0, -radius]];
        for i in 1..rings {
            let theta = std::f64::consts::PI * i as f64 / rings as f64;
            for j in 0..segments {
                let phi = 2.0 * std::f64::consts::PI * j as f64 / segments as f64;
                vertices.push([
                    radius * theta.sin() * phi.cos(),
                    radius * theta.sin() * phi.sin(),
                    radius * theta.cos(),
                ]);
            }
        }
        let ring = |i: usize, j: usize| (2 + (i - 1) * segments + j % segments) as u32;
        let mut faces = Vec::new();
        for j in 0..segments {
            faces.push([0, ring(1, j), ring(1, j + 1)]);
            faces.push([1, ring(rings - 1, j + 1), ring(rings - 1, j)]);
            for i in 1..rings - 1 {
                faces.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
                faces.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
            }
        }
        Self::new(vertices, faces)
    }

    /// The mesh with a BVH of leaves of at most `leaf_size` (≥ 1) triangles; the faces (and
    /// their normals) are reordered.
    pub fn with_bvh(mut self, leaf_size: usize) -> Self {
        let leaf_size = leaf_size.max(1);
        let centroid = |f: &[u32; 3]| {
            let mut c = [0.0; 3];
            for &v in f {
                for (x, p) in c.iter_mut().zip(self.vertices[v as usize]) {
                    *x += p / 3.0;
                }
            }
            c
        };
        let mut order: Vec<(usize, [f64; 3])> = self.faces.iter().map(centroid).enumerate().collect();
        let mut nodes = vec![Node { min: [0.0; 3], max: [0.0; 3], first: 0, count: 0 }];
        // (node, start, end) ranges of `order` still to place.
        let mut pending = vec![(0usize, 0usize, order.len())];
        while let Some((node, start, end)) = pending.pop() {
            let (mut min, mut max) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            let (mut cmin, mut cmax) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for (face, c) in &order[start..end] {
                for &v in &self.faces[*face] {
                    for ((lo, hi), x) in min.iter_mut().zip(max.iter_mut()).zip(self.vertices[v as usize]) {
                        *lo = lo.min(x);
                        *hi = hi.max(x);
                    }
                }
                for ((lo, hi), x) in cmin.iter_mut().zip(cmax.iter_mut()).zip(c) {
                    *lo = lo.min(*x);
                    *hi = hi.max(*x);
                }
            }
            if end - start <= leaf_size {
                nodes[node] = Node { min, max, first: start as u32, count: (end - start) as u32 };
                continue;
            }
            let axis =
                (0..3).max_by(|&i, &j| (cmax[i] - cmin[i]).total_cmp(&(cmax[j] - cmin[j]))).unwrap_or(0);
            order[start..end].sort_by(|a, b| a.1[axis].total_cmp(&b.1[axis]));
            let middle = start + (end - start) / 2;
            let first = nodes.len();
            nodes.push(Node { min, max, first: 0, count: 0 });
            nodes.push(Node { min, max, first: 0, count: 0 });
            nodes[node] = Node { min, max, first: first as u32, count: 0 };
            pending.push((first + 1, middle, end));
            pending.push((first, start, middle));
        }
        self.faces = order.iter().map(|(f, _)| self.faces[*f]).collect();
        self.face_normals = order.iter().map(|(f, _)| self.face_normals[*f]).collect();
        self.nodes = if self.faces.is_empty() { Vec::new() } else { nodes };
        self
    }
}

/// Reads a mesh from a Wavefront OBJ (`v` and `f` lines; polygons are fanned into triangles,
/// `v/vt/vn` and negative indices accepted) or an STL file (ASCII or binary; coincident
/// vertices merged), chosen by the file's extension.
pub fn load(path: impl AsRef<Path>) -> Result<TriangleMesh, String> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let is_stl = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("stl"));
    let parsed = if is_stl { parse_stl(&bytes) } else { parse_obj(&String::from_utf8_lossy(&bytes)) };
    parsed.map_err(|e| format!("{}: {e}", path.display()))
}

/// Parses Wavefront OBJ text.
pub fn parse_obj(text: &str) -> Result<TriangleMesh, String> {
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let line_number = number + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut v = [0.0; 3];
                for x in v.iter_mut() {
                    *x = words
                        .next()
                        .and_then(|w| w.parse().ok())
                        .ok_or_else(|| format!("{line_number}: a vertex needs three numbers"))?;
                }
                vertices.push(v);
            }
            Some("f") => {
                let mut corners = Vec::new();
                for word in words {
                    let index: i64 = word
                        .split('/')
                        .next()
                        .and_then(|w| w.parse().ok())
                        .ok_or_else(|| format!("{line_number}: bad face index `{word}`"))?;
                    let resolved = if index < 0 { vertices.len() as i64 + index } else { index - 1 };
                    if resolved < 0 || resolved >= vertices.len() as i64 {
                        return Err(format!("{line_number}: face index {index} out of range"));
                    }
                    corners.push(resolved as u32);
                }
                if corners.len() < 3 {
                    return Err(format!("{line_number}: a face needs three vertices"));
                }
                for k in 1..corners.len() - 1 {
                    faces.push([corners[0], corners[k], corners[k + 1]]);
                }
            }
            _ => {}
        }
    }
    TriangleMesh::new(vertices, faces)
}

/// Parses an ASCII or binary STL file.
pub fn parse_stl(bytes: &[u8]) -> Result<TriangleMesh, String> {
    let mut triangles: Vec<[[f64; 3]; 3]> = Vec::new();
    let binary_length =
        bytes.get(80..84).map(|n| 84 + 50 * u32::from_le_bytes([n[0], n[1], n[2], n[3]]) as usize);
    if binary_length == Some(bytes.len()) {
        for record in bytes[84..].chunks_exact(50) {
            let float = |i: usize| {
                let b = &record[12 + 4 * i..16 + 4 * i];
                f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64
            };
            triangles.push([
                [float(0), float(1), float(2)],
                [float(3), float(4), float(5)],
                [float(6), float(7), float(8)],
            ]);
        }
    } else {
        let text = String::from_utf8_lossy(bytes);
        let mut corners = Vec::new();
        for (number, line) in text.lines().enumerate() {
            let mut words = line.split_whitespace();
            if words.next() == Some("vertex") {
                let mut v = [0.0; 3];
                for x in v.iter_mut() {
                    *x = words
                        .next()
                        .and_then(|w| w.parse().ok())
                        .ok_or_else(|| format!("{}: a vertex needs three numbers", number + 1))?;
                }
                corners.push(v);
            }
        }
        if corners.len() % 3 != 0 {
            return Err(format!("{} vertices: not whole triangles", corners.len()));
        }
        triangles = corners.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    }
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut faces = Vec::with_capacity(triangles.len());
    for triangle in &triangles {
        let mut face = [0u32; 3];
        for (slot, v) in face.iter_mut().zip(triangle) {
            let key = v.map(f64::to_bits);
            *slot = *index.entry(key).or_insert_with(|| {
                vertices.push(*v);
                (vertices.len() - 1) as u32
            });
        }
        faces.push(face);
    }
    TriangleMesh::new(vertices, faces)
}

fn literal(x: f64, scalar: Scalar) -> Literal {
    match scalar {
        Scalar::F32 => Literal::f32_unsuffixed(x as f32),
        Scalar::F64 => Literal::f64_unsuffixed(x),
    }
}

/// Rust source (formatted) defining `static NAME: Mesh<'static, S, 3>` and its arrays
/// `NAME_VERTICES`, `NAME_FACES`, `NAME_FACE_NORMALS`, `NAME_VERTEX_NORMALS`, `NAME_NODES`.
pub fn emit(mesh: &TriangleMesh, name: &str, scalar: Scalar) -> String {
    let ty = match scalar {
        Scalar::F32 => quote!(f32),
        Scalar::F64 => quote!(f64),
    };
    let ident = |suffix: &str| Ident::new(&format!("{name}{suffix}"), Span::call_site());
    let points = |list: &[[f64; 3]]| -> Vec<TokenStream> {
        list.iter()
            .map(|p| {
                let [x, y, z] = p.map(|x| literal(x, scalar));
                quote!([#x, #y, #z])
            })
            .collect()
    };
    let (vertices, face_normals, vertex_normals) =
        (points(&mesh.vertices), points(&mesh.face_normals), points(&mesh.vertex_normals));
    let faces: Vec<TokenStream> = mesh.faces.iter().map(|[a, b, c]| quote!([#a, #b, #c])).collect();
    let nodes: Vec<TokenStream> = mesh
        .nodes
        .iter()
        .map(|node| {
            let [min, max] = [node.min, node.max].map(|p| {
                let [x, y, z] = p.map(|x| literal(x, scalar));
                quote!([#x, #y, #z])
            });
            let (first, count) = (node.first, node.count);
            quote!(::hapticgen_runtime::shape::BvhNode { min: #min, max: #max, first: #first, count: #count })
        })
        .collect();
    let [nv, nf, nn] =
        [mesh.vertices.len(), mesh.faces.len(), mesh.nodes.len()].map(Literal::usize_unsuffixed);
    let [mesh_name, v, f, fnorm, vnorm, n] =
        ["", "_VERTICES", "_FACES", "_FACE_NORMALS", "_VERTEX_NORMALS", "_NODES"].map(ident);
    let tokens = quote! {
        /// Vertex positions of the mesh.
        pub static #v: [[#ty; 3]; #nv] = [#(#vertices),*];
        /// Triangles, BVH order.
        pub static #f: [[u32; 3]; #nf] = [#(#faces),*];
        /// Face normals.
        pub static #fnorm: [[#ty; 3]; #nf] = [#(#face_normals),*];
        /// Vertex normals (force shading).
        pub static #vnorm: [[#ty; 3]; #nv] = [#(#vertex_normals),*];
        /// The BVH, root first.
        pub static #n: [::hapticgen_runtime::shape::BvhNode<#ty, 3>; #nn] = [#(#nodes),*];
        /// The mesh, for `hapticgen_runtime::shape::Shape::Mesh`.
        pub static #mesh_name: ::hapticgen_runtime::shape::Mesh<'static, #ty, 3> = ::hapticgen_runtime::shape::Mesh {
            vertices: &#v,
            faces: &#f,
            face_normals: &#fnorm,
            vertex_normals: &#vnorm,
            nodes: &#n,
        };
    };
    format!(
        "// @generated by hapticgen {} from a mesh. Do not edit.\n{}",
        crate::version::VERSION,
        crate::format_tokens(&tokens)
    )
}
