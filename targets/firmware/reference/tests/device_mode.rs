//! Device mode's board-independent part (`hapticgen_fw_control::device`), on the host with the
//! f32 rig of the `horizontal` image (the parallel link, the device image's line): what the
//! host's messages do to the controller, and the state frame as the host decodes it. The
//! QEMU run (`scripts/device-run.sh`) drives the same code over a UART; this checks it value
//! by value.

use hapticgen_fw_control::device::{loop_settings, state_frame, DeviceMode, TickSensors};
use hapticgen_fw_control::link::{DeviceLink, LinkSettings};
use hapticgen_fw_control::link_scene::{device_info, LinkSource, Reference};
use hapticgen_fw_control::{Controller, CycleCounter};
use hapticgen_fw_reference::variants::horizontal_f32 as image;
use hapticgen_fw_sim::plant::SimBoard;
use hapticgen_protocol::{
    encode, DeviceMessage, ExcitationJoint, FrameDecoder, HostMessage, ImpedanceSettings, LinkEffect,
    SceneAnswer, SceneObject, SceneOutcome, StateFrame, EXCITATION_HARMONICS, MAX_FRAME_BYTES,
    PROTOCOL_VERSION,
};
use hapticgen_runtime::control::{ImpedanceLaw, ImpedanceParameters};
use hapticgen_runtime::estimation::ForceSensorCalibration;
use hapticgen_runtime::tick::ReferenceSource;

type Control = Controller<image::Rig, LinkSource<2>, 2, 2>;

struct NoClock;

impl CycleCounter for NoClock {
    fn now(&self) -> u32 {
        0
    }
}

/// A device at the image's start pose: its link, its mode, its controller, its plant.
struct Device {
    link: DeviceLink,
    mode: DeviceMode<2, 2>,
    control: Control,
    board: SimBoard<image::Rig, 2, 2>,
}

impl Device {
    fn new() -> Self {
        let rig = image::Rig::NOMINAL;
        let setup = image::setup();
        let mode = DeviceMode::new(rig.position(&setup.start), 1500.0, 5.0, 3e-4);
        let calibration = ForceSensorCalibration { scale: [1.0; 2], offset: [0.0; 2] };
        let settings =
            loop_settings(&setup, mode.parameters(), image::IMPEDANCE_LOOP_HZ, [0; 2], calibration);
        // The boards' settings are Controller 3 at the model's rates, homed at the start pose.
        assert_eq!(settings.controller.law, ImpedanceLaw::JacobianTranspose);
        assert_eq!((settings.zero_offset, settings.estimator.sample_period), (setup.start, 1e-3));
        let control = Controller::new(rig, mode.source().unwrap(), &settings, false).unwrap();
        let board = SimBoard::new(rig, setup.start, 1.0 / image::CURRENT_LOOP_HZ as f32, 1e-4);
        let link = DeviceLink::new(
            device_info(image::NAME, 2, 2, image::IMPEDANCE_LOOP_HZ),
            LinkSettings::with_timeout_ms(6, image::CURRENT_LOOP_HZ),
        );
        Self { link, mode, control, board }
    }

    /// Feeds `message`'s frame byte by byte; returns the frames the device answers with.
    fn feed(&mut self, message: &HostMessage) -> Vec<Vec<u8>> {
        let mut frame = [0u8; MAX_FRAME_BYTES];
        let length = encode(message, &mut frame).unwrap();
        let mut answers = Vec::new();
        for &byte in &frame[..length] {
            if let Some(event) = self.link.receive::<f32>(byte) {
                let mut out = [0u8; MAX_FRAME_BYTES];
                if let Some(n) = self.mode.on_event(event, &mut self.control, &self.link, &mut out) {
                    answers.push(out[..n].to_vec());
                }
            }
        }
        answers
    }

