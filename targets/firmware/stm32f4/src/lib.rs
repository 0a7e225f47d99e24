//! Example real-board image: the 2-DOF parallel link on an STM32F407 at 168 MHz, through
//! `stm32f4xx-hal`. **Compiles; untested on hardware.** It shows how a board support crate
//! plugs into the board-layer traits of `hapticgen_fw_control` without touching the control
//! code (the same `Controller::on_current_tick` as under QEMU).
//!
//! Wiring assumed (change to suit the board):
//!
//! | role | peripheral | pins |
//! | --- | --- | --- |
//! | encoder joint 1 | TIM2 (32-bit) encoder mode | PA0, PA1 |
//! | encoder joint 2 | TIM3 (16-bit, sign-extended) | PA6, PA7 |
//! | motor currents | ADC1 after the Bessel filter, 0–3.3 V = −20…+20 A | PA2, PA3 |
//! | force sensor | ADC1, raw volts (calibrated by the runtime) | PA4, PA5 |
//! | PWM (locked antiphase, 50 % = 0 V) | TIM1 CH1, CH2 at 20 kHz | PA8, PA9 |
//! | current-loop interrupt | SysTick at `CURRENT_LOOP_HZ` | — |
//! | cycle counter | DWT CYCCNT | — |
//!
//! The crate is the board support (the HAL drivers behind the board-layer traits, and the
//! current-loop interrupt body [`on_current_loop_interrupt`]); its binaries are the image
//! (`src/main.rs`: start-up, then SysTick runs the interrupt body), the device-mode image
//! (`src/bin/device.rs`: the same, driven by a host over USART1, [`device`]) and their
//! control-path probes (`src/bin/control_path.rs`, `src/bin/device_path.rs`, linked and never
//! run, checked for panics by `scripts/firmware.sh`). It depends on `hapticgen-fw-control` and the runtime only: the
//! model-derived settings come from the generated glue's `setup()`
//! (`hapticgen_fw_control::Setup`), not from the simulator.
#![no_std]
#![deny(missing_docs)]

pub mod device;

use core::cell::RefCell;

use cortex_m::interrupt::Mutex;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{DWT, SYST};
use hapticgen_fw_control::board::{
    CurrentSense, CycleCounter, Encoders, ForceSense, TickTimer, VoltageOutput,
};
use hapticgen_fw_control::Controller;
use hapticgen_runtime::control::ImpedanceParameters;
use hapticgen_runtime::estimation::ForceSensorCalibration;
use hapticgen_runtime::render::Scene;
use hapticgen_runtime::tick::HapticLoopSettings;
use stm32f4xx_hal::adc::config::{AdcConfig, SampleTime, Sequence};
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::gpio::{gpiob, Analog, Pin};
use stm32f4xx_hal::pac::{self, ADC1, TIM1, TIM2, TIM3};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;
use stm32f4xx_hal::rcc::{Config, Rcc};
use stm32f4xx_hal::timer::PwmChannel;

/// The generated rig of the image named by `HAPTICGEN_FW_VARIANT` and its glue (`image`).
#[allow(clippy::all, dead_code, missing_docs)]
pub mod generated {
    include!(concat!(env!("OUT_DIR"), "/image.rs"));
}
pub use generated::image;

/// The core clock, Hz.
pub const SYSCLK_HZ: u32 = 168_000_000;
const ADC_FULL_SCALE: f32 = 4095.0;
const CURRENT_RANGE_AMPS: f32 = 20.0;
const ADC_VOLTS: f32 = 3.3;

/// The STM32F407 board: HAL drivers behind the board-layer traits.
pub struct F4Board {
    /// Joint 1's quadrature encoder (TIM2, 32 bits).
    pub encoder1: Qei<TIM2>,
    /// Joint 2's quadrature encoder (TIM3, 16 bits).
    pub encoder2: Qei<TIM3>,
    /// The ADC for currents and forces.
    pub adc: Adc<ADC1>,
    /// Motor-current inputs (after the anti-aliasing filter).
    pub current_pins: (Pin<'A', 2, Analog>, Pin<'A', 3, Analog>),
    /// Force-sensor inputs.
    pub force_pins: (Pin<'A', 4, Analog>, Pin<'A', 5, Analog>),
    /// The bridges' PWM channels (locked antiphase).
    pub pwm: (PwmChannel<TIM1, 0>, PwmChannel<TIM1, 1>),
    /// Bridge supply, V (full duty).
    pub supply: f32,
}

