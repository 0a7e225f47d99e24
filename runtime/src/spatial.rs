//! The paper's point-based rendering rules (section 4, eq. (16)) in an `M`-dimensional task
//! space, for rigs whose task point moves in 3-D (the planar renderer, with the paper's
//! contours, is [`crate::render`]). Memoryless: for history (thin objects, corners) use the
//! god-object proxy of [`crate::proxy`], which takes the same objects.
//!
//! * **Contact.** An object is *solid* (the HIP is kept out) or a *cavity* (the HIP is kept
//!   in). When the HIP violates an object, the IHIP (the impedance law's reference) is the
//!   closest point of the object's boundary (eq. (16)), so the spring `K_d (x − x_d)` pushes
//!   back along the normal and the operator slides along the surface; with several violated
//!   objects the deepest violation wins (on an exact tie, the object added first). A mesh has
//!   no inside, so it never acts here.
//! * **Free space** is collocation on the anti-drift grid of spacing `h`: the IHIP is a grid
//!   node, and moves (to the node nearest the HIP, every coordinate rounded to a multiple of
//!   `h`) only when the HIP is more than `h` from it along some axis. The proxy velocity is
//!   taken as zero.
//!
//! Everything is fixed-size; nothing allocates or panics.

use crate::control::{ImpedanceParameters, TaskReference};
use crate::render::ObjectKind;
use crate::shape::{sub, Object};
use crate::tick::ReferenceSource;
use crate::Real;

/// A fixed-capacity scene of up to `K` objects in an `M`-dimensional task space, rendered
/// with the minimum-distance rule.
#[derive(Clone, Copy, Debug)]
pub struct MinDistanceScene<'a, S, const K: usize, const M: usize> {
    /// The objects; `None` slots are empty.
    pub objects: [Option<Object<'a, S, M>>; K],
    /// `K_d` in free space (holds the HIP to the grid node).
    pub free_space_stiffness: S,
    /// `B_d` in free space.
    pub free_space_damping: S,
    grid_spacing: S,
    node: Option<[S; M]>,
    last_proxy: [S; M],
    contact: Option<usize>,
}

impl<'a, S: Real, const K: usize, const M: usize> MinDistanceScene<'a, S, K, M> {
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
    pub fn add(&mut self, object: Object<'a, S, M>) -> Option<usize> {
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
            let surface = match object.shape.closest(hip) {
                Some(surface) => surface,
                None => continue,
            };
            let violated = match object.kind {
                ObjectKind::Solid => surface.inside,
                ObjectKind::Cavity => !surface.inside,
            };
            if violated {
                let offset = sub(&surface.point, hip);
                let mut depth = S::ZERO;
                for d in offset.iter() {
                    depth += *d * *d;
                }
                if deepest.map_or(true, |(d, _, _)| depth > d) {
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
                (point, object.material.stiffness, object.material.damping)
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

impl<'a, S: Real, const K: usize, const M: usize> ReferenceSource<S, M> for MinDistanceScene<'a, S, K, M> {
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
