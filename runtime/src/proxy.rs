//! God-object haptic rendering with history (Zilles & Salisbury 1995; Ruspini, Kolarov &
//! Khatib 1997) for 2-D and 3-D task spaces, with friction (Salisbury et al.'s friction cone).
//!
//! The device point is the HIP `x`; the renderer keeps a **proxy** `p` (the god object, a
//! ball of radius `r`) that never enters an object and is used by the impedance law as its
//! reference `x_d`, so the force is `K_d (p − x) − B_d ẋ`. Unlike the paper's minimum-distance
//! rule (eq. (16), [`crate::spatial`] and [`crate::render`]), the proxy remembers which side
//! of each surface it is on: a thin plate cannot be pushed through, and corners and edges
//! where several surfaces meet hold the proxy on all of them at once.
//!
//! # The update (each tick)
//!
//! The proxy moves towards the HIP in at most [`PASSES`] straight **sweeps**. Each sweep goes
//! from `p` towards a goal `g` and stops at the first contact:
//!
//! 1. `g` is the point closest to `x` on the constraints collected in this tick: up to
//!    [`MAX_CONSTRAINTS`] tangent planes `n_i · (y − c_i) ≥ 0` (through the contact points
//!    `c_i`, normals `n_i` pointing into free space) and, for curved cavities, the cavity
//!    shrunk by `r` itself. The planes' part is the small quadratic programme
//!    `min |y − x|²` over the planes, solved exactly by trying every subset of them as
//!    equalities (`G λ = b` with the Gram matrix `G_ij = n_i · n_j`, `b_i = n_i · (x − c_i)`,
//!    `y = x − Σ λ_i n_i`) and keeping the feasible solution closest to `x`. Curved cavities
//!    then project `g` into themselves (exact for one cavity).
//! 2. The sweep is **conservative advancement**: from the current point `y`, every object
//!    gives a step the proxy can certainly take along the direction `d` without coming within
//!    `r + ε` of it (ε, the skin, is the tolerance): for a convex solid and for each triangle
//!    of a mesh, with `q` the closest point and `n = (y − q)/|y − q|`, the supporting plane
//!    gives `s = (|y − q| − r − ε)/(−d · n)` when `d · n < 0` and no limit otherwise (moving
//!    away from a convex set never brings the proxy closer); for a polytope the same for each
//!    of its planes, the union of their outer half-spaces being free; for a flat cavity
//!    (half-space or polytope) the exit through its planes; for a curved cavity (convex from
//!    inside) the exit found by bisection. The proxy moves by the smallest step and repeats;
//!    a step below ε is a contact with that object, whose free-side normal becomes a new
//!    plane. Because each step is certified, **the proxy never crosses a surface**, however
//!    fast the HIP moves: history is the proxy's position itself.
//! 3. A sweep that reaches its goal while constrained starts a new round towards `x` itself
//!    (the tangent planes of curved surfaces are only a local model), until no sweep is left.
//!    The round keeps the planes of flat pieces the proxy still touches (a mesh face met
//!    inside the face, whose constraint is the face's own plane `r + 1.125 ε` off it, and a
//!    half-space): they are no local model. A round that keeps them all ends there, its goal
//!    being the proxy.
//! 4. The next update starts on the constraints this one ended on (after a friction step, on
//!    the flat pieces' planes the proxy touches), so a proxy at rest against surfaces finds its
//!    goal without a sweep.
//!
//! With no contact in the last round the proxy has reached the HIP: free space, the force is
//! zero and the free-space `K_d`, `B_d` apply.
//!
//! # Friction
//!
//! In contact (this tick and the last), with `f` the frictionless proxy found above, `p₀` the
//! previous proxy and `δ = |x − f|` the penetration: the proxy **sticks** (stays at `p₀`) while
//! `|f − p₀| ≤ μ δ`, the HIP within the friction cone about the normal, with `μ = μ_s` when it
//! stuck at the last tick and `μ_d` when it slid; otherwise it **slides** to the point of the
//! segment `f p₀` at `μ_d δ` from `f` (on the dynamic cone), reached by a sweep from `p₀`. Every
//! move of the proxy is towards points no farther from `x` than where it was, so the spring
//! energy `½ K_d |x − p|²` never grows when the proxy moves: the renderer is passive, friction
//! only dissipates.
//!
//! Everything is fixed-size; nothing allocates or panics (a non-finite HIP keeps the last proxy
//! with zero gains).

use crate::control::{ImpedanceParameters, TaskReference};
use crate::effects::{Effect, EffectState};
use crate::linalg::dot;
use crate::render::ObjectKind;
use crate::shape::{
    add_scaled, direction_into_frame, direction_out_of_frame, exceeds, finite, into_frame, norm,
    segment_box_entry, sub, triangle_entry, unit, Mesh, Object, Plane, RigidMotion, Shape,
};
use crate::tick::ReferenceSource;
use crate::Real;

/// The most constraints (tangent planes and curved cavities) one round of sweeps collects; three
/// meet at a corner in 3-D.
pub const MAX_CONSTRAINTS: usize = 3;
/// The most sweeps per update.
pub const PASSES: usize = 8;
/// The most conservative-advancement steps per sweep.
pub const ADVANCE_STEPS: usize = 32;
/// Bisection steps for the exit from a curved cavity.
const BISECTIONS: usize = 48;

/// The most faces, over every mesh of the scene, kept as the candidates that can limit the
/// proxy's sweeps (see `GodObject::gather_candidates`), shared equally among the meshes.
pub const CANDIDATE_FACES: usize = 8;

/// The most faces one gathering examines per mesh (whole BVH leaves; see
/// [`Mesh::nearest_faces`]): from a point about as far from many faces as from the nearest,
/// such as the centre of a spherical cavity, the ball the candidates exhaust is then bounded
/// by the boxes left unopened instead of by a walk through the whole mesh.
const GATHER_BUDGET: usize = 16 * CANDIDATE_FACES;

/// The candidates are gathered within this many times the distance from the proxy to the HIP
/// (and the margin `r + ε`) of the proxy: far enough for this update's sweeps and the next
/// few, near enough that a walk from inside a cavity does not open every box.
const GATHER_REACH: f64 = 4.0;

/// The candidates are gathered again once the proxy has moved this share of the way from the
/// centre they were gathered about to the edge of the ball they certify: the rest is left for
/// the sweeps of the update.
const REGATHER_SHARE: f64 = 0.5;

/// The faces of the scene's meshes nearest the proxy, which can limit its sweeps near where
/// they were gathered (see `GodObject::gather_candidates`).
#[derive(Clone, Copy, Debug)]
struct CandidateCache<S, const K: usize, const M: usize> {
    /// Face indices of every mesh, one range per object, each in ascending order of distance
    /// from its mesh's centre.
    faces: [u32; CANDIDATE_FACES],
    /// Each face's distance from its mesh's centre.
    distances: [S; CANDIDATE_FACES],
    /// Per object, its faces and the ball they exhaust; `None` for an object that is not a mesh.
    balls: [Option<CandidateBall<S, M>>; K],
    /// The proxy they were gathered about, task frame; `None` before the first gathering and
    /// after an object is added.
    gathered_at: Option<[S; M]>,
}

