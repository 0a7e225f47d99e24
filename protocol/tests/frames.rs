//! The link's framing and state stream: every valid frame is accepted and gives back its
//! message, everything else is counted and dropped; corruption, garbage, truncation and
//! oversized input never stall or panic the receiver; the state frame's size and precision.

use hapticgen_protocol::message::Channels;
use hapticgen_protocol::{
    encode, ActuatorFrame, ChannelScales, CountUnwrapper, DeviceInfo, DeviceMessage, ExcitationJoint,
    FrameDecoder, HostKind, HostMessage, ImpedanceSettings, LinkCounters, LinkEffect, PilLaw, PilSetup,
    SceneAnswer, SceneObject, SceneOutcome, SensorFrame, StateFrame, StateSample, EXCITATION_HARMONICS,
    MAX_FRAME_BYTES,
};
use proptest::prelude::*;

fn frame_of<T: serde::Serialize>(message: &T) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME_BYTES];
    let length = encode(message, &mut out).expect("every message fits a frame");
    out[..length].to_vec()
}

/// Feeds `bytes` one at a time; the messages that come out.
fn receive<T: serde::de::DeserializeOwned>(decoder: &mut FrameDecoder, bytes: &[u8]) -> Vec<T> {
    bytes.iter().filter_map(|&b| decoder.push::<T>(b)).collect()
}

fn finite() -> impl Strategy<Value = f32> {
    -1e6f32..1e6f32
}

fn task_vector() -> impl Strategy<Value = [f32; 3]> {
    [finite(), finite(), finite()]
}

fn scene_object() -> impl Strategy<Value = SceneObject> {
    prop_oneof![
        Just(SceneObject::Empty),
        (task_vector(), finite(), any::<bool>(), finite(), finite()).prop_map(
            |(centre, radius, cavity, stiffness, damping)| SceneObject::Sphere {
                centre,
                radius,
                cavity,
                stiffness,
                damping
            }
        ),
        (task_vector(), task_vector(), finite(), finite()).prop_map(|(point, normal, stiffness, damping)| {
            SceneObject::HalfSpace { point, normal, stiffness, damping }
        }),
        (task_vector(), task_vector(), finite(), finite()).prop_map(
            |(centre, half_extents, stiffness, damping)| SceneObject::Box {
                centre,
                half_extents,
                stiffness,
                damping
            }
        ),
    ]
}

fn host_message() -> impl Strategy<Value = HostMessage> {
    prop_oneof![
        any::<u16>().prop_map(|version| HostMessage::Hello { version }),
        any::<u16>().prop_map(|sequence| HostMessage::Heartbeat { sequence }),
        Just(HostMessage::Enable),
        Just(HostMessage::Disable),
        Just(HostMessage::ResetFault),
        (task_vector(), task_vector(), task_vector()).prop_map(|(stiffness, damping, mass)| {
            HostMessage::SetImpedance(ImpedanceSettings { stiffness, damping, mass })
        }),
        (any::<u8>(), scene_object()).prop_map(|(slot, object)| HostMessage::SetObject { slot, object }),
        (
            any::<u16>(),
            any::<[i32; 6]>(),
            [finite(), finite(), finite(), finite(), finite(), finite()],
            task_vector()
        )
            .prop_map(|(tick, encoder_counts, motor_current, force_readings)| {
                HostMessage::Sensors(SensorFrame { tick, encoder_counts, motor_current, force_readings })
            }),
        pil_setup().prop_map(HostMessage::PilSetup),
        link_effect().prop_map(HostMessage::SetEffect),
        excitation_joint().prop_map(HostMessage::SetExcitation),
    ]
}

fn excitation_joint() -> impl Strategy<Value = ExcitationJoint> {
    (
        any::<u8>(),
        [finite(), finite(), finite(), finite()],
        proptest::array::uniform12(finite()),
        proptest::array::uniform12(finite()),
    )
        .prop_map(|(joint, [period, ramp, tracking_hz, offset], sine, cosine)| ExcitationJoint {
            joint,
            period,
            ramp,
            tracking_hz,
            offset,
            sine,
            cosine,
        })
}

fn link_effect() -> impl Strategy<Value = LinkEffect> {
    prop_oneof![
        Just(LinkEffect::None),
        (task_vector(), finite()).prop_map(|(anchor, stiffness)| LinkEffect::Spring { anchor, stiffness }),
        finite().prop_map(|damping| LinkEffect::Viscous { damping }),
        task_vector().prop_map(|force| LinkEffect::Force { force }),
        (task_vector(), finite(), finite()).prop_map(|(direction, amplitude, frequency)| {
            LinkEffect::Vibration { direction, amplitude, frequency }
        }),
    ]
}

