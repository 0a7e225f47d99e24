//! What every image with a host link runs besides the link itself: the reference its
//! controller follows, fixed, a planar scene (a 2-D task) or a spatial one (a 3-D task) whose
//! objects come over the link ([`LinkSource`]), what the device answers for each object
//! ([`object_outcome`]), and the device's [`DeviceInfo`] ([`device_info`]). Used by the QEMU
//! board's PIL and device images and by the STM32F4 board's device image, so that the host's
//! `SetObject` means the same on every board.

use hapticgen_protocol::{
    rig_name_hash, ChannelScales, DeviceInfo, LinkEffect, SceneObject, SceneOutcome, MAX_TASK,
    PROTOCOL_VERSION,
};
use hapticgen_runtime::control::{ImpedanceParameters, TaskReference};
use hapticgen_runtime::effects::{Effect, EffectState};
use hapticgen_runtime::proxy::GodObject;
use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};
use hapticgen_runtime::shape::{self, Material, Object};
use hapticgen_runtime::tick::ReferenceSource;
use hapticgen_runtime::Real;

/// Scene objects a link image holds (the slots `SetObject` may name).
pub const SCENE_OBJECTS: usize = hapticgen_protocol::SCENE_SLOTS;

/// Points of a polygon or table in the scene's objects (boxes are drawn as rectangles).
pub const SCENE_VERTICES: usize = 8;

/// The god object's contact tolerance in a spatial link scene, m (1 µm, as the self-contained
/// images' `scene_contact`).
pub const SPATIAL_SKIN: f32 = 1e-6;

/// The reference of a link image: fixed, a planar scene rendered on the device (a 2-D task:
/// the runtime's proxy renderer with its anti-drift grid, as the self-contained images'
/// `wall_contact` and the host's simulator run it), or a spatial scene (a 3-D task: the
/// runtime's god object with a point proxy, as the self-contained images' `scene_contact`).
// One instance, in a static-sized controller: no heap on the device, so no box for the scene.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy)]
pub enum Reference<const M: usize> {
    /// A fixed reference.
    Fixed(TaskReference<f32, M>),
    /// A planar scene.
    Scene(Scene<f32, SCENE_OBJECTS, SCENE_VERTICES>),
    /// A spatial scene (`M = 3`). Its proxy starts at the first device point rendered, moved
    /// out of the objects the point is in (`GodObject::start_in_free_space`).
    Spatial(GodObject<'static, f32, SCENE_OBJECTS, M>),
}

/// [`Reference`] and the last reference position it gave (sent back to the host).
#[derive(Clone, Copy)]
pub struct LinkSource<const M: usize> {
    /// The reference.
    pub reference: Reference<M>,
    /// The last reference position.
    pub last: [f32; M],
    /// What a scene renders while the point touches none of its objects.
    effect: Effect<f32, M>,
    effect_state: EffectState<f32>,
}

impl<const M: usize> LinkSource<M> {
    /// The reference at rest at `position` when no scene is asked for (`grid` is `None`), else
    /// the scene of `objects` with `impedance`'s first axis as the free space's stiffness and
    /// damping: on a 2-D task the planar scene with the anti-drift grid `grid` (m), on a 3-D
    /// task the god object (no grid). `None` for a scene on a task of another dimension, an
    /// object [`object_outcome`] does not answer `Rendered` for, a negative or non-finite grid,
    /// or more objects than the scene holds.
    pub fn new(
        position: [f32; M],
        impedance: &ImpedanceParameters<f32, MAX_TASK>,
        objects: &[SceneObject; SCENE_OBJECTS],
        grid: Option<f32>,
    ) -> Option<Self> {
        let fixed = TaskReference::at_rest(position);
        let reference = match grid {
            None => Reference::Fixed(fixed),
            Some(grid) => {
                if !grid.is_finite() || grid < 0.0 {
                    return None;
                }
                if objects.iter().any(|object| object_outcome::<M>(object) != SceneOutcome::Rendered) {
                    return None;
                }
                let (stiffness, damping) = (impedance.stiffness[0], impedance.damping[0]);
                match M {
                    2 => {
                        let mut scene = Scene::new(stiffness, damping, grid);
                        for object in objects.iter().filter_map(planar_object) {
                            scene.add(object)?;
                        }
                        Reference::Scene(scene)
                    }
                    3 => {
                        let mut god_object = GodObject::new(stiffness, damping, 0.0, SPATIAL_SKIN);
                        for object in objects.iter().filter_map(spatial_object::<M>) {
                            god_object.add(object)?;
                        }
                        Reference::Spatial(god_object)
                    }
                    _ => return None,
                }
            }
        };
        Some(Self { reference, last: position, effect: Effect::None, effect_state: EffectState::default() })
    }

