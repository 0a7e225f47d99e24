//! Point-based haptic rendering in an `M`-dimensional task space, for rigs whose task point
//! moves in 3-D (the runtime's `hapticgen_runtime::render` is planar): the same rules as the
//! planar renderer, with primitives that exist in any dimension.
//!
//! * **Contact.** An object is *solid* (the HIP is kept out) or a *cavity* (the HIP is kept
//!   in). When the HIP violates an object, the IHIP (the impedance law's reference) is the
//!   closest point of the object's boundary, so the spring `K_d (x − x_d)` pushes back along
//!   the normal and the operator slides along the surface; with several violated objects the
//!   deepest violation wins.
//! * **Free space** is collocation on the anti-drift grid of spacing `h`: the IHIP is a grid
//!   node, and moves (to the node nearest the HIP, every coordinate rounded to a multiple of
//!   `h`) only when the HIP is more than `h` from it along some axis. The proxy velocity is
//!   taken as zero.
//!
//! Everything is fixed-size; nothing allocates or panics.

use hapticgen_runtime::control::{ImpedanceParameters, TaskReference};
use hapticgen_runtime::render::ObjectKind;
use hapticgen_runtime::tick::ReferenceSource;
use hapticgen_runtime::Real;

/// A primitive in `M` dimensions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive<S, const M: usize> {
    /// A ball (a disc in 2-D, a sphere's interior in 3-D).
    Ball {
        /// Centre.
        center: [S; M],
        /// Radius, > 0 and finite.
        radius: S,
    },
    /// The half-space `n · (x − p) < 0` (`n` points out of it, towards free space when solid).
    HalfSpace {
        /// A point `p` of the boundary plane.
        point: [S; M],
        /// Unit outward normal `n` (see [`Primitive::half_space`]).
        normal: [S; M],
    },
}

/// The closest boundary point to a query point and whether the query is strictly inside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface<S, const M: usize> {
    /// Closest boundary point.
    pub point: [S; M],
    /// `true` when the query point is strictly inside the primitive.
    pub inside: bool,
}

fn dot<S: Real, const M: usize>(a: &[S; M], b: &[S; M]) -> S {
    let mut sum = S::ZERO;
    for (x, y) in a.iter().zip(b.iter()) {
        sum += *x * *y;
    }
    sum
}

fn distance_squared<S: Real, const M: usize>(a: &[S; M], b: &[S; M]) -> S {
    let mut sum = S::ZERO;
    for (x, y) in a.iter().zip(b.iter()) {
        let d = *x - *y;
        sum += d * d;
    }
    sum
}

impl<S: Real, const M: usize> Primitive<S, M> {
    /// A half-space through `point` whose outward normal is along `normal` (normalised here);
    /// `None` for a zero or non-finite normal.
    pub fn half_space(point: [S; M], normal: [S; M]) -> Option<Self> {
        let length = dot(&normal, &normal).sqrt();
        if !(length > S::ZERO && length.is_finite()) {
            return None;
        }
        let mut unit = normal;
        for x in unit.iter_mut() {
            *x = *x / length;
        }
        Some(Primitive::HalfSpace { point, normal: unit })
    }

    /// Closest boundary point to `p`; `None` for a degenerate primitive or a non-finite result.
    /// For a query at a ball's exact centre the boundary point along `+x1` is returned.
    pub fn closest_surface_point(&self, p: &[S; M]) -> Option<Surface<S, M>> {
        let surface = match *self {
            Primitive::Ball { center, radius } => {
                if !radius.is_finite() || radius <= S::ZERO {
                    return None;
                }
                let mut offset = [S::ZERO; M];
                for ((o, x), c) in offset.iter_mut().zip(p.iter()).zip(center.iter()) {
                    *o = *x - *c;
                }
                let length = dot(&offset, &offset).sqrt();
                let mut point = center;
                if length > S::ZERO {
                    for (x, o) in point.iter_mut().zip(offset.iter()) {
                        *x += *o * (radius / length);
                    }
                } else if let Some(first) = point.first_mut() {
                    *first += radius;
                }
                Surface { point, inside: length < radius }
            }
            Primitive::HalfSpace { point, normal } => {
                let mut offset = [S::ZERO; M];
                for ((o, x), c) in offset.iter_mut().zip(p.iter()).zip(point.iter()) {
                    *o = *x - *c;
                }
                let height = dot(&normal, &offset);
                let mut foot = *p;
                for (x, n) in foot.iter_mut().zip(normal.iter()) {
                    *x -= height * *n;
                }
                Surface { point: foot, inside: height < S::ZERO }
            }
        };
        if surface.point.iter().all(|x| x.is_finite()) {
            Some(surface)
        } else {
            None
        }
    }
}

