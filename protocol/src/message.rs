//! The messages of the link and the fixed-point state stream.
//!
//! Arrays are sized for the largest rig ([`MAX_JOINTS`] joints, [`MAX_TASK`] task axes); a
//! rig uses the first `joints` / `task_dim` entries its [`DeviceInfo`] announces. The state
//! stream is compact instead: each of its channels is an integer from −32,512 to 32,512 in a
//! unit the device announces once ([`ChannelScales`]), sent as two bytes that are never zero
//! ([`CHANNEL_CODES`]); the joint positions are the encoders' counts modulo 65,025 (exact;
//! the host unwraps them with [`CountUnwrapper`], which holds as long as a joint turns less
//! than 32,512 counts between two frames it receives), and a value that does not fit its
//! channel is sent at the channel's limit with [`StateFrame::SATURATED`] set, never clamped
//! silently; a NaN is sent as [`StateFrame::NOT_A_NUMBER`] and comes back as NaN.

use crate::frame::Received;
use serde::{Deserialize, Serialize};

/// The protocol version both sides must speak (exchanged in the handshake). Version 7: a device
/// plays an identification excitation too (the `SetExcitation` messages, in device mode), says
/// so in the state stream ([`StateFrame::EXCITING`]), and the state frame's motor-current
/// channels carry the *measured* currents (version 6 sent the current loops' setpoints, which
/// follow from the commanded torques the frame also carries). Version 6 adds
/// [`HostMessage::SetExcitation`] and [`PilLaw::Excitation`] (a processor-in-the-loop run
/// playing an identification excitation on the device). Version 5 adds
/// [`DeviceMessage::Scene`] (the device answers every `SetObject` with what it did with the
/// object: [`SceneAnswer`]). Version 4 adds
/// [`HostMessage::SetEffect`] (a free-space effect for the device's scene). Version 3 sends
/// the state frame's channels in a code without zero bytes ([`CHANNEL_CODES`]; version 2 sent
/// them as `i16`, and the encoder counts modulo 2¹⁶); version 2 added [`HostMessage::PilSetup`]
/// and made [`DeviceMessage::Actuators`] an [`ActuatorFrame`] (processor in the loop);
/// version 1 had neither.
pub const PROTOCOL_VERSION: u16 = 7;

/// The values a state frame's channel can take: its two bytes on the wire are each from 1 to
/// 255, the base-255 digits (low first) of the value plus [`CHANNEL_LIMIT`], each plus one.
/// A channel therefore never holds a zero byte, and COBS, whose work is at the zero bytes,
/// has nothing to do in the channels whatever their values (docs/link.md, "Cost on the
/// Cortex-M4F"): the state frame's cost does not depend on what the device sends.
pub const CHANNEL_CODES: i32 = 255 * 255;

/// The largest magnitude of a channel's value: the [`CHANNEL_CODES`] values run from
/// −32,512 to 32,512. A scaled channel's finite values stop one short, at ±32,511
/// (−32,512 is [`StateFrame::NOT_A_NUMBER`]).
pub const CHANNEL_LIMIT: i16 = 32_512;

/// The most joints a rig on the link may have.
pub const MAX_JOINTS: usize = 6;

/// The most task coordinates a rig on the link may have.
pub const MAX_TASK: usize = 3;

/// Harmonics per joint of an excitation trajectory on the link ([`ExcitationJoint`]): the
/// most a trajectory file may have, and what fits one message.
pub const EXCITATION_HARMONICS: usize = 12;

/// Scene slots a device holds: `SetObject` names slots `0..SCENE_SLOTS`; a device counts a
/// higher slot as refused and ignores it.
pub const SCENE_SLOTS: usize = 4;

/// Channels of a state frame: encoder counts, joint velocities, joint torques and motor
/// currents per joint, task position and velocity per task axis.
const MAX_CHANNELS: usize = 4 * MAX_JOINTS + 2 * MAX_TASK;

/// The unit of one step of each kind of state channel (SI units per count).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChannelScales {
    /// Joint velocity, rad/s (or m/s) per step.
    pub joint_velocity: f32,
    /// Task position, m per step.
    pub task_position: f32,
    /// Task velocity, m/s per step.
    pub task_velocity: f32,
    /// Commanded joint torque, N·m (or N) per step.
    pub joint_torque: f32,
    /// Measured motor current, A per step.
    pub motor_current: f32,
}

impl ChannelScales {
    /// Scales whose ranges (±32,767 steps) cover a desktop device: ±32.8 rad/s, ±0.655 m,
    /// ±6.55 m/s, ±32.8 N·m, ±32.8 A.
    pub const DESKTOP: Self = Self {
        joint_velocity: 1e-3,
        task_position: 2e-5,
        task_velocity: 2e-4,
        joint_torque: 1e-3,
        motor_current: 1e-3,
    };
}

/// The [`DeviceInfo::rig_name_hash`] of an image named `name`: FNV-1a, 32 bits, of its bytes.
pub fn rig_name_hash(name: &str) -> u32 {
    let mut hash = 0x811c_9dc5u32;
    for &byte in name.as_bytes() {
        hash ^= u32::from(byte);
        hash = hash.wrapping_mul(0x0100_0193);
    }
    hash
}