    /// Runs current-loop periods until an impedance tick; returns its state frame, decoded.
    fn state(&mut self) -> StateFrame {
        loop {
            let open = self.link.on_current_tick();
            let mut gated = hapticgen_fw_control::link::Gated { board: &mut self.board, open };
            let outcome = self.mode.on_current_tick(&mut self.control, &mut gated, &NoClock, open);
            let sensors = TickSensors {
                counts: hapticgen_fw_control::Encoders::counts(&mut self.board),
                currents: hapticgen_fw_control::CurrentSense::currents(&mut self.board),
            };
            self.board.advance(&[0.0; 2]);
            if let Some(report) = outcome.impedance {
                let mut out = [0u8; MAX_FRAME_BYTES];
                let rig = image::Rig::NOMINAL;
                let exciting = self.mode.exciting();
                let n = state_frame(&self.control, &rig, &self.link, &sensors, exciting, &report, &mut out)
                    .unwrap();
                match decode(&out[..n]) {
                    DeviceMessage::State(frame) => return frame,
                    other => panic!("not a state frame: {other:?}"),
                }
            }
        }
    }
}

fn decode(frame: &[u8]) -> DeviceMessage {
    let mut decoder = FrameDecoder::new();
    let mut message = None;
    for &byte in frame {
        message = decoder.push::<DeviceMessage>(byte).or(message);
    }
    message.expect("one valid frame")
}

/// FNV-1a, 32 bits, written out here (the device's is `hapticgen_protocol::rig_name_hash`).
fn fnv1a(bytes: &[u8]) -> u32 {
    bytes.iter().fold(2_166_136_261u32, |hash, &byte| (hash ^ u32::from(byte)).wrapping_mul(16_777_619))
}

fn box_at(x: f32) -> SceneObject {
    SceneObject::Box {
        centre: [x, 0.15, 0.0],
        half_extents: [0.02, 0.05, 0.0],
        stiffness: 900.0,
        damping: 3.0,
    }
}

#[test]
fn hello_is_answered_with_this_images_identity() {
    let mut device = Device::new();
    let answers = device.feed(&HostMessage::Hello { version: PROTOCOL_VERSION });
    assert_eq!(answers.len(), 1);
    let DeviceMessage::Hello(info) = decode(&answers[0]) else { panic!("not a hello") };
    assert_eq!(
        (info.version, info.joints, info.task_dim, info.impedance_loop_hz),
        (PROTOCOL_VERSION, 2, 2, 1000)
    );
    assert_eq!(info.rig_name_hash, fnv1a(b"horizontal"));
}

#[test]
fn settings_and_objects_reach_the_controller_after_the_handshake_only() {
    let mut device = Device::new();
    let settings = ImpedanceSettings { stiffness: [800.0; 3], damping: [2.0; 3], mass: [0.5; 3] };
    // Before the handshake: refused by the link, so nothing changes.
    device.feed(&HostMessage::SetImpedance(settings));
    assert_eq!(device.control.haptic.controller.parameters.stiffness, [1500.0; 2]);
    device.feed(&HostMessage::Hello { version: PROTOCOL_VERSION });
    device.feed(&HostMessage::SetImpedance(settings));
    let parameters = device.control.haptic.controller.parameters;
    assert_eq!((parameters.stiffness, parameters.damping, parameters.mass), ([800.0; 2], [2.0; 2], [0.5; 2]));
    // An object turns the spring to the start pose into the planar scene with the object and
    // the settings' free space; emptying the slot turns it back.
    assert!(matches!(device.control.haptic.source.reference, Reference::Fixed(_)));
    let answers = device.feed(&HostMessage::SetObject { slot: 2, object: box_at(-0.033) });
    assert_eq!(
        answers.iter().map(|a| decode(a)).collect::<Vec<_>>(),
        vec![scene_answer(2, SceneOutcome::Rendered)]
    );
    let Reference::Scene(scene) = &device.control.haptic.source.reference else { panic!("no scene") };
    assert_eq!(scene.objects.iter().flatten().count(), 1);
    assert_eq!((scene.free_space_stiffness, scene.free_space_damping), (800.0, 2.0));
    device.feed(&HostMessage::SetObject { slot: 2, object: SceneObject::Empty });
    assert!(matches!(device.control.haptic.source.reference, Reference::Fixed(_)));
    // A slot the device does not have is counted, ignored and answered so.
    assert_eq!(device.mode.refused_changes(), 0);
    let answers = device.feed(&HostMessage::SetObject { slot: 4, object: box_at(0.0) });
    assert_eq!(decode(&answers[0]), scene_answer(4, SceneOutcome::NoSlot));
    assert_eq!(device.mode.refused_changes(), 1);
    assert!(matches!(device.control.haptic.source.reference, Reference::Fixed(_)));
    // A half-space is not drawn by this 2-D device: answered `NotRendered`, the slot keeps its
    // box (seen failing before protocol version 5: the half-space was taken, dropped by the
    // planar renderer, and nothing told the host).
    device.feed(&HostMessage::SetObject { slot: 1, object: box_at(-0.033) });
    let half_space =
        SceneObject::HalfSpace { point: [0.0; 3], normal: [0.0, 0.0, 1.0], stiffness: 1000.0, damping: 2.0 };
    let answers = device.feed(&HostMessage::SetObject { slot: 1, object: half_space });
    assert_eq!(decode(&answers[0]), scene_answer(1, SceneOutcome::NotRendered));
    assert_eq!(device.mode.refused_changes(), 2);
    let Reference::Scene(scene) = &device.control.haptic.source.reference else { panic!("no scene") };
    assert_eq!(scene.objects.iter().flatten().count(), 1);
}

