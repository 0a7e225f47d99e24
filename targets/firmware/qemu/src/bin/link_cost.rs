//! The host link's cost on the Cortex-M4F (issue 19): for rigs of 1–6 joints, each
//! impedance tick's state frame is quantised, framed and written to UART0 (the CMSDK UART of
//! the MPS2-AN386, which QEMU connects to a file), and a command frame (a heartbeat, or new
//! impedance settings) is fed to the device's [`DeviceLink`] byte by byte, as the UART would
//! deliver it. Each part is timed with the APB timer (`-icount shift=10`: exact, repeatable)
//! and printed in instructions:
//!
//! `LINK joints=3 task=3 part=state frames=200 state_bytes=49 min=… max=…` (parts: `state`,
//! the state frame quantised and framed, `StateFrame::encode_sample`; `heartbeat` and `impedance`, a command frame received).
//!
//! `scripts/firmware.sh` holds each part to a ceiling just above its measured cost (the goal,
//! a state frame and a command frame in ≤ 1,000 instructions, is not met for 3 joints:
//! docs/link.md) and decodes the UART file on the host (`hapticgen-fw-reference
//! link-stream`): every frame must decode.
#![no_std]
#![no_main]

// The board support of the images (timer, semihosting, exit, panic handler), shared as source:
// the image crate is a binary whose build script needs an image variant.
#[allow(dead_code)]
#[path = "../qemu.rs"]
mod qemu;
// The polled UART the link talks through.
#[allow(dead_code)]
#[path = "../uart.rs"]
mod uart;

use core::hint::black_box;

use cortex_m_rt::entry;
use hapticgen_fw_control::board::CycleCounter;
use hapticgen_fw_control::link::{DeviceLink, LinkEvent, LinkSettings};
use hapticgen_fw_control::report::Line;
use hapticgen_fw_control::CostStats;
use hapticgen_protocol::{
    encode, ChannelScales, DeviceInfo, HostMessage, ImpedanceSettings, StateFrame, StateSample,
    MAX_FRAME_BYTES, PROTOCOL_VERSION,
};
use uart::Uart0;

/// State frames per rig shape.
const FRAMES: u32 = 200;

/// Counter ticks as instructions, from the ticks of [`qemu::KNOWN_INSTRUCTIONS`] instructions.
fn instructions(ticks: u32, cal_ticks: u32) -> i64 {
    (i64::from(ticks) * qemu::KNOWN_INSTRUCTIONS + i64::from(cal_ticks.max(1)) / 2)
        / i64::from(cal_ticks.max(1))
}

fn frame_of(message: &HostMessage) -> ([u8; MAX_FRAME_BYTES], usize) {
    let mut out = [0u8; MAX_FRAME_BYTES];
    match encode(message, &mut out) {
        Ok(n) => (out, n),
        Err(_) => qemu::exit(4),
    }
}

/// Keeps a received event from being optimised away, as firmware acting on it would, without
/// the copy of the whole event per byte that `black_box(event)` costs (about 10 instructions a
/// byte, once counted in the receive figures).
#[inline(always)]
fn consume(event: Option<LinkEvent<f32>>) {
    if let Some(event) = event {
        black_box(&event);
    }
}