/// What the device tells the host first (and again on every host `Hello`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeviceInfo {
    /// The device's [`PROTOCOL_VERSION`].
    pub version: u16,
    /// FNV-1a hash of the rig's model name, so the host can check it drives the rig it loaded.
    pub rig_name_hash: u32,
    /// Joints of the rig (≤ [`MAX_JOINTS`]).
    pub joints: u8,
    /// Task coordinates (≤ [`MAX_TASK`]).
    pub task_dim: u8,
    /// Impedance-loop rate, Hz.
    pub impedance_loop_hz: u16,
    /// Units of the state stream's channels.
    pub scales: ChannelScales,
}

/// Target impedance of the task space (the runtime's `ImpedanceParameters`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImpedanceSettings {
    /// `K_d` per task axis, N/m.
    pub stiffness: [f32; MAX_TASK],
    /// `B_d` per task axis, N·s/m.
    pub damping: [f32; MAX_TASK],
    /// `M_d` per task axis, kg.
    pub mass: [f32; MAX_TASK],
}

/// A virtual object sent to the device's scene (positions in the task frame, m).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum SceneObject {
    /// The slot is empty.
    Empty,
    /// A sphere, solid (pushes out) or a cavity (keeps the point inside).
    Sphere {
        /// Centre.
        centre: [f32; MAX_TASK],
        /// Radius.
        radius: f32,
        /// `true`: the point is kept inside.
        cavity: bool,
        /// Surface stiffness, N/m.
        stiffness: f32,
        /// Surface damping, N·s/m.
        damping: f32,
    },
    /// The half-space behind a plane.
    HalfSpace {
        /// A point on the plane.
        point: [f32; MAX_TASK],
        /// The outward normal (unit length).
        normal: [f32; MAX_TASK],
        /// Surface stiffness, N/m.
        stiffness: f32,
        /// Surface damping, N·s/m.
        damping: f32,
    },
    /// An axis-aligned box.
    Box {
        /// Centre.
        centre: [f32; MAX_TASK],
        /// Half the edge lengths.
        half_extents: [f32; MAX_TASK],
        /// Surface stiffness, N/m.
        stiffness: f32,
        /// Surface damping, N·s/m.
        damping: f32,
    },
}

/// What the operator feels away from every object of the device's scene (the runtime's
/// `effects::Effect`; vectors in the task frame).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum LinkEffect {
    /// No effect.
    None,
    /// A spring pulling towards `anchor`.
    Spring {
        /// The point it pulls towards, m.
        anchor: [f32; MAX_TASK],
        /// Stiffness, N/m.
        stiffness: f32,
    },
    /// A viscous field.
    Viscous {
        /// Damping, N·s/m.
        damping: f32,
    },
    /// A constant force, N.
    Force {
        /// The force.
        force: [f32; MAX_TASK],
    },
    /// `amplitude · sin(2π frequency t)` along the unit `direction` (the device advances it
    /// by its impedance tick's period).
    Vibration {
        /// Unit direction.
        direction: [f32; MAX_TASK],
        /// Amplitude, N.
        amplitude: f32,
        /// Frequency, Hz.
        frequency: f32,
    },
}

/// Processor-in-the-loop sensor frame: what the device's peripherals would read this tick.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorFrame {
    /// The tick this frame is for (wrapping).
    pub tick: u16,
    /// Encoder counts per joint.
    pub encoder_counts: [i32; MAX_JOINTS],
    /// Measured motor currents, A.
    pub motor_current: [f32; MAX_JOINTS],
    /// Force-sensor readings per task axis (raw units).
    pub force_readings: [f32; MAX_TASK],
}

/// The impedance law of a processor-in-the-loop run (the runtime's `ImpedanceLaw`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum PilLaw {
    /// Controller 1: force feedback.
    ForceFeedback,
    /// Controller 2, first variant: acceleration feedback.
    AccelerationFeedback,
    /// Controller 2, second variant: natural inertia, `M_d = W⁻¹`.
    NaturalInertia,
    /// Controller 3: Jacobian transpose.
    JacobianTranspose,
    /// No impedance law: the device plays the identification excitation it was sent
    /// ([`HostMessage::SetExcitation`], one message per joint) with the joint-space tracking
    /// law of the runtime's `excitation` module.
    Excitation,
}

/// Processor in the loop: one joint's share of an identification excitation, a finite Fourier
/// series `q_j(t) = offset + Σ_k sine[k] sin((k+1) ω t) + cosine[k] cos((k+1) ω t)`,
/// `ω = 2π / period`, entered from rest over `ramp` seconds (the runtime's
/// `FourierTrajectory`). Every joint's message carries the same period, ramp and tracking
/// bandwidth; the device plays the trajectory once it has one message per joint, all
/// agreeing, and a [`PilSetup`] with [`PilLaw::Excitation`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExcitationJoint {
    /// The joint (0-based).
    pub joint: u8,
    /// The series' period `T`, s.
    pub period: f32,
    /// The blend from rest into the series, s.
    pub ramp: f32,
    /// The tracking law's bandwidth (critically damped error dynamics), Hz.
    pub tracking_hz: f32,
    /// The series' mean, rad (or m).
    pub offset: f32,
    /// The sine coefficients, harmonics 1 to [`EXCITATION_HARMONICS`] (unused: zero).
    pub sine: [f32; EXCITATION_HARMONICS],
    /// The cosine coefficients.
    pub cosine: [f32; EXCITATION_HARMONICS],
}

