//! Geometry for haptic rendering in an `M`-dimensional task space (2-D and 3-D rigs alike):
//! the shapes of virtual objects, their closest boundary points and outward normals, and
//! triangle meshes with a bounding-volume hierarchy.
//!
//! Every query is a fixed number of arithmetic steps on fixed-size arrays: nothing allocates,
//! slices are read with `get` (a malformed mesh gives no contact, not a panic), and a
//! degenerate shape (zero radius, zero-length axis, …) or a non-finite result gives `None`.
//!
//! Closest points, for a query `p` (all exact unless said otherwise):
//!
//! * **half-space** `n · (x − q) < 0`: `p − (n · (p − q)) n`;
//! * **sphere** (a ball in `M` dimensions) of centre `c`, radius `R`: `c + R (p − c)/|p − c|`;
//! * **box** with centre `c`, orthonormal axes `a_i` and half extents `h_i`: outside, the
//!   local coordinates `a_i · (p − c)` clamped to `[−h_i, h_i]`; inside, the nearest face;
//! * **capsule** (segment `ab` swept by a ball of radius `R`): the sphere rule about the
//!   segment's closest point `a + clamp(t, 0, 1)(b − a)`, `t = (p − a)·(b − a)/|b − a|²`;
//! * **cylinder** (axis `ab`, radius `R`, flat caps): the axial coordinate clamped to the
//!   caps and the radial distance to `R` outside, the nearer of side and cap inside;
//! * **convex polytope** `{x : n_i · x ≤ d_i}`: the projection on the plane of largest
//!   `n_i · p − d_i` (exact inside; outside it is the plane the god-object proxy sees, so
//!   edges and corners of the polytope stay sharp for it);
//! * **triangle mesh**: the closest point over the triangles (Ericson, *Real-Time Collision
//!   Detection*, 5.1.5, dot products only so any `M` works), pruned with the mesh's AABB tree;
//!   with vertex normals the normal is interpolated from the barycentric coordinates of the
//!   closest point (force shading). A mesh is a surface: it has no inside.

use crate::linalg::dot;
use crate::Real;

/// Depth of the traversal stack of a mesh's BVH (a tree of up to 2⁶⁴ leaves).
pub const BVH_STACK: usize = 64;

pub(crate) fn sub<S: Real, const M: usize>(a: &[S; M], b: &[S; M]) -> [S; M] {
    let mut out = *a;
    for (o, y) in out.iter_mut().zip(b.iter()) {
        *o -= *y;
    }
    out
}

/// `a + t b`.
pub(crate) fn add_scaled<S: Real, const M: usize>(a: &[S; M], t: S, b: &[S; M]) -> [S; M] {
    let mut out = *a;
    for (o, y) in out.iter_mut().zip(b.iter()) {
        *o += t * *y;
    }
    out
}

pub(crate) fn norm<S: Real, const M: usize>(a: &[S; M]) -> S {
    dot(a, a).sqrt()
}

/// `a / |a|`, or `None` for a zero or non-finite vector.
pub(crate) fn unit<S: Real, const M: usize>(a: &[S; M]) -> Option<[S; M]> {
    let length = norm(a);
    if length > S::ZERO && length.is_finite() {
        let mut out = *a;
        for o in out.iter_mut() {
            *o = *o / length;
        }
        Some(out)
    } else {
        None
    }
}

/// `x > bound`, false for NaN (so `!exceeds(..)` rejects NaN too).
pub(crate) fn exceeds<S: Real>(x: S, bound: S) -> bool {
    x > bound
}

pub(crate) fn finite<S: Real, const M: usize>(a: &[S; M]) -> bool {
    a.iter().all(|x| x.is_finite())
}

/// The unit basis vector along axis `i` (the zero vector when `i >= M`).
fn basis<S: Real, const M: usize>(i: usize) -> [S; M] {
    let mut out = [S::ZERO; M];
    if let Some(x) = out.get_mut(i) {
        *x = S::ONE;
    }
    out
}

/// A unit vector perpendicular to the unit vector `u` (for `M >= 2`): the basis vector least
/// aligned with `u`, made orthogonal to it.
fn perpendicular<S: Real, const M: usize>(u: &[S; M]) -> [S; M] {
    let mut best = 0;
    for (i, x) in u.iter().enumerate() {
        if x.abs() < u.get(best).map_or(S::ONE, |b| b.abs()) {
            best = i;
        }
    }
    let e = basis::<S, M>(best);
    let v = add_scaled(&e, -dot(&e, u), u);
    unit(&v).unwrap_or(e)
}

/// A rigid motion `x ↦ R x + t` of the task space: where a moving object goes
/// ([`crate::proxy::GodObject::move_object`]), or where a borrowed shape (a mesh or a polytope,
/// whose arrays stay in flash in their own frame) is placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidMotion<S, const M: usize> {
    /// The rotation `R`, by rows: orthonormal, determinant 1.
    pub rotation: [[S; M]; M],
    /// The translation `t`.
    pub translation: [S; M],
}

impl<S: Real, const M: usize> RigidMotion<S, M> {
    /// No motion.
    pub fn identity() -> Self {
        Self::translation([S::ZERO; M])
    }

    /// A translation by `t` alone.
    pub fn translation(translation: [S; M]) -> Self {
        let mut rotation = [[S::ZERO; M]; M];
        for (i, row) in rotation.iter_mut().enumerate() {
            *row = basis(i);
        }
        Self { rotation, translation }
    }

    /// `R v` (a direction or normal moved).
    pub fn rotate(&self, v: &[S; M]) -> [S; M] {
        let mut out = [S::ZERO; M];
        for (o, row) in out.iter_mut().zip(self.rotation.iter()) {
            *o = dot(row, v);
        }
        out
    }

    /// `Rᵀ v` (a direction taken back into the moved shape's own frame).
    pub fn unrotate(&self, v: &[S; M]) -> [S; M] {
        let mut out = [S::ZERO; M];
        for (row, x) in self.rotation.iter().zip(v.iter()) {
            out = add_scaled(&out, *x, row);
        }
        out
    }

    /// `R x + t` (a point moved).
    pub fn apply(&self, x: &[S; M]) -> [S; M] {
        add_scaled(&self.rotate(x), S::ONE, &self.translation)
    }

    /// `Rᵀ (y − t)`: the point that the motion takes to `y`.
    pub fn unapply(&self, y: &[S; M]) -> [S; M] {
        self.unrotate(&sub(y, &self.translation))
    }

