//! Device mode (docs/link-device.md): the image runs on its own clock like a device on a desk, and a host
//! drives it over UART0 (`hapticgen connect`): impedance settings, scene objects, enable,
//! disable, fault reset and heartbeats in; the 1 kHz state stream out.
//!
//! QEMU has no motors, amplifiers or encoders, so the board's peripherals are the simulated
//! plant of the self-contained images (`hapticgen_fw_sim::plant::SimBoard`: the rig's
//! dynamics, its drives, the encoders' quantisation, the current sense's lag) with end stops at
//! the joint limits (unpowered, the arm rests on them instead of sagging through them); on a
//! real board they are the board's (`targets/firmware/stm32f4`). A hand on it, if the
//! semihosting command line says so (`-semihosting-config …,arg=hand=FX:FY:FZ`, newtons in
//! the task frame, as many as the task has axes): the hand holds the grip with that force
//! while the bridges are on (link enabled, no fault), and lets go when they are off. Everything else is
//! the firmware's: [`Controller::on_current_tick`] once per current-loop period, with the
//! bridges held off by the link ([`Gated`]) until the host enables them and whenever its
//! heartbeat has stopped.
//!
//! * **Clock**: one current-loop period each time the APB timer passes the next deadline
//!   (`SYSCLK_HZ / CURRENT_LOOP_HZ` ticks). Run QEMU *without* `-icount`: its timers then
//!   follow the host's clock, so that 10 ms on the device are 10 ms for the host sending the
//!   heartbeats. A period that starts more than a period late is counted (`overruns`) and the
//!   deadlines restart from it: the control counts its own time in periods.
//! * **Link**: between deadlines the core takes UART0's received bytes, at most
//!   [`BYTES_PER_POLL`] before it looks at the clock again (bounded work per byte,
//!   `DeviceLink::receive`), and waits in `wfi` when there is none: UART0's receive interrupt
//!   and SysTick (at the current-loop rate) wake it. Waiting instead of polling matters under
//!   QEMU: a core that spins on the UART's status holds the emulator's lock, and bytes then
//!   reach the UART at about 4 kB/s, fewer than 1 kHz of heartbeats need (measured).
//!   Heartbeat timeout [`LINK_TIMEOUT_MS`]: without a heartbeat for that long, the link latches
//!   its fault and the bridges are off in the same period; only `ResetFault` then `Enable`
//!   (with fresh heartbeats) turns them on again.
//! * **Controller**: Controller 3 (`J^T`, any rig), at start a spring to the start pose with
//!   the model's rendering stiffness and damping (else the paper's 1500 N/m, 5 N·s/m).
//!   `SetImpedance` and `SetObject` change it as `hapticgen_fw_control::device` says, the
//!   same on every board: on a 2-D task a sphere is a circle, a box a rectangle in the
//!   runtime's planar proxy renderer; on a 3-D task spheres, boxes and half-spaces are the
//!   runtime's god object's; every object is answered (`DeviceMessage::Scene`), refused if the
//!   task cannot render it.
//! * **Excitation**: the host's `SetExcitation` messages, one per joint, played from where
//!   the device is with the runtime's joint-space tracking law while the bridges are on
//!   (`hapticgen_fw_control::device`; `hapticgen connect --excite`).
//! * **State stream**: after each impedance tick, a `State` frame
//!   (`hapticgen_fw_control::device::state_frame`: encoder counts and measured motor currents
//!   as the tick read them, joint velocities, task position and velocity, commanded torques,
//!   whether an excitation plays, the safety monitor's fault
//!   and the link's, the tick's cost in timer ticks: 25 MHz, the count of instructions only
//!   under `-icount`); every
//!   [`COUNTERS_TICKS`] ticks, the link's receive counters (`Link`).
//!
//! Semihosting prints `DEVICE_READY` at start (the host need not read it: the UART is the
//! interface). The image runs until QEMU is stopped.
#![no_std]
#![no_main]

// The board support of the images (timer, semihosting, exit, panic handler), shared as source.
#[allow(dead_code)]
#[path = "../qemu.rs"]
mod qemu;
// The polled UART the link talks through.
#[allow(dead_code)]
#[path = "../uart.rs"]
mod uart;

use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::board::{CurrentSense, CycleCounter, Encoders, TickTimer};
use hapticgen_fw_control::device::{loop_settings, state_frame, DeviceMode, TickSensors};
use hapticgen_fw_control::link::{DeviceLink, Gated, LinkSettings};
use hapticgen_fw_control::link_scene::{device_info, LinkSource};
use hapticgen_fw_control::report::Line;
use hapticgen_fw_control::Controller;
use hapticgen_fw_sim::plant::SimBoard;
use hapticgen_fw_sim::scenarios::PAPER_RENDERING;
use hapticgen_protocol::{encode, DeviceMessage, MAX_FRAME_BYTES};
use hapticgen_runtime::estimation::ForceSensorCalibration;
use uart::Uart0;