fn joint_vector() -> impl Strategy<Value = [f32; 6]> {
    [finite(), finite(), finite(), finite(), finite(), finite()]
}

fn pil_setup() -> impl Strategy<Value = PilSetup> {
    (
        prop_oneof![
            Just(PilLaw::ForceFeedback),
            Just(PilLaw::AccelerationFeedback),
            Just(PilLaw::NaturalInertia),
            Just(PilLaw::JacobianTranspose),
            Just(PilLaw::Excitation)
        ],
        [finite(), finite(), finite(), finite()],
        joint_vector(),
        any::<[i32; 6]>(),
        (task_vector(), task_vector(), task_vector()),
        proptest::option::of(finite()),
    )
        .prop_map(
            |(law, [velocity, acceleration, determinant, lead], zero_offset, initial_counts, axes, grid)| {
                let (reference, force_scale, force_offset) = axes;
                PilSetup {
                    law,
                    velocity_cutoff_hz: velocity,
                    acceleration_cutoff_hz: acceleration,
                    zero_offset,
                    initial_counts,
                    reference,
                    force_scale,
                    force_offset,
                    min_abs_jacobian_determinant: determinant,
                    spring_lead_time: lead,
                    scene_grid_spacing: grid,
                }
            },
        )
}

/// A state sample of `joints` joints and `task` axes with values inside the desktop scales.
fn state_frame(joints: usize, task: usize) -> impl Strategy<Value = StateFrame> {
    (
        any::<u32>(),
        any::<bool>(),
        any::<u8>(),
        proptest::collection::vec(any::<i32>(), joints),
        proptest::collection::vec(-30.0f32..30.0, 3 * joints),
        proptest::collection::vec(-0.6f32..0.6, 2 * task),
        any::<u32>(),
    )
        .prop_map(move |(tick, enabled, fault, counts, per_joint, per_axis, tick_instructions)| {
            let sample = StateSample {
                tick,
                enabled,
                exciting: false,
                fault,
                encoder_counts: &counts,
                joint_velocity: &per_joint[..joints],
                task_position: &per_axis[..task],
                task_velocity: &per_axis[task..],
                joint_torque: &per_joint[joints..2 * joints],
                motor_current: &per_joint[2 * joints..],
                tick_instructions,
            };
            StateFrame::quantise(&sample, &ChannelScales::DESKTOP).expect("a valid shape")
        })
}

