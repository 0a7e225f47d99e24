//! The host link's cost on the Cortex-M4F (docs/link.md): for rigs of 1–6 joints, each
//! impedance tick's state frame is quantised, framed and written to UART0 (the CMSDK UART of
//! the MPS2-AN386, which QEMU connects to a file), and a command frame (a heartbeat, or new
//! impedance settings) is fed to the device's [`DeviceLink`] byte by byte, as the UART would
//! deliver it. Each part is timed with the APB timer (`-icount shift=10`: exact, repeatable)
//! and printed in instructions:
//!
//! `LINK joints=3 task=3 part=state frames=200 state_bytes=49 min=… max=…` (parts: `state`,
//! 200 state frames of a moving device quantised and framed, `StateFrame::encode_sample`;
//! `state_rest` and `state_clipped`, one frame each of a device at rest and of one whose
//! every value is out of range; `heartbeat` and `impedance`, a command frame received).
//!
//! `scripts/firmware.sh` holds each part to a ceiling just above its measured cost, asserts
//! the goal (for 3 joints, the costliest state frame and a heartbeat in ≤ 1,000 instructions,
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

/// The counter and its calibration.
struct Timing<'a> {
    counter: &'a qemu::ApbCounter,
    /// Ticks of two back-to-back reads.
    calibration: u32,
    /// Ticks of [`qemu::KNOWN_INSTRUCTIONS`] instructions.
    cal_ticks: u32,
}

impl Timing<'_> {
    /// Ticks of `work`, without the reads' own.
    #[inline(always)]
    fn ticks<T>(&self, work: impl FnOnce() -> T) -> (T, u32) {
        let start = self.counter.now();
        let result = work();
        let end = self.counter.now();
        (result, end.wrapping_sub(start).saturating_sub(self.calibration))
    }
}

/// One state frame of a rig of `N` joints and `M` task axes, from arrays of those sizes as the
/// device's `state_frame` builds it (so that the compiler knows the channels' counts, as it
/// does there), quantised and framed by `StateFrame::encode_sample`. Not inlined: every frame
/// measured runs this same code, whatever surrounds the call.
#[inline(never)]
fn encode_state<const N: usize, const M: usize>(
    header: (u32, bool, u32),
    counts: &[i32; N],
    per_joint: &[f32; N],
    per_axis: &[f32; M],
    out: &mut [u8; MAX_FRAME_BYTES],
) -> Option<usize> {
    let (tick, enabled, tick_instructions) = header;
    let sample = StateSample {
        tick,
        enabled,
        exciting: false,
        fault: 0,
        encoder_counts: counts,
        joint_velocity: per_joint,
        task_position: per_axis,
        task_velocity: per_axis,
        joint_torque: per_joint,
        motor_current: per_joint,
        tick_instructions,
    };
    StateFrame::encode_sample(&sample, &ChannelScales::DESKTOP, out)
}

/// Prints one part's `LINK` line.
fn print_part<const N: usize, const M: usize>(
    out: &mut qemu::Semihosting,
    part: &str,
    frame_bytes: usize,
    frames: u32,
    cost: CostStats,
    timing: &Timing<'_>,
) {
    let mut line = Line::new();
    line.str("LINK").kv("joints", N as i64).kv("task", M as i64).str(" part=").str(part);
    line.kv("frames", i64::from(frames)).kv("state_bytes", frame_bytes as i64);
    line.kv("min", instructions(cost.min, timing.cal_ticks))
        .kv("max", instructions(cost.max, timing.cal_ticks));
    line.emit(out);
}

/// The framed host messages fed to the device's link.
struct Commands<'a> {
    hello: &'a [u8],
    heartbeat: &'a [u8],
    impedance: &'a [u8],
}