    /// This motion followed by `next`: `x ↦ R_next (R x + t) + t_next`.
    pub fn then(&self, next: &Self) -> Self {
        let mut rotation = [[S::ZERO; M]; M];
        for (row, next_row) in rotation.iter_mut().zip(next.rotation.iter()) {
            // Row i of R_next R is (row i of R_next) R = Rᵀ (row i of R_next) as a column.
            *row = self.unrotate(next_row);
        }
        Self { rotation, translation: next.apply(&self.translation) }
    }

    /// `true` when every entry is finite and `R` is a rotation to within `tolerance`:
    /// `|R Rᵀ − I|` at most `tolerance` entry by entry and `det R > 0` (a reflection would turn
    /// solids inside out).
    pub fn is_rigid(&self, tolerance: S) -> bool {
        let entries_finite = self.rotation.iter().all(finite) && finite(&self.translation);
        let orthonormal = self.rotation.iter().enumerate().all(|(i, a)| {
            self.rotation.iter().enumerate().all(|(j, b)| {
                let expected = if i == j { S::ONE } else { S::ZERO };
                !exceeds((dot(a, b) - expected).abs(), tolerance)
            })
        });
        entries_finite && orthonormal && determinant_positive(&self.rotation)
    }
}

/// Where a borrowed shape (a mesh's or a polytope's arrays) is placed: `None` for its own frame.
pub type Placement<S, const M: usize> = Option<RigidMotion<S, M>>;

/// The sign of an orthonormal matrix's determinant (`M` of 1 to 3; for more, the first rows'
/// triple product as in 3-D), `true` when positive.
fn determinant_positive<S: Real, const M: usize>(rows: &[[S; M]; M]) -> bool {
    let entry = |i: usize, j: usize| rows.get(i).and_then(|row| row.get(j)).copied().unwrap_or(S::ZERO);
    let determinant = match M {
        1 => entry(0, 0),
        2 => entry(0, 0) * entry(1, 1) - entry(0, 1) * entry(1, 0),
        _ => {
            entry(0, 0) * (entry(1, 1) * entry(2, 2) - entry(1, 2) * entry(2, 1))
                - entry(0, 1) * (entry(1, 0) * entry(2, 2) - entry(1, 2) * entry(2, 0))
                + entry(0, 2) * (entry(1, 0) * entry(2, 1) - entry(1, 1) * entry(2, 0))
        }
    };
    determinant > S::ZERO
}

/// A plane `n · x = d` bounding a convex polytope `{x : n · x ≤ d}` (`n` unit, outward).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane<S, const M: usize> {
    /// Unit outward normal `n`.
    pub normal: [S; M],
    /// Offset `d`.
    pub offset: S,
}

impl<S: Real, const M: usize> Plane<S, M> {
    /// The plane through `point` with outward normal along `normal` (normalised here);
    /// `None` for a zero or non-finite normal.
    pub fn through(point: &[S; M], normal: &[S; M]) -> Option<Self> {
        let normal = unit(normal)?;
        Some(Self { normal, offset: dot(&normal, point) })
    }
}

/// A node of a mesh's bounding-volume hierarchy (an AABB tree, built with the mesh at build
/// time, see `hapticgen_codegen::mesh`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhNode<S, const M: usize> {
    /// Lower corner of the box bounding every triangle below the node.
    pub min: [S; M],
    /// Upper corner.
    pub max: [S; M],
    /// A leaf (`count > 0`): index of its first face in the mesh's `faces`; an inner node:
    /// index of its first child (the second is the next node).
    pub first: u32,
    /// Number of faces of a leaf; 0 for an inner node.
    pub count: u32,
}

/// A triangle mesh held in borrowed (typically `const`, so in flash) arrays.
#[derive(Clone, Copy, Debug)]
pub struct Mesh<'a, S, const M: usize> {
    /// Vertex positions.
    pub vertices: &'a [[S; M]],
    /// Triangles as vertex indices, ordered so every BVH leaf's faces are contiguous.
    pub faces: &'a [[u32; 3]],
    /// Unit normal of each face, perpendicular to it: used when the query point lies on the
    /// face's plane, and by the god object's sweeps in 3-D to rule a face out by its plane
    /// (a wrong normal there could let the proxy through the face).
    pub face_normals: &'a [[S; M]],
    /// Unit normal of each vertex for force shading; empty for flat faces.
    pub vertex_normals: &'a [[S; M]],
    /// The BVH; node 0 is the root.
    pub nodes: &'a [BvhNode<S, M>],
}

