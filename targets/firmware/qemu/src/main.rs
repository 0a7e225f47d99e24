//! The firmware image for the MPS2-AN386 board (Cortex-M4F) under QEMU.
//!
//! * The rig (generated in f32 by the build script from the line of `variants.txt` named by
//!   `HAPTICGEN_FW_VARIANT`), the runtime's control cycle and the simulated board run in the
//!   SysTick interrupt, started at the rig's `CURRENT_LOOP_HZ` on the 25 MHz core clock; each
//!   interrupt is one current-loop period (and, when the runtime's scheduler says so, one
//!   impedance tick), after which the plant model advances by one period.
//! * Cost: the CMSDK APB timer 0, free running on the same clock, is read around each
//!   current-loop and impedance computation (`-icount shift=10`: 25.6 timer ticks per
//!   instruction, identical on every run).
//! * Output over semihosting: a `CAL` line (ticks of a block of 1000 `nop`s), the trace,
//!   `SUMMARY`, `COST`, `PROFILE`, then exit with status 0 (`SYS_EXIT_EXTENDED`); a panic
//!   or a refused scenario exits with a non-zero status.
//!
//! Under `-icount shift=10` QEMU's virtual CPU executes ~1 instruction per µs, so the
//! interrupt body (control plus the plant model and its bookkeeping) overruns the 133 µs
//! period and SysTick runs back to back; the plant and the control use the nominal period,
//! so the closed loop is unaffected.
#![no_std]
#![no_main]

mod qemu;

use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::board::TickTimer;

#[allow(clippy::all, dead_code)]
mod generated {
    include!(concat!(env!("OUT_DIR"), "/image.rs"));
}
use generated::image;

#[entry]
fn main() -> ! {
    // cortex-m-rt has enabled the FPU (CPACR) before `main` on this -eabihf target.
    let core = match cortex_m::Peripherals::take() {
        Some(core) => core,
        None => qemu::exit(2),
    };
    let counter = qemu::ApbCounter::start();
    let mut out = qemu::Semihosting::new();
    qemu::calibrate(&counter, &mut out);
    let mut timer = qemu::SysTickTimer::new(core.SYST);
    timer.start(image::CURRENT_LOOP_HZ);
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
fn SysTick() {
    static mut RUN: Option<image::Run> = None;
    static mut OUT: Option<qemu::Semihosting> = None;
    let out = OUT.get_or_insert_with(qemu::Semihosting::new);
    if RUN.is_none() {
        *RUN = image::new(true);
        if RUN.is_none() {
            out.line(b"ERROR the scenario refused the rig\n");
            qemu::exit(3);
        }
        if let Some(run) = RUN.as_mut() {
            let overhead = run.controller.calibrate(&qemu::ApbCounter);
            let mut line = hapticgen_fw_control::report::Line::new();
            line.str("START variant=").str(image::NAME).kv("clock_overhead", i64::from(overhead));
            line.emit(out);
        }
    }
    if let Some(run) = RUN.as_mut() {
        run.step(&qemu::ApbCounter, out);
        if run.finished() {
            run.report("f32", out);
            out.line(b"DONE\n");
            qemu::exit(0);
        }
    }
}