/// One mesh's candidates: every face of the mesh nearer than `radius` to `center` is in the
/// pool's range `start..start + count`.
#[derive(Clone, Copy, Debug)]
struct CandidateBall<S, const M: usize> {
    start: u16,
    count: u16,
    /// The centre, in the task frame (moved with the mesh by `GodObject::move_object`, so the
    /// candidates stay true when it moves).
    center: [S; M],
    /// The radius (infinite when every face of the mesh is in the range).
    radius: S,
    /// The distance from the centre to the nearest candidate, `radius` with none.
    nearest: S,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Constraint<S, const M: usize> {
    /// `flat`: the object and its flat piece (a mesh's face; 0 for a half-space) whose own
    /// plane, just beyond the margin off it, this is (see `GodObject::flat_plane_point`);
    /// `None` for a tangent plane through the proxy.
    Plane {
        normal: [S; M],
        point: [S; M],
        flat: Option<(usize, u32)>,
    },
    Inside {
        object: usize,
    },
}

/// The constraints of a round of sweeps (see `GodObject::constrained_proxy`) and the object
/// in contact.
/// How far one object lets a sweep step go (see `GodObject::safe_step`).
#[derive(Clone, Copy, Debug)]
struct StepLimit<S, const M: usize> {
    /// How far the proxy can certainly move.
    step: S,
    /// The object's free-side normal where the step ends.
    normal: [S; M],
    /// `step` is where the proxy reaches the object's margin, head on: the exact entry (a mesh
    /// face's, a half-space's), not a lower bound of it, at more than the grazing angle. A sweep
    /// stopped by it ends there; another step would only find the proxy on the margin.
    reaches: bool,
}

#[derive(Clone, Copy, Debug)]
struct ActiveSet<S, const M: usize> {
    constraints: [Option<Constraint<S, M>>; MAX_CONSTRAINTS],
    count: usize,
    contact: Option<usize>,
}

impl<S: Real, const M: usize> ActiveSet<S, M> {
    const EMPTY: Self = Self { constraints: [None; MAX_CONSTRAINTS], count: 0, contact: None };
}

/// What the renderer asks of the impedance law this tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProxyOutput<S, const M: usize> {
    /// The proxy `p`, to be used as `x_d`.
    pub proxy: [S; M],
    /// `K_d` in effect (isotropic).
    pub stiffness: S,
    /// `B_d` in effect.
    pub damping: S,
    /// Index of the object in contact, `None` in free space.
    pub contact: Option<usize>,
    /// `true` when friction held the proxy in place this tick.
    pub sticking: bool,
    /// `false` when the HIP was NaN or infinite: the last proxy is kept and the gains are zero.
    pub valid: bool,
    /// The straight sweeps this update made (at most [`PASSES`], and one more for a friction
    /// slide): the renderer's work, for profiling. A proxy at rest against the surfaces it
    /// rested on at the last update makes none.
    pub sweeps: u8,
    /// The steps of conservative advancement those sweeps took (each asks every object how far
    /// the proxy may go: the work within a sweep). A sweep stopped by an exact head-on entry
    /// (a mesh face's, a half-space's) takes one; one that reaches its goal unhindered, one.
    pub steps: u16,
}

/// A god-object renderer of up to `K` objects in an `M`-dimensional task space.
#[derive(Clone, Copy, Debug)]
pub struct GodObject<'a, S, const K: usize, const M: usize> {
    /// The objects; `None` slots are empty (changed only by [`GodObject::add`] and
    /// [`GodObject::move_object`], which keep the candidate faces in step).
    objects: [Option<Object<'a, S, M>>; K],
    /// `K_d` in free space (the proxy is at the HIP there, so this only matters at the moment
    /// of leaving contact).
    pub free_space_stiffness: S,
    /// `B_d` in free space (a viscous field).
    pub free_space_damping: S,
    /// What the operator feels in free space ([`crate::effects`]), applied by the
    /// [`ReferenceSource`] implementation.
    pub effect: Effect<S, M>,
    effect_state: EffectState<S>,
    radius: S,
    skin: S,
    proxy: Option<[S; M]>,
    contact: Option<usize>,
    sticking: bool,
    /// The candidate faces of the meshes.
    candidates: CandidateCache<S, K, M>,
    /// `false` after [`GodObject::search_every_step`].
    keeps_candidates: bool,
    /// The constraints the last update ended on, where the next one starts (see
    /// `GodObject::render`).
    held: ActiveSet<S, M>,
}

impl<'a, S: Real, const K: usize, const M: usize> GodObject<'a, S, K, M> {
    /// An empty scene with a proxy of radius `radius` (≥ 0) and contact tolerance `skin`
    /// (> 0, far below the thinnest object and `radius`; 1 µm suits metres in `f64` and
    /// `f32` alike). The proxy starts at the first HIP rendered, which must be in free space.
    pub fn new(free_space_stiffness: S, free_space_damping: S, radius: S, skin: S) -> Self {
        Self {
            objects: [None; K],
            free_space_stiffness,
            free_space_damping,
            effect: Effect::None,
            effect_state: EffectState::default(),
            radius: radius.max(S::ZERO),
            skin,
            proxy: None,
            contact: None,
            sticking: false,
            candidates: CandidateCache {
                faces: [0; CANDIDATE_FACES],
                distances: [S::ZERO; CANDIDATE_FACES],
                balls: [None; K],
                gathered_at: None,
            },
            keeps_candidates: true,
            held: ActiveSet::EMPTY,
        }
    }

    /// Puts `object` in the first free slot; returns its index, or `None` if the scene is full.
    pub fn add(&mut self, object: Object<'a, S, M>) -> Option<usize> {
        let index = self.objects.iter().position(|slot| slot.is_none())?;
        if let Some(slot) = self.objects.get_mut(index) {
            *slot = Some(object);
        }
        self.candidates.gathered_at = None;
        self.held = ActiveSet::EMPTY;
        Some(index)
    }

    /// Keeps no candidate faces: every sweep step searches each mesh's BVH (slower; the
    /// reference the candidates are checked against, and a baseline for benches).
    pub fn search_every_step(&mut self) {
        self.keeps_candidates = false;
        self.candidates.balls = [None; K];
        self.candidates.gathered_at = None;
    }

    /// The proxy, `None` before the first update.
    pub fn proxy(&self) -> Option<[S; M]> {
        self.proxy
    }

    /// Puts the proxy at `position` (which must be in free space) and forgets the contact.
    pub fn reset(&mut self, position: [S; M]) {
        self.proxy = Some(position);
        self.contact = None;
        self.sticking = false;
        self.held = ActiveSet::EMPTY;
    }

