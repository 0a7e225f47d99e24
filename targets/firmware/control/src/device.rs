//! Device mode (docs/link-device.md): what every board does the same when a host drives it
//! over the link. The board image owns the transport (a UART, polled or by interrupt) and its
//! clock; this module applies what the host sends to the controller ([`DeviceMode::on_event`]:
//! the answer to `Hello`, new impedance settings, scene objects) and frames the state stream
//! ([`state_frame`]). The link's own rules (handshake, heartbeat watchdog, enable, reset) are
//! [`DeviceLink`]'s. [`TransmitQueue`] holds the bytes for a transmitter that takes one at a
//! time.
//!
//! The controller follows a [`LinkSource`]: at start a spring to the start pose; on a 2-D task,
//! the planar scene of the objects the host sent, on a 3-D task the god object's, with the
//! scene's free-space effect. Every `SetObject` is answered (`DeviceMessage::Scene`): the slot
//! holds the object and the device renders it, or the slot keeps what it held and the answer
//! says why ([`object_outcome`]; an object is never acknowledged that is not rendered). A
//! change of settings, objects or effect replaces the
//! reference (the renderer starts afresh at the device point) and keeps the estimator and the
//! filters running; with every slot empty again, the spring to the start pose is back.
//!
//! **Identification excitation.** Once every joint's `SetExcitation` has arrived and they make
//! a playable excitation ([`ExcitationParts::playable`]), the device holds it, and plays it
//! from where it is from the first tick its bridges are on ([`DeviceMode::on_current_tick`]:
//! the runtime's joint-space tracking law in place of the impedance law, the series entered
//! from the current pose by `FourierTrajectory::reference_from`); its state frames say so
//! ([`StateFrame::EXCITING`]). A refused excitation (unplayable) is counted
//! ([`DeviceMode::refused_changes`]) and never played, so the frames never carry the bit. A
//! new excitation replaces the one before; a `Disable`, `SetImpedance`, `SetObject` or
//! `SetEffect`, or the bridges going off while it plays, ends it (back to the settings' and the
//! scene's reference; it must be sent again). The host sends it before `Enable`: a 118-byte
//! message takes QEMU's UART about 10 ms, longer than the heartbeat timeout of an enabled
//! device.

use hapticgen_protocol::{
    encode, ChannelScales, DeviceMessage, LinkEffect, SceneAnswer, SceneObject, SceneOutcome, StateFrame,
    StateSample, MAX_FRAME_BYTES, MAX_TASK,
};
use hapticgen_runtime::control::{ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters};
use hapticgen_runtime::estimation::JointState;
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_runtime::linalg::mat_vec;
use hapticgen_runtime::tick::HapticLoopSettings;
use hapticgen_runtime::tick::ImpedanceReport;
use hapticgen_runtime::Real;

use crate::app::{Controller, TickOutcome};
use crate::board::{Board, CycleCounter};
use crate::excitation::{Excitation, ExcitationParts};
use crate::link::{DeviceLink, LinkEvent};
use crate::link_scene::{first, object_outcome, LinkSource, SCENE_OBJECTS};
use crate::setup::Setup;

/// The host's settings and scene as the device holds them (a rig of `N` joints and `M` task
/// axes), and the identification excitation it plays, if any.
#[derive(Clone, Copy, Debug)]
pub struct DeviceMode<const N: usize, const M: usize> {
    impedance: ImpedanceParameters<f32, MAX_TASK>,
    objects: [SceneObject; SCENE_OBJECTS],
    effect: LinkEffect,
    home: [f32; M],
    grid: f32,
    refused_changes: u32,
    excitation_parts: ExcitationParts<N>,
    armed: Option<Excitation<N>>,
    playing: Option<Playing<N>>,
}

/// An excitation being played: from `start` (the joint angles when it began), its first tick
/// the controller's impedance tick `first_tick`.
#[derive(Clone, Copy, Debug)]
struct Playing<const N: usize> {
    excitation: Excitation<N>,
    start: [f32; N],
    first_tick: u32,
}

impl<const N: usize, const M: usize> DeviceMode<N, M> {
    /// Holding the task point at `home` with `stiffness` and `damping` on every axis (unit
    /// mass), scenes to be drawn on the anti-drift grid `grid` (m); no object yet.
    pub fn new(home: [f32; M], stiffness: f32, damping: f32, grid: f32) -> Self {
        Self {
            impedance: ImpedanceParameters {
                stiffness: [stiffness; MAX_TASK],
                damping: [damping; MAX_TASK],
                mass: [1.0; MAX_TASK],
            },
            objects: [SceneObject::Empty; SCENE_OBJECTS],
            effect: LinkEffect::None,
            home,
            grid,
            refused_changes: 0,
            excitation_parts: ExcitationParts::EMPTY,
            armed: None,
            playing: None,
        }
    }

