//! The control-path probe of the STM32F407 image (see `hapticgen_fw_control::probe`): linked,
//! never run. Its SysTick handler is the image's whole current-loop interrupt body,
//! [`on_current_loop_interrupt`] (critical section, the state's `RefCell`, the HAL drivers and
//! the control cycle), on state the optimiser cannot see; `main` does nothing.
//! `scripts/firmware.sh` fails when a panic survives in it.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::probe;
use hapticgen_fw_stm32f4::{on_current_loop_interrupt, State};

#[entry]
fn main() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
fn SysTick() {
    // SAFETY: a probe is never run.
    if let Some(state) = unsafe { probe::opaque::<State>() } {
        on_current_loop_interrupt(state);
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    probe::hapticgen_fw_panic_reached()
}