    /// Puts the proxy at a free-space point near `hip`, for a scene set up while the device is
    /// already where its objects are (a device's scene arrives over the link wherever the
    /// grip is): `hip` itself when it is clear of every object; out of a solid, onto its
    /// surface plus the proxy's radius and twice the skin along the surface's outward normal;
    /// into a cavity, to its nearest point that far inside. The objects are taken one at a
    /// time in slot order, so where they overlap the point may end inside another; a mesh
    /// (a surface) moves it only when it is within the margin. The operator then feels the
    /// object at once, pushed out along its normal, instead of nothing until the device leaves
    /// it ([`GodObject::new`]'s first HIP must be in free space).
    pub fn start_in_free_space(&mut self, hip: &[S; M]) {
        let margin = self.radius + self.skin + self.skin;
        let mut point = *hip;
        for object in self.objects.iter().flatten() {
            match object.kind {
                ObjectKind::Solid => {
                    if let Some(closest) = object.shape.closest(&point) {
                        if closest.inside || !exceeds(norm(&sub(&point, &closest.point)), margin) {
                            point = add_scaled(&closest.point, margin, &closest.normal);
                        }
                    }
                }
                ObjectKind::Cavity => {
                    if let Some(inside) = object.shape.project_inside(&point, margin) {
                        point = inside;
                    }
                }
            }
        }
        if finite(&point) {
            self.reset(point);
        }
    }

    /// The proxy's radius.
    pub fn radius(&self) -> S {
        self.radius
    }

    /// Moves object `index` by the rigid motion `motion` (a moving object, updated each tick
    /// before [`GodObject::render`]); a proxy in contact with it is carried along, as if the
    /// object pushed or dragged it. A mesh or a polytope (borrowed arrays) becomes a
    /// [`Shape::MeshAt`] or [`Shape::PolytopeAt`]. `false`, and nothing moved, for an empty
    /// slot or a motion that is not rigid to within 10⁻⁶ ([`RigidMotion::is_rigid`]: a
    /// non-finite entry, a rotation that is not orthonormal or a reflection).
    pub fn move_object(&mut self, index: usize, motion: &RigidMotion<S, M>) -> bool {
        if !motion.is_rigid(S::from_f64(1e-6)) {
            return false;
        }
        let object = match self.objects.get_mut(index).and_then(|slot| slot.as_mut()) {
            Some(object) => object,
            None => return false,
        };
        object.shape = object.shape.moved(motion);
        // The planes held from the last update are where the object was.
        self.held = ActiveSet::EMPTY;
        // The candidates stay true, about their centre moved with the mesh.
        if let Some(ball) = self.candidates.balls.get_mut(index).and_then(|b| b.as_mut()) {
            ball.center = motion.apply(&ball.center);
        }
        if self.contact == Some(index) {
            if let Some(p) = self.proxy.as_mut() {
                *p = motion.apply(p);
            }
        }
        true
    }

    /// Updates the proxy for the HIP `hip` (see the module docs).
    pub fn render(&mut self, hip: &[S; M]) -> ProxyOutput<S, M> {
        let previous = match self.proxy {
            Some(p) if finite(hip) => p,
            Some(p) => return self.invalid(p),
            None if finite(hip) => *hip,
            None => return self.invalid([S::ZERO; M]),
        };
        self.gather_candidates(&previous, hip);
        let mut active = self.held;
        let mut steps = 0u16;
        let (frictionless, mut sweeps) = self.constrained_proxy(&previous, hip, &mut active, &mut steps);
        let contact = active.contact;
        let mut proxy = frictionless;
        let mut sticking = false;
        if let (Some(index), Some(_)) = (contact, self.contact) {
            if let Some(object) = self.objects.get(index).copied().flatten() {
                let material = object.material;
                let depth = norm(&sub(hip, &frictionless));
                let slide = norm(&sub(&frictionless, &previous));
                let mu = if self.sticking { material.static_friction } else { material.dynamic_friction };
                if slide <= mu * depth {
                    proxy = previous;
                    sticking = true;
                } else if material.dynamic_friction > S::ZERO && slide > S::ZERO {
                    // On the dynamic cone: μ_d δ from f towards p₀, reached by a sweep from p₀.
                    let back = (material.dynamic_friction * depth / slide).min(S::ONE);
                    let target = add_scaled(&frictionless, back, &sub(&previous, &frictionless));
                    let travel = sub(&target, &previous);
                    let length = norm(&travel);
                    proxy = previous;
                    if let Some(direction) = unit(&travel) {
                        let (s, _) = self.sweep(&previous, &direction, length, &mut [None; K], &mut steps);
                        sweeps += 1;
                        proxy = add_scaled(&previous, s, &direction);
                    }
                }
            }
        }
        self.proxy = Some(proxy);
        self.contact = contact;
        self.sticking = sticking;
        // The next update starts on the constraints this one ended on, as long as the proxy is
        // where they hold it (a friction step leaves it elsewhere): a proxy resting against
        // faces or in a corner finds its goal at once instead of meeting each surface again.
        if proxy != frictionless {
            // Friction left the proxy off the frictionless one: of the planes it ended on, those
            // of flat pieces hold wherever it touches them.
            let (constraints, count) = self.still_touched(&active.constraints, &proxy);
            active = ActiveSet { constraints, count, contact: active.contact };
        }
        self.held = active;
        let (stiffness, damping) = match contact.and_then(|i| self.objects.get(i).copied().flatten()) {
            Some(object) => (object.material.stiffness, object.material.damping),
            None => (self.free_space_stiffness, self.free_space_damping),
        };
        ProxyOutput { proxy, stiffness, damping, contact, sticking, valid: true, sweeps, steps }
    }

    /// The faces of each mesh nearest the proxy `p₀`, found with one BVH walk per mesh
    /// ([`Mesh::nearest_faces`]) and kept from update to update, so that a sweep step near
    /// `p₀` checks a few faces instead of searching the BVH. With `c` the centre they were
    /// gathered about and `R` the radius they exhaust (every face nearer than `R` to `c` is
    /// among them), a step from `y` whose segment stays within `R − r − ε` of `c` cannot come
    /// within `r + ε` of any other face (the triangle inequality), so the candidates decide
    /// it; a step that would leave that ball searches the BVH (see `GodObject::safe_step`).
    /// Gathered again about `p₀` once `p₀` has gone [`REGATHER_SHARE`] of the way from `c` to
    /// the ball's edge, and after an object is added.
    fn gather_candidates(&mut self, previous: &[S; M], hip: &[S; M]) {
        if !self.keeps_candidates {
            return;
        }
        let margin = self.radius + self.skin;
        let cache = &self.candidates;
        let keep = cache.gathered_at.map_or(false, |at| {
            at == *previous
                || cache.balls.iter().flatten().all(|ball| {
                    let from_center = norm(&sub(previous, &ball.center));
                    !exceeds(from_center, (ball.radius - margin) * S::from_f64(REGATHER_SHARE))
                })
        });
        if keep {
            return;
        }
        // This update's sweeps stay within `ρ = |x − p₀|` of the HIP `x` (each goal is the point
        // nearest `x` on constraints the proxy satisfies, a friction slide ends between the
        // frictionless proxy and `p₀`), so within `2ρ` of `p₀`: twice that, for later updates.
        let reach = margin + self.skin + S::from_f64(GATHER_REACH) * norm(&sub(hip, previous));
        let meshes = self.objects.iter().flatten().filter(|o| o.shape.placed_mesh().is_some()).count();
        let share = CANDIDATE_FACES / meshes.max(1);
        let mut used = 0usize;
        let cache = &mut self.candidates;
        for (slot, ball) in self.objects.iter().zip(cache.balls.iter_mut()) {
            *ball = None;
            if let Some((mesh, placement)) = slot.as_ref().and_then(|o| o.shape.placed_mesh()) {
                let mut nearest = [(S::ZERO, 0u32); CANDIDATE_FACES];
                let found = nearest.get_mut(..share).unwrap_or(&mut []);
                let (count, radius) =
                    mesh.nearest_faces(&into_frame(&placement, previous), reach, found, GATHER_BUDGET);
                let pool = cache.faces.iter_mut().zip(cache.distances.iter_mut()).skip(used);
                for ((face, distance), &(d, f)) in pool.zip(nearest.iter().take(count)) {
                    *face = f;
                    *distance = d;
                }
                // `used + count` ≤ CANDIDATE_FACES, far below `u16::MAX`.
                let nearest = if count > 0 { nearest.first().map_or(radius, |&(d, _)| d) } else { radius };
                *ball = Some(CandidateBall {
                    start: used as u16,
                    count: count as u16,
                    center: *previous,
                    radius,
                    nearest,
                });
                used += count;
            }
        }
        cache.gathered_at = Some(*previous);
    }

