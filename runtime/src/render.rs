//! Point-based haptic rendering in 2-D (paper, section 4, Fig. 2, eq. (16)).
//!
//! The device point is the HIP (manual proxy); the renderer places the IHIP (virtual proxy),
//! which the impedance law then uses as its reference `x_d`, with the `K_d`, `B_d` of the
//! object touched (or of free space).
//!
//! * **Contact.** An object is *solid* (the HIP is kept out) or a *cavity* (the HIP is kept
//!   in, as Fig. 7 traces a square and a circle from the inside). When the HIP violates an
//!   object, the IHIP is the point of the object's boundary closest to the HIP (eq. (16),
//!   minimum distance), so the spring `K_d (x − x_d)` pushes back along the normal and the
//!   operator can slide along the outline. With several violated objects the deepest
//!   violation wins (on an exact tie, the object added first; corners between two objects are
//!   not treated specially).
//! * **Free space** is collocation, on the **anti-drift grid** of spacing `h` (0.3 mm in the
//!   paper): the IHIP is a grid node. It moves only when the HIP is more than `h` away from it
//!   along either axis (`max(|Δx₁|, |Δx₂|) > h`); it then jumps to the node nearest the HIP
//!   (each coordinate rounded to a multiple of `h`), which is within `h/2` per axis. So a
//!   displacement of up to `h` is held by the spring and the device cannot creep on its own:
//!   with no operator force the spring pulls the HIP towards the node and the IHIP never
//!   moves. The proxy velocity `ẋ_d` is taken as zero throughout (damping acts on `ẋ`).
//! * **Contours** `x2 = f(x1)` over `x1 ∈ [a, b]` bound the region `x2 <= f(x1)`: as a solid,
//!   the HIP is kept above the curve (a floor), as a cavity below it (a ceiling); outside
//!   `[a, b]` they do not act. The closest point minimises eq. (16) with a bounded search:
//!   33 samples, then 100 bisection steps on `d(d²)/dx1 = 0` in the best sample's bracket
//!   (needs `f'`), or exact segment projection for a sampled table.

use crate::control::{ImpedanceParameters, TaskReference};
use crate::Real;

/// A 2-D point or vector `(x1, x2)`.
pub type Point<S> = [S; 2];

/// Number of uniform samples of the closest-point search on a contour function.
const CONTOUR_SAMPLES: usize = 33;
/// Bisection steps of that search.
const CONTOUR_BISECTIONS: usize = 100;

/// A primitive's geometry. `V` bounds the vertices of polygons and the samples of tables.
#[derive(Clone, Copy, Debug)]
pub enum Shape<S, const V: usize> {
    /// A disc.
    Circle {
        /// Centre.
        center: Point<S>,
        /// Radius, > 0.
        radius: S,
    },
    /// A rectangle rotated by `angle` (rad, counter-clockwise) about its centre.
    Rectangle {
        /// Centre.
        center: Point<S>,
        /// Half side lengths along the rectangle's own axes, > 0.
        half_extents: [S; 2],
        /// Rotation, rad.
        angle: S,
    },
    /// A convex polygon with `count` (3 to `V`) vertices in counter-clockwise order.
    ConvexPolygon {
        /// Vertices; only the first `count` are used.
        vertices: [Point<S>; V],
        /// Number of vertices used.
        count: usize,
    },
    /// A contour `x2 = f(x1)` given in closed form with its derivative.
    ContourFunction {
        /// `f`.
        function: fn(S) -> S,
        /// `f'`.
        slope: fn(S) -> S,
        /// `[a, b]`, the `x1` range over which the contour acts.
        x1_range: [S; 2],
    },
    /// A contour `x2 = f(x1)` sampled at `count` (2 to `V`) uniformly spaced `x1` over
    /// `x1_range`, interpolated linearly.
    ContourTable {
        /// `f` at the samples; only the first `count` are used.
        samples: [S; V],
        /// Number of samples used.
        count: usize,
        /// `[a, b]`.
        x1_range: [S; 2],
    },
}

/// Whether an object keeps the HIP out or in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectKind {
    /// The HIP is kept outside.
    Solid,
    /// The HIP is kept inside.
    Cavity,
}

/// The closest boundary point to a query point and whether the query is inside the shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint<S> {
    /// Closest point of the boundary (eq. (16)).
    pub point: Point<S>,
    /// `true` when the query point is strictly inside.
    pub inside: bool,
}

