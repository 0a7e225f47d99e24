//! The STM32F407 image in device mode (docs/link-device.md; the crate's documentation has the wiring,
//! [`hapticgen_fw_stm32f4::device`] the design): start-up, USART1 at 1 Mbit/s for the host
//! link, SysTick at `CURRENT_LOOP_HZ` for the control cycle; the main loop moves the link's
//! bytes. **Compiles; untested on hardware.**
#![no_std]
#![no_main]

use core::cell::RefCell;

use cortex_m::interrupt::Mutex;
use cortex_m_rt::{entry, exception};
use hapticgen_fw_control::board::{Encoders, TickTimer};
use hapticgen_fw_control::device::{DeviceMode, TransmitQueue};
use hapticgen_fw_control::link::{DeviceLink, LinkSettings};
use hapticgen_fw_control::link_scene::device_info;
use hapticgen_fw_stm32f4::device::{
    next_byte_to_send, on_device_interrupt, on_received_byte, DeviceApp, DeviceState, SharedDevice,
};
use hapticgen_fw_stm32f4::{halt, image, loop_settings, rendering, start, Cycles, Started, SysTickTimer};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::serial::{Config, Serial};

/// The heartbeat timeout, ms: the bridges are off within 10 ms of the last heartbeat (the
/// link's safe-state bound, docs/link.md), as on the QEMU board's device image.
const LINK_TIMEOUT_MS: u32 = 6;

/// The host link's speed, bit/s.
const LINK_BAUD: u32 = 1_000_000;

static DEVICE: SharedDevice = Mutex::new(RefCell::new(None));

#[entry]
fn main() -> ! {
    let Some(Started { mut board, syst, mut rcc, usart1, gpiob }) = start() else { halt() };
    let Ok(serial) = Serial::<_, u8>::new(
        usart1,
        (gpiob.pb6, gpiob.pb7),
        Config::default().baudrate(LINK_BAUD.bps()),
        &mut rcc,
    ) else {
        halt()
    };
    let (mut transmitter, mut receiver) = serial.split();
    let rig = image::Rig::NOMINAL;
    let [grid, stiffness, damping] = rendering();
    let mode = DeviceMode::new(rig.position(&image::setup().start), stiffness, damping, grid);
    let settings = loop_settings(mode.parameters(), board.counts());
    let Some(source) = mode.source() else { halt() };
    let Some(mut app) = DeviceApp::new(rig, source, &settings, false) else { halt() };
    app.calibrate(&Cycles);
    let link = DeviceLink::new(
        device_info(image::NAME, image::JOINTS, image::TASK_DIM, image::IMPEDANCE_LOOP_HZ),
        LinkSettings::with_timeout_ms(LINK_TIMEOUT_MS, image::CURRENT_LOOP_HZ),
    );
    cortex_m::interrupt::free(|cs| {
        if let Ok(mut slot) = DEVICE.borrow(cs).try_borrow_mut() {
            *slot = Some(DeviceState {
                app,
                board,
                link,
                mode,
                transmit: TransmitQueue::new(),
                frames_dropped: 0,
            });
        }
    });
    SysTickTimer(syst).start(image::CURRENT_LOOP_HZ);
    loop {
        // A byte in: an overrun or framing error loses bytes, which the frames' CRC and the
        // next zero byte take care of.
        if let Ok(byte) = receiver.read() {
            on_received_byte(&DEVICE, byte);
        }
        if transmitter.is_tx_empty() {
            if let Some(byte) = next_byte_to_send(&DEVICE) {
                let _ = transmitter.write(byte);
            }
        }
    }
}

#[exception]
fn SysTick() {
    on_device_interrupt(&DEVICE);
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    // A real product would disable the bridges here first.
    halt()
}