    fn invalid(&mut self, proxy: [S; M]) -> ProxyOutput<S, M> {
        self.contact = None;
        self.sticking = false;
        self.held = ActiveSet::EMPTY;
        ProxyOutput {
            proxy,
            stiffness: S::ZERO,
            damping: S::ZERO,
            contact: None,
            sticking: false,
            valid: false,
            sweeps: 0,
            steps: 0,
        }
    }

    /// The frictionless proxy reached from `start` towards `hip` in a round that begins with the
    /// constraints `active` holds (the last update's); `active` ends with the constraints of the
    /// last round and the object in contact. Also the number of sweeps made; `steps` counts
    /// their steps.
    fn constrained_proxy(
        &self,
        start: &[S; M],
        hip: &[S; M],
        active: &mut ActiveSet<S, M>,
        steps: &mut u16,
    ) -> ([S; M], u8) {
        let mut p = *start;
        let mut sweeps = 0u8;
        let ActiveSet { constraints, count, contact } = active;
        // Per object, the face of a mesh that limited its last step (see `GodObject::safe_step`).
        let mut faces_met = [None; K];
        for _ in 0..PASSES {
            let goal = self.goal(&p, hip, constraints);
            let travel = sub(&goal, &p);
            let length = norm(&travel);
            let direction = match unit(&travel) {
                Some(direction) if length > self.skin => direction,
                _ => {
                    if *count == 0 {
                        p = goal; // At the HIP (or within the skin of it).
                        *contact = None;
                    }
                    break;
                }
            };
            let before = p;
            let (s, hit) = self.sweep(&p, &direction, length, &mut faces_met, steps);
            sweeps += 1;
            p = if hit.is_none() { goal } else { add_scaled(&p, s, &direction) };
            match hit {
                None if *count == 0 => {
                    *contact = None; // Reached the HIP: free space.
                    break;
                }
                None => {
                    // Reached the constrained goal: a new round towards the HIP, on the planes
                    // of flat pieces (mesh faces, half-spaces) the proxy still touches (their
                    // planes are no local model, and a goal on them that the sweep reached is
                    // where the proxy stays while it touches them). With all of them kept, the
                    // next goal would be this one: the proxy is there. The last round's contact
                    // stands until this one ends in free space or in a contact of its own: the
                    // pass limit can end it before its first sweep, with the proxy still held
                    // off the HIP.
                    let (kept, kept_count) = self.still_touched(constraints, &p);
                    if kept_count > 0 && kept_count == *count {
                        break;
                    }
                    *constraints = kept;
                    *count = kept_count;
                }
                Some((index, normal)) => {
                    if *count == 0 {
                        *contact = Some(index); // The first contact of the round.
                    }
                    let curved_cavity = self.objects.get(index).copied().flatten().map_or(false, |o| {
                        o.kind == ObjectKind::Cavity
                            && matches!(
                                o.shape,
                                Shape::Sphere { .. }
                                    | Shape::Box { .. }
                                    | Shape::Capsule { .. }
                                    | Shape::Cylinder { .. }
                            )
                    });
                    let face = faces_met.get(index).copied().flatten();
                    let new = if curved_cavity {
                        Constraint::Inside { object: index }
                    } else {
                        match self.flat_plane_point(index, face, &normal) {
                            Some(point) => {
                                Constraint::Plane { normal, point, flat: Some((index, face.unwrap_or(0))) }
                            }
                            None => Constraint::Plane { normal, point: p, flat: None },
                        }
                    };
                    // The same plane or cavity again replaces the old one.
                    let same = constraints.iter().position(|c| match (c, &new) {
                        (Some(Constraint::Plane { normal: a, .. }), Constraint::Plane { normal: b, .. }) => {
                            dot(a, b) > S::ONE - same_plane_tolerance::<S>()
                        }
                        (Some(Constraint::Inside { object: a }), Constraint::Inside { object: b }) => a == b,
                        _ => false,
                    });
                    match same {
                        // Stopped where it started by the constraint it already had: the next
                        // pass would repeat this one exactly (same proxy, same constraints, same
                        // goal), and so would every later one, so the passes left change nothing.
                        Some(i) if constraints.get(i) == Some(&Some(new)) && p == before => break,
                        Some(i) => {
                            if let Some(slot) = constraints.get_mut(i) {
                                *slot = Some(new);
                            }
                        }
                        None if *count < MAX_CONSTRAINTS => {
                            if let Some(slot) = constraints.get_mut(*count) {
                                *slot = Some(new);
                            }
                            *count += 1;
                        }
                        None => break, // More surfaces than a corner: stay.
                    }
                }
            }
        }
        // A round ended by the pass limit while constrained, or before its first sweep, is
        // still in contact.
        (p, sweeps)
    }

    /// For a contact on a flat piece of object `index`, inside face `face` of a mesh (where the
    /// contact's `normal` is the face's own, see `entered_normal`) or on a half-space, a point of
    /// the plane `r + 1.125 ε` off it on the free side: the constraint's plane is then the same
    /// at every contact with the piece, where a plane through the proxy would stand anywhere
    /// within the skin of it (and rounds of sweeps between two faces' planes could then creep
    /// along them, a skin at a time). An eighth of a skin beyond the margin `r + ε`: a goal on
    /// the margin itself left the proxy a few 10⁻⁸ m inside it by rounding (`f32`), where the
    /// rounded edge of the coplanar face next to the one it rests on stopped its slide at once.
    /// `None` on a mesh's edge or vertex (another normal) and for other shapes.
    fn flat_plane_point(&self, index: usize, face: Option<u32>, normal: &[S; M]) -> Option<[S; M]> {
        let margin = self.radius + self.skin * S::from_f64(1.125);
        let shape = self.objects.get(index).copied().flatten()?.shape;
        if let Shape::HalfSpace { point, normal: outward } = shape {
            let parallel = *normal == outward || *normal == negate(&outward);
            return parallel.then(|| add_scaled(&point, margin, normal));
        }
        let face = face?;
        let (mesh, placement) = shape.placed_mesh()?;
        let face_normal = direction_out_of_frame(&placement, mesh.face_normals.get(face as usize)?);
        if *normal != face_normal && *normal != negate(&face_normal) {
            return None;
        }
        let [a, _, _] = mesh.triangle(face as usize)?;
        let a = placement.as_ref().map_or(a, |motion| motion.apply(&a));
        Some(add_scaled(&a, margin, normal))
    }