/// Processor in the loop: how the device's controller is configured for the run, besides the
/// target impedance ([`HostMessage::SetImpedance`]). Sent after the handshake and before the
/// first [`SensorFrame`]; the device builds its controller from it (the host's simulation of
/// the same scenario uses the same values, so the two runs can be compared).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PilSetup {
    /// The impedance law.
    pub law: PilLaw,
    /// Velocity low-pass cut-off of the joint-state estimator, Hz.
    pub velocity_cutoff_hz: f32,
    /// Acceleration low-pass cut-off of the joint-state estimator, Hz.
    pub acceleration_cutoff_hz: f32,
    /// Joint coordinates at the initial encoder counts, rad (or m).
    pub zero_offset: [f32; MAX_JOINTS],
    /// Encoder counts at start-up.
    pub initial_counts: [i32; MAX_JOINTS],
    /// The fixed task-space reference `x_d` (at rest).
    pub reference: [f32; MAX_TASK],
    /// Force-sensor calibration: force per raw unit, per task axis.
    pub force_scale: [f32; MAX_TASK],
    /// Force-sensor calibration: raw reading at zero force, per task axis.
    pub force_offset: [f32; MAX_TASK],
    /// `|det J|` below which Controllers 1 and 2 fall back to Controller 3.
    pub min_abs_jacobian_determinant: f32,
    /// Lead time of the spring term, s (0: the paper's law).
    pub spring_lead_time: f32,
    /// `None`: the reference is [`PilSetup::reference`]. `Some(grid spacing, m)`: a planar
    /// scene rendered by the device (a 2-D task): the objects sent with
    /// [`HostMessage::SetObject`] (a sphere is a circle, a box a rectangle), free space with
    /// the target impedance's `K_d`, `B_d` of the first axis and this anti-drift grid.
    pub scene_grid_spacing: Option<f32>,
}

/// Processor in the loop: what the device commands in one current-loop period, the answer to
/// one [`SensorFrame`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActuatorFrame {
    /// The tick of the sensor frame this answers (wrapping).
    pub tick: u16,
    /// Armature voltage per joint, V (zero while the bridges are off).
    pub voltage: [f32; MAX_JOINTS],
    /// Motor current setpoints after this period's impedance tick, A.
    pub current_setpoint: [f32; MAX_JOINTS],
    /// Joint torques commanded by the latest impedance tick (after the safety rules), N·m.
    pub torque: [f32; MAX_JOINTS],
    /// The impedance law's reference position after this period (the proxy of a scene).
    pub reference: [f32; MAX_TASK],
    /// [`ActuatorFrame::IMPEDANCE_TICK`], [`ActuatorFrame::DRIVEN`], [`ActuatorFrame::CLAMPED`],
    /// [`ActuatorFrame::FALLBACK`], [`ActuatorFrame::LINK_FAULT`].
    pub status: u8,
    /// The safety monitor's latched fault (0: none; 1 non-finite input, 2 non-finite torque,
    /// 3 missed ticks, 4 tick counter stalled, 5 control refused, 6 sensor implausible, 7 loop
    /// singular: `FaultCode::number`).
    pub fault: u8,
    /// Periods so far for which no sensor frame arrived in time.
    pub missed: u32,
}

impl ActuatorFrame {
    /// Status bit: an impedance tick ran this period.
    pub const IMPEDANCE_TICK: u8 = 1;
    /// Status bit: the bridges were driven this period (link enabled, no link fault).
    pub const DRIVEN: u8 = 2;
    /// Status bit: this period's impedance tick clamped a torque to its limit.
    pub const CLAMPED: u8 = 4;
    /// Status bit: this period's impedance tick fell back to Controller 3 near a singularity.
    pub const FALLBACK: u8 = 8;
    /// Status bit: the link's heartbeat watchdog has latched its fault (safe state).
    pub const LINK_FAULT: u8 = 16;
}

/// Host → device.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum HostMessage {
    /// Opens the link; the device answers with its [`DeviceInfo`].
    Hello {
        /// The host's [`PROTOCOL_VERSION`].
        version: u16,
    },
    /// Keeps the device enabled; without one for the device's timeout it goes to its safe
    /// state.
    Heartbeat {
        /// Increments by one per heartbeat (wrapping).
        sequence: u16,
    },
    /// Enables the bridges (only from a fault-free, disabled state).
    Enable,
    /// Disables the bridges.
    Disable,
    /// Clears a latched fault (the device stays disabled until `Enable`).
    ResetFault,
    /// New target impedance.
    SetImpedance(ImpedanceSettings),
    /// Replaces one slot of the device's scene.
    SetObject {
        /// The slot.
        slot: u8,
        /// Its new object.
        object: SceneObject,
    },
    /// Processor-in-the-loop: the sensors for the next tick (also proves the host alive, as a
    /// heartbeat does).
    Sensors(SensorFrame),
    /// Processor-in-the-loop: the controller's configuration for the run.
    PilSetup(PilSetup),
    /// The free-space effect of the device's scene (rendered while the point touches none of
    /// the scene's objects).
    SetEffect(LinkEffect),
    /// Processor-in-the-loop: one joint of the excitation to play ([`PilLaw::Excitation`]).
    SetExcitation(ExcitationJoint),
}

