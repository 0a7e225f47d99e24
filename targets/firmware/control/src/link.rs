//! The device's end of the host link (the protocol is `hapticgen-protocol`, see
//! docs/link.md): received bytes in, commands applied, state frames out, and the link's
//! safety rules.
//!
//! * **Handshake**: nothing from the host but `Disable` is acted on before a `Hello` of this
//!   protocol version; every `Hello` is answered with the device's [`DeviceInfo`].
//! * **Heartbeat**: while the bridges are enabled, a heartbeat must arrive at least every
//!   [`LinkSettings::heartbeat_timeout_ticks`] current-loop periods; when none does, the link
//!   latches [`LinkFault::HeartbeatLost`] and the bridges are disabled ([`Gated`]) in the same
//!   period. Only a `ResetFault` followed by an `Enable` (with fresh heartbeats) turns them on
//!   again: a host that reappears does not re-enable a device by itself.
//! * **Processor in the loop**: a [`HostMessage::Sensors`](hapticgen_protocol::HostMessage::Sensors) frame is kept
//!   ([`DeviceLink::sensors`], announced by [`LinkEvent::Sensors`]) and counts as a heartbeat
//!   (the host that computes the plant is alive); so is
//!   [`HostMessage::PilSetup`](hapticgen_protocol::HostMessage::PilSetup)
//!   ([`DeviceLink::pil_setup`], [`LinkEvent::PilSetup`]), and so is each joint of an
//!   identification excitation
//!   ([`HostMessage::SetExcitation`](hapticgen_protocol::HostMessage::SetExcitation),
//!   [`DeviceLink::excitation_joint`], [`LinkEvent::ExcitationJoint`]); `Disable` is reported
//!   ([`LinkEvent::Disabled`]) so that a PIL image can end its run. The events carry no
//!   payload of their own: an event is returned for every byte, so it is kept small.
//! * **Bounded work**: [`DeviceLink::receive`] takes one byte (the frame decoder's constant
//!   time per byte, one decoding per zero byte); unknown, corrupt or premature messages are
//!   counted and dropped.

use hapticgen_protocol::{
    encode, DeviceInfo, DeviceMessage, EncodeError, ExcitationJoint, FrameDecoder, HostKind,
    ImpedanceSettings, LinkCounters, LinkEffect, PilSetup, SceneObject, SensorFrame, MAX_FRAME_BYTES,
    MAX_TASK, PROTOCOL_VERSION,
};
use hapticgen_runtime::control::ImpedanceParameters;
use hapticgen_runtime::Real;

use crate::board::{CurrentSense, Encoders, ForceSense, VoltageOutput};

/// How the device's link behaves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkSettings {
    /// Current-loop periods without a heartbeat after which the bridges are disabled.
    pub heartbeat_timeout_ticks: u32,
}

impl LinkSettings {
    /// A heartbeat timeout of `timeout_ms` at `current_loop_hz` (rounded down, at least one
    /// period): the bridges are off within `timeout_ms` of the last heartbeat.
    pub fn with_timeout_ms(timeout_ms: u32, current_loop_hz: u32) -> Self {
        let ticks = u64::from(timeout_ms) * u64::from(current_loop_hz) / 1000;
        Self { heartbeat_timeout_ticks: u32::try_from(ticks).unwrap_or(u32::MAX).max(1) }
    }
}

/// Why the link holds the bridges off until a reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkFault {
    /// The heartbeat stopped while the bridges were enabled.
    HeartbeatLost,
}

/// What a received message asks of the rest of the firmware (the link has already applied
/// what concerns itself: handshake, enable, heartbeat, reset).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LinkEvent<S> {
    /// The host opened the link: send [`DeviceLink::hello`].
    Hello,
    /// New target impedance (checked: finite, stiffness and damping ≥ 0, mass > 0).
    Impedance(ImpedanceParameters<S, MAX_TASK>),
    /// A scene slot's new object.
    Object {
        /// The slot.
        slot: u8,
        /// The object.
        object: SceneObject,
    },
    /// Processor in the loop: the sensors of the next current-loop period arrived
    /// ([`DeviceLink::sensors`]).
    Sensors,
    /// Processor in the loop: the controller's configuration arrived ([`DeviceLink::pil_setup`]).
    PilSetup,
    /// Processor in the loop: one joint of an excitation arrived
    /// ([`DeviceLink::excitation_joint`]).
    ExcitationJoint,
    /// The host disabled the bridges (honoured before and after the handshake).
    Disabled,
    /// The scene's new free-space effect (checked: finite, stiffness, damping, amplitude and
    /// frequency ≥ 0, a vibration's direction not zero).
    Effect(LinkEffect),
}

/// Counts of what the link refused, besides the frame decoder's [`LinkCounters`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RefusedCounters {
    /// Valid messages before a handshake of this protocol version.
    pub before_handshake: u32,
    /// `Enable` while a link fault is latched or without a fresh heartbeat.
    pub enable_refused: u32,
    /// Impedance settings with a non-finite or out-of-range value.
    pub bad_settings: u32,
}

