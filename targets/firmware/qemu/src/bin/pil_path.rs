//! The control-path probe of the processor-in-the-loop image (`hapticgen-fw-qemu-pil`, see
//! `hapticgen_fw_control::probe`): linked, never run. Its SysTick handler is what the PIL image
//! does with every byte and every period, on state and input the optimiser cannot see: a
//! received byte through `DeviceLink::receive` (frame decoding: COBS, CRC, postcard); on a
//! sensor frame, the link's watchdog, `Controller::on_current_tick` through the link's `Gated`
//! board, and the actuator frame's encoding. `scripts/firmware.sh --only pil` fails when a
//! panic survives in it. Its reference source is a fixed reference; the PIL image's may also
//! be the runtime's planar `Scene`, which the probes of the `wall_contact` images check.
#![no_std]
#![no_main]

use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};

use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::link::{DeviceLink, Gated, LinkEvent};
use hapticgen_fw_control::probe::{self, OpaqueBoard, OpaqueClock};
use hapticgen_fw_control::Controller;
use hapticgen_protocol::{encode, ActuatorFrame, DeviceMessage, MAX_FRAME_BYTES};
use hapticgen_runtime::control::TaskReference;

#[allow(clippy::all, dead_code)]
mod generated {
    include!(concat!(env!("OUT_DIR"), "/image.rs"));
}
use generated::image;

const N: usize = image::JOINTS;
const M: usize = image::TASK_DIM;

/// What the PIL image keeps between bytes and periods.
struct PilState {
    link: DeviceLink,
    control: Controller<image::Rig, TaskReference<f32, M>, N, M>,
}

static mut RECEIVED: u8 = 0;
static mut SENT: u8 = 0;

/// The first `K` entries of `values` (zero beyond them).
fn first<const K: usize>(values: &[f32]) -> [f32; K] {
    let mut out = [0.0; K];
    for (slot, value) in out.iter_mut().zip(values) {
        *slot = *value;
    }
    out
}

#[entry]
fn main() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
fn SysTick() {
    // SAFETY: a probe is never run.
    let state = match unsafe { probe::opaque::<PilState>() } {
        Some(state) => state,
        None => return,
    };
    // SAFETY: a volatile read of a plain static (never run).
    let byte = unsafe { read_volatile(addr_of!(RECEIVED)) };
    let sensors = match state.link.receive::<f32>(byte) {
        Some(LinkEvent::Sensors) => state.link.sensors().copied(),
        _ => None,
    };
    if let Some(frame) = sensors {
        let open = state.link.on_current_tick();
        let outcome =
            state.control.on_current_tick(&mut Gated { board: &mut OpaqueBoard, open }, &OpaqueClock);
        let torque = outcome.impedance.map_or([0.0; N], |report| report.command.torque);
        let answer = ActuatorFrame {
            tick: frame.tick,
            voltage: first(&outcome.volts),
            current_setpoint: first(state.control.haptic.current_setpoints()),
            torque: first(&torque),
            reference: [0.0; 3],
            status: u8::from(open),
            fault: 0,
            missed: 0,
        };
        let mut buffer = [0u8; MAX_FRAME_BYTES];
        if let Ok(length) = encode(&DeviceMessage::Actuators(answer), &mut buffer) {
            for byte in buffer.iter().take(length) {
                // SAFETY: a volatile write of a plain static (never run).
                unsafe { write_volatile(addr_of_mut!(SENT), *byte) };
            }
        }
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    probe::hapticgen_fw_panic_reached()
}