/// The kind of a [`HostMessage`]: the first byte of its serialisation (postcard writes an
/// enum's variant index first, as a varint: one byte for the first 128 variants), in the
/// order of [`HostMessage`]'s variants. A receiver can dispatch on it and decode only that
/// variant's fields ([`crate::Received::payload`]) instead of a whole [`HostMessage`], which
/// is built and moved at the size of its largest variant (116 bytes, [`PilSetup`]) whatever
/// its kind: the device's link does, for its instruction budget (docs/link.md).
///
/// The fields of each kind, as [`crate::Received::payload`] decodes them: `Hello`: the version
/// (`u16`); `Heartbeat`: the sequence (`u16`); `Enable`, `Disable`, `ResetFault`: nothing
/// (`()`); `SetImpedance`: [`ImpedanceSettings`]; `SetObject`: `(u8, SceneObject)`;
/// `Sensors`: [`SensorFrame`]; `PilSetup`: [`PilSetup`]; `SetEffect`: [`LinkEffect`];
/// `SetExcitation`: [`ExcitationJoint`] (checked for every message by
/// `host_kinds_decode_as_host_messages` in `tests/frames.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostKind {
    /// [`HostMessage::Hello`].
    Hello,
    /// [`HostMessage::Heartbeat`].
    Heartbeat,
    /// [`HostMessage::Enable`].
    Enable,
    /// [`HostMessage::Disable`].
    Disable,
    /// [`HostMessage::ResetFault`].
    ResetFault,
    /// [`HostMessage::SetImpedance`].
    SetImpedance,
    /// [`HostMessage::SetObject`].
    SetObject,
    /// [`HostMessage::Sensors`].
    Sensors,
    /// [`HostMessage::PilSetup`].
    PilSetup,
    /// [`HostMessage::SetEffect`].
    SetEffect,
    /// [`HostMessage::SetExcitation`].
    SetExcitation,
}

impl HostKind {
    /// The kind of the serialised host message `body`, if its first byte names one.
    pub fn of(body: &[u8]) -> Option<Self> {
        Some(match body.first()? {
            0 => Self::Hello,
            1 => Self::Heartbeat,
            2 => Self::Enable,
            3 => Self::Disable,
            4 => Self::ResetFault,
            5 => Self::SetImpedance,
            6 => Self::SetObject,
            7 => Self::Sensors,
            8 => Self::PilSetup,
            9 => Self::SetEffect,
            10 => Self::SetExcitation,
            _ => return None,
        })
    }
}

impl Received<'_> {
    /// The kind of host message the body holds, if it is one ([`HostKind`]). Defined here,
    /// beside the messages, so that the framing (`frame`) knows nothing of them.
    pub fn host_kind(&self) -> Option<HostKind> {
        HostKind::of(self.body())
    }
}

/// What a device did with one object it was sent ([`HostMessage::SetObject`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SceneOutcome {
    /// The slot now holds the object, and the device renders it (an `Empty` object: the slot
    /// is emptied).
    Rendered,
    /// The device cannot render this kind of object in its task's dimension (a 1-D device
    /// renders no 3-D object; a 2-D device's planar renderer draws spheres as circles and
    /// boxes as rectangles in the plane `z = 0`, not half-spaces nor anything off that
    /// plane). The slot keeps what it held.
    NotRendered,
    /// The object's values cannot be rendered: not finite, a radius or a half-extent not
    /// positive, a negative stiffness or damping, a zero normal. The slot keeps what it held.
    BadValues,
    /// The slot is not one of the device's ([`SCENE_SLOTS`]).
    NoSlot,
}

/// The device's answer to one [`HostMessage::SetObject`] (protocol version 5): the slot it
/// named and what became of the object. A device never answers [`SceneOutcome::Rendered`] for
/// an object it does not render.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SceneAnswer {
    /// The slot the host named.
    pub slot: u8,
    /// What the device did.
    pub outcome: SceneOutcome,
}

/// Device → host.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum DeviceMessage {
    /// The device's identity, rates and channel units.
    Hello(DeviceInfo),
    /// One impedance tick's state.
    State(StateFrame),
    /// Processor-in-the-loop: what this period commands (the answer to a sensor frame).
    Actuators(ActuatorFrame),
    /// The device's receive counters.
    Link(crate::frame::LinkCounters),
    /// The answer to one [`HostMessage::SetObject`] (protocol version 5).
    Scene(SceneAnswer),
}