    /// Of `constraints`, those on flat pieces (see `GodObject::flat_plane_point`) that `p` still
    /// touches, with their number: within a skin of the plane, and for a mesh's face within the
    /// margin and two skins of the face itself (past its edge the plane is no longer the
    /// surface).
    fn still_touched(
        &self,
        constraints: &[Option<Constraint<S, M>>; MAX_CONSTRAINTS],
        p: &[S; M],
    ) -> ([Option<Constraint<S, M>>; MAX_CONSTRAINTS], usize) {
        let mut kept = [None; MAX_CONSTRAINTS];
        let mut count = 0;
        for constraint in constraints.iter().flatten() {
            let (normal, point, index, face) = match constraint {
                Constraint::Plane { normal, point, flat: Some((index, face)) } => {
                    (normal, point, *index, *face)
                }
                _ => continue,
            };
            if exceeds(dot(normal, &sub(p, point)).abs(), self.skin) {
                continue;
            }
            let shape = self.objects.get(index).copied().flatten().map(|o| o.shape);
            let on_the_face = match shape.as_ref().and_then(|shape| shape.placed_mesh()) {
                Some((mesh, placement)) => mesh.triangle(face as usize).map_or(false, |[a, b, c]| {
                    let y = into_frame(&placement, p);
                    let (closest, _) = crate::shape::closest_on_triangle(&y, &a, &b, &c);
                    !exceeds(norm(&sub(&y, &closest)), self.radius + self.skin * S::from_f64(2.0))
                }),
                None => true,
            };
            if on_the_face {
                if let Some(slot) = kept.get_mut(count) {
                    *slot = Some(*constraint);
                    count += 1;
                }
            }
        }
        (kept, count)
    }

    /// The point closest to `hip` on the constraints (see the module docs), `p` when none of
    /// the candidate solutions is feasible.
    fn goal(
        &self,
        p: &[S; M],
        hip: &[S; M],
        constraints: &[Option<Constraint<S, M>>; MAX_CONSTRAINTS],
    ) -> [S; M] {
        let mut planes: [([S; M], [S; M]); MAX_CONSTRAINTS] = [([S::ZERO; M], [S::ZERO; M]); MAX_CONSTRAINTS];
        let mut k = 0;
        for c in constraints.iter().flatten() {
            if let Constraint::Plane { normal, point, .. } = c {
                if let Some(slot) = planes.get_mut(k) {
                    *slot = (*normal, *point);
                    k += 1;
                }
            }
        }
        let mut goal = project_on_planes(hip, planes.get(..k).unwrap_or(&[]), self.skin).unwrap_or(*p);
        for c in constraints.iter().flatten() {
            if let Constraint::Inside { object } = c {
                if let Some(object) = self.objects.get(*object).copied().flatten() {
                    let margin = self.radius + self.skin * S::from_f64(1.5);
                    goal = object.shape.project_inside(&goal, margin).unwrap_or(goal);
                }
            }
        }
        goal
    }

    /// Conservative advancement from `p` along the unit `direction` for up to `length`: the
    /// distance travelled and, if stopped short, the object hit with its free-side normal.
    ///
    /// `faces_met` holds, per object, the mesh face that limited its last step, which its next
    /// step checks first (see `GodObject::safe_step`); kept from sweep to sweep of an update.
    /// `steps` counts the steps taken.
    fn sweep(
        &self,
        p: &[S; M],
        direction: &[S; M],
        length: S,
        faces_met: &mut [Option<u32>; K],
        steps: &mut u16,
    ) -> (S, Option<(usize, [S; M])>) {
        let mut s = S::ZERO;
        let mut last = None;
        for _ in 0..ADVANCE_STEPS {
            *steps = steps.saturating_add(1);
            let y = add_scaled(p, s, direction);
            let remaining = length - s;
            let mut step = remaining;
            let mut hit = None;
            let mut reaches = false;
            for ((index, slot), face_met) in self.objects.iter().enumerate().zip(faces_met.iter_mut()) {
                if let Some(object) = slot {
                    if let Some(limit) = self.safe_step(index, object, &y, direction, step, face_met) {
                        if limit.step < step {
                            step = limit.step;
                            hit = Some((index, limit.normal));
                            reaches = limit.reaches;
                        }
                    }
                }
            }
            match hit {
                None => return (length, None),
                Some(_) if step <= self.skin => return (s, hit),
                Some(_) if reaches => return (s + step, hit),
                Some(_) => {
                    s += step;
                    last = hit;
                }
            }
        }
        (s, last)
    }