    /// `true` while the device plays an identification excitation (module documentation).
    pub fn exciting(&self) -> bool {
        self.playing.is_some()
    }

    /// The impedance the controller starts with.
    pub fn parameters(&self) -> ImpedanceParameters<f32, M> {
        ImpedanceParameters {
            stiffness: first(&self.impedance.stiffness),
            damping: first(&self.impedance.damping),
            mass: first(&self.impedance.mass),
        }
    }

    /// The reference the settings, objects and effect ask for (a scene when there is an object
    /// or an effect; the effect itself is added by [`LinkSource::with_effect`]); `None` if
    /// unusable (a scene on a task that is neither 2-D nor 3-D, an object the task cannot draw,
    /// more objects than the scene holds).
    pub fn source(&self) -> Option<LinkSource<M>> {
        let has_objects = self.objects.iter().any(|object| *object != SceneObject::Empty);
        let scene = has_objects || self.effect != LinkEffect::None;
        LinkSource::new(self.home, &self.impedance, &self.objects, scene.then_some(self.grid))
    }

    /// Changes the host asked for that could not be applied (a slot out of range, an object or
    /// a scene the task cannot draw, an excitation that cannot be played): counted, never
    /// acted on.
    pub fn refused_changes(&self) -> u32 {
        self.refused_changes
    }

    /// Applies `event` (what [`DeviceLink::receive`] returned for a byte) to `control`; returns
    /// the length of a frame to send back, framed into `out` (the answer to `Hello`, the
    /// `Scene` answer to an object), if any.
    pub fn on_event<R>(
        &mut self,
        event: LinkEvent<f32>,
        control: &mut Controller<R, LinkSource<M>, N, M>,
        link: &DeviceLink,
        out: &mut [u8; MAX_FRAME_BYTES],
    ) -> Option<usize>
    where
        R: FusedImpedance<N, M, Scalar = f32> + Clone,
    {
        // Anything the host changes ends an excitation: the settings' and the scene's
        // reference is given back (rebuilt below, or by `set_object`).
        let stops = matches!(
            event,
            LinkEvent::Impedance(_) | LinkEvent::Object { .. } | LinkEvent::Effect(_) | LinkEvent::Disabled
        );
        if stops {
            self.armed = None;
        }
        let stopped = stops && self.playing.take().is_some();
        match event {
            LinkEvent::Hello => return link.hello(out).ok(),
            LinkEvent::Impedance(parameters) => self.impedance = parameters,
            LinkEvent::ExcitationJoint => {
                // One that was playing and is not replaced gives its reference back.
                if self.excitation_joint::<R>(link) && self.armed.is_none() && !self.apply(control) {
                    self.refused_changes = self.refused_changes.saturating_add(1);
                }
                return None;
            }
            LinkEvent::Object { slot, object } => {
                let outcome = self.set_object(slot, object, control);
                if outcome != SceneOutcome::Rendered {
                    self.refused_changes = self.refused_changes.saturating_add(1);
                    if stopped && !self.apply(control) {
                        self.refused_changes = self.refused_changes.saturating_add(1);
                    }
                }
                return encode(&DeviceMessage::Scene(SceneAnswer { slot, outcome }), out).ok();
            }
            LinkEvent::Effect(effect) => self.effect = effect,
            // After an excitation, the reference it replaced.
            LinkEvent::Disabled if stopped => {}
            // Enable, disable, heartbeats and resets are the link's own; sensor frames and
            // PIL setups are for the PIL image.
            LinkEvent::Sensors | LinkEvent::PilSetup | LinkEvent::Disabled => return None,
        }
        if !self.apply(control) {
            self.refused_changes = self.refused_changes.saturating_add(1);
        }
        None
    }

    /// Takes one joint of an excitation; once all have arrived, holds it to play from the next
    /// tick the bridges are on if it is playable (it replaces any excitation before it), else
    /// counts it refused. Returns whether an excitation that was playing has ended.
    fn excitation_joint<R>(&mut self, link: &DeviceLink) -> bool
    where
        R: FusedImpedance<N, M, Scalar = f32> + Clone,
    {
        let Some(part) = link.excitation_joint() else { return false };
        self.excitation_parts.add(part);
        if !self.excitation_parts.settled() {
            return false;
        }
        let parts = core::mem::take(&mut self.excitation_parts);
        self.armed = parts.playable(R::IMPEDANCE_LOOP_HZ);
        if self.armed.is_none() {
            self.refused_changes = self.refused_changes.saturating_add(1);
        }
        self.playing.take().is_some()
    }