fn scene_answer(slot: u8, outcome: SceneOutcome) -> DeviceMessage {
    DeviceMessage::Scene(SceneAnswer { slot, outcome })
}

/// `SetEffect` gives the device's scene its free-space effect: away from the scene's box, a
/// spring's anchor and stiffness are the reference and `K_d`; touching the box, the box's
/// proxy and stiffness; an effect the device cannot render (a negative stiffness) is refused
/// by the link and changes nothing.
#[test]
fn a_scene_s_effect_reaches_the_reference_away_from_its_objects() {
    let mut device = Device::new();
    device.feed(&HostMessage::Hello { version: PROTOCOL_VERSION });
    device.feed(&HostMessage::SetObject { slot: 0, object: box_at(-0.033) });
    let anchor = [0.01, 0.16, 0.0];
    device.feed(&HostMessage::SetEffect(LinkEffect::Spring { anchor, stiffness: 300.0 }));
    let mut parameters = ImpedanceParameters { stiffness: [0.0; 2], damping: [0.0; 2], mass: [1.0; 2] };
    // Far from the box (its right face is at x = −0.013): the spring.
    let free = device.control.haptic.source.update_reference(&[0.05, 0.15], &mut parameters);
    assert_eq!(free.position, [0.01, 0.16]);
    assert_eq!((parameters.stiffness, parameters.damping), ([300.0; 2], [5.0; 2]));
    // In the box, 3 mm inside its right face: the box's proxy and stiffness, no spring.
    let touching = device.control.haptic.source.update_reference(&[-0.016, 0.15], &mut parameters);
    assert_eq!(parameters.stiffness, [900.0; 2]);
    assert!((touching.position[0] - (-0.013)).abs() < 1e-6, "{:?}", touching.position);
    // A negative stiffness is refused by the link: the spring stays.
    let refused = device.link.refused().bad_settings;
    device.feed(&HostMessage::SetEffect(LinkEffect::Spring { anchor, stiffness: -1.0 }));
    assert_eq!(device.link.refused().bad_settings, refused + 1);
    device.control.haptic.source.update_reference(&[0.05, 0.15], &mut parameters);
    assert_eq!(parameters.stiffness, [300.0; 2]);
    // With the box gone the effect still acts (a scene of no object); with the effect gone
    // too, the spring to the start pose is back.
    device.feed(&HostMessage::SetObject { slot: 0, object: SceneObject::Empty });
    let alone = device.control.haptic.source.update_reference(&[0.05, 0.15], &mut parameters);
    assert_eq!((alone.position, parameters.stiffness), ([0.01, 0.16], [300.0; 2]));
    device.feed(&HostMessage::SetEffect(LinkEffect::None));
    assert!(matches!(device.control.haptic.source.reference, Reference::Fixed(_)));
}

