//! The STM32F407 image (see the crate's documentation for the wiring): start-up, then the
//! current-loop interrupt (SysTick at `CURRENT_LOOP_HZ`) runs the control cycle.
#![no_std]
#![no_main]

use core::cell::RefCell;

use cortex_m::interrupt::Mutex;
use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::board::{Encoders, TickTimer, VoltageOutput};
use hapticgen_fw_stm32f4::{
    image, on_current_loop_interrupt, App, Cycles, F4Board, State, SysTickTimer, SYSCLK_HZ,
};
use hapticgen_runtime::control::{ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters};
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::render::Scene;
use hapticgen_runtime::tick::HapticLoopSettings;
use stm32f4xx_hal::adc::config::AdcConfig;
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;
use stm32f4xx_hal::rcc::Config;

static STATE: State = Mutex::new(RefCell::new(None));

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
            law: ImpedanceLaw::JacobianTranspose,
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
        current_gains: setup.current_gains,
        max_tick_gap: 1,
    };
    let Some(mut app) = App::new(rig, scene, &settings, false) else { halt() };
    app.calibrate(&Cycles);
    cortex_m::interrupt::free(|cs| {
        if let Ok(mut slot) = STATE.borrow(cs).try_borrow_mut() {
            *slot = Some((app, board));
        }
    });
    SysTickTimer(cp.SYST).start(image::CURRENT_LOOP_HZ);
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
fn SysTick() {
    on_current_loop_interrupt(&STATE);
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