/// [`FRAMES`] state frames of a rig of `N` joints and `M` task axes ([`encode_state`]), each
/// written to UART0, and a heartbeat and new
/// impedance settings fed to a [`DeviceLink`] after each; prints a `LINK` line per part and
/// returns the bytes the UART dropped.
#[inline(never)]
fn measure_rig<const N: usize, const M: usize>(
    timing: &Timing<'_>,
    commands: &Commands<'_>,
    uart: &mut Uart0,
    out: &mut qemu::Semihosting,
) -> u32 {
    let info = DeviceInfo {
        version: PROTOCOL_VERSION,
        rig_name_hash: 0,
        joints: N as u8,
        task_dim: M as u8,
        impedance_loop_hz: 1000,
        scales: ChannelScales::DESKTOP,
    };
    let mut link = DeviceLink::new(info, LinkSettings::with_timeout_ms(5, 7500));
    for &byte in commands.hello {
        let _ = link.receive::<f32>(byte);
    }
    let (mut encode_cost, mut heartbeat_cost, mut impedance_cost) =
        (CostStats::EMPTY, CostStats::EMPTY, CostStats::EMPTY);
    let mut frame_bytes = 0;
    let mut dropped = 0;
    for tick in 0..FRAMES {
        // Values that change from tick to tick, out of the optimiser's sight.
        let t = black_box(tick as f32 * 1e-3);
        let counts: [i32; N] = black_box([tick as i32 * 37 - 4000; N]);
        let per_joint: [f32; N] =
            black_box(core::array::from_fn(|j| [t, -0.5 * t, 2.0 * t, 0.25, -1.5 * t, 3.0 * t][j % 6]));
        let per_axis: [f32; M] = black_box(core::array::from_fn(|k| [0.01 * t, -0.02, 0.03 * t][k % 3]));
        let mut buffer = [0u8; MAX_FRAME_BYTES];
        let (length, ticks) = timing
            .ticks(|| encode_state((tick, true, 1000 + tick), &counts, &per_joint, &per_axis, &mut buffer));
        let Some(length) = length else { qemu::exit(5) };
        frame_bytes = length;
        encode_cost.record(ticks);
        dropped += uart.write(&buffer[..length]);

        let ((), ticks) = timing.ticks(|| {
            for &byte in black_box(commands.heartbeat) {
                consume(link.receive::<f32>(byte));
            }
        });
        heartbeat_cost.record(ticks);
        let ((), ticks) = timing.ticks(|| {
            for &byte in black_box(commands.impedance) {
                consume(link.receive::<f32>(byte));
            }
        });
        impedance_cost.record(ticks);
    }
    if link.counters().frames != 1 + 2 * FRAMES {
        qemu::exit(6);
    }
    let parts = [("state", encode_cost), ("heartbeat", heartbeat_cost), ("impedance", impedance_cost)];
    for (part, cost) in parts {
        print_part::<N, M>(out, part, frame_bytes, FRAMES, cost, timing);
    }
    // Two more frames, each alone: a device at rest with its bridges off (every value zero), at
    // a tick that is a multiple of 2¹⁶ and with no tick cost yet, the most zero bytes a state
    // frame can hold (six in its head; the channels never hold one), which costs the stuffing
    // most; and every scaled value out of its channel (too large either way, or NaN), which
    // costs the quantisation most (each is clipped out of line).
    let out_of_range = [1e30f32, -f32::INFINITY, f32::NAN];
    for (part, fill, tick) in [("state_rest", None, 1u32 << 16), ("state_clipped", Some(out_of_range), 0)] {
        let value = |k: usize| fill.map_or(0.0, |values| values[k % 3]);
        let (counts, per_joint, per_axis) = black_box((
            [0i32; N],
            core::array::from_fn::<f32, N, _>(value),
            core::array::from_fn::<f32, M, _>(value),
        ));
        let mut buffer = [0u8; MAX_FRAME_BYTES];
        let (length, ticks) =
            timing.ticks(|| encode_state((tick, false, 0), &counts, &per_joint, &per_axis, &mut buffer));
        let Some(length) = length else { qemu::exit(5) };
        dropped += uart.write(&buffer[..length]);
        let mut cost = CostStats::EMPTY;
        cost.record(ticks);
        print_part::<N, M>(out, part, length, 1, cost, timing);
    }
    dropped
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
    let (hello, hello_length) = frame_of(&HostMessage::Hello { version: PROTOCOL_VERSION });
    let (heartbeat, heartbeat_length) = frame_of(&HostMessage::Heartbeat { sequence: 7 });
    let settings = ImpedanceSettings { stiffness: [300.0, 250.0, 200.0], damping: [2.0; 3], mass: [0.1; 3] };
    let (impedance, impedance_length) = frame_of(&HostMessage::SetImpedance(settings));
    let commands = Commands {
        hello: &hello[..hello_length],
        heartbeat: &heartbeat[..heartbeat_length],
        impedance: &impedance[..impedance_length],
    };
    let timing = Timing { counter: &counter, calibration, cal_ticks };
    let mut dropped = 0u32;
    dropped += measure_rig::<1, 1>(&timing, &commands, &mut uart, &mut out);
    dropped += measure_rig::<2, 2>(&timing, &commands, &mut uart, &mut out);
    dropped += measure_rig::<3, 3>(&timing, &commands, &mut uart, &mut out);
    dropped += measure_rig::<6, 3>(&timing, &commands, &mut uart, &mut out);
    let mut line = Line::new();
    line.str("LINK_DONE").kv("uart_dropped", i64::from(dropped));
    line.emit(&mut out);
    qemu::exit(0)
}
