//! The control-path probe of the image named by `HAPTICGEN_FW_VARIANT` (see
//! `hapticgen_fw_control::probe`): linked, never run. Its SysTick handler is the image's
//! control path, `Controller::on_current_tick` for the image's rig and reference source, on
//! state and sensors the optimiser cannot see, and for an image that reads a stylus's gimbal
//! the read (`Stylus::read`) too; `main` does nothing. `scripts/firmware.sh`
//! fails when a panic survives in it.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::probe::{self, OpaqueBoard, OpaqueClock};

#[allow(clippy::all, dead_code)]
mod generated {
    include!(concat!(env!("OUT_DIR"), "/image.rs"));
}
use generated::image;

#[entry]
fn main() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
fn SysTick() {
    // SAFETY: a probe is never run.
    if let Some(control) = unsafe { probe::opaque::<image::Control>() } {
        let _ = control.on_current_tick(&mut OpaqueBoard, &OpaqueClock);
    }
    image::probe_stylus_read();
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    probe::hapticgen_fw_panic_reached()
}