impl<S: Real, const V: usize> Shape<S, V> {
    /// Closest boundary point to `p`; `None` for a degenerate shape, a non-finite result or
    /// (for contours) `p` outside the contour's `x1` range.
    pub fn closest_surface_point(&self, p: &Point<S>) -> Option<SurfacePoint<S>> {
        let result = match *self {
            Shape::Circle { center, radius } => circle(center, radius, p),
            Shape::Rectangle { center, half_extents, angle } => rectangle(center, half_extents, angle, p),
            Shape::ConvexPolygon { vertices, count } => polygon(&vertices, count, p),
            Shape::ContourFunction { function, slope, x1_range } => {
                contour_function(function, slope, x1_range, p)
            }
            Shape::ContourTable { samples, count, x1_range } => contour_table(&samples, count, x1_range, p),
        }?;
        if result.point[0].is_finite() && result.point[1].is_finite() {
            Some(result)
        } else {
            None
        }
    }
}

fn sub<S: Real>(a: &Point<S>, b: &Point<S>) -> Point<S> {
    [a[0] - b[0], a[1] - b[1]]
}

fn norm_squared<S: Real>(a: &Point<S>) -> S {
    a[0] * a[0] + a[1] * a[1]
}

fn circle<S: Real>(center: Point<S>, radius: S, p: &Point<S>) -> Option<SurfacePoint<S>> {
    let valid = radius > S::ZERO;
    if !valid {
        return None;
    }
    let offset = sub(p, &center);
    let distance = norm_squared(&offset).sqrt();
    let direction = if distance > S::ZERO {
        [offset[0] / distance, offset[1] / distance]
    } else {
        [S::ONE, S::ZERO] // At the centre every boundary point is closest; pick +x1.
    };
    Some(SurfacePoint {
        point: [center[0] + radius * direction[0], center[1] + radius * direction[1]],
        inside: distance < radius,
    })
}

fn rectangle<S: Real>(center: Point<S>, half: [S; 2], angle: S, p: &Point<S>) -> Option<SurfacePoint<S>> {
    if !(half[0] > S::ZERO && half[1] > S::ZERO) {
        return None;
    }
    let (sin, cos) = (angle.sin(), angle.cos());
    let offset = sub(p, &center);
    // Into the rectangle's frame (rotate by −angle).
    let local = [cos * offset[0] + sin * offset[1], -sin * offset[0] + cos * offset[1]];
    let inside = local[0].abs() < half[0] && local[1].abs() < half[1];
    let mut closest = [local[0].clamp_to(-half[0], half[0]), local[1].clamp_to(-half[1], half[1])];
    if inside {
        // Push out through the nearest face.
        let gap_x = half[0] - local[0].abs();
        let gap_y = half[1] - local[1].abs();
        if gap_x <= gap_y {
            closest[0] = if local[0] >= S::ZERO { half[0] } else { -half[0] };
        } else {
            closest[1] = if local[1] >= S::ZERO { half[1] } else { -half[1] };
        }
    }
    Some(SurfacePoint {
        point: [
            center[0] + cos * closest[0] - sin * closest[1],
            center[1] + sin * closest[0] + cos * closest[1],
        ],
        inside,
    })
}

/// Closest point of segment `[a, b]` to `p`.
fn closest_on_segment<S: Real>(a: &Point<S>, b: &Point<S>, p: &Point<S>) -> Point<S> {
    let edge = sub(b, a);
    let length_squared = norm_squared(&edge);
    let t = if length_squared > S::ZERO {
        ((p[0] - a[0]) * edge[0] + (p[1] - a[1]) * edge[1]) / length_squared
    } else {
        S::ZERO
    };
    let t = t.clamp_to(S::ZERO, S::ONE);
    [a[0] + t * edge[0], a[1] + t * edge[1]]
}

fn polygon<S: Real, const V: usize>(
    vertices: &[Point<S>; V],
    count: usize,
    p: &Point<S>,
) -> Option<SurfacePoint<S>> {
    let count = count.min(V);
    if count < 3 {
        return None;
    }
    let mut inside = true;
    let mut best: Option<(S, Point<S>)> = None;
    // Each edge (a, b), the last one back to the first vertex; iterated, not indexed: an
    // index `(i + 1) % count` kept a bounds check (a panic path) the optimiser could not
    // remove (found by the STM32F4 device image's panic probe).
    let polygon = vertices.get(..count).unwrap_or(&[]);
    for (a, b) in polygon.iter().zip(polygon.iter().cycle().skip(1)) {
        let cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        if cross <= S::ZERO {
            inside = false;
        }
        let candidate = closest_on_segment(a, b, p);
        let distance = norm_squared(&sub(&candidate, p));
        if best.map_or(true, |(d, _)| distance < d) {
            best = Some((distance, candidate));
        }
    }
    best.map(|(_, point)| SurfacePoint { point, inside })
}