/// The closest point of a triangle `abc` to `p` with its barycentric coordinates.
pub fn closest_on_triangle<S: Real, const M: usize>(
    p: &[S; M],
    a: &[S; M],
    b: &[S; M],
    c: &[S; M],
) -> ([S; M], [S; 3]) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(&ab, &ap);
    let d2 = dot(&ac, &ap);
    if d1 <= S::ZERO && d2 <= S::ZERO {
        return (*a, [S::ONE, S::ZERO, S::ZERO]);
    }
    let bp = sub(p, b);
    let d3 = dot(&ab, &bp);
    let d4 = dot(&ac, &bp);
    if d3 >= S::ZERO && d4 <= d3 {
        return (*b, [S::ZERO, S::ONE, S::ZERO]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= S::ZERO && d1 >= S::ZERO && d3 <= S::ZERO {
        let v = d1 / (d1 - d3);
        return (add_scaled(a, v, &ab), [S::ONE - v, v, S::ZERO]);
    }
    let cp = sub(p, c);
    let d5 = dot(&ab, &cp);
    let d6 = dot(&ac, &cp);
    if d6 >= S::ZERO && d5 <= d6 {
        return (*c, [S::ZERO, S::ZERO, S::ONE]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= S::ZERO && d2 >= S::ZERO && d6 <= S::ZERO {
        let w = d2 / (d2 - d6);
        return (add_scaled(a, w, &ac), [S::ONE - w, S::ZERO, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= S::ZERO && (d4 - d3) >= S::ZERO && (d5 - d6) >= S::ZERO {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add_scaled(b, w, &sub(c, b)), [S::ZERO, S::ONE - w, w]);
    }
    let denominator = va + vb + vc;
    if !exceeds(denominator.abs(), S::ZERO) {
        return (*a, [S::ONE, S::ZERO, S::ZERO]); // A degenerate triangle: any vertex.
    }
    let v = vb / denominator;
    let w = vc / denominator;
    (add_scaled(&add_scaled(a, v, &ab), w, &ac), [S::ONE - v - w, v, w])
}

/// The first `t` in `[0, limit]` at which the point `y + t d` (`d` a unit vector) comes
/// within `margin` (> 0) of the triangle `abc`: the entry of the swept point into the triangle
/// grown by `margin` (a slab over the face, a capsule about each edge, a ball about each
/// vertex; the first entry into their union is the first into one of them). `None` when it
/// stays farther than `margin` up to `limit`; `Some(0)` when `y` is within `margin` already.
///
/// Exact, where conservative advancement (a step to the supporting plane, repeated) takes many
/// steps to reach a surface it approaches at a grazing angle: each piece is the smallest root
/// of `|u + t v|² = margin²` (the distance to the face's plane, an edge's line or a vertex),
/// kept when the point of entry projects onto the piece's own part of the triangle.
pub fn triangle_entry<S: Real, const M: usize>(
    y: &[S; M],
    d: &[S; M],
    limit: S,
    margin: S,
    [a, b, c]: [&[S; M]; 3],
) -> Option<S> {
    let squared_margin = margin * margin;
    // The smallest root in [0, limit] of |u + t v|² = margin², `u` the offset at t = 0. The
    // constant term `|u|² − margin²` and the discriminant `(u · v)² − |v|² (|u|² − margin²)` are
    // formed so that they keep the margin where it is far below `|u|`: as written, in `f32`
    // a margin of 1 µm vanishes against an offset of 5 cm (10⁻¹² against 2.5·10⁻³ is below the
    // rounding of `|u|²`), and the entry came out on the surface itself instead of a margin
    // before it. So: `(|u| − margin)(|u| + margin)`, and with Lagrange's identity
    // `|u|²|v|² − (u · v)² = Σ_{i<j} (u_i v_j − u_j v_i)²` the discriminant is
    // `|v|² margin² − Σ_{i<j} (u_i v_j − u_j v_i)²`, no difference of nearly equal terms.
    let entry = |u: &[S; M], v: &[S; M]| -> Option<S> {
        let distance = norm(u);
        if distance <= margin {
            return Some(S::ZERO);
        }
        let quadratic = dot(v, v);
        let half_linear = dot(u, v);
        if half_linear >= S::ZERO || quadratic <= S::ZERO {
            return None; // Not approaching.
        }
        let constant = (distance - margin) * (distance + margin);
        let mut wedge_squared = S::ZERO;
        for i in 0..M {
            for j in i + 1..M {
                if let (Some(&ui), Some(&uj), Some(&vi), Some(&vj)) = (u.get(i), u.get(j), v.get(i), v.get(j))
                {
                    let area = ui * vj - uj * vi;
                    wedge_squared += area * area;
                }
            }
        }
        let discriminant = quadratic * squared_margin - wedge_squared;
        if discriminant < S::ZERO {
            return None;
        }
        // The entering root, in the form that does not cancel (half_linear < 0).
        let t = constant / (-half_linear + discriminant.sqrt());
        if t <= limit {
            Some(t)
        } else {
            None
        }
    };
    let mut first: Option<S> = None;
    let mut keep = |t: S| {
        if first.map_or(true, |f| t < f) {
            first = Some(t);
        }
    };
    // The face: the offset from the triangle's plane, the in-plane part removed with the
    // Gram matrix of the edges (any dimension; none for a degenerate triangle).
    let (e1, e2) = (sub(b, a), sub(c, a));
    let (g11, g12, g22) = (dot(&e1, &e1), dot(&e1, &e2), dot(&e2, &e2));
    let determinant = g11 * g22 - g12 * g12;
    if determinant > S::ZERO {
        let in_plane = |w: &[S; M]| -> (S, S) {
            let (r1, r2) = (dot(&e1, w), dot(&e2, w));
            ((g22 * r1 - g12 * r2) / determinant, (g11 * r2 - g12 * r1) / determinant)
        };
        let normal_part = |w: &[S; M]| -> [S; M] {
            let (alpha, beta) = in_plane(w);
            add_scaled(&add_scaled(w, -alpha, &e1), -beta, &e2)
        };
        let from_a = sub(y, a);
        if let Some(t) = entry(&normal_part(&from_a), &normal_part(d)) {
            let (alpha, beta) = in_plane(&add_scaled(&from_a, t, d));
            // Entered over the face itself: the first entry (the grown triangle is convex and
            // before `t` the point is farther than `margin` from the face's plane).
            if alpha >= S::ZERO && beta >= S::ZERO && alpha + beta <= S::ONE {
                return Some(t);
            }
        }
    }
    // The edges' capsules: the offset from the edge's line, entered where the point projects
    // onto the segment, else through the ball of the vertex it projects beyond. A ball is
    // tried only for the edge starting at its vertex, when that edge's (infinite) cylinder is
    // entered before the start: the ball lies inside the cylinder of each edge through it, so
    // the point can enter the ball only after the cylinder, and while inside the cylinder it
    // passes the segment's part (the capsule, entered first) before any point projecting
    // beyond the other end; so where a ball is the first entry of all, the cylinder of the
    // edge starting there was entered before its start.
    for (start, end) in [(a, b), (b, c), (c, a)] {
        let edge = sub(end, start);
        let length_squared = dot(&edge, &edge);
        let from_start = sub(y, start);
        if length_squared <= S::ZERO {
            // A degenerate edge: its capsule is the ball.
            if let Some(t) = entry(&from_start, d) {
                keep(t);
            }
            continue;
        }
        let across = |w: &[S; M]| add_scaled(w, -dot(w, &edge) / length_squared, &edge);
        if let Some(t) = entry(&across(&from_start), &across(d)) {
            let along = dot(&add_scaled(&from_start, t, d), &edge) / length_squared;
            if along < S::ZERO {
                if let Some(t) = entry(&from_start, d) {
                    keep(t);
                }
            } else if along <= S::ONE {
                keep(t);
            }
        }
    }
    first
}

/// Squared distance from `p` to the box `[min, max]` (0 inside).
fn box_distance_squared<S: Real, const M: usize>(p: &[S; M], min: &[S; M], max: &[S; M]) -> S {
    let mut sum = S::ZERO;
    for i in 0..M {
        let (x, lo, hi) = match (p.get(i), min.get(i), max.get(i)) {
            (Some(x), Some(lo), Some(hi)) => (*x, *lo, *hi),
            _ => continue,
        };
        let d = if x < lo {
            lo - x
        } else if x > hi {
            x - hi
        } else {
            S::ZERO
        };
        sum += d * d;
    }
    sum
}

/// Where the segment `p + s dir`, `s ∈ [0, length]`, enters the box `[min − r, max + r]`
/// (slab test): the smallest such `s`, or `None` when the segment misses the box.
pub(crate) fn segment_box_entry<S: Real, const M: usize>(
    p: &[S; M],
    dir: &[S; M],
    length: S,
    min: &[S; M],
    max: &[S; M],
    r: S,
) -> Option<S> {
    let mut enter = S::ZERO;
    let mut exit = length;
    for i in 0..M {
        let (x, d, lo, hi) = match (p.get(i), dir.get(i), min.get(i), max.get(i)) {
            (Some(x), Some(d), Some(lo), Some(hi)) => (*x, *d, *lo - r, *hi + r),
            _ => continue,
        };
        if d.abs() > S::ZERO {
            let (a, b) = ((lo - x) / d, (hi - x) / d);
            let (a, b) = if a <= b { (a, b) } else { (b, a) };
            enter = enter.max(a);
            exit = exit.min(b);
            if enter > exit {
                return None;
            }
        } else if x < lo || x > hi {
            return None;
        }
    }
    Some(enter)
}

/// A face's closest point to a query, for [`Mesh::closest`] and the proxy's sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FacePoint<S, const M: usize> {
    /// Index of the face in the mesh's `faces`.
    pub face: usize,
    /// Closest point of the face.
    pub point: [S; M],
    /// Barycentric coordinates of `point`.
    pub barycentric: [S; 3],
}

impl<'a, S: Real, const M: usize> Mesh<'a, S, M> {
    /// The three vertices of face `face`; `None` for an index out of range.
    pub fn triangle(&self, face: usize) -> Option<[[S; M]; 3]> {
        let [i, j, k] = *self.faces.get(face)?;
        Some([
            *self.vertices.get(i as usize)?,
            *self.vertices.get(j as usize)?,
            *self.vertices.get(k as usize)?,
        ])
    }

    /// The faces nearest `p` within `reach`, as many as `out` holds, written to its start as
    /// (distance, face) in ascending order of distance: their number, and the radius of a
    /// ball about `p` they exhaust: every face closer to `p` than it is among them (the nearer
    /// of the nearest face left out and the nearest box not opened; infinite when every face
    /// fits; with `out` filled, no less than the farthest face in it unless the budget ended
    /// the walk). One walk of the BVH ([`Mesh::nearest_first`]) pruned by `reach` and, once
    /// `out` is full, by its farthest face (a box beyond it holds no face for the list; before,
    /// by the nearest face left out), that stops once it has examined `budget` faces (and the
    /// rest of that leaf). The reach and the budget bound the walk where many faces are about
    /// as near as the nearest (from the centre of a spherical cavity the walk would open every
    /// box); the radius can be larger than the reach.
    pub fn nearest_faces(&self, p: &[S; M], reach: S, out: &mut [(S, u32)], budget: usize) -> (usize, S) {
        let infinity = S::from_f64(f64::INFINITY);
        let mut count = 0usize;
        let mut examined = 0usize;
        // Squared, as the walk's bound; the distances in `out` are squared until the end.
        let reach_squared = reach * reach;
        let mut left_out = infinity;
        let unopened = self.nearest_first(
            reach_squared,
            |min, max| box_distance_squared(p, min, max),
            |face| {
                if let Some([a, b, c]) = self.triangle(face) {
                    let (q, _) = closest_on_triangle(p, &a, &b, &c);
                    let offset = sub(p, &q);
                    let squared = dot(&offset, &offset);
                    // In the ascending list after its equals (the first found stay), unless it
                    // is beyond the reach or, with the list full, no nearer than its last.
                    let full = count == out.len();
                    let last = out.get(count.wrapping_sub(1)).map(|&(d, _)| d);
                    let within_reach = squared <= reach_squared; // (false for NaN)
                    if !within_reach || (full && last.map_or(true, |d| squared >= d)) {
                        left_out = left_out.min(squared);
                    } else {
                        let mut slot = count;
                        if full {
                            // The last falls off the end: left out.
                            slot = count.saturating_sub(1);
                            left_out = last.map_or(left_out, |d| left_out.min(d));
                        } else {
                            count += 1;
                        }
                        while slot > 0 {
                            match out.get(slot - 1) {
                                Some(&farther) if farther.0 > squared => {
                                    if let Some(entry) = out.get_mut(slot) {
                                        *entry = farther;
                                    }
                                    slot -= 1;
                                }
                                _ => break,
                            }
                        }
                        if let Some(entry) = out.get_mut(slot) {
                            *entry = (squared, face as u32);
                        }
                    }
                }
                examined += 1;
                if examined >= budget {
                    -infinity
                } else {
                    // With the list full, a box farther than its last face holds none for it.
                    let last = if count == out.len() { out.get(count.wrapping_sub(1)) } else { None };
                    last.map_or(left_out, |&(d, _)| d).min(reach_squared)
                }
            },
        );
        for entry in out.iter_mut().take(count) {
            entry.0 = entry.0.sqrt();
        }
        (count, left_out.min(unopened).sqrt())
    }

    /// Visits the faces nearest first, for a search that keeps a best value and stops where no
    /// box can beat it (branch and bound). `lower_bound(min, max)` bounds from below what any
    /// face in the box can give (infinite: nothing); `visit(face)` considers one face and
    /// returns the best value so far; a node whose lower bound exceeds the best is skipped,
    /// also when it is popped (the best may have improved since it was pushed), and of two
    /// children the one with the smaller lower bound is visited first. Without a BVH every
    /// face is visited. Returns the smallest lower bound of the boxes it did not open
    /// (infinite when it opened every one): a `visit` that returns `−∞` ends the walk, and
    /// this bounds every face it did not visit.
    pub fn nearest_first(
        &self,
        initial_best: S,
        mut lower_bound: impl FnMut(&[S; M], &[S; M]) -> S,
        mut visit: impl FnMut(usize) -> S,
    ) -> S {
        let mut unopened = S::from_f64(f64::INFINITY);
        if self.nodes.is_empty() {
            for face in 0..self.faces.len() {
                let _ = visit(face);
            }
            return unopened;
        }
        let mut best = initial_best;
        // Each entry: a node and the lower bound of its box.
        let mut stack = [(0u32, S::ZERO); BVH_STACK];
        if let (Some(slot), Some(root)) = (stack.get_mut(0), self.nodes.first()) {
            *slot = (0, lower_bound(&root.min, &root.max));
        }
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            // (`match`, not `let … else`: the runtime builds with Rust 1.63.)
            let (index, bound) = match stack.get(depth) {
                Some(&entry) => entry,
                None => break,
            };
            let node = match self.nodes.get(index as usize) {
                Some(node) => node,
                None => continue,
            };
            if bound > best {
                unopened = unopened.min(bound);
                continue;
            }
            if node.count > 0 {
                let first = node.first as usize;
                for face in first..first.saturating_add(node.count as usize).min(self.faces.len()) {
                    best = visit(face);
                }
                continue;
            }
            let children = [node.first, node.first.saturating_add(1)];
            let bounds = children.map(|child| {
                self.nodes
                    .get(child as usize)
                    .map_or(S::from_f64(f64::INFINITY), |n| lower_bound(&n.min, &n.max))
            });
            // The farther child below the nearer one, so that the nearer is popped first.
            let order = if bounds[0] <= bounds[1] { [1, 0] } else { [0, 1] };
            for k in order {
                if bounds[k] <= best && depth < BVH_STACK {
                    if let Some(slot) = stack.get_mut(depth) {
                        *slot = (children[k], bounds[k]);
                        depth += 1;
                    }
                } else {
                    unopened = unopened.min(bounds[k]);
                }
            }
        }
        unopened
    }

    /// The face point closest to `p`, or `None` for an empty mesh ([`Mesh::nearest_first`]
    /// on the squared distance to each box).
    pub fn closest(&self, p: &[S; M]) -> Option<FacePoint<S, M>> {
        let mut best: Option<(S, FacePoint<S, M>)> = None;
        self.nearest_first(
            S::from_f64(f64::INFINITY),
            |min, max| box_distance_squared(p, min, max),
            |face| {
                if let Some([a, b, c]) = self.triangle(face) {
                    let (point, barycentric) = closest_on_triangle(p, &a, &b, &c);
                    let d = dot(&sub(p, &point), &sub(p, &point));
                    if best.map_or(true, |(e, _)| d < e) {
                        best = Some((d, FacePoint { face, point, barycentric }));
                    }
                }
                best.map_or(S::from_f64(f64::INFINITY), |(d, _)| d)
            },
        );
        best.map(|(_, point)| point)
    }

    /// The outward normal at a face point: the vertex normals interpolated with its barycentric
    /// coordinates when the mesh has them (force shading), else the face normal.
    pub fn normal_at(&self, point: &FacePoint<S, M>) -> Option<[S; M]> {
        let face = self.faces.get(point.face)?;
        if !self.vertex_normals.is_empty() {
            let mut n = [S::ZERO; M];
            for (index, weight) in face.iter().zip(point.barycentric.iter()) {
                n = add_scaled(&n, *weight, self.vertex_normals.get(*index as usize)?);
            }
            if let Some(n) = unit(&n) {
                return Some(n);
            }
        }
        self.face_normals.get(point.face).copied()
    }
}

/// A shape's geometry in an `M`-dimensional task space.
#[derive(Clone, Copy, Debug)]
pub enum Shape<'a, S, const M: usize> {
    /// The half-space `n · (x − q) < 0`.
    HalfSpace {
        /// A point `q` of the boundary plane.
        point: [S; M],
        /// Unit outward normal `n` (see [`Shape::half_space`]).
        normal: [S; M],
    },
    /// A ball (a disc in 2-D, a sphere's interior in 3-D).
    Sphere {
        /// Centre.
        center: [S; M],
        /// Radius, > 0 and finite.
        radius: S,
    },
    /// A box with its own orthonormal axes.
    Box {
        /// Centre.
        center: [S; M],
        /// Orthonormal axes (rows); the identity for an axis-aligned box.
        axes: [[S; M]; M],
        /// Half side lengths along the axes, > 0.
        half_extents: [S; M],
    },
    /// The points within `radius` of the segment `ab`.
    Capsule {
        /// One end of the axis.
        a: [S; M],
        /// The other end.
        b: [S; M],
        /// Radius, > 0.
        radius: S,
    },
    /// The points within `radius` of the line `ab` and between the planes through `a` and `b`
    /// perpendicular to it (flat caps).
    Cylinder {
        /// Centre of one cap.
        a: [S; M],
        /// Centre of the other.
        b: [S; M],
        /// Radius, > 0.
        radius: S,
    },
    /// The convex polytope `{x : n_i · x ≤ d_i}` (at least one plane).
    Polytope {
        /// The bounding planes.
        planes: &'a [Plane<S, M>],
    },
    /// A convex polytope moved by `placement` (its planes stay where they are, in their own
    /// frame; [`crate::proxy::GodObject::move_object`] turns a [`Shape::Polytope`] into one).
    PolytopeAt {
        /// The bounding planes, in the polytope's own frame.
        planes: &'a [Plane<S, M>],
        /// Where the polytope's frame is.
        placement: RigidMotion<S, M>,
    },
    /// A triangle mesh (a surface: it has no inside).
    Mesh(&'a Mesh<'a, S, M>),
    /// A triangle mesh moved by `placement`: a mesh placed or moved at run time
    /// ([`crate::proxy::GodObject::move_object`] turns a [`Shape::Mesh`] into one), while its
    /// vertices, normals and BVH stay where they are (in flash, in the mesh's own frame).
    MeshAt {
        /// The mesh, in its own frame.
        mesh: &'a Mesh<'a, S, M>,
        /// Where the mesh's frame is.
        placement: RigidMotion<S, M>,
    },
}

impl<'a, S: Real, const M: usize> Shape<'a, S, M> {
    /// The mesh of a [`Shape::Mesh`] or [`Shape::MeshAt`] and where it is placed (`None` for
    /// the mesh's own frame).
    pub fn placed_mesh(&self) -> Option<(&'a Mesh<'a, S, M>, Placement<S, M>)> {
        match *self {
            Shape::Mesh(mesh) => Some((mesh, None)),
            Shape::MeshAt { mesh, placement } => Some((mesh, Some(placement))),
            _ => None,
        }
    }

    /// The planes of a [`Shape::Polytope`] or [`Shape::PolytopeAt`] and where they are placed
    /// (`None` for their own frame).
    pub fn placed_polytope(&self) -> Option<(&'a [Plane<S, M>], Placement<S, M>)> {
        match *self {
            Shape::Polytope { planes } => Some((planes, None)),
            Shape::PolytopeAt { planes, placement } => Some((planes, Some(placement))),
            _ => None,
        }
    }

    /// The shape after the rigid motion `motion` (see [`RigidMotion`]): points moved, axes and
    /// normals turned; a mesh or a polytope, whose arrays are borrowed, gets (or composes) a
    /// placement. The motion is not checked here ([`RigidMotion::is_rigid`]).
    pub fn moved(&self, motion: &RigidMotion<S, M>) -> Self {
        match *self {
            Shape::HalfSpace { point, normal } => {
                Shape::HalfSpace { point: motion.apply(&point), normal: motion.rotate(&normal) }
            }
            Shape::Sphere { center, radius } => Shape::Sphere { center: motion.apply(&center), radius },
            Shape::Box { center, axes, half_extents } => {
                let mut turned = axes;
                for axis in turned.iter_mut() {
                    *axis = motion.rotate(axis);
                }
                Shape::Box { center: motion.apply(&center), axes: turned, half_extents }
            }
            Shape::Capsule { a, b, radius } => {
                Shape::Capsule { a: motion.apply(&a), b: motion.apply(&b), radius }
            }
            Shape::Cylinder { a, b, radius } => {
                Shape::Cylinder { a: motion.apply(&a), b: motion.apply(&b), radius }
            }
            Shape::Polytope { planes } => Shape::PolytopeAt { planes, placement: *motion },
            Shape::PolytopeAt { planes, placement } => {
                Shape::PolytopeAt { planes, placement: placement.then(motion) }
            }
            Shape::Mesh(mesh) => Shape::MeshAt { mesh, placement: *motion },
            Shape::MeshAt { mesh, placement } => Shape::MeshAt { mesh, placement: placement.then(motion) },
        }
    }
}

/// `p` in the own frame of a shape placed by `placement` (`p` itself for none).
pub(crate) fn into_frame<S: Real, const M: usize>(placement: &Placement<S, M>, p: &[S; M]) -> [S; M] {
    placement.as_ref().map_or(*p, |motion| motion.unapply(p))
}

/// The direction `d` in the own frame of a shape placed by `placement`.
pub(crate) fn direction_into_frame<S: Real, const M: usize>(
    placement: &Placement<S, M>,
    d: &[S; M],
) -> [S; M] {
    placement.as_ref().map_or(*d, |motion| motion.unrotate(d))
}

/// The direction `d`, given in the own frame of a shape placed by `placement`, in the task frame.
pub(crate) fn direction_out_of_frame<S: Real, const M: usize>(
    placement: &Placement<S, M>,
    d: &[S; M],
) -> [S; M] {
    placement.as_ref().map_or(*d, |motion| motion.rotate(d))
}

/// The closest boundary point of a shape to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest<S, const M: usize> {
    /// Closest boundary point.
    pub point: [S; M],
    /// Unit outward normal of the boundary at `point` (for a mesh, the side of the query).
    pub normal: [S; M],
    /// `true` when the query point is strictly inside the shape (never for a mesh).
    pub inside: bool,
}

impl<'a, S: Real, const M: usize> Shape<'a, S, M> {
    /// A half-space through `point` whose outward normal is along `normal` (normalised here);
    /// `None` for a zero or non-finite normal.
    pub fn half_space(point: [S; M], normal: [S; M]) -> Option<Self> {
        Some(Shape::HalfSpace { point, normal: unit(&normal)? })
    }

    /// An axis-aligned box.
    pub fn aligned_box(center: [S; M], half_extents: [S; M]) -> Self {
        let mut axes = [[S::ZERO; M]; M];
        for (i, row) in axes.iter_mut().enumerate() {
            *row = basis(i);
        }
        Shape::Box { center, axes, half_extents }
    }

    /// Closest boundary point to `p` (see the module docs); `None` for a degenerate shape or
    /// a non-finite result. For a query at a sphere's exact centre the boundary point along
    /// `+x1` is returned; for a polytope, the point on the plane the query is farthest outside
    /// of (least deep inside of), the first plane listed on an exact tie.
    pub fn closest(&self, p: &[S; M]) -> Option<Closest<S, M>> {
        let result = match *self {
            Shape::HalfSpace { point, normal } => {
                let height = dot(&normal, &sub(p, &point));
                Closest { point: add_scaled(p, -height, &normal), normal, inside: height < S::ZERO }
            }
            Shape::Sphere { center, radius } => sphere(&center, radius, p)?,
            Shape::Box { center, axes, half_extents } => oriented_box(&center, &axes, &half_extents, p)?,
            Shape::Capsule { a, b, radius } => {
                let axis = sub(&b, &a);
                let length_squared = dot(&axis, &axis);
                let t = if length_squared > S::ZERO {
                    (dot(&sub(p, &a), &axis) / length_squared).clamp_to(S::ZERO, S::ONE)
                } else {
                    S::ZERO
                };
                sphere(&add_scaled(&a, t, &axis), radius, p)?
            }
            Shape::Cylinder { a, b, radius } => cylinder(&a, &b, radius, p)?,
            Shape::Polytope { .. } | Shape::PolytopeAt { .. } => {
                let (planes, placement) = self.placed_polytope()?;
                // The query in the polytope's frame; the point and normal back in the task frame.
                let local = into_frame(&placement, p);
                let mut best: Option<(S, &Plane<S, M>)> = None;
                for plane in planes {
                    let value = dot(&plane.normal, &local) - plane.offset;
                    if best.map_or(true, |(v, _)| value > v) {
                        best = Some((value, plane));
                    }
                }
                let (value, plane) = best?;
                let normal = direction_out_of_frame(&placement, &plane.normal);
                Closest { point: add_scaled(p, -value, &normal), normal, inside: value < S::ZERO }
            }
            Shape::Mesh(_) | Shape::MeshAt { .. } => {
                let (mesh, placement) = self.placed_mesh()?;
                // The query in the mesh's frame; the point and normal back in the task frame.
                let local = into_frame(&placement, p);
                let mut face = mesh.closest(&local)?;
                let shading = direction_out_of_frame(&placement, &mesh.normal_at(&face)?);
                if let Some(motion) = &placement {
                    face.point = motion.apply(&face.point);
                }
                // The side of the surface the query is on.
                let normal = if dot(&shading, &sub(p, &face.point)) < S::ZERO {
                    let mut flipped = shading;
                    for x in flipped.iter_mut() {
                        *x = -*x;
                    }
                    flipped
                } else {
                    shading
                };
                Closest { point: face.point, normal, inside: false }
            }
        };
        if finite(&result.point) && finite(&result.normal) {
            Some(result)
        } else {
            None
        }
    }

    /// Signed distance from `p` to the boundary: negative inside (for a polytope outside, the
    /// largest plane distance, a lower bound of the distance; for a mesh, unsigned).
    pub fn signed_distance(&self, p: &[S; M]) -> Option<S> {
        let closest = self.closest(p)?;
        if let Shape::Polytope { .. } | Shape::PolytopeAt { .. } = self {
            return Some(dot(&closest.normal, &sub(p, &closest.point)));
        }
        let distance = norm(&sub(p, &closest.point));
        Some(if closest.inside { -distance } else { distance })
    }

    /// The point of the shape shrunk by `margin` (its inner parallel body, convex for every
    /// convex shape) closest to `p`: `p` itself when it is inside it. `None` for a polytope, a
    /// half-space and a mesh (flat, so the proxy treats them with planes), or when `margin`
    /// leaves nothing.
    pub fn project_inside(&self, p: &[S; M], margin: S) -> Option<[S; M]> {
        let ball = |center: &[S; M], radius: S| {
            let radius = radius - margin;
            if !exceeds(radius, S::ZERO) {
                return None;
            }
            let offset = sub(p, center);
            let length = norm(&offset);
            if length <= radius {
                Some(*p)
            } else {
                Some(add_scaled(center, radius / length, &offset))
            }
        };
        match *self {
            Shape::Sphere { center, radius } => ball(&center, radius),
            Shape::Capsule { a, b, radius } => {
                let axis = sub(&b, &a);
                let length_squared = dot(&axis, &axis);
                let t = if length_squared > S::ZERO {
                    (dot(&sub(p, &a), &axis) / length_squared).clamp_to(S::ZERO, S::ONE)
                } else {
                    S::ZERO
                };
                ball(&add_scaled(&a, t, &axis), radius)
            }
            Shape::Box { center, axes, half_extents } => {
                let offset = sub(p, &center);
                let mut out = center;
                for (axis, half) in axes.iter().zip(half_extents.iter()) {
                    let h = *half - margin;
                    if !exceeds(h, S::ZERO) {
                        return None;
                    }
                    out = add_scaled(&out, dot(axis, &offset).clamp_to(-h, h), axis);
                }
                Some(out)
            }
            Shape::Cylinder { a, b, radius } => {
                let axis = sub(&b, &a);
                let length = norm(&axis);
                let u = unit(&axis)?;
                let middle = add_scaled(&a, S::from_f64(0.5), &axis);
                let (h, r) = (length * S::from_f64(0.5) - margin, radius - margin);
                if !(h > S::ZERO && r > S::ZERO) {
                    return None;
                }
                let offset = sub(p, &middle);
                let axial = dot(&offset, &u);
                let radial = add_scaled(&offset, -axial, &u);
                let rho = norm(&radial);
                let radial = if rho > r { add_scaled(&[S::ZERO; M], r / rho, &radial) } else { radial };
                let mut out = add_scaled(&middle, axial.clamp_to(-h, h), &u);
                out = add_scaled(&out, S::ONE, &radial);
                Some(out)
            }
            Shape::HalfSpace { .. }
            | Shape::Polytope { .. }
            | Shape::PolytopeAt { .. }
            | Shape::Mesh(_)
            | Shape::MeshAt { .. } => None,
        }
    }
}

fn sphere<S: Real, const M: usize>(center: &[S; M], radius: S, p: &[S; M]) -> Option<Closest<S, M>> {
    if !radius.is_finite() || radius <= S::ZERO {
        return None;
    }
    let offset = sub(p, center);
    let length = dot(&offset, &offset).sqrt();
    let mut point = *center;
    let normal = if length > S::ZERO {
        for (x, o) in point.iter_mut().zip(offset.iter()) {
            *x += *o * (radius / length);
        }
        let mut n = offset;
        for x in n.iter_mut() {
            *x = *x / length;
        }
        n
    } else {
        if let Some(first) = point.first_mut() {
            *first += radius;
        }
        basis(0)
    };
    Some(Closest { point, normal, inside: length < radius })
}

fn oriented_box<S: Real, const M: usize>(
    center: &[S; M],
    axes: &[[S; M]; M],
    half: &[S; M],
    p: &[S; M],
) -> Option<Closest<S, M>> {
    if !half.iter().all(|h| *h > S::ZERO) {
        return None;
    }
    let offset = sub(p, center);
    let mut local = [S::ZERO; M];
    for (l, axis) in local.iter_mut().zip(axes.iter()) {
        *l = dot(axis, &offset);
    }
    let inside = local.iter().zip(half.iter()).all(|(l, h)| l.abs() < *h);
    let mut clamped = local;
    for (c, h) in clamped.iter_mut().zip(half.iter()) {
        *c = c.clamp_to(-*h, *h);
    }
    let mut face_normal = None;
    if inside {
        // Out through the nearest face.
        let mut best: Option<(S, usize)> = None;
        for (i, (l, h)) in local.iter().zip(half.iter()).enumerate() {
            let gap = *h - l.abs();
            if best.map_or(true, |(g, _)| gap < g) {
                best = Some((gap, i));
            }
        }
        let (_, i) = best?;
        let sign = if *local.get(i)? >= S::ZERO { S::ONE } else { -S::ONE };
        *clamped.get_mut(i)? = sign * *half.get(i)?;
        face_normal = Some(add_scaled(&[S::ZERO; M], sign, axes.get(i)?));
    }
    let mut point = *center;
    for (c, axis) in clamped.iter().zip(axes.iter()) {
        point = add_scaled(&point, *c, axis);
    }
    let normal = match face_normal {
        Some(n) => n,
        None => outward(p, &point, axes, &local, half)?,
    };
    Some(Closest { point, normal, inside })
}

/// The outward normal at `point` of a box for a query `p` outside (or on) it.
fn outward<S: Real, const M: usize>(
    p: &[S; M],
    point: &[S; M],
    axes: &[[S; M]; M],
    local: &[S; M],
    half: &[S; M],
) -> Option<[S; M]> {
    if let Some(n) = unit(&sub(p, point)) {
        return Some(n);
    }
    // On the boundary: the face the query is farthest along.
    let mut best: Option<(S, usize)> = None;
    for (i, (l, h)) in local.iter().zip(half.iter()).enumerate() {
        let ratio = l.abs() - *h;
        if best.map_or(true, |(r, _)| ratio > r) {
            best = Some((ratio, i));
        }
    }
    let (_, i) = best?;
    let sign = if *local.get(i)? >= S::ZERO { S::ONE } else { -S::ONE };
    Some(add_scaled(&[S::ZERO; M], sign, axes.get(i)?))
}

fn cylinder<S: Real, const M: usize>(a: &[S; M], b: &[S; M], radius: S, p: &[S; M]) -> Option<Closest<S, M>> {
    if !(radius > S::ZERO && radius.is_finite()) {
        return None;
    }
    let axis = sub(b, a);
    let u = unit(&axis)?;
    let half = norm(&axis) * S::from_f64(0.5);
    let middle = add_scaled(a, S::from_f64(0.5), &axis);
    let offset = sub(p, &middle);
    let axial = dot(&offset, &u);
    let radial = add_scaled(&offset, -axial, &u);
    let rho = norm(&radial);
    let e = if rho > S::ZERO { add_scaled(&[S::ZERO; M], S::ONE / rho, &radial) } else { perpendicular(&u) };
    let axial_sign = if axial >= S::ZERO { S::ONE } else { -S::ONE };
    let inside = axial.abs() < half && rho < radius;
    let (along, out, normal) = if inside {
        if half - axial.abs() < radius - rho {
            (axial_sign * half, rho, add_scaled(&[S::ZERO; M], axial_sign, &u))
        } else {
            (axial, radius, e)
        }
    } else {
        let along = axial.clamp_to(-half, half);
        let out = rho.min(radius);
        let point = add_scaled(&add_scaled(&middle, along, &u), out, &e);
        let normal = match unit(&sub(p, &point)) {
            Some(n) => n,
            None if axial.abs() >= half => add_scaled(&[S::ZERO; M], axial_sign, &u),
            None => e,
        };
        (along, out, normal)
    };
    let point = add_scaled(&add_scaled(&middle, along, &u), out, &e);
    Some(Closest { point, normal, inside })
}

/// What an object feels like in contact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material<S> {
    /// `K_d` in contact, N/m.
    pub stiffness: S,
    /// `B_d` in contact, N·s/m.
    pub damping: S,
    /// Static friction coefficient `μ_s` (the proxy sticks while the device is within the
    /// cone of half-angle `atan μ_s` about the normal), ≥ 0.
    pub static_friction: S,
    /// Dynamic friction coefficient `μ_d` (while sliding, the proxy trails on the cone of
    /// half-angle `atan μ_d`), `0 ≤ μ_d ≤ μ_s`.
    pub dynamic_friction: S,
}