#[allow(clippy::all, dead_code)]
mod generated {
    include!(concat!(env!("OUT_DIR"), "/image.rs"));
}
use generated::image;

const N: usize = image::JOINTS;
const M: usize = image::TASK_DIM;
type Rig = image::Rig;
type Control = Controller<Rig, LinkSource<M>, N, M>;

/// The heartbeat timeout, ms: the bridges are off within 10 ms of the last heartbeat (the link's
/// safe-state bound, docs/link.md), with 4 ms to spare for the link's latency both ways and the tick in which the state frame
/// tells the host (`hapticgen connect --check-safety` measures the sum from the host).
const LINK_TIMEOUT_MS: u32 = 6;

/// Received bytes taken in one poll before the clock is looked at again: at most a period's
/// worth of link work delays a deadline (a byte is about a dozen instructions, docs/link.md).
const BYTES_PER_POLL: usize = 64;

/// Impedance ticks between two `Link` messages (the receive counters) to the host.
const COUNTERS_TICKS: u32 = 1000;

/// Periods between two lines of `DEVICE_STATUS` on semihosting (one per 10 s at 7.5 kHz).
const STATUS_PERIODS: u32 = 75_000;

/// The semihosting command line (`-semihosting-config …,arg=…`), read into `text`; `None`
/// without one.
fn command_line(text: &mut [u8; 128]) -> Option<&str> {
    const SYS_GET_CMDLINE: usize = 0x15;
    let mut block = [text.as_mut_ptr() as usize, text.len()];
    // SAFETY: a semihosting call with a valid parameter block (a buffer and its length, which
    // the host overwrites with the length written).
    let status = unsafe { cortex_m_semihosting::syscall1(SYS_GET_CMDLINE, block.as_mut_ptr() as usize) };
    if status != 0 {
        return None;
    }
    let length = block[1].min(text.len());
    core::str::from_utf8(text.get(..length)?).ok().map(|line| line.trim_end_matches('\0'))
}

/// The hand's force from the command line's `hand=FX:FY:FZ` (newtons; missing axes zero, axes
/// beyond the task's ignored); `None` without one or with a value that is not a finite number.
fn hand_force(line: &str) -> Option<[f32; M]> {
    let values = line.split(' ').find_map(|word| word.strip_prefix("hand="))?;
    let mut force = [0.0f32; M];
    for (k, value) in values.split(':').enumerate() {
        let value: f32 = value.parse().ok()?;
        if !value.is_finite() {
            return None;
        }
        if let Some(slot) = force.get_mut(k) {
            *slot = value;
        }
    }
    Some(force)
}

/// The heartbeat timeout, ms: the command line's `timeout_ms=N` (1 to 1000), else
/// [`LINK_TIMEOUT_MS`]. A longer one is for runs that do not test the link's safety rules on an
/// emulator short of time: the Delta's plant at 7.5 kHz takes QEMU most of a host core, and its
/// UART then delivers heartbeats late (`scripts/device-run-3d.sh`).
fn timeout_ms(line: &str) -> u32 {
    line.split(' ')
        .find_map(|word| word.strip_prefix("timeout_ms="))
        .and_then(|value| value.parse::<u32>().ok())
        .filter(|ms| (1..=1000).contains(ms))
        .unwrap_or(LINK_TIMEOUT_MS)
}

/// The controller at start, as `mode` says (a spring to the start pose); `None` if the rig's
/// rates are unusable.
fn build(mode: &DeviceMode<N, M>) -> Option<Control> {
    let calibration = ForceSensorCalibration { scale: [1.0; M], offset: [0.0; M] };
    let settings =
        loop_settings(&image::setup(), mode.parameters(), image::IMPEDANCE_LOOP_HZ, [0; N], calibration);
    Controller::new(Rig::NOMINAL, mode.source()?, &settings, false)
}

/// Wakes the core from `wfi` at the current-loop rate; the period itself is timed by the APB
/// counter.
#[exception]
fn SysTick() {}

/// UART0's receive interrupt (the only one enabled): acknowledged; the byte is taken by the
/// main loop.
#[exception]
unsafe fn DefaultHandler(irq: i16) {
    if irq == uart::UART0_RX_IRQ {
        Uart0::clear_receive_interrupt();
    }
}