#[entry]
fn main() -> ! {
    let counter = qemu::ApbCounter::start();
    let mut out = qemu::Semihosting::new();
    // Ticks of 1001 known instructions, to print instructions.
    let calibration = {
        let mut overhead = u32::MAX;
        for _ in 0..16 {
            let a = counter.now();
            let b = counter.now();
            overhead = overhead.min(b.wrapping_sub(a));
        }
        overhead
    };
    qemu::calibrate(&counter, &mut out);
    let cal_ticks = {
        let a = counter.now();
        qemu::known_instructions();
        counter.now().wrapping_sub(a).saturating_sub(calibration)
    };
    let mut uart = Uart0::start();
    let info = |joints: u8, task_dim: u8| DeviceInfo {
        version: PROTOCOL_VERSION,
        rig_name_hash: 0,
        joints,
        task_dim,
        impedance_loop_hz: 1000,
        scales: ChannelScales::DESKTOP,
    };
    let (hello, hello_length) = frame_of(&HostMessage::Hello { version: PROTOCOL_VERSION });
    let (heartbeat, heartbeat_length) = frame_of(&HostMessage::Heartbeat { sequence: 7 });
    let settings = ImpedanceSettings { stiffness: [300.0, 250.0, 200.0], damping: [2.0; 3], mass: [0.1; 3] };
    let (impedance, impedance_length) = frame_of(&HostMessage::SetImpedance(settings));
    let mut dropped = 0u32;
    for (joints, task) in [(1usize, 1usize), (2, 2), (3, 3), (6, 3)] {
        let mut link =
            DeviceLink::new(info(joints as u8, task as u8), LinkSettings::with_timeout_ms(5, 7500));
        for &byte in &hello[..hello_length] {
            let _ = link.receive::<f32>(byte);
        }
        let (mut encode_cost, mut heartbeat_cost, mut impedance_cost) =
            (CostStats::EMPTY, CostStats::EMPTY, CostStats::EMPTY);
        let mut frame_bytes = 0;
        for tick in 0..FRAMES {
            // Values that change from tick to tick, out of the optimiser's sight.
            let t = black_box(tick as f32 * 1e-3);
            let counts = [black_box(tick as i32 * 37 - 4000); 6];
            let per_joint = [t, -0.5 * t, 2.0 * t, 0.25, -1.5 * t, 3.0 * t];
            let per_axis = [0.01 * t, -0.02, 0.03 * t];
            let sample = StateSample {
                tick,
                enabled: true,
                fault: 0,
                encoder_counts: &counts[..joints],
                joint_velocity: &per_joint[..joints],
                task_position: &per_axis[..task],
                task_velocity: &per_axis[..task],
                joint_torque: &per_joint[..joints],
                motor_current: &per_joint[..joints],
                tick_instructions: 1000 + tick,
            };
            let mut buffer = [0u8; MAX_FRAME_BYTES];
            let t0 = counter.now();
            let length = StateFrame::encode_sample(black_box(&sample), &ChannelScales::DESKTOP, &mut buffer);
            let t1 = counter.now();
            let Some(length) = length else { qemu::exit(5) };
            frame_bytes = length;
            encode_cost.record(t1.wrapping_sub(t0).saturating_sub(calibration));
            dropped += uart.write(&buffer[..length]);

            let t2 = counter.now();
            for &byte in black_box(&heartbeat[..heartbeat_length]) {
                consume(link.receive::<f32>(byte));
            }
            let t3 = counter.now();
            heartbeat_cost.record(t3.wrapping_sub(t2).saturating_sub(calibration));
            let t4 = counter.now();
            for &byte in black_box(&impedance[..impedance_length]) {
                consume(link.receive::<f32>(byte));
            }
            let t5 = counter.now();
            impedance_cost.record(t5.wrapping_sub(t4).saturating_sub(calibration));
        }
        if link.counters().frames != 1 + 2 * FRAMES {
            qemu::exit(6);
        }
        for (part, cost) in
            [("state", encode_cost), ("heartbeat", heartbeat_cost), ("impedance", impedance_cost)]
        {
            let mut line = Line::new();
            line.str("LINK").kv("joints", joints as i64).kv("task", task as i64).str(" part=").str(part);
            line.kv("frames", i64::from(FRAMES)).kv("state_bytes", frame_bytes as i64);
            line.kv("min", instructions(cost.min, cal_ticks)).kv("max", instructions(cost.max, cal_ticks));
            line.emit(&mut out);
        }
    }
    let mut line = Line::new();
    line.str("LINK_DONE").kv("uart_dropped", i64::from(dropped));
    line.emit(&mut out);
    qemu::exit(0)
}