fn contour_function<S: Real>(
    function: fn(S) -> S,
    slope: fn(S) -> S,
    range: [S; 2],
    p: &Point<S>,
) -> Option<SurfacePoint<S>> {
    let [low, high] = range;
    let in_range = low < high && p[0] >= low && p[0] <= high;
    if !in_range {
        return None;
    }
    let distance_squared = |t: S| {
        let dx = t - p[0];
        let dy = function(t) - p[1];
        dx * dx + dy * dy
    };
    // Half the derivative of eq. (16) squared: (t − x1) + (f(t) − x2) f'(t).
    let gradient = |t: S| (t - p[0]) + (function(t) - p[1]) * slope(t);
    let step = (high - low) / S::from_f64((CONTOUR_SAMPLES - 1) as f64);
    let sample = |i: usize| {
        if i + 1 >= CONTOUR_SAMPLES {
            high
        } else {
            low + step * S::from_f64(i as f64)
        }
    };
    let mut best_index = 0;
    let mut best_distance = distance_squared(low);
    for i in 1..CONTOUR_SAMPLES {
        let d = distance_squared(sample(i));
        if d < best_distance {
            best_distance = d;
            best_index = i;
        }
    }
    let mut best_t = sample(best_index);
    let before = sample(best_index.saturating_sub(1));
    let after = sample((best_index + 1).min(CONTOUR_SAMPLES - 1));
    // Refine in the bracket around the best sample, on each side where the gradient changes
    // sign (the minimum may be on either side of the sample). An end where the gradient is
    // exactly zero counts as a change: a neighbouring sample can be a stationary point of the
    // distance (a maximum, such as the bottom of a narrow dip right under the query) with the
    // minimum between it and the best sample.
    for (mut left, mut right) in [(before, best_t), (best_t, after)] {
        if gradient(left) <= S::ZERO && gradient(right) >= S::ZERO {
            for _ in 0..CONTOUR_BISECTIONS {
                let middle = (left + right) * S::from_f64(0.5);
                if gradient(middle) > S::ZERO {
                    right = middle;
                } else {
                    left = middle;
                }
            }
            let t = (left + right) * S::from_f64(0.5);
            let d = distance_squared(t);
            if d < best_distance {
                best_distance = d;
                best_t = t;
            }
        }
    }
    Some(SurfacePoint { point: [best_t, function(best_t)], inside: p[1] < function(p[0]) })
}

fn contour_table<S: Real, const V: usize>(
    samples: &[S; V],
    count: usize,
    range: [S; 2],
    p: &Point<S>,
) -> Option<SurfacePoint<S>> {
    let count = count.min(V);
    let [low, high] = range;
    let in_range = low < high && p[0] >= low && p[0] <= high;
    if count < 2 || !in_range {
        return None;
    }
    let step = (high - low) / S::from_f64((count - 1) as f64);
    let node = |i: usize| [low + step * S::from_f64(i as f64), samples[i]];
    let mut best: Option<(S, Point<S>)> = None;
    let mut height_at_query = samples[0];
    for i in 0..count - 1 {
        let (a, b) = (node(i), node(i + 1));
        if p[0] >= a[0] && p[0] <= b[0] {
            let t = (p[0] - a[0]) / step;
            height_at_query = a[1] + t * (b[1] - a[1]);
        }
        let candidate = closest_on_segment(&a, &b, p);
        let distance = norm_squared(&sub(&candidate, p));
        if best.map_or(true, |(d, _)| distance < d) {
            best = Some((distance, candidate));
        }
    }
    best.map(|(_, point)| SurfacePoint { point, inside: p[1] < height_at_query })
}

/// One virtual object: shape, solid or cavity, and its impedance.
#[derive(Clone, Copy, Debug)]
pub struct VirtualObject<S, const V: usize> {
    /// Geometry.
    pub shape: Shape<S, V>,
    /// Solid (keep out) or cavity (keep in).
    pub kind: ObjectKind,
    /// `K_d` in contact, N/m (1500 in the paper's Fig. 7).
    pub stiffness: S,
    /// `B_d` in contact, N·s/m (5 in Fig. 7).
    pub damping: S,
}

/// The free-space anti-drift grid (see the module docs for the rule).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AntiDriftGrid<S> {
    spacing: S,
    node: Option<Point<S>>,
}

impl<S: Real> AntiDriftGrid<S> {
    /// A grid of the given spacing (m); a non-positive or non-finite spacing disables it
    /// (pure collocation: the IHIP follows the HIP).
    pub fn new(spacing: S) -> Self {
        Self { spacing, node: None }
    }

    /// The current IHIP in free space.
    pub fn node(&self) -> Option<Point<S>> {
        self.node
    }