/// The device's link state.
#[derive(Clone, Debug)]
pub struct DeviceLink {
    decoder: FrameDecoder,
    info: DeviceInfo,
    settings: LinkSettings,
    handshake: bool,
    enabled: bool,
    ticks_since_heartbeat: u32,
    fault: Option<LinkFault>,
    refused: RefusedCounters,
    sensors: Option<SensorFrame>,
    pil_setup: Option<PilSetup>,
    excitation_joint: Option<ExcitationJoint>,
}

impl DeviceLink {
    /// A link that announces `info` (its `version` is set to this protocol's), disabled,
    /// waiting for the host's `Hello`.
    pub fn new(info: DeviceInfo, settings: LinkSettings) -> Self {
        Self {
            decoder: FrameDecoder::new(),
            info: DeviceInfo { version: PROTOCOL_VERSION, ..info },
            settings,
            handshake: false,
            enabled: false,
            ticks_since_heartbeat: u32::MAX,
            fault: None,
            refused: RefusedCounters::default(),
            sensors: None,
            pil_setup: None,
            excitation_joint: None,
        }
    }

    /// Takes one received byte; returns what a completed message asks of the firmware.
    ///
    /// A frame is decoded by its kind ([`HostKind`]): only the fields of the message that came
    /// are built, never a whole [`HostMessage`](hapticgen_protocol::HostMessage) (116 bytes, whatever its kind), which would
    /// cost about 500 instructions per frame in copies (docs/link.md). Every message is
    /// decoded, and so checked, before the handshake rule is applied, as a `HostMessage`
    /// would be: a malformed one is counted as not a message, a valid one as refused.
    #[inline]
    pub fn receive<S: Real>(&mut self, byte: u8) -> Option<LinkEvent<S>> {
        if byte != 0 {
            // A frame's byte: unstuffed inside the caller's loop, no call (docs/link.md).
            return self.decoder.push_frame(byte).and(None);
        }
        self.frame_end()
    }

    /// A zero byte: the frame it closes, decoded and applied (out of line, see `receive`).
    #[inline(never)]
    fn frame_end<S: Real>(&mut self) -> Option<LinkEvent<S>> {
        let frame = self.decoder.push_frame(0)?;
        let Some(kind) = frame.host_kind() else {
            frame.reject();
            return None;
        };
        match kind {
            HostKind::Hello => {
                let version: u16 = frame.payload()?;
                self.handshake = version == PROTOCOL_VERSION;
                Some(LinkEvent::Hello)
            }
            // Turning the bridges off is honoured from anyone, handshake or not.
            HostKind::Disable => {
                frame.payload::<()>()?;
                self.enabled = false;
                Some(LinkEvent::Disabled)
            }
            HostKind::Heartbeat => {
                let _sequence: u16 = frame.payload()?;
                self.after_handshake()?;
                self.ticks_since_heartbeat = 0;
                None
            }
            HostKind::Enable => {
                frame.payload::<()>()?;
                self.after_handshake()?;
                if self.fault.is_none() && self.heartbeat_fresh() {
                    self.enabled = true;
                } else {
                    bump(&mut self.refused.enable_refused);
                }
                None
            }
            HostKind::ResetFault => {
                frame.payload::<()>()?;
                self.after_handshake()?;
                self.fault = None;
                None
            }
            HostKind::SetImpedance => {
                let settings: ImpedanceSettings = frame.payload()?;
                self.after_handshake()?;
                if !impedance_is_valid(&settings) {
                    bump(&mut self.refused.bad_settings);
                    return None;
                }
                // Built in the event itself: through an `Option` of the parameters, the
                // compiler copied the event byte by byte (about 440 instructions).
                Some(LinkEvent::Impedance(ImpedanceParameters {
                    stiffness: converted(&settings.stiffness),
                    damping: converted(&settings.damping),
                    mass: converted(&settings.mass),
                }))
            }
            HostKind::SetObject => {
                let (slot, object): (u8, SceneObject) = frame.payload()?;
                self.after_handshake()?;
                Some(LinkEvent::Object { slot, object })
            }
            HostKind::Sensors => {
                let sensors: SensorFrame = frame.payload()?;
                self.after_handshake()?;
                self.ticks_since_heartbeat = 0;
                self.sensors = Some(sensors);
                Some(LinkEvent::Sensors)
            }
            HostKind::PilSetup => {
                let setup: PilSetup = frame.payload()?;
                self.after_handshake()?;
                self.pil_setup = Some(setup);
                Some(LinkEvent::PilSetup)
            }
            HostKind::SetExcitation => {
                let joint: ExcitationJoint = frame.payload()?;
                self.after_handshake()?;
                self.excitation_joint = Some(joint);
                Some(LinkEvent::ExcitationJoint)
            }
            HostKind::SetEffect => {
                let effect: LinkEffect = frame.payload()?;
                self.after_handshake()?;
                if !usable_effect(&effect) {
                    bump(&mut self.refused.bad_settings);
                    return None;
                }
                Some(LinkEvent::Effect(effect))
            }
        }
    }

