//! The device's link under faults, at the paper's 7.5 kHz current loop with the host's bytes
//! arriving as a 1 Mbit/s UART delivers them (13 bytes per period): heartbeat loss, the host
//! disappearing mid-run, a corrupted frame every N, random bytes at full rate. The bridges
//! must be off within 10 ms of the last heartbeat, stay off until a reset and an enable, and
//! no byte stream may stall the period or panic.

use std::collections::VecDeque;

use hapticgen_fw_control::board::VoltageOutput;
use hapticgen_fw_control::link::{DeviceLink, Gated, LinkEvent, LinkFault, LinkSettings};
use hapticgen_protocol::{
    encode, ChannelScales, DeviceInfo, DeviceMessage, ExcitationJoint, FrameDecoder, HostMessage,
    ImpedanceSettings, PilLaw, PilSetup, SensorFrame, EXCITATION_HARMONICS, MAX_FRAME_BYTES,
    PROTOCOL_VERSION,
};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

const CURRENT_LOOP_HZ: u32 = 7500;
const BYTES_PER_TICK: usize = 13; // 1 Mbit/s, 8N1, over one 133 µs period
const HEARTBEAT_EVERY_TICKS: u32 = 15; // 2 ms

fn info() -> DeviceInfo {
    DeviceInfo {
        version: 0,
        rig_name_hash: 0x1234_5678,
        joints: 2,
        task_dim: 2,
        impedance_loop_hz: 1000,
        scales: ChannelScales::DESKTOP,
    }
}

fn frame(message: &HostMessage) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME_BYTES];
    let n = encode(message, &mut out).unwrap();
    out[..n].to_vec()
}

/// The bridges as the board sees them.
#[derive(Default)]
struct Bridges {
    driven: bool,
}

impl VoltageOutput<f32, 2> for Bridges {
    fn set_voltages(&mut self, _volts: &[f32; 2]) {
        self.driven = true;
    }
    fn disable(&mut self) {
        self.driven = false;
    }
}

/// The device side: a link, a receive queue drained at the UART's rate, and the bridges.
struct Device {
    link: DeviceLink,
    incoming: VecDeque<u8>,
    bridges: Bridges,
    ticks: u32,
    hellos: u32,
    impedance: Option<[f32; 3]>,
    /// The period in which the last heartbeat was queued.
    last_heartbeat: u32,
}

impl Device {
    fn new() -> Self {
        Self {
            link: DeviceLink::new(info(), LinkSettings::with_timeout_ms(5, CURRENT_LOOP_HZ)),
            incoming: VecDeque::new(),
            bridges: Bridges::default(),
            ticks: 0,
            hellos: 0,
            impedance: None,
            last_heartbeat: 0,
        }
    }

    fn send(&mut self, message: &HostMessage) {
        self.incoming.extend(frame(message));
    }

    /// One current-loop period: at most a UART period's bytes, the watchdog, the voltages.
    fn tick(&mut self) {
        for _ in 0..BYTES_PER_TICK {
            let Some(byte) = self.incoming.pop_front() else { break };
            match self.link.receive::<f32>(byte) {
                Some(LinkEvent::Hello) => self.hellos += 1,
                Some(LinkEvent::Impedance(p)) => self.impedance = Some(p.stiffness),
                _ => {}
            }
        }
        let open = self.link.on_current_tick();
        Gated { board: &mut self.bridges, open }.set_voltages(&[1.0, -1.0]);
        self.ticks += 1;
    }

    /// Runs `ticks` periods with a heartbeat every 2 ms while `beating`.
    fn run(&mut self, ticks: u32, beating: bool, sequence: &mut u16) {
        for _ in 0..ticks {
            if beating && self.ticks.is_multiple_of(HEARTBEAT_EVERY_TICKS) {
                *sequence = sequence.wrapping_add(1);
                self.send(&HostMessage::Heartbeat { sequence: *sequence });
                self.last_heartbeat = self.ticks;
            }
            self.tick();
        }
    }

    /// Handshake, heartbeats, enable: the bridges driven.
    fn connect(&mut self, sequence: &mut u16) {
        self.send(&HostMessage::Hello { version: PROTOCOL_VERSION });
        self.run(30, true, sequence);
        self.send(&HostMessage::Enable);
        self.run(30, true, sequence);
        assert!(self.bridges.driven, "enabled after the handshake and a heartbeat");
    }
}