    /// How far the proxy can certainly move from `y` along `d` (up to `limit`) without
    /// coming within `r + ε` of `object`, with the free-side normal there and whether the step
    /// reaches the margin exactly (see `StepLimit`); `None` when the object does not limit it
    /// (or is degenerate). For a mesh, `face_met` is a face to check
    /// first (the one that limited the last step, likely to limit this one: its step then rules
    /// most of the others out by their planes alone; the answer does not depend on the order),
    /// and becomes the face that limits this step.
    fn safe_step(
        &self,
        index: usize,
        object: &Object<'a, S, M>,
        y: &[S; M],
        d: &[S; M],
        limit: S,
        face_met: &mut Option<u32>,
    ) -> Option<StepLimit<S, M>> {
        let margin = self.radius + self.skin;
        let half_skin = self.skin * S::from_f64(0.5);
        let solid = object.kind == ObjectKind::Solid;
        match object.shape {
            Shape::Mesh(_) | Shape::MeshAt { .. } => {
                // The candidates (see `gather_candidates`): a step that stays nearer their
                // centre than the nearest of them (or the ball's edge) less the margin meets
                // none of the mesh's faces.
                let ball = self.candidates.balls.get(index).copied().flatten();
                // `|y − c|`, task frame (where the centre is kept).
                let ball_offset = ball.map_or(S::ZERO, |ball| norm(&sub(y, &ball.center)));
                if ball.map_or(false, |ball| ball_offset + limit + margin + self.skin < ball.nearest) {
                    return None;
                }
                let (task_y, task_d) = (y, d);
                let (mesh, placement) = object.shape.placed_mesh()?;
                // The sweep in the mesh's frame; the normal found back in the task frame.
                let y = &into_frame(&placement, y);
                let d = &direction_into_frame(&placement, d);
                let infinity = S::from_f64(f64::INFINITY);
                // The best so far: its step, its face, the offset from that face at `y`, and
                // whether the step is the face's exact entry.
                let consider = |best: &mut Option<(S, usize, [S; M], bool)>, face: usize| {
                    // After a face met at once, only a face before it in the mesh can win.
                    if let Some((b, f, _, _)) = *best {
                        if b <= S::ZERO && face > f {
                            return b;
                        }
                    }
                    if let Some([a, b, c]) = mesh.triangle(face) {
                        let bound = best.map_or(limit, |(b, _, _, _)| b);
                        if M == 3
                            && beyond_the_face_plane(mesh.face_normals.get(face), y, d, &a, bound, margin)
                        {
                            return bound;
                        }
                        let (q, _) = crate::shape::closest_on_triangle(y, &a, &b, &c);
                        let offset = sub(y, &q);
                        let distance = norm(&offset);
                        let gap = distance - margin;
                        // The supporting plane's step is a lower bound of the entry: a face
                        // it puts at or beyond the best so far cannot limit the sweep, and
                        // a face within the margin limits it now (or never, receding). Only
                        // the faces left get the exact entry into the triangle grown by the
                        // margin (one query where conservative advancement approaches a
                        // surface met at a grazing angle in many). No grazing allowance for
                        // them: the exact entry decides, and the bound must stay a lower bound
                        // of it. A proxy resting on the face (within the margin) and sweeping
                        // along it gets the allowance of the other shapes (`convex_step`): its
                        // direction, projected onto the face's plane, comes out a few ulps
                        // towards the face as often as away, and without the allowance it
                        // could not slide.
                        // The unit offset (`unit`, without a second square root).
                        let n = if distance > S::ZERO && distance.is_finite() {
                            Some(offset.map(|x| x / distance))
                        } else {
                            None
                        };
                        let step = match n {
                            Some(n) if gap > S::ZERO => {
                                if convex_step(gap, dot(d, &n), bound, S::ZERO) >= bound {
                                    None
                                } else {
                                    triangle_entry(y, d, bound, margin, [&a, &b, &c]).map(|t| (t, true))
                                }
                            }
                            // Against the sweep's whole length, not the best so far: a face
                            // met at the same step as the best is then found whichever
                            // comes first.
                            // Within the margin, a face stops the proxy half a skin inside
                            // it whatever the angle (not only grazing): a proxy left a few
                            // 10⁻⁸ m inside the margin by rounding (`f32`) and sliding over a
                            // flat part of the mesh approaches, at a shallow angle, the rounded
                            // edge of the coplanar face next to the one it rests on, and would
                            // otherwise be stopped there at once.
                            Some(n) => {
                                let step = convex_step(gap, dot(d, &n), limit, half_skin);
                                (step < limit).then_some((step, false))
                            }
                            None => Some((S::ZERO, false)),
                        };
                        // Of faces met at the same step, the first in the mesh: the answer does
                        // not depend on the order they are visited in.
                        if let Some((step, entry)) = step {
                            if best.map_or(step < limit, |(b, f, _, _)| step < b || (step == b && face < f)) {
                                *best = Some((step, face, offset, entry));
                            }
                        }
                    }
                    best.map_or(limit, |(b, _, _, _)| b)
                };
                // This update's candidates decide the step while it stays in their ball (see
                // `gather_candidates`), nearest first: a face at `D` from the centre is at
                // least `D − |y − c| − s` from the point `s` along, so once that stays above
                // the margin up to beyond the best step so far, it and every farther face are out.
                let mut best: Option<(S, usize, [S; M], bool)> = None;
                let mut decided = false;
                if let Some(ball) = ball {
                    // (In the task frame, where the centre is kept.)
                    let from_center = sub(task_y, &ball.center);
                    if let Some(exit) = ball_exit(&from_center, task_d, ball.radius - margin - self.skin) {
                        let offset = ball_offset;
                        let (start, count) = (usize::from(ball.start), usize::from(ball.count));
                        let range = self.candidates.faces.iter().zip(self.candidates.distances.iter());
                        if let Some(face) = *face_met {
                            consider(&mut best, face as usize);
                        }
                        for (&face, &distance) in range.skip(start).take(count) {
                            let bound = best.map_or(limit, |(b, _, _, _)| b);
                            if distance - offset - margin - self.skin > bound {
                                break;
                            }
                            if Some(face) != *face_met {
                                consider(&mut best, face as usize);
                            }
                        }
                        decided = best.map_or(limit, |(b, _, _, _)| b) <= exit;
                    }
                }
                // Else the BVH, nearest first along the segment: a box the segment enters
                // beyond the best step so far cannot limit it.
                if !decided {
                    best = None;
                    let search = |face: usize| consider(&mut best, face);
                    mesh.nearest_first(
                        limit,
                        |min, max| segment_box_entry(y, d, limit, min, max, margin).unwrap_or(infinity),
                        search,
                    );
                }
                let (step, face, offset, entry) = best?;
                // (`face` < the mesh's face count, which `u32` indexes.)
                *face_met = Some(face as u32);
                let normal = entered_normal(mesh, face, y, d, step, &offset);
                let reaches = entry && dot(d, &normal) < -S::from_f64(GRAZING);
                Some(StepLimit { step, normal: direction_out_of_frame(&placement, &normal), reaches })
            }
            Shape::HalfSpace { point, normal } => {
                let n = if solid { normal } else { negate(&normal) };
                let gap = dot(&n, &sub(y, &point)) - margin;
                let rate = dot(d, &n);
                // A plane's step is its exact entry, unless grazing or already within the margin.
                let reaches = gap > S::ZERO && rate < -S::from_f64(GRAZING);
                Some(StepLimit { step: convex_step(gap, rate, limit, half_skin), normal: n, reaches })
            }
            Shape::Polytope { .. } | Shape::PolytopeAt { .. } => {
                let (planes, placement) = object.shape.placed_polytope()?;
                // The sweep in the polytope's frame; the normal found back in the task frame.
                let (y, d) = (into_frame(&placement, y), direction_into_frame(&placement, d));
                let (step, normal) = if solid {
                    solid_polytope_step(planes, &y, &d, limit, margin, self.skin)?
                } else {
                    polytope_cavity_step(planes, &y, &d, limit, margin, half_skin)?
                };
                Some(StepLimit { step, normal: direction_out_of_frame(&placement, &normal), reaches: false })
            }
            _ if solid => {
                let closest = object.shape.closest(y)?;
                let offset = sub(y, &closest.point);
                let (distance, normal) = if closest.inside {
                    (-norm(&offset), closest.normal)
                } else {
                    (norm(&offset), unit(&offset).unwrap_or(closest.normal))
                };
                let step = convex_step(distance - margin, dot(d, &normal), limit, half_skin);
                Some(StepLimit { step, normal, reaches: false })
            }
            _ => {
                // A curved cavity: the exit from its (convex) inner parallel body.
                let inside = |z: &[S; M]| object.shape.signed_distance(z).map_or(false, |sd| sd <= -margin);
                let normal = negate(&object.shape.closest(y)?.normal);
                if inside(&add_scaled(y, limit, d)) {
                    return Some(StepLimit { step: limit, normal, reaches: false });
                }
                if !inside(y) {
                    return Some(StepLimit { step: S::ZERO, normal, reaches: false });
                }
                let (mut low, mut high) = (S::ZERO, limit);
                for _ in 0..BISECTIONS {
                    if high - low <= self.skin * S::from_f64(0.5) {
                        break;
                    }
                    let middle = (low + high) * S::from_f64(0.5);
                    if inside(&add_scaled(y, middle, d)) {
                        low = middle;
                    } else {
                        high = middle;
                    }
                }
                let normal = negate(&object.shape.closest(&add_scaled(y, low, d))?.normal);
                Some(StepLimit { step: low, normal, reaches: false })
            }
        }
    }
}

