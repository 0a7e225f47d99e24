//! The STM32F407 image (see the crate's documentation for the wiring): start-up, then the
//! current-loop interrupt (SysTick at `CURRENT_LOOP_HZ`) runs the control cycle.
#![no_std]
#![no_main]

use core::cell::RefCell;

use cortex_m::interrupt::Mutex;
use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::board::{Encoders, TickTimer};
use hapticgen_fw_stm32f4::{
    halt, image, loop_settings, on_current_loop_interrupt, rendering, start, App, Cycles, Started, State,
    SysTickTimer,
};
use hapticgen_runtime::control::ImpedanceParameters;
use hapticgen_runtime::render::Scene;

static STATE: State = Mutex::new(RefCell::new(None));

#[entry]
fn main() -> ! {
    let Some(Started { mut board, syst, .. }) = start() else { halt() };
    // A free-space scene with the model's rendering settings; add walls with `Scene::add`.
    let [grid, stiffness, damping] = rendering();
    let scene = Scene::new(stiffness, damping, grid);
    let parameters = ImpedanceParameters { stiffness: [stiffness; 2], damping: [damping; 2], mass: [1.0; 2] };
    let settings = loop_settings(parameters, board.counts());
    let Some(mut app) = App::new(image::Rig::NOMINAL, scene, &settings, false) else { halt() };
    app.calibrate(&Cycles);
    cortex_m::interrupt::free(|cs| {
        if let Ok(mut slot) = STATE.borrow(cs).try_borrow_mut() {
            *slot = Some((app, board));
        }
    });
    SysTickTimer(syst).start(image::CURRENT_LOOP_HZ);
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
fn SysTick() {
    on_current_loop_interrupt(&STATE);
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    // A real product would disable the bridges here first.
    halt()
}