    /// The source with the scene's free-space `effect` (a vibration advanced every
    /// `impedance_period` seconds); a fixed reference renders none. `None` for a vector the
    /// task cannot hold (a non-zero coordinate beyond its `M`).
    pub fn with_effect(mut self, effect: &LinkEffect, impedance_period: f32) -> Option<Self> {
        let vector = |values: &[f32; MAX_TASK]| -> Option<[f32; M]> {
            if values.iter().skip(M).any(|v| *v != 0.0) {
                return None;
            }
            Some(first(values))
        };
        self.effect = match *effect {
            LinkEffect::None => Effect::None,
            LinkEffect::Spring { anchor, stiffness } => {
                Effect::Spring { anchor: vector(&anchor)?, stiffness }
            }
            LinkEffect::Viscous { damping } => Effect::Viscous { damping },
            LinkEffect::Force { force } => Effect::Force { force: vector(&force)? },
            LinkEffect::Vibration { direction, amplitude, frequency } => {
                let direction = vector(&direction)?;
                let length = Real::sqrt(direction.iter().map(|v| v * v).sum::<f32>());
                if !(length > 0.0 && length.is_finite()) {
                    return None;
                }
                Effect::Vibration {
                    direction: direction.map(|v| v / length),
                    amplitude,
                    frequency,
                    period: impedance_period,
                }
            }
        };
        Some(self)
    }
}

impl<const M: usize> ReferenceSource<f32, M> for LinkSource<M> {
    fn update_reference(
        &mut self,
        task_position: &[f32; M],
        parameters: &mut ImpedanceParameters<f32, M>,
    ) -> TaskReference<f32, M> {
        let reference = match &mut self.reference {
            Reference::Fixed(fixed) => *fixed,
            Reference::Scene(scene) => {
                // The scene is planar: the first two task coordinates (`LinkSource::new` only
                // makes a scene for a 2-D task).
                let out = scene.render(&first(task_position));
                let (mut position, mut stiffness, mut damping) =
                    (first(&out.proxy), out.stiffness, out.damping);
                if out.valid && out.contact.is_none() && self.effect != Effect::None {
                    // Free space: the effect, on the free space's gains (the same on both axes).
                    let (reference, k, b) = self.effect_state.apply(
                        &self.effect,
                        task_position,
                        out.stiffness[0],
                        out.damping[0],
                    );
                    (position, stiffness, damping) = (reference, [k; 2], [b; 2]);
                }
                for (target, value) in parameters.stiffness.iter_mut().zip(stiffness) {
                    *target = value;
                }
                for (target, value) in parameters.damping.iter_mut().zip(damping) {
                    *target = value;
                }
                TaskReference::at_rest(position)
            }
            // Only a 3-D task builds one (`LinkSource::new`); the test, constant for each image,
            // keeps the god object's code out of the 2-D images.
            Reference::Spatial(_) if M != 3 => TaskReference::at_rest(self.last),
            Reference::Spatial(god_object) => {
                if god_object.proxy().is_none() {
                    god_object.start_in_free_space(task_position);
                }
                let out = god_object.render(task_position);
                let (mut position, mut stiffness, mut damping) = (out.proxy, out.stiffness, out.damping);
                if out.valid && out.contact.is_none() && self.effect != Effect::None {
                    (position, stiffness, damping) =
                        self.effect_state.apply(&self.effect, task_position, stiffness, damping);
                }
                parameters.stiffness = [stiffness; M];
                parameters.damping = [damping; M];
                TaskReference::at_rest(position)
            }
        };
        self.last = reference.position;
        reference
    }
}

/// A scene object of the link as a planar virtual object: a sphere is a circle, a box an
/// axis-aligned rectangle; `None` for an empty slot or a half-space (not rendered in 2-D here).
pub fn planar_object(object: &SceneObject) -> Option<VirtualObject<f32, SCENE_VERTICES>> {
    let kind = |cavity: bool| if cavity { ObjectKind::Cavity } else { ObjectKind::Solid };
    match *object {
        SceneObject::Sphere { centre, radius, cavity, stiffness, damping } => Some(VirtualObject {
            shape: Shape::Circle { center: first(&centre), radius },
            kind: kind(cavity),
            stiffness,
            damping,
        }),
        SceneObject::Box { centre, half_extents, stiffness, damping } => Some(VirtualObject {
            shape: Shape::Rectangle {
                center: first(&centre),
                half_extents: first(&half_extents),
                angle: 0.0,
            },
            kind: ObjectKind::Solid,
            stiffness,
            damping,
        }),
        SceneObject::Empty | SceneObject::HalfSpace { .. } => None,
    }
}

/// A scene object of the link as a spatial virtual object of the god object (`M = 3`): a sphere
/// (solid or cavity), a half-space, an axis-aligned box, frictionless; `None` for an empty slot
/// or a zero normal.
pub fn spatial_object<const M: usize>(object: &SceneObject) -> Option<Object<'static, f32, M>> {
    let kind = |cavity: bool| if cavity { ObjectKind::Cavity } else { ObjectKind::Solid };
    let (shape, kind, stiffness, damping) = match *object {
        SceneObject::Empty => return None,
        SceneObject::Sphere { centre, radius, cavity, stiffness, damping } => {
            (shape::Shape::Sphere { center: first(&centre), radius }, kind(cavity), stiffness, damping)
        }
        SceneObject::HalfSpace { point, normal, stiffness, damping } => {
            (shape::Shape::half_space(first(&point), first(&normal))?, ObjectKind::Solid, stiffness, damping)
        }
        SceneObject::Box { centre, half_extents, stiffness, damping } => (
            shape::Shape::aligned_box(first(&centre), first(&half_extents)),
            ObjectKind::Solid,
            stiffness,
            damping,
        ),
    };
    Some(Object { shape, kind, material: Material::frictionless(stiffness, damping) })
}