fn device_message() -> impl Strategy<Value = DeviceMessage> {
    prop_oneof![
        (any::<u16>(), any::<u32>(), 1u8..=6, 1u8..=3, any::<u16>()).prop_map(
            |(version, rig_name_hash, joints, task_dim, impedance_loop_hz)| {
                DeviceMessage::Hello(DeviceInfo {
                    version,
                    rig_name_hash,
                    joints,
                    task_dim,
                    impedance_loop_hz,
                    scales: ChannelScales::DESKTOP,
                })
            }
        ),
        (1usize..=6, 1usize..=3).prop_flat_map(|(n, m)| state_frame(n, m)).prop_map(DeviceMessage::State),
        (any::<u16>(), joint_vector(), joint_vector(), joint_vector(), task_vector(), any::<(u8, u8, u32)>())
            .prop_map(|(tick, voltage, current_setpoint, torque, reference, (status, fault, missed))| {
                DeviceMessage::Actuators(ActuatorFrame {
                    tick,
                    voltage,
                    current_setpoint,
                    torque,
                    reference,
                    status,
                    fault,
                    missed,
                })
            }),
        any::<[u32; 5]>().prop_map(|[frames, oversized, bad_stuffing, bad_crc, not_a_message]| {
            DeviceMessage::Link(LinkCounters { frames, oversized, bad_stuffing, bad_crc, not_a_message })
        }),
        (any::<u8>(), 0usize..4).prop_map(|(slot, outcome)| {
            let outcome = [
                SceneOutcome::Rendered,
                SceneOutcome::NotRendered,
                SceneOutcome::BadValues,
                SceneOutcome::NoSlot,
            ][outcome];
            DeviceMessage::Scene(SceneAnswer { slot, outcome })
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Every message, framed and received a byte at a time, comes back equal, after any
    /// garbage that ends in a zero byte (the receiver is back in step).
    #[test]
    fn every_valid_frame_is_accepted(
        host in host_message(),
        device in device_message(),
        garbage in proptest::collection::vec(any::<u8>(), 0..300),
    ) {
        let mut decoder = FrameDecoder::new();
        let mut stream = garbage.clone();
        stream.push(0);
        let before = receive::<HostMessage>(&mut decoder, &stream).len();
        let frames_before = decoder.counters().frames;
        prop_assert_eq!(receive::<HostMessage>(&mut decoder, &frame_of(&host)), vec![host]);
        prop_assert_eq!(decoder.counters().frames, frames_before + 1);
        prop_assert!(before <= 1);

        let mut decoder = FrameDecoder::new();
        let frame = frame_of(&device);
        prop_assert!(!frame[..frame.len() - 1].contains(&0), "a zero inside the frame");
        prop_assert_eq!(receive::<DeviceMessage>(&mut decoder, &frame), vec![device]);
        prop_assert_eq!(decoder.counters(), LinkCounters { frames: 1, ..LinkCounters::default() });
    }

    /// Whatever the bytes, what the receiver accepts is a valid frame: re-encoding the message
    /// gives exactly the bytes it came from. Nothing panics, and every closed non-empty frame
    /// is either accepted or counted.
    #[test]
    fn random_bytes_are_accepted_only_as_valid_frames(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        let mut decoder = FrameDecoder::new();
        let mut current: Vec<u8> = Vec::new();
        let mut closed = 0u32;
        for &b in &bytes {
            current.push(b);
            if let Some(message) = decoder.push::<HostMessage>(b) {
                prop_assert_eq!(frame_of(&message), current.clone());
            }
            if b == 0 {
                closed += u32::from(current.len() > 1);
                current.clear();
            }
        }
        let c = decoder.counters();
        prop_assert_eq!(c.frames + c.dropped(), closed);
    }
}

/// A host message decoded by its kind (`HostKind`, `Received::payload`, as the device's link
/// does): the fields of each kind as `HostKind`'s documentation lists them.
fn by_kind(frame: &[u8]) -> Option<HostMessage> {
    let mut decoder = FrameDecoder::new();
    let (&last, bytes) = frame.split_last()?;
    for &b in bytes {
        assert!(decoder.push_frame(b).is_none());
    }
    let received = decoder.push_frame(last)?;
    Some(match received.host_kind()? {
        HostKind::Hello => HostMessage::Hello { version: received.payload()? },
        HostKind::Heartbeat => HostMessage::Heartbeat { sequence: received.payload()? },
        HostKind::Enable => received.payload::<()>().map(|()| HostMessage::Enable)?,
        HostKind::Disable => received.payload::<()>().map(|()| HostMessage::Disable)?,
        HostKind::ResetFault => received.payload::<()>().map(|()| HostMessage::ResetFault)?,
        HostKind::SetImpedance => HostMessage::SetImpedance(received.payload()?),
        HostKind::SetObject => {
            let (slot, object) = received.payload()?;
            HostMessage::SetObject { slot, object }
        }
        HostKind::Sensors => HostMessage::Sensors(received.payload()?),
        HostKind::PilSetup => HostMessage::PilSetup(received.payload()?),
        HostKind::SetEffect => HostMessage::SetEffect(received.payload()?),
        HostKind::SetExcitation => HostMessage::SetExcitation(received.payload()?),
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1024, ..ProptestConfig::default() })]

    /// Every host message decoded by its kind and fields is the message (the order of
    /// `HostKind` is `HostMessage`'s, and each kind's fields are its variant's); a frame with
    /// a byte more or less is not a message.
    #[test]
    fn host_kinds_decode_as_host_messages(host in host_message()) {
        let frame = frame_of(&host);
        prop_assert_eq!(by_kind(&frame), Some(host));
        let body = postcard::to_allocvec(&host).unwrap();
        for change in [Some(7u8), None] {
            let mut changed = body.clone();
            match change {
                Some(byte) => changed.push(byte),
                None => { changed.pop(); }
            }
            prop_assert_eq!(by_kind(&framed(&changed)), None);
        }
    }

    /// The device's state frame, quantised and framed in one pass (`encode_sample`), is byte
    /// for byte the frame of the quantised `StateFrame` as a `DeviceMessage`, for every shape
    /// and for values in range, out of range and NaN.
    #[test]
    fn state_frames_encoded_in_one_pass_are_the_messages_frames(
        (joints, task) in (0usize..=6, 0usize..=3),
        tick in any::<u32>(),
        enabled in any::<bool>(),
        fault in any::<u8>(),
        counts in any::<[i32; 6]>(),
        per_joint in proptest::collection::vec(prop_oneof![-40.0f32..40.0, Just(f32::NAN), Just(1e30)], 18),
        per_axis in proptest::collection::vec(prop_oneof![-0.7f32..0.7, Just(-f32::INFINITY)], 6),
        tick_instructions in prop_oneof![0u32..70_000, any::<u32>()],
    ) {
        let sample = StateSample {
            tick,
            enabled,
            exciting: false,
            fault,
            encoder_counts: &counts[..joints],
            joint_velocity: &per_joint[..joints],
            task_position: &per_axis[..task],
            task_velocity: &per_axis[3..3 + task],
            joint_torque: &per_joint[6..6 + joints],
            motor_current: &per_joint[12..12 + joints],
            tick_instructions,
        };
        let expected = frame_of(&DeviceMessage::State(StateFrame::quantise(&sample, &ChannelScales::DESKTOP).unwrap()));
        let mut out = [0xAAu8; MAX_FRAME_BYTES];
        let length = StateFrame::encode_sample(&sample, &ChannelScales::DESKTOP, &mut out);
        prop_assert_eq!(length.map(|n| out[..n].to_vec()), Some(expected));
        // A shape `quantise` refuses is refused here too.
        let uneven = StateSample { joint_torque: &per_joint[..joints + 1], ..sample };
        prop_assert_eq!(StateFrame::encode_sample(&uneven, &ChannelScales::DESKTOP, &mut out), None);
    }
}

/// `body` framed as it is, whatever it holds.
fn framed(body: &[u8]) -> Vec<u8> {
    let mut with_crc = body.to_vec();
    with_crc.extend(crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC).checksum(body).to_le_bytes());
    let mut stuffed = vec![0u8; with_crc.len() + 2];
    let n = cobs::encode(&with_crc, &mut stuffed);
    stuffed.truncate(n);
    stuffed.push(0);
    stuffed
}

/// CRC-16/IBM-SDLC detects every error of one or two bits: flipping any bit, or any two bits,
/// of a frame's stuffed body is never accepted as a message (exhaustive over one state frame
/// and one link-counter message).
#[test]
fn every_one_and_two_bit_error_is_rejected() {
    let sample = StateSample {
        tick: 70_000,
        enabled: true,
        exciting: false,
        fault: 0,
        encoder_counts: &[12_000, -5, 40_000],
        joint_velocity: &[0.5, -1.25, 3.0],
        task_position: &[0.1, -0.05, 0.2],
        task_velocity: &[0.01, 0.0, -0.3],
        joint_torque: &[0.25, -0.5, 1.0],
        motor_current: &[0.7, -1.4, 2.8],
        tick_instructions: 1394,
    };
    let state = DeviceMessage::State(StateFrame::quantise(&sample, &ChannelScales::DESKTOP).unwrap());
    let counters = DeviceMessage::Link(LinkCounters {
        frames: 1,
        oversized: 2,
        bad_stuffing: 3,
        bad_crc: 4,
        not_a_message: 5,
    });
    let mut checked = 0u64;
    for message in [state, counters] {
        let frame = frame_of(&message);
        let body_bits = 8 * (frame.len() - 1);
        for first in 0..body_bits {
            for second in first..body_bits {
                let mut corrupted = frame.clone();
                corrupted[first / 8] ^= 1 << (first % 8);
                if second != first {
                    corrupted[second / 8] ^= 1 << (second % 8);
                }
                // A flip that makes a zero byte splits the frame: feed it all the same.
                let mut decoder = FrameDecoder::new();
                let accepted = receive::<DeviceMessage>(&mut decoder, &corrupted);
                assert!(accepted.is_empty(), "bits {first} and {second} flipped: accepted {accepted:?}");
                assert!(decoder.counters().dropped() >= 1);
                checked += 1;
            }
        }
    }
    println!("{checked} corrupted frames, none accepted");
    assert!(checked > 10_000, "{checked} corruptions checked");
}

/// A truncated frame costs at most the frame after it; an endless stream without a zero byte
/// is counted once as oversized when it ends, and the next frame is received.
#[test]
fn truncation_and_oversized_input_cost_at_most_one_more_frame() {
    let heartbeat = |sequence| HostMessage::Heartbeat { sequence };
    let mut decoder = FrameDecoder::new();
    let first = frame_of(&heartbeat(1));
    let mut stream = first[..first.len() / 2].to_vec();
    for sequence in 2..6 {
        stream.extend(frame_of(&heartbeat(sequence)));
    }
    let received = receive::<HostMessage>(&mut decoder, &stream);
    assert_eq!(received, vec![heartbeat(3), heartbeat(4), heartbeat(5)]);
    assert_eq!(decoder.counters().dropped(), 1);

    let mut flood = vec![0x55u8; 100_000];
    flood.push(0);
    flood.extend(frame_of(&heartbeat(9)));
    let received = receive::<HostMessage>(&mut decoder, &flood);
    assert_eq!(received, vec![heartbeat(9)]);
    assert_eq!(decoder.counters().oversized, 1);
}

/// A frame of another protocol's message with a correct CRC (an unknown message kind) is
/// counted as not a message, not acted on.
#[test]
fn an_unknown_message_kind_is_counted_and_dropped() {
    // Variant index 200 of `HostMessage` does not exist.
    #[derive(serde::Serialize)]
    struct Unknown {
        kind: u8,
        payload: [u8; 3],
    }
    let frame = frame_of(&Unknown { kind: 200, payload: [1, 2, 3] });
    let mut decoder = FrameDecoder::new();
    assert!(receive::<HostMessage>(&mut decoder, &frame).is_empty());
    assert_eq!(decoder.counters().not_a_message, 1);
    // A valid message with a byte left over is not accepted either.
    let mut body = postcard::to_allocvec(&HostMessage::Enable).unwrap();
    body.push(7);
    let crc = crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC).checksum(&body).to_le_bytes();
    body.extend(crc);
    let mut stuffed = vec![0u8; body.len() + 2];
    let n = cobs::encode(&body, &mut stuffed);
    stuffed.truncate(n);
    stuffed.push(0);
    assert!(receive::<HostMessage>(&mut decoder, &stuffed).is_empty());
    assert_eq!(decoder.counters().not_a_message, 2);
}