/// One virtual object: geometry, solid or cavity, and its impedance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialObject<S, const M: usize> {
    /// Geometry.
    pub shape: Primitive<S, M>,
    /// Solid (keep out) or cavity (keep in).
    pub kind: ObjectKind,
    /// `K_d` in contact, N/m.
    pub stiffness: S,
    /// `B_d` in contact, N·s/m.
    pub damping: S,
}

/// A fixed-capacity scene of up to `K` objects in an `M`-dimensional task space.
#[derive(Clone, Copy, Debug)]
pub struct SpatialScene<S, const K: usize, const M: usize> {
    /// The objects; `None` slots are empty.
    pub objects: [Option<SpatialObject<S, M>>; K],
    /// `K_d` in free space (holds the HIP to the grid node).
    pub free_space_stiffness: S,
    /// `B_d` in free space.
    pub free_space_damping: S,
    grid_spacing: S,
    node: Option<[S; M]>,
    last_proxy: [S; M],
    contact: Option<usize>,
}

impl<S: Real, const K: usize, const M: usize> SpatialScene<S, K, M> {
    /// An empty scene; a non-positive or non-finite grid spacing disables the grid (the IHIP
    /// then follows the HIP in free space).
    pub fn new(free_space_stiffness: S, free_space_damping: S, grid_spacing: S) -> Self {
        Self {
            objects: [None; K],
            free_space_stiffness,
            free_space_damping,
            grid_spacing,
            node: None,
            last_proxy: [S::ZERO; M],
            contact: None,
        }
    }

    /// Puts `object` in the first free slot; returns its index, or `None` if the scene is full.
    pub fn add(&mut self, object: SpatialObject<S, M>) -> Option<usize> {
        let index = self.objects.iter().position(|slot| slot.is_none())?;
        if let Some(slot) = self.objects.get_mut(index) {
            *slot = Some(object);
        }
        Some(index)
    }

    /// The object in contact at the last update, `None` in free space.
    pub fn contact(&self) -> Option<usize> {
        self.contact
    }

    /// The free-space IHIP (grid node) for this HIP.
    fn free_space(&mut self, hip: &[S; M]) -> [S; M] {
        let h = self.grid_spacing;
        if !(h > S::ZERO && h.is_finite()) {
            self.node = Some(*hip);
            return *hip;
        }
        let stays = match &self.node {
            Some(node) => hip.iter().zip(node.iter()).all(|(x, n)| (*x - *n).abs() <= h),
            None => false,
        };
        if !stays {
            let mut snapped = *hip;
            for x in snapped.iter_mut() {
                *x = (*x / h).round() * h;
            }
            self.node = Some(snapped);
        }
        self.node.unwrap_or(*hip)
    }

    /// Places the IHIP for `hip`; returns it with the `K_d`, `B_d` in effect (isotropic), or
    /// `None` for a non-finite HIP (the last IHIP is kept, and the caller zeroes the gains).
    pub fn render(&mut self, hip: &[S; M]) -> Option<([S; M], S, S)> {
        if !hip.iter().all(|x| x.is_finite()) {
            self.contact = None;
            return None;
        }
        let mut deepest: Option<(S, usize, [S; M])> = None;
        for (index, slot) in self.objects.iter().enumerate() {
            let object = match slot {
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
                let depth = distance_squared(&surface.point, hip);
                if deepest.is_none_or(|(d, _, _)| depth > d) {
                    deepest = Some((depth, index, surface.point));
                }
            }
        }
        let contact = deepest.and_then(|(_, index, point)| {
            self.objects.get(index).copied().flatten().map(|object| (index, point, object))
        });
        let (proxy, stiffness, damping) = match contact {
            Some((index, point, object)) => {
                self.contact = Some(index);
                (point, object.stiffness, object.damping)
            }
            None => {
                self.contact = None;
                (self.free_space(hip), self.free_space_stiffness, self.free_space_damping)
            }
        };
        self.last_proxy = proxy;
        Some((proxy, stiffness, damping))
    }
}

