//! What every image with a host link runs besides the link itself: the reference its
//! controller follows, fixed or a planar scene whose objects come over the link
//! ([`LinkSource`]), and the device's [`DeviceInfo`] ([`device_info`]). Used by the QEMU
//! board's PIL and device images and by the STM32F4 board's device image, so that the host's
//! `SetObject` means the same on every board.

use hapticgen_protocol::{
    rig_name_hash, ChannelScales, DeviceInfo, LinkEffect, SceneObject, MAX_TASK, PROTOCOL_VERSION,
};
use hapticgen_runtime::control::{ImpedanceParameters, TaskReference};
use hapticgen_runtime::effects::{Effect, EffectState};
use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};
use hapticgen_runtime::tick::ReferenceSource;
use hapticgen_runtime::Real;

/// Scene objects a link image holds (the slots `SetObject` may name).
pub const SCENE_OBJECTS: usize = hapticgen_protocol::SCENE_SLOTS;

/// Points of a polygon or table in the scene's objects (boxes are drawn as rectangles).
pub const SCENE_VERTICES: usize = 8;

/// The reference of a link image: fixed, or a planar scene rendered on the device (a 2-D task:
/// the runtime's proxy renderer with its anti-drift grid, as the self-contained images'
/// `wall_contact` and the host's simulator run it).
// One instance, in a static-sized controller: no heap on the device, so no box for the scene.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy)]
pub enum Reference<const M: usize> {
    /// A fixed reference.
    Fixed(TaskReference<f32, M>),
    /// A planar scene.
    Scene(Scene<f32, SCENE_OBJECTS, SCENE_VERTICES>),
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
    /// The reference at rest at `position` when no object is set, else (2-D tasks only: `None`
    /// for another dimension) the scene of `objects` with `impedance`'s first axis as the free
    /// space's stiffness and damping and the anti-drift grid `grid` (m). `None` too for a
    /// negative or non-finite grid or more objects than the scene holds.
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
                if M != 2 || !grid.is_finite() || grid < 0.0 {
                    return None;
                }
                let mut scene = Scene::new(impedance.stiffness[0], impedance.damping[0], grid);
                for object in objects.iter().filter_map(planar_object) {
                    scene.add(object)?;
                }
                Reference::Scene(scene)
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