/// The state stream's size: a 3-joint, 3-axis device's frame with every field at its widest
/// is at most 50 bytes (0.5 Mbit/s at 1 kHz on an 8N1 UART: half of 1 Mbit/s); a 6-joint
/// one's at most 74.
#[test]
fn state_frames_fit_a_megabit_uart_at_one_kilohertz() {
    for (joints, task, limit) in [(1, 1, 50), (2, 2, 50), (3, 3, 50), (6, 3, 74)] {
        let counts = vec![i32::MIN; joints];
        let widest = vec![-1e9f32; joints];
        let axis = vec![1e9f32; task];
        let sample = StateSample {
            tick: u32::MAX,
            enabled: true,
            exciting: false,
            fault: u8::MAX,
            encoder_counts: &counts,
            joint_velocity: &widest,
            task_position: &axis,
            task_velocity: &axis,
            joint_torque: &widest,
            motor_current: &widest,
            tick_instructions: u32::MAX,
        };
        let frame = StateFrame::quantise(&sample, &ChannelScales::DESKTOP).unwrap();
        assert!(frame.status & StateFrame::SATURATED != 0);
        let bytes = frame_of(&DeviceMessage::State(frame)).len();
        println!(
            "state frame, {joints} joints, {task} axes: {bytes} bytes, {} kbit/s at 1 kHz (8N1)",
            bytes * 10
        );
        assert!(bytes <= limit, "{joints}×{task}: {bytes} bytes");
    }
}