    /// The interrupt body of device mode, once per current-loop period
    /// ([`Controller::on_current_tick`]); while an excitation plays, its tracking law takes the
    /// impedance law's place ([`Controller::on_current_tick_joint`]). `open`: the link lets the
    /// bridges on this period (an excitation held starts when they are, one playing ends when
    /// they are not).
    pub fn on_current_tick<R, B, C>(
        &mut self,
        control: &mut Controller<R, LinkSource<M>, N, M>,
        board: &mut B,
        clock: &C,
        open: bool,
    ) -> TickOutcome<f32, N>
    where
        R: FusedImpedance<N, M, Scalar = f32> + Clone,
        B: Board<f32, N, M>,
        C: CycleCounter,
    {
        if !open && self.playing.take().is_some() && !self.apply(control) {
            self.refused_changes = self.refused_changes.saturating_add(1);
        }
        if let (true, Some(excitation)) = (open, self.armed) {
            self.armed = None;
            self.playing = Some(Playing {
                excitation,
                start: control.haptic.joint_state().position,
                first_tick: control.impedance_ticks().wrapping_add(1),
            });
        }
        match &self.playing {
            Some(play) => control.on_current_tick_joint(board, clock, |tick| {
                let excitation = &play.excitation;
                let t =
                    excitation.time(tick.wrapping_sub(play.first_tick).wrapping_add(1), R::IMPEDANCE_LOOP_HZ);
                let reference = excitation.trajectory.reference_from(&play.start, t);
                let tracking = excitation.tracking;
                move |rig: &R, terms: &_, state: &JointState<f32, N>| {
                    tracking.torque(rig, terms, &state.position, &state.velocity, &reference)
                }
            }),
            None => control.on_current_tick(board, clock),
        }
    }

    /// Puts `object` in `slot` if the device renders it there, and says what became of it (a
    /// refused object leaves the slot and the controller as they were).
    fn set_object<R>(
        &mut self,
        slot: u8,
        object: SceneObject,
        control: &mut Controller<R, LinkSource<M>, N, M>,
    ) -> SceneOutcome
    where
        R: FusedImpedance<N, M, Scalar = f32> + Clone,
    {
        let Some(previous) = self.objects.get(usize::from(slot)).copied() else {
            return SceneOutcome::NoSlot;
        };
        let outcome = object_outcome::<M>(&object);
        if outcome != SceneOutcome::Rendered {
            return outcome;
        }
        self.set_slot(slot, object);
        if self.apply(control) {
            SceneOutcome::Rendered
        } else {
            // Not drawn after all (no room in the renderer): as it was.
            self.set_slot(slot, previous);
            SceneOutcome::NotRendered
        }
    }

    fn set_slot(&mut self, slot: u8, object: SceneObject) {
        if let Some(entry) = self.objects.get_mut(usize::from(slot)) {
            *entry = object;
        }
    }

    /// Gives `control` the settings and the reference the device now holds; `false` (and
    /// `control`'s reference unchanged) if that reference cannot be built.
    fn apply<R>(&self, control: &mut Controller<R, LinkSource<M>, N, M>) -> bool
    where
        R: FusedImpedance<N, M, Scalar = f32> + Clone,
    {
        // The controller keeps its estimator and filters (the device has not stopped); the
        // settings and the reference are replaced.
        control.haptic.controller.parameters = self.parameters();
        let impedance_period = 1.0 / R::IMPEDANCE_LOOP_HZ as f32;
        match self.source().and_then(|source| source.with_effect(&self.effect, impedance_period)) {
            Some(source) => {
                control.haptic.source = source;
                true
            }
            None => false,
        }
    }
}