impl Encoders<2> for F4Board {
    fn counts(&mut self) -> [i32; 2] {
        // TIM3 is 16 bits wide: sign-extend, the runtime accumulates wrap-safe differences
        // between ticks (at most 32767 counts per tick).
        [self.encoder1.count() as i32, i32::from(self.encoder2.count() as i16)]
    }
}

/// Polls of the end-of-conversion flag before a conversion counts as failed. A conversion
/// (15 + 12 ADC cycles at 21 MHz) takes under 2 µs; a poll takes a few core cycles at
/// 168 MHz, so this allows several times that and bounds the interrupt's wait.
const CONVERSION_POLLS: u32 = 2_000;

/// One conversion of `pin`, or `None` if it did not complete within [`CONVERSION_POLLS`].
/// Not the HAL's `Adc::convert`, which panics when the status register says that no
/// conversion started (a panic path in the interrupt) and waits without bound.
fn convert<PIN>(adc: &mut Adc<ADC1>, pin: &PIN, sample_time: SampleTime) -> Option<u16>
where
    PIN: stm32f4xx_hal::hal_02::adc::Channel<ADC1, ID = u8>,
{
    adc.reset_sequence();
    adc.configure_channel(pin, Sequence::One, sample_time);
    adc.clear_end_of_conversion_flag();
    // SAFETY: ADC1's registers; its HAL driver is the board's, which only the interrupt uses
    // once start-up is done.
    let registers = unsafe { &*ADC1::ptr() };
    registers.cr2().modify(|_, w| w.adon().set_bit().swstart().set_bit());
    for _ in 0..CONVERSION_POLLS {
        if registers.sr().read().eoc().bit_is_set() {
            return Some(adc.current_sample());
        }
    }
    None
}

/// A failed conversion reads NaN, which the runtime does not act on: a motor whose current
/// reads NaN gets 0 V for that period (`CurrentLoopStatus::NonFiniteInput`), and a
/// force-sensing law given a NaN force latches `FaultCode::NonFiniteInput`.
fn or_nan(raw: Option<u16>, scale: impl Fn(f32) -> f32) -> f32 {
    match raw {
        Some(raw) => scale(f32::from(raw)),
        None => f32::NAN,
    }
}

impl CurrentSense<f32, 2> for F4Board {
    fn currents(&mut self) -> [f32; 2] {
        let a = convert(&mut self.adc, &self.current_pins.0, SampleTime::Cycles_3);
        let b = convert(&mut self.adc, &self.current_pins.1, SampleTime::Cycles_3);
        let amps = |raw: f32| (raw / ADC_FULL_SCALE * 2.0 - 1.0) * CURRENT_RANGE_AMPS;
        [or_nan(a, amps), or_nan(b, amps)]
    }
}

impl ForceSense<f32, 2> for F4Board {
    fn force_readings(&mut self) -> [f32; 2] {
        let a = convert(&mut self.adc, &self.force_pins.0, SampleTime::Cycles_15);
        let b = convert(&mut self.adc, &self.force_pins.1, SampleTime::Cycles_15);
        let volts = |raw: f32| raw / ADC_FULL_SCALE * ADC_VOLTS;
        [or_nan(a, volts), or_nan(b, volts)]
    }
}

impl VoltageOutput<f32, 2> for F4Board {
    fn set_voltages(&mut self, volts: &[f32; 2]) {
        let max = self.pwm.0.get_max_duty();
        let duty = |v: f32| {
            let fraction = (0.5 + 0.5 * v / self.supply).clamp(0.0, 1.0);
            (fraction * f32::from(max)) as u16
        };
        let (d0, d1) = (duty(volts[0]), duty(volts[1]));
        self.pwm.0.set_duty(d0);
        self.pwm.1.set_duty(d1);
    }

    fn disable(&mut self) {
        self.pwm.0.disable();
        self.pwm.1.disable();
    }
}

/// DWT cycle counter.
pub struct Cycles;

impl CycleCounter for Cycles {
    fn now(&self) -> u32 {
        DWT::cycle_count()
    }
}

/// SysTick on the core clock as the current-loop timer.
pub struct SysTickTimer(pub SYST);

impl TickTimer for SysTickTimer {
    fn start(&mut self, hz: u32) {
        self.0.set_clock_source(SystClkSource::Core);
        // SysTick counts 24 bits; a zero rate is not an error to panic on in firmware.
        self.0.set_reload((SYSCLK_HZ / hz.max(1)).saturating_sub(1).min(0x00ff_ffff));
        self.0.clear_current();
        self.0.enable_interrupt();
        self.0.enable_counter();
    }
}