/// What a device with an `M`-dimensional task does with `object` (its answer to `SetObject`,
/// protocol version 5): `Rendered` for an empty slot and for what its renderer draws;
/// `BadValues` for a value that is not finite, a radius or one of the task's half-extents not
/// positive (the others negative), a negative stiffness or damping, a zero normal;
/// `NotRendered` for a kind the task's dimension cannot draw: on a 3-D task none (spheres,
/// boxes and half-spaces by the god object); on a 2-D task (the planar renderer, in the plane
/// `z = 0`) a half-space, and a sphere or a box whose centre is off that plane; on a 1-D (or a
/// more than 3-D) task every object.
pub fn object_outcome<const M: usize>(object: &SceneObject) -> SceneOutcome {
    let finite = |values: &[f32]| values.iter().all(|v| v.is_finite());
    let material = |stiffness: f32, damping: f32| stiffness >= 0.0 && damping >= 0.0;
    let (values_ok, centre_z) = match object {
        SceneObject::Empty => return SceneOutcome::Rendered,
        SceneObject::Sphere { centre, radius, stiffness, damping, .. } => (
            finite(centre)
                && finite(&[*radius, *stiffness, *damping])
                && *radius > 0.0
                && material(*stiffness, *damping),
            Some(centre[2]),
        ),
        SceneObject::Box { centre, half_extents, stiffness, damping } => (
            finite(centre)
                && finite(half_extents)
                && finite(&[*stiffness, *damping])
                && material(*stiffness, *damping)
                && half_extents.iter().enumerate().all(|(i, h)| if i < M { *h > 0.0 } else { *h >= 0.0 }),
            Some(centre[2]),
        ),
        SceneObject::HalfSpace { point, normal, stiffness, damping } => (
            finite(point)
                && finite(normal)
                && finite(&[*stiffness, *damping])
                && material(*stiffness, *damping)
                && normal.iter().any(|n| *n != 0.0),
            None,
        ),
    };
    if !values_ok {
        return SceneOutcome::BadValues;
    }
    match (M, centre_z) {
        (3, _) => SceneOutcome::Rendered,
        (2, Some(0.0)) => SceneOutcome::Rendered,
        _ => SceneOutcome::NotRendered,
    }
}

/// The first `K` entries of `values` (zero beyond them).
pub fn first<const K: usize, T: Copy + Default>(values: &[T]) -> [T; K] {
    let mut out = [T::default(); K];
    for (slot, value) in out.iter_mut().zip(values) {
        *slot = *value;
    }
    out
}

/// What an image named `name` (its line of `variants.txt`) with `joints` joints, `task_dim`
/// task coordinates and an impedance loop at `impedance_loop_hz` tells the host in answer to
/// `Hello`: the state stream in [`ChannelScales::DESKTOP`] units.
pub fn device_info(name: &str, joints: usize, task_dim: usize, impedance_loop_hz: u32) -> DeviceInfo {
    DeviceInfo {
        version: PROTOCOL_VERSION,
        rig_name_hash: rig_name_hash(name),
        joints: u8::try_from(joints).unwrap_or(u8::MAX),
        task_dim: u8::try_from(task_dim).unwrap_or(u8::MAX),
        impedance_loop_hz: u16::try_from(impedance_loop_hz).unwrap_or(u16::MAX),
        scales: ChannelScales::DESKTOP,
    }
}