#[test]
fn the_state_frame_says_where_the_device_is_and_what_the_link_holds() {
    let mut device = Device::new();
    let rig = image::Rig::NOMINAL;
    let scales = hapticgen_protocol::ChannelScales::DESKTOP;
    let frame = device.state();
    let expected = rig.position(&image::setup().start);
    for (k, x) in expected.iter().enumerate() {
        let sent = frame.task_position(k, &scales).unwrap();
        assert!((sent - x).abs() <= scales.task_position, "axis {k}: {sent} vs {x}");
    }
    assert_eq!(
        (frame.joints(), frame.task_dim(), frame.status & StateFrame::ENABLED, frame.fault),
        (2, 2, 0, 0)
    );
    // Enabled with fresh heartbeats: the frame says so; the heartbeats stop: the link fault.
    device.feed(&HostMessage::Hello { version: PROTOCOL_VERSION });
    device.feed(&HostMessage::Heartbeat { sequence: 1 });
    device.feed(&HostMessage::Enable);
    let frame = device.state();
    assert_eq!((frame.status & StateFrame::ENABLED, frame.fault), (StateFrame::ENABLED, 0));
    let mut faulted = device.state();
    for _ in 0..20 {
        faulted = device.state();
    }
    assert_eq!((faulted.status & StateFrame::ENABLED, faulted.fault), (0, StateFrame::LINK_FAULT));
}

#[test]
fn the_state_frame_carries_the_task_velocity_of_the_estimated_joint_velocities() {
    let mut device = Device::new();
    let rig = image::Rig::NOMINAL;
    let scales = hapticgen_protocol::ChannelScales::DESKTOP;
    // Set the plant moving (the bridges are off: it coasts to a stop); every tick's frame
    // against `J q̇` of the joints' estimated state.
    device.board.qd = [3.0, -2.0];
    let mut speed = 0.0f32;
    for _ in 0..30 {
        let frame = device.state();
        let state = device.control.haptic.joint_state();
        let jacobian = rig.jacobian(&state.position);
        let mut tick_speed = 0.0f32;
        for (k, row) in jacobian.iter().enumerate() {
            let expected: f32 = row[0] * state.velocity[0] + row[1] * state.velocity[1];
            let sent = frame.task_velocity(k, &scales).unwrap();
            assert!((sent - expected).abs() <= scales.task_velocity, "axis {k}: {sent} vs J q̇ = {expected}");
            tick_speed = tick_speed.hypot(expected);
        }
        speed = speed.max(tick_speed);
    }
    assert!(speed > 0.05, "the device should have moved: largest |J q̇| = {speed} m/s");
}

/// The device's excitation: `period` s, `ramp` s of blend, one harmonic per joint.
fn excitation(period: f32, ramp: f32) -> Vec<HostMessage> {
    (0..2u8)
        .map(|joint| {
            let mut sine = [0.0; EXCITATION_HARMONICS];
            sine[0] = 0.3;
            HostMessage::SetExcitation(ExcitationJoint {
                joint,
                period,
                ramp,
                tracking_hz: 8.0,
                offset: image::setup().start[usize::from(joint)] + 0.1,
                sine,
                cosine: [0.0; EXCITATION_HARMONICS],
            })
        })
        .collect()
}

impl Device {
    /// Hello, a heartbeat and Enable: the bridges on for the next few ticks.
    fn enable(&mut self) {
        self.feed(&HostMessage::Hello { version: PROTOCOL_VERSION });
        self.feed(&HostMessage::Heartbeat { sequence: 1 });
        self.feed(&HostMessage::Enable);
    }

    /// `ticks` state frames, a heartbeat before each (the link stays open).
    fn states(&mut self, ticks: usize) -> Vec<StateFrame> {
        (0..ticks)
            .map(|i| {
                self.feed(&HostMessage::Heartbeat { sequence: 2 + i as u16 });
                self.state()
            })
            .collect()
    }
}