/// The processor-in-the-loop frames at their widest (every count and every counter at the
/// longest varint) fit a frame; their sizes are those of docs/link.md.
#[test]
fn pil_frames_fit_at_their_widest() {
    let sensors = HostMessage::Sensors(SensorFrame {
        tick: u16::MAX,
        encoder_counts: [i32::MIN; 6],
        motor_current: [1e9; 6],
        force_readings: [1e9; 3],
    });
    let setup = HostMessage::PilSetup(PilSetup {
        law: PilLaw::JacobianTranspose,
        velocity_cutoff_hz: 1e9,
        acceleration_cutoff_hz: 1e9,
        zero_offset: [1e9; 6],
        initial_counts: [i32::MIN; 6],
        reference: [1e9; 3],
        force_scale: [1e9; 3],
        force_offset: [1e9; 3],
        min_abs_jacobian_determinant: 1e9,
        spring_lead_time: 1e9,
        scene_grid_spacing: Some(1e9),
    });
    let actuators = DeviceMessage::Actuators(ActuatorFrame {
        tick: u16::MAX,
        voltage: [1e9; 6],
        current_setpoint: [1e9; 6],
        torque: [1e9; 6],
        reference: [1e9; 3],
        status: u8::MAX,
        fault: u8::MAX,
        missed: u32::MAX,
    });
    let excitation = HostMessage::SetExcitation(ExcitationJoint {
        joint: u8::MAX,
        period: 1e9,
        ramp: 1e9,
        tracking_hz: 1e9,
        offset: 1e9,
        sine: [1e9; EXCITATION_HARMONICS],
        cosine: [1e9; EXCITATION_HARMONICS],
    });
    let sizes = [
        frame_of(&sensors).len(),
        frame_of(&setup).len(),
        frame_of(&actuators).len(),
        frame_of(&excitation).len(),
    ];
    println!(
        "PIL frames at their widest: sensors {} B, setup {} B, actuators {} B, excitation {} B",
        sizes[0], sizes[1], sizes[2], sizes[3]
    );
    assert!(sizes.iter().all(|&n| n <= MAX_FRAME_BYTES));
    // A version-1 peer's actuator frame (tick and voltages only) is not a message of this
    // version: refused, not misread.
    #[derive(serde::Serialize)]
    struct ActuatorsV1 {
        kind: u8,
        tick: u16,
        voltage: [f32; 6],
    }
    let mut decoder = FrameDecoder::new();
    let old = frame_of(&ActuatorsV1 { kind: 2, tick: 1, voltage: [0.5; 6] });
    assert!(receive::<DeviceMessage>(&mut decoder, &old).is_empty());
    assert_eq!(decoder.counters().not_a_message, 1);
}

