//! Device mode on a 3-D task (docs/link-device.md), on the host with the f32 rig of the `falcon` image
//! (the Delta, the `device-3d` image's line): the scene's objects answered and rendered by the
//! god object, a hand pushing the grip into a half-space held at the depth the wall spring
//! predicts, and the unpowered plant resting on its end stops instead of sagging through its
//! joint limits. The QEMU run (`scripts/device-run-3d.sh`) drives the same code over a UART.

use hapticgen_fw_control::device::{loop_settings, DeviceMode};
use hapticgen_fw_control::link::{DeviceLink, Gated, LinkSettings};
use hapticgen_fw_control::link_scene::{device_info, LinkSource, Reference};
use hapticgen_fw_control::{Controller, CycleCounter};
use hapticgen_fw_reference::variants::falcon_f32 as image;
use hapticgen_fw_sim::plant::SimBoard;
use hapticgen_protocol::{
    encode, DeviceMessage, FrameDecoder, HostMessage, ImpedanceSettings, SceneAnswer, SceneObject,
    SceneOutcome, MAX_FRAME_BYTES, PROTOCOL_VERSION,
};
use hapticgen_runtime::estimation::ForceSensorCalibration;
use hapticgen_runtime::RigModel;

type Control = Controller<image::Rig, LinkSource<3>, 3, 3>;

struct NoClock;

impl CycleCounter for NoClock {
    fn now(&self) -> u32 {
        0
    }
}

struct Device {
    link: DeviceLink,
    mode: DeviceMode<3, 3>,
    control: Control,
    board: SimBoard<image::Rig, 3, 3>,
    periods: u32,
}

impl Device {
    fn new() -> Self {
        let rig = image::Rig::NOMINAL;
        let setup = image::setup();
        let mode = DeviceMode::new(rig.position(&setup.start), 1500.0, 5.0, 3e-4);
        let calibration = ForceSensorCalibration { scale: [1.0; 3], offset: [0.0; 3] };
        let settings =
            loop_settings(&setup, mode.parameters(), image::IMPEDANCE_LOOP_HZ, [0; 3], calibration);
        let control = Controller::new(rig, mode.source().unwrap(), &settings, false).unwrap();
        let board = SimBoard::new(rig, setup.start, 1.0 / image::CURRENT_LOOP_HZ as f32, 1e-4);
        let link = DeviceLink::new(
            device_info(image::NAME, 3, 3, image::IMPEDANCE_LOOP_HZ),
            LinkSettings::with_timeout_ms(6, image::CURRENT_LOOP_HZ),
        );
        Self { link, mode, control, board, periods: 0 }
    }

    fn feed(&mut self, message: &HostMessage) -> Vec<DeviceMessage> {
        let mut frame = [0u8; MAX_FRAME_BYTES];
        let length = encode(message, &mut frame).unwrap();
        let mut answers = Vec::new();
        for &byte in &frame[..length] {
            if let Some(event) = self.link.receive::<f32>(byte) {
                let mut out = [0u8; MAX_FRAME_BYTES];
                if let Some(n) = self.mode.on_event(event, &mut self.control, &self.link, &mut out) {
                    let mut decoder = FrameDecoder::new();
                    answers.extend(out[..n].iter().filter_map(|&b| decoder.push::<DeviceMessage>(b)));
                }
            }
        }
        answers
    }

    /// Runs `seconds` of current-loop periods with a heartbeat every 2 ms; the hand pushes with
    /// `hand` while the bridges are on, as in the QEMU image.
    fn run(&mut self, seconds: f32, hand: [f32; 3]) {
        let periods = (seconds * image::CURRENT_LOOP_HZ as f32) as u32;
        let heartbeat_every = image::CURRENT_LOOP_HZ / 500;
        for _ in 0..periods {
            if self.periods.is_multiple_of(heartbeat_every) {
                self.feed(&HostMessage::Heartbeat { sequence: self.periods as u16 });
            }
            self.periods += 1;
            let open = self.link.on_current_tick();
            self.control.on_current_tick(&mut Gated { board: &mut self.board, open }, &NoClock);
            self.board.advance(&if open { hand } else { [0.0; 3] });
            self.board.stop_at_limits();
        }
    }

    fn position(&self) -> [f32; 3] {
        image::Rig::NOMINAL.position(&self.board.q)
    }
}

/// Unpowered, the Delta rests on its end stops (seen failing without them: joint 0 at 1.48 rad
/// after 0.5 s, through its 0.85 rad limit); every object kind of a 3-D scene is answered `Rendered` and drawn by the god
/// object; enabled, a hand pushing up with 2 N into a half-space whose face is 5 mm above the
/// start is held 2 N / 1000 N/m = 2 mm inside the face, within 2 %.
#[test]
fn a_hand_pushing_into_a_half_space_is_held_at_the_wall_spring_s_depth() {
    let mut device = Device::new();
    let drives = image::Rig::NOMINAL.drives();
    device.run(0.5, [0.0; 3]);
    for (j, (q, drive)) in device.board.q.iter().zip(drives.iter()).enumerate() {
        assert!(
            *q >= drive.position_lower && *q <= drive.position_upper,
            "joint {j} at {q} rad, outside its limits [{}, {}]",
            drive.position_lower,
            drive.position_upper
        );
    }
    assert_eq!(device.feed(&HostMessage::Hello { version: PROTOCOL_VERSION }).len(), 1);
    device.feed(&HostMessage::SetImpedance(ImpedanceSettings {
        stiffness: [1500.0; 3],
        damping: [5.0; 3],
        mass: [1.0; 3],
    }));
    let start_z = image::Rig::NOMINAL.position(&image::setup().start)[2];
    let face = start_z + 0.005;
    let ceiling = SceneObject::HalfSpace {
        point: [0.0, 0.0, face],
        normal: [0.0, 0.0, -1.0],
        stiffness: 1000.0,
        damping: 5.0,
    };
    let sphere = SceneObject::Sphere {
        centre: [0.0, 0.08, start_z],
        radius: 0.01,
        cavity: false,
        stiffness: 1000.0,
        damping: 5.0,
    };
    for (slot, object) in [(0, ceiling), (1, sphere)] {
        assert_eq!(
            device.feed(&HostMessage::SetObject { slot, object }),
            vec![DeviceMessage::Scene(SceneAnswer { slot, outcome: SceneOutcome::Rendered })]
        );
    }
    let Reference::Spatial(_) = &device.control.haptic.source.reference else { panic!("no 3-D scene") };
    device.feed(&HostMessage::Heartbeat { sequence: 0 });
    device.feed(&HostMessage::Enable);
    device.run(1.5, [0.0, 0.0, 2.0]);
    assert!(device.link.outputs_allowed(), "disabled: {:?}", device.link.fault());
    let held = device.position();
    let depth = held[2] - face;
    println!("held {:.4} mm inside the face at {held:?}; F/K = 2 N / 1000 N/m = 2 mm", depth * 1e3);
    assert!((depth - 0.002).abs() < 0.02 * 0.002, "held {depth} m inside the face, F/K = 0.002 m");
    assert!(held[0].abs() < 1e-3 && held[1].abs() < 1e-3, "{held:?}");
}