#[test]
fn the_bridges_are_off_within_10_ms_of_the_last_heartbeat_and_stay_off_until_reset() {
    let mut device = Device::new();
    let mut sequence = 0;
    device.connect(&mut sequence);
    assert_eq!(device.hellos, 1);

    // The host stops (its process died): no more bytes at all.
    let last_heartbeat_tick = device.last_heartbeat;
    let mut off_at = None;
    for _ in 0..CURRENT_LOOP_HZ {
        device.tick();
        if off_at.is_none() && !device.bridges.driven {
            off_at = Some(device.ticks);
        }
    }
    let off_at = off_at.expect("the bridges went off");
    let after_ms = f64::from(off_at - last_heartbeat_tick) * 1000.0 / f64::from(CURRENT_LOOP_HZ);
    println!("bridges off {after_ms:.2} ms after the last heartbeat was sent");
    assert!(after_ms <= 10.0, "{after_ms} ms");
    assert_eq!(device.link.fault(), Some(LinkFault::HeartbeatLost));

    // The host comes back and beats again: still off. Enable alone is refused.
    device.run(300, true, &mut sequence);
    assert!(!device.bridges.driven);
    device.send(&HostMessage::Enable);
    device.run(30, true, &mut sequence);
    assert!(!device.bridges.driven, "a reappearing host must not re-enable by itself");
    assert_eq!(device.link.refused().enable_refused, 1);
    // Reset, then enable: driven again.
    device.send(&HostMessage::ResetFault);
    device.send(&HostMessage::Enable);
    device.run(30, true, &mut sequence);
    assert!(device.bridges.driven);
}

#[test]
fn nothing_but_disable_is_acted_on_before_the_handshake() {
    let mut device = Device::new();
    let mut sequence = 0;
    device.send(&HostMessage::Hello { version: PROTOCOL_VERSION + 1 });
    device.run(30, true, &mut sequence);
    device.send(&HostMessage::Enable);
    device.send(&HostMessage::SetImpedance(ImpedanceSettings {
        stiffness: [100.0; 3],
        damping: [1.0; 3],
        mass: [0.1; 3],
    }));
    device.run(30, true, &mut sequence);
    assert!(!device.bridges.driven);
    assert_eq!(device.impedance, None);
    assert!(device.link.refused().before_handshake >= 2);
    assert_eq!(device.hellos, 1, "a Hello of another version is still answered");

    device.connect(&mut sequence);
    // Out-of-range settings are refused, valid ones passed on.
    let bad = ImpedanceSettings { stiffness: [f32::NAN, 1.0, 1.0], damping: [1.0; 3], mass: [0.1; 3] };
    device.send(&HostMessage::SetImpedance(bad));
    let negative = ImpedanceSettings { stiffness: [1.0; 3], damping: [-1.0, 0.0, 0.0], mass: [0.1; 3] };
    device.send(&HostMessage::SetImpedance(negative));
    let massless = ImpedanceSettings { stiffness: [1.0; 3], damping: [1.0; 3], mass: [0.1, 0.0, 0.1] };
    device.send(&HostMessage::SetImpedance(massless));
    device.run(30, true, &mut sequence);
    assert_eq!(device.impedance, None);
    assert_eq!(device.link.refused().bad_settings, 3);
    let good = ImpedanceSettings { stiffness: [300.0, 200.0, 100.0], damping: [1.0; 3], mass: [0.1; 3] };
    device.send(&HostMessage::SetImpedance(good));
    device.run(30, true, &mut sequence);
    assert_eq!(device.impedance, Some([300.0, 200.0, 100.0]));
    device.send(&HostMessage::Disable);
    device.run(30, true, &mut sequence);
    assert!(!device.bridges.driven);
}

#[test]
fn corrupted_frames_and_random_bytes_never_stall_or_enable() {
    let mut rng = SmallRng::seed_from_u64(19);
    let mut device = Device::new();
    let mut sequence = 0;
    device.connect(&mut sequence);

    // One heartbeat in five corrupted in one random bit: the others keep the device enabled.
    for round in 0..400u32 {
        sequence = sequence.wrapping_add(1);
        let mut bytes = frame(&HostMessage::Heartbeat { sequence });
        if round.is_multiple_of(5) {
            let bit = rng.gen_range(0..8 * (bytes.len() - 1));
            bytes[bit / 8] ^= 1 << (bit % 8);
        }
        device.incoming.extend(bytes);
        for _ in 0..HEARTBEAT_EVERY_TICKS {
            device.tick();
        }
        assert!(device.bridges.driven, "round {round}: one lost heartbeat in five must not trip the link");
    }
    let counters = device.link.counters();
    println!("corrupted heartbeats: {counters:?}");
    assert!(counters.dropped() >= 80, "{counters:?}");

    // Random bytes at the UART's full rate for one second, no heartbeat among them: the
    // bridges go off (heartbeat lost) and nothing the noise says enables them again.
    let garbage: Vec<u8> = (0..BYTES_PER_TICK * CURRENT_LOOP_HZ as usize).map(|_| rng.gen()).collect();
    device.incoming.extend(garbage);
    let mut driven_ticks = 0;
    let start = std::time::Instant::now();
    for _ in 0..CURRENT_LOOP_HZ {
        device.tick();
        driven_ticks += u32::from(device.bridges.driven);
    }
    println!("one second of random bytes: {:?} on the host, {:?}", start.elapsed(), device.link.counters());
    assert!(device.incoming.is_empty(), "every byte consumed at the UART's rate");
    assert!(driven_ticks <= 40, "{driven_ticks} periods driven: the 5 ms timeout is 37");
    assert!(!device.bridges.driven);
    assert_eq!(device.link.fault(), Some(LinkFault::HeartbeatLost));
}