/// One impedance tick's state in SI units, as the device has it (the input of
/// [`StateFrame::quantise`]). Slices hold one entry per joint or task axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StateSample<'a> {
    /// Impedance ticks since start.
    pub tick: u32,
    /// The bridges are enabled.
    pub enabled: bool,
    /// The device is playing an identification excitation ([`StateFrame::EXCITING`]).
    pub exciting: bool,
    /// The latched fault's code (0: none), as [`StateFrame::fault`] holds it.
    pub fault: u8,
    /// Encoder counts per joint.
    pub encoder_counts: &'a [i32],
    /// Joint velocities, rad/s.
    pub joint_velocity: &'a [f32],
    /// Task position, m.
    pub task_position: &'a [f32],
    /// Task velocity, m/s.
    pub task_velocity: &'a [f32],
    /// Commanded joint torques, N·m.
    pub joint_torque: &'a [f32],
    /// Measured motor currents, A (what the current loops read in the tick's period).
    pub motor_current: &'a [f32],
    /// Instructions (or cycles) the last impedance tick took.
    pub tick_instructions: u32,
}

/// One impedance tick's state on the wire: every channel 16 bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateFrame {
    /// Impedance ticks since start, modulo 2¹⁶.
    #[serde(with = "two_bytes")]
    pub tick: u16,
    /// [`StateFrame::ENABLED`], [`StateFrame::SATURATED`], [`StateFrame::EXCITING`].
    pub status: u8,
    /// The safety monitor's latched fault's code in the low 7 bits (0: none; `FaultCode::number`),
    /// and [`StateFrame::LINK_FAULT`] while the link's heartbeat fault is latched.
    pub fault: u8,
    /// Instructions the last impedance tick took (65,535 and [`StateFrame::SATURATED`] if more).
    #[serde(with = "two_bytes")]
    pub tick_instructions: u16,
    /// Channels present: joints in the low nibble, task axes in the high nibble.
    pub shape: u8,
    /// The channels, little-endian `i16`: encoder counts mod 2¹⁶, joint velocities, task
    /// position, task velocity, joint torques, motor currents, each present entry in turn.
    pub channels: Channels,
}

/// A `u16` as two little-endian bytes: postcard's variable-length integer would take three
/// for values from 2¹⁴, and the state frame is sized for its worst case.
mod two_bytes {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(value: &u16, serializer: S) -> Result<S::Ok, S::Error> {
        value.to_le_bytes().serialize(serializer)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<u16, D::Error> {
        <[u8; 2]>::deserialize(deserializer).map(u16::from_le_bytes)
    }
}

/// The state frame's channel bytes: only the present ones are sent (postcard writes a byte
/// array as its length and its bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Channels {
    bytes: [u8; 2 * MAX_CHANNELS],
    length: u8,
}

impl Channels {
    fn new() -> Self {
        Self { bytes: [0; 2 * MAX_CHANNELS], length: 0 }
    }

    /// Appends the channel of `code` ([`code_bytes`]).
    fn push(&mut self, code: u32) {
        let at = usize::from(self.length);
        if let Some(slot) = self.bytes.get_mut(at..at + 2) {
            slot.copy_from_slice(&code_bytes(code));
            self.length += 2;
        }
    }

    /// The `index`-th channel's value, if present (from −[`CHANNEL_LIMIT`] to
    /// [`CHANNEL_LIMIT`]).
    pub fn get(&self, index: usize) -> Option<i16> {
        let bytes = self.as_bytes().get(2 * index..2 * index + 2)?;
        value_of(bytes.try_into().ok()?)
    }

    /// The bytes sent.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..usize::from(self.length)).unwrap_or(&[])
    }
}

impl Serialize for Channels {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_bytes(self.as_bytes())
    }
}

impl<'de> Deserialize<'de> for Channels {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct ChannelBytes;
        impl<'de> serde::de::Visitor<'de> for ChannelBytes {
            type Value = Channels;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                write!(f, "an even number of at most {} bytes, none of them zero", 2 * MAX_CHANNELS)
            }
            fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Channels, E> {
                // `& 1`, not `is_multiple_of` (Rust 1.87): the protocol builds with Rust 1.63.
                if v.len() & 1 == 1 || v.len() > 2 * MAX_CHANNELS {
                    return Err(E::invalid_length(v.len(), &self));
                }
                // No channel's code has a zero byte: such a frame was not sent by a device.
                if v.contains(&0) {
                    return Err(E::invalid_value(serde::de::Unexpected::Bytes(v), &self));
                }
                let mut channels = Channels::new();
                channels.bytes[..v.len()].copy_from_slice(v);
                channels.length = v.len() as u8;
                Ok(channels)
            }
        }
        deserializer.deserialize_bytes(ChannelBytes)
    }
}

impl StateFrame {
    /// Status bit: the bridges are enabled.
    pub const ENABLED: u8 = 1;
    /// Status bit: a channel (or the instruction count) did not fit and was sent at its limit.
    pub const SATURATED: u8 = 2;
    /// Status bit: the device is playing the identification excitation the host sent
    /// (`SetExcitation`, one per joint); this tick's commanded torques are its tracking law's.
    pub const EXCITING: u8 = 4;
    /// Bit of [`StateFrame::fault`]: the link's heartbeat watchdog has latched its fault (the
    /// safe state; cleared only by the host's `ResetFault`).
    pub const LINK_FAULT: u8 = 0x80;
    /// A scaled channel's value for NaN (a finite value never quantises to it).
    pub const NOT_A_NUMBER: i16 = -CHANNEL_LIMIT;