/// Quantisation: within half a step of the value; beyond the channel's range sent at the
/// limit with the saturation flag; NaN sent as NaN; counts exact modulo 2¹⁶ and unwrapped.
#[test]
fn state_channels_round_to_the_nearest_step_and_flag_what_does_not_fit() {
    let scales = ChannelScales::DESKTOP;
    fn with_velocity(joint_velocity: &[f32]) -> StateSample<'_> {
        StateSample {
            tick: 3,
            enabled: false,
            exciting: false,
            fault: 0,
            encoder_counts: &[123_456, -7],
            joint_velocity,
            task_position: &[0.123_456_7, -0.5],
            task_velocity: &[1.0, -1.0],
            joint_torque: &[0.001_49, 0.0],
            motor_current: &[-2.5, 32.0],
            tick_instructions: 900,
        }
    }
    let sample = |velocity: f32| [velocity, -0.0004];
    let frame = StateFrame::quantise(&with_velocity(&sample(12.345_6)), &scales).unwrap();
    assert!(frame.is_consistent());
    assert_eq!(frame.status, 0, "nothing saturated, disabled");
    let close = |got: Option<f32>, want: f32, unit: f32| {
        let got = got.expect("present");
        assert!((got - want).abs() <= 0.5 * unit * (1.0 + 1e-5), "{got} for {want} (unit {unit})");
    };
    close(frame.joint_velocity(0, &scales), 12.345_6, scales.joint_velocity);
    close(frame.joint_velocity(1, &scales), -0.0004, scales.joint_velocity);
    close(frame.task_position(0, &scales), 0.123_456_7, scales.task_position);
    close(frame.task_position(1, &scales), -0.5, scales.task_position);
    close(frame.task_velocity(1, &scales), -1.0, scales.task_velocity);
    close(frame.joint_torque(0, &scales), 0.001_49, scales.joint_torque);
    close(frame.motor_current(0, &scales), -2.5, scales.motor_current);
    close(frame.motor_current(1, &scales), 32.0, scales.motor_current);
    assert_eq!(frame.joint_velocity(2, &scales), None);
    assert_eq!(frame.encoder_count_wrapped(0), Some(wrapped(123_456)));

    let fast = StateFrame::quantise(&with_velocity(&sample(40.0)), &scales).unwrap();
    assert_eq!(fast.status & StateFrame::SATURATED, StateFrame::SATURATED);
    close(fast.joint_velocity(0, &scales), 32.511, scales.joint_velocity);
    let broken = StateFrame::quantise(&with_velocity(&sample(f32::NAN)), &scales).unwrap();
    assert!(broken.joint_velocity(0, &scales).unwrap().is_nan());
    assert_eq!(broken.status & StateFrame::SATURATED, StateFrame::SATURATED);

    // A shape the protocol cannot carry is refused, not truncated.
    let seven = [0; 7];
    let zero = sample(0.0);
    let too_many = StateSample { encoder_counts: &seven, ..with_velocity(&zero) };
    assert_eq!(StateFrame::quantise(&too_many, &scales), None);

    // Counts: a joint turning 24,000 counts per frame for 50 frames either way.
    let mut unwrapper = CountUnwrapper::new();
    let mut count: i32 = 5;
    for step in [24_000, -24_000] {
        for _ in 0..50 {
            count += step;
            assert_eq!(unwrapper.unwrap(wrapped(count)), count);
        }
    }
}

