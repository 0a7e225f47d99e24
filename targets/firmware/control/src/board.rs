//! The board layer: what the control code needs from the hardware, one trait per role.
//!
//! Units are those of the runtime: counts, amperes, volts, and the force sensor's raw units
//! (calibrated by the runtime's `ForceSensorCalibration`). Implement these for a board's HAL
//! types (see `targets/firmware/stm32f4` for an STM32F4 example, `targets/firmware/sim` for
//! the simulated board that runs under QEMU and on the host).

/// Incremental encoder counters, one per joint (quadrature-decoded motor-shaft counts).
/// A counter may wrap: the runtime accumulates wrap-safe differences.
pub trait Encoders<const N: usize> {
    /// The counters now.
    fn counts(&mut self) -> [i32; N];
}

/// The encoders of measured passive joints (a stylus's gimbal: encoders, no motors), one
/// counter per joint, zero at the joint's reference pose (see `hapticgen_runtime::measured`).
pub trait MeasuredEncoders<const K: usize> {
    /// The counters now.
    fn measured_counts(&mut self) -> [i32; K];
}

/// Motor-current sense: the ADC behind the anti-aliasing filter, converted to amperes.
pub trait CurrentSense<S, const N: usize> {
    /// The measured (filtered) motor currents, A.
    fn currents(&mut self) -> [S; N];
}

/// Force sensors (Controller 1), raw readings in sensor units, one per task axis.
pub trait ForceSense<S, const M: usize> {
    /// The readings now.
    fn force_readings(&mut self) -> [S; M];
}

/// The PWM power stage: armature voltage commands, V (held until the next period).
pub trait VoltageOutput<S, const N: usize> {
    /// Applies the voltages (the implementation maps them to duty cycles).
    fn set_voltages(&mut self, volts: &[S; N]);
    /// Puts the bridges in a safe state (zero volts / high impedance).
    fn disable(&mut self);
}

/// The periodic interrupt that drives the current loop.
pub trait TickTimer {
    /// Starts periodic interrupts at `hz` (the rig's `CURRENT_LOOP_HZ`).
    fn start(&mut self, hz: u32);
}

/// A free-running up-counter for cost measurement, wrapping at 2^32 (a down-counter or a
/// narrower one is adapted by the implementation).
pub trait CycleCounter {
    /// The counter now.
    fn now(&self) -> u32;
}

/// A counter that never advances (host runs: no cost measurement).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoClock;

impl CycleCounter for NoClock {
    #[inline(always)]
    fn now(&self) -> u32 {
        0
    }
}

/// Everything a control cycle reads and writes.
pub trait Board<S, const N: usize, const M: usize>:
    Encoders<N> + CurrentSense<S, N> + ForceSense<S, M> + VoltageOutput<S, N>
{
}

impl<T, S, const N: usize, const M: usize> Board<S, N, M> for T where
    T: Encoders<N> + CurrentSense<S, N> + ForceSense<S, M> + VoltageOutput<S, N>
{
}