/// The haptic loop's settings of a board image: Controller 3 (`J^T`: any rig) with
/// `parameters`, the estimator at `impedance_loop_hz` (50 Hz velocity and 20 Hz acceleration
/// filters), the device homed at `setup.start` where the encoders read `initial_counts`, the
/// force sensor's `force_calibration`, each joint's current-loop gains from the model.
pub fn loop_settings<S: Real, const N: usize, const M: usize>(
    setup: &Setup<S, N>,
    parameters: ImpedanceParameters<S, M>,
    impedance_loop_hz: u32,
    initial_counts: [i32; N],
    force_calibration: ForceSensorCalibration<S, M>,
) -> HapticLoopSettings<S, N, M> {
    HapticLoopSettings {
        controller: ImpedanceController {
            law: ImpedanceLaw::JacobianTranspose,
            parameters,
            options: ControlOptions {
                omit_damping_compensation: false,
                min_abs_jacobian_determinant: S::from_f64(1e-6),
                spring_lead_time: S::ZERO,
                friction_compensation_band: None,
            },
        },
        estimator: EstimatorSettings::at_rate(impedance_loop_hz),
        zero_offset: setup.start,
        initial_counts,
        force_calibration,
        current_gains: setup.current_gains,
        max_tick_gap: 1,
    }
}

/// What a board's sensors read in the period of an impedance tick, for its state frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickSensors<const N: usize> {
    /// The encoders' counts.
    pub counts: [i32; N],
    /// The measured motor currents, A.
    pub currents: [f32; N],
}

/// Frames the state of the impedance tick that produced `report` into `out` (a `State`
/// message in [`ChannelScales::DESKTOP`] units): the encoders' counts and the measured motor
/// currents of `sensors`, the estimator's joint velocities, the task position and velocity
/// through `rig`, the commanded torques, whether an excitation plays (`exciting`,
/// [`StateFrame::EXCITING`]), the safety monitor's fault and the link's
/// ([`StateFrame::LINK_FAULT`]), the largest impedance-tick cost so far. Returns its length.
pub fn state_frame<R, const N: usize, const M: usize>(
    control: &Controller<R, LinkSource<M>, N, M>,
    rig: &R,
    link: &DeviceLink,
    sensors: &TickSensors<N>,
    exciting: bool,
    report: &ImpedanceReport<f32, N>,
    out: &mut [u8; MAX_FRAME_BYTES],
) -> Option<usize>
where
    R: FusedImpedance<N, M, Scalar = f32> + Clone,
{
    let state = control.haptic.joint_state();
    let position = rig.position(&state.position);
    let velocity = mat_vec(&rig.jacobian(&state.position), &state.velocity);
    let safety_fault = control.first_fault.map_or(0, |(_, fault)| fault.number());
    let link_fault = if link.fault().is_some() { StateFrame::LINK_FAULT } else { 0 };
    let sample = StateSample {
        tick: control.impedance_ticks(),
        enabled: link.outputs_allowed(),
        exciting,
        fault: safety_fault | link_fault,
        encoder_counts: &sensors.counts,
        joint_velocity: &state.velocity,
        task_position: &position,
        task_velocity: &velocity,
        joint_torque: &report.command.torque,
        motor_current: &sensors.currents,
        tick_instructions: control.impedance_cost.max,
    };
    StateFrame::encode_sample(&sample, &ChannelScales::DESKTOP, out)
}

/// Bytes waiting for a transmitter that takes one at a time (a polled UART): a ring of 256
/// indexed by `u8`, so that no index can be out of bounds (no panic path), holding at most 255.
/// A frame is queued whole or not at all, so that a full queue never sends half a frame.
#[derive(Clone, Debug)]
pub struct TransmitQueue {
    bytes: [u8; 256],
    head: u8,
    tail: u8,
}

impl TransmitQueue {
    /// An empty queue.
    pub const fn new() -> Self {
        Self { bytes: [0; 256], head: 0, tail: 0 }
    }

    /// Bytes queued.
    pub fn len(&self) -> usize {
        usize::from(self.tail.wrapping_sub(self.head))
    }

    /// `true` when no byte is queued.
    pub fn is_empty(&self) -> bool {
        self.head == self.tail
    }

    /// Queues all of `frame`, or none of it if it does not fit; returns whether it did.
    pub fn push_frame(&mut self, frame: &[u8]) -> bool {
        if frame.len() > 255 - self.len() {
            return false;
        }
        for &byte in frame {
            self.bytes[usize::from(self.tail)] = byte;
            self.tail = self.tail.wrapping_add(1);
        }
        true
    }

    /// The next byte to send.
    pub fn pop(&mut self) -> Option<u8> {
        if self.is_empty() {
            return None;
        }
        let byte = self.bytes[usize::from(self.head)];
        self.head = self.head.wrapping_add(1);
        Some(byte)
    }
}

impl Default for TransmitQueue {
    fn default() -> Self {
        Self::new()
    }
}