    /// Updates and returns the IHIP for this HIP.
    pub fn update(&mut self, hip: &Point<S>) -> Point<S> {
        let h = self.spacing;
        if !(h > S::ZERO && h.is_finite()) {
            self.node = Some(*hip);
            return *hip;
        }
        let stays = match self.node {
            Some(node) => (hip[0] - node[0]).abs() <= h && (hip[1] - node[1]).abs() <= h,
            None => false,
        };
        if !stays {
            let snapped = [(hip[0] / h).round() * h, (hip[1] / h).round() * h];
            self.node = Some(snapped);
        }
        self.node.unwrap_or(*hip)
    }
}

/// What the renderer asks of the impedance law this tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOutput<S> {
    /// IHIP `x_p`, to be used as `x_d`.
    pub proxy: Point<S>,
    /// `K_d` in effect (isotropic).
    pub stiffness: [S; 2],
    /// `B_d` in effect.
    pub damping: [S; 2],
    /// Index of the object in contact, `None` in free space.
    pub contact: Option<usize>,
    /// `false` when the HIP was NaN or infinite: the last proxy is kept and the gains are
    /// zero.
    pub valid: bool,
}

/// A fixed-capacity scene of up to `K` objects with polygons/tables of up to `V` points.
#[derive(Clone, Copy, Debug)]
pub struct Scene<S, const K: usize, const V: usize> {
    /// The objects; `None` slots are empty.
    pub objects: [Option<VirtualObject<S, V>>; K],
    /// `K_d` in free space (holds the HIP to the grid node).
    pub free_space_stiffness: S,
    /// `B_d` in free space.
    pub free_space_damping: S,
    grid: AntiDriftGrid<S>,
    last_proxy: Point<S>,
}

impl<S: Real, const K: usize, const V: usize> Scene<S, K, V> {
    /// An empty scene.
    pub fn new(free_space_stiffness: S, free_space_damping: S, grid_spacing: S) -> Self {
        Self {
            objects: [None; K],
            free_space_stiffness,
            free_space_damping,
            grid: AntiDriftGrid::new(grid_spacing),
            last_proxy: [S::ZERO; 2],
        }
    }

    /// Puts `object` in the first free slot; returns its index, or `None` if the scene is full.
    pub fn add(&mut self, object: VirtualObject<S, V>) -> Option<usize> {
        let index = self.objects.iter().position(|slot| slot.is_none())?;
        if let Some(slot) = self.objects.get_mut(index) {
            *slot = Some(object);
        }
        Some(index)
    }

    /// The free-space grid.
    pub fn grid(&self) -> &AntiDriftGrid<S> {
        &self.grid
    }

    /// Places the IHIP for the HIP `hip` (see the module docs).
    pub fn render(&mut self, hip: &Point<S>) -> RenderOutput<S> {
        if !(hip[0].is_finite() && hip[1].is_finite()) {
            return RenderOutput {
                proxy: self.last_proxy,
                stiffness: [S::ZERO; 2],
                damping: [S::ZERO; 2],
                contact: None,
                valid: false,
            };
        }
        let mut deepest: Option<(S, usize, Point<S>)> = None;
        for (index, object) in self.objects.iter().enumerate() {
            let object = match object {
                Some(object) => object,
                None => continue,
            };
            let surface = match object.shape.closest_surface_point(hip) {
                Some(surface) => surface,
                None => continue,
            };
            let violated = match object.kind {
                ObjectKind::Solid => surface.inside,
                ObjectKind::Cavity => !surface.inside,
            };
            if violated {
                let depth = norm_squared(&sub(&surface.point, hip));
                if deepest.map_or(true, |(d, _, _)| depth > d) {
                    deepest = Some((depth, index, surface.point));
                }
            }
        }
        let contact = deepest.and_then(|(_, index, point)| {
            self.objects.get(index).copied().flatten().map(|object| (index, point, object))
        });
        let output = match contact {
            Some((index, point, object)) => RenderOutput {
                proxy: point,
                stiffness: [object.stiffness; 2],
                damping: [object.damping; 2],
                contact: Some(index),
                valid: true,
            },
            None => RenderOutput {
                proxy: self.grid.update(hip),
                stiffness: [self.free_space_stiffness; 2],
                damping: [self.free_space_damping; 2],
                contact: None,
                valid: true,
            },
        };
        self.last_proxy = output.proxy;
        output
    }

    /// [`Scene::render`] written into the impedance law's reference and gains (`M_d` kept).
    pub fn update_reference(
        &mut self,
        hip: &Point<S>,
        parameters: &mut ImpedanceParameters<S, 2>,
    ) -> TaskReference<S, 2> {
        let output = self.render(hip);
        parameters.stiffness = output.stiffness;
        parameters.damping = output.damping;
        TaskReference::at_rest(output.proxy)
    }
}