/// The channel bytes a peer sends must match the frame's shape before it is used: odd or
/// oversized byte strings are not a message, and `is_consistent` tells a shape mismatch.
#[test]
fn channel_bytes_are_checked() {
    let sample = StateSample {
        tick: 0,
        enabled: true,
        exciting: false,
        fault: 0,
        encoder_counts: &[1],
        joint_velocity: &[0.0],
        task_position: &[0.0],
        task_velocity: &[0.0],
        joint_torque: &[0.0],
        motor_current: &[0.0],
        tick_instructions: 0,
    };
    let mut frame = StateFrame::quantise(&sample, &ChannelScales::DESKTOP).unwrap();
    assert!(frame.is_consistent());
    frame.shape = 0x12; // claims 2 joints, 1 axis
    assert!(!frame.is_consistent());
    let odd: Result<Channels, _> = postcard::from_bytes(&[3, 1, 2, 3]);
    assert!(odd.is_err());
    let too_long: Vec<u8> = std::iter::once(62u8).chain(std::iter::repeat_n(1, 62)).collect();
    assert!(postcard::from_bytes::<Channels>(&too_long).is_err());
}

/// `count` as the state frame sends it: modulo 65,025, from −32,512 to 32,512 (in `i64`, apart
/// from the protocol's own `i32` arithmetic).
fn wrapped(count: i32) -> i16 {
    ((i64::from(count) + 32_512).rem_euclid(65_025) - 32_512) as i16
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2048))]
    /// Whatever the device sends (any count, any float: NaN, infinities, far out of range), the
    /// state frame's channels hold no zero byte, each channel's two bytes are the base-255
    /// digits plus one of its value plus 32,512 (decoded here by hand), the scaled values are
    /// the rounded steps clipped to ±32,511 with NaN as −32,512, and the counts are exact
    /// modulo 65,025; and the host unwraps counts that move up to 32,512 a frame.
    #[test]
    fn channels_hold_no_zero_byte_and_decode_by_hand(
        counts in proptest::collection::vec(any::<i32>(), 3),
        values in proptest::collection::vec(prop_oneof![
            any::<f32>(),
            -40.0f32..40.0,
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(32.511_5f32),
            Just(-32.510_5f32),
        ], 9),
        start in any::<i32>(),
        moves in proptest::collection::vec(-32_512i32..=32_512, 1..40),
    ) {
        let scales = ChannelScales::DESKTOP;
        let sample = StateSample {
            tick: 0,
            enabled: true,
            exciting: false,
            fault: 0,
            encoder_counts: &counts,
            joint_velocity: &values[..3],
            task_position: &[],
            task_velocity: &[],
            joint_torque: &values[3..6],
            motor_current: &values[6..],
            tick_instructions: 0,
        };
        let frame = StateFrame::quantise(&sample, &scales).unwrap();
        let bytes = frame.channels.as_bytes();
        prop_assert!(!bytes.contains(&0), "{:?}", bytes);
        let by_hand: Vec<i64> =
            bytes.chunks(2).map(|pair| (i64::from(pair[1]) - 1) * 255 + i64::from(pair[0]) - 1 - 32_512).collect();
        for (j, &count) in counts.iter().enumerate() {
            prop_assert_eq!(by_hand[j], i64::from(wrapped(count)));
            prop_assert_eq!(frame.encoder_count_wrapped(j), Some(wrapped(count)));
        }
        let units = [scales.joint_velocity, scales.joint_torque, scales.motor_current];
        for (k, &value) in values.iter().enumerate() {
            let steps = value / units[k / 3];
            let expected = if steps.is_nan() { -32_512 } else { (steps.round_ties_even() as i64).clamp(-32_511, 32_511) };
            prop_assert_eq!(by_hand[3 + k], expected, "{} steps", steps);
        }
        let mut unwrapper = CountUnwrapper::new();
        let mut count = i32::from(wrapped(start));
        prop_assert_eq!(unwrapper.unwrap(wrapped(count)), count);
        for step in moves {
            count = count.wrapping_add(step);
            prop_assert_eq!(unwrapper.unwrap(wrapped(count)), count);
        }
    }
}

