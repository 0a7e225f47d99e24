//! What a *control-path probe* is built from: a firmware binary that is linked, never run, to
//! show that no panic can be reached from an image's interrupt body.
//!
//! A probe's only interrupt handler runs the image's control path (for the QEMU images
//! [`Controller::on_current_tick`](crate::Controller::on_current_tick), for a board the whole
//! current-loop interrupt body) on state the compiler cannot see: a pointer read with a
//! volatile load ([`opaque`]), sensors read with volatile loads ([`OpaqueBoard`],
//! [`OpaqueClock`]), voltages written with volatile stores. So no value is known at compile
//! time and every check the code does is compiled in, as on a running device whose state was
//! computed at run time. Its `main` does nothing, so the binary holds the control path and
//! the start-up code and nothing else.
//!
//! Its panic handler calls [`hapticgen_fw_panic_reached`], a function that the linker keeps
//! only when some panic path survives optimisation and `--gc-sections`; `scripts/firmware.sh`
//! fails when the linked probe has that symbol or any of `core`'s panic entry points
//! (`hapticgen-fw-reference panics <elf>`), and names the call sites.

use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};

use crate::board::{CurrentSense, CycleCounter, Encoders, ForceSense, MeasuredEncoders, VoltageOutput};

/// The largest joint and task dimension an [`OpaqueBoard`] serves.
pub const MAX_AXES: usize = 8;

static mut STATE: usize = 0;
static mut COUNTS: [i32; MAX_AXES] = [0; MAX_AXES];
static mut READINGS: [u32; MAX_AXES] = [0; MAX_AXES];
static mut VOLTS: [u32; MAX_AXES] = [0; MAX_AXES];
static mut CYCLES: u32 = 0;

/// A `&mut T` the optimiser knows nothing about (`None` when the pointer, read with a volatile
/// load, is null).
///
/// # Safety
///
/// Only for a probe, which is linked and never run: the pointer is never set.
#[inline(always)]
pub unsafe fn opaque<T>() -> Option<&'static mut T> {
    // SAFETY: a volatile read of a plain static; the caller never runs the code.
    let address = unsafe { read_volatile(addr_of!(STATE)) };
    // SAFETY: see above; never dereferenced at run time.
    unsafe { (address as *mut T).as_mut() }
}

/// A board whose sensors are volatile loads and whose output is a volatile store: every
/// reading is unknown to the optimiser.
#[derive(Clone, Copy, Debug, Default)]
pub struct OpaqueBoard;

#[inline(always)]
fn read<T: Copy, const N: usize>(source: *const [T; MAX_AXES], zero: T) -> [T; N] {
    const { assert!(N <= MAX_AXES, "more axes than an OpaqueBoard serves") };
    let mut out = [zero; N];
    for (k, slot) in out.iter_mut().enumerate() {
        // SAFETY: `k < N <= MAX_AXES` (asserted at compile time) and never executed.
        *slot = unsafe { read_volatile((source as *const T).wrapping_add(k)) };
    }
    out
}

impl<const N: usize> Encoders<N> for OpaqueBoard {
    fn counts(&mut self) -> [i32; N] {
        read(addr_of!(COUNTS), 0)
    }
}

impl<const K: usize> MeasuredEncoders<K> for OpaqueBoard {
    fn measured_counts(&mut self) -> [i32; K] {
        read(addr_of!(COUNTS), 0)
    }
}

impl<const N: usize> CurrentSense<f32, N> for OpaqueBoard {
    fn currents(&mut self) -> [f32; N] {
        read::<u32, N>(addr_of!(READINGS), 0).map(f32::from_bits)
    }
}

impl<const M: usize> ForceSense<f32, M> for OpaqueBoard {
    fn force_readings(&mut self) -> [f32; M] {
        read::<u32, M>(addr_of!(READINGS), 0).map(f32::from_bits)
    }
}

impl<const N: usize> VoltageOutput<f32, N> for OpaqueBoard {
    fn set_voltages(&mut self, volts: &[f32; N]) {
        const { assert!(N <= MAX_AXES, "more axes than an OpaqueBoard serves") };
        for (k, v) in volts.iter().enumerate() {
            // SAFETY: as in `read`.
            unsafe { write_volatile((addr_of_mut!(VOLTS) as *mut u32).wrapping_add(k), v.to_bits()) };
        }
    }

    fn disable(&mut self) {
        // SAFETY: as in `read`.
        unsafe { write_volatile(addr_of_mut!(VOLTS) as *mut u32, 0) };
    }
}

/// A cycle counter read with a volatile load.
#[derive(Clone, Copy, Debug, Default)]
pub struct OpaqueClock;

impl CycleCounter for OpaqueClock {
    #[inline(always)]
    fn now(&self) -> u32 {
        // SAFETY: a volatile read of a plain static.
        unsafe { read_volatile(addr_of!(CYCLES)) }
    }
}

/// What a probe's `#[panic_handler]` calls. Never inlined, so its symbol (whose name contains
/// [`PANIC_MARKER`]) is in the linked probe if and only if a panic path survived; dropped
/// by the linker otherwise, like any unreferenced function. Never returns (and never runs: a
/// probe is not run).
#[inline(never)]
pub fn hapticgen_fw_panic_reached() -> ! {
    loop {
        core::hint::spin_loop();
    }
}

/// Part of the symbol name of [`hapticgen_fw_panic_reached`], which the check looks for.
pub const PANIC_MARKER: &str = "hapticgen_fw_panic_reached";
