//! The MPS2-AN386's CMSDK APB UART0, polled: what the link images (`link_cost`, `pil`) talk
//! to the host through (QEMU connects it to a file or a socket). Shared as source, like
//! `qemu.rs`: the image crate's binaries include it with `#[path]`.

use core::ptr::{read_volatile, write_volatile};

/// CMSDK APB UART0 of the MPS2-AN386: data, state (bit 0: transmit buffer full, bit 1: receive
/// buffer full), control (bit 0: transmit enable, bit 1: receive enable), baud divider (≥ 16).
const UART0: usize = 0x4000_4000;
const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const INTSTATUS: usize = 0x0C;
const BAUDDIV: usize = 0x10;

/// UART0's receive interrupt on the MPS2-AN386 (QEMU's `mps2` board: UART n's receive
/// interrupt is IRQ 2n for the first three, its transmit one the next).
pub const UART0_RX_IRQ: i16 = 0;

/// Polls of a full transmitter before a byte is dropped: far more than QEMU ever needs (its
/// transmitter is never full for long), few enough that a stuck one cannot hang the image.
const TRANSMIT_POLLS: u32 = 100_000;

/// Polled UART0.
pub struct Uart0;

impl Uart0 {
    /// Enables the transmitter and the receiver.
    pub fn start() -> Self {
        // SAFETY: UART0's registers; nothing else uses it.
        unsafe {
            write_volatile((UART0 + BAUDDIV) as *mut u32, 16);
            write_volatile((UART0 + CTRL) as *mut u32, 0b11);
        }
        Uart0
    }

    /// Also raises UART0's receive interrupt (IRQ 0 of the MPS2-AN386) for every byte
    /// received, so that a core waiting in `wfi` wakes when one arrives; the handler must call
    /// [`Uart0::clear_receive_interrupt`].
    pub fn enable_receive_interrupt(&mut self) {
        // SAFETY: UART0's control register (bit 3: receive interrupt enable) and the NVIC's
        // set-enable register for IRQ 0; nothing else uses either.
        unsafe {
            write_volatile((UART0 + CTRL) as *mut u32, 0b1011);
            (*cortex_m::peripheral::NVIC::PTR).iser[0].write(1 << UART0_RX_IRQ);
        }
    }

    /// Acknowledges the receive interrupt (write one to clear).
    pub fn clear_receive_interrupt() {
        // SAFETY: a write-one-to-clear of UART0's receive interrupt status.
        unsafe { write_volatile((UART0 + INTSTATUS) as *mut u32, 0b10) };
    }

    /// The received byte, if one is waiting.
    #[inline(always)]
    pub fn read(&mut self) -> Option<u8> {
        // SAFETY: reads of UART0's state and data registers.
        unsafe {
            if read_volatile((UART0 + STATE) as *const u32) & 2 == 0 {
                return None;
            }
            Some(read_volatile((UART0 + DATA) as *const u32) as u8)
        }
    }

    /// Writes `bytes`, waiting at most [`TRANSMIT_POLLS`] polls per byte; returns how many
    /// bytes were dropped because the transmitter stayed full.
    pub fn write(&mut self, bytes: &[u8]) -> u32 {
        let mut dropped = 0;
        for &byte in bytes {
            let mut polls = 0u32;
            // SAFETY: reads of UART0's state register.
            while unsafe { read_volatile((UART0 + STATE) as *const u32) } & 1 != 0 && polls < TRANSMIT_POLLS {
                polls += 1;
            }
            if polls == TRANSMIT_POLLS {
                dropped += 1;
                continue;
            }
            // SAFETY: a write of one byte to UART0's data register.
            unsafe { write_volatile((UART0 + DATA) as *mut u32, u32::from(byte)) };
        }
        dropped
    }
}