    /// The frame of `sample` in the units `scales`; `None` if the sample has more than
    /// [`MAX_JOINTS`] joints or [`MAX_TASK`] task axes, or its per-joint slices differ in length.
    pub fn quantise(sample: &StateSample<'_>, scales: &ChannelScales) -> Option<Self> {
        let (joints, task) = shape_of(sample)?;
        let mut saturated = false;
        let mut channels = Channels::new();
        for &count in sample.encoder_counts {
            channels.push(count_code(count));
        }
        let mut push_scaled = |values: &[f32], unit: f32| {
            for &value in values {
                let (step, clipped) = to_step(value, unit);
                saturated |= clipped;
                channels.push(value_code(step));
            }
        };
        push_scaled(sample.joint_velocity, scales.joint_velocity);
        push_scaled(sample.task_position, scales.task_position);
        push_scaled(sample.task_velocity, scales.task_velocity);
        push_scaled(sample.joint_torque, scales.joint_torque);
        push_scaled(sample.motor_current, scales.motor_current);
        let tick_instructions = u16::try_from(sample.tick_instructions).unwrap_or_else(|_| {
            saturated = true;
            u16::MAX
        });
        let status = if sample.enabled { Self::ENABLED } else { 0 }
            | if saturated { Self::SATURATED } else { 0 }
            | if sample.exciting { Self::EXCITING } else { 0 };
        Some(Self {
            tick: sample.tick as u16,
            status,
            fault: sample.fault,
            tick_instructions,
            shape: (joints as u8) | ((task as u8) << 4),
            channels,
        })
    }

    /// Quantises `sample` and frames it as a [`DeviceMessage::State`] into `out`, without
    /// building a `StateFrame`: the same bytes as
    /// `encode(&DeviceMessage::State(StateFrame::quantise(sample, scales)?), out)` (the tests
    /// compare), in a third of the instructions (the device's 1 kHz stream, docs/link.md).
    /// Returns the frame's length, its final zero byte included; `None` for a sample that
    /// [`StateFrame::quantise`] refuses. Always inlined: a caller whose slices come from
    /// arrays of the rig's sizes (the device's `state_frame`) gets a copy with the channels'
    /// counts fixed, without a loop or a length test per channel.
    #[inline(always)]
    pub fn encode_sample(
        sample: &StateSample<'_>,
        scales: &ChannelScales,
        out: &mut [u8; crate::frame::MAX_FRAME_BYTES],
    ) -> Option<usize> {
        let (joints, task) = shape_of(sample)?;
        let channels = 4 * joints + 2 * task;
        // The body starts at out[1] (out[0] is the stuffing's code byte): the message's kind,
        // the fixed fields (STATE_HEAD bytes), then the channels' bytes.
        let (head, mut rest) = out.split_at_mut(1 + STATE_HEAD);
        let counts = take_front(&mut rest, 2 * joints);
        for (slot, &count) in counts.chunks_exact_mut(2).zip(sample.encoder_counts) {
            put(slot, count_code(count));
        }
        let joint_velocity = take_front(&mut rest, 2 * joints);
        let task_position = take_front(&mut rest, 2 * task);
        let task_velocity = take_front(&mut rest, 2 * task);
        let joint_torque = take_front(&mut rest, 2 * joints);
        let motor_current = take_front(&mut rest, 2 * joints);
        let mut saturated = put_steps(joint_velocity, sample.joint_velocity, scales.joint_velocity);
        saturated |= put_steps(task_position, sample.task_position, scales.task_position);
        saturated |= put_steps(task_velocity, sample.task_velocity, scales.task_velocity);
        saturated |= put_steps(joint_torque, sample.joint_torque, scales.joint_torque);
        saturated |= put_steps(motor_current, sample.motor_current, scales.motor_current);
        let tick_instructions = u16::try_from(sample.tick_instructions).unwrap_or_else(|_| {
            saturated = true;
            u16::MAX
        });
        let status = if sample.enabled { Self::ENABLED } else { 0 }
            | if saturated { Self::SATURATED } else { 0 }
            | if sample.exciting { Self::EXCITING } else { 0 };
        let [tick_low, tick_high] = (sample.tick as u16).to_le_bytes();
        let [instructions_low, instructions_high] = tick_instructions.to_le_bytes();
        // postcard: the variant index (a one-byte varint), the fields in order (the two-byte
        // ones as their bytes), the channels as a byte string: its length (a one-byte varint,
        // at most 60) and its bytes.
        head.copy_from_slice(&[
            0,
            STATE_KIND,
            tick_low,
            tick_high,
            status,
            sample.fault,
            instructions_low,
            instructions_high,
            (joints as u8) | ((task as u8) << 4),
            2 * channels as u8,
        ]);
        // The channels hold no zero byte (`CHANNEL_CODES`): only the head is looked at.
        crate::frame::finish_with_zeros_in(out, STATE_HEAD + 2 * channels, STATE_HEAD).ok()
    }

    /// Joints in the frame.
    pub fn joints(&self) -> usize {
        usize::from(self.shape & 0x0f)
    }

    /// Task axes in the frame.
    pub fn task_dim(&self) -> usize {
        usize::from(self.shape >> 4)
    }