/// A frame whose channels hold a zero byte (which no device sends) is not a state message.
#[test]
fn a_zero_byte_in_the_channels_is_not_a_message() {
    let sample = StateSample {
        tick: 1,
        enabled: true,
        exciting: false,
        fault: 0,
        encoder_counts: &[5],
        joint_velocity: &[0.0],
        task_position: &[],
        task_velocity: &[],
        joint_torque: &[0.0],
        motor_current: &[0.0],
        tick_instructions: 0,
    };
    let message = DeviceMessage::State(StateFrame::quantise(&sample, &ChannelScales::DESKTOP).unwrap());
    let mut body = postcard::to_allocvec(&message).unwrap();
    assert!(postcard::from_bytes::<DeviceMessage>(&body).is_ok());
    // The last byte is the last channel's high byte.
    *body.last_mut().unwrap() = 0;
    assert!(postcard::from_bytes::<DeviceMessage>(&body).is_err());
}

/// Since protocol version 5: the device's answer to a `SetObject` is `Scene { slot, outcome }`, four
/// bytes of postcard (the kind 4, the slot, the outcome's index); every outcome and the
/// highest slot come back equal through the framing, and an outcome this version does not know
/// is refused, not misread.
#[test]
fn scene_answers_round_trip() {
    use hapticgen_protocol::PROTOCOL_VERSION;
    const { assert!(PROTOCOL_VERSION >= 5) };
    let outcomes =
        [SceneOutcome::Rendered, SceneOutcome::NotRendered, SceneOutcome::BadValues, SceneOutcome::NoSlot];
    for (index, outcome) in outcomes.into_iter().enumerate() {
        for slot in [0u8, 3, 255] {
            let message = DeviceMessage::Scene(SceneAnswer { slot, outcome });
            let body = postcard::to_allocvec(&message).unwrap();
            assert_eq!(body, vec![4, slot, index as u8]);
            let mut decoder = FrameDecoder::new();
            assert_eq!(receive::<DeviceMessage>(&mut decoder, &frame_of(&message)), vec![message]);
        }
    }
    #[derive(serde::Serialize)]
    struct Unknown(u8, u8, u8);
    let mut decoder = FrameDecoder::new();
    assert!(receive::<DeviceMessage>(&mut decoder, &frame_of(&Unknown(4, 0, 4))).is_empty());
    assert_eq!(decoder.counters().not_a_message, 1);
}

/// The excitation's status bit goes out as the device says, by both encoders, beside the
/// enabled bit, and nothing else sets it.
#[test]
fn the_state_frame_says_when_the_device_plays_an_excitation() {
    for (enabled, exciting) in [(false, false), (true, false), (false, true), (true, true)] {
        let sample = StateSample {
            tick: 12,
            enabled,
            exciting,
            fault: 0,
            encoder_counts: &[3, -4],
            joint_velocity: &[0.5, -1.25],
            task_position: &[0.1, -0.05],
            task_velocity: &[0.01, 0.0],
            joint_torque: &[0.25, -0.5],
            motor_current: &[0.7, -1.4],
            tick_instructions: 900,
        };
        let frame = StateFrame::quantise(&sample, &ChannelScales::DESKTOP).unwrap();
        assert_eq!(frame.status & StateFrame::EXCITING != 0, exciting);
        assert_eq!(frame.status & StateFrame::ENABLED != 0, enabled);
        let mut direct = [0u8; hapticgen_protocol::MAX_FRAME_BYTES];
        let length = StateFrame::encode_sample(&sample, &ChannelScales::DESKTOP, &mut direct).unwrap();
        assert_eq!(&direct[..length], &frame_of(&DeviceMessage::State(frame))[..]);
    }
}
