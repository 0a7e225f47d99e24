//! The control-path probe of the STM32F407 device-mode image (see
//! `hapticgen_fw_control::probe`): linked, never run. Its SysTick handler is the image's
//! current-loop interrupt body and its main loop the link's byte handling
//! (`hapticgen_fw_stm32f4::device`), on state and bytes the optimiser cannot see.
//! `scripts/firmware.sh` fails when a panic survives in it.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::probe;
use hapticgen_fw_stm32f4::device::{next_byte_to_send, on_device_interrupt, on_received_byte, SharedDevice};

#[entry]
fn main() -> ! {
    loop {
        // SAFETY: a probe is never run.
        if let Some(shared) = unsafe { probe::opaque::<SharedDevice>() } {
            on_received_byte(shared, core::hint::black_box(0u8));
            let _ = core::hint::black_box(next_byte_to_send(shared));
        }
    }
}

#[exception]
fn SysTick() {
    // SAFETY: a probe is never run.
    if let Some(shared) = unsafe { probe::opaque::<SharedDevice>() } {
        on_device_interrupt(shared);
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    probe::hapticgen_fw_panic_reached()
}