/// The free-side normal where a sweep from `y` along the unit `d` meets face `face` after
/// `step` (`offset`: from the face's closest point to `y`): where the closest point lies inside
/// the face, the face's own normal on the proxy's side (exact: a face is flat, so the same face
/// gives the same plane at every contact, which the offset's direction, a difference of nearly
/// equal coordinates when the proxy rests within the skin, would not); on an edge or a vertex,
/// from the closest point to the proxy; with the proxy on the face itself, the face's normal
/// turned against the sweep; else `−d`.
fn entered_normal<S: Real, const M: usize>(
    mesh: &Mesh<'_, S, M>,
    face: usize,
    y: &[S; M],
    d: &[S; M],
    step: S,
    offset: &[S; M],
) -> [S; M] {
    let face_normal = mesh.face_normals.get(face).filter(|n| finite(n));
    let (entered, inside_the_face) = match mesh.triangle(face) {
        Some([a, b, c]) => {
            let z = add_scaled(y, step, d);
            let (closest, barycentric) = crate::shape::closest_on_triangle(&z, &a, &b, &c);
            (sub(&z, &closest), barycentric.iter().all(|&w| w > S::ZERO))
        }
        None => (*offset, false),
    };
    match face_normal {
        Some(n) if inside_the_face && dot(n, &entered) > S::ZERO => return *n,
        Some(n) if inside_the_face && dot(n, &entered) < S::ZERO => return negate(n),
        _ => {}
    }
    unit(&entered).unwrap_or_else(|| match face_normal {
        Some(n) if dot(n, d) <= S::ZERO => *n,
        Some(n) => negate(n),
        None => negate(d),
    })
}

/// How far the ray `c + f + s d` (`d` a unit vector, `f` its start relative to the centre
/// `c`) stays within the ball of radius `radius` about `c`: the larger root of
/// `|f + s d|² = radius²`; infinite for an infinite radius, `None` when the start is outside.
fn ball_exit<S: Real, const M: usize>(f: &[S; M], d: &[S; M], radius: S) -> Option<S> {
    let infinity = S::from_f64(f64::INFINITY);
    if radius == infinity {
        return Some(infinity);
    }
    let outside = dot(f, f) - radius * radius;
    if !(radius >= S::ZERO && outside <= S::ZERO) {
        return None;
    }
    let along = dot(f, d);
    Some(-along + (along * along - outside).sqrt())
}

/// `true` when a sweep from `y` along the unit `d` cannot come within `margin` of a triangle
/// (through `a`, with the unit `normal` of a 3-D mesh's face) before `bound`: the distance to
/// a triangle is at least the distance `|n · (z − a)|` to its plane, which the sweep brings
/// down to `margin` no sooner than `(|h| − margin)/rate`, `h = n · (y − a)`, and never if it
/// moves away from the plane or along it. A cheap test before the triangle's closest point;
/// `false` (decide by the triangle) without a finite normal.
fn beyond_the_face_plane<S: Real, const M: usize>(
    normal: Option<&[S; M]>,
    y: &[S; M],
    d: &[S; M],
    a: &[S; M],
    bound: S,
    margin: S,
) -> bool {
    let normal = match normal {
        Some(n) if finite(n) => n,
        _ => return false,
    };
    let height = dot(normal, &sub(y, a));
    let rate = dot(normal, d);
    // Towards the plane from the side `y` is on: the height falls at `approach` per metre.
    let (height, approach) = if height >= S::ZERO { (height, -rate) } else { (-height, rate) };
    if !exceeds(height, margin) {
        return false;
    }
    approach <= S::ZERO || (height - margin) >= bound * approach
}

/// The safe step from `y` along `d` (up to `limit`) outside a solid polytope of `planes`, with
/// the free-side normal, all in the polytope's frame (see [`GodObject::safe_step`]).
fn solid_polytope_step<S: Real, const M: usize>(
    planes: &[Plane<S, M>],
    y: &[S; M],
    d: &[S; M],
    limit: S,
    margin: S,
    skin: S,
) -> Option<(S, [S; M])> {
    // Free while outside any one plane: the longest step any plane allows. A plane the proxy is
    // inside of (beyond the skin) allows nothing, whatever the direction: moving along or away
    // from it does not take the proxy outside it now, and only being outside a plane keeps it
    // out of the polytope. Of planes allowing the same step (no step at all, when the proxy
    // rests on the polytope and moves into it), the one it is least inside of, the face it
    // rests on, gives the normal: not the first plane listed, whose constraint would hold a
    // proxy resting on a tilted face where it first touched.
    let half_skin = skin * S::from_f64(0.5);
    let mut best: Option<(S, S, [S; M])> = None;
    for plane in planes {
        let gap = dot(&plane.normal, y) - plane.offset - margin;
        let rate = dot(d, &plane.normal);
        let step = if gap > -skin { convex_step(gap, rate, limit, half_skin) } else { S::ZERO };
        if best.map_or(true, |(b, g, _)| step > b || (step == b && gap > g)) {
            best = Some((step, gap, plane.normal));
        }
    }
    best.map(|(step, _, normal)| (step, normal))
}

/// The safe step from `y` along `d` (up to `limit`) inside a polytope cavity of `planes`, with
/// the free-side normal, all in the polytope's frame: free while inside every plane, the
/// shortest step any plane allows.
fn polytope_cavity_step<S: Real, const M: usize>(
    planes: &[Plane<S, M>],
    y: &[S; M],
    d: &[S; M],
    limit: S,
    margin: S,
    half_skin: S,
) -> Option<(S, [S; M])> {
    let mut best: Option<(S, [S; M])> = None;
    for plane in planes {
        let n = negate(&plane.normal);
        let gap = dot(&n, y) + plane.offset - margin;
        let step = convex_step(gap, dot(d, &n), limit, half_skin);
        if best.map_or(true, |(b, _)| step < b) {
            best = Some((step, n));
        }
    }
    best
}

fn negate<S: Real, const M: usize>(v: &[S; M]) -> [S; M] {
    let mut out = *v;
    for x in out.iter_mut() {
        *x = -*x;
    }
    out
}

/// How close to 1 the dot product of two unit normals is for one plane: 10⁻⁹, or in a scalar
/// too coarse for it (`f32`, where `1 − 10⁻⁹` rounds to 1, and two equal normals' computed dot
/// product can fall an ulp short of 1, so the same plane met again took a new slot) 10⁻⁶.
fn same_plane_tolerance<S: Real>() -> S {
    let fine = S::from_f64(1e-9);
    if S::ONE - fine < S::ONE {
        fine
    } else {
        S::from_f64(1e-6)
    }
}

/// `|d · n|` at most this is a grazing sweep (within 0.06° of the surface's tangent plane).
const GRAZING: f64 = 1e-3;

/// The step along a direction with rate `rate = d · n` towards a convex obstacle whose
/// supporting plane is `gap` away along `−n`: unlimited when moving away (`rate ≥ 0`), else
/// `gap / −rate`; 0 when already within the margin. A grazing sweep may go on into the outer
/// half of the skin (down to `gap = −skin/2`): a proxy resting on a surface (gap 0) slides
/// along it towards a goal projected onto its tangent plane, whose direction rounding leaves
/// a few ulps below the plane as often as above it (read as approaching, it could not move).
fn convex_step<S: Real>(gap: S, rate: S, limit: S, half_skin: S) -> S {
    if rate >= S::ZERO {
        return limit;
    }
    let allowance = if rate >= -S::from_f64(GRAZING) { gap + half_skin } else { gap };
    if allowance <= S::ZERO {
        S::ZERO
    } else {
        (allowance / -rate).min(limit)
    }
}