    /// `Some` after a handshake of this protocol version; else `None`, the message counted as
    /// refused.
    fn after_handshake(&mut self) -> Option<()> {
        if !self.handshake {
            bump(&mut self.refused.before_handshake);
        }
        self.handshake.then_some(())
    }

    /// Once per current-loop period: advances the heartbeat watchdog. Returns `true` when the
    /// bridges may be driven this period.
    pub fn on_current_tick(&mut self) -> bool {
        self.ticks_since_heartbeat = self.ticks_since_heartbeat.saturating_add(1);
        if self.enabled && !self.heartbeat_fresh() {
            self.enabled = false;
            self.fault = Some(LinkFault::HeartbeatLost);
        }
        self.outputs_allowed()
    }

    fn heartbeat_fresh(&self) -> bool {
        self.ticks_since_heartbeat <= self.settings.heartbeat_timeout_ticks
    }

    /// `true` when the host has enabled the bridges and no link fault is latched.
    pub fn outputs_allowed(&self) -> bool {
        self.enabled && self.fault.is_none()
    }

    /// The latched link fault, if any.
    pub fn fault(&self) -> Option<LinkFault> {
        self.fault
    }

    /// The last sensor frame received (processor in the loop).
    pub fn sensors(&self) -> Option<&SensorFrame> {
        self.sensors.as_ref()
    }

    /// The last processor-in-the-loop setup received.
    pub fn pil_setup(&self) -> Option<&PilSetup> {
        self.pil_setup.as_ref()
    }

    /// The last joint of an excitation received (processor in the loop).
    pub fn excitation_joint(&self) -> Option<&ExcitationJoint> {
        self.excitation_joint.as_ref()
    }

    /// The frame decoder's counts.
    pub fn counters(&self) -> LinkCounters {
        self.decoder.counters()
    }

    /// What the link refused.
    pub fn refused(&self) -> RefusedCounters {
        self.refused
    }

    /// Frames the answer to a `Hello` into `out`; returns its length.
    pub fn hello(&self, out: &mut [u8; MAX_FRAME_BYTES]) -> Result<usize, EncodeError> {
        encode(&DeviceMessage::Hello(self.info), out)
    }
}

/// Whether impedance settings may be applied: every value finite, the stiffness and damping
/// not negative, the mass positive.
fn impedance_is_valid(settings: &ImpedanceSettings) -> bool {
    let gains = || settings.stiffness.iter().chain(&settings.damping);
    gains().chain(&settings.mass).all(|v| v.is_finite())
        && gains().all(|v| *v >= 0.0)
        && settings.mass.iter().all(|v| *v > 0.0)
}

/// `true` for an effect the device can render: every value finite, stiffness, damping,
/// amplitude and frequency not negative, a vibration's direction not zero.
fn usable_effect(effect: &LinkEffect) -> bool {
    let finite = |values: &[f32]| values.iter().all(|v| v.is_finite());
    let not_negative = |value: f32| value.is_finite() && value >= 0.0;
    match *effect {
        LinkEffect::None => true,
        LinkEffect::Spring { anchor, stiffness } => finite(&anchor) && not_negative(stiffness),
        LinkEffect::Viscous { damping } => not_negative(damping),
        LinkEffect::Force { force } => finite(&force),
        LinkEffect::Vibration { direction, amplitude, frequency } => {
            finite(&direction)
                && direction.iter().any(|v| *v != 0.0)
                && not_negative(amplitude)
                && not_negative(frequency)
        }
    }
}

/// Per-axis settings in the runtime's scalar type.
#[inline(always)]
fn converted<S: Real>(values: &[f32; MAX_TASK]) -> [S; MAX_TASK] {
    let [x, y, z] = *values;
    [S::from_f64(f64::from(x)), S::from_f64(f64::from(y)), S::from_f64(f64::from(z))]
}

fn bump(count: &mut u32) {
    *count = count.saturating_add(1);
}

/// A board whose bridges the link may hold off: with `open == false`, every voltage command
/// becomes [`VoltageOutput::disable`]; the sensors are read as usual.
pub struct Gated<'a, B> {
    /// The board.
    pub board: &'a mut B,
    /// Whether the bridges may be driven this period ([`DeviceLink::on_current_tick`]).
    pub open: bool,
}

impl<B: Encoders<N>, const N: usize> Encoders<N> for Gated<'_, B> {
    fn counts(&mut self) -> [i32; N] {
        self.board.counts()
    }
}

impl<S, B: CurrentSense<S, N>, const N: usize> CurrentSense<S, N> for Gated<'_, B> {
    fn currents(&mut self) -> [S; N] {
        self.board.currents()
    }
}

impl<S, B: ForceSense<S, M>, const M: usize> ForceSense<S, M> for Gated<'_, B> {
    fn force_readings(&mut self) -> [S; M] {
        self.board.force_readings()
    }
}

impl<S, B: VoltageOutput<S, N>, const N: usize> VoltageOutput<S, N> for Gated<'_, B> {
    fn set_voltages(&mut self, volts: &[S; N]) {
        if self.open {
            self.board.set_voltages(volts);
        } else {
            self.board.disable();
        }
    }
    fn disable(&mut self) {
        self.board.disable();
    }
}