    /// `true` if the channels hold exactly what [`StateFrame::shape`] says.
    pub fn is_consistent(&self) -> bool {
        let (n, m) = (self.joints(), self.task_dim());
        n <= MAX_JOINTS && m <= MAX_TASK && self.channels.as_bytes().len() == 2 * (4 * n + 2 * m)
    }

    /// Encoder count of joint `j` modulo [`CHANNEL_CODES`], from −32,512 to 32,512: the full
    /// count is this plus a multiple of 65,025 ([`CountUnwrapper`] finds which).
    pub fn encoder_count_wrapped(&self, j: usize) -> Option<i16> {
        (j < self.joints()).then(|| self.channels.get(j)).flatten()
    }

    /// Joint velocity of joint `j`, rad/s.
    pub fn joint_velocity(&self, j: usize, scales: &ChannelScales) -> Option<f32> {
        self.scaled(j, self.joints(), self.joints(), scales.joint_velocity)
    }

    /// Task position along axis `k`, m.
    pub fn task_position(&self, k: usize, scales: &ChannelScales) -> Option<f32> {
        self.scaled(k, self.task_dim(), 2 * self.joints(), scales.task_position)
    }

    /// Task velocity along axis `k`, m/s.
    pub fn task_velocity(&self, k: usize, scales: &ChannelScales) -> Option<f32> {
        self.scaled(k, self.task_dim(), 2 * self.joints() + self.task_dim(), scales.task_velocity)
    }

    /// Commanded torque of joint `j`, N·m.
    pub fn joint_torque(&self, j: usize, scales: &ChannelScales) -> Option<f32> {
        self.scaled(j, self.joints(), 2 * self.joints() + 2 * self.task_dim(), scales.joint_torque)
    }

    /// Measured current of joint `j`'s motor, A.
    pub fn motor_current(&self, j: usize, scales: &ChannelScales) -> Option<f32> {
        self.scaled(j, self.joints(), 3 * self.joints() + 2 * self.task_dim(), scales.motor_current)
    }

    fn scaled(&self, index: usize, count: usize, first: usize, unit: f32) -> Option<f32> {
        if index >= count {
            return None;
        }
        let step = self.channels.get(first + index)?;
        Some(if step == Self::NOT_A_NUMBER { f32::NAN } else { f32::from(step) * unit })
    }
}

/// `DeviceMessage::State`'s variant index, the first byte of its serialisation.
const STATE_KIND: u8 = 1;

/// Bytes of a serialised state message before its channels: the kind, tick (2), status,
/// fault, tick instructions (2), shape and the channels' length.
const STATE_HEAD: usize = 9;

/// Joints and task axes of `sample`, if the protocol can carry it: at most [`MAX_JOINTS`]
/// joints and [`MAX_TASK`] axes, every per-joint and per-axis slice of the same length.
fn shape_of(sample: &StateSample<'_>) -> Option<(usize, usize)> {
    let joints = sample.encoder_counts.len();
    let task = sample.task_position.len();
    let per_joint = [sample.joint_velocity.len(), sample.joint_torque.len(), sample.motor_current.len()];
    if joints > MAX_JOINTS || task > MAX_TASK || per_joint.iter().any(|&n| n != joints) {
        return None;
    }
    (sample.task_velocity.len() == task).then_some((joints, task))
}

/// The first `n` bytes of `rest` (all of it if shorter), and `rest` advanced past them.
fn take_front<'a>(rest: &mut &'a mut [u8], n: usize) -> &'a mut [u8] {
    let all = core::mem::take(rest);
    let (front, back) = all.split_at_mut(n.min(all.len()));
    *rest = back;
    front
}

/// A channel's `code` into a two-byte slot ([`code_bytes`]).
fn put(slot: &mut [u8], code: u32) {
    // As an array: one 16-bit store.
    if let Ok(pair) = <&mut [u8; 2]>::try_from(slot) {
        *pair = code_bytes(code);
    }
}

/// A channel's code (its value plus [`CHANNEL_LIMIT`], below [`CHANNEL_CODES`]) as its two
/// bytes on the wire: `code mod 255 + 1`, then `code / 255 + 1`. As one little-endian `u16`
/// that is `code + code / 255 + 257`: a multiplication by the reciprocal, a shift and two
/// additions on the Cortex-M4F.
#[inline(always)]
fn code_bytes(code: u32) -> [u8; 2] {
    ((code + code / 255 + 257) as u16).to_le_bytes()
}

/// A channel's value from its two bytes on the wire (the inverse of [`code_bytes`]); `None` if
/// either is zero, which no device sends.
fn value_of(bytes: [u8; 2]) -> Option<i16> {
    let [low, high] = bytes;
    let code = i32::from(high.checked_sub(1)?) * 255 + i32::from(low.checked_sub(1)?);
    Some((code - i32::from(CHANNEL_LIMIT)) as i16)
}

/// The code of a channel's `value` (within ±[`CHANNEL_LIMIT`]).
fn value_code(value: i16) -> u32 {
    (i32::from(value) + i32::from(CHANNEL_LIMIT)) as u32
}