/// The point closest to `x` satisfying `n_i · (y − c_i) ≥ 0` for every plane `(n_i, c_i)`:
/// each subset of the planes is tried as equalities, the feasible solution closest to `x`
/// kept; `None` if none is feasible (within `tolerance`).
pub fn project_on_planes<S: Real, const M: usize>(
    x: &[S; M],
    planes: &[([S; M], [S; M])],
    tolerance: S,
) -> Option<[S; M]> {
    let k = planes.len().min(MAX_CONSTRAINTS);
    let mut best: Option<(S, [S; M])> = None;
    for mask in 0u32..(1u32 << k) {
        let mut chosen = [0usize; MAX_CONSTRAINTS];
        let mut size = 0;
        for (i, slot) in (0..k).filter(|i| mask & (1 << i) != 0).zip(0..) {
            if let Some(c) = chosen.get_mut(slot) {
                *c = i;
                size = slot + 1;
            }
        }
        let candidate = match equality_projection(x, planes, chosen.get(..size).unwrap_or(&[])) {
            Some(y) => y,
            None => continue,
        };
        let feasible = planes.iter().all(|(n, c)| dot(n, &sub(&candidate, c)) >= -tolerance);
        let distance = norm(&sub(&candidate, x));
        if feasible && best.map_or(true, |(d, _)| distance < d) {
            best = Some((distance, candidate));
        }
    }
    best.map(|(_, y)| y)
}

/// `x − Σ λ_i n_i` on the planes `chosen` as equalities (`G λ = b`, Cramer's rule); `None`
/// for (nearly) dependent normals.
fn equality_projection<S: Real, const M: usize>(
    x: &[S; M],
    planes: &[([S; M], [S; M])],
    chosen: &[usize],
) -> Option<[S; M]> {
    let mut normals = [[S::ZERO; M]; MAX_CONSTRAINTS];
    let mut b = [S::ZERO; MAX_CONSTRAINTS];
    for (slot, &i) in chosen.iter().enumerate() {
        let (n, c) = planes.get(i)?;
        *normals.get_mut(slot)? = *n;
        *b.get_mut(slot)? = dot(n, &sub(x, c));
    }
    let g = |i: usize, j: usize| match (normals.get(i), normals.get(j)) {
        (Some(a), Some(b)) => dot(a, b),
        _ => S::ZERO,
    };
    let singular = S::from_f64(1e-10);
    let lambda: [S; MAX_CONSTRAINTS] = match chosen.len() {
        0 => return Some(*x),
        1 => [b[0] / g(0, 0), S::ZERO, S::ZERO],
        2 => {
            let det = g(0, 0) * g(1, 1) - g(0, 1) * g(1, 0);
            if !exceeds(det.abs(), singular) {
                return None;
            }
            [(b[0] * g(1, 1) - g(0, 1) * b[1]) / det, (g(0, 0) * b[1] - b[0] * g(1, 0)) / det, S::ZERO]
        }
        3 => {
            let m = [[g(0, 0), g(0, 1), g(0, 2)], [g(1, 0), g(1, 1), g(1, 2)], [g(2, 0), g(2, 1), g(2, 2)]];
            let det3 = |m: &[[S; 3]; 3]| {
                m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                    - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                    + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
            };
            let det = det3(&m);
            if !exceeds(det.abs(), singular) {
                return None;
            }
            let mut lambda = [S::ZERO; 3];
            for (column, l) in lambda.iter_mut().enumerate() {
                let mut replaced = m;
                for (r, value) in replaced.iter_mut().zip(b.iter()) {
                    if let Some(x) = r.get_mut(column) {
                        *x = *value;
                    }
                }
                *l = det3(&replaced) / det;
            }
            lambda
        }
        _ => return None,
    };
    let mut y = *x;
    for (n, l) in normals.iter().zip(lambda.iter()).take(chosen.len()) {
        y = add_scaled(&y, -*l, n);
    }
    if finite(&y) {
        Some(y)
    } else {
        None
    }
}

impl<'a, S: Real, const K: usize, const M: usize> ReferenceSource<S, M> for GodObject<'a, S, K, M> {
    fn update_reference(
        &mut self,
        task_position: &[S; M],
        parameters: &mut ImpedanceParameters<S, M>,
    ) -> TaskReference<S, M> {
        let output = self.render(task_position);
        let (reference, stiffness, damping) = if output.valid && output.contact.is_none() {
            self.effect_state.apply(&self.effect, task_position, output.stiffness, output.damping)
        } else {
            (output.proxy, output.stiffness, output.damping)
        };
        parameters.stiffness = [stiffness; M];
        parameters.damping = [damping; M];
        TaskReference::at_rest(reference)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    /// `ball_exit` by hand (a ray from the centre, from a point on the edge going in and going
    /// out, a start outside, a negative radius, an infinite ball) and against bisection on
    /// `|f + s d| ≤ radius` for random starts inside balls and random directions (held-out
    /// cargo-mutants survivors: the function replaced by `None`, the discriminant's sign, the
    /// inside test inverted, the root's terms combined wrongly; the candidate faces' test against
    /// a BVH search did not see them, because its steps rarely reach the ball's edge).
    #[test]
    fn ball_exit_is_where_a_ray_leaves_the_ball() {
        let close = |a: Option<f64>, b: f64| a.map_or(false, |a| (a - b).abs() < 1e-12);
        assert!(close(ball_exit(&[0.0; 3], &[1.0, 0.0, 0.0], 2.0), 2.0));
        assert!(close(ball_exit(&[0.0, 0.0, -2.0], &[0.0, 0.0, 1.0], 2.0), 4.0));
        assert!(close(ball_exit(&[0.0, 0.0, 2.0], &[0.0, 0.0, 1.0], 2.0), 0.0));
        assert!(close(ball_exit(&[0.5, 0.0], &[0.0, 1.0], 1.0), 0.75f64.sqrt()));
        assert_eq!(ball_exit(&[3.0, 0.0, 0.0], &[-1.0, 0.0, 0.0], 2.0), None);
        assert_eq!(ball_exit(&[0.0; 3], &[1.0, 0.0, 0.0], -1.0), None);
        assert_eq!(ball_exit(&[5.0, 0.0, 0.0], &[1.0, 0.0, 0.0], f64::INFINITY), Some(f64::INFINITY));
        let mut rng = SmallRng::seed_from_u64(17);
        for case in 0..2000 {
            let radius = rng.gen_range(0.01..2.0);
            let direction = loop {
                let v: [f64; 3] =
                    [rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)];
                if let Some(u) = unit(&v) {
                    break u;
                }
            };
            let start: [f64; 3] =
                [rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)];
            let start = start.map(|x| x * radius * 0.57); // inside: |start| ≤ 0.99 radius
            let inside = |s: f64| norm(&add_scaled(&start, s, &direction)) <= radius;
            let (mut low, mut high) = (0.0, 2.0 * radius);
            for _ in 0..200 {
                let middle = 0.5 * (low + high);
                if inside(middle) {
                    low = middle;
                } else {
                    high = middle;
                }
            }
            let exit = ball_exit(&start, &direction, radius);
            assert!(close(exit, low), "case {case}: {exit:?}, bisection {low}");
        }
    }
}
