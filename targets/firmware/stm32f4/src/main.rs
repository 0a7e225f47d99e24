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
#![no_std]
#![no_main]

use core::cell::RefCell;

use cortex_m::interrupt::Mutex;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{DWT, SYST};
use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::board::{
    CurrentSense, CycleCounter, Encoders, ForceSense, TickTimer, VoltageOutput,
};
use hapticgen_fw_control::Controller;
use hapticgen_runtime::control::{ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters};
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::render::Scene;
use hapticgen_runtime::tick::HapticLoopSettings;
use stm32f4xx_hal::adc::config::{AdcConfig, SampleTime};
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::gpio::{Analog, Pin};
use stm32f4xx_hal::pac::{self, ADC1, TIM1, TIM2, TIM3};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;
use stm32f4xx_hal::rcc::Config;
use stm32f4xx_hal::timer::PwmChannel;

#[allow(clippy::all, dead_code)]
mod generated {
    include!(concat!(env!("OUT_DIR"), "/image.rs"));
}
use generated::image;

const SYSCLK_HZ: u32 = 168_000_000;
const ADC_FULL_SCALE: f32 = 4095.0;
const CURRENT_RANGE_AMPS: f32 = 20.0;
const ADC_VOLTS: f32 = 3.3;

/// The STM32F407 board: HAL drivers behind the board-layer traits.
struct F4Board {
    encoder1: Qei<TIM2>,
    encoder2: Qei<TIM3>,
    adc: Adc<ADC1>,
    current_pins: (Pin<'A', 2, Analog>, Pin<'A', 3, Analog>),
    force_pins: (Pin<'A', 4, Analog>, Pin<'A', 5, Analog>),
    pwm: (PwmChannel<TIM1, 0>, PwmChannel<TIM1, 1>),
    supply: f32,
}

impl Encoders<2> for F4Board {
    fn counts(&mut self) -> [i32; 2] {
        // TIM3 is 16 bits wide: sign-extend, the runtime accumulates wrap-safe differences
        // between ticks (at most 32767 counts per tick).
        [self.encoder1.count() as i32, i32::from(self.encoder2.count() as i16)]
    }
}

impl CurrentSense<f32, 2> for F4Board {
    fn currents(&mut self) -> [f32; 2] {
        let a = self.adc.convert(&self.current_pins.0, SampleTime::Cycles_3);
        let b = self.adc.convert(&self.current_pins.1, SampleTime::Cycles_3);
        let amps = |raw: u16| (f32::from(raw) / ADC_FULL_SCALE * 2.0 - 1.0) * CURRENT_RANGE_AMPS;
        [amps(a), amps(b)]
    }
}

impl ForceSense<f32, 2> for F4Board {
    fn force_readings(&mut self) -> [f32; 2] {
        let a = self.adc.convert(&self.force_pins.0, SampleTime::Cycles_15);
        let b = self.adc.convert(&self.force_pins.1, SampleTime::Cycles_15);
        [f32::from(a) / ADC_FULL_SCALE * ADC_VOLTS, f32::from(b) / ADC_FULL_SCALE * ADC_VOLTS]
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
struct Cycles;

impl CycleCounter for Cycles {
    fn now(&self) -> u32 {
        DWT::cycle_count()
    }
}

struct SysTickTimer(SYST);

impl TickTimer for SysTickTimer {
    fn start(&mut self, hz: u32) {
        self.0.set_clock_source(SystClkSource::Core);
        self.0.set_reload(SYSCLK_HZ / hz - 1);
        self.0.clear_current();
        self.0.enable_interrupt();
        self.0.enable_counter();
    }
}

type App = Controller<image::Rig, Scene<f32, 1, 1>, 2, 2>;

static STATE: Mutex<RefCell<Option<(App, F4Board)>>> = Mutex::new(RefCell::new(None));

#[entry]
fn main() -> ! {
    let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else { halt() };
    let mut rcc = dp.RCC.freeze(Config::hse(8.MHz()).sysclk(SYSCLK_HZ.Hz()));
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();
    let gpioa = dp.GPIOA.split(&mut rcc);
    let encoder1 = Qei::new(dp.TIM2, (gpioa.pa0, gpioa.pa1), &mut rcc);
    let encoder2 = Qei::new(dp.TIM3, (gpioa.pa6, gpioa.pa7), &mut rcc);
    let adc = Adc::new(dp.ADC1, true, AdcConfig::default(), &mut rcc);
    let (_, (ch1, ch2, ..)) = dp.TIM1.pwm_hz(20.kHz(), &mut rcc);
    let mut pwm = (ch1.with(gpioa.pa8), ch2.with(gpioa.pa9));
    pwm.0.enable();
    pwm.1.enable();
    let setup = image::setup();
    let rig = image::Rig::NOMINAL;
    let supply = image::Rig::DRIVES[0].supply_voltage;
    let mut board = F4Board {
        encoder1,
        encoder2,
        adc,
        current_pins: (gpioa.pa2.into_analog(), gpioa.pa3.into_analog()),
        force_pins: (gpioa.pa4.into_analog(), gpioa.pa5.into_analog()),
        pwm,
        supply,
    };
    board.set_voltages(&[0.0; 2]);
    // A free-space scene with the model's rendering settings; add walls with `Scene::add`.
    let [grid, stiffness, damping] = setup.rendering.unwrap_or([3e-4, 1500.0, 5.0]);
    let scene = Scene::new(stiffness, damping, grid);
    // Homing: the device is assumed to start at the image's pose in variants.txt (for the
    // parallel link q = (π/2, 0): link 1 upright, link 2 level).
    let q0 = setup.start;
    let settings = HapticLoopSettings {
        controller: ImpedanceController {
            law: ImpedanceLaw::Controller3,
            parameters: ImpedanceParameters {
                stiffness: [stiffness; 2],
                damping: [damping; 2],
                mass: [1.0; 2],
            },
            options: ControlOptions {
                omit_damping_compensation: false,
                min_abs_jacobian_determinant: 1e-6,
                spring_lead_time: 0.0,
            },
        },
        estimator: EstimatorSettings {
            sample_period: 1.0 / image::IMPEDANCE_LOOP_HZ as f32,
            velocity_cutoff_hz: 50.0,
            acceleration_cutoff_hz: 20.0,
        },
        zero_offset: q0,
        initial_counts: board.counts(),
        force_calibration: ForceSensorCalibration { scale: [5.0; 2], offset: [2.5; 2] },
        current_gains: setup.current_gains[0],
        max_tick_gap: 1,
    };
    let Some(mut app) = App::new(rig, scene, &settings, false) else { halt() };
    // Each motor's own gains (identical for the parallel link's two motors).
    app.haptic.set_current_loop_gains(&setup.current_gains);
    app.calibrate(&Cycles);
    cortex_m::interrupt::free(|cs| STATE.borrow(cs).replace(Some((app, board))));
    SysTickTimer(cp.SYST).start(image::CURRENT_LOOP_HZ);
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
fn SysTick() {
    cortex_m::interrupt::free(|cs| {
        if let Some((app, board)) = STATE.borrow(cs).borrow_mut().as_mut() {
            let _ = app.on_current_tick(board, &Cycles);
        }
    });
}

fn halt() -> ! {
    loop {
        cortex_m::asm::bkpt();
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    // A real product would disable the bridges here first.
    halt()
}
