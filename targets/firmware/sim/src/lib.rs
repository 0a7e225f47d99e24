//! The board the QEMU images (and the host reference) run against: a plant model of the rig
//! and its drives ([`plant::SimBoard`]), and closed-loop [`Scenario`]s built from it.
//!
//! Everything is `no_std` and generic over the scalar: the firmware runs it in `f32` on the
//! Cortex-M4F, the host runs the *same code* in `f64` (the reference) and in `f32` (which must
//! reproduce the target's trajectory bit for bit, checked through the checksum).
#![no_std]
#![deny(missing_docs)]
// The plant integrates joint by joint; index loops mirror the equations.
#![allow(clippy::needless_range_loop)]

pub mod gimbal;
pub mod plant;
pub mod scenario;
pub mod scenarios;

pub use plant::SimBoard;
pub use scenario::{Load, Scenario, StylusRun};