impl<S: Real> Material<S> {
    /// A frictionless material.
    pub fn frictionless(stiffness: S, damping: S) -> Self {
        Self { stiffness, damping, static_friction: S::ZERO, dynamic_friction: S::ZERO }
    }
}

/// One virtual object: geometry, solid or cavity, and material.
#[derive(Clone, Copy, Debug)]
pub struct Object<'a, S, const M: usize> {
    /// Geometry.
    pub shape: Shape<'a, S, M>,
    /// Solid (keep out) or cavity (keep in); a mesh is a surface whichever is set.
    pub kind: crate::render::ObjectKind,
    /// Stiffness, damping and friction.
    pub material: Material<S>,
}

#[cfg(test)]
mod tests {
    use super::*;

    const UNIT_BOX: ([f64; 3], [f64; 3]) = ([0.0; 3], [1.0; 3]);

    /// The slab test's entry parameter, worked out by hand for the box `[0, 1]³` (held-out
    /// cargo-mutants survivors of `segment_box_entry`: the box grown by `r` on the low side
    /// shrunk instead, `(lo − x)/d` multiplied, and a miss `enter > exit` seen only as
    /// `enter == exit`; the proxy's sweep prunes a mesh's BVH with this test).
    #[test]
    fn segment_box_entry_by_hand() {
        let (min, max) = UNIT_BOX;
        // Along +x from x = −1: the box grown by r = 1/8 is entered at x = −1/8, s = 7/8.
        let entry = segment_box_entry(&[-1.0, 0.5, 0.5], &[1.0, 0.0, 0.0], 3.0, &min, &max, 0.125);
        assert_eq!(entry, Some(0.875));
        // Too short to reach it: no entry.
        assert_eq!(segment_box_entry(&[-1.0, 0.5, 0.5], &[1.0, 0.0, 0.0], 0.5, &min, &max, 0.0), None);
        // Obliquely, d = (0.6, 0.8, 0) from (−1, −1): x ≥ 0 from s = 1/0.6 = 5/3, y ≥ 0 from
        // s = 1/0.8 = 1.25 (y ≤ 1 until 2.5): the box is entered at s = 5/3, at y = 1/3.
        let d = [0.6, 0.8, 0.0];
        let entry = segment_box_entry(&[-1.0, -1.0, 0.5], &d, 10.0, &min, &max, 0.0).unwrap();
        assert!((entry - 5.0 / 3.0).abs() < 1e-15, "{entry}");
        // The same direction from (−1, 0.5): y ≤ 1 ends at s = 0.5/0.8 = 0.625, before x ≥ 0
        // begins at 5/3; the line passes over the box's edge and misses it.
        assert_eq!(segment_box_entry(&[-1.0, 0.5, 0.5], &d, 10.0, &min, &max, 0.0), None);
        // Starting inside: entered at once.
        assert_eq!(segment_box_entry(&[0.5, 0.5, 0.5], &d, 10.0, &min, &max, 0.0), Some(0.0));
        // Along +x in the plane of the face y = 0 (no motion in y or z): the closed box is
        // grazed from x = 0, s = 1. (Held-out shard 2/8: `|d| > 0` → `>=` divided 0 by 0 for
        // that face and gave no finite entry.)
        assert_eq!(segment_box_entry(&[-1.0, 0.0, 0.5], &[1.0, 0.0, 0.0], 3.0, &min, &max, 0.0), Some(1.0));
        assert_eq!(segment_box_entry(&[-1.0, 1.0, 1.0], &[1.0, 0.0, 0.0], 3.0, &min, &max, 0.0), Some(1.0));
    }
}
