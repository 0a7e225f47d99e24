//! Device mode on the STM32F407 (docs/link-device.md): the board's control cycle with the
//! host link of `hapticgen connect` on USART1 (PB6 TX, PB7 RX, 1 Mbit/s 8N1), polled.
//!
//! Two contexts share the [`DeviceState`] through a critical section:
//!
//! * the **main loop** (thread mode) moves bytes: each received byte goes through
//!   [`on_received_byte`] (the link's bounded work per byte, and what the host asked applied as
//!   [`DeviceMode::on_event`] says); each time the transmitter has room it takes the next byte
//!   of [`next_byte_to_send`];
//! * the **current-loop interrupt** ([`on_device_interrupt`], SysTick at `CURRENT_LOOP_HZ`)
//!   advances the link's heartbeat watchdog, runs the control cycle on the board with the
//!   bridges gated by the link ([`Gated`]: off until the host enables them, and from the period
//!   in which the heartbeat is found missing), and after each impedance tick queues the state
//!   frame ([`state_frame`]); a frame that does not fit the queue is dropped whole and counted.
//!
//! Polling keeps up: at 1 Mbit/s a byte takes 10 µs, 1,680 core cycles, far more than the main
//! loop's round; the state stream (49 B per impedance tick at 1 kHz) fills half the line.

use core::cell::RefCell;

use cortex_m::interrupt::Mutex;
use hapticgen_fw_control::board::{CurrentSense, Encoders};
use hapticgen_fw_control::device::{state_frame, DeviceMode, TickSensors, TransmitQueue};
use hapticgen_fw_control::link::{DeviceLink, Gated};
use hapticgen_fw_control::link_scene::LinkSource;
use hapticgen_fw_control::Controller;
use hapticgen_protocol::MAX_FRAME_BYTES;

use crate::{image, Cycles, F4Board};

/// The device image's control state: the generated rig following the link's reference.
pub type DeviceApp = Controller<image::Rig, LinkSource<2>, 2, 2>;

/// Everything device mode keeps between the two contexts.
pub struct DeviceState {
    /// The controller.
    pub app: DeviceApp,
    /// The board.
    pub board: F4Board,
    /// The link's state.
    pub link: DeviceLink,
    /// The host's settings and scene.
    pub mode: DeviceMode<2, 2>,
    /// Bytes for the transmitter.
    pub transmit: TransmitQueue,
    /// Frames dropped because the queue was full.
    pub frames_dropped: u32,
}

impl DeviceState {
    fn send(&mut self, frame: &[u8]) {
        if !self.transmit.push_frame(frame) {
            self.frames_dropped = self.frames_dropped.saturating_add(1);
        }
    }
}

/// Where both contexts find the state (`None` until start-up is done).
pub type SharedDevice = Mutex<RefCell<Option<DeviceState>>>;

/// Runs `body` on the state in a critical section; `None` before start-up (or if the state
/// were borrowed elsewhere, which no caller leaves it).
fn with_state<T>(shared: &SharedDevice, body: impl FnOnce(&mut DeviceState) -> T) -> Option<T> {
    cortex_m::interrupt::free(|cs| {
        let mut slot = shared.borrow(cs).try_borrow_mut().ok()?;
        slot.as_mut().map(body)
    })
}

/// One received byte (main loop): through the link, and what it completes applied.
pub fn on_received_byte(shared: &SharedDevice, byte: u8) {
    with_state(shared, |state| {
        let Some(event) = state.link.receive::<f32>(byte) else { return };
        let mut frame = [0u8; MAX_FRAME_BYTES];
        if let Some(length) = state.mode.on_event(event, &mut state.app, &state.link, &mut frame) {
            state.send(frame.get(..length).unwrap_or(&[]));
        }
    });
}

/// The next byte for the transmitter (main loop), if one is queued.
pub fn next_byte_to_send(shared: &SharedDevice) -> Option<u8> {
    with_state(shared, |state| state.transmit.pop()).flatten()
}

/// The current-loop interrupt body of device mode.
pub fn on_device_interrupt(shared: &SharedDevice) {
    with_state(shared, |state| {
        let open = state.link.on_current_tick();
        let outcome = state.mode.on_current_tick(
            &mut state.app,
            &mut Gated { board: &mut state.board, open },
            &Cycles,
            open,
        );
        if let Some(report) = outcome.impedance {
            let sensors = TickSensors { counts: state.board.counts(), currents: state.board.currents() };
            let mut frame = [0u8; MAX_FRAME_BYTES];
            let rig = image::Rig::NOMINAL;
            let exciting = state.mode.exciting();
            if let Some(length) =
                state_frame(&state.app, &rig, &state.link, &sensors, exciting, &report, &mut frame)
            {
                state.send(frame.get(..length).unwrap_or(&[]));
            }
        }
    });
}