impl<S: Real, const K: usize, const M: usize> ReferenceSource<S, M> for SpatialScene<S, K, M> {
    fn update_reference(
        &mut self,
        task_position: &[S; M],
        parameters: &mut ImpedanceParameters<S, M>,
    ) -> TaskReference<S, M> {
        let (proxy, stiffness, damping) =
            self.render(task_position).unwrap_or((self.last_proxy, S::ZERO, S::ZERO));
        parameters.stiffness = [stiffness; M];
        parameters.damping = [damping; M];
        TaskReference::at_rest(proxy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cavity(center: [f64; 3], radius: f64) -> SpatialScene<f64, 2, 3> {
        let mut scene = SpatialScene::new(100.0, 1.0, 1e-3);
        scene
            .add(SpatialObject {
                shape: Primitive::Ball { center, radius },
                kind: ObjectKind::Cavity,
                stiffness: 1500.0,
                damping: 5.0,
            })
            .unwrap();
        scene
    }

    #[test]
    fn ball_surface_point_is_along_the_ray_from_the_centre() {
        let ball = Primitive::Ball { center: [1.0, 2.0, 3.0], radius: 0.5 };
        let p = [1.3, 2.4, 3.0]; // 0.5 from the centre: on the surface
        let s = ball.closest_surface_point(&[1.6, 2.8, 3.0]).unwrap(); // 1.0 out along (0.6, 0.8, 0)
        for (a, b) in s.point.iter().zip(p.iter()) {
            assert!((a - b).abs() < 1e-12);
        }
        assert!(!s.inside);
        assert!(ball.closest_surface_point(&[1.1, 2.0, 3.0]).unwrap().inside);
        assert_eq!(ball.closest_surface_point(&[1.0, 2.0, 3.0]).unwrap().point, [1.5, 2.0, 3.0]);
        assert!(Primitive::Ball { center: [0.0; 3], radius: 0.0 }.closest_surface_point(&p).is_none());
    }

    #[test]
    fn half_space_projects_onto_its_plane() {
        let wall = Primitive::half_space([0.0, 0.0, 1.0], [0.0, 0.0, 2.0]).unwrap();
        let s = wall.closest_surface_point(&[0.3, -0.2, 0.9]).unwrap();
        assert_eq!(s.point, [0.3, -0.2, 1.0]);
        assert!(s.inside);
        assert!(!wall.closest_surface_point(&[0.0, 0.0, 1.5]).unwrap().inside);
        assert!(Primitive::<f64, 3>::half_space([0.0; 3], [0.0; 3]).is_none());
    }

    #[test]
    fn cavity_holds_the_hip_in_with_the_wall_gains() {
        let mut scene = cavity([0.0; 3], 0.01);
        let mut parameters = ImpedanceParameters { stiffness: [0.0; 3], damping: [0.0; 3], mass: [1.0; 3] };
        // Outside, 12 mm along (2, 1, -2)/3: the proxy is on the sphere along the same ray.
        let hip = [0.008, 0.004, -0.008];
        let reference = scene.update_reference(&hip, &mut parameters);
        let length = (hip.iter().map(|x| x * x).sum::<f64>()).sqrt();
        for (x, h) in reference.position.iter().zip(hip.iter()) {
            assert!((x - h * 0.01 / length).abs() < 1e-15);
        }
        assert_eq!(parameters.stiffness, [1500.0; 3]);
        assert_eq!(parameters.damping, [5.0; 3]);
        assert_eq!(scene.contact(), Some(0));
    }

    #[test]
    fn free_space_grid_moves_only_beyond_one_spacing() {
        let mut scene = cavity([0.0; 3], 1.0);
        let mut parameters = ImpedanceParameters { stiffness: [0.0; 3], damping: [0.0; 3], mass: [1.0; 3] };
        let first = scene.update_reference(&[0.0104, 0.0, -0.0021], &mut parameters).position;
        assert_eq!(parameters.stiffness, [100.0; 3]);
        assert_eq!(scene.contact(), None);
        // Nearest node: every coordinate rounded to a multiple of 1 mm.
        let expected = [0.010, 0.0, -0.002];
        for (x, e) in first.iter().zip(expected.iter()) {
            assert!((x - e).abs() < 1e-15);
        }
        // Within one spacing along every axis: the node holds.
        assert_eq!(scene.update_reference(&[0.0109, 0.0009, -0.0029], &mut parameters).position, first);
        // Beyond along one axis: it jumps to the new nearest node.
        let moved = scene.update_reference(&[0.0121, 0.0, -0.002], &mut parameters).position;
        assert!((moved[0] - 0.012).abs() < 1e-15);
        // A NaN HIP keeps the last proxy with zero gains.
        let kept = scene.update_reference(&[f64::NAN, 0.0, 0.0], &mut parameters).position;
        assert_eq!(kept, moved);
        assert_eq!(parameters.stiffness, [0.0; 3]);
    }
}