#[test]
fn the_hello_answer_is_this_devices_info() {
    let link = DeviceLink::new(info(), LinkSettings::with_timeout_ms(5, CURRENT_LOOP_HZ));
    let mut out = [0u8; MAX_FRAME_BYTES];
    let n = link.hello(&mut out).unwrap();
    let mut decoder = FrameDecoder::new();
    let answer: Vec<DeviceMessage> = out[..n].iter().filter_map(|&b| decoder.push(b)).collect();
    assert_eq!(answer, vec![DeviceMessage::Hello(DeviceInfo { version: PROTOCOL_VERSION, ..info() })]);
    assert_eq!(LinkSettings::with_timeout_ms(5, CURRENT_LOOP_HZ).heartbeat_timeout_ticks, 37);
    assert_eq!(LinkSettings::with_timeout_ms(0, CURRENT_LOOP_HZ).heartbeat_timeout_ticks, 1);
}

/// Processor in the loop: sensor frames are handed on only after the handshake, each one
/// keeps the watchdog fed as a heartbeat does (a host that sends sensors every period keeps the
/// bridges on without heartbeats), and when they stop the bridges are off within 10 ms; the
/// setup is handed on; `Disable` is reported.
#[test]
fn sensor_frames_feed_the_watchdog_and_are_handed_on_after_the_handshake() {
    let sensors = |tick: u16| {
        HostMessage::Sensors(SensorFrame {
            tick,
            encoder_counts: [tick as i32; 6],
            motor_current: [0.5; 6],
            force_readings: [0.0; 3],
        })
    };
    let mut link = DeviceLink::new(info(), LinkSettings::with_timeout_ms(5, CURRENT_LOOP_HZ));
    let feed = |link: &mut DeviceLink, message: &HostMessage| -> Vec<LinkEvent<f32>> {
        frame(message).into_iter().filter_map(|b| link.receive::<f32>(b)).collect()
    };
    assert!(feed(&mut link, &sensors(1)).is_empty(), "refused before the handshake");
    assert_eq!(link.refused().before_handshake, 1);
    assert_eq!(feed(&mut link, &HostMessage::Hello { version: PROTOCOL_VERSION }), vec![LinkEvent::Hello]);
    let setup = PilSetup {
        law: PilLaw::NaturalInertia,
        velocity_cutoff_hz: 100.0,
        acceleration_cutoff_hz: 25.0,
        zero_offset: [0.0; 6],
        initial_counts: [0; 6],
        reference: [0.0; 3],
        force_scale: [1.0; 3],
        force_offset: [0.0; 3],
        min_abs_jacobian_determinant: 0.0,
        spring_lead_time: 0.0,
        scene_grid_spacing: None,
    };
    assert_eq!(feed(&mut link, &HostMessage::PilSetup(setup)), vec![LinkEvent::PilSetup]);
    assert_eq!(link.pil_setup(), Some(&setup));
    let joint = ExcitationJoint {
        joint: 0,
        period: 5.0,
        ramp: 1.0,
        tracking_hz: 8.0,
        offset: 0.1,
        sine: [0.2; EXCITATION_HARMONICS],
        cosine: [-0.1; EXCITATION_HARMONICS],
    };
    assert_eq!(feed(&mut link, &HostMessage::SetExcitation(joint)), vec![LinkEvent::ExcitationJoint]);
    assert_eq!(link.excitation_joint(), Some(&joint));
    assert!(feed(&mut link, &HostMessage::Heartbeat { sequence: 1 }).is_empty());
    assert!(feed(&mut link, &HostMessage::Enable).is_empty());
    // One sensor frame per period, no heartbeat: the bridges stay on for a second.
    for tick in 0..CURRENT_LOOP_HZ as u16 {
        let events = feed(&mut link, &sensors(tick));
        assert_eq!(events, vec![LinkEvent::Sensors]);
        assert_eq!(link.sensors().map(|f| f.tick), Some(tick));
        assert!(link.on_current_tick(), "driven at period {tick}");
    }
    // The host stops: the bridges are off within 10 ms of periods.
    let mut periods = 0u32;
    while link.on_current_tick() {
        periods += 1;
        assert!(periods < CURRENT_LOOP_HZ, "never disabled");
    }
    let ms = f64::from(periods + 1) * 1000.0 / f64::from(CURRENT_LOOP_HZ);
    println!("PIL: bridges off {ms:.2} ms after the last sensor frame");
    assert!(ms <= 10.0);
    assert_eq!(link.fault(), Some(LinkFault::HeartbeatLost));
    assert_eq!(feed(&mut link, &HostMessage::Disable), vec![LinkEvent::Disabled]);
}