/// A complete excitation sent to an enabled device is played from where the device is: the
/// frames say so from the next tick, the device follows the blend out of its start pose and
/// then the series, and the frames' currents are the measured ones (the torque they stand for
/// follows the commanded one); `Disable` stops it and gives the spring back.
#[test]
fn a_complete_excitation_is_played_from_where_the_device_is_until_disabled() {
    let mut device = Device::new();
    device.enable();
    let start = image::setup().start;
    device.states(5);
    let messages = excitation(1.0, 0.5);
    device.feed(&messages[0]);
    assert!(!device.states(3).iter().any(|f| f.status & StateFrame::EXCITING != 0), "half an excitation");
    device.feed(&messages[1]);
    let frames = device.states(1500);
    assert!(frames.iter().all(|f| f.status & StateFrame::EXCITING != 0 && f.fault == 0));
    assert_eq!(device.mode.refused_changes(), 0);
    let scales = hapticgen_protocol::ChannelScales::DESKTOP;
    // Where the tracking law wants the device: the blend from the start pose into the series
    // (offset start + 0.1, 0.3 rad of the first harmonic, period 1 s). The tick is 1 ms.
    let series = |t: f32, j: usize| start[j] + 0.1 + 0.3 * (core::f32::consts::TAU * t).sin();
    let q = device.control.haptic.joint_state().position;
    for (j, &angle) in q.iter().enumerate() {
        let wanted = series(1.5, j);
        assert!((angle - wanted).abs() < 0.01, "joint {j}: {angle} vs {wanted} rad at 1.5 s");
    }
    // Measured against commanded current, in blocks of 50 ticks (the commanded torque carries
    // the velocity estimate's tick-to-tick noise, which the current loop and the current
    // sense filter out): the measured currents follow the commanded ones, and are not them.
    let (mut difference, mut size, mut equal) = (0.0f32, 0.0f32, 0);
    for block in frames[500..].chunks_exact(50) {
        for j in 0..2 {
            let (mut measured, mut commanded) = (0.0f32, 0.0f32);
            for frame in block {
                let current = frame.motor_current(j, &scales).unwrap();
                let from_torque = frame.joint_torque(j, &scales).unwrap() / image_torque_per_amp(j);
                equal += usize::from((current - from_torque).abs() < scales.motor_current);
                measured += current / 50.0;
                commanded += from_torque / 50.0;
            }
            difference += (measured - commanded).powi(2);
            size += measured.powi(2);
        }
    }
    assert!(size > 0.0 && difference < 0.05 * size, "measured vs commanded currents: {difference} vs {size}");
    assert!(equal < 500, "{equal} of 2000 measured currents are the commanded ones");
    device.feed(&HostMessage::Disable);
    let after = device.states(3);
    assert!(after.iter().all(|f| f.status & (StateFrame::EXCITING | StateFrame::ENABLED) == 0));
    assert!(matches!(device.control.haptic.source.reference, Reference::Fixed(_)));
}

/// The joint torque one ampere of joint `j`'s motor stands for (`k_t N η`).
fn image_torque_per_amp(j: usize) -> f32 {
    let drive = hapticgen_runtime::RigModel::drives(&image::Rig::NOMINAL)[j];
    drive.torque_constant * drive.gear_ratio * drive.efficiency
}

/// An excitation is never claimed that is not played: held while the bridges are off (it
/// plays from the first tick they are on), refused with a period that is not a whole number of
/// ticks (counted), stopped by new settings; the frames carry the bit exactly while it plays.
#[test]
fn an_excitation_that_is_not_played_is_never_claimed() {
    let mut device = Device::new();
    device.feed(&HostMessage::Hello { version: PROTOCOL_VERSION });
    for message in excitation(2.0, 0.5) {
        device.feed(&message);
    }
    assert!(!device.states(3).iter().any(|f| f.status & StateFrame::EXCITING != 0), "the bridges are off");
    device.enable();
    assert!(device.states(3).iter().all(|f| f.status & StateFrame::EXCITING != 0), "held until enabled");
    assert_eq!(device.mode.refused_changes(), 0);
    for message in excitation(2.0005, 0.5) {
        device.feed(&message);
    }
    assert_eq!(device.mode.refused_changes(), 1, "not a whole number of ticks");
    assert!(
        !device.states(3).iter().any(|f| f.status & StateFrame::EXCITING != 0),
        "and it ends the one before"
    );
    assert!(matches!(device.control.haptic.source.reference, Reference::Fixed(_)));
    for message in excitation(2.0, 0.5) {
        device.feed(&message);
    }
    assert!(device.states(3).iter().all(|f| f.status & StateFrame::EXCITING != 0));
    let settings = ImpedanceSettings { stiffness: [800.0; 3], damping: [2.0; 3], mass: [0.5; 3] };
    device.feed(&HostMessage::SetImpedance(settings));
    assert!(
        !device.states(3).iter().any(|f| f.status & StateFrame::EXCITING != 0),
        "stopped by new settings"
    );
    assert_eq!(device.mode.refused_changes(), 1);
}
