//! The MPS2-AN386 side of the board layer under QEMU: SysTick as the current-loop timer, the
//! CMSDK APB timer 0 as the cycle counter, semihosting for output and exit. The sensors and
//! the power stage are the simulated board (`hapticgen_fw_sim::SimBoard`).

use core::ptr::{read_volatile, write_volatile};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use hapticgen_fw_control::board::{CycleCounter, TickTimer};
use hapticgen_fw_control::report::{Line, Sink};

/// The MPS2 core and peripheral clock, Hz.
pub const SYSCLK_HZ: u32 = 25_000_000;

const APB_TIMER0: usize = 0x4000_0000;
const CTRL: usize = 0x00;
const VALUE: usize = 0x04;
const RELOAD: usize = 0x08;

/// CMSDK APB timer 0, free running from 0xFFFF_FFFF down at 25 MHz; read as an up-counter.
#[derive(Clone, Copy, Debug)]
pub struct ApbCounter;

impl ApbCounter {
    /// Starts the timer.
    pub fn start() -> Self {
        // SAFETY: the AN386's APB timer 0 registers; nothing else uses this timer.
        unsafe {
            write_volatile((APB_TIMER0 + CTRL) as *mut u32, 0);
            write_volatile((APB_TIMER0 + RELOAD) as *mut u32, u32::MAX);
            write_volatile((APB_TIMER0 + VALUE) as *mut u32, u32::MAX);
            write_volatile((APB_TIMER0 + CTRL) as *mut u32, 1);
        }
        ApbCounter
    }
}

impl CycleCounter for ApbCounter {
    #[inline(always)]
    fn now(&self) -> u32 {
        // SAFETY: a read of the running timer's value register.
        !unsafe { read_volatile((APB_TIMER0 + VALUE) as *const u32) }
    }
}

/// SysTick on the core clock, interrupting at the current-loop rate.
pub struct SysTickTimer(SYST);

impl SysTickTimer {
    /// Takes SysTick.
    pub fn new(syst: SYST) -> Self {
        Self(syst)
    }
}

impl TickTimer for SysTickTimer {
    fn start(&mut self, hz: u32) {
        let reload = (SYSCLK_HZ / hz.max(1)).saturating_sub(1).min(0x00ff_ffff);
        self.0.set_clock_source(SystClkSource::Core);
        self.0.set_reload(reload);
        self.0.clear_current();
        self.0.enable_interrupt();
        self.0.enable_counter();
    }
}

/// Semihosting standard output.
pub struct Semihosting(Option<cortex_m_semihosting::hio::HostStream>);

impl Semihosting {
    /// Opens the host's standard output.
    pub fn new() -> Self {
        Self(cortex_m_semihosting::hio::hstdout().ok())
    }

    /// Writes raw bytes.
    pub fn line(&mut self, bytes: &[u8]) {
        self.write(bytes);
    }
}

impl Sink for Semihosting {
    fn write(&mut self, bytes: &[u8]) {
        if let Some(stream) = self.0.as_mut() {
            let _ = stream.write_all(bytes);
        }
    }
}

/// Ends the QEMU run with `code` as its exit status (semihosting `SYS_EXIT_EXTENDED`).
pub fn exit(code: u32) -> ! {
    const SYS_EXIT_EXTENDED: usize = 0x20;
    const ADP_STOPPED_APPLICATION_EXIT: usize = 0x20026;
    loop {
        // SAFETY: a semihosting call with a valid parameter block.
        unsafe {
            cortex_m_semihosting::syscall(SYS_EXIT_EXTENDED, &[ADP_STOPPED_APPLICATION_EXIT, code as usize]);
        }
    }
}

/// Instructions executed by [`known_instructions`].
pub const KNOWN_INSTRUCTIONS: i64 = 1 + 2 * 500;

/// Executes exactly [`KNOWN_INSTRUCTIONS`] instructions: `movw`, then 500 × (`subs`, `bne`).
#[inline(always)]
pub fn known_instructions() {
    // SAFETY: a counted loop on a scratch register.
    unsafe {
        core::arch::asm!(
            "movw {n}, #500",
            "2:",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = out(reg) _,
            options(nomem, nostack)
        )
    };
}

/// Prints `CAL instructions=1001 ticks=<n>`: the counter ticks of a loop of known length, so
/// the output itself shows the ticks-per-instruction factor (25.6 under `-icount shift=10`).
#[inline(never)]
pub fn calibrate(counter: &ApbCounter, out: &mut Semihosting) {
    let mut overhead = u32::MAX;
    for _ in 0..4 {
        let a = counter.now();
        let b = counter.now();
        overhead = overhead.min(b.wrapping_sub(a));
    }
    let a = counter.now();
    known_instructions();
    let b = counter.now();
    let mut line = Line::new();
    line.str("CAL").kv("instructions", KNOWN_INSTRUCTIONS);
    line.kv("ticks", i64::from(b.wrapping_sub(a).saturating_sub(overhead)))
        .kv("overhead", i64::from(overhead));
    line.emit(out);
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    // No formatting of the message: that would pull core::fmt into every image.
    let mut out = Semihosting::new();
    out.line(b"PANIC\n");
    exit(101)
}