#[entry]
fn main() -> ! {
    let Some(core) = cortex_m::Peripherals::take() else { qemu::exit(2) };
    let counter = qemu::ApbCounter::start();
    let mut out = qemu::Semihosting::new();
    let mut uart = Uart0::start();
    uart.enable_receive_interrupt();
    let mut wake = qemu::SysTickTimer::new(core.SYST);
    wake.start(image::CURRENT_LOOP_HZ);
    let setup = image::setup();
    let period_ticks = qemu::SYSCLK_HZ / image::CURRENT_LOOP_HZ.max(1);
    let mut text = [0u8; 128];
    let line = command_line(&mut text).unwrap_or("");
    let hand = hand_force(line);
    let timeout = timeout_ms(line);
    let mut link = DeviceLink::new(
        device_info(image::NAME, N, M, image::IMPEDANCE_LOOP_HZ),
        LinkSettings::with_timeout_ms(timeout, image::CURRENT_LOOP_HZ),
    );
    let mut board: SimBoard<Rig, N, M> = SimBoard::new(
        Rig::NOMINAL,
        setup.start,
        1.0 / image::CURRENT_LOOP_HZ as f32,
        image::sense_time_constant(),
    );
    let [grid, stiffness, damping] = setup.rendering.unwrap_or([
        PAPER_RENDERING[0] as f32,
        PAPER_RENDERING[1] as f32,
        PAPER_RENDERING[2] as f32,
    ]);
    let mut mode = DeviceMode::new(Rig::NOMINAL.position(&setup.start), stiffness, damping, grid);
    let Some(mut control) = build(&mode) else {
        out.line(b"ERROR the rig's rates are unusable\n");
        qemu::exit(3);
    };
    let mut line = Line::new();
    line.str("DEVICE_READY variant=").str(image::NAME).kv("joints", N as i64).kv("task", M as i64);
    line.kv("current_loop_hz", i64::from(image::CURRENT_LOOP_HZ)).kv("timeout_ms", i64::from(timeout));
    if let Some(force) = &hand {
        line.str(" hand_mn=");
        for (k, f) in force.iter().enumerate() {
            if k > 0 {
                line.str(":");
            }
            line.i64((f * 1e3) as i64);
        }
    }
    line.emit(&mut out);
    let mut buffer = [0u8; MAX_FRAME_BYTES];
    let mut periods = 0u32;
    let mut overruns = 0u32;
    let mut uart_dropped = 0u32;
    let mut next = counter.now().wrapping_add(period_ticks);
    loop {
        let mut taken = 0;
        while taken < BYTES_PER_POLL {
            let Some(byte) = uart.read() else { break };
            taken += 1;
            let Some(event) = link.receive::<f32>(byte) else { continue };
            if let Some(length) = mode.on_event(event, &mut control, &link, &mut buffer) {
                uart_dropped += uart.write(buffer.get(..length).unwrap_or(&[]));
            }
        }
        let late = counter.now().wrapping_sub(next);
        if late > u32::MAX / 2 {
            // Before the deadline (the difference wrapped): wait for a byte or SysTick.
            if taken == 0 {
                cortex_m::asm::wfi();
            }
            continue;
        }
        if late > period_ticks {
            overruns = overruns.saturating_add(1);
            next = counter.now();
        }
        next = next.wrapping_add(period_ticks);
        periods = periods.wrapping_add(1);
        let open = link.on_current_tick();
        let outcome =
            mode.on_current_tick(&mut control, &mut Gated { board: &mut board, open }, &counter, open);
        // What the tick read (the sensors before the plant moves on), for its state frame.
        let sensors =
            outcome.impedance.map(|_| TickSensors { counts: board.counts(), currents: board.currents() });
        // The hand holds the grip while the bridges are on.
        let force = match (&hand, open) {
            (Some(force), true) => *force,
            _ => [0.0; M],
        };
        board.advance(&force);
        board.stop_at_limits();
        if let (Some(report), Some(sensors)) = (outcome.impedance, sensors) {
            let exciting = mode.exciting();
            if let Some(length) =
                state_frame(&control, &Rig::NOMINAL, &link, &sensors, exciting, &report, &mut buffer)
            {
                uart_dropped += uart.write(buffer.get(..length).unwrap_or(&[]));
            }
            if control.impedance_ticks().is_multiple_of(COUNTERS_TICKS) {
                if let Ok(length) = encode(&DeviceMessage::Link(link.counters()), &mut buffer) {
                    uart_dropped += uart.write(buffer.get(..length).unwrap_or(&[]));
                }
            }
        }
        if periods.is_multiple_of(STATUS_PERIODS) {
            let counters = link.counters();
            let mut line = Line::new();
            line.str("DEVICE_STATUS").kv("periods", i64::from(periods)).kv("overruns", i64::from(overruns));
            line.kv("frames", i64::from(counters.frames)).kv("dropped_frames", i64::from(counters.dropped()));
            line.kv("refused_changes", i64::from(mode.refused_changes()))
                .kv("uart_dropped", i64::from(uart_dropped));
            line.emit(&mut out);
        }
    }
}