/// What start-up hands the image: the board, SysTick, and what it leaves for the image (the
/// clocks, USART1 and port B: a device image's host link, `src/bin/device.rs`).
pub struct Started {
    /// The board, bridges at 0 V.
    pub board: F4Board,
    /// SysTick, for the current-loop interrupt ([`SysTickTimer`]).
    pub syst: SYST,
    /// The clocks.
    pub rcc: Rcc,
    /// USART1 (its pins: PB6 TX, PB7 RX).
    pub usart1: pac::USART1,
    /// Port B.
    pub gpiob: gpiob::Parts,
}

/// Start-up: the core at [`SYSCLK_HZ`] from an 8 MHz crystal, the cycle counter, the encoders,
/// the ADC and the bridges' PWM at 20 kHz, driven at 0 V. `None` if the peripherals were
/// already taken.
pub fn start() -> Option<Started> {
    let (dp, mut cp) = (pac::Peripherals::take()?, cortex_m::Peripherals::take()?);
    let mut rcc = dp.RCC.freeze(Config::hse(8.MHz()).sysclk(SYSCLK_HZ.Hz()));
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let encoder1 = Qei::new(dp.TIM2, (gpioa.pa0, gpioa.pa1), &mut rcc);
    let encoder2 = Qei::new(dp.TIM3, (gpioa.pa6, gpioa.pa7), &mut rcc);
    let adc = Adc::new(dp.ADC1, true, AdcConfig::default(), &mut rcc);
    let (_, (ch1, ch2, ..)) = dp.TIM1.pwm_hz(20.kHz(), &mut rcc);
    let mut pwm = (ch1.with(gpioa.pa8), ch2.with(gpioa.pa9));
    pwm.0.enable();
    pwm.1.enable();
    let mut board = F4Board {
        encoder1,
        encoder2,
        adc,
        current_pins: (gpioa.pa2.into_analog(), gpioa.pa3.into_analog()),
        force_pins: (gpioa.pa4.into_analog(), gpioa.pa5.into_analog()),
        pwm,
        supply: image::Rig::DRIVES[0].supply_voltage,
    };
    board.set_voltages(&[0.0; 2]);
    Some(Started { board, syst: cp.SYST, rcc, usart1: dp.USART1, gpiob })
}

/// The haptic loop's settings on this board (`hapticgen_fw_control::device::loop_settings`:
/// Controller 3 with `parameters`), the device homed at the image's start pose
/// (`variants.txt`; for the parallel link q = (π/2, 0): link 1 upright, link 2 level) where
/// the encoders read `initial_counts`, the force sensor's calibration 5 N/V about 2.5 V.
pub fn loop_settings(
    parameters: ImpedanceParameters<f32, 2>,
    initial_counts: [i32; 2],
) -> HapticLoopSettings<f32, 2, 2> {
    let calibration = ForceSensorCalibration { scale: [5.0; 2], offset: [2.5; 2] };
    hapticgen_fw_control::device::loop_settings(
        &image::setup(),
        parameters,
        image::IMPEDANCE_LOOP_HZ,
        initial_counts,
        calibration,
    )
}

/// The model's rendering settings `[grid, stiffness, damping]` (m, N/m, N·s/m), else the
/// paper's (0.3 mm, 1500 N/m, 5 N·s/m).
pub fn rendering() -> [f32; 3] {
    image::setup().rendering.unwrap_or([3e-4, 1500.0, 5.0])
}

/// Stops the core where a debugger can see it (start-up failed, or a panic).
pub fn halt() -> ! {
    loop {
        cortex_m::asm::bkpt();
    }
}

/// The control state: the generated rig, the runtime's planar renderer, two joints, two task
/// coordinates.
pub type App = Controller<image::Rig, Scene<f32, 1, 1>, 2, 2>;

/// Where the interrupt finds the control state and the board (`None` until start-up is done).
pub type State = Mutex<RefCell<Option<(App, F4Board)>>>;

/// The current-loop interrupt body: one control cycle (current tick, and the impedance tick
/// when due) on the board, inside a critical section. Does nothing before start-up has put
/// the state in place (or if it were borrowed elsewhere, which start-up never leaves it).
pub fn on_current_loop_interrupt(state: &State) {
    cortex_m::interrupt::free(|cs| {
        if let Ok(mut slot) = state.borrow(cs).try_borrow_mut() {
            if let Some((app, board)) = slot.as_mut() {
                let _ = app.on_current_tick(board, &Cycles);
            }
        }
    });
}