/// The code of an encoder count: the count modulo [`CHANNEL_CODES`], as a value from −32,512
/// to 32,512 (every `i32`, exactly: the remainder first, then the offset, reduced once more).
#[inline(always)]
fn count_code(count: i32) -> u32 {
    let code = count.rem_euclid(CHANNEL_CODES) + i32::from(CHANNEL_LIMIT);
    (if code >= CHANNEL_CODES { code - CHANNEL_CODES } else { code }) as u32
}

/// `value / unit` rounded to the nearest step, and whether it had to be clipped to ±32,511 or
/// is not a number ([`StateFrame::NOT_A_NUMBER`]: a NaN value, a NaN quotient such as ∞/∞, or
/// a unit that is not positive).
fn to_step(value: f32, unit: f32) -> (i16, bool) {
    let steps = value / unit;
    match step_code(steps) {
        Some(code) if unit > 0.0 => ((code as i32 - i32::from(CHANNEL_LIMIT)) as i16, false),
        _ if unit > 0.0 => (clipped(steps), true),
        _ => (StateFrame::NOT_A_NUMBER, true),
    }
}

/// The largest step of a scaled channel, either way (−32,512 is [`StateFrame::NOT_A_NUMBER`]).
const STEP_LIMIT: f32 = CHANNEL_LIMIT as f32 - 1.0;

/// The code of `steps` rounded to the nearest integer (halves to even), if that integer is
/// within ±32,511; `None` otherwise and for NaN.
///
/// Written for the device's state stream (15 scaled channels of a 3-joint rig per impedance
/// tick): adding 1.5 × 2²³ + [`CHANNEL_LIMIT`] leaves a float whose unit is 1, so the sum is
/// an integer (the FPU's rounding mode: nearest, ties to even; the offset is even and does not
/// change which), and its bits count up by one per step: the range test is one subtraction
/// and one comparison of them, and their low 16 bits are the code (2²² and 1.5 × 2²³ are
/// multiples of 2¹⁶). Five instructions on the Cortex-M4F where a float comparison, the
/// rounding and the offset take nine.
#[inline(always)]
fn step_code(steps: f32) -> Option<u32> {
    const ROUNDING: f32 = 12_582_912.0 + CHANNEL_LIMIT as f32;
    let bits = (steps + ROUNDING).to_bits();
    // Folded to a constant: the bits of the sum for −32,511 steps.
    let lowest = (ROUNDING - STEP_LIMIT).to_bits();
    (bits.wrapping_sub(lowest) <= 2 * STEP_LIMIT as u32).then_some(bits & 0xFFFF)
}

/// The step sent for `steps` out of range: the limit on its side, or NaN. Inline: two
/// comparisons cost less than a call on the Cortex-M4F, and a state frame whose every value
/// is out of range is the costliest (docs/link.md).
#[inline(always)]
fn clipped(steps: f32) -> i16 {
    if steps > STEP_LIMIT {
        CHANNEL_LIMIT - 1
    } else if steps < -STEP_LIMIT {
        1 - CHANNEL_LIMIT
    } else {
        StateFrame::NOT_A_NUMBER
    }
}

/// The steps of `values` in `unit` into `slots` (two bytes each, little-endian), as far as
/// both go; whether any was clipped or not a number (as [`to_step`]).
#[inline(always)]
fn put_steps(slots: &mut [u8], values: &[f32], unit: f32) -> bool {
    let mut any_clipped = false;
    let pairs = slots.chunks_exact_mut(2).zip(values);
    if unit > 0.0 {
        for (slot, &value) in pairs {
            let steps = value / unit;
            let code = step_code(steps).unwrap_or_else(|| {
                any_clipped = true;
                value_code(clipped(steps))
            });
            put(slot, code);
        }
    } else {
        for (slot, _) in pairs {
            put(slot, value_code(StateFrame::NOT_A_NUMBER));
        }
        any_clipped = !values.is_empty();
    }
    any_clipped
}

/// Recovers full encoder counts from their values modulo [`CHANNEL_CODES`], frame after frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CountUnwrapper {
    last: Option<i32>,
}

impl Default for CountUnwrapper {
    fn default() -> Self {
        Self::new()
    }
}

impl CountUnwrapper {
    /// Starts at the first frame's count, taken as it is sent (start the device with its
    /// counters within ±32,512, as `HapticLoopSettings::initial_counts` does).
    pub const fn new() -> Self {
        Self { last: None }
    }

    /// The full count that is `wrapped` modulo [`CHANNEL_CODES`]
    /// ([`StateFrame::encoder_count_wrapped`]), nearest the previous one.
    pub fn unwrap(&mut self, wrapped: i16) -> i32 {
        let full = match self.last {
            None => i32::from(wrapped),
            Some(last) => {
                // The difference modulo 65,025, taken within ±32,512, is the change, as long
                // as the joint moved less than that.
                let last_code = count_code(last) as i32;
                let delta = (value_code(wrapped) as i32 - last_code).rem_euclid(CHANNEL_CODES);
                let delta = if delta > i32::from(CHANNEL_LIMIT) { delta - CHANNEL_CODES } else { delta };
                last.wrapping_add(delta)
            }
        };
        self.last = Some(full);
        full
    }
}
